import math

import mpmath as mp
import numpy as np
import pytest
from scipy.special import ellipkinc

from vibrissa_ros.core import tip_loaded_elastica
from vibrissa_ros.core.exact.elastica import amplitude, family, family_centerline
from vibrissa_ros.core.checks.shooting import integrate

HALF_PI = math.pi / 2
P0_LOWER = 0.45694658104446363  # 4 Gamma(3/4)^2 / Gamma(1/4)^2


def test_p0_lower_closed_form():
    mp.mp.dps = 30
    closed = 4 * mp.gamma(0.75) ** 2 / mp.gamma(0.25) ** 2
    assert float(closed) == pytest.approx(P0_LOWER, abs=1e-17)
    # phase 1 at alpha = 0 with s1 = 1 (paper eq. 13): p0 = (2E - K)/K at m = 1/2
    fam = family(0.0, HALF_PI)
    assert fam.N / fam.S == pytest.approx(P0_LOWER, abs=5e-16)
    # the paper prints 0.4569465811 (last digit off by one)
    assert round(fam.N / fam.S, 10) == 0.4569465810


def test_complete_integral_of_the_papers_modulus():
    # K(1/sqrt 2) = 1.8540746773 is sqrt(f) s1 of phase 1 at alpha = 0 (paper eq. 7)
    assert family(0.0, HALF_PI).S == pytest.approx(1.8540746773, abs=5e-11)


@pytest.mark.parametrize(
    "load, w, u, rotation",
    [(1, 0.30172, 0.05643, 0.46135), (2, 0.49346, 0.16064, None), (5, 0.71379, 0.38763, None),
     (10, 0.81061, 0.55500, None)],
)
def test_cantilever_under_perpendicular_tip_load(load, w, u, rotation):
    """Bisshopp & Drucker (1945), Mattiasson (1981): 5 published digits."""
    r = tip_loaded_elastica(load)
    assert r.deflection == pytest.approx(w, abs=5e-6)
    assert r.shortening == pytest.approx(u, abs=5e-6)
    if rotation is not None:
        assert HALF_PI - r.tip_slope == pytest.approx(rotation, abs=5e-6)
    # moment of the tip force about the clamp
    assert r.m0 == pytest.approx(-load * r.tip_y, rel=1e-12)


@pytest.mark.parametrize("load, alpha", [(1.0, HALF_PI), (7.0, 1.0), (3.0, 2.4), (0.01, 0.3)])
def test_tip_loaded_elastica_against_direct_integration(load, alpha):
    r = tip_loaded_elastica(load, alpha)
    x, y, phi, kappa = integrate(0.0, r.m0, load, alpha, 1.0)
    assert (x, y, phi) == pytest.approx((r.tip_x, r.tip_y, r.tip_slope), abs=1e-11)
    assert kappa == pytest.approx(0.0, abs=1e-11)


POINTS = [(0.3, 0.4), (-0.2, 0.9), (0.8, 0.05), (1.0, HALF_PI - 1.0), (0.5, 1e-6), (-0.6, 1.5),
          (0.0, HALF_PI)]


@pytest.mark.parametrize("alpha, gamma", POINTS)
def test_family_partial_derivatives_match_finite_differences(alpha, gamma):
    fam = family(alpha, gamma)
    h = 1e-6 * min(1.0, gamma)
    plus_a, minus_a = family(alpha + h, gamma), family(alpha - h, gamma)
    plus_g, minus_g = family(alpha, gamma + h), family(alpha, gamma - h)
    scale = max(abs(v) for v in fam[3:])
    for name in ("A", "N", "S"):
        fd_a = (getattr(plus_a, name) - getattr(minus_a, name)) / (2 * h)
        fd_g = (getattr(plus_g, name) - getattr(minus_g, name)) / (2 * h)
        assert getattr(fam, name + "_a") == pytest.approx(fd_a, abs=1e-7 * scale)
        assert getattr(fam, name + "_g") == pytest.approx(fd_g, abs=1e-7 * scale)


@pytest.mark.parametrize("alpha, gamma",
                         [(0.3, 0.4), (-0.2, 0.9), (0.8, 0.05), (1.0, HALF_PI - 1.0), (-0.6, 1.5)])
def test_family_against_the_papers_integrals_in_high_precision(alpha, gamma):
    """Paper eqs. (19)-(23) evaluated independently with mpmath (30 digits, tanh-sinh)."""
    mp.mp.dps = 30
    a = mp.mpf(alpha)
    phi1 = mp.pi / 2 - mp.mpf(gamma)
    k = mp.sin(mp.pi / 4 - (phi1 - a) / 2)
    m = k * k
    psi0 = mp.asin(mp.sin(a / 2) / k)
    sqrt_f = mp.ellipk(m) - mp.ellipf(psi0, m)  # eq. (21)
    f = sqrt_f**2

    def weight(t):  # 1/|kappa|, eq. (18)
        return 1 / mp.sqrt(2 * f * (mp.sin(t - a) - mp.sin(phi1 - a)))

    x = mp.quad(lambda t: mp.cos(t) * weight(t), [phi1, mp.pi / 2])  # eq. (23)
    y = mp.quad(lambda t: mp.sin(t) * weight(t), [phi1, mp.pi / 2])
    fam = family(alpha, gamma)
    ca, sa = math.cos(alpha), math.sin(alpha)
    assert fam.S == pytest.approx(float(sqrt_f), rel=1e-14)
    assert (fam.A * ca - fam.N * sa) / fam.S == pytest.approx(float(x), abs=1e-14)
    assert (fam.A * sa + fam.N * ca) / fam.S == pytest.approx(float(y), abs=1e-14)
    m0 = -mp.sqrt(2 * f) * mp.sqrt(mp.cos(a) - mp.sin(phi1 - a))  # paper, below eq. (23)
    assert -fam.A * fam.S == pytest.approx(float(m0), rel=1e-13)


@pytest.mark.parametrize("alpha, gamma", [(0.3, 0.4), (-0.3, 0.9), (0.7, HALF_PI - 0.7)])
def test_centerline_is_a_unit_speed_curve_ending_at_the_load_point(alpha, gamma):
    fam = family(alpha, gamma)
    sqrt_f = fam.S
    s = np.linspace(0.0, 1.0, 4001)
    pts = family_centerline(alpha, gamma, sqrt_f, s)
    assert pts[0] == pytest.approx([0.0, 0.0], abs=1e-15)
    ca, sa = math.cos(alpha), math.sin(alpha)
    load = ((fam.A * ca - fam.N * sa) / sqrt_f, (fam.A * sa + fam.N * ca) / sqrt_f)
    assert pts[-1] == pytest.approx(load, abs=1e-14)
    seg = np.hypot(*np.diff(pts, axis=0).T)
    assert seg.sum() == pytest.approx(1.0, abs=1e-7)  # chord sum of a unit-length curve
    slope0 = math.atan2(*(pts[1] - pts[0])[::-1])
    assert slope0 == pytest.approx(HALF_PI, abs=1e-3)


def test_amplitude_inverts_the_incomplete_integral_exactly():
    for m in (0.1, 0.5, 0.93):
        u = np.linspace(-2.0, 3.5, 23)
        assert np.max(np.abs(ellipkinc(amplitude(u, m), m) - u)) < 5e-15
