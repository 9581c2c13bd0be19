"""
The inverse problem for the general (tapered, intrinsically curved) whisker.

From the foot pose and the base wrench alone, with the whisker's known taper and curvature: with
one frictionless contact the measured force is the contact force (its direction gives the
obstacle's slope alpha at the contact, f (sin alpha, -cos alpha)), and it is constant between the
foot and the contact. So the whisker there solves an initial value problem from the foot,

    x' = cos(theta), y' = sin(theta), theta' = kappa0(s) + M / B(s), M' = f cos(theta - alpha),
    x(0), y(0) = foot, theta(0) = heading, M(0) = m0 (measured),

integrated with DOP853 (rtol 1e-13). The contact is where the bending moment first vanishes: at
s1 < 1 (tangential contact) or at the tip (s1 = 1, tip contact). Beyond the contact the whisker is
unloaded, so a moment that has not vanished by the tip means the reading is inconsistent.
(Assumption: the whisker does not cross the force's line of action before the contact, where
M would vanish too; true unless the whisker wraps round the obstacle.)
"""

from __future__ import annotations

import math
from typing import Optional

from scipy.integrate import solve_ivp

from .model import WhiskerShape
from ..exact.inverse import TIP_TOLERANCE, ContactEstimate, canonical_pose
from ..state import FootPose, Phase

HALF_PI = 0.5 * math.pi


def loaded_whisker_rhs(shape: WhiskerShape, f: float, alpha: float):
    """
    Return the right-hand side of the loaded whisker's 4th-order system in the world frame.

    u = (x, y, theta, M): x' = cos theta, y' = sin theta, theta' = kappa0(s) + M / B(s) and
    M' = f cos(theta - alpha), under the contact force f (sin alpha, -cos alpha) beyond s.
    """
    ca, sa = math.cos(alpha), math.sin(alpha)
    k0, k1, c = shape.k0, shape.k1, 1.0 - shape.taper

    def rhs(s, u):
        _, _, th, m = u
        b = (1.0 - c * s) ** 4
        return [math.cos(th), math.sin(th), k0 + k1 * s + m / b,
                f * (math.cos(th) * ca + math.sin(th) * sa)]

    return rhs


def estimate_contact_general(pose: FootPose, fx: float, fy: float, m0: float, shape: WhiskerShape,
                             min_force: float = 0.0) -> Optional[ContactEstimate]:
    """
    Estimate the contact point from one reading of a general whisker (units EI_b, L; world frame).

    Parameters
    ----------
    pose : FootPose
        The foot pose of the reading.
    fx, fy : float
        The force of the obstacle on the whisker, world frame [EI_b/L^2].
    m0 : float
        The base moment [EI_b/L], counter-clockwise positive.
    shape : WhiskerShape
        The whisker's taper and intrinsic curvature.
    min_force : float, optional
        A reading with a force magnitude f <= ``min_force`` has no usable contact.

    Returns
    -------
    ContactEstimate or None
        The estimate (``alpha`` is the force's direction in the world frame; the pose's heading
        in (-pi, pi], like the trackers'); None when there is no usable contact:
        f <= ``min_force``, m0 = 0, or a moment that does not vanish along the whisker (no single
        frictionless contact produces that reading).

    """
    f = math.hypot(fx, fy)
    if not (math.isfinite(f) and math.isfinite(m0)) or f <= min_force or f == 0.0 or m0 == 0.0:
        return None
    pose = canonical_pose(pose)  # the heading in (-pi, pi], like the trackers'
    alpha = math.atan2(fx, -fy)
    rhs = loaded_whisker_rhs(shape, f, alpha)

    def moment(s, u):
        return u[3]

    moment.terminal = True
    sol = solve_ivp(rhs, (0.0, 1.0), [pose.x, pose.y, pose.heading, m0], method="DOP853",
                    rtol=1e-13, atol=1e-14, events=moment)
    if not sol.success:
        return None
    if sol.t_events[0].size and sol.t_events[0][0] < 1.0 - TIP_TOLERANCE:
        s1 = float(sol.t_events[0][0])
        x, y, th, _ = sol.y_events[0][0]
        phase, delta = Phase.TANGENTIAL, 0.0
    else:
        x, y, th, m_end = sol.y[:, -1]
        if abs(m_end) > 1e-6 * max(1.0, abs(m0)):
            return None
        s1, phase = 1.0, Phase.TIP
        delta = math.remainder(th - alpha, 2.0 * math.pi)
    side = 1 if m0 < 0.0 else -1
    return ContactEstimate(pose, phase, (float(x), float(y)), alpha, s1, side, float(delta))


__all__ = ["estimate_contact_general", "loaded_whisker_rhs"]
