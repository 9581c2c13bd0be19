"""
Speed of the 3D whisker (issue 19's figures): poses per second, with the shooting baseline.

Three streams of base poses, 1 kHz-like (every point of the whisker moves <= ~1e-3 L per pose):

- ``one contact``: a rolled, tapered whisker with a parabolic shape sweeps past a sphere while
  its base turns (a genuinely 3D path); only the poses in contact are timed.
- ``two contacts``: a straight whisker pressed against two pegs (cylinders along z), the
  two-peg scene of the planar tests, base turning out of the plane as it goes.
- ``free``: the same whisker moving near (not touching) the sphere.

Each pose is one ``RodTracker.step``; the figures are the median and p90 of the step time and
poses/s = 1 / median. The baseline, measured in the same run on the same states, is the
independent shooting solver (``core.checks.rod3d_shooting.shoot_contacts``) warm-started from
the tracker's own solution (its contact s, f and base load): the cheapest a shooting step can
be. Set OPENBLAS_NUM_THREADS=1 (the Jacobians are ~70 x 70; BLAS threads only add overhead):
the script sets it when it is unset, before numpy loads.

The solver runs its compiled kernels (numba) unless VIBRISSA_NO_JIT=1 selects the numpy
reference; the first line says which, and how long the kernels took to load (from numba's
on-disk cache) or, the first time, to compile.

Run: OPENBLAS_NUM_THREADS=1 python bench/bench_rod3d.py [--poses 600] [--baseline 8]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from vibrissa_ros.core.checks.rod3d_shooting import shoot_contacts  # noqa: E402
from vibrissa_ros.core.rod3d import (  # noqa: E402
    BasePose, Cylinder, RodShape, RodTracker, Sphere,
)
from vibrissa_ros.core.rod3d import _jit  # noqa: E402
from vibrissa_ros.core.rod3d.model import warm_up  # noqa: E402
from vibrissa_ros.core.rod3d.pose import quat_about, quat_multiply  # noqa: E402


def _pose(x, y, z, yaw, roll, pitch=0.0):
    q = quat_multiply(quat_about((0, 0, 1), yaw),
                      quat_multiply(quat_about((0, 1, 0), pitch), quat_about((1, 0, 0), roll)))
    return BasePose((x, y, z), tuple(q))


def _streams(n):
    u = np.linspace(0.0, 1.0, n)
    ball = Sphere((0.55, 0.2, 0.05), 0.12, "ball")
    shape = RodShape(taper=0.3, parabola=0.5)
    one = [_pose(0.0, -0.35 + 0.55 * t, 0.02 * math.sin(3 * t), 0.1 * t, 0.4 + 0.3 * t)
           for t in u]
    pegs = [Cylinder((0.0, 0.4, 0.0), (0, 0, 1), 0.04, "peg0"),
            Cylinder((-0.2, 0.85, 0.0), (0, 0, 1), 0.03, "peg1")]
    two = [_pose(0.03 + 0.04 * t, 0.0, 0.0, 0.5 * math.pi, 0.0, 0.05 * t) for t in u]
    free = [_pose(0.0, -0.6 + 0.2 * t, 0.0, 0.1 * t, 0.4) for t in u]
    return [("one contact", [ball], shape, one, 1), ("two contacts", pegs, RodShape(), two, 2),
            ("free", [ball], shape, free, 0)]


def _prime(obstacles, shape, poses, contacts):
    """Return a tracker brought to the stream's first pose along a path from where it is free."""
    if contacts == 2:
        tracker = RodTracker(obstacles, _pose(-0.4, 0.0, 0.0, 0.5 * math.pi, 0.0), shape=shape)
        for x in np.linspace(-0.4, poses[0].position[0], 60)[1:]:
            tracker.step(_pose(float(x), 0.0, 0.0, 0.5 * math.pi, 0.0))
        return tracker
    return RodTracker(obstacles, poses[0], shape=shape)


def _measure(name, obstacles, shape, poses, contacts, baseline):
    tracker = _prime(obstacles, shape, poses, contacts)
    times, states = [], []
    for pose in poses[1:]:
        t0 = time.perf_counter()
        state = tracker.step(pose).state
        dt = time.perf_counter() - t0
        if len(state.contacts) == contacts:
            times.append(dt)
            states.append(state)
    if not times:
        print(f"{name}: no pose with {contacts} contacts")
        return
    med = statistics.median(times)
    p90 = float(np.percentile(times, 90))
    print(f"{name:13s} {len(times):5d} poses  median {med * 1e6:8.1f} us  p90 {p90 * 1e6:8.1f} "
          f"us  {1.0 / med:8.0f} poses/s")
    if contacts == 0 or baseline == 0:
        return
    picks = states[:: max(1, len(states) // baseline)][:baseline]
    shots = []
    worst = 0.0
    for state in picks:
        spec = [(obstacles[c.obstacle], c.kind) for c in state.contacts]
        guess = [(c.s, c.f) for c in state.contacts]
        base = (np.array(state.force), np.array(state.moment))
        t0 = time.perf_counter()
        shot = shoot_contacts(shape, state.pose, spec, guess, base_guess=base)
        shots.append(time.perf_counter() - t0)
        if shot.success:
            worst = max(worst, float(np.max(np.abs(np.array(shot.force) - state.force))),
                        float(np.max(np.abs(np.array(shot.moment) - state.moment))))
    smed = statistics.median(shots)
    print(f"{'':13s} shooting baseline ({len(shots)} states, warm): median {smed * 1e3:8.1f} ms"
          f"  -> collocation {smed / med:6.0f}x faster; base load agrees to {worst:.1e}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument("--poses", type=int, default=600, help="poses per stream")
    parser.add_argument("--baseline", type=int, default=8, help="shooting solves per stream")
    args = parser.parse_args(argv)
    print(f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}; numpy "
          f"{np.__version__}")
    if _jit.ENABLED:
        t0 = time.perf_counter()
        warm_up()
        print(f"compiled kernels (numba {_jit.numba.__version__}): ready in "
              f"{time.perf_counter() - t0:.2f} s")
    else:
        print("numpy reference (VIBRISSA_NO_JIT=1 or numba missing)")
    for name, obstacles, shape, poses, contacts in _streams(args.poses):
        _measure(name, obstacles, shape, poses, contacts, args.baseline)


if __name__ == "__main__":
    main()
