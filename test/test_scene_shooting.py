"""
The scene shooting solver: several contacts with friction, checked against independent answers.

One contact must equal the exact single-contact models; several contacts are checked by physics
that the solver does not impose (global equilibrium, the moment along the whisker, Maxwell-Betti
symmetry, friction cones), by its own tolerance sweep, by events located two different ways, and
by the golden values in data/scene_golden.json (written by data/make_scene_golden.py).
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from vibrissa_ros.core import (
    Circle,
    ConvergenceError,
    FootPose,
    GeneralWhiskerModel,
    ParameterError,
    Phase,
    QuasistaticTracker,
    WhiskerShape,
)
from vibrissa_ros.core.scenes.boundary import CircleArc, GraphArc, ProfileArc, SegmentArc, Vertex
from vibrissa_ros.core.checks.scene_shooting import (
    arc_end_margin,
    ContactSpec,
    PosePath,
    cone_margin,
    follow_path,
    locate_event,
    nearest_approach,
    reaches_arc_length,
    release,
    slip_onset,
    solve_scene_equilibrium,
    touch_gap,
    touching_contact,
)

DATA = Path(__file__).parent / "data"
STRAIGHT = WhiskerShape()
CURVED = WhiskerShape(0.5, 0.5, 1.0)
HALF_PI = 0.5 * math.pi


def cross(ax, ay, bx, by):
    return ax * by - ay * bx


# -- one contact: the exact models --------------------------------------------------------------
def _tracked(model, poses):
    tracker = QuasistaticTracker(Circle(0.3, 0.8), 1.0, model=model)
    out = []
    for x0 in np.arange(0.98, min(poses) - 0.01, -0.02):
        tracker.step(FootPose(float(x0)))
        if any(abs(x0 - p) < 1e-9 for p in poses):
            out.append(tracker.state)
    return out


@pytest.mark.parametrize("model, shape, poses", [
    ("elastica", STRAIGHT, (0.78, 0.74, 0.6, 0.2, -0.3)),
    (GeneralWhiskerModel(WhiskerShape(0.4, 0.3, -0.5)), WhiskerShape(0.4, 0.3, -0.5),
     (0.84, 0.8, 0.6, 0.0, -0.4)),
], ids=["elastica", "general"])
def test_one_contact_equals_the_single_contact_models(model, shape, poses):
    arc = ProfileArc(Circle(0.3, 0.8))
    phases = set()
    for st in _tracked(model, poses):
        assert st.phase != Phase.FREE
        phases.add(st.phase)
        kind = "side" if st.phase == Phase.TANGENTIAL else "tip"
        guess = ContactSpec(kind, arc, s=min(st.s1 * 1.02, 0.99) if kind == "side" else 1.0,
                            u=st.alpha + 0.01, N=st.f * 1.05)
        eq = solve_scene_equilibrium(shape, st.pose, [guess])
        c = eq.contacts[0]
        assert eq.residual < 1e-12
        for mine, exact in ((c.N, st.f), (c.u, st.alpha), (c.s, st.s1), (eq.m0, st.m0),
                            (eq.fx, st.fx), (eq.fy, st.fy), (eq.tip_slope, st.tip_slope),
                            (c.x, st.contact[0]), (c.y, st.contact[1])):
            assert mine == pytest.approx(exact, abs=1e-10)
        assert c.T == 0.0
    assert phases == {Phase.TANGENTIAL, Phase.TIP}


# -- two pegs by continuation -------------------------------------------------------------------
PEG1 = CircleArc(-0.05, 0.45, 0.03)
PEG2 = {"straight": CircleArc(0.10, 0.85, 0.03), "curved": CircleArc(0.20, 0.75, 0.03)}
SHAPES = {"straight": STRAIGHT, "curved": CURVED}
SWEEP = PosePath(FootPose(0.1, 0.0, HALF_PI), FootPose(-0.5, 0.0, HALF_PI))


def _two_pegs(name):
    """Peg 1 touches first (located), then peg 2 (located); both are added as they touch."""
    shape, peg2 = SHAPES[name], PEG2[name]
    touch1 = locate_event(shape, SWEEP, [], touch_gap(PEG1, side=1))
    c1 = touching_contact(touch1.equilibrium, PEG1, side=1)
    rest = PosePath(touch1.pose, SWEEP.end)
    touch2 = locate_event(shape, rest, [c1], touch_gap(peg2, side=-1))
    c2 = touching_contact(touch2.equilibrium, peg2, side=-1)
    return shape, peg2, touch1, touch2, touch2.equilibrium.warm() + (c2,)


@pytest.fixture(scope="module", params=["straight", "curved"])
def two_pegs(request):
    shape, peg2, touch1, touch2, specs = _two_pegs(request.param)
    pose = FootPose(touch2.pose.x - 0.03, 0.0, HALF_PI)
    path = PosePath(touch2.pose, pose)
    eq = follow_path(shape, path, specs, np.linspace(0.0, 1.0, 7)[1:])[-1]
    return request.param, shape, peg2, touch2, eq


def test_two_pegs_touch_at_once_and_balance_globally(two_pegs):
    _, shape, peg2, _, eq = two_pegs
    assert len(eq.contacts) == 2 and eq.residual < 1e-12
    (a, b), foot = eq.contacts, eq.pose
    assert a.N > 0.0 and b.N > 0.0 and 0.0 < a.s < b.s < 1.0
    # contact points on the pegs' circles, forces along their normals (what the solver solved)
    for c, peg in ((a, PEG1), (b, peg2)):
        assert math.hypot(c.x - peg.cx, c.y - peg.cy) == pytest.approx(peg.r, abs=1e-12)
        assert cross(c.fx, c.fy, c.x - peg.cx, c.y - peg.cy) == pytest.approx(0.0, abs=1e-11)
    # global equilibrium: base load = sum of the forces and of their moments about the foot
    assert eq.fx == pytest.approx(a.fx + b.fx, abs=1e-13)
    m = sum(cross(c.x - foot.x, c.y - foot.y, c.fx, c.fy) for c in eq.contacts)
    assert eq.m0 == pytest.approx(m, abs=1e-10)
    # the moment along the whisker: M(s) = sum over the contacts beyond s of (r_c - r(s)) x F_c
    s = np.linspace(0.0, 1.0, 41)
    x, y, _, moment = eq.state(s)
    for si, xi, yi, mi in zip(s, x, y, moment):
        expect = sum(cross(c.x - xi, c.y - yi, c.fx, c.fy) for c in eq.contacts if c.s > si)
        assert mi == pytest.approx(expect, abs=1e-10)
    # the centerline is continuous and of length 1
    pts = eq.centerline(2001)
    assert np.sum(np.hypot(*np.diff(pts, axis=0).T)) == pytest.approx(1.0, abs=1e-6)
    assert tuple(pts[-1]) == pytest.approx(eq.tip, abs=1e-13)


def test_two_pegs_tolerance_sweep(two_pegs):
    _, shape, _, _, eq = two_pegs
    coarse = solve_scene_equilibrium(shape, eq.pose, eq.warm(), rtol=1e-11)
    for c, d in zip(eq.contacts, coarse.contacts):
        for key in ("s", "u", "N", "x", "y"):
            assert getattr(c, key) == pytest.approx(getattr(d, key), abs=1e-9)
    assert (eq.fx, eq.fy, eq.m0) == pytest.approx((coarse.fx, coarse.fy, coarse.m0), abs=1e-9)


def test_two_pegs_maxwell_betti_symmetry(two_pegs):
    """Frictionless contacts are conservative: d(fx, fy, m0)/d(x, y, heading) is symmetric."""
    _, shape, _, _, eq = two_pegs
    jac = _stiffness(shape, eq)
    assert np.max(np.abs(jac - jac.T)) < 1e-6 * np.max(np.abs(jac)), jac


def test_touch_and_release_are_one_event_located_two_ways(two_pegs):
    """Peg 2's touch (gap = 0, free of it) and release (N = 0, with it) agree to 1e-9."""
    _, shape, _, touch2, eq = two_pegs
    back = PosePath(eq.pose, FootPose(touch2.pose.x + 0.02, 0.0, HALF_PI))
    found = locate_event(shape, back, eq.warm(), release(1), steps=4)
    assert found is not None
    assert found.pose.x == pytest.approx(touch2.pose.x, abs=1e-9 * 0.05)
    assert found.equilibrium.contacts[0].N == pytest.approx(
        touch2.equilibrium.contacts[0].N, abs=1e-8)


