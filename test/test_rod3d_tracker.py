"""
The 3D whisker's tracker: the planar golden tests run through the 3D solver, and its behaviour.

Planar problems (base in z = 0 turning about z, obstacles that are prisms along z) must give the
planar results to <= 1e-10 wherever the planar state is stable in 3D: the paper's exact scan of
a parabola (test/data/elastica_parabola_p0_0.3.csv, elliptic integrals with mpmath events), the
two-contact golden scenes (test/data/scene_golden.json) and the planar scene tracker's two-peg
sweep. The genuinely 3D comparisons with the shooting solver are in test_rod3d_accuracy.py.
"""

import json
import math
import os

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from vibrissa_ros.core.errors import ConvergenceError, InvalidPoseError, ModelAssumptionError
from vibrissa_ros.core.general.model import WhiskerShape
from vibrissa_ros.core.rod3d import (
    BasePose, Cylinder, Plane, Prism, RodContactMode, RodShape, RodSolver, RodTracker, Scene3D,
    Sphere,
)
from vibrissa_ros.core.rod3d.pose import quat_about
from vibrissa_ros.core.scenes.scene import obstacle_from_dict
from vibrissa_ros.core.scenes.tracker import SceneTracker
from vibrissa_ros.scan.scene_file import load_scene

from rat_pad import SOAK_PEGS, soak_head

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "data")
#: where the paper's parabola scan's planar equilibrium loses stability out of its plane
PARABOLA_BIFURCATION = -0.5007761050


def _golden_rows():
    path = os.path.join(DATA, "elastica_parabola_p0_0.3.csv")
    lines = [ln for ln in open(path) if not ln.startswith("#")]
    header = lines[0].strip().split(",")
    rows = [dict(zip(header, map(float, ln.strip().split(",")))) for ln in lines[1:]]
    events = {}
    for ln in open(path):
        if ln.startswith("# event:"):
            parts = dict(p.split("=") for p in ln.split()[3:])
            events[ln.split()[2]] = float(parts["x0_mp"])
    return rows, events


@pytest.fixture(scope="module")
def parabola_scan():
    rows, events = _golden_rows()
    scene = Scene3D.from_dict({"obstacles": [{"type": "parabola", "p0": 0.3}]})
    tracker = RodTracker(scene, BasePose.from_planar(rows[0]["x0"]))
    states, found, previous = {}, [], None
    for row in rows[1:]:
        x0 = row["x0"]
        if x0 == previous:
            continue
        previous = x0
        result = tracker.step(BasePose.from_planar(x0))
        found += [(e.kind, e.pose.position[0], e.reason) for e in result.events]
        states[x0] = result.state
    return rows, events, states, found


def _row_error(state, row, mirror=1.0):
    c = state.contacts[0]
    return max(abs(state.force[0] - mirror * row["fx"]), abs(state.force[1] - row["fy"]),
               abs(state.moment[2] - mirror * row["m0"]), abs(c.s - row["s1"]),
               abs(c.point[0] - mirror * row["contact_x"]), abs(c.point[1] - row["contact_y"]),
               abs(state.tip[0] - mirror * row["tip_x"]), abs(state.tip[1] - row["tip_y"]),
               abs(state.force[2]), abs(state.moment[0]), abs(state.moment[1]))


def test_the_paper_scan_equals_the_exact_planar_solution_until_it_buckles_out_of_plane(
        parabola_scan):
    rows, events, states, found = parabola_scan
    kinds = [k for k, _, _ in found]
    assert kinds[:3] == ["touch", "tangential", "snap"]
    touch, tangential, snap = (x for _, x, _ in found[:3])
    assert touch == pytest.approx(events["first_touch"], abs=1e-9)
    assert tangential == pytest.approx(events["tip_to_tangential"], abs=1e-9)
    assert snap == pytest.approx(PARABOLA_BIFURCATION, abs=1e-9)
    assert "unstable" in found[2][2]
    # the planar model folds much later: the 3D branch is lost before
    assert snap > events["snap_off"] + 0.9
    twice = {r["x0"] for r, q in zip(rows, rows[1:]) if r["x0"] == q["x0"]}   # event rows
    checked = worst = 0
    for row in rows:
        x0 = row["x0"]
        if x0 <= snap or x0 not in states or x0 in twice:
            continue
        state = states[x0]
        if row["phase"] == 0:
            assert state.contacts == ()
            continue
        worst = max(worst, _row_error(state, row))
        checked += 1
    assert checked > 500
    assert worst < 1e-10


def test_after_buckling_the_whisker_lands_bent_round_the_other_side(parabola_scan):
    """The parabola is symmetric: the state at -a is the mirror image of the one at +a."""
    rows, events, states, found = parabola_scan
    kinds = [k for k, _, _ in found]
    assert kinds[3:] == ["tip", "release"]
    assert found[3][1] == pytest.approx(-events["tip_to_tangential"], abs=1e-9)
    assert found[4][1] == pytest.approx(-events["first_touch"], abs=1e-9)
    by_x = {round(r["x0"], 9): r for r in rows if r["phase"] != 0}
    checked = worst = 0
    for x0, state in states.items():
        if x0 >= PARABOLA_BIFURCATION - 1e-3 or not state.contacts:
            continue
        row = by_x.get(round(-x0, 9))
        if row is None or row["x0"] > events["first_touch"]:
            continue
        if (row["phase"] == 1) != (state.contacts[0].kind == "side"):
            continue   # the two rows at an event
        worst = max(worst, _row_error(state, row, mirror=-1.0))
        checked += 1
    assert checked > 300
    assert worst < 1e-10


