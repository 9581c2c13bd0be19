"""
Soak of the whisker array under random histories: its equality with single trackers, randomized.

``test/test_array_histories.py`` checks in CI, on 100 derandomized examples, that every tick of
an ArrayTracker equals a single-whisker RodTracker per whisker stepped to the same poses
(contacts, wrench and tip to 1e-12 relative, the same events and refusals). This runs the same
property with fresh random draws (Hypothesis, no example database), more whiskers and longer
histories, for as many examples as asked: worth a run after every change to the array's tick,
its clearance test or the 3D tracker.

Printed: what the run met (ticks, events by kind, refusals, whisker-ticks the clearance test
skipped) and its time; on a failure the example Hypothesis shrank it to, with the traceback,
and the exit status 1.

Run: OPENBLAS_NUM_THREADS=1 python bench/soak_array_random.py [--examples 1500] [--ticks 30]
     [--whiskers 5]
(~2-4 minutes for 1,500 examples on the 2-core development machine.)
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import traceback  # noqa: E402
from pathlib import Path  # noqa: E402

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "test"))
import test_array_histories as H  # noqa: E402  (the property and its strategies)


def run(examples: int, ticks: int, whiskers: int) -> bool:
    """Run the property; return whether every example held."""
    inner = H.test_the_array_equals_a_single_tracker_per_whisker_under_any_history
    prop = settings(max_examples=examples, deadline=None, database=None, derandomize=False,
                    suppress_health_check=list(HealthCheck))(
        given(names=st.lists(st.sampled_from(H.NAMES), min_size=2, max_size=whiskers,
                             unique=True).map(tuple),
              obstacle=H.obstacles(), history=st.lists(H.ticks(), min_size=4, max_size=ticks),
              start=st.floats(-35.0, 0.0))(inner.hypothesis.inner_test))
    try:
        prop()
    except Exception:  # noqa: BLE001 - the falsifying example and its traceback are the report
        traceback.print_exc()
        return False
    return True


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument("--examples", type=int, default=1500)
    parser.add_argument("--ticks", type=int, default=30, help="the longest history drawn")
    parser.add_argument("--whiskers", type=int, default=5,
                        help=f"the most whiskers drawn (2 to {len(H.NAMES)})")
    args = parser.parse_args(argv)
    if not 2 <= args.whiskers <= len(H.NAMES) or args.ticks < 4 or args.examples < 1:
        parser.error(f"need --whiskers from 2 to {len(H.NAMES)}, --ticks >= 4, --examples >= 1")
    t0 = time.perf_counter()
    ok = run(args.examples, args.ticks, args.whiskers)
    met = ", ".join(f"{k} {v}" for k, v in sorted(H.TALLY.items()))
    print(f"{'held' if ok else 'FAILED'}: {args.examples} examples, up to {args.whiskers} "
          f"whiskers and {args.ticks} ticks, {time.perf_counter() - t0:.0f} s; met: {met}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
