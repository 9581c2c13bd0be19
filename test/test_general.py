"""
The general (tapered, intrinsically curved) whisker.

The collocation solver against the closed forms, its Jacobians, and its convergence.
"""

import math

import numpy as np
import pytest

from vibrissa_ros.core import (
    Catenary,
    Circle,
    Ellipse,
    FootPose,
    Parabola,
    Peg,
    Phase,
    QuasistaticTracker,
    TwoCircles,
    run_scan,
    scan_grid,
)
from vibrissa_ros.core.checks.general_shooting import shoot_state
from vibrissa_ros.core.errors import InvalidPoseError, ModelAssumptionError, ParameterError
from vibrissa_ros.core.scan import run_poses
from vibrissa_ros.core.general.model import (
    GeneralWhiskerModel,
    WhiskerShape,
    free_centerline,
)
from vibrissa_ros.core.exact.models import ElasticaModel

FIELDS = ("alpha", "s1", "tip_slope", "f", "fx", "fy", "m0")

CONVEX = [
    Parabola(0.3),
    Parabola(0.6),
    Catenary(0.5, 0.6),
    Circle(0.4, 0.9),
    TwoCircles(0.4, 0.8, 1.5),
    Ellipse(0.3, 1.2, 0.9),
]


def _rel(a, b):
    return abs(a - b) / max(1.0, abs(a))


def assert_scans_agree(exact, numeric, tol=1e-9):
    worst = 0.0
    assert len(exact.states) == len(numeric.states)
    for a, b in zip(exact.states, numeric.states):
        assert a.phase == b.phase, a.x0
        assert a.side == b.side, a.x0
        for name in FIELDS:
            va, vb = getattr(a, name), getattr(b, name)
            if va is None:
                assert vb is None
                continue
            worst = max(worst, _rel(va, vb))
        for pa, pb in ((a.contact, b.contact), (a.tip, b.tip)):
            if pa is None:
                assert pb is None
                continue
            worst = max(worst, _rel(pa[0], pb[0]), _rel(pa[1], pb[1]))
    assert worst <= tol, worst
    assert [(e.kind, e.from_phase, e.to_phase) for e in exact.events] == [
        (e.kind, e.from_phase, e.to_phase) for e in numeric.events
    ]
    for ea, eb in zip(exact.events, numeric.events):
        assert abs(ea.x0 - eb.x0) <= tol, (ea.kind, ea.x0, eb.x0)
    return worst


@pytest.mark.parametrize("profile", CONVEX, ids=lambda p: p.describe())
def test_numeric_equals_closed_forms_on_full_scans(profile):
    """Every field of every state and every event of a back-and-forth scan, to 1e-9."""
    grid = scan_grid(2.5, -2.5, 0.02, back=True)
    exact = run_scan(profile, grid)
    numeric = run_scan(profile, grid, model=GeneralWhiskerModel())
    assert len(exact.events) >= 4
    assert_scans_agree(exact, numeric)


@pytest.mark.parametrize(
    "phase, z_exact",
    [(Phase.TIP, (0.3, 0.2)), (Phase.TIP, (0.8, 0.5)), (Phase.TIP, (0.2, 1.2)),
     (Phase.TANGENTIAL, (0.3, 0.5)), (Phase.TANGENTIAL, (1.2, 0.9)),
     (Phase.TANGENTIAL, (0.1, 0.3))],
)
def test_collocation_reproduces_the_elliptic_family(phase, z_exact):
    em, gm = ElasticaModel(), GeneralWhiskerModel()
    f, m0, s1, phi1, offset = em.contact_quantities(phase, z_exact)
    P = em.load_point(phase, z_exact)[:2]
    z = (z_exact[0], s1 if phase == Phase.TANGENTIAL else z_exact[1])
    Q = gm.load_point(phase, z)[:2]
    g = gm.contact_quantities(phase, z)
    for a, b in [(P[0], Q[0]), (P[1], Q[1]), (f, g[0]), (m0, g[1]), (s1, g[2]), (phi1, g[3]),
                 (offset[0], g[4][0]), (offset[1], g[4][1])]:
        assert abs(a - b) < 1e-12