@pytest.mark.parametrize("case", range(3))
def test_the_golden_two_contact_scenes_are_reproduced(case):
    golden = json.load(open(os.path.join(DATA, "scene_golden.json")))["cases"][case]
    golden["contacts"].sort(key=lambda c: 1.0 if c["kind"] == "tip" else c["s"])
    shape = RodShape(**golden["shape"])
    obstacles, modes, breaks, forces = [], [], [], []
    for k, c in enumerate(golden["contacts"]):
        feature = c["feature"]
        if feature["type"] == "circle":
            planar = obstacle_from_dict({"type": "peg", "x": feature["cx"], "y": feature["cy"],
                                         "r": feature["r"]}, f"peg{k}")
        else:
            planar = obstacle_from_dict({"type": "curve", "points": feature["points"],
                                         "side": feature["side"]}, f"curve{k}")
        obstacles.append(Prism(planar))
        modes.append(RodContactMode("tip" if c["kind"] == "tip" else "side", k))
        breaks.append(1.0 if c["kind"] == "tip" else c["s"] * (1 - 1e-3))
        forces.append(math.hypot(c["fx"], c["fy"]) * (1 + 1e-3))
    x, y, heading = golden["pose"]["x"], golden["pose"]["y"], golden["pose"]["heading"]
    pose = BasePose.from_planar(x, y, heading)
    # the golden contact forces integrated from the base (x, y, slope) as the starting shape
    # (Newton from the unloaded whisker finds other equilibria of these strongly bent states)
    loads = [(c["s"], c["x"], c["y"], c["fx"], c["fy"]) for c in golden["contacts"]]

    def rhs(s, z):
        m = sum((xc - z[0]) * fy - (yc - z[1]) * fx for sc, xc, yc, fx, fy in loads if sc > s)
        kappa = float(shape.curvature(s)) + m / float(shape.stiffness(s))
        return [math.cos(z[2]), math.sin(z[2]), kappa]

    grid = np.linspace(0.0, 1.0, 2001)
    path = solve_ivp(rhs, (0.0, 1.0), [x, y, heading], t_eval=grid, rtol=1e-10, atol=1e-12,
                     max_step=0.01)
    slopes = path.y[2]

    def quaternions(s):
        half = 0.5 * np.interp(s, grid, slopes)
        return np.column_stack((np.cos(half), 0 * s, 0 * s, np.sin(half)))

    solver = RodSolver(shape, obstacles)
    solved = solver.solve(modes, pose, solver.guess(modes, breaks, forces, quaternions))
    eq = solver.equilibrium(modes, solved.vec, pose)
    base = golden["base"]
    assert eq.force[0] == pytest.approx(base["fx"], abs=1e-9)
    assert eq.force[1] == pytest.approx(base["fy"], abs=1e-9)
    assert eq.moment[2] == pytest.approx(base["m0"], abs=1e-9)
    for c, s, x in zip(golden["contacts"], eq.s, eq.points):
        assert s == pytest.approx(c["s"], abs=1e-9)
        assert x[:2] == pytest.approx((c["x"], c["y"]), abs=1e-9)


@pytest.mark.parametrize("shapes", [(WhiskerShape(), RodShape()),
                                    (WhiskerShape(0.3, -0.5, 0.4), RodShape(0.3, -0.5, 0.4))],
                         ids=["straight", "tapered-curved"])
def test_the_two_peg_sweep_equals_the_planar_scene_tracker(shapes):
    planar_shape, shape = shapes
    scene = load_scene(os.path.join(HERE, "..", "config", "scene_two_pegs.yaml"))
    planar = SceneTracker(list(scene), -0.4, shape=planar_shape, friction=[0.0, 0.0])
    tracker = RodTracker(Scene3D.from_planar(scene, drop_friction=True),
                         BasePose.from_planar(-0.4), shape=shape)
    planar_events, events, worst, two = [], [], 0.0, 0
    for x0 in np.linspace(-0.4, 0.2, 61)[1:]:
        a = planar.step(float(x0))
        b = tracker.step(BasePose.from_planar(float(x0)))
        planar_events += [(e.kind, e.obstacle, e.pose.x) for e in a.events]
        events += [(e.kind, e.obstacle, e.pose.position[0]) for e in b.events]
        sa, sb = a.state, b.state
        assert len(sa.contacts) == len(sb.contacts)
        two += len(sb.contacts) == 2
        worst = max(worst, abs(sb.force[0] - sa.fx), abs(sb.force[1] - sa.fy),
                    abs(sb.moment[2] - sa.m0), abs(sb.force[2]), abs(sb.moment[0]),
                    abs(sb.moment[1]))
        for ca, cb in zip(sa.contacts, sb.contacts):
            worst = max(worst, abs(ca.s - cb.s), abs(ca.x - cb.point[0]),
                        abs(ca.y - cb.point[1]))
    assert two >= 3
    assert worst < 1e-10
    assert [(k, o) for k, o, _ in events] == [(k, o) for k, o, _ in planar_events]
    for (_, _, x), (_, _, y) in zip(events, planar_events):
        assert x == pytest.approx(y, abs=1e-9)


