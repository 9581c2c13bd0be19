"""
The 3D collocation tracker against the independent shooting solver, in genuinely 3D cases.

Required (issue 19): along 3D base paths (position and orientation changing) the tracker's
equilibria agree with :func:`~vibrissa_ros.core.checks.rod3d_shooting.shoot_contacts` to
<= 1e-9 (arc lengths, forces, contact points, base force and moment) and its events (touch,
release, tip, tangential) with independently located ones to <= 1e-9 in the path parameter t
(p linear, q by slerp: ``BasePose.at``). The shooting side gets its own minimal obstacles
(``_Ball``, ``_Pole``, ``_HalfSpace``), so nothing of ``core/rod3d`` but the shape, the pose and
the free centerline enters the reference answers; the parabola's prism is the scene's own.

Events located here, not by the tracker:

- touch of a free whisker: the root in t of the unloaded centerline's distance to the obstacle
  (401 samples, then a bounded minimisation in s);
- touch of a loaded whisker, and release: the root in t of that contact's force in the shooting
  solution of the configuration with it (at f = 0 the two configurations coincide);
- tip: the root of s - 1 of the last side contact, shot past the tip (the rod's ODE extends);
- tangential: the root of d1(1) . n of the tip contact.

The parabola scan (the paper's profile as a prism, the base swept along x) snaps out of its
plane at x0 = -0.5007761. Checked here with the shooting formulation: the determinant of its
Jacobian (central differences) changes sign at the same x0, with a null vector that is a pure
M0x: a rigid roll of the bent whisker about its base axis. That roll costs no elastic energy
(straight isotropic whisker), so the contact alone decides its stability: rolled by alpha, the
contact point lifts off by (-fx / f) (xc - x0) alpha^2 / 2, which changes sign where the contact
crosses the parabola's apex (fx = 0) -- exactly the snap. It is not Euler buckling of the base
segment: the axial load passes pi^2 / (4 s_c^2) at x0 ~ -0.04 already, 0.46 L before the snap.
After the snap the whisker lies on the mirror image of its planar states (bent the other way).
"""

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

from vibrissa_ros.core.checks.rod3d_shooting import shoot_contacts
from vibrissa_ros.core.rod3d import BasePose, Cylinder, Plane, RodShape, RodTracker, Sphere
from vibrissa_ros.core.rod3d.pose import quat_about, quat_multiply
from vibrissa_ros.scan.scene_file import load_scene3d

TOL = 1e-9
#: largest residual of a shooting solution used here (its own acceptance bound)
RESIDUAL = 1e-10
#: relative change of the tracker's s, f and base load before they seed the shooting
JIGGLE = 1e-3


# -- minimal obstacles of the shooting side ------------------------------------------------------
@dataclass(frozen=True)
class _Surface:
    distance: float
    normal: np.ndarray


@dataclass(frozen=True)
class _Ball:
    center: np.ndarray
    r: float

    def distance(self, points):
        return np.linalg.norm(np.atleast_2d(points) - self.center, axis=1) - self.r

    def surface(self, x):
        d = np.asarray(x, dtype=float) - self.center
        rho = float(np.linalg.norm(d))
        return _Surface(rho - self.r, d / rho)


@dataclass(frozen=True)
class _Pole:
    point: np.ndarray
    axis: np.ndarray
    r: float

    def _radial(self, points):
        d = np.atleast_2d(points) - self.point
        return d - np.outer(d @ self.axis, self.axis)

    def distance(self, points):
        return np.linalg.norm(self._radial(points), axis=1) - self.r

    def surface(self, x):
        d = self._radial(np.asarray(x, dtype=float))[0]
        rho = float(np.linalg.norm(d))
        return _Surface(rho - self.r, d / rho)


@dataclass(frozen=True)
class _HalfSpace:
    point: np.ndarray
    normal: np.ndarray

    def distance(self, points):
        return (np.atleast_2d(points) - self.point) @ self.normal

    def surface(self, x):
        return _Surface(float((np.asarray(x, dtype=float) - self.point) @ self.normal),
                        self.normal)


