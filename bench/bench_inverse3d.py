"""
Accuracy of the 3D inverse problem (the contact from the 6-axis base wrench), measured.

For a few whiskers at a tilted and rolled base pose, random contacts: arc length s uniform in
[0.2, 1] (one draw in five at the tip, s = 1), the force of magnitude uniform in [0.2, 2] EI_b/L^2
in a random direction normal to the unloaded whisker at s (a frictionless contact on its side).
The forward model (:func:`tip_loaded_rod`) gives the reading; it is inverted noise-free, then
with Gaussian noise of relative size eps on the six components (sigma = eps |F| on each force
component, eps |M0| on each moment component; the same draws at each eps). Printed: the distance
between the recovered and the true contact point [L] (over all draws and over those with
s <= 0.8: near a tapered tip the base moment hardly changes with s) and the error of s (median,
p95, max), the median consistency |M0 . F| / (|M0| |F|), and the time per inversion.

Run: python bench/bench_inverse3d.py [--draws 100] [--seed 3]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from vibrissa_ros.core.rod3d import BasePose, RodShape, contact_from_wrench, tip_loaded_rod

WHISKERS = (
    ("straight, uniform", RodShape()),
    ("parabola A = 0.6, taper 0.3", RodShape(taper=0.3, parabola=0.6)),
    ("k0 = 0.8, k1 = -0.5, taper 0.5", RodShape(taper=0.5, k0=0.8, k1=-0.5)),
)
NOISE = (0.001, 0.01, 0.05)
#: contacts up to this arc length are also reported apart (the tapered tip is ill-conditioned)
INNER = 0.8


def _pose():
    q = np.array((0.8, -0.2, 0.35, 0.4))
    return BasePose((0.2, -0.1, 0.4), tuple(q / np.linalg.norm(q)))


def _draws(shape, pose, count, rng):
    """Return (true s, true point, F, M0) of ``count`` random contacts (world frame)."""
    out = []
    R = pose.rotation
    while len(out) < count:
        s = 1.0 if rng.random() < 0.2 else float(rng.uniform(0.2, 1.0))
        phi = float(shape.intrinsic_slope(s))
        tangent = R @ np.array((math.cos(phi), math.sin(phi), 0.0))
        normal = R @ np.array((-math.sin(phi), math.cos(phi), 0.0))
        binormal = np.cross(tangent, normal)
        a = rng.uniform(0.0, 2.0 * math.pi)
        F = rng.uniform(0.2, 2.0) * (math.cos(a) * normal + math.sin(a) * binormal)
        loaded = tip_loaded_rod(shape, pose, F, s=s)
        out.append((s, np.array(loaded.load_point), F, np.array(loaded.base_moment)))
    return out


def _stats(values):
    v = np.asarray(values)
    return f"{np.median(v):.2e} / {np.percentile(v, 95):.2e} / {v.max():.2e}"


def run(shape, pose, draws, eps, rng):
    """Invert the draws with noise ``eps``; return errors, s errors, consistencies, times."""
    point_err, s_err, consistency, times, inner = [], [], [], [], []
    for s, point, F, M in draws:
        nF = F + eps * np.linalg.norm(F) * rng.standard_normal(3)
        nM = M + eps * np.linalg.norm(M) * rng.standard_normal(3)
        t0 = time.perf_counter()
        est = contact_from_wrench(shape, pose, nF, nM)
        times.append(time.perf_counter() - t0)
        point_err.append(np.linalg.norm(np.subtract(est.point, point)))
        s_err.append(abs(est.s - s))
        consistency.append(est.consistency)
        if s <= INNER:
            inner.append(point_err[-1])
    return point_err, s_err, consistency, times, inner


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=100)
    parser.add_argument("--seed", type=int, default=3)
    args = parser.parse_args(argv)
    pose = _pose()
    print(f"base pose p = {pose.position}, q = {tuple(round(v, 4) for v in pose.quaternion)}; "
          f"{args.draws} draws per whisker, seed {args.seed}")
    print("columns: median / p95 / max")
    for name, shape in WHISKERS:
        rng = np.random.default_rng(args.seed)
        draws = _draws(shape, pose, args.draws, rng)
        print(f"\n{name}:")
        for eps in (0.0,) + NOISE:
            err, serr, cons, times, inner = run(shape, pose, draws, eps, rng)
            label = "noise-free" if eps == 0.0 else f"noise {eps:.1%}"
            print(f"  {label:>11}: point error [L] {_stats(err)} (s <= {INNER}: "
                  f"{_stats(inner)}); |ds| [L] {_stats(serr)}")
            print(f"  {'':>11}  consistency {np.median(cons):.1e}; "
                  f"{1e3 * np.mean(times):.0f} ms per inversion (p95 "
                  f"{1e3 * np.percentile(times, 95):.0f})")


if __name__ == "__main__":
    main()