# -- behaviour ----------------------------------------------------------------------------------

def _sphere_tracker(**kw):
    return RodTracker([Sphere((0.6, 0.3, 0.05), 0.15, "ball")], BasePose((0, 0, 0)), **kw)


def test_a_base_inside_an_obstacle_or_a_cutting_whisker_is_refused_with_the_obstacle():
    with pytest.raises(InvalidPoseError, match="ball"):
        RodTracker([Sphere((0.0, 0.0, 0.0), 0.1, "ball")], BasePose((0, 0, 0)))
    with pytest.raises(InvalidPoseError, match="ball"):
        RodTracker([Sphere((0.5, 0.0, 0.0), 0.1, "ball")], BasePose((0, 0, 0)))


def test_a_rolled_whisker_sweeping_a_sphere_touches_presses_and_releases():
    shape = RodShape(taper=0.4, parabola=0.5)
    ball = Sphere((0.55, 0.35, 0.1), 0.12, "ball")
    q0 = np.array([math.cos(0.3), math.sin(0.3), 0.0, 0.0])      # rolled 0.6 rad
    tracker = RodTracker([ball], BasePose((0.0, -0.3, 0.0), tuple(q0)), shape=shape)
    kinds = []
    for y in np.linspace(-0.3, 0.6, 91)[1:]:
        result = tracker.step(BasePose((0.0, float(y), 0.0), tuple(q0)))
        kinds += [e.kind for e in result.events]
        state = result.state
        for c in state.contacts:
            assert c.f >= -1e-12
            assert ball.signed_distance(np.array([c.point]))[0] == pytest.approx(0.0, abs=1e-12)
        assert np.all(ball.signed_distance(state.centerline(201)) > -1e-9)
    assert kinds[0] == "touch"
    assert "release" in kinds or "snap" in kinds


def test_an_edge_contact_is_refused_and_a_free_whisker_recovers():
    polygon = obstacle_from_dict({"type": "polygon", "vertices": [[0.2, 0.5], [0.6, 0.5],
                                                                  [0.6, 0.9]]}, "wedge")
    scene = [Prism(polygon)]
    tracker = RodTracker(scene, BasePose.from_planar(0.2 - 0.3, 0.0, math.pi / 2),
                         recover=False)
    before = tracker.state
    with pytest.raises(ModelAssumptionError, match="edge"):
        tracker.step(BasePose.from_planar(0.3, 0.0, math.pi / 2))
    assert tracker.state is before


def test_a_failed_step_keeps_the_state_and_reset_places_the_whisker():
    tracker = _sphere_tracker(recover=False)
    tracker.step(BasePose((0.0, 0.15, 0.0)))
    kept = tracker.state
    with pytest.raises(InvalidPoseError):
        tracker.step("not a pose")
    assert tracker.state is kept
    result = tracker.reset(BasePose((0.0, -0.5, 0.0)))
    assert [e.kind for e in result.events] == ["reset"]
    assert result.state.contacts == ()


def test_a_free_whisker_forgets_its_history():
    tracker = _sphere_tracker()
    for y in np.linspace(0, 0.3, 31):
        tracker.step(BasePose((0.0, float(y), 0.02)))
    tracker.step(BasePose((0.0, -0.6, 0.0)))
    fresh = RodTracker(tracker.obstacles, BasePose((0.0, -0.6, 0.0)))
    for y in np.linspace(-0.6, 0.3, 19):
        a = tracker.step(BasePose((0.0, float(y), 0.0))).state
        b = fresh.step(BasePose((0.0, float(y), 0.0))).state
        assert a == b


def test_planes_and_cylinders_hold_a_tip_and_a_side_contact():
    floor = Plane((0.0, 0.0, -0.3), (0.0, 0.0, 1.0), "floor")
    pole = Cylinder((0.5, 0.0, 0.0), (0.0, 1.0, 0.3), 0.05, "pole")
    pitch = 0.35   # whisker tilted toward the floor (a turn about +y takes +x toward -z)
    q = np.array([math.cos(0.5 * pitch), 0.0, math.sin(0.5 * pitch), 0.0])
    tracker = RodTracker([floor, pole], BasePose((-0.2, 0.0, 0.1), tuple(q)))
    for z in np.linspace(0.1, -0.1, 41)[1:]:
        result = tracker.step(BasePose((-0.2, 0.0, float(z)), tuple(q)))
        for c in result.state.contacts:
            assert c.f >= -1e-12
    names = {c.name for c in tracker.state.contacts}
    assert "floor" in names