def test_side_contact_reaching_the_tip_continues_as_a_tip_contact():
    shape, peg2, _, touch2, specs = _two_pegs("straight")
    path = PosePath(touch2.pose, SWEEP.end)
    ev = locate_event(shape, path, specs, reaches_arc_length(1, 1.0), steps=6)
    assert ev is not None and abs(ev.equilibrium.contacts[1].s - 1.0) < 1e-12
    side = ev.equilibrium
    tip = solve_scene_equilibrium(shape, ev.pose, (side.warm()[0], ContactSpec(
        "tip", peg2, s=1.0, u=side.contacts[1].u, N=side.contacts[1].N)))
    for key in ("N", "u", "x", "y"):
        assert getattr(tip.contacts[1], key) == pytest.approx(getattr(side.contacts[1], key),
                                                              abs=1e-9)
    assert tip.m0 == pytest.approx(side.m0, abs=1e-9)


def test_golden_values():
    """The stored golden scenes are reproduced (regression of this solver)."""
    golden = json.loads((DATA / "scene_golden.json").read_text())
    for case in golden["cases"]:
        shape = WhiskerShape(**case["shape"])
        pose = FootPose(**case["pose"])
        specs = []
        for c in case["contacts"]:
            feat = c["feature"]
            if feat["type"] == "circle":
                f = CircleArc(feat["cx"], feat["cy"], feat["r"])
            else:
                f = GraphArc(tuple(map(tuple, feat["points"])), side=feat["side"])
            specs.append(ContactSpec(c["kind"], f, s=c["s"] * 1.001, u=c["u"] + 1e-3,
                                     N=c["N"] * 1.01))
        eq = solve_scene_equilibrium(shape, pose, specs)
        for mine, c in zip(eq.contacts, case["contacts"]):
            for key in ("s", "u", "N", "T", "x", "y", "fx", "fy"):
                assert getattr(mine, key) == pytest.approx(c[key], abs=1e-10), (case["name"], key)
        for key in ("fx", "fy", "m0"):
            assert getattr(eq, key) == pytest.approx(case["base"][key], abs=1e-10)