def _own(ob):
    """Return the shooting side's copy of a scene obstacle (a prism: the obstacle itself)."""
    if ob.kind == "sphere":
        return _Ball(np.array(ob.center), ob.r)
    if ob.kind == "cylinder":
        a = np.array(ob.axis)
        return _Pole(np.array(ob.point), a / np.linalg.norm(a), ob.r)
    if ob.kind == "plane":
        n = np.array(ob.normal)
        return _HalfSpace(np.array(ob.point), n / np.linalg.norm(n))
    return ob


# -- the cases ----------------------------------------------------------------------------------
def _rotation(*turns):
    """Return the quaternion of successive rotations (axis, angle) about the turned axes."""
    q = np.array((1.0, 0.0, 0.0, 0.0))
    for axis, angle in turns:
        q = quat_multiply(q, quat_about(np.array(axis) / np.linalg.norm(axis), angle))
    return q


def _turned(pose, position, *turns):
    """Return the pose at ``position`` turned from ``pose`` by world rotations (axis, angle)."""
    return BasePose(tuple(position), tuple(quat_multiply(_rotation(*turns), pose.q)))


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


@dataclass(frozen=True)
class Case:
    """A scene, a whisker and its base path, with the states to shoot and the events expected."""

    shape: RodShape
    obstacles: tuple
    legs: tuple  # (BasePose from, BasePose to, steps)
    checks: tuple  # (leg, step) of states compared with the shooting
    events: tuple  # (kind, obstacle) of every event, in path order


def _sphere_case():
    # a tapered whisker curving in its own plane, rolled 0.6 rad; the sphere off that plane
    shape = RodShape(taper=0.5, k0=0.8, k1=-0.4)
    a = BasePose((0.1, -0.2, 0.3), tuple(_rotation(((0, 0, 1), 0.7), ((0, 1, 0), -0.4),
                                                   ((1, 0, 0), 0.6))))
    rot = a.rotation
    u = rot @ _unit((0.0, 0.3, 1.0))
    ball = Sphere(tuple(a.p + rot @ shape.free_centerline([0.55])[0] + 0.19 * u), 0.15)
    b = _turned(a, a.p + 0.16 * u + 0.05 * rot[:, 0], ((1, 1, 0), 0.25))
    return Case(shape, (ball,), ((a, b, 12), (b, a, 12)), ((0, 6), (0, 12), (1, 8)),
                (("touch", 0), ("release", 0)))


def _cylinder_case():
    # a parabola whisker rolled -0.8 rad; a tilted pole pushes it and it slides to the tip
    shape = RodShape(taper=0.6, parabola=0.7)
    a = BasePose((-0.2, 0.1, 0.0), tuple(_rotation(((0, 0, 1), -0.5), ((0, 1, 0), 0.3),
                                                   ((1, 0, 0), -0.8))))
    rot = a.rotation
    axis = rot @ np.array((0.2, 0.3, 1.0))
    u = rot @ np.array((0.0, 1.0, 0.4))
    u = _unit(u - (u @ axis) / (axis @ axis) * axis)
    pole = Cylinder(tuple(a.p + rot @ shape.free_centerline([0.75])[0] + 0.13 * u),
                    tuple(axis), 0.1)
    b = _turned(a, a.p + 0.12 * u - 0.35 * rot[:, 0], ((0, 1, 1), 0.2))
    return Case(shape, (pole,), ((a, b, 16),), ((0, 4), (0, 11)),
                (("touch", 0), ("tip", 0), ("snap", None)))


def _floor_case():
    # a tapered whisker pitched down, curving up: its belly lands on a tilted floor
    shape = RodShape(taper=0.4, k0=1.5)
    a = BasePose((0.0, 0.0, 0.5), tuple(_rotation(((0, 0, 1), 0.4), ((0, 1, 0), 0.6),
                                                  ((1, 0, 0), 1.3))))
    n = _unit((0.1, -0.2, 1.0))
    free = a.p + shape.free_centerline(np.linspace(0.0, 1.0, 1001)) @ a.rotation.T
    floor = Plane(tuple(free[np.argmin(free @ n)] - 0.03 * n), tuple(n))
    b = _turned(a, a.p - 0.08 * n + np.array((0.1, 0.1, 0.0)), ((1, 0, 0), 0.3),
                ((0, 0, 1), 0.3))
    return Case(shape, (floor,), ((a, b, 12),), ((0, 10), (0, 12)), (("touch", 0),))


