import math

import numpy as np
import pytest

from vibrissa_ros.core import (
    Catenary,
    Circle,
    Ellipse,
    Parabola,
    ParameterError,
    PlacedProfile,
    TwoCircles,
    make_profile,
)

PROFILES = [
    Parabola(0.3),
    Parabola(0.6, k=2.5),
    Catenary(0.5, 0.6),
    Circle(0.3, 1.2),
    TwoCircles(0.4, 0.8, 1.6),
    Ellipse(0.2, 1.5, 0.9),
]
ALPHAS = np.linspace(-1.3, 1.3, 26)  # avoids alpha = 0, where two_circles' curvature jumps


@pytest.mark.parametrize("profile", PROFILES, ids=lambda p: p.describe())
def test_apex_and_slope_parametrization(profile):
    assert profile.xi(0.0) == pytest.approx(0.0, abs=1e-15)
    assert profile.eta(0.0) == pytest.approx(profile.params["p0"], abs=1e-15)
    for a in ALPHAS:
        h = 1e-6
        dx = (profile.xi(a + h) - profile.xi(a - h)) / (2 * h)
        dy = (profile.eta(a + h) - profile.eta(a - h)) / (2 * h)
        # the tangent has slope alpha, and its length is the radius of curvature (> 0: convex)
        assert math.atan2(dy, dx) == pytest.approx(a, abs=1e-8)
        assert profile.radius_of_curvature(a) > 0
        assert math.hypot(dx, dy) == pytest.approx(profile.radius_of_curvature(a), rel=1e-7)
        assert profile.dxi(a) == pytest.approx(dx, rel=1e-7, abs=1e-9)
        assert profile.deta(a) == pytest.approx(dy, rel=1e-7, abs=1e-9)


@pytest.mark.parametrize("profile", PROFILES, ids=lambda p: p.describe())
def test_inverse_lookups(profile):
    for a in ALPHAS:
        assert profile.alpha_at_x(profile.xi(a)) == pytest.approx(a, abs=1e-12)
    for side in (+1, -1):
        a = profile.alpha_at_height(1.0, side)
        assert profile.eta(a) == pytest.approx(1.0, abs=1e-13)
        assert np.sign(a) == side


def test_vectorized_evaluation_matches_scalar():
    p = Catenary(0.5, 0.6)
    xs = p.xi(ALPHAS)
    assert xs.shape == ALPHAS.shape
    assert xs[3] == p.xi(float(ALPHAS[3]))


def test_two_circles_use_their_own_radius_on_each_side():
    p = TwoCircles(0.4, 0.8, 1.6)
    assert p.radius_of_curvature(-0.1) == 0.8
    assert p.radius_of_curvature(0.1) == 1.6
    assert p.point(-0.5) == pytest.approx((0.8 * math.sin(-0.5), 0.4 + 0.8 * (1 - math.cos(0.5))))


def test_ellipse_with_equal_axes_is_the_circle():
    e, c = Ellipse(0.3, 1.2, 1.2), Circle(0.3, 1.2)
    for a in ALPHAS:
        assert e.point(a) == pytest.approx(c.point(a), abs=1e-14)
        assert e.radius_of_curvature(a) == pytest.approx(1.2, rel=1e-14)


def test_placement_is_a_rigid_motion():
    base = Parabola(0.3)
    theta = 0.4
    placed = base.placed(0.5, -0.2, theta)
    assert isinstance(placed, PlacedProfile)
    c, s = math.cos(theta), math.sin(theta)
    for a in ALPHAS:
        x, y = base.point(a)
        assert placed.point(a + theta) == pytest.approx(
            (0.5 + c * x - s * y, -0.2 + s * x + c * y), rel=1e-14, abs=1e-14)
        assert placed.radius_of_curvature(a + theta) == pytest.approx(base.radius_of_curvature(a))
    twice = placed.placed(0.1, 0.3, -0.1)
    once = base.placed(*_compose((0.5, -0.2, theta), (0.1, 0.3, -0.1)))
    for a in (-0.5, 0.0, 0.7):
        assert twice.point(a) == pytest.approx(once.point(a), abs=1e-14)
    assert base.placed() is base


def _compose(first, second):
    x1, y1, t1 = first
    x2, y2, t2 = second
    c, s = math.cos(t2), math.sin(t2)
    return x2 + c * x1 - s * y1, y2 + s * x1 + c * y1, t1 + t2


@pytest.mark.parametrize(
    "name, params, words",
    [
        ("parabola", {"p0": 1.2}, ["p0", "1.2", "(0, 1)"]),
        ("parabola", {"p0": 0.0}, ["p0", "(0, 1)"]),
        ("parabola", {"p0": 0.3, "k": -1.0}, ["k", "-1.0", "> 0"]),
        ("catenary", {"p0": 0.3, "c": 0.0}, ["c", "> 0"]),
        ("circle", {"p0": 0.3, "R": 0.5}, ["p0 + R", "height 1"]),
        ("two_circles", {"p0": 0.3, "R_left": 2.0, "R_right": 0.6}, ["p0 + R_right", "height 1"]),
        ("ellipse", {"p0": 0.3, "a": 1.0, "b": 0.5}, ["p0 + b", "height 1"]),
        ("ellipse", {"p0": 0.3, "a": float("nan"), "b": 1.5}, ["a", "nan"]),
        ("parabola", {"p0": 0.3, "R": 1.0}, ["unknown parameter", "R", "allowed: p0, k"]),
        ("circle", {"p0": 0.3}, ["R", "required"]),
        ("cone", {"p0": 0.3}, ["unknown profile", "parabola"]),
    ],
)
def test_bad_parameters_say_what_is_wrong_and_what_is_allowed(name, params, words):
    with pytest.raises(ParameterError) as info:
        make_profile(name, params)
    for word in words:
        assert word in str(info.value)


def test_make_profile_defaults_to_the_papers_unit_parabola():
    assert make_profile("parabola", {"p0": 0.3}) == Parabola(0.3, 1.0)
