import math

import numpy as np
import pytest

from vibrissa_ros.core import (
    Catenary,
    Circle,
    Ellipse,
    FootPose,
    InvalidPoseError,
    Parabola,
    Phase,
    QuasistaticTracker,
    TwoCircles,
    run_scan,
    scan_grid,
)

HALF_PI = math.pi / 2
P0_LOWER = 0.45694658104446363
REF_COLUMNS = ("alpha", "s1", "tip_slope", "f", "fx", "fy", "m0")


def _state_value(state, name):
    if name == "contact_x":
        return state.contact[0]
    if name == "contact_y":
        return state.contact[1]
    if name == "tip_x":
        return state.tip[0]
    if name == "tip_y":
        return state.tip[1]
    return getattr(state, name)


def test_reference_scan_every_row(reference_scan):
    """The independent reference (two methods, ~1e-12) for parabola p0 = 0.3, all columns."""
    rows, _ = reference_scan
    tracker = QuasistaticTracker(Parabola(0.3), rows[0]["x0"])
    worst = 0.0
    checked = 0
    for i, row in enumerate(rows):
        if i and row["x0"] == rows[i - 1]["x0"]:
            continue  # an event: the second row of the pair starts the next segment
        state = tracker.step(row["x0"]).state
        twin = rows[i + 1] if i + 1 < len(rows) and rows[i + 1]["x0"] == row["x0"] else None
        if twin is not None and state.phase != int(row["phase"]):
            row = twin  # exactly at an event: we may already be on the other side
        assert state.phase == int(row["phase"]), row["x0"]
        for name in REF_COLUMNS + ("contact_x", "contact_y", "tip_x", "tip_y"):
            ref = row[name]
            value = (_state_value(state, name)
                     if state.phase or name.startswith("tip")
                     or name in ("f", "fx", "fy", "m0", "tip_slope") else None)
            if math.isnan(ref):
                assert value is None
                continue
            err = abs(value - ref) / max(1.0, abs(ref))
            worst = max(worst, err)
            assert err < 1e-9, (name, row["x0"], value, ref)
        checked += 1
    assert checked > 1300
    assert worst < 1e-9


def test_reference_events(reference_scan):
    rows, ref_events = reference_scan
    result = run_scan(Parabola(0.3), scan_grid(2.0, -2.0, 0.01))
    kinds = [(e.kind, int(e.from_phase), int(e.to_phase)) for e in result.events]
    assert kinds == [("touch", 0, 2), ("phase", 2, 1), ("phase", 1, 2), ("snap", 2, 0)]
    assert [name for name, _, _ in ref_events] == ["first_touch", "tip_to_tangential",
                                                   "tangential_to_tip", "snap_off"]
    for event, (_, x0, alpha) in zip(result.events, ref_events):
        assert event.x0 == pytest.approx(x0, abs=1e-10)
        assert event.alpha == pytest.approx(alpha, abs=1e-9)


def test_phase_one_ends_at_alpha_zero_exactly_for_the_papers_p0_lower():
    result = run_scan(Parabola(P0_LOWER), scan_grid(2.0, -2.0, 0.01))
    ends = [e for e in result.events if e.kind == "phase" and e.from_phase == Phase.TANGENTIAL]
    assert len(ends) == 1
    assert ends[0].alpha == pytest.approx(0.0, abs=1e-9)
    # and alpha1 > 0 (< 0) for p0 above (below) p0_lower (paper §2.1)
    for p0, sign in ((0.44, -1), (0.47, +1)):
        ev = [e for e in run_scan(Parabola(p0), scan_grid(2.0, -2.0, 0.01)).events
              if e.kind == "phase"]
        assert np.sign(ev[-1].alpha) == sign