@pytest.mark.parametrize("shape", [RodShape(), RodShape(taper=0.3, k0=0.8, k1=-0.4),
                                   RodShape(taper=1 / 15, parabola=0.34),
                                   RodShape(parabola=-1.5)])
def test_the_touch_search_newton_minimum_equals_the_brent_search(shape):
    # the free whisker's distance minimized over s near its nearest sample: Newton on
    # d'(s) = n . t (RodTracker._refine with the whisker's geometry) against a bounded Brent
    # search in s, for every kind of obstacle, the minimum inside the samples or at the tip
    obstacles = [Sphere((0.6, 0.25, 0.1), 0.2), Cylinder((0.5, 0.0, 0.0), (0.3, 0.2, 1.0), 0.15),
                 Plane((0.0, 0.0, -0.2), (0.2, 0.1, 1.0)),
                 Prism(obstacle_from_dict({"type": "peg", "x": 0.7, "y": 0.3, "r": 0.1}, "peg"))]
    tracker = RodTracker((), BasePose((0.0, 0.0, 0.0)), shape=shape)
    rng = np.random.default_rng(3)
    compared = 0
    for ob in obstacles:
        tracker.obstacles = (ob,)
        for _ in range(12):
            axis = rng.normal(size=3)
            q = quat_about(axis / np.linalg.norm(axis), rng.uniform(-0.6, 0.6))
            pose = BasePose(tuple(rng.uniform(-0.2, 0.2, 3)), tuple(q))
            pts = pose.p + tracker._free_points @ pose.rotation.T
            d = ob.signed_distance(pts)
            j = int(np.argmin(d))
            samples = np.linspace(0.0, 1.0, pts.shape[0])
            newton = tracker._refine(ob, lambda s: tracker._free_point(pose, s), j, float(d[j]),
                                     samples, lambda s: tracker._free_geometry(pose, s))
            brent = tracker._refine(ob, lambda s: tracker._free_point(pose, s), j, float(d[j]),
                                    samples)
            assert newton[0] <= brent[0] + 1e-15
            assert abs(newton[0] - brent[0]) <= 1e-14 and abs(newton[1] - brent[1]) <= 1e-6
            compared += 1
    assert compared == 48


def test_a_pose_given_with_the_other_quaternion_sign_is_the_same_pose():
    # q and -q are the same rotation: a stream that flips the sign (a rotation matrix's
    # quaternion taken with w >= 0 as w crosses 0) must not change the whisker's state
    shape = RodShape(taper=0.4, parabola=0.5)
    ball = Sphere((0.55, 0.35, 0.1), 0.12, "ball")
    q0 = np.array([math.cos(0.3), math.sin(0.3), 0.0, 0.0])
    plain = RodTracker([ball], BasePose((0.0, -0.3, 0.0), tuple(q0)), shape=shape)
    flipping = RodTracker([ball], BasePose((0.0, -0.3, 0.0), tuple(q0)), shape=shape)
    in_contact = 0
    for k, y in enumerate(np.linspace(-0.3, 0.3, 41)[1:]):
        pose = BasePose((0.0, float(y), 0.0), tuple(q0))
        given = BasePose(pose.position, tuple(-q0)) if k % 3 else pose
        a, b = plain.step(pose), flipping.step(given)
        assert [e.kind for e in b.events] == [e.kind for e in a.events]
        a = a.state
        assert b.state.pose == given and flipping.pose == given
        assert np.allclose(a.force, b.state.force, rtol=0, atol=1e-12)
        assert np.allclose(a.moment, b.state.moment, rtol=0, atol=1e-12)
        assert np.allclose(a.tip, b.state.tip, rtol=0, atol=1e-12)
        assert np.allclose(a.centerline(21), b.state.centerline(21), rtol=0, atol=1e-12)
        in_contact += bool(a.contacts)
    assert in_contact >= 10


def test_a_pose_along_a_path_is_slerp_and_linear_interpolation():
    # BasePose.at computes in floats what slerp (the same routine) and (1 - t) p_a + t p_b
    # compute: the position to the last bit, the orientation as numpy's slerp formula does to
    # rounding (the norm's dot may round otherwise in another numpy)
    from vibrissa_ros.core.rod3d.pose import quat_conjugate, quat_multiply, slerp

    def numpy_slerp(qa, qb, t):
        rel = quat_multiply(quat_conjugate(qa), qb)
        rel = -rel if rel[0] < 0.0 else rel
        sin_half = float(np.linalg.norm(rel[1:]))
        if sin_half == 0.0:
            return qa
        half = math.atan2(sin_half, float(rel[0]))
        return quat_multiply(qa, np.concatenate(
            ([math.cos(t * half)], math.sin(t * half) * rel[1:] / sin_half)))

    rng = np.random.default_rng(11)
    for i in range(2000):
        qa = rng.normal(size=4)
        qb = qa + rng.normal(size=4) * 10.0 ** rng.uniform(-9.0, 0.5)
        if i % 3 == 0:
            qb = -qb  # the other sign: the shorter arc
        a = BasePose(tuple(rng.normal(size=3)), tuple(qa / np.linalg.norm(qa)))
        b = BasePose(tuple(rng.normal(size=3)), tuple(qb / np.linalg.norm(qb)))
        if i % 17 == 0:
            b = BasePose(b.position, a.quaternion)  # no turn
        t = float(rng.choice([rng.uniform(), 0.5, 1e-10, 1.0 - 1e-10]))
        got = a.at(b, t)
        assert got.position == tuple((1.0 - t) * a.p + t * b.p)
        assert got.quaternion == BasePose((0, 0, 0), tuple(slerp(a.q, b.q, t))).quaternion
        want = BasePose((0, 0, 0), tuple(numpy_slerp(a.q, b.q, t))).quaternion
        if np.lib.NumpyVersion(np.__version__) >= "2.0.0":
            assert got.quaternion == want  # (the bits the tracker's states were checked on)
        else:
            assert np.max(np.abs(np.subtract(got.quaternion, want))) <= 4.5e-16


