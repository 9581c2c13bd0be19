"""
Cost and self-consistency of the scene shooting solver (the independent check of issue 13).

For the golden scenes of test/data/scene_golden.json (two pegs on a straight and on a tapered,
curved whisker; a tip and a side contact on a non-convex curve) and for one contact on a circle:

1. accuracy: the largest difference of every contact quantity and of the base load between
   solves at DOP853 rtol 1e-11, 1e-12 and 1e-13 (the default);
2. time per solve: warm-started solves along a short path of foot poses (each from the previous
   equilibrium, as the event locator and the continuation do), median over ``--repeats`` runs of
   ``--poses`` poses, with the number of ODE integrations per solve; and the time of one event
   located on the path (release of the second contact).

Run: python bench/bench_scene_shooting.py [--poses 20] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "test"))  # the tests' scenes: the imports below follow it (E402)

from vibrissa_ros.core import FootPose, WhiskerShape  # noqa: E402
from vibrissa_ros.core.scenes.boundary import CircleArc, GraphArc  # noqa: E402
from vibrissa_ros.core.checks.scene_shooting import (  # noqa: E402
    ContactSpec,
    PosePath,
    follow_path,
    locate_event,
    release,
    solve_scene_equilibrium,
)

KEYS = ("s", "u", "x", "y", "fx", "fy", "N", "T")


def _scenes():
    golden = json.loads((ROOT / "test" / "data" / "scene_golden.json").read_text())
    out = []
    for case in golden["cases"]:
        specs = []
        for c in case["contacts"]:
            f = c["feature"]
            feat = (CircleArc(f["cx"], f["cy"], f["r"]) if f["type"] == "circle"
                    else GraphArc(tuple(map(tuple, f["points"])), side=f["side"]))
            specs.append(ContactSpec(c["kind"], feat, s=c["s"], u=c["u"], N=c["N"]))
        out.append((case["name"], WhiskerShape(**case["shape"]), FootPose(**case["pose"]),
                    tuple(specs)))
    peg = CircleArc(-0.05, 0.45, 0.03)
    out.append(("one peg, straight whisker", WhiskerShape(), FootPose(-0.116, 0.0, 0.5 * np.pi),
                (ContactSpec("side", peg, s=0.45, u=1.3, N=5.0),)))
    return out


def _difference(a, b):
    d = max(abs(getattr(p, k) - getattr(q, k)) for p, q in zip(a.contacts, b.contacts)
            for k in KEYS)
    return max(d, abs(a.fx - b.fx), abs(a.fy - b.fy), abs(a.m0 - b.m0))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    print(f"{'scene':34s} {'|1e-11 - 1e-13|':>16s} {'|1e-12 - 1e-13|':>16s} {'residual':>9s} "
          f"{'ms/solve':>9s} {'ODEs/solve':>10s} {'event s':>8s}")
    for name, shape, pose, specs in _scenes():
        ref = solve_scene_equilibrium(shape, pose, specs)
        d11 = _difference(ref, solve_scene_equilibrium(shape, pose, ref.warm(), rtol=1e-11))
        d12 = _difference(ref, solve_scene_equilibrium(shape, pose, ref.warm(), rtol=1e-12))
        # a short path pressing on (1e-3 L), solved pose by pose, warm-started
        direction = (-1e-3, 0.0) if pose.y == 0.0 else (0.0, -1e-3)
        end = FootPose(pose.x + direction[0], pose.y + direction[1], pose.heading)
        path = PosePath(pose, end)
        ts = np.linspace(0.0, 1.0, args.poses + 1)[1:]
        times, calls = [], []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            eqs = follow_path(shape, path, ref.warm(), ts)
            times.append((time.perf_counter() - t0) / len(ts))
            calls.append(statistics.mean(e.evaluations for e in eqs))
        event = "-"
        if len(specs) == 2:
            # back to beyond the second touch (3e-2 L before the pegs' pose, 5e-3 the curve's)
            k = 50.0 if pose.y == 0.0 else 8.0
            back = PosePath(pose, FootPose(pose.x - k * direction[0], pose.y - k * direction[1],
                                           pose.heading))
            t0 = time.perf_counter()
            found = locate_event(shape, back, ref.warm(), release(1), steps=4)
            event = f"{time.perf_counter() - t0:.2f}" if found else "none"
        print(f"{name:34s} {d11:16.1e} {d12:16.1e} {ref.residual:9.1e} "
              f"{1e3 * statistics.median(times):9.1f} {statistics.median(calls):10.1f} "
              f"{event:>8s}")


if __name__ == "__main__":
    main()