def test_one_big_step_equals_many_small_steps():
    profile = Catenary(0.5, 0.6)
    small = QuasistaticTracker(profile, 2.0)
    events_small = []
    for x0 in scan_grid(2.0, -0.9, 0.001)[1:]:
        events_small += small.step(float(x0)).events
    big = QuasistaticTracker(profile, 2.0)
    result = big.step(-0.9)
    assert result.state.phase == small.state.phase
    for name in ("alpha", "s1", "tip_slope", "f", "fx", "fy", "m0"):
        assert getattr(result.state, name) == pytest.approx(getattr(small.state, name), abs=1e-12)
    assert [(e.kind, e.from_phase, e.to_phase) for e in result.events] == [
        (e.kind, e.from_phase, e.to_phase) for e in events_small
    ]
    for a, b in zip(result.events, events_small):
        assert a.x0 == pytest.approx(b.x0, abs=1e-11)
    # and across the snap: both end free with the same events
    assert big.step(-2.0).state.phase == Phase.FREE
    assert [e.kind for e in small.step(-2.0).events] == ["snap"]


def test_reversing_the_foot_retraces_the_branch_and_releases_at_first_touch():
    profile = Parabola(0.3)
    forward = {round(s.x0, 9): s for s in run_scan(profile, scan_grid(2.0, -0.5, 0.05)).states}
    tracker = QuasistaticTracker(profile, 2.0)
    tracker.step(-0.5)
    events = []
    for x0 in scan_grid(-0.5, 2.0, 0.05)[1:]:
        res = tracker.step(float(x0))
        events += res.events
        ref = forward[round(float(x0), 9)]
        assert res.state.phase == ref.phase
        assert res.state.m0 == pytest.approx(ref.m0, abs=1e-11)
        assert res.state.f == pytest.approx(ref.f, abs=1e-11)
    assert [(e.kind, e.to_phase) for e in events] == [("phase", Phase.TIP),
                                                      ("release", Phase.FREE)]
    release = events[-1]
    touch_x = Parabola(0.3).xi(Parabola(0.3).alpha_at_height(1.0, +1))
    assert release.x0 == pytest.approx(touch_x, abs=1e-10)


def test_back_and_forth_sweep_shows_hysteresis_mirrored_for_a_symmetric_profile():
    profile = Parabola(0.3)
    grid = scan_grid(2.0, -2.0, 0.01, back=True)
    result = run_scan(profile, grid)
    n = len(grid) // 2
    forward, backward = result.states[: n + 1], result.states[n:]
    kinds = [(e.kind, int(e.to_phase)) for e in result.events]
    assert kinds == [("touch", 2), ("phase", 1), ("phase", 2), ("snap", 0)] * 2
    snaps = [e.x0 for e in result.events if e.kind == "snap"]
    assert snaps[0] == pytest.approx(-snaps[1], abs=1e-10)
    fwd = {round(s.x0, 9): s for s in forward}
    loop_area = 0.0
    for st in backward:
        mirror = fwd[round(-st.x0, 9)]
        assert st.phase == mirror.phase
        if st.phase:
            assert st.side == -mirror.side == -1
            assert st.m0 == pytest.approx(-mirror.m0, abs=1e-11)
            assert st.fx == pytest.approx(-mirror.fx, abs=1e-11)
            assert st.alpha == pytest.approx(-mirror.alpha, abs=1e-12)
        loop_area += abs(st.m0 - fwd[round(st.x0, 9)].m0)
    # at x0 = 0 the whisker is bent one way going left and the other way going right
    assert fwd[0.0].m0 < 0 < [s for s in backward if s.x0 == 0.0][0].m0
    assert loop_area > 1.0


PROFILES = [Parabola(0.3), Parabola(0.6), Catenary(0.5, 0.6), TwoCircles(0.4, 0.8, 1.6),
            Circle(0.35, 0.9), Ellipse(0.3, 1.4, 0.9)]