# -- corners, tips on edges, a non-convex curve -------------------------------------------------
DIAMOND_RIGHT = Vertex(-0.05, 0.5, 0.25 * math.pi, 0.75 * math.pi)


def test_corner_on_the_whiskers_side():
    path = PosePath(FootPose(0.1, 0.0, HALF_PI), FootPose(-0.3, 0.0, HALF_PI))
    touch = locate_event(STRAIGHT, path, [], touch_gap(DIAMOND_RIGHT, side=1))
    assert touch.pose.x == pytest.approx(-0.05, abs=1e-12)
    spec = touching_contact(touch.equilibrium, DIAMOND_RIGHT, side=1)
    assert spec.kind == "corner" and spec.side == -1 and spec.s == pytest.approx(0.5, abs=1e-9)
    rest = PosePath(touch.pose, path.end)
    eqs = follow_path(STRAIGHT, rest, [spec], np.linspace(0.0, 0.5, 6)[1:])
    for eq in eqs:
        c = eq.contacts[0]
        assert (c.x, c.y) == pytest.approx((DIAMOND_RIGHT.x, DIAMOND_RIGHT.y), abs=1e-12)
        assert c.N > 0.0 and c.T == pytest.approx(0.0, abs=1e-12)
        # frictionless: the force is normal to the whisker there
        assert c.fx * math.cos(c.theta) + c.fy * math.sin(c.theta) == pytest.approx(0.0, abs=1e-11)
        assert eq.m0 == pytest.approx(cross(c.x - eq.pose.x, c.y - eq.pose.y, c.fx, c.fy),
                                      abs=1e-10)
    # the whisker turns about the corner until its normal leaves the corner's cone
    margins = [cone_margin(0)(eq) for eq in eqs]
    assert margins[0] > 0.0 and margins == sorted(margins, reverse=True)
    # a corner is the limit of a rounded corner: a peg of radius 1e-6 there agrees to ~1e-6
    eq = eqs[-1]
    c = eq.contacts[0]
    r = 1e-6
    nx, ny = c.fx / c.N, c.fy / c.N
    peg = CircleArc(c.x - r * nx, c.y - r * ny, r)
    rounded = solve_scene_equilibrium(STRAIGHT, eq.pose, [ContactSpec(
        "side", peg, s=c.s, u=math.atan2(nx, -ny), N=c.N)])
    assert rounded.contacts[0].N == pytest.approx(c.N, rel=1e-5)