# -- event location: the rules found by the array soaks (doc/mechanics/rod3d.md, "Snaps") --------

def _pressed_sphere_tracker():
    """Return a whisker pressing a ball in one side contact, and a short path on from there."""
    from vibrissa_ros.core.rod3d.tracker import _Path

    tracker = _sphere_tracker()
    for y in np.linspace(0.0, 0.2, 41)[1:]:
        tracker.step(BasePose((0.0, float(y), 0.0)))
    assert len(tracker.state.contacts) == 1
    path = _Path(tracker.pose, BasePose((0.0, 0.205, 0.0)))
    return tracker, path


@pytest.mark.parametrize("value, expected", [
    # negative by rounding at the start, positive just after: the zero further on
    (lambda tau: -3e-16 + 1e-3 * tau * (0.25 - tau), 0.25),
    # negative by rounding at the start and still negative after: crossed at the start
    (lambda tau: -3e-16 - 1e-3 * tau, 0.0),
    # clearly negative at the start (beyond -1e-12): crossed there, not probed
    (lambda tau: -1e-9 + 1e-3 * tau * (0.25 - tau), 0.0),
])
def test_an_event_value_zero_by_construction_is_judged_just_after_the_start(
        monkeypatch, value, expected):
    tracker, path = _pressed_sphere_tracker()
    monkeypatch.setattr(RodTracker, "_event_values",
                        lambda self, path, tau, vec, lu: {("release", 0): value(tau)})
    changes = []
    monkeypatch.setattr(RodTracker, "_change",
                        lambda self, path, t, key, events: changes.append((t, key)) or t)
    t = tracker._first_event(path, 0.0, 0.5, [("release", 0)], [])
    assert changes == [(t, ("release", 0))]
    assert t == pytest.approx(expected, abs=1e-10)


def test_a_probe_that_cannot_be_solved_leaves_the_event_at_the_start(monkeypatch):
    tracker, path = _pressed_sphere_tracker()
    monkeypatch.setattr(RodTracker, "_event_values",
                        lambda self, path, tau, vec, lu: {("release", 0): -3e-16 + tau})
    real = RodTracker._solve_at

    def solve_at(self, path, t, t_new, solved, exact=True):
        if t_new != 0.5:
            raise ConvergenceError("not followed")
        return real(self, path, t, t_new, solved, exact)

    monkeypatch.setattr(RodTracker, "_solve_at", solve_at)
    changes = []
    monkeypatch.setattr(RodTracker, "_change",
                        lambda self, path, t, key, events: changes.append((t, key)) or t)
    assert tracker._first_event(path, 0.0, 0.5, [("release", 0)], []) == 0.0


def test_a_solve_within_a_sub_step_that_lands_on_another_branch_is_not_taken(monkeypatch):
    # an event is located from solves within the sub-step; one that Newton carries to another
    # branch is judged as a trial step is (_off_branch), and is a ConvergenceError
    tracker, path = _pressed_sphere_tracker()
    solved = tracker._solved
    on = tracker._solve_at(path, 0.0, 0.5, solved)
    change = float(np.max(np.abs(on.vec - solved.vec)))  # (the force: 0.034)
    assert 0.0 < change < 0.1
    real = RodSolver.solve

    def far(self, modes, pose, guess, *args, **kwargs):
        found = real(self, modes, pose, guess, *args, **kwargs)
        return type(found)(found.vec + 4.0 * change, found.lu, found.sens)

    monkeypatch.setattr(RodSolver, "solve", far)
    with pytest.raises(ConvergenceError, match="another branch"):
        tracker._solve_at(path, 0.0, 0.5, solved)