@pytest.mark.parametrize("profile", PROFILES, ids=lambda p: p.describe())
def test_invariants_on_every_state_of_a_sweep(profile):
    result = run_scan(profile, scan_grid(2.5, -2.5, 0.02, back=True))
    tracker = QuasistaticTracker(profile, 2.5)
    contact_states = [s for s in result.states if s.phase]
    assert len(contact_states) > 40
    for st in result.states:
        values = [st.tip_slope, st.f, st.fx, st.fy, st.m0, *st.tip]
        assert all(math.isfinite(v) for v in values)
        line = st.centerline(201)
        assert np.all(np.isfinite(line))
        assert line[-1] == pytest.approx(st.tip, abs=1e-12)
        assert line[0] == pytest.approx((st.x0, 0.0), abs=1e-14)
        if not st.phase:
            continue
        # moment balance: kappa(0) is the moment of the contact force about the foot
        rx, ry = st.contact[0] - st.x0, st.contact[1]
        assert st.m0 == pytest.approx(rx * st.fy - ry * st.fx, abs=1e-11 * max(1.0, st.f))
        # force along the obstacle's outward normal, with magnitude f
        assert math.hypot(st.fx, st.fy) == pytest.approx(st.f, rel=1e-14)
        # WH1: bent one way only, with the sign the equations assume
        assert st.side * st.m0 < 0
        # no point of the whisker inside the obstacle
        for x, y in line:
            assert tracker._gap(x, y) > -1e-12
        # the contact point is on the profile and on the whisker
        s1_index = int(round(st.s1 * 200))
        assert math.dist(line[s1_index], st.contact) < 2e-2
        if st.phase == Phase.TIP:
            assert st.s1 == 1.0
            assert st.tip == pytest.approx(st.contact, abs=1e-12)
            # phi1 >= alpha in the contact frame (paper (17)); mirrored when bent counter-clockwise
            delta = st.tip_slope - st.alpha if st.side > 0 else math.pi - st.tip_slope + st.alpha
            assert delta >= -1e-12
        else:
            assert 0 < st.s1 < 1
            # the free part lies along the profile's tangent (direction alpha, or alpha + pi)
            assert math.remainder(st.tip_slope - st.alpha, math.pi) == pytest.approx(0.0,
                                                                                     abs=1e-15)


def _move(pose, g):
    x, y, theta = g
    c, s = math.cos(theta), math.sin(theta)
    return FootPose(x + c * pose.x - s * pose.y, y + s * pose.x + c * pose.y, pose.heading + theta)


def test_rigid_motion_of_the_whole_set_up_changes_nothing_but_the_frame():
    g = (0.7, -0.2, 0.35)
    base = TwoCircles(0.4, 0.8, 1.6)
    moved = base.placed(*g)
    plain = QuasistaticTracker(base, 2.0)
    other = QuasistaticTracker(moved, _move(FootPose(2.0), g))
    c, s = math.cos(g[2]), math.sin(g[2])
    for x0 in list(scan_grid(2.0, -2.0, 0.05)) + list(scan_grid(-1.5, 1.0, 0.1)):
        a = plain.step(float(x0))
        b = other.step(_move(FootPose(float(x0)), g))
        assert [e.kind for e in a.events] == [e.kind for e in b.events]
        sa, sb = a.state, b.state
        assert sa.phase == sb.phase
        for name in ("f", "m0", "s1"):
            assert getattr(sb, name) == pytest.approx(getattr(sa, name), abs=1e-10)
        if sa.phase:
            assert sb.alpha == pytest.approx(sa.alpha + g[2], abs=1e-11)
            assert sb.fx == pytest.approx(c * sa.fx - s * sa.fy, abs=1e-10)
            moved_contact = (g[0] + c * sa.contact[0] - s * sa.contact[1], g[1] + s * sa.contact[0]
                             + c * sa.contact[1])
            assert sb.contact == pytest.approx(moved_contact, abs=1e-10)
        assert sb.tip_slope == pytest.approx(sa.tip_slope + g[2], abs=1e-11)