def test_corner_leaves_its_cone_where_the_whisker_lies_along_an_edge():
    """The cone event of a corner is where the whisker becomes parallel to the adjacent edge."""
    path = PosePath(FootPose(0.1, 0.0, HALF_PI), FootPose(-0.3, 0.0, HALF_PI))
    touch = locate_event(STRAIGHT, path, [], touch_gap(DIAMOND_RIGHT, side=1))
    spec = touching_contact(touch.equilibrium, DIAMOND_RIGHT, side=1)
    ev = locate_event(STRAIGHT, PosePath(touch.pose, FootPose(-1.0, 0.0, HALF_PI)), [spec],
                      cone_margin(0), steps=10)
    assert ev is not None
    c = ev.equilibrium.contacts[0]
    assert math.remainder(c.theta - DIAMOND_RIGHT.phi_in, math.pi) == pytest.approx(0.0,
                                                                                    abs=1e-12)
    assert c.N > 0.0


EDGE = SegmentArc(-1.0, 0.95, 1.0, 0.95)  # a wall above, obstacle to the left of +x


def _tip_on_edge(friction):
    path = PosePath(FootPose(0.0, -0.2, 1.3), FootPose(0.0, 0.2, 1.3))
    touch = locate_event(STRAIGHT, path, [], touch_gap(EDGE))
    spec = touching_contact(touch.equilibrium, EDGE, **friction)
    assert spec.kind == "tip"
    return touch, spec


def test_tip_on_a_straight_edge_frictionless():
    touch, spec = _tip_on_edge({})
    path = PosePath(touch.pose, FootPose(0.0, touch.pose.y + 0.1, 1.3))
    for eq in follow_path(STRAIGHT, path, [spec], np.linspace(0.0, 1.0, 6)[1:]):
        c = eq.contacts[0]
        assert c.y == pytest.approx(0.95, abs=1e-12) and c.fx == pytest.approx(0.0, abs=1e-12)
        assert c.fy < 0.0 and c.s == 1.0
        assert eq.tip == pytest.approx((c.x, c.y), abs=1e-12)