@pytest.mark.parametrize("recover", [False, True])
def test_a_base_driven_into_or_through_an_obstacle_is_reported_as_such(recover):
    # such a step fails on its budget (~1 s); the failure then names the base's path as its
    # cause: inside at the target an InvalidPoseError, through on the way a ModelAssumptionError
    q = (math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4))  # the whisker along +y
    # a base ending inside one obstacle is invalid, whatever the path crossed before it
    two = Scene3D((Cylinder((0.0, -0.3, 0.0), (0, 0, 1), 0.05, "A"),
                   Cylinder((0.0, -0.6, 0.0), (0, 0, 1), 0.05, "B")))
    with pytest.raises(InvalidPoseError, match="base inside B"):
        RodTracker(two, BasePose((0.0, 0.0, 0.0), q), recover=recover).step(
            BasePose((0.0, -0.6, 0.0), q))
    scene = Scene3D((Cylinder((0.0, 0.4, 0.0), (0, 0, 1), 0.1, "peg"),))
    tracker = RodTracker(scene, BasePose((0.3, 0.2, 0.0), q), recover=recover)
    tracker.step(BasePose((0.1, 0.2, 0.0), q))
    before = tracker.state
    with pytest.raises(InvalidPoseError, match="base inside peg"):
        tracker.step(BasePose((0.0, 0.4, 0.0), q))
    assert tracker.state is before
    through = BasePose((-0.3, 0.7, 0.0), q)
    if not recover:
        with pytest.raises(ModelAssumptionError, match="passes through peg"):
            tracker.step(through)
        assert tracker.state is before
        return
    result = tracker.step(through)  # re-placed unloaded at the target, where it is clear
    assert [e.kind for e in result.events] == ["reset"]
    assert "base's path" in result.events[0].reason


def test_an_event_never_located_shortens_the_sub_step_until_the_step_fails(monkeypatch):
    """Rule 4 is bounded: each retry quarters the sub-step; below 1e-12 the step fails."""
    from vibrissa_ros.core.rod3d import tracker as rod_tracker

    tracker, _ = _pressed_sphere_tracker()
    before = tracker.state
    trials = []

    def never(self, path, t_a, t_b, crossed, events):
        trials.append(t_b - t_a)
        raise rod_tracker._Unlocated("an event between two sub-steps could not be located")

    monkeypatch.setattr(RodTracker, "_first_event", never)
    monkeypatch.setattr(RodTracker, "_event_values",
                        lambda self, path, tau, vec, lu: {("release", 0): -1.0})
    # (the general path: the compiled plain step judges its solution by the kernel's values)
    monkeypatch.setattr(RodTracker, "_plain_step", lambda self, path, events: None)
    with pytest.raises(ConvergenceError, match="could not be located"):
        tracker.step(BasePose((0.0, 0.205, 0.0)))
    assert tracker.state == before
    assert len(trials) < 30 and trials[-1] < 4e-12
    assert all(b <= 0.25 * a * (1 + 1e-12) for a, b in zip(trials, trials[1:]))


def test_a_tip_change_and_its_reverse_apart_on_the_path_are_not_a_slip(monkeypatch):
    """Rule 3 fires only for the reverse change of the same contact within 1e-9 of the path."""
    from vibrissa_ros.core.rod3d.tracker import _SLIPS

    tracker, path = _pressed_sphere_tracker()
    snaps = []
    monkeypatch.setattr(RodTracker, "_snap",
                        lambda self, path, t, events, reason: snaps.append((t, reason)) or t)
    monkeypatch.setattr(RodTracker, "_set_configuration", lambda self, *a: None)
    tracker._change(path, 0.1, ("tip", 0), [])
    tracker._change(path, 0.1 + 1e-6, ("tangential", 0), [])      # apart: two changes
    assert snaps == []
    tracker._change(path, 0.1 + 1e-6 + 1e-10, ("tip", 0), [])     # at once: a slip
    assert snaps == [(0.1 + 1e-6 + 1e-10, _SLIPS)]


def _pressed_on_a_ball():
    shape = RodShape(taper=0.4, parabola=0.5)
    ball = Sphere((0.55, 0.35, 0.1), 0.12, "ball")
    q0 = (math.cos(0.3), math.sin(0.3), 0.0, 0.0)
    tracker = RodTracker([ball], BasePose((0.0, -0.3, 0.0), q0), shape=shape)
    for y in np.linspace(-0.3, 0.2, 51)[1:]:
        tracker.step(BasePose((0.0, float(y), 0.0), q0))
    assert [c.kind for c in tracker.state.contacts] == ["side"]
    return tracker.solver, tracker._modes, tracker._vec, tracker._pose


@pytest.mark.parametrize("offset,factorizations", [(3e-6, 1), (1e-3, 2)])
def test_newton_closes_with_chord_steps_on_its_fresh_jacobian_once_within_1e_4(
        offset, factorizations):
    # a Newton step shorter than 1e-4 is followed by chord steps on its own Jacobian, not by
    # another factorization; from farther off Newton needs one step more first
    solver, modes, vec, pose = _pressed_on_a_ball()
    direction = np.random.default_rng(3).uniform(-1.0, 1.0, vec.size)
    guess = vec + offset * direction / np.max(np.abs(direction))
    before = solver.factorizations
    solved = solver.solve(modes, pose, guess)
    assert solver.factorizations - before == factorizations
    assert np.max(np.abs(solved.vec - vec)) < 1e-12
    assert np.max(np.abs(solver.residual(modes, solved.vec, pose, jacobian=False)[0])) < 1e-13


