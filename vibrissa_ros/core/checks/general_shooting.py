"""
A second, independent solver for the general whisker: shooting on the 4th-order system.

It shares nothing with the Chebyshev collocation of :mod:`.general` or with the tracker: in the
world frame it integrates

    x' = cos(theta),  y' = sin(theta),  theta' = kappa0(s) + M / B(s),  M' = f cos(theta - alpha)

from the foot (x, y, theta = heading, M = m0) with ``solve_ivp`` (DOP853, rtol 1e-13) and solves
for the unknowns with ``scipy.optimize.root``:

* tangential contact: unknowns (m0, f, alpha, s1); at s1: (x, y) = Q(alpha), theta = alpha
  (+ pi when the obstacle lies on the whisker's right), M = 0;
* tip contact: unknowns (m0, f, alpha); at s = 1: (x, y) = Q(alpha), M = 0.

Q(alpha) is the obstacle's point of slope alpha; (fx, fy) = f (sin alpha, -cos alpha). Slow (each
residual is an ODE solve): it validates the collocation and is the baseline it is timed against.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import root

from ..errors import ConvergenceError
from ..general.inverse import loaded_whisker_rhs
from ..general.model import WhiskerShape
from ..profiles import ConvexProfile
from ..state import FootPose, Phase

_RTOL = 1e-13
_ATOL = 1e-14


@dataclass(frozen=True)
class ShotState:
    """An equilibrium found by shooting (world frame, units EI_b)."""

    phase: Phase
    m0: float
    f: float
    alpha: float
    s1: float


def _integrate(shape: WhiskerShape, pose: FootPose, m0: float, f: float, alpha: float, s1: float):
    rhs = loaded_whisker_rhs(shape, f, alpha)
    sol = solve_ivp(rhs, (0.0, s1), [pose.x, pose.y, pose.heading, m0], method="DOP853",
                    rtol=_RTOL, atol=_ATOL)
    if not sol.success:
        raise ConvergenceError(f"shooting: the integration failed ({sol.message})")
    return sol.y[:, -1]


def shoot(shape: WhiskerShape, profile: ConvexProfile, pose: FootPose, phase: Phase,
          guess: ShotState, right: bool = False, tol: float = 1e-13) -> ShotState:
    """
    Solve the equilibrium of ``phase`` at ``pose`` by shooting from ``guess``.

    Parameters
    ----------
    shape : WhiskerShape
        The whisker's taper and intrinsic curvature.
    profile : ConvexProfile
        The obstacle; Q(alpha) is its point of slope alpha.
    pose : FootPose
        The foot's position and heading (world frame).
    phase : Phase
        The contact to solve for: tangential (unknowns m0, f, alpha, s1) or at the tip (unknowns
        m0, f, alpha; s1 = 1).
    guess : ShotState
        The root finder's starting point.
    right : bool, optional
        The obstacle lies on the whisker's right at a tangential contact (theta = alpha + pi).
    tol : float, optional
        The root finder's ``xtol``.

    Returns
    -------
    ShotState
        The equilibrium found (world frame, units EI_b).

    Raises
    ------
    ConvergenceError
        When the root finder does not converge.

    """
    turn = math.pi if right else 0.0

    def residual(v):
        if phase == Phase.TANGENTIAL:
            m0, f, alpha, s1 = v
        else:
            (m0, f, alpha), s1 = v, 1.0
        x, y, th, m = _integrate(shape, pose, m0, f, alpha, s1)
        qx, qy = profile.point(alpha)
        out = [x - qx, y - qy, m]
        if phase == Phase.TANGENTIAL:
            out.append(math.remainder(th - alpha - turn, 2.0 * math.pi))
        return out

    x0 = [guess.m0, guess.f, guess.alpha] + ([guess.s1] if phase == Phase.TANGENTIAL else [])
    res = root(residual, x0, method="hybr", options={"xtol": tol})
    if not res.success or max(abs(r) for r in res.fun) > 1e-10:
        raise ConvergenceError(f"shooting did not converge: {res.message}")
    v = res.x
    return ShotState(phase, float(v[0]), float(v[1]), float(v[2]),
                     float(v[3]) if phase == Phase.TANGENTIAL else 1.0)


def shoot_state(shape: WhiskerShape, profile: ConvexProfile, state, perturbation: float = 1e-3,
                seed: Optional[int] = 0) -> ShotState:
    """Re-solve a tracker state independently, from a guess perturbed by ``perturbation``."""
    rng = np.random.default_rng(seed)
    p = 1.0 + perturbation * rng.uniform(-1.0, 1.0, 4)
    guess = ShotState(state.phase, state.m0 * p[0], state.f * p[1],
                      state.alpha + perturbation * (p[2] - 1.0),
                      min(state.s1 * p[3], 0.999) if state.phase == Phase.TANGENTIAL else 1.0)
    # which side of the whisker the obstacle lies on: the force pushes towards the whisker's right
    # when the obstacle is on its left (theta(s1) = alpha), and to its left otherwise
    right = False
    if state.phase == Phase.TANGENTIAL:
        th = state.tip_slope - float(shape.intrinsic_slope(1.0) - shape.intrinsic_slope(state.s1))
        right = math.cos(th - state.alpha) < 0.0
    return shoot(shape, profile, state.pose, state.phase, guess, right)