@pytest.mark.parametrize("shape", [WhiskerShape(1 / 15, 1.0, -0.5), WhiskerShape(0.3, -2.0, 1.0)])
@pytest.mark.parametrize("phase, z", [(Phase.TIP, (1.0, 0.5)), (Phase.TANGENTIAL, (1.4, 0.7))])
def test_jacobian_matches_finite_differences(shape, phase, z):
    gm = GeneralWhiskerModel(shape)
    J = np.array(gm.load_point(phase, z)[2:]).reshape(2, 2)
    h = 1e-6
    fd = np.empty((2, 2))
    for j in range(2):
        zp, zm = list(z), list(z)
        zp[j] += h
        zm[j] -= h
        fd[:, j] = (np.array(gm.load_point(phase, zp)[:2])
                    - np.array(gm.load_point(phase, zm)[:2])) / (2 * h)
    assert np.allclose(J, fd, atol=1e-7)


def test_spectral_convergence_for_a_rat_like_taper():
    """Error vs collocation points decays exponentially (taper 1/15, curved, tip contact)."""
    shape = WhiskerShape(1 / 15, 1.0, -0.5)
    ref = np.array(GeneralWhiskerModel(shape, n=96).load_point(Phase.TIP, (1.0, 0.5))[:2])
    errors = []
    for n in (8, 12, 16, 24):
        p = np.array(GeneralWhiskerModel(shape, n=n).load_point(Phase.TIP, (1.0, 0.5))[:2])
        errors.append(np.max(np.abs(p - ref)))
    assert errors[-1] < 1e-11
    assert all(b < a for a, b in zip(errors, errors[1:]))


def test_mirrored_side_model_flips_the_curvature():
    gm = GeneralWhiskerModel(WhiskerShape(0.5, 1.0, 0.5))
    assert gm.for_side(1) is gm
    mirror = gm.for_side(-1)
    assert (mirror.shape.k0, mirror.shape.k1) == (-1.0, -0.5)
    assert mirror.for_side(-1) is gm


@pytest.mark.parametrize(
    "kwargs", [dict(taper=0.0), dict(taper=1.5), dict(taper=math.nan), dict(k0=30.0),
               dict(k1=math.inf)]
)
def test_bad_whisker_shape_is_a_parameter_error(kwargs):
    with pytest.raises(ParameterError):
        WhiskerShape(**kwargs)


def test_centerline_of_a_general_state_ends_at_the_contact():
    tracker = QuasistaticTracker(Parabola(0.3), 2.0,
                                 model=GeneralWhiskerModel(WhiskerShape(0.5, 0.0, 0.0)))
    state = tracker.step(0.0).state
    assert state.phase != Phase.FREE
    pts = state.centerline(201)
    assert np.allclose(pts[0], (0.0, 0.0), atol=1e-14)
    assert np.allclose(pts[-1], state.tip, atol=1e-12)
    seg = np.hypot(*np.diff(pts, axis=0).T)
    assert abs(seg.sum() - 1.0) < 1e-4  # inextensible


# -- pegs -------------------------------------------------------------------------------------


@pytest.mark.parametrize("p0, R", [(0.4, 0.9), (0.3, 1.5)])
def test_a_peg_reaching_past_the_whisker_is_the_circle_profile(p0, R):
    grid = scan_grid(2.5, -2.5, 0.02, back=True)
    exact = run_scan(Circle(p0, R), grid)
    numeric = run_scan(Peg(0.0, p0 + R, R), grid, model=GeneralWhiskerModel())
    assert_scans_agree(exact, numeric)


def _scan_peg(model, peg, grid):
    return run_scan(peg, grid, model=model)


def test_tapered_curved_whisker_touches_a_peg_side_first_and_slips_off():
    model = GeneralWhiskerModel(WhiskerShape(1 / 15, 1.0, 0.0))
    peg = Peg(0.0, 0.6, 0.05)
    scan = _scan_peg(model, peg, scan_grid(1.0, -1.0, 0.01, back=True))
    kinds = [(e.kind, e.from_phase, e.to_phase) for e in scan.events]
    assert kinds[0] == ("touch", Phase.FREE, Phase.TANGENTIAL)
    assert ("snap", Phase.TANGENTIAL, Phase.FREE) in kinds
    for state in scan.states:
        if state.phase == Phase.FREE:
            continue
        assert 0.0 <= state.f
        assert state.s1 < 1.0
        # the whole centerline stays outside the peg (it touches at the contact)
        pts = state.centerline(401)
        assert np.min(np.hypot(pts[:, 0] - peg.x, pts[:, 1] - peg.y)) >= peg.r - 1e-9
        # the contact point lies on the peg and the whisker passes through it
        assert abs(math.hypot(state.contact[0] - peg.x, state.contact[1] - peg.y) - peg.r) < 1e-12
        # moment balance: m0 = r x f about the foot
        rx, ry = state.contact[0] - state.pose.x, state.contact[1] - state.pose.y
        assert abs(state.m0 - (rx * state.fy - ry * state.fx)) < 1e-10


