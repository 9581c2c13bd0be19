"""The rigid one-link model (paper §3) against its closed forms, and beside the elastica."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from vibrissa_ros.core import (
    Catenary,
    Parabola,
    Phase,
    QuasistaticTracker,
    TwoCircles,
    run_scan,
    scan_grid,
)
from vibrissa_ros.core.exact.models import RigidModel, make_model

HALF_PI = math.pi / 2
PROFILES = [Parabola(0.3), Parabola(0.6), Catenary(0.5, 0.6), TwoCircles(0.4, 0.8, 1.6)]


@pytest.mark.parametrize("profile", PROFILES, ids=lambda p: p.describe())
def test_rigid_states_satisfy_the_papers_closed_forms(profile):
    result = run_scan(profile, scan_grid(2.5, -2.5, 0.01, back=True), model="rigid")
    tracker = QuasistaticTracker(profile, 2.5, model="rigid")
    checked = 0
    for st in result.states:
        assert all(math.isfinite(v) for v in (st.f, st.fx, st.fy, st.m0, st.tip_slope, *st.tip))
        if not st.phase:
            assert st.f == 0 and st.tip_slope == HALF_PI
            continue
        # contact frame: mirror the left-flank contacts
        a = st.side * st.alpha
        phi = st.tip_slope if st.side > 0 else math.pi - st.tip_slope
        eta = st.contact[1]
        xi_rel = st.side * (st.contact[0] - st.x0)
        # geometry: s1 sin(phi) = eta, s1 cos(phi) = xi - x0 (paper §3)
        assert st.s1 * math.sin(phi) == pytest.approx(eta, abs=1e-12)
        assert st.s1 * math.cos(phi) == pytest.approx(xi_rel, abs=1e-12)
        # m0 = phi - pi/2 (the moment of the contact force about the foot, ccw positive)
        assert st.side * st.m0 == pytest.approx(phi - HALF_PI, abs=1e-13)
        rx, ry = st.contact[0] - st.x0, st.contact[1]
        assert st.m0 == pytest.approx(rx * st.fy - ry * st.fx, rel=1e-11, abs=1e-12)
        if st.phase == Phase.TANGENTIAL:  # mode 1
            assert phi == pytest.approx(a, abs=1e-13)
            assert math.sin(a) > eta
            assert st.f == pytest.approx((HALF_PI - phi) * math.sin(a) / eta, rel=1e-11)
        else:  # mode 2
            assert math.sin(a) < eta + 1e-12
            # tan(phi) = eta / sqrt(1 - eta^2) with phi in (0, pi/2]: checked in its
            # well-conditioned form
            assert math.sin(phi) == pytest.approx(eta, abs=1e-13)
            assert math.cos(phi) == pytest.approx(math.sqrt(1 - eta * eta), abs=1e-12)
            assert phi >= a - 1e-12
            expected = (HALF_PI - phi) / (math.sqrt(1 - eta**2) * math.cos(a) + eta * math.sin(a))
            # f ~ 1/cos(phi - alpha) is ill-conditioned near the fold: both sides agree to ~1e-14
            # in angle
            assert st.f == pytest.approx(expected, rel=1e-14 / math.cos(phi - a) ** 2)
        # the straight rod stays outside the obstacle
        for x, y in st.centerline(101):
            assert tracker._gap(x, y) > -1e-12
        checked += 1
    assert checked > 100


def _roots(g, lo, hi, n=4000):
    xs = np.linspace(lo, hi, n)
    vals = [g(x) for x in xs]
    return [brentq(g, xs[i], xs[i + 1], xtol=1e-15) for i in range(n - 1)
            if vals[i] * vals[i + 1] < 0]


@pytest.mark.parametrize("p0", [0.3, 0.6])
def test_rigid_parabola_scan_events_at_their_closed_form_positions(p0):
    """
    Fig. 3.1: the events of a rigid scan of a parabola where the closed forms put them.

    Touch at eta = 1, mode changes where sin(alpha) = eta(alpha), snap where the rod is orthogonal
    to the profile, cos(alpha) = eta(alpha) on the left flank.
    """
    prof = Parabola(p0)
    a_touch = prof.alpha_at_height(1.0, +1)
    modes = _roots(lambda a: math.sin(a) - prof.eta(a), 0.0, 1.5)
    a_snap = _roots(lambda a: math.cos(a) - prof.eta(a), -1.5, 0.0)[0]
    expected = [("touch", prof.xi(a_touch))]
    for a in sorted(modes, reverse=True):
        expected.append(("phase", prof.xi(a) - math.cos(a)))
    expected.append(("snap", prof.xi(a_snap) + math.sin(a_snap)))
    result = run_scan(prof, scan_grid(2.0, -2.0, 0.01), model="rigid")
    assert [e.kind for e in result.events] == [k for k, _ in expected]
    for event, (_, x0) in zip(result.events, expected):
        assert event.x0 == pytest.approx(x0, abs=1e-10)
    assert [int(e.to_phase) for e in result.events] == ([2, 1, 2, 0] if modes else [2, 0])
    assert (len(modes) == 2) == (p0 == 0.3)


def test_rigid_output_never_reaches_the_singular_point():
    prof = Parabola(0.3)
    snap = [e for e in run_scan(prof, scan_grid(2.0, -2.0, 0.01), model="rigid").events
            if e.kind == "snap"][0]
    tracker = QuasistaticTracker(prof, 2.0, model="rigid")
    for d in (1e-3, 1e-6, 1e-9, 1e-12):
        st = tracker.step(snap.x0 + d).state
        assert st.phase == Phase.TIP and math.isfinite(st.f) and st.f > 0
    big = tracker.state.f
    assert big > 1e4  # f grows like 1/sqrt(distance to the fold)
    result = tracker.step(snap.x0)
    assert [e.kind for e in result.events] == ["snap"]
    assert result.state.phase == Phase.FREE and result.state.f == 0.0


def test_rigid_reversal_releases_where_it_touched_and_big_step_equals_small_steps():
    prof = Catenary(0.5, 0.6)
    small = QuasistaticTracker(prof, 2.0, model="rigid")
    for x0 in scan_grid(2.0, -0.5, 0.002)[1:]:
        small.step(float(x0))
    big = QuasistaticTracker(prof, 2.0, model="rigid")
    big.step(-0.5)
    for name in ("alpha", "f", "m0", "s1", "tip_slope"):
        assert getattr(big.state, name) == pytest.approx(getattr(small.state, name), abs=1e-12)
    back = big.step(2.0)
    assert [e.kind for e in back.events][-1] == "release"
    assert back.events[-1].x0 == pytest.approx(prof.xi(prof.alpha_at_height(1.0, +1)), abs=1e-10)


def test_spring_stiffness_expresses_the_rigid_model_in_elastica_units():
    prof = Parabola(0.3)
    unit = run_scan(prof, scan_grid(1.5, -1.0, 0.1), model="rigid").states
    three = run_scan(prof, scan_grid(1.5, -1.0, 0.1),
                     model=make_model("rigid", stiffness=3.0)).states
    for a, b in zip(unit, three):
        assert b.f == pytest.approx(3 * a.f, rel=1e-14)
        assert b.m0 == pytest.approx(3 * a.m0, rel=1e-14)
        assert b.alpha == a.alpha and b.s1 == a.s1
    with pytest.raises(ValueError, match="stiffness"):
        RigidModel(0.0)


def test_c_equal_3EI_over_L_matches_the_elastica_at_small_deflection():
    prof = Parabola(0.3)
    x_touch = prof.xi(prof.alpha_at_height(1.0, +1))
    for d in (1e-4, 1e-6):
        el = QuasistaticTracker(prof, 2.0)
        rg = QuasistaticTracker(prof, 2.0, model=make_model("rigid", stiffness=3.0))
        a, b = el.step(x_touch - d).state, rg.step(x_touch - d).state
        assert b.f / a.f == pytest.approx(1.0, abs=20 * d)
        assert b.m0 / a.m0 == pytest.approx(1.0, abs=20 * d)