def _two_case():
    # a sphere near the base and a skew pole near the tip, on the same side of the whisker
    shape = RodShape(taper=0.6, k0=0.6, k1=0.4)
    a = BasePose((0.3, -0.1, 0.2), tuple(_rotation(((0, 0, 1), 1.0), ((0, 1, 0), -0.2),
                                                   ((1, 0, 0), -0.9))))
    rot = a.rotation

    def free(s):
        return a.p + rot @ shape.free_centerline([s])[0]

    u = rot @ _unit((0.0, -0.4, 1.0))
    ball = Sphere(tuple(free(0.4) + 0.13 * u), 0.08)
    axis = rot @ np.array((0.3, 1.0, 0.2))
    w = _unit(u - (u @ axis) / (axis @ axis) * axis)
    pole = Cylinder(tuple(free(0.85) + 0.14 * w), tuple(axis), 0.05)
    b = _turned(a, a.p + 0.2 * u + 0.1 * rot[:, 0], ((1, -1, 1), 0.3))
    return Case(shape, (ball, pole), ((a, b, 16),), ((0, 5), (0, 8), (0, 11)),
                (("touch", 0), ("touch", 1), ("snap", None)))


def _wall_case():
    # a tapered curved whisker, rolled 1 rad, pushed tip first into an oblique wall until its
    # tip lies along the wall
    shape = RodShape(taper=0.5, k0=0.5, k1=0.3)
    a = BasePose((0.1, 0.0, 0.2), tuple(_rotation(((0, 0, 1), -0.3), ((0, 1, 0), 0.2),
                                                  ((1, 0, 0), 1.0))))
    rot = a.rotation
    n = -rot @ _unit((1.0, 0.3, 0.4))
    wall = Plane(tuple(a.p + rot @ shape.free_centerline([1.0])[0] - 0.04 * n), tuple(n))
    b = _turned(a, a.p - 0.7 * n + 0.1 * rot[:, 1], ((0, 0, 1), 0.3))
    return Case(shape, (wall,), ((a, b, 20),), ((0, 6), (0, 14), (0, 20)),
                (("touch", 0), ("tangential", 0)))


CASES = {
    "sphere": _sphere_case,
    "tilted-cylinder": _cylinder_case,
    "plane-under-whisker": _floor_case,
    "sphere-and-cylinder": _two_case,
    "tip-on-plane": _wall_case,
}


@lru_cache(maxsize=None)
def _tracked(name):
    """Track the case; return it and per leg the states at its steps and the events by step."""
    case = CASES[name]()
    a = case.legs[0][0]
    tracker = RodTracker(case.obstacles, a, shape=case.shape)
    legs = []
    for p, q, steps in case.legs:
        assert tracker.pose == p
        states, events = [tracker.state], []
        for k in range(1, steps + 1):
            result = tracker.step(q if k == steps else p.at(q, k / steps))
            states.append(result.state)
            events += [(k, e) for e in result.events]
        legs.append((states, events))
    return case, legs


# -- the shooting side --------------------------------------------------------------------------
def _shot_inputs(obstacles, state, jiggle):
    """Return the contacts, guesses and base guess of shoot_contacts from a tracker state."""
    contacts = [(_own(obstacles[c.obstacle]), c.kind) for c in state.contacts]
    guess = [(min(c.s * (1.0 - jiggle), 1.0 - 1e-6), c.f * (1.0 + jiggle))
             for c in state.contacts]
    base = (np.array(state.force) * (1.0 + jiggle), np.array(state.moment) * (1.0 - jiggle))
    return contacts, guess, base


def _difference(res, state):
    """Largest difference between a shooting solution and a tracker state, and its name."""
    worst = [(np.max(np.abs(res.force - state.force)), "force"),
             (np.max(np.abs(res.moment - state.moment)), "moment")]
    for a, b in zip(res.contacts, state.contacts):
        worst += [(abs(a.s - b.s), "s"), (abs(a.f - b.f), "f"),
                  (np.max(np.abs(a.point - b.point)), "point"),
                  (np.max(np.abs(a.force - b.force)), "contact force")]
    return max(worst)