def test_sticking_tip_holds_q_until_it_slips():
    """Press the tip on the wall without friction, then let it stick and move the foot sideways."""
    mu = 0.3
    touch, spec = _tip_on_edge({})
    pressed = solve_scene_equilibrium(STRAIGHT, FootPose(0.0, touch.pose.y + 0.03, 1.3), [spec])
    c0 = pressed.contacts[0]
    stick = ContactSpec("tip", EDGE, friction="stick", mu=mu, anchor=c0.q, s=1.0, u=c0.u,
                        N=c0.N)
    path = PosePath(pressed.pose, FootPose(0.0015, pressed.pose.y, 1.3))
    ev = locate_event(STRAIGHT, path, [stick], slip_onset(0), steps=6)
    assert ev is not None and 0.1 < ev.t < 0.9
    eqs = follow_path(STRAIGHT, path, [stick], np.linspace(0.0, ev.t, 4))
    assert eqs[0].contacts[0].T == pytest.approx(0.0, abs=1e-10)  # nothing pulls it yet
    for eq in eqs:
        c = eq.contacts[0]
        assert c.friction == "stick"
        assert c.q == pytest.approx(c0.q, abs=1e-12)
        assert c.x == pytest.approx(c0.x, abs=1e-12)  # the tip is held
        # the last time is the located slip onset, where |T| = mu N to the shooting's accuracy
        # (rtol 1e-13 per integration; the event's own solve and this one differ by ~1e-12)
        assert abs(c.T) <= mu * c.N * (1.0 + 1e-10)
    c = ev.equilibrium.contacts[0]
    assert abs(c.T) == pytest.approx(mu * c.N, abs=1e-12)
    # beyond the event the tip slips; friction opposes the slip: T = -slip_sign mu N
    slip_sign = -int(math.copysign(1.0, c.T))
    slip = ContactSpec("tip", EDGE, friction="slip", mu=mu, slip_sign=slip_sign, s=1.0, u=c.u,
                       N=c.N, T=c.T)
    at = solve_scene_equilibrium(STRAIGHT, ev.pose, [slip])
    assert at.contacts[0].u == pytest.approx(c.u, abs=1e-9)
    assert at.contacts[0].N == pytest.approx(c.N, abs=1e-9)
    later = solve_scene_equilibrium(STRAIGHT, path.pose(ev.t + 0.05), at.warm())
    dq = later.contacts[0].q - at.contacts[0].q
    assert math.copysign(1.0, dq) == slip_sign  # the sliding contact moves against its friction


def test_tip_slides_to_the_end_of_an_edge():
    touch, spec = _tip_on_edge({})
    end = touch.equilibrium.tip[0] + 0.01
    short = SegmentArc(-1.0, 0.95, end, 0.95)
    spec = ContactSpec("tip", short, s=1.0, u=spec.u)
    path = PosePath(touch.pose, FootPose(0.0, touch.pose.y + 0.1, 1.3))
    ev = locate_event(STRAIGHT, path, [spec], arc_end_margin(0), steps=5)
    assert ev is not None
    c = ev.equilibrium.contacts[0]
    assert (c.x, c.u) == pytest.approx((end, short.u_max), abs=1e-12)


def test_tip_held_at_a_vertex():
    """The tip on a corner: held there, the force free within the cone widened by atan(mu)."""
    shape = WhiskerShape(1.0, 0.8, 0.0)
    free = solve_scene_equilibrium(shape, FootPose(0.0, 0.0, HALF_PI), [])
    chord = math.atan2(free.tip[1], free.tip[0])
    mid = chord + 1.5 * math.pi  # the cone's bisector: the force pushes back towards the foot
    # the force turns by ~0.14 rad from -chord while the foot advances; the cone ends at 0.16
    corner = Vertex(free.tip[0], free.tip[1], mid - 0.3, mid + 0.16 - math.atan(0.05))
    spec = ContactSpec("tip_corner", corner, s=1.0, mu=0.05)
    d = 0.03  # the foot moves towards the tip: the whisker bows further
    path = PosePath(FootPose(0.0, 0.0, HALF_PI),
                    FootPose(d * math.cos(chord), d * math.sin(chord), HALF_PI))
    eqs = follow_path(shape, path, [spec], np.linspace(0.0, 1.0, 4)[1:])
    for eq in eqs:
        c = eq.contacts[0]
        assert eq.tip == pytest.approx((corner.x, corner.y), abs=1e-12)
        assert cone_margin(0)(eq) > 0.0 and c.q is None and c.u is None and c.N > 0.0
        assert eq.m0 == pytest.approx(cross(c.x - eq.pose.x, c.y - eq.pose.y, c.fx, c.fy),
                                      abs=1e-10)
        assert eq.state(1.0)[3, 0] == pytest.approx(0.0, abs=1e-12)  # no moment at the tip
    # turning the foot turns the force out of the widened cone
    turn = PosePath(eqs[-1].pose, FootPose(eqs[-1].pose.x, eqs[-1].pose.y, HALF_PI + 0.5))
    ev = locate_event(shape, turn, eqs[-1].warm(), cone_margin(0), steps=6)
    assert ev is not None
    c = ev.equilibrium.contacts[0]
    off = math.remainder(math.atan2(c.fx, -c.fy) - mid, 2.0 * math.pi)
    assert off == pytest.approx(0.16, abs=1e-12)


