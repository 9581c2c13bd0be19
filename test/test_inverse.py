"""The inverse problem: contact points from (foot pose, force, moment) alone."""

import math

import numpy as np
import pytest

from vibrissa_ros.core import (
    Catenary,
    Circle,
    Ellipse,
    FootPose,
    Parabola,
    QuasistaticTracker,
    TwoCircles,
    run_scan,
    scan_grid,
)
from vibrissa_ros.core.exact.inverse import covered_intervals, estimate_contact, reconstruct


def random_profiles(seed, n):
    """Convex profiles nobody tuned on: random families, shapes and small rigid motions."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        p0 = rng.uniform(0.15, 0.8)
        kind = rng.integers(5)
        if kind == 0:
            prof = Parabola(p0, rng.uniform(0.3, 3.0))
        elif kind == 1:
            prof = Catenary(p0, rng.uniform(0.3, 2.0))
        elif kind == 2:
            prof = Circle(p0, rng.uniform(1.05 - p0, 3.0) + 0.05)
        elif kind == 3:
            prof = TwoCircles(p0, rng.uniform(1.05 - p0, 2.5) + 0.05,
                              rng.uniform(1.05 - p0, 2.5) + 0.05)
        else:
            prof = Ellipse(p0, rng.uniform(0.5, 2.5), rng.uniform(1.05 - p0, 2.0) + 0.05)
        out.append(prof.placed(rng.uniform(-0.2, 0.2), 0.0, rng.uniform(-0.15, 0.15)))
    return out


@pytest.mark.parametrize("profile", random_profiles(2024, 12), ids=lambda p: p.describe()[:60])
def test_noise_free_estimates_are_the_true_contact_points(profile):
    result = run_scan(profile, scan_grid(3.0, -3.0, 0.01, back=True))
    checked = 0
    for st in result.states:
        est = estimate_contact(st.pose, st.fx, st.fy, st.m0)
        if not st.phase:
            assert est is None
            continue
        assert est is not None
        assert math.dist(est.contact, st.contact) < 1e-8
        assert est.phase == st.phase and est.side == st.side
        assert est.alpha == pytest.approx(st.alpha, abs=1e-12)
        assert est.s1 == pytest.approx(st.s1, abs=1e-9)
        checked += 1
    assert checked > 50


def test_general_foot_poses_and_both_bending_directions():
    prof = Ellipse(0.3, 1.4, 0.9).placed(0.5, 0.2, 0.25)
    c, s = math.cos(0.25), math.sin(0.25)
    tracker = QuasistaticTracker(prof, FootPose(0.5 + 2.5 * c, 0.2 + 2.5 * s, math.pi / 2 + 0.25))
    errors = []
    for t in list(np.linspace(2.5, -2.5, 101)) + list(np.linspace(-2.5, 2.5, 101)):
        st = tracker.step(FootPose(0.5 + t * c, 0.2 + t * s, math.pi / 2 + 0.25)).state
        if st.phase:
            est = estimate_contact(st.pose, st.fx, st.fy, st.m0)
            errors.append(math.dist(est.contact, st.contact))
    assert len(errors) > 80 and max(errors) < 1e-8


def test_readings_without_a_single_frictionless_contact_give_none():
    pose = FootPose(0.0)
    assert estimate_contact(pose, 0.0, 0.0, 0.0) is None  # free
    assert estimate_contact(pose, 1.0, -1.0, 0.0) is None  # force through the foot
    assert estimate_contact(pose, 0.0, -1.0, -5.0) is None  # moment too large for that force
    assert estimate_contact(pose, 1.0, -1.0, -0.5, min_force=2.0) is None
    assert estimate_contact(pose, float("nan"), -1.0, -0.5) is None


def test_noisy_readings_still_trace_the_profile():
    """
    Noise of sigma = 1% of the scan's peak |f| and |m0|.

    The closing note's numbers come from bench/bench_inverse.py.
    """
    prof = Parabola(0.3)
    result = run_scan(prof, scan_grid(2.0, -2.0, 0.005))
    rng = np.random.default_rng(7)
    f_peak = max(s.f for s in result.states)
    m_peak = max(abs(s.m0) for s in result.states)
    readings = [(s.pose, s.fx + rng.normal(0, 0.01 * f_peak), s.fy + rng.normal(0, 0.01 * f_peak),
                 s.m0 + rng.normal(0, 0.01 * m_peak)) for s in result.states if s.phase]
    estimates = reconstruct(readings, min_force=0.05 * f_peak)
    assert len(estimates) > 0.8 * len(readings)
    gaps = []
    for e in estimates:
        a = prof.alpha_at_x(e.contact[0])
        # distance to the profile, to first order
        gaps.append(abs(e.contact[1] - prof.eta(a)) * math.cos(a))
    assert np.median(gaps) < 0.02
    assert set(int(e.phase) for e in estimates) == {1, 2}


def test_covered_intervals_merge_close_samples():
    assert covered_intervals([0.0, 0.1, 0.2, 1.0, 1.05], 0.15) == [(0.0, 0.2), (1.0, 1.05)]
    assert covered_intervals([], 0.1) == []