def test_side_touch_starts_at_zero_force_and_release_returns_there():
    model = GeneralWhiskerModel(WhiskerShape(0.5, -0.5, 0.0))
    peg = Peg(0.0, 0.5, 0.1)
    tracker = QuasistaticTracker(peg, FootPose(-1.0, 0.0), model=model)
    touch = [e for e in tracker.step(FootPose(0.1, 0.0)).events if e.kind == "touch"]
    assert len(touch) == 1 and touch[0].to_phase == Phase.TANGENTIAL
    back = tracker.step(FootPose(-1.0, 0.0))
    release = [e for e in back.events if e.kind == "release"]
    assert len(release) == 1
    assert abs(release[0].x0 - touch[0].x0) < 1e-10
    assert back.state.phase == Phase.FREE


def test_a_point_peg_lets_the_tip_slip_off():
    model = GeneralWhiskerModel(WhiskerShape(0.3, 0.0, 0.0))
    scan = run_scan(Peg(0.0, 0.9, 0.0), scan_grid(0.5, -0.5, 0.01), model=model)
    kinds = [(e.kind, e.from_phase, e.to_phase) for e in scan.events]
    assert kinds[0] == ("touch", Phase.FREE, Phase.TANGENTIAL)
    assert kinds[1][0] == "snap" and kinds[1][1] == Phase.TANGENTIAL
    assert all(s.phase != Phase.TIP for s in scan.states)


def test_closed_forms_refuse_a_side_first_touch():
    tracker = QuasistaticTracker(Peg(0.0, 0.5, 0.1), FootPose(-1.0, 0.0))
    with pytest.raises(ModelAssumptionError, match="side"):
        tracker.step(FootPose(0.0, 0.0))
    assert tracker.state.phase == Phase.FREE


@pytest.mark.parametrize("shape", [WhiskerShape(1 / 15, 1.0, 0.5), WhiskerShape(0.3, -0.8, 0.3),
                                   WhiskerShape(0.5, 2.5, -1.0)])
def test_free_point_agrees_with_the_free_centerline(shape):
    # the Chebyshev series (a touch search's single points) against Gauss-Legendre quadrature
    model = GeneralWhiskerModel(shape)
    s = np.linspace(0.0, 1.0, 1001)
    points = np.array([model.free_point(float(u)) for u in s])
    assert np.max(np.abs(points - free_centerline(shape, s))) < 1e-14
    x, y, slope = model.free_tip()
    assert (x, y) == pytest.approx(tuple(free_centerline(shape, [1.0])[0]), abs=1e-14)
    assert slope == pytest.approx(shape.k0 + 0.5 * shape.k1, abs=1e-15)


@pytest.mark.parametrize("shape", [WhiskerShape(), WhiskerShape(1 / 15, 1.0, 0.5),
                                   WhiskerShape(0.5, 2.5, -1.0)])
@pytest.mark.parametrize("r", [0.0, 0.05])
def test_peg_clearance_bound_is_a_tight_lower_bound(shape, r):
    # the coarse clearance that lets a free step skip the exact one: never above the gap
    # (else a touch could be stepped over), and within a few 1e-4 of it
    rng = np.random.default_rng(7)
    dense = free_centerline(shape, np.linspace(0.0, 1.0, 200001))
    tracker = QuasistaticTracker(Peg(0.0, 0.6, r), FootPose(2.0, 0.0),
                                 model=GeneralWhiskerModel(shape))
    tight = 0
    for _ in range(300):
        pose = FootPose(*rng.uniform(-0.6, 0.6, 2), math.pi / 2 + rng.uniform(-1.0, 1.0))
        beta = pose.heading - math.pi / 2
        c, sn = math.cos(beta), math.sin(beta)
        wx = pose.x + c * dense[:, 0] - sn * dense[:, 1]
        wy = pose.y + sn * dense[:, 0] + c * dense[:, 1]
        gap = float(np.min(np.hypot(wx, wy - 0.6))) - r
        bound, s = tracker._peg_clearance_bound(pose.x, pose.y, c, sn)
        assert bound <= gap + 1e-12
        assert gap - bound < 1e-3
        tight += gap - bound < 1e-9 if shape.k0 == shape.k1 == 0.0 else 1
        assert 0.0 <= s <= 1.0
    assert tight == 300  # a straight whisker's chords are the whisker: the bound is the gap