def _stiffness(shape, eq, h=1e-4):
    """d(fx, fy, m0)/d(x, y, heading) by central differences, each solve from ``eq``."""
    jac = np.empty((3, 3))
    for j in range(3):
        loads = []
        for sign in (1.0, -1.0):
            d = [0.0, 0.0, 0.0]
            d[j] = sign * h
            p = FootPose(eq.pose.x + d[0], eq.pose.y + d[1], eq.pose.heading + d[2])
            e = solve_scene_equilibrium(shape, p, eq.warm())
            loads.append(np.array([e.fx, e.fy, e.m0]))
        jac[:, j] = (loads[0] - loads[1]) / (2.0 * h)
    return jac


def test_a_sticking_tip_is_conservative():
    """A held tip is a workless constraint: Maxwell-Betti symmetry holds with it too."""
    touch, spec = _tip_on_edge({})
    pressed = solve_scene_equilibrium(STRAIGHT, FootPose(0.0, touch.pose.y + 0.03, 1.3), [spec])
    c0 = pressed.contacts[0]
    stick = ContactSpec("tip", EDGE, friction="stick", mu=0.3, anchor=c0.q, s=1.0, u=c0.u,
                        N=c0.N)
    eq = solve_scene_equilibrium(STRAIGHT, FootPose(0.0005, pressed.pose.y, 1.3), [stick])
    assert eq.contacts[0].T != 0.0
    jac = _stiffness(STRAIGHT, eq, h=2e-6)
    assert np.max(np.abs(jac - jac.T)) < 1e-5 * np.max(np.abs(jac)), jac
    # the sliding tip on the horizontal wall takes no sideways load at all; the held one does
    free = _stiffness(STRAIGHT, solve_scene_equilibrium(STRAIGHT, eq.pose, [spec]), h=2e-6)
    assert abs(free[0, 0]) < 1e-6 and jac[0, 0] < -1.0
    assert np.max(np.abs(free - free.T)) < 1e-5 * np.max(np.abs(free)), free


def test_mu_zero_is_exactly_frictionless():
    touch, spec = _tip_on_edge({})
    pose = FootPose(0.0, touch.pose.y + 0.05, 1.3)
    plain = solve_scene_equilibrium(STRAIGHT, pose, [spec])
    for friction in ({"friction": "slip", "mu": 0.0, "slip_sign": 1},
                     {"friction": "slip", "mu": 0.0, "slip_sign": -1},
                     {"friction": "stick", "mu": 0.0, "anchor": 0.3}):
        eq = solve_scene_equilibrium(STRAIGHT, pose, [ContactSpec(
            "tip", EDGE, s=1.0, u=spec.u, **friction)])
        assert eq.contacts[0].T == 0.0
        assert (eq.fx, eq.fy, eq.m0, eq.contacts[0].u) == (plain.fx, plain.fy, plain.m0,
                                                           plain.contacts[0].u)


VALLEY = GraphArc(((-1.0, 0.8), (0.0, 0.5), (1.0, 0.9)), side="below")
VALLEY_PATH = PosePath(FootPose(-1.3, 1.4, -0.6), FootPose(-1.3, 0.7, -0.6))


def _valley():
    touch1 = locate_event(STRAIGHT, VALLEY_PATH, [], touch_gap(VALLEY), steps=14)
    tip = touching_contact(touch1.equilibrium, VALLEY)
    rest = PosePath(touch1.pose, VALLEY_PATH.end)
    touch2 = locate_event(STRAIGHT, rest, [tip], touch_gap(VALLEY, s_to=0.8))
    side = touching_contact(touch2.equilibrium, VALLEY, s_to=0.8)
    return touch1, touch2, (tip, side)


