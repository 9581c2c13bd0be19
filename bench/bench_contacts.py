"""
Speed of the scene tracker with two simultaneous contacts (issue 13: >= 1,000 poses/s on one core).

Prints medians per pose and poses/s for:

* two contacts: ``config/scene_two_pegs.yaml`` (the whisker pressed on one peg and reaching the
  other), the foot sweeping through the span where both touch, in small steps;
* one contact, same tracker: the same sweep with the second peg removed;
* baselines measured in the same run: the single-contact tracker (issue 12's collocation) on the
  same peg, and the paper's exact closed forms on a circle profile.

Run it with one BLAS thread (``OPENBLAS_NUM_THREADS=1 python bench/bench_contacts.py``): the
claim is per core.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

# the checkout's package, for a run from bench/: the imports below must follow (E402)
sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from vibrissa_ros.core.general.model import GeneralWhiskerModel, WhiskerShape  # noqa: E402
from vibrissa_ros.core.profiles import Circle  # noqa: E402
from vibrissa_ros.core.scenes.tracker import SceneTracker  # noqa: E402
from vibrissa_ros.core.exact.tracker import QuasistaticTracker  # noqa: E402
from vibrissa_ros.scan.scene_file import load_scene  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def _timed(step, poses):
    times = []
    for p in poses:
        t0 = time.perf_counter()
        step(p)
        times.append(time.perf_counter() - t0)
    return times


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    parser.add_argument("--poses", type=int, default=1000, help="poses per measurement")
    parser.add_argument("--repeat", type=int, default=3, help="repetitions (the best is kept)")
    args = parser.parse_args(argv)
    scene = load_scene(os.path.join(HERE, "..", "config", "scene_two_pegs.yaml"))
    obstacles = list(scene)
    mu = [0.0] * len(obstacles)  # frictionless: the contact count is what is measured
    lead = np.linspace(-0.15, 0.06, 30)
    span = np.linspace(0.06, 0.26, args.poses + 1)
    report = {}
    for _ in range(args.repeat):
        tracker = SceneTracker(obstacles, float(lead[0]), friction=mu)
        for x0 in lead[1:]:
            tracker.step(float(x0))
        counts = []

        def step2(x0, tracker=tracker, counts=counts):
            counts.append(len(tracker.step(float(x0)).state.contacts))

        t2 = _timed(step2, span[1:])
        assert min(counts) == 2, f"the two-contact span lost a contact: {sorted(set(counts))}"
        one = SceneTracker(obstacles[:1], float(lead[0]))
        for x0 in lead[1:]:
            one.step(float(x0))
        t1 = _timed(lambda x0: one.step(float(x0)), span[1:])
        single = QuasistaticTracker(obstacles[0].profile(), float(lead[0]),
                                    model=GeneralWhiskerModel(WhiskerShape()))
        for x0 in lead[1:]:
            single.step(float(x0))
        ts = _timed(lambda x0: single.step(float(x0)), span[1:])
        exact = QuasistaticTracker(Circle(0.5, 1.0), 0.9)
        te = _timed(lambda x0: exact.step(float(x0)), np.linspace(0.9, 0.2, args.poses + 1)[1:])
        for key, times in (("two contacts (scene tracker)", t2),
                           ("one contact (scene tracker)", t1),
                           ("one contact (single-contact collocation)", ts),
                           ("one contact (exact closed forms)", te)):
            med = statistics.median(times)
            if key not in report or med < report[key][0]:
                report[key] = (med, len(times) / sum(times), max(times))
    base = report["one contact (single-contact collocation)"][0]
    print(f"{args.poses} poses per run, best of {args.repeat} runs, "
          f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    for key, (med, rate, worst) in report.items():
        print(f"  {key:42s} median {med * 1e6:7.1f} us/pose ({1.0 / med:6.0f}/s), "
              f"all poses {rate:6.0f}/s, slowest {worst * 1e3:5.1f} ms; "
              f"{med / base:4.2f} x the single-contact collocation")
    return 0


if __name__ == "__main__":
    sys.exit(main())