@pytest.mark.parametrize("steps", [1, 1000])
def test_a_free_whisker_whisked_in_small_steps_touches_a_peg_where_one_step_does(steps):
    # free steps near the peg are certified by the coarse bound: none may step over the touch
    shape = WhiskerShape(1 / 15, 1.0, 0.5)
    peg = Peg(0.0, 0.6, 0.05)
    start = FootPose(0.3, 0.0, math.pi / 2 + 0.6)
    probe = QuasistaticTracker(peg, start, model=GeneralWhiskerModel(shape))
    touch = [e for e in probe.step(FootPose(0.3, 0.0, math.pi / 2 - 0.6)).events
             if e.kind == "touch"][0]
    h0 = touch.pose.heading + 0.02
    tracker = QuasistaticTracker(peg, start, model=GeneralWhiskerModel(shape))
    tracker.step(FootPose(0.3, 0.0, h0))
    found = []
    for i in range(steps):
        result = tracker.step(FootPose(0.3, 0.0, h0 - 0.021 * (i + 1) / steps))
        found += [e for e in result.events if e.kind == "touch"]
        if not found:
            assert result.state.phase == Phase.FREE
    assert len(found) == 1
    assert found[0].pose.heading == pytest.approx(touch.pose.heading, abs=1e-12)


@pytest.mark.parametrize("recover", [False, True])
def test_a_foot_driven_into_or_through_a_peg_is_refused_at_once(recover):
    # (such a step once crept for ~45 s: the contact pressed by the foot slides toward the
    # foot, s1 -> 0, and the continuation's sub-steps shrink with it, 20,000 of them)
    from vibrissa_ros.core import TrackerOptions

    peg = Peg(0.0, 0.5, 0.1)
    tracker = QuasistaticTracker(peg, FootPose(0.3, 0.2), model=GeneralWhiskerModel(
        WhiskerShape(0.5, 0.3, 0.0)), options=TrackerOptions(recover=recover))
    tracker.step(FootPose(0.1, 0.2))
    before = tracker.state
    assert before.phase == Phase.TANGENTIAL
    with pytest.raises(InvalidPoseError, match="foot inside the obstacle"):
        tracker.step(FootPose(0.0, 0.45))
    assert tracker.state is before
    through = FootPose(-0.3, 0.8)
    if not recover:
        with pytest.raises(ModelAssumptionError, match="passes through the obstacle"):
            tracker.step(through)
        assert tracker.state is before
        return
    result = tracker.step(through)  # re-placed unloaded at the target, where it is clear
    assert [e.kind for e in result.events] == ["reset"]
    assert "passes through the obstacle" in result.events[0].reason
    assert result.evaluations < 1000


def test_peg_parameters():
    with pytest.raises(ParameterError):
        Peg(0.0, 1.0, -0.1)
    with pytest.raises(ParameterError):
        Peg(math.nan, 1.0, 0.1)
    moved = Peg(1.0, 2.0, 0.5).placed(1.0, 0.0, math.pi / 2)
    assert (moved.x, moved.y, moved.r) == pytest.approx((-1.0, 1.0, 0.5), abs=1e-15)


# -- second, independent method: shooting (DOP853) on the 4th-order system --------------------


def _assert_shooting_agrees(shape, peg, scan, every=1):
    checked = 0
    phases = set()
    for state in scan.states[::every]:
        if state.phase == Phase.FREE:
            continue
        shot = shoot_state(shape, peg, state)
        assert abs(shot.f - state.f) <= 1e-9 * max(1.0, state.f)
        assert abs(shot.m0 - state.m0) <= 1e-9 * max(1.0, abs(state.m0))
        assert abs(shot.alpha - state.alpha) <= 1e-9
        assert abs(shot.s1 - state.s1) <= 1e-9
        checked += 1
        phases.add(state.phase)
    return checked, phases