@pytest.mark.parametrize("name", sorted(CASES))
def test_tracked_states_equal_the_shooting_solutions(name):
    case, legs = _tracked(name)
    kinds = set()
    for leg, step in case.checks:
        state = legs[leg][0][step]
        assert state.contacts, (leg, step)
        kinds |= {(c.kind, len(state.contacts)) for c in state.contacts}
        contacts, guess, base = _shot_inputs(case.obstacles, state, JIGGLE)
        res = shoot_contacts(case.shape, state.pose, contacts, guess, base_guess=base)
        assert res.success and res.admissible, res.message
        diff, what = _difference(res, state)
        assert diff <= TOL, (leg, step, what, diff)
        # genuinely 3D: the load twists the whisker (zero in any planar problem)
        moment = np.array(state.moment)
        assert abs(moment @ state.pose.rotation[:, 0]) > 0.02 * np.linalg.norm(moment)
    want = {"tip-on-plane": {("tip", 1), ("side", 1)}, "sphere-and-cylinder": {("side", 1),
                                                                               ("side", 2)}}
    assert kinds == want.get(name, {("side", 1)})


class _Branch:
    """One configuration shot along a leg, each solve started from the nearest one solved."""

    def __init__(self, case, leg, contacts, guess, base):
        self.case, self.leg, self.contacts = case, leg, contacts
        self.seed = (guess, base)
        self.solved = {}

    def at(self, t):
        if t not in self.solved:
            guess, base = self.seed
            if self.solved:
                near = self.solved[min(self.solved, key=lambda u: abs(u - t))]
                guess = [(min(c.s, 1.0 - 1e-6), c.f) for c in near.contacts]
                base = (near.n0, near.m0)
            p, q, _ = self.leg
            res = shoot_contacts(self.case.shape, p.at(q, t), self.contacts, guess,
                                 base_guess=base)
            assert res.residual <= RESIDUAL, res.message
            self.solved[t] = res
        return self.solved[t]


def _free_gap(shape, ob, pose):
    """Return the unloaded whisker's distance to ``ob`` at ``pose`` (samples, then Brent in s)."""
    s = np.linspace(0.0, 1.0, 401)
    pts = pose.p + shape.free_centerline(s) @ pose.rotation.T
    d = ob.distance(pts)
    j = int(np.argmin(d))

    def dist(u):
        return float(ob.distance(pose.p + pose.rotation @ shape.free_centerline([u])[0])[0])

    res = minimize_scalar(dist, bounds=(s[max(j - 1, 0)], s[min(j + 1, s.size - 1)]),
                          method="bounded", options={"xatol": 1e-12})
    return min(float(d[j]), float(res.fun))


def _path_parameter(leg, pose):
    """Return t of a pose on the leg (p linear in t), checking its orientation is slerp's."""
    p, q, _ = leg
    dp = q.p - p.p
    t = float((pose.p - p.p) @ dp / (dp @ dp))
    assert abs(abs(float(p.at(q, t).q @ pose.q)) - 1.0) < 1e-12
    assert np.max(np.abs(p.at(q, t).p - pose.p)) < 1e-12
    return t


def _locate(case, leg, before, event, bracket):
    """Locate ``event`` in t independently of the tracker; also return the s found."""
    kind = event.kind
    own = [_own(ob) for ob in case.obstacles]
    p, q, _ = leg
    if kind == "touch" and not before.contacts:
        ob = own[event.obstacle]
        t = brentq(lambda t: _free_gap(case.shape, ob, p.at(q, t)), *bracket, xtol=1e-13)
        return t, None
    contacts, guess, base = _shot_inputs(case.obstacles, before, 0.0)
    if kind == "touch":  # the configuration with the new contact, at zero force
        index = int(np.searchsorted([c.s for c in before.contacts], event.s))
        contacts.insert(index, (own[event.obstacle], "side"))
        guess.insert(index, (event.s, 0.0))
    else:
        index = [c.obstacle for c in before.contacts].index(event.obstacle)
    branch = _Branch(case, leg, contacts, guess, base)

    def g(t):
        c = branch.at(t).contacts[index]
        if kind in ("touch", "release"):
            return c.f
        if kind == "tip":
            return c.s - 1.0
        return float(c.tangent @ c.normal)  # tangential

    t = brentq(g, *bracket, xtol=1e-13)
    return t, branch.at(t).contacts[index].s


