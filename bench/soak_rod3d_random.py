"""
Soak of the 3D whisker under random histories: the robustness property, randomized and longer.

``test/test_rod3d_robustness.py`` checks in CI, on 40 derandomized examples, that every step of
the 3D whisker returns an admissible state or raises a VibrissaError keeping the state, within
its budget. This runs the same property with fresh random draws (Hypothesis, no example
database), longer histories (up to --moves moves) and a chosen ``points_tolerance``, for as many
examples as asked: worth a run after every change to the solver or the tracker (one found a
KeyError out of a discrete touch whose force was exactly 0 at the touch, which 40 examples had
not met). At a coarse tolerance the centerline may lie inside an obstacle by the
discretization's error: it is allowed 100 times the tolerance (at least 1e-6 L).

Printed: what the run met (steps, events by kind, refusals) and its time; on a failure the
example Hypothesis shrank it to, with the traceback, and the exit status 1.

Run: OPENBLAS_NUM_THREADS=1 python bench/soak_rod3d_random.py [--examples 400]
     [--points-tolerance 1e-11] [--moves 20]
(~10 minutes for 400 examples at the default tolerance on the 2-core development machine.)
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import traceback  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "test"))
import test_rod3d_robustness as R  # noqa: E402  (the property's strategies)

from vibrissa_ros.core.errors import InvalidPoseError, VibrissaError  # noqa: E402
from vibrissa_ros.core.rod3d import BasePose, RodTracker  # noqa: E402


def run(examples: int, tolerance: float, moves: int) -> bool:
    """Run the property; return whether every example held."""
    deepest = max(1e-6, 100.0 * tolerance)

    @settings(max_examples=examples, deadline=None, database=None, derandomize=False,
              suppress_health_check=list(HealthCheck))
    @given(shape=R.shapes(), first=R.obstacles(0), second=st.one_of(st.none(), R.obstacles(1)),
           history=st.lists(R.moves(), min_size=3, max_size=moves),
           start=st.tuples(R.unit, R.unit))
    def prop(shape, first, second, history, start):
        scene = [first] if second is None else [first, second]
        try:
            tracker = RodTracker(scene, BasePose((1.5 * start[0], 1.5 * start[1], 0.0)),
                                 shape=shape, max_evaluations=R.BUDGET,
                                 points_tolerance=tolerance)
        except InvalidPoseError:
            R.TALLY["unplaceable start"] += 1
            return
        pose = tracker.pose
        for move in history:
            pose = R._apply(pose, move)
            before = tracker.state
            start_evals = tracker.solver.evaluations
            try:
                result = tracker.step(pose)
            except VibrissaError:
                R.TALLY["refused"] += 1
                assert tracker.state is before
                continue
            finally:
                assert tracker.solver.evaluations - start_evals <= 3 * R.BUDGET
            R.TALLY["steps"] += 1
            R.TALLY.update(e.kind for e in result.events)
            state = result.state
            assert all(np.isfinite(v) for v in state.force + state.moment + state.tip)
            for c in state.contacts:
                assert c.f >= -1e-9
            points = state.centerline(61)
            for ob in tracker.obstacles:
                assert np.min(ob.signed_distance(points)) > -deepest

    try:
        prop()
    except Exception:  # noqa: BLE001 - the falsifying example and its traceback are the report
        traceback.print_exc()
        return False
    return True


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument("--examples", type=int, default=400)
    parser.add_argument("--points-tolerance", type=float, default=1e-11, metavar="T")
    parser.add_argument("--moves", type=int, default=20, help="the longest history drawn")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    ok = run(args.examples, args.points_tolerance, args.moves)
    met = ", ".join(f"{k} {v}" for k, v in sorted(R.TALLY.items()))
    print(f"{'held' if ok else 'FAILED'}: {args.examples} examples at points_tolerance "
          f"{args.points_tolerance:g}, histories of up to {args.moves} moves, "
          f"{time.perf_counter() - t0:.0f} s; met: {met}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
