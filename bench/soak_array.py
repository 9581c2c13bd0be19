"""
Soak of the whole whisker array: many ticks of both pads among obstacles, every failure counted.

The array of ``config/rat_array.yaml`` (both sides, 60 whiskers) whisks with the built-in cosine
whisk at 1 kHz while the head moves and turns slowly (a few mm, +-3 deg), among one of two
scenes (head frame, metres):

- ``pegs``: a peg of radius 2 mm tilted towards the snout on the right, a thin one (1 mm) tilted
  sideways on the left and a ball (6 mm) in front; whisk 7 Hz from -30 to +25 deg by default.
- ``wall``: a wall tilted across the right pad's lateral side, a ball (8 mm) on the left and a
  bar across the front; whisk 8 Hz from -25 to +20 deg by default.

Printed: the events by kind, the failed whisker steps (``ArrayStep.errors``) by whisker and by
reason (the message with its numbers blanked), the first tick of each, the resets (a whisker
re-placed where it is clear after a failure), the solver evaluations and the time taken. It is
how the rules of doc/mechanics/rod3d.md, "Snaps", were found: the ``pegs`` scene has no failed
step and no reset at 7 Hz (4,000 ticks) and 9.5 Hz (6,000); the ``wall`` scene found the touch
behind a pressed tip (same page, "Snaps") and shows the line contact that point contacts do not
model ("What is not modelled (yet)").

Run: OPENBLAS_NUM_THREADS=1 python bench/soak_array.py [--scene pegs|wall] [--ticks 4000]
     [--frequency HZ]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import re  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from pathlib import Path  # noqa: E402

from vibrissa_ros.core.arrays import ArrayTracker, CosineWhisk  # noqa: E402
from vibrissa_ros.core.rod3d import BasePose, Cylinder, Plane, Scene3D, Sphere  # noqa: E402
from vibrissa_ros.scan.array_file import load_array  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

SCENES = {
    "pegs": (Scene3D((Cylinder((0.025, -0.012, 0.0), (0, 0.2, 1), 0.002, "peg_right"),
                      Cylinder((-0.028, -0.018, 0.0), (0.1, 0, 1), 0.001, "peg_left"),
                      Sphere((0.0, 0.045, -0.005), 0.006, "ball"))),
             7.0, (-30.0, 25.0)),
    "wall": (Scene3D((Plane((0.032, 0.0, 0.0), (-1.0, -0.3, 0.2), "wall"),
                      Sphere((-0.03, 0.0, 0.01), 0.008, "ball_left"),
                      Cylinder((0.0, 0.035, 0.0), (1.0, 0.0, 0.3), 0.0015, "bar"))),
             8.0, (-25.0, 20.0)),
}


def head(t: float) -> BasePose:
    """Return the head pose at t [s]: a slow wander of a few mm and a turn of +-3 deg."""
    turn = 0.05 * math.sin(t)
    return BasePose((0.004 * math.sin(2 * math.pi * 0.7 * t),
                     0.003 * math.sin(2 * math.pi * 0.4 * t),
                     0.002 * math.sin(2 * math.pi * 0.9 * t)),
                    (math.cos(turn), 0.0, 0.0, math.sin(turn)))


def _reason(message: str) -> str:
    """Return a failure's message with its numbers blanked, to count alike failures together."""
    return re.sub(r"-?\d[\d.e+-]*", "#", message)[:110]


def run(scene_name: str, ticks: int, frequency=None) -> None:
    scene, default_frequency, (lo, hi) = SCENES[scene_name]
    frequency = default_frequency if frequency is None else frequency
    array = load_array(ROOT / "config" / "rat_array.yaml")
    whisk = CosineWhisk(frequency, math.radians(lo), math.radians(hi))
    tracker = ArrayTracker(array, scene, head(0.0), whisk.angle(0.0))
    kinds, failed, first = Counter(), Counter(), {}
    most = 0
    t0 = time.perf_counter()
    for k in range(1, ticks + 1):
        step = tracker.step(head(k * 1e-3), whisk.angle(k * 1e-3))
        most = max(most, step.in_contact)
        kinds.update(e.kind for e in step.events)
        for e in step.errors:
            key = (e.whisker, _reason(e.message))
            failed[key] += 1
            first.setdefault(key, k)
    took = time.perf_counter() - t0
    print(f"\n== scene {scene_name!r}: {len(array)} whiskers, {ticks} ticks of 1 ms, whisk "
          f"{frequency:g} Hz from {lo:g} to {hi:g} deg; {took:.0f} s")
    evaluations = sum(tracker.tracker(name).solver.evaluations for name in tracker.names)
    print(f"   most whiskers in contact at once: {most}; solver evaluations {evaluations:,} "
          "(counts compare exactly between runs, times do not)")
    print(f"   events: {dict(sorted(kinds.items()))}")
    print(f"   failed whisker steps: {sum(failed.values())} ({len({w for w, _ in failed})} "
          f"whiskers); resets: {kinds.get('reset', 0)}")
    for (whisker, reason), n in failed.most_common(20):
        print(f"   {n:6d} x {whisker} (from tick {first[(whisker, reason)]}): {reason}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument("--scene", choices=sorted(SCENES), default="pegs")
    parser.add_argument("--ticks", type=int, default=4000, help="ticks of 1 ms (default 4000)")
    parser.add_argument("--frequency", type=float, default=None,
                        help="whisk frequency [Hz] (default: the scene's)")
    args = parser.parse_args(argv)
    run(args.scene, args.ticks, args.frequency)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