@pytest.mark.parametrize("name", sorted(CASES))
def test_events_agree_with_independently_located_ones(name):
    case, legs = _tracked(name)
    seen = []
    for leg, (states, events) in zip(case.legs, legs):
        steps = leg[2]
        for k, event in events:
            seen.append((event.kind, event.obstacle))
            if event.kind == "snap":
                continue
            t = _path_parameter(leg, event.pose)
            before = states[k - 1]
            assert event.contacts_before == len(before.contacts)
            bracket = ((k - 1) / steps, k / steps)
            assert bracket[0] < t < bracket[1]
            located, s = _locate(case, leg, before, event, bracket)
            assert abs(located - t) <= TOL, (event.kind, located, t)
            if s is not None:
                # a touch's s is where a distance is least: the tracker's minimisation in s
                # finds it to ~1e-8 only (the distance is flat there)
                tol = 1e-7 if event.kind == "touch" else TOL
                assert abs(s - event.s) <= tol, (event.kind, s, event.s)
    assert tuple(seen) == case.events


# -- the out-of-plane snap on the paper's parabola ---------------------------------------------
PARABOLA = "obstacles:\n  - {type: parabola, p0: 0.3}\n"
STRAIGHT = RodShape()


@lru_cache(maxsize=None)
def _parabola_scan():
    """Sweep x0 from 1.2 to -1.2 in steps of 0.01; the states by x0 (rounded) and the events."""
    scene = load_scene3d(PARABOLA)
    tracker = RodTracker(scene, BasePose.from_planar(1.2))
    states, events = {}, []
    for i in range(1, 241):
        x0 = round(1.2 - 0.01 * i, 2)
        result = tracker.step(BasePose.from_planar(x0))
        states[x0] = result.state
        events += list(result.events)
    return scene.obstacles[0], states, events


def _snap():
    _, _, events = _parabola_scan()
    (snap,) = [e for e in events if e.kind == "snap"]
    return snap


class _PlanarBranch:
    """
    The tracked side contact on the parabola (before the snap), shot at any x0.

    Each solve starts from the nearest x0 solved or tracked before the snap.
    """

    def __init__(self, prism, states, x_snap):
        self.prism = prism
        self.solved = {}
        for x0, state in states.items():
            if x0 > x_snap and state.contacts and state.contacts[0].kind == "side":
                c = state.contacts[0]
                self.solved[x0] = (np.array(state.force), np.array(state.moment), c.s, c.f)

    def at(self, x0):
        n0, m0, s, f = self.solved[min(self.solved, key=lambda u: abs(u - x0))]
        res = shoot_contacts(STRAIGHT, BasePose.from_planar(x0), [(self.prism, "side")],
                             [(s, f)], base_guess=(n0, m0))
        assert res.success and res.residual <= RESIDUAL, res.message
        self.solved[x0] = (res.n0, res.m0, res.contacts[0].s, res.contacts[0].f)
        return res


def _jacobian(res, h=1e-5):
    """Central differences of the shooting residual in its unknowns (n0, M0, s, f)."""
    problem, x = res._problem, res._x
    jac = np.empty((x.size, x.size))
    for j in range(x.size):
        e = np.zeros(x.size)
        e[j] = h
        jac[:, j] = (problem.residual(x + e) - problem.residual(x - e)) / (2.0 * h)
    return jac


def test_the_parabola_snap_is_where_the_shooting_jacobian_turns_singular():
    prism, states, _ = _parabola_scan()
    snap = _snap()
    assert "becomes unstable" in snap.reason and "swings out of its plane" in snap.reason
    x_snap = snap.pose.position[0]
    assert abs(x_snap + 0.5007761) < 1e-7
    branch = _PlanarBranch(prism, states, x_snap)
    # det J keeps its sign along the side contact's planar branch down to the snap ...
    signs = {x0: np.sign(np.linalg.det(_jacobian(branch.at(x0))))
             for x0 in (-0.5, -0.4, -0.2, 0.0, 0.2, 0.4, 0.56)}
    assert len(set(signs.values())) == 1
    # ... and changes it exactly there
    root = brentq(lambda x0: np.linalg.det(_jacobian(branch.at(x0))), -0.505, -0.5, xtol=1e-13)
    assert abs(root - x_snap) <= TOL
    res = branch.at(root)
    sv, vt = np.linalg.svd(_jacobian(res))[1:]
    assert sv[-1] < 1e-9 * sv[0] and sv[-2] > 1e-3 * sv[0]
    null = vt[-1]
    # out of plane: only (n0z, M0x, M0y) move, and only M0x: a roll about the base axis (y)
    assert np.max(np.abs(np.delete(null, 3))) < 1e-9
    # the roll is neutral when the contact force is along the base axis: at the apex
    c = res.contacts[0]
    assert abs(res.force[0]) < TOL and abs(c.point[0]) < TOL
    assert abs(c.point[1] - 0.3) < TOL
    # not Euler buckling: the axial load passed pi^2 / (4 s^2) long before, on a stable branch
    for x0, expect in ((0.0, False), (-0.1, True), (root, True)):
        r = branch.at(x0)
        s = r.contacts[0].s
        assert (-r.force[1] > math.pi ** 2 / (4.0 * s * s)) == expect, x0


