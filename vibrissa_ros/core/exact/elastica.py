"""
Closed forms of the elastica clamped at the foot and loaded by one force (paper §2).

Frame ("contact frame"): foot at the origin, slope phi(0) = pi/2 (the undeformed rod along +y),
the rod bent clockwise (kappa <= 0, the paper's WH1). A force of magnitude f acts at arc length s1
in the direction of the obstacle's outward normal (sin alpha, -cos alpha); no moment acts there
(kappa(s1) = 0). Units: length L, force EI/L^2, moment EI/L.

With theta = phi - alpha and delta = theta(s1), the first integral (paper eq. 15) is
kappa^2 = 2 f (sin theta - sin delta). The paper's substitution (eq. 19) with the Jacobi amplitude
psi,

    sin(pi/4 - theta/2) = k sin(psi),   k = sin(pi/4 - delta/2),   m = k^2,

gives sqrt(f) s = F(psi, m) - F(psi0, m) (eq. 20) and, integrating x' = cos phi, y' = sin phi with
Jacobi's functions, the position relative to the foot in the basis a = (cos alpha, sin alpha),
n = (-sin alpha, cos alpha):

    sqrt(f) (r . a) = 2 k (cn u0 - cn u),     sqrt(f) (r . n) = 2 (E(psi) - E(psi0)) - (u - u0).

The load point is at psi = pi/2 (kappa = 0). We describe a member of this family by the profile
slope ``alpha`` and the *tip rotation* gamma = pi/2 - phi(s1) (so delta = pi/2 - alpha - gamma,
k = sin((alpha + gamma)/2)); gamma is the variable in which the family is smooth and computed
without cancellation near f = 0. Phase 1 (tangential contact, delta = 0) is gamma = pi/2 - alpha,
m = 1/2: the paper's H1 with modulus 1/sqrt(2).

The complete integrals are never subtracted from incomplete ones: K - F(psi0) = F(chi0) with the
complementary amplitude tan(chi0) tan(psi0) = 1/k' (DLMF 19.11.9-type addition), so quantities that
vanish with f keep their relative accuracy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.optimize import brentq
from scipy.special import ellipeinc, ellipj, ellipkinc

from ..errors import ParameterError

HALF_PI = 0.5 * math.pi


class Family(NamedTuple):
    """
    One member of the loaded-elastica family and its partial derivatives (internal, hot path).

    The load point is at (A a + N n) / sqrt(f) and sqrt(f) s1 = S; m0 = kappa(0) = -A sqrt(f).
    Suffixes ``_a`` and ``_g`` are partial derivatives with respect to alpha and gamma.
    """

    A: float
    N: float
    S: float
    A_a: float
    A_g: float
    N_a: float
    N_g: float
    S_a: float
    S_g: float


def family(alpha: float, gamma: float, derivatives: bool = True) -> Family:
    """
    Compute the closed-form shape numbers of the loaded elastica.

    ``alpha`` is the slope and ``gamma`` the tip rotation [rad]. Valid for gamma > 0,
    gamma/2 + alpha > 0 (kappa(0) < 0: WH1) and alpha + gamma < pi (k < 1). Returns NaN
    outside; callers check :func:`family_domain_ok` first.
    """
    h = 0.5 * gamma
    b = h + alpha
    c = 0.5 * (gamma + alpha)
    k = math.sin(c)
    kp = math.cos(c)
    sh = math.sin(h)
    sb = math.sin(b)
    A = 2.0 * math.sqrt(sh * sb)  # = 2 k cos(psi0) = -m0 / sqrt(f)   (paper: m0 below eq. 23)
    s_ha = math.sin(0.5 * alpha)
    c_ha = math.cos(0.5 * alpha)
    D = 2.0 * kp * s_ha
    chi = math.atan2(A, D)  # complementary amplitude of psi0: F(chi) = K - F(psi0)
    m = k * k
    S = float(ellipkinc(chi, m))  # sqrt(f) s1 (eq. 20 at psi = pi/2)
    Eb = float(ellipeinc(chi, m))  # E(m) - E(psi0) + m sin(psi0) sin(chi)
    T = s_ha / c_ha
    N = 2.0 * Eb - A * T - S
    if not derivatives:
        return Family(A, N, S, *_NO_DERIVATIVES)

    # partial derivatives (checked against finite differences in the tests)
    A_a = 2.0 * sh * math.cos(b) / A
    A_g = math.sin(gamma + alpha) / A
    k_x = 0.5 * kp  # dk/dalpha = dk/dgamma
    D_a = -k * s_ha + kp * c_ha
    D_g = -k * s_ha
    r2 = A * A + D * D
    chi_a = (D * A_a - A * D_a) / r2
    chi_g = (D * A_g - A * D_g) / r2
    s_chi = math.sin(chi)
    c_chi = math.cos(chi)
    dn_chi = math.sqrt(1.0 - m * s_chi * s_chi)
    kp2 = kp * kp
    F_k = (Eb - kp2 * S) / (k * kp2) - k * s_chi * c_chi / (kp2 * dn_chi)  # DLMF 19.4.2
    E_k = (Eb - S) / k  # DLMF 19.4.2
    S_a = chi_a / dn_chi + F_k * k_x
    S_g = chi_g / dn_chi + F_k * k_x
    E_a = dn_chi * chi_a + E_k * k_x
    E_g = dn_chi * chi_g + E_k * k_x
    N_a = 2.0 * E_a - A_a * T - A * 0.5 / (c_ha * c_ha) - S_a
    N_g = 2.0 * E_g - A_g * T - S_g
    return Family(A, N, S, A_a, A_g, N_a, N_g, S_a, S_g)


_NO_DERIVATIVES = (math.nan,) * 6


def family_domain_ok(alpha: float, gamma: float) -> bool:
    """Tell where :func:`family` is defined: gamma > 0, WH1 (gamma/2 + alpha > 0), k < 1."""
    return gamma > 0.0 and 0.5 * gamma + alpha > 0.0 and alpha + gamma < math.pi


def amplitude(u, m):
    """
    Jacobi amplitude am(u | m): the exact inverse of F(., m) (paper footnote 2's H1^-1).

    scipy's ``ellipj`` phase, polished by one Newton step on F(phi, m) = u.
    """
    phi = ellipj(u, m)[3]
    return phi - (ellipkinc(phi, m) - u) * np.sqrt(1.0 - m * np.sin(phi) ** 2)


def family_centerline(alpha: float, gamma: float, sqrt_f: float, s) -> np.ndarray:
    """Centerline points (contact frame) of the loaded part 0 <= s <= s1, shape (len(s), 2)."""
    s = np.asarray(s, dtype=float)
    k = math.sin(0.5 * (gamma + alpha))
    m = k * k
    A = 2.0 * math.sqrt(math.sin(0.5 * gamma) * math.sin(0.5 * gamma + alpha))
    psi0 = math.atan2(math.sin(0.5 * alpha), 0.5 * A)  # sin psi0 = sin(alpha/2)/k, cos = A/(2k)
    u0 = float(ellipkinc(psi0, m))
    e0 = float(ellipeinc(psi0, m))
    u = u0 + sqrt_f * s
    psi = amplitude(u, m)
    cn = np.cos(psi)
    ra = 2.0 * k * (math.cos(psi0) - cn) / sqrt_f
    rn = (2.0 * (ellipeinc(psi, m) - e0) - (u - u0)) / sqrt_f
    ca, sa = math.cos(alpha), math.sin(alpha)
    return np.column_stack((ra * ca - rn * sa, ra * sa + rn * ca))


@dataclass(frozen=True)
class TipLoadedElastica:
    """
    The elastica clamped at the origin along +y with a force at its tip (no tip moment).

    Returned by :func:`tip_loaded_elastica`; the parameters are the dataclass's fields, kept as
    attributes of the same names.

    Parameters
    ----------
    f : float
        Force magnitude [EI/L^2].
    alpha : float
        The force acts along (sin alpha, -cos alpha) [rad]; alpha = pi/2 pushes along +x.
    tip_x, tip_y : float
        Tip position [L].
    tip_slope : float
        phi(1) [rad].
    m0 : float
        Bending moment at the clamp kappa(0) [EI/L], counter-clockwise positive.

    """

    f: float
    alpha: float
    tip_x: float
    tip_y: float
    tip_slope: float
    m0: float

    @property
    def deflection(self) -> float:
        """Tip displacement perpendicular to the undeformed rod (along +x) [L]."""
        return self.tip_x

    @property
    def shortening(self) -> float:
        """Axial shortening 1 - tip_y [L]."""
        return 1.0 - self.tip_y


def tip_loaded_elastica(f: float, alpha: float = HALF_PI) -> TipLoadedElastica:
    """
    Solve the constant-force elastica: unit rod clamped along +y, tip force f (sin a, -cos a).

    The rod bends clockwise; ``alpha`` in (0, pi) covers every force direction with a component
    along +x. Solved exactly: the tip rotation gamma is the root of S(alpha, gamma) = sqrt(f)
    (eq. 21), then the tip position follows in closed form.

    Parameters
    ----------
    f : float
        The force magnitude [EI/L^2], finite and > 0.
    alpha : float, optional
        The force's direction [rad], in (0, pi): it acts along (sin alpha, -cos alpha); the
        default pi/2 pushes along +x.

    Returns
    -------
    TipLoadedElastica
        The force, the tip's position and slope and the clamp's moment.

    Raises
    ------
    ParameterError
        When f is not finite and > 0, or alpha is not in (0, pi).

    """
    f = float(f)
    alpha = float(alpha)
    if not (math.isfinite(f) and f > 0.0):
        raise ParameterError(f"tip load f = {f!r} must be finite and > 0")
    if not (0.0 < alpha < math.pi):
        raise ParameterError(f"load direction alpha = {alpha!r} must be in (0, pi)")
    sqrt_f = math.sqrt(f)
    g_lo = max(0.0, -2.0 * alpha)
    g_hi = math.pi - alpha
    eps = 1e-15
    gamma = brentq(
        lambda g: family(alpha, g, False).S - sqrt_f, g_lo + eps, g_hi - eps, xtol=1e-16,
        rtol=1e-15, maxiter=200
    )
    fam = family(alpha, gamma)
    ca, sa = math.cos(alpha), math.sin(alpha)
    x = (fam.A * ca - fam.N * sa) / sqrt_f
    y = (fam.A * sa + fam.N * ca) / sqrt_f
    return TipLoadedElastica(f, alpha, x, y, HALF_PI - gamma, -fam.A * sqrt_f)
