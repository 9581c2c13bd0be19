"""
An independent reference solver: shooting on the paper's 4th-order boundary value problem.

This solver shares nothing with the closed forms of :mod:`.elastica` or with the tracker: it
integrates the paper's system (§2.1 (2) and §2.2)

    x' = cos(phi),  y' = sin(phi),  phi' = kappa,  kappa' = f cos(phi - alpha),

from the foot x(0) = x0, y(0) = 0, phi(0) = pi/2, kappa(0) = kappa0 with ``solve_ivp`` (DOP853)
and solves for the unknowns with ``scipy.optimize.root``, parametrized by the foot position x0
directly (the paper's set-up; bending clockwise, i.e. a foot moving in -x):

* phase 1 (tangential, s1 < 1): unknowns (kappa0, f, alpha, s1); at s1: x = xi(alpha),
  y = eta(alpha), phi = alpha, kappa = 0;
* phase 2 (tip, s1 = 1): unknowns (kappa0, f, alpha); at s = 1: x = xi(alpha), y = eta(alpha),
  kappa = 0.

It is slow (each residual is an ODE solve) and exists to validate the core and to be timed
against it. :class:`ShootingScan` follows a forward scan by natural-parameter continuation in x0,
switching phase when the solution leaves its phase's domain, and stops where it loses the branch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Sequence

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, root

from ..errors import ConvergenceError
from ..profiles import ConvexProfile

HALF_PI = 0.5 * math.pi
_RTOL = 1e-13
_ATOL = 1e-15


@dataclass(frozen=True)
class ShootingState:
    """A solution of the boundary value problem (paper frame, dimensionless)."""

    x0: float
    phase: int
    kappa0: float
    f: float
    alpha: float
    s1: float
    tip_slope: float

    @property
    def m0(self) -> float:
        return self.kappa0

    @property
    def fx(self) -> float:
        return self.f * math.sin(self.alpha)

    @property
    def fy(self) -> float:
        return -self.f * math.cos(self.alpha)


def _rhs(_s, u, f, alpha):
    x, y, phi, kappa = u
    return (math.cos(phi), math.sin(phi), kappa, f * math.cos(phi - alpha))


def integrate(x0: float, kappa0: float, f: float, alpha: float, s_end: float) -> np.ndarray:
    """(x, y, phi, kappa) at arc length ``s_end`` from the clamped foot at (x0, 0)."""
    if s_end <= 0.0:
        return np.array([x0, 0.0, HALF_PI, kappa0])
    sol = solve_ivp(
        _rhs, (0.0, s_end), (x0, 0.0, HALF_PI, kappa0), method="DOP853", rtol=_RTOL, atol=_ATOL,
        args=(f, alpha),
    )
    if not sol.success:
        raise ConvergenceError(f"shooting: the initial value problem failed ({sol.message})")
    return sol.y[:, -1]


class ShootingSolver:
    """
    Solve the boundary value problem at one foot position, from a seed.

    Parameters
    ----------
    profile : ConvexProfile
        The obstacle whose point of slope alpha, (xi(alpha), eta(alpha)), the whisker touches.

    """

    def __init__(self, profile: ConvexProfile):
        self.profile = profile

    def residual(self, x0: float, phase: int, unknowns: Sequence[float]) -> np.ndarray:
        if phase == 1:
            kappa0, f, alpha, s1 = unknowns
            x, y, phi, kappa = integrate(x0, kappa0, f, alpha, s1)
            xi, eta = self.profile.point(alpha)
            return np.array([x - xi, y - eta, phi - alpha, kappa])
        kappa0, f, alpha = unknowns
        x, y, phi, kappa = integrate(x0, kappa0, f, alpha, 1.0)
        xi, eta = self.profile.point(alpha)
        return np.array([x - xi, y - eta, kappa])

    def solve(self, x0: float, phase: int, seed: Sequence[float]) -> Optional[ShootingState]:
        """Newton-type solve from ``seed``; None if it does not converge to ~1e-12."""
        try:
            sol = root(lambda u: self.residual(x0, phase, u), np.asarray(seed, float),
                       method="hybr", options={"xtol": 1e-14, "maxfev": 400})
        except (ValueError, OverflowError):
            return None
        if not np.all(np.isfinite(sol.x)) or np.max(np.abs(sol.fun)) > 1e-11:
            return None
        u = sol.x
        if phase == 1:
            kappa0, f, alpha, s1 = u
            tip = alpha
        else:
            kappa0, f, alpha = u
            s1 = 1.0
            tip = integrate(x0, kappa0, f, alpha, 1.0)[2]
        return ShootingState(float(x0), phase, float(kappa0), float(f), float(alpha), float(s1),
                             float(tip))


class ShootingScan:
    """Natural-parameter continuation of the shooting solver along a decreasing x0 grid."""

    def __init__(self, profile: ConvexProfile):
        self.profile = profile
        self.solver = ShootingSolver(profile)
        # first touch: the straight whisker's tip (x0, 1) meets the right flank, eta(alpha) = 1
        hi = profile.alpha_max - 1e-9
        self.alpha_touch = brentq(lambda a: profile.point(a)[1] - 1.0, 0.0, hi, xtol=1e-15)
        self.x_touch = profile.point(self.alpha_touch)[0]

    def run(self, grid: Sequence[float]) -> List[Optional[ShootingState]]:
        """States on the grid (None where free); stops (shorter list) where the branch is lost."""
        out: List[Optional[ShootingState]] = []
        current: Optional[ShootingState] = None
        for x0 in grid:
            if current is None and x0 >= self.x_touch:
                out.append(None)
                continue
            if current is None:
                a = self.alpha_touch
                f = 3.0 * (self.x_touch - x0) / math.sin(a)
                current = ShootingState(x0, 2, -f * math.sin(a), f, a, 1.0, HALF_PI)
            state = self._advance(current, x0)
            if state is None:
                break
            out.append(state)
            current = state
        return out

    def _advance(self, prev: ShootingState, x0: float) -> Optional[ShootingState]:
        phase = prev.phase
        for _ in range(2):
            if phase == 1:
                seed = (prev.kappa0, prev.f, prev.alpha, min(prev.s1, 1.0 - 1e-9))
            else:
                seed = (prev.kappa0, prev.f, prev.alpha)
            state = self.solver.solve(x0, phase, seed)
            if state is not None:
                if phase == 2 and state.tip_slope < state.alpha:
                    phase = 1  # the tip would cut the profile: tangential contact
                    continue
                if phase == 1 and state.s1 > 1.0:
                    phase = 2  # the contact point would leave the whisker: tip contact
                    continue
                return state
            phase = 1 if phase == 2 else 2
        return None