def test_non_convex_curve_two_point_contact():
    touch1, touch2, specs = _valley()
    assert [c.kind for c in specs] == ["tip", "side"]
    path = PosePath(touch2.pose, FootPose(-1.3, touch2.pose.y - 0.008, -0.6))
    eqs = follow_path(STRAIGHT, path, (touch2.equilibrium.warm()[0], specs[1]),
                      np.linspace(0.0, 1.0, 6)[1:])
    for eq in eqs:
        tip, side = eq.contacts
        assert tip.N > 0.0 and side.N > 0.0 and side.s < 0.5
        for c in (tip, side):
            assert c.y == pytest.approx(VALLEY.height(c.x)[0], abs=1e-12)
        # both forces along the curve's normal (frictionless)
        for c in (tip, side):
            assert c.fx + VALLEY.height(c.x)[1] * c.fy == pytest.approx(0.0, abs=1e-11)
        m = sum(cross(c.x - eq.pose.x, c.y - eq.pose.y, c.fx, c.fy) for c in eq.contacts)
        assert eq.m0 == pytest.approx(m, abs=1e-10)
    # the side touch and its release are the same event
    back = PosePath(eqs[-1].pose, FootPose(-1.3, touch2.pose.y + 0.002, -0.6))
    found = locate_event(STRAIGHT, back, eqs[-1].warm(), release(1), steps=4)
    assert found.pose.y == pytest.approx(touch2.pose.y, abs=1e-9 * 0.01)


# -- bad input and failure --------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, text", [
    ({"kind": "edge", "feature": PEG1}, "kind"),
    ({"kind": "corner", "feature": PEG1}, "Vertex"),
    ({"kind": "side", "feature": DIAMOND_RIGHT}, "Arc"),
    ({"kind": "side", "feature": PEG1, "mu": -0.1}, "mu"),
    ({"kind": "side", "feature": PEG1, "friction": "roll"}, "friction"),
    ({"kind": "side", "feature": PEG1, "slip_sign": 2}, "slip_sign"),
    ({"kind": "side", "feature": PEG1, "s": math.nan}, "finite"),
])
def test_bad_contacts_are_refused(kwargs, text):
    with pytest.raises(ParameterError, match=text):
        ContactSpec(**kwargs)


def test_an_unreachable_contact_raises_convergence_error():
    far = CircleArc(3.0, 3.0, 0.1)
    with pytest.raises(ConvergenceError):
        solve_scene_equilibrium(STRAIGHT, FootPose(0.0), [ContactSpec("side", far, s=0.5,
                                                                      u=0.0, N=1.0)])


def test_a_load_far_too_large_fails_instead_of_hanging():
    """A straight whisker pushed along its axis onto a held tip: singular, Newton overshoots."""
    free = solve_scene_equilibrium(STRAIGHT, FootPose(0.0, 0.0, 1.3), [])
    corner = Vertex(free.tip[0], free.tip[1], -0.4, 0.4)
    with pytest.raises(ConvergenceError):
        solve_scene_equilibrium(STRAIGHT, FootPose(0.0, 0.01, 1.3),
                                [ContactSpec("tip_corner", corner, s=1.0)])


def test_nearest_approach_of_a_free_whisker():
    eq = solve_scene_equilibrium(STRAIGHT, FootPose(0.0), [])
    assert eq.m0 == 0.0 and eq.tip == pytest.approx((0.0, 1.0), abs=1e-13)
    gap, s, u = nearest_approach(eq, CircleArc(0.3, 0.5, 0.1))
    assert (gap, s) == pytest.approx((0.2, 0.5), abs=1e-10)
    assert nearest_approach(eq, Vertex(-0.2, 0.4, 0.0, 1.0))[0] == pytest.approx(0.2, abs=1e-12)
    assert nearest_approach(eq, Vertex(0.2, 0.4, 0.0, 1.0))[0] == pytest.approx(-0.2, abs=1e-12)
