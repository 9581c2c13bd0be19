"""
Cost of the scene's geometric queries: signed distance of points to each kind of obstacle.

The solvers of several contacts call ``signed_distance`` on the whisker's points at every step and
``closest`` when a touch is located, so this is their geometric overhead. For each obstacle kind
(a peg, a 6-corner polygon, an 8-point spline curve, a placed parabola, a circle strip) it times a
batch of 1 point and a batch of 100 points, ``--repeats`` times, and prints the median time per
call and per point, with the ratio to the single-obstacle tracker's peg (``profiles.Peg``,
measured in the same run: the machine may be shared). Also the cost of validating the shipped
example scenes (overlap checks), once each.

Run: python bench/bench_scene.py [--repeats 200]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from vibrissa_ros.core.profiles import Peg
from vibrissa_ros.core.scenes.scene import (CurveObstacle, PegObstacle, PolygonObstacle,
                                            ProfileObstacle)
from vibrissa_ros.scan.scene_file import load_scene

ROOT = Path(__file__).resolve().parents[1]


def median_time(fun, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fun()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=200)
    args = parser.parse_args()
    obstacles = {
        "peg": PegObstacle(0.1, 0.4, 0.2),
        "polygon (6 corners)": PolygonObstacle(
            [[0, 0], [1, 0], [1, 0.4], [0.4, 0.4], [0.4, 1], [0, 1]]),
        "curve (8 points)": CurveObstacle(
            [[-1.0, 1.3], [-0.5, 1.15], [-0.15, 0.7], [0.1, 0.62], [0.3, 0.8], [0.5, 0.6],
             [0.75, 0.75], [1.1, 1.2]]),
        "parabola (placed)": ProfileObstacle("parabola", {"p0": 0.3, "k": 1.0}, 0.1, 0.2, 0.4),
        "circle strip": ProfileObstacle("circle", {"p0": 0.3, "R": 0.5}),
    }
    rng = np.random.default_rng(0)
    batches = {m: rng.uniform(-1.0, 1.0, (m, 2)) for m in (1, 100)}
    base = Peg(0.1, 0.4, 0.2, scan_checks=False)
    baseline = {m: median_time(lambda p=p: base.signed_distance(p[:, 0], p[:, 1]), args.repeats)
                for m, p in batches.items()}
    print(f"signed_distance, median of {args.repeats} calls "
          "(ratio: to profiles.Peg.signed_distance, same run)")
    print(f"{'obstacle':22s} {'1 point [us]':>13s} {'ratio':>7s} {'100 points [us]':>16s} "
          f"{'per point [us]':>15s} {'ratio':>7s}")
    for name, ob in obstacles.items():
        t1 = median_time(lambda: ob.signed_distance(batches[1]), args.repeats)
        t100 = median_time(lambda: ob.signed_distance(batches[100]), max(args.repeats // 10, 5))
        print(f"{name:22s} {t1 * 1e6:13.1f} {t1 / baseline[1]:7.1f} {t100 * 1e6:16.1f} "
              f"{t100 * 1e4:15.2f} {t100 / baseline[100]:7.1f}")
    print("validation of the shipped scenes (overlap checks included), one load each:")
    for name in ("scene_two_pegs", "scene_contour", "scene_mixed"):
        t = time.perf_counter()
        load_scene(ROOT / "config" / f"{name}.yaml")
        print(f"  {name}: {(time.perf_counter() - t) * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
