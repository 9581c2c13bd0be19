"""
The collocation solver and scene tracker against the independent shooting method (issue 13).

Required: for two pegs and for a non-convex curve, the two methods agree to <= 1e-9, and events
to <= 1e-9 in the pose parameter. The shooting method (``core/checks/scene_shooting.py``) shares
nothing with the collocation but the geometry of ``boundary.py``; its golden values are in
``test/data/scene_golden.json``.
"""

import json
import math
import os

import numpy as np
import pytest

from vibrissa_ros.core.scenes.boundary import CircleArc, GraphArc
from vibrissa_ros.core.general.model import WhiskerShape
from vibrissa_ros.core.scenes.multicontact import ContactMode, MultiContactSolver
from vibrissa_ros.core.checks.scene_shooting import (
    ContactSpec,
    PosePath,
    arc_length_coordinate,
    locate_event,
    release,
    solve_scene_equilibrium,
    touch_gap,
)
from vibrissa_ros.core.scenes.tracker import SceneTracker
from vibrissa_ros.core.state import FootPose
from vibrissa_ros.scan.scene_file import load_scene

HERE = os.path.dirname(__file__)
GOLDEN = os.path.join(HERE, "data", "scene_golden.json")
TOL = 1e-9


def _feature(spec):
    if spec["type"] == "circle":
        return CircleArc(spec["cx"], spec["cy"], spec["r"])
    return GraphArc(tuple(map(tuple, spec["points"])), spec["side"])


def _cases():
    with open(GOLDEN) as stream:
        return json.load(stream)["cases"]


@pytest.mark.parametrize("case", _cases(), ids=lambda c: c["name"])
def test_collocation_reproduces_the_shooting_golden_values(case):
    shape = WhiskerShape(**case["shape"])
    pose = FootPose(**case["pose"])
    solver = MultiContactSolver(shape)
    modes, params = [], []
    for c in sorted(case["contacts"], key=lambda c: c["s"]):
        feature = _feature(c["feature"])
        if c["kind"] == "side":
            e = 1 if math.cos(math.atan2(c["fy"], c["fx"]) - feature.at(c["u"]).phi
                              - 0.5 * math.pi) < 0 else -1
            modes.append(ContactMode("side", feature, e=e))
            params.append([c["s"] * (1 + 1e-3), c["u"] + 1e-3, c["N"] * (1 - 1e-3)])
        else:
            modes.append(ContactMode("tip", feature))
            params.append([c["u"] + 1e-3, c["N"] * (1 - 1e-3)])
    # slopes: the unloaded whisker as a rough start
    guess = []
    from vibrissa_ros.core.scenes.multicontact import _Segment

    a = 0.0
    for m, p in zip(modes, params):
        b = p[0] if m.kind == "side" else 1.0
        seg = _Segment(shape, solver._t, solver._S, a, b)
        guess.append(pose.heading + shape.intrinsic_slope(seg.s))
        a = b
    vec = np.concatenate(guess + [np.array(p, dtype=float) for p in params])
    vec, _ = solver.solve(modes, pose, vec)
    cfg = solver.configuration(modes, vec, pose)
    base = case["base"]
    assert abs(cfg.fx - base["fx"]) < TOL and abs(cfg.fy - base["fy"]) < TOL
    assert abs(cfg.m0 - base["m0"]) < TOL
    want = sorted(case["contacts"], key=lambda c: c["s"])
    for got, c in zip(cfg.contacts, want):
        for key in ("s", "x", "y", "fx", "fy", "N"):
            assert abs(getattr(got, key) - c[key]) < TOL, (key, getattr(got, key), c[key])


def _spec(mode, contact, jiggle=1e-4):
    """Describe one of the tracker's contacts for the shooting method (guesses jiggled)."""
    anchor = 0.0
    if mode.stick:
        u_a, s_a = mode.anchor
        if mode.kind == "side":
            anchor = arc_length_coordinate(mode.feature, u_a) - mode.e * s_a
        elif mode.kind == "corner":
            anchor = -s_a
        else:
            anchor = arc_length_coordinate(mode.feature, u_a)
    kw = dict(kind=mode.kind, feature=mode.feature, friction="stick" if mode.stick else "slip",
              mu=mode.mu, anchor=anchor, slip_sign=mode.slip_sign,
              side=mode.e if mode.kind == "corner" else 1,
              s=contact.s * (1 - jiggle) if mode.kind in ("side", "corner") else 1.0,
              u=(contact.u or 0.0) + jiggle, N=contact.N * (1 + jiggle), T=contact.T)
    return ContactSpec(**kw)


def _compare(state, shape):
    """Solve the tracker's configuration by shooting from jiggled guesses; largest difference."""
    cfg = state.configuration
    specs = [_spec(m, c) for m, c in zip(cfg.modes, cfg.contacts)]
    eq = solve_scene_equilibrium(shape, state.pose, specs)
    worst = max(abs(eq.fx - state.fx), abs(eq.fy - state.fy), abs(eq.m0 - state.m0))
    for a, b in zip(eq.contacts, state.contacts):
        worst = max(worst, abs(a.s - b.s), abs(a.x - b.x), abs(a.y - b.y), abs(a.fx - b.fx),
                    abs(a.fy - b.fy))
    return worst


@pytest.mark.parametrize("shape", [WhiskerShape(), WhiskerShape(0.3, -0.5, 0.4)],
                         ids=["straight", "tapered-curved"])