def test_motion_in_y_and_heading_follows_the_same_branch_by_any_path():
    profile = Parabola(0.3)
    direct = QuasistaticTracker(profile, FootPose(1.6, 0.0))
    direct.step(FootPose(0.8, 0.06, HALF_PI + 0.05))
    around = QuasistaticTracker(profile, FootPose(1.6, 0.0))
    for pose in (FootPose(1.6, 0.06), FootPose(1.6, 0.06, HALF_PI + 0.05),
                 FootPose(0.8, 0.06, HALF_PI + 0.05)):
        around.step(pose)
    assert direct.state.phase == around.state.phase == Phase.TIP
    for name in ("alpha", "f", "m0", "tip_slope"):
        assert getattr(direct.state, name) == pytest.approx(getattr(around.state, name), abs=1e-11)


def test_turning_the_whisker_is_turning_the_obstacle_the_other_way():
    profile = Parabola(0.3)
    x0, angle = 1.3, 0.3
    turned = QuasistaticTracker(profile, FootPose(x0))
    res = turned.step(FootPose(x0, 0.0, HALF_PI + angle))
    assert [e.kind for e in res.events] == ["touch"]
    # the obstacle rotated by -angle about the foot, approached by a translation
    c, s = math.cos(-angle), math.sin(-angle)
    obstacle = profile.placed(x0 - c * x0, -s * x0, -angle)
    other = QuasistaticTracker(obstacle, FootPose(x0 + 1.0))
    other.step(FootPose(x0))
    a, b = turned.state, other.state
    assert a.phase == b.phase == Phase.TIP
    for name in ("f", "m0", "s1"):
        assert getattr(a, name) == pytest.approx(getattr(b, name), abs=1e-11)
    assert a.alpha - angle == pytest.approx(b.alpha, abs=1e-12)
    assert a.tip_slope - angle == pytest.approx(b.tip_slope, abs=1e-12)


def test_bad_poses_are_rejected_and_the_state_is_kept():
    with pytest.raises(InvalidPoseError, match="inside the obstacle"):
        QuasistaticTracker(Parabola(0.3), 0.0)
    tracker = QuasistaticTracker(Parabola(0.3), 2.0)
    tracker.step(0.5)
    before = tracker.state
    for bad in (math.nan, math.inf, "x"):
        with pytest.raises((InvalidPoseError, ValueError)):
            tracker.step(bad)
        assert tracker.state is before
    with pytest.raises(InvalidPoseError, match="must be finite"):
        FootPose(0.0, math.inf)


def test_free_state_reports_zero_force_and_no_contact():
    st = QuasistaticTracker(Parabola(0.3), 2.0).state
    assert (st.phase, st.f, st.fx, st.fy, st.m0, st.alpha, st.s1, st.contact) == (0, 0, 0, 0, 0,
                                                                                  None, None, None)
    assert st.tip == pytest.approx((2.0, 1.0))
    assert st.tip_slope == HALF_PI


def test_settling_on_the_other_flank_after_a_snap():
    """
    After a snap, the whisker settles on the other flank.

    No sweep we know folds where a straight whisker would cut the obstacle, so the mechanism that
    would then settle the whisker on the other flank is exercised directly: from x0 = 0 under the
    apex (straight whisker inside), travelling left, it must find the branch that a whisker coming
    back from the left is on.
    """
    from vibrissa_ros.core.exact.tracker import _Path

    profile = Parabola(0.3)
    tracker = QuasistaticTracker(profile, 2.0)
    path = _Path(FootPose(2.0), FootPose(-2.0))
    contact = tracker._approach_from_free(FootPose(0.0), path, side=+1)
    state = tracker._contact_state(FootPose(0.0), contact.phase, contact.side, contact.z)
    coming_back = QuasistaticTracker(profile, -2.0)
    expected = coming_back.step(0.0).state
    assert state.side == expected.side == -1
    assert state.phase == expected.phase
    for name in ("alpha", "f", "m0", "s1", "tip_slope"):
        assert getattr(state, name) == pytest.approx(getattr(expected, name), abs=1e-11)