def _curled_at_a_wall():
    # a whisker curved towards +y, its tip 0.02 L below a wall it is pushed against
    shape = RodShape(taper=0.2, parabola=0.8)
    tip = shape.free_centerline(np.array([1.0]))[0]
    wall = Plane((0.0, tip[1] + 0.02, 0.0), (0.0, -1.0, 0.0), "wall")
    return RodTracker([wall], BasePose((0.0, 0.0, 0.0)), shape=shape, recover=False), wall


def _push(tracker, wall, ys):
    events = []
    for y in ys:
        result = tracker.step(BasePose((0.0, float(y), 0.0)))
        events += [(e.kind, e.s, e.reason) for e in result.events]
        for c in result.state.contacts:
            assert c.f >= -1e-12
        assert np.min(wall.signed_distance(result.state.centerline(401))) > -1e-9
    return events


@pytest.mark.parametrize("name, start, before, snap, check", [
    # a sub-step's Newton, taken in full, wandered for ten iterations and converged on the
    # equilibrium past the fold: a sub-step's solve now gives up once Newton stops contracting
    # (without the branch check, which would also catch it)
    ("RA2", 3645, {3652: ["touch"]}, 3655, False),
    # a sub-step's Newton converged at once on the equilibrium past the fold, 2.8 times as far
    # from the tangent's prediction as the prediction went: such a trial step now fails
    ("RE2", 1775, {1776: ["touch"]}, 1781, True),
    # in the soak, a compiled plain step from the stream's prediction converged past the fold (a
    # check against the stream's prediction instead of the tangent's let it through); replayed
    # from a free start, without that history, the step is the general path's, whose branch
    # check catches it (the plain step's is tested in test_rod3d_trusted_step.py)
    ("RE2", 4858, {4859: ["touch"], 4860: ["tangential"]}, 4862, True),
])
def test_a_trial_step_that_newton_carries_across_a_fold_reports_the_snap(
        monkeypatch, name, start, before, snap, check):
    # bench/soak_array.py's pegs at 9.5 Hz: the whisker, free at tick ``start``, touches a peg
    # (the events ``before``), and at ``snap`` its branch folds. Its tip jumps (0.08 to 0.11 L
    # in one step); before, it did so with no event. The sub-steps now close in on the fold,
    # and the snap is reported. Each replay starts where the whisker is free: no history.
    from vibrissa_ros.core.arrays import WhiskerArray
    from vibrissa_ros.core.arrays.rat import rat_array
    from vibrissa_ros.core.arrays.tracker import ArrayTracker
    from vibrissa_ros.core.arrays.whisking import CosineWhisk
    from vibrissa_ros.core.rod3d import tracker as tracker_module

    if not check:
        # (no trial step is ever judged off its branch, in the general path or the plain step)
        monkeypatch.setattr(tracker_module, "_OFF_BRANCH", math.inf)
    head, scene = soak_head, SOAK_PEGS
    whisk = CosineWhisk(9.5, math.radians(-30.0), math.radians(25.0))
    array = WhiskerArray((rat_array("right")[name],), name)
    array_tracker = ArrayTracker(array, scene, head(start * 1e-3), whisk.angle(start * 1e-3))
    rod = array_tracker.tracker(name)
    assert not rod.state.contacts
    events, jumps = {}, {}
    for k in range(start + 1, snap + 1):
        pose = array_tracker.whisker_poses(head(k * 1e-3), whisk.angle(k * 1e-3))[0]
        tip = np.array(rod.state.tip)
        result = rod.step(pose)
        events[k] = [(e.kind, e.reason) for e in result.events]
        jumps[k] = float(np.linalg.norm(np.array(result.state.tip) - tip))
    assert {k: [kind for kind, _ in v] for k, v in events.items() if v} == {
        **before, snap: ["snap"]}
    assert events[snap][0][1].startswith("the equilibrium branch folds")
    assert jumps[snap] > 0.05


def test_a_whisker_curved_into_a_wall_lays_its_side_on_it_behind_its_pressed_tip():
    # the tip touches first; before it turns tangent the whisker touches the wall a second
    # time 0.006 L behind it (a regular touch, at zero force); pulled back, that contact is
    # released where it was made
    tracker, wall = _curled_at_a_wall()
    ys = np.linspace(0.0, 0.3, 301)[1:]
    events = _push(tracker, wall, ys)
    assert [(k, s == 1.0) for k, s, _ in events] == [("touch", True), ("touch", False)]
    s_touch = events[1][1]
    assert 0.99 < s_touch < 0.999
    kinds = [(c.kind, c.name) for c in tracker.state.contacts]
    assert kinds == [("side", "wall"), ("tip", "wall")]
    back = _push(tracker, wall, ys[::-1][1:])
    assert [k for k, _, _ in back] == ["release", "release"]
    assert back[0][1] == pytest.approx(s_touch, abs=1e-6)