def test_shooting_agrees_on_a_tapered_curved_whisker_translating_past_a_peg():
    shape = WhiskerShape(1 / 15, 1.0, 0.5)
    peg = Peg(0.0, 0.6, 0.05)
    scan = run_scan(peg, scan_grid(1.0, -1.0, 0.05, back=True), model=GeneralWhiskerModel(shape))
    checked, _ = _assert_shooting_agrees(shape, peg, scan, every=2)
    assert checked >= 5


def test_shooting_agrees_on_a_whisking_whisker_in_tip_and_side_contact():
    shape = WhiskerShape(0.3, -0.8, 0.3)
    peg = Peg(0.15, 0.97, 0.1)
    poses = [FootPose(0.0, 0.0, math.pi / 2 + 0.3 - 0.02 * i) for i in range(40)]
    scan = run_poses(peg, poses, model=GeneralWhiskerModel(shape))
    kinds = [(e.kind, e.to_phase) for e in scan.events]
    assert kinds[:2] == [("touch", Phase.TIP), ("phase", Phase.TANGENTIAL)]
    checked, phases = _assert_shooting_agrees(shape, peg, scan)
    assert checked >= 4 and phases == {Phase.TIP, Phase.TANGENTIAL}


# -- published mechanics ------------------------------------------------------------------------
def _rotate_against_point(shape, d, push):
    """Turn a whisker's foot clockwise (whisking) against a point peg at radial distance d."""
    tracker = QuasistaticTracker(Peg(0.0, d, 0.0), FootPose(0.0, 0.0, math.pi / 2 + 0.05),
                                 model=GeneralWhiskerModel(shape))
    before = tracker.step(FootPose(0.0, 0.0, math.pi / 2)).events  # the touch is at pi/2
    result = tracker.step(FootPose(0.0, 0.0, math.pi / 2 - push))
    return [e for e in before + result.events if e.kind == "touch"], result


@pytest.mark.parametrize("taper", [1.0, 1 / 15, 0.3])
@pytest.mark.parametrize("d", [0.3, 0.6, 0.9])
def test_small_angle_rotational_stiffness_matches_linear_theory(taper, d):
    """
    Solomon & Hartmann 2006: dM/dtheta -> 3 EI / d (cylinder).

    A cone gives d^2 / int_0^d (d - s)^2 / B(s) ds (units EI_b).
    """
    shape = WhiskerShape(taper)
    dtheta = 1e-5
    touch, result = _rotate_against_point(shape, d, dtheta)
    assert len(touch) == 1 and abs(touch[0].pose.heading - math.pi / 2) < 1e-12
    stiffness = abs(result.state.m0) / dtheta
    expected = d * d / shape.linear_compliance(d)
    if taper == 1.0:
        assert expected == pytest.approx(3.0 / d, rel=1e-14)
    assert stiffness == pytest.approx(expected, rel=1e-8)


@pytest.mark.parametrize("d", [0.3, 0.5, 0.7])
def test_tapered_whiskers_slip_off_a_pole_cylindrical_ones_do_not(d):
    """
    Hires et al. 2013: pushed against a pole, a conical whisker slips off at a critical angle.

    A cylindrical one does not within plausible angles (here: 60 degrees).
    """
    push = math.radians(60.0)
    _, cone = _rotate_against_point(WhiskerShape(1 / 15), d, push)
    snaps = [e for e in cone.events if e.kind == "snap"]
    assert len(snaps) == 1 and snaps[0].from_phase == Phase.TANGENTIAL
    assert math.pi / 2 - snaps[0].pose.heading < push
    _, cylinder = _rotate_against_point(WhiskerShape(1.0), d, push)
    assert not [e for e in cylinder.events if e.kind == "snap"]
    assert cylinder.state.phase == Phase.TANGENTIAL


def test_a_point_peg_released_on_the_way_back_is_not_touched_again():
    # the release leaves the point exactly on the straight whisker: the touch search must take
    # the side the motion leaves it on (it once re-touched from the other side, pulling)
    from vibrissa_ros.core.profiles import Peg
    from vibrissa_ros.core.scan import run_scan, scan_grid

    result = run_scan(Peg(0.3, 0.6, 0.0), scan_grid(1.0, 0.2, 0.02, back=True),
                      model=GeneralWhiskerModel(WhiskerShape()))
    assert [e.kind for e in result.events] == ["touch", "release"]
    assert result.states[-1].phase == 0 and result.states[-1].m0 == 0.0
    assert all(s.m0 <= 1e-12 for s in result.states)  # the point only ever pushes