@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_two_pegs_agree_with_shooting_along_the_sweep(shape, mu):
    scene = load_scene(os.path.join(HERE, "..", "config", "scene_two_pegs.yaml"))
    tracker = SceneTracker(list(scene), -0.4, shape=shape, friction=[mu, mu])
    checked = worst = 0
    for x0 in np.linspace(-0.4, 0.2, 61)[1:]:
        state = tracker.step(float(x0)).state
        if len(state.contacts) == 2 or (x0 > 0.1 and state.contacts):
            worst = max(worst, _compare(state, shape))
            checked += 1
    assert checked >= 3
    assert worst < TOL


def test_a_non_convex_contour_two_point_contact_agrees_with_shooting():
    scene = load_scene(os.path.join(HERE, "..", "config", "scene_contour.yaml"))
    tracker = SceneTracker(list(scene), -0.6)
    shape = WhiskerShape()
    two = worst = 0
    for x0 in np.linspace(-0.6, 0.6, 121)[1:]:
        state = tracker.step(float(x0)).state
        if state.contacts and (len(state.contacts) == 2 or int(round(x0 * 100)) % 10 == 0):
            worst = max(worst, _compare(state, shape))
            two += len(state.contacts) == 2
    assert two >= 3
    assert worst < TOL


def test_two_peg_events_agree_with_shooting():
    scene = load_scene(os.path.join(HERE, "..", "config", "scene_two_pegs.yaml"))
    obstacles = list(scene)
    shape = WhiskerShape()
    tracker = SceneTracker(obstacles, -0.4)
    grid = np.linspace(-0.4, 0.2, 61)
    events, states = [], {}
    for x0 in grid[1:]:
        result = tracker.step(float(x0))
        events += [(e.kind, e.obstacle, e.pose.x) for e in result.events]
        states[float(x0)] = result.state
    kinds = [(k, o) for k, o, _ in events]
    assert kinds == [("touch", 1), ("touch", 0), ("release", 1)]
    # second touch: peg0 reaches the whisker bent around peg1
    x_touch = events[1][2]
    before = max(x for x in states if x < x_touch)
    st = states[before]
    path = PosePath(FootPose(before), FootPose(before + 0.01))
    specs = [_spec(m, c, 0.0) for m, c in zip(st.configuration.modes, st.contacts)]
    peg0 = obstacles[0].arcs[0]
    located = locate_event(shape, path, specs, touch_gap(peg0))
    assert located is not None
    assert abs(located.pose.x - x_touch) < TOL
    # release of peg1 while peg0 holds
    x_release = events[2][2]
    before = max(x for x in states if x < x_release)
    st = states[before]
    path = PosePath(FootPose(before), FootPose(before + 0.01))
    specs = [_spec(m, c, 0.0) for m, c in zip(st.configuration.modes, st.contacts)]
    index = [c.obstacle for c in st.contacts].index(1)
    located = locate_event(shape, path, specs, release(index))
    assert located is not None
    assert abs(located.pose.x - x_release) < TOL


def test_sticking_and_slipping_contacts_agree_with_shooting():
    # a peg swept past and back with mu = 0.3: the reversal sticks, then slips the other way
    scene = load_scene("obstacles:\n  - {type: peg, x: 0.0, y: 0.3, r: 0.03, friction: 0.3}\n")
    shape = WhiskerShape(0.5, 0.0, 0.0)
    tracker = SceneTracker(list(scene), 0.6, shape=shape, friction=[0.3])
    seen, worst = set(), 0.0
    grid = np.concatenate((np.linspace(0.6, -0.3, 46), np.linspace(-0.3, -0.29, 11)[1:],
                           np.linspace(-0.29, 0.2, 25)[1:]))
    for x0 in grid[1:]:
        state = tracker.step(float(x0)).state
        if state.contacts:
            seen |= {c.state for c in state.contacts}
            worst = max(worst, _compare(state, shape))
    assert seen == {"stick", "slip"}
    assert worst < TOL


def test_a_polygon_corner_edge_and_tip_agree_with_shooting_and_mirror():
    # a diamond: its right corner meets the whisker's side, the contact moves onto an edge, slides
    # to the bottom corner, reaches the tip there, and the tip slips off; the way back mirrors it
    scene = load_scene("obstacles:\n  - {type: polygon, vertices: "
                       "[[0.0, 0.45], [0.2, 0.65], [0.0, 0.85], [-0.2, 0.65]]}\n")
    shape = WhiskerShape()
    tracker = SceneTracker(list(scene), 0.6)
    events, kinds, worst = [], set(), 0.0
    grid = np.concatenate((np.linspace(0.6, -0.8, 141), np.linspace(-0.8, 0.6, 141)[1:]))
    for x0 in grid[1:]:
        result = tracker.step(float(x0))
        events += [(e.kind, e.pose.x) for e in result.events]
        for c in result.state.contacts:
            kinds.add(c.kind)
        if result.state.contacts:
            worst = max(worst, _compare(result.state, shape))
    assert kinds == {"corner", "side", "tip_corner"}
    assert worst < TOL
    names = [k for k, _ in events]
    assert names[:6] == ["touch", "edge", "corner", "tip", "edge", "snap"]
    assert names[6:] == ["touch", "edge", "corner"]
    for (_, a), (_, b) in zip(events[:3], events[6:9]):
        assert abs(a + b) < 1e-9  # the diamond is symmetric about x = 0