def test_where_that_touch_is_missed_the_tip_turning_tangent_slips_and_lands_on_both(
        monkeypatch):
    # the fallback: a tip contact turning tangent where the unloaded whisker curves into the
    # surface can go on neither at the tip nor along the side; the snap lands with a side
    # contact behind the tip, on the branch the touch leads to
    tracker, wall = _curled_at_a_wall()
    ys = np.linspace(0.0, 0.3, 301)[1:]
    _push(tracker, wall, ys)
    expected = tracker.state
    monkeypatch.setattr(RodTracker, "_gap_behind_tip",
                        lambda self, *args: (math.inf, -1, 0.0))
    tracker, wall = _curled_at_a_wall()
    events = _push(tracker, wall, ys)
    assert [k for k, _, _ in events] == ["touch", "snap"]
    assert "turns tangent to wall" in events[1][2]
    assert events[1][2].endswith("it lands with its side and its tip on wall")
    state = tracker.state
    assert [c.kind for c in state.contacts] == ["side", "tip"]
    for a, b in zip(state.contacts, expected.contacts):
        assert a.s == pytest.approx(b.s, abs=1e-9)
        assert a.f == pytest.approx(b.f, abs=1e-9)


def test_a_sag_between_two_contacts_on_one_obstacle_is_refused_with_the_state_kept():
    # pressed on, the whisker between its side and tip contacts sags into the wall (it would
    # lie on it along a segment): refused, not returned cutting the wall
    tracker, wall = _curled_at_a_wall()
    _push(tracker, wall, np.linspace(0.0, 0.3, 301)[1:])
    kept = None
    with pytest.raises(ModelAssumptionError, match="between its two contacts on one obstacle"):
        for y in np.linspace(0.3, 0.5, 201)[1:]:
            kept = tracker.state
            tracker.step(BasePose((0.0, float(y), 0.0)))
    assert tracker.state is kept


def test_a_whisker_cutting_an_obstacle_it_touches_away_from_its_contact_is_refused():
    # the tip contact's equilibrium continued past the touch behind the tip: the whisker lies
    # inside the wall there, a state the tracker refuses (it does not return it)
    tracker, wall = _curled_at_a_wall()
    _push(tracker, wall, np.linspace(0.0, 0.23, 231)[1:])
    assert [c.kind for c in tracker.state.contacts] == ["tip"]
    solver, modes = tracker.solver, tracker._modes
    pose = BasePose((0.0, 0.25, 0.0))
    vec = tracker._vec
    for y in np.linspace(0.23, 0.25, 5)[1:]:
        vec = solver.solve(modes, BasePose((0.0, float(y), 0.0)), vec).vec
    assert np.min(wall.signed_distance(solver.centerline(modes, vec, pose, np.linspace(0, 1, 81)))
                  ) < -1e-6
    with pytest.raises(ModelAssumptionError, match="would cut wall away from its contact on it"):
        tracker._check_between(modes, vec, pose)


@pytest.mark.parametrize("radius,kinds", [(4.0, ["touch", "touch"]), (10.0, ["touch", "touch"]),
                                          (2.0, ["touch", "tangential"])])
def test_on_a_ball_the_touch_behind_the_tip_depends_on_its_curvature(radius, kinds):
    # the whisker's curvature at its tip (~0.36 / L) against the ball's (1 / radius): a flatter
    # ball is touched a second time behind the pressed tip, a rounder one lets the tip contact
    # turn tangent and slide on as a side contact
    shape = RodShape(taper=0.2, parabola=0.8)
    tip = shape.free_centerline(np.array([1.0]))[0]
    ball = Sphere((tip[0], tip[1] + 0.02 + radius, 0.0), radius, "ball")
    tracker = RodTracker([ball], BasePose((0.0, 0.0, 0.0)), shape=shape, recover=False)
    events = _push(tracker, ball, np.linspace(0.0, 0.3, 301)[1:])
    assert [k for k, _, _ in events] == kinds
    assert events[0][1] == 1.0
    if kinds[1] == "touch":
        assert 0.99 < events[1][1] < 1.0
        assert [c.kind for c in tracker.state.contacts] == ["side", "tip"]
    else:
        assert [c.kind for c in tracker.state.contacts] == ["side"]


@pytest.mark.parametrize("compiled", [True, False])
def test_a_state_is_a_value_its_arrays_cannot_be_written(compiled, monkeypatch):
    # the equilibrium's arrays are shared with the solver's record of its last answer, which
    # the tracker's next checks read: writing into one would change the tracking, so none can
    from vibrissa_ros.core.rod3d import _jit

    monkeypatch.setattr(_jit, "ENABLED", compiled and _jit.ENABLED)
    shape = RodShape(taper=0.2, parabola=0.8)
    mid = shape.free_centerline(np.array([0.6]))[0]
    ball = Sphere((mid[0], mid[1] + 0.16, 0.0), 0.1, "ball")
    tracker = RodTracker([ball], BasePose((0.0, 0.0, 0.0)), shape=shape)
    states = [tracker.state]
    for y in np.linspace(0.0, 0.1, 21)[1:]:
        states.append(tracker.step(BasePose((0.0, float(y), 0.0))).state)
    assert states[-1].contacts and not states[0].contacts
    for state in (states[0], states[-1]):
        eq = state.equilibrium
        for name in ("vec", "points", "forces", "force", "moment", "tip", "tip_frame"):
            arr = getattr(eq, name)
            with pytest.raises(ValueError, match="read-only"):
                arr[...] = 0.0
