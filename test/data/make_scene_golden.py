"""
Writes test/data/scene_golden.json: golden two-contact scenes from the shooting solver.

Run ``python test/data/make_scene_golden.py`` (a few seconds). Each scene is reached by
continuation exactly as test_scene_shooting.py does it (the first touch located on the foot's
path with the whisker free, its contact added, the second touch located, its contact added) and
then solved at a round foot pose near the second touch with ``solve_scene_equilibrium`` (DOP853
rtol 1e-13, Newton to a residual <= 1e-13). The values agree with the same solve at rtol 1e-11 to
the ``agreement`` stored with each scene, so they carry about 12 significant digits; a second,
independent method (e.g. collocation) should reproduce them to <= 1e-9.
"""

import json
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # test/: the imports below must follow it (E402)
import test_scene_shooting as scenes  # noqa: E402

from vibrissa_ros.core import FootPose  # noqa: E402
from vibrissa_ros.core.scenes.boundary import CircleArc  # noqa: E402
from vibrissa_ros.core.checks.scene_shooting import (  # noqa: E402
    PosePath,
    follow_path,
    solve_scene_equilibrium,
)

NOTE = (
    "Golden equilibria of a whisker (WhiskerShape taper, k0, k1; length 1, base stiffness 1) "
    "clamped at 'pose' (x, y, heading) and touched at two points, frictionless. Computed by "
    "vibrissa_ros.core.checks.scene_shooting (DOP853 shooting, rtol 1e-13, Newton "
    "residual <= 1e-13) after continuation from a one-contact state "
    "(test/data/make_scene_golden.py). Per contact: kind, feature (circle: centre cx, cy and "
    "radius r; curve: a natural-spline graph through 'points' with the obstacle on 'side'), arc "
    "length s on the whisker, arc parameter u (circle: the tangent angle phi, the point (cx + r "
    "sin u, cy - r cos u); curve 'below': u = -x), the contact point x, y, the force of the "
    "obstacle on the whisker fx, fy, its normal and tangential components N, T. 'base': the total "
    "force fx, fy and the base moment m0 (counter-clockwise positive). 'agreement': the largest "
    "difference of these numbers against the same solve at rtol 1e-11."
)


def _feature(arc):
    if isinstance(arc, CircleArc):
        return {"type": "circle", "cx": arc.cx, "cy": arc.cy, "r": arc.r}
    return {"type": "curve", "points": [list(p) for p in arc.points], "side": arc.side}


def _case(name, shape, pose, specs):
    eq = solve_scene_equilibrium(shape, pose, specs)
    coarse = solve_scene_equilibrium(shape, pose, eq.warm(), rtol=1e-11)
    keys = ("s", "u", "x", "y", "fx", "fy", "N", "T")
    diff = max(abs(getattr(a, k) - getattr(b, k))
               for a, b in zip(eq.contacts, coarse.contacts) for k in keys)
    diff = max(diff, abs(eq.m0 - coarse.m0), abs(eq.fx - coarse.fx), abs(eq.fy - coarse.fy))
    assert eq.residual < 1e-12, eq.residual
    return {
        "name": name,
        "shape": {"taper": shape.taper, "k0": shape.k0, "k1": shape.k1},
        "pose": {"x": pose.x, "y": pose.y, "heading": pose.heading},
        "contacts": [dict({"kind": c.kind, "feature": _feature(spec.feature)},
                          **{k: getattr(c, k) for k in keys})
                     for spec, c in zip(eq.specs, eq.contacts)],
        "base": {"fx": eq.fx, "fy": eq.fy, "m0": eq.m0},
        "residual": eq.residual,
        "agreement": diff,
    }


def main():
    cases = []
    for name in ("straight", "curved"):
        shape, _, _, touch2, specs = scenes._two_pegs(name)
        pose = FootPose(round(touch2.pose.x - 0.03, 3), 0.0, 0.5 * math.pi)
        path = PosePath(touch2.pose, pose)
        eq = follow_path(shape, path, specs, np.linspace(0.0, 1.0, 7)[1:])[-1]
        cases.append(_case(f"two pegs, {name} whisker", shape, pose, eq.warm()))
    _, touch2, specs = scenes._valley()
    pose = FootPose(-1.3, round(touch2.pose.y - 0.005, 3), -0.6)
    path = PosePath(touch2.pose, pose)
    eq = follow_path(scenes.STRAIGHT, path, (touch2.equilibrium.warm()[0], specs[1]),
                     np.linspace(0.0, 1.0, 6)[1:])[-1]
    cases.append(_case("non-convex curve, tip and side", scenes.STRAIGHT, pose, eq.warm()))
    out = {"note": NOTE, "cases": cases}
    (HERE / "scene_golden.json").write_text(json.dumps(out, indent=1) + "\n")
    for c in cases:
        print(c["name"], "pose", c["pose"], "residual %.1e agreement %.1e"
              % (c["residual"], c["agreement"]))


if __name__ == "__main__":
    main()