def _rolled_clearance(prism, res, x0, angle):
    """Return the least distance to the prism of the whisker rolled about its base axis (y)."""
    line = res.centerline(2001) - (x0, 0.0, 0.0)
    c, s = math.cos(angle), math.sin(angle)
    rolled = line @ np.array(((c, 0.0, -s), (0.0, 1.0, 0.0), (s, 0.0, c))) + (x0, 0.0, 0.0)
    return float(np.min(prism.signed_distance(rolled)))


@pytest.mark.parametrize("x0", [-0.45, -0.55])
def test_past_the_apex_a_rolled_whisker_lifts_off(x0):
    # rolling the planar state about the base axis keeps its elastic energy (straight,
    # isotropic); before the apex the roll cuts into the parabola, past it the contact lifts
    # off: an admissible neighbour with the same energy, not in equilibrium -- not a minimum
    prism, states, _ = _parabola_scan()
    res = _PlanarBranch(prism, states, _snap().pose.position[0]).at(x0)
    c = res.contacts[0]
    for angle in (0.05, -0.05):
        lift = _rolled_clearance(prism, res, x0, angle)
        predicted = -res.force[0] / c.f * (c.point[0] - x0) * angle ** 2 / 2.0
        assert abs(lift - predicted) < 0.02 * abs(predicted)
        assert (lift > 0.0) == (x0 < _snap().pose.position[0])


def _mirror_difference(a, b):
    """Largest difference between state a and the mirror image (x -> -x) of state b."""
    m = np.array((-1.0, 1.0, 1.0))
    worst = max(np.max(np.abs(np.array(a.force) - m * b.force)),
                np.max(np.abs(np.array(a.moment) + m * b.moment)))
    for ca, cb in zip(a.contacts, b.contacts):
        assert ca.kind == cb.kind
        worst = max(worst, abs(ca.s - cb.s), abs(ca.f - cb.f),
                    np.max(np.abs(np.array(ca.point) - m * cb.point)))
    return worst


def test_after_the_snap_the_whisker_lies_on_the_mirrored_planar_states():
    prism, states, events = _parabola_scan()
    x_snap = _snap().pose.position[0]
    compared = 0
    for x0, state in states.items():
        if x0 < x_snap and state.contacts and states[-x0].contacts:
            assert len(state.contacts) == len(states[-x0].contacts) == 1
            assert _mirror_difference(state, states[-x0]) <= TOL, x0
            assert state.force[2] == 0.0 and np.max(np.abs(state.moment[:2])) < 1e-15
            compared += 1
    assert compared == 68  # x0 = -0.51 ... -1.18
    kinds = [(e.kind, round(e.pose.position[0], 4)) for e in events]
    assert kinds == [("touch", 1.1832), ("tangential", 0.5795), ("snap", -0.5008),
                     ("tip", -0.5795), ("release", -1.1832)]
    for a, b in ((0, 4), (1, 3)):
        assert abs(events[a].pose.position[0] + events[b].pose.position[0]) <= TOL
    # and the shooting agrees with the tracker on both sides of the snap
    for x0 in (-0.3, -0.6):
        state = states[x0]
        contacts, guess, base = _shot_inputs((prism,), state, JIGGLE)
        res = shoot_contacts(STRAIGHT, state.pose, contacts, guess, base_guess=base)
        assert res.success, res.message
        assert _difference(res, state)[0] <= TOL
