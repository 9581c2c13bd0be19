"""
The inverse problem (the paper's closing question).

Where is the contact, from what a sensor measures? Only the foot pose and the base wrench are
used, never the simulator's internal state.

With one frictionless contact the measured force is the contact force: its direction gives the
profile's slope at the contact, alpha (force = f (sin alpha, -cos alpha)), its length f. The
whisker between the foot and the contact is then the elastica clamped at the foot under that
constant force, and the measured base moment m0 = kappa(0) fixes it completely: the first integral
kappa^2 = 2 f (sin theta - sin delta) (paper eq. 15) at the foot (theta = pi/2 - alpha) gives

    sin(delta) = cos(alpha) - m0^2 / (2 f),

the angle delta = phi - alpha where the bending moment vanishes. The contact is where the moment
vanishes: at arc length s* = S(alpha, delta)/sqrt(f) (eq. 20). Exactly one of two things holds:
s* < 1 with delta = 0 (phase 1: tangential contact at s1 = s*), or s* = 1 with delta > 0 (phase 2:
the tip). The phase is decided from the data alone by s*, and the contact point follows in closed
form from the same loaded-elastica family the forward solver uses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, List, Optional, Sequence, Tuple

from .elastica import family, family_centerline, family_domain_ok
from ..state import FootPose, Phase, wrap_heading

HALF_PI = 0.5 * math.pi
#: s* within this of 1 is the tip (phase 2)
TIP_TOLERANCE = 1e-9


@dataclass(frozen=True)
class ContactEstimate:
    """
    A contact point estimated from one sensor reading (dimensionless, world frame).

    Returned by :func:`estimate_contact`; the parameters are the dataclass's fields, kept as
    attributes of the same names.

    Parameters
    ----------
    pose : FootPose
        The foot pose of the reading, its heading in (-pi, pi].
    phase : Phase
        TANGENTIAL when the zero-moment point lies inside the whisker (s1 < 1), TIP otherwise.
    contact : tuple of float
        The estimated contact point (x, y) [L].
    alpha : float
        The profile's slope there [rad], from the force direction.
    s1 : float
        Arc length of the contact on the whisker [L].
    side : int
        +1 bent clockwise, -1 counter-clockwise (from the sign of m0).
    delta : float
        phi - alpha at the zero-moment point (0 for a tangential contact; clamped at 0 for noisy
        data).

    """

    pose: FootPose
    phase: Phase
    contact: Tuple[float, float]
    alpha: float
    s1: float
    side: int
    delta: float


def canonical_pose(pose: FootPose) -> FootPose:
    """Return ``pose`` with its heading in (-pi, pi] (whole turns removed)."""
    heading = wrap_heading(pose.heading)
    return pose if heading == pose.heading else FootPose(pose.x, pose.y, heading)


def estimate_contact(pose: FootPose, fx: float, fy: float, m0: float,
                     min_force: float = 0.0) -> Optional[ContactEstimate]:
    """
    Estimate the contact point from one reading.

    The reading is the force (fx, fy) of the obstacle on the whisker (world frame) and the base
    moment m0 (ccw positive), in the paper's units.

    Parameters
    ----------
    pose : FootPose
        The foot pose of the reading.
    fx, fy : float
        The force of the obstacle on the whisker, world frame [EI/L^2].
    m0 : float
        The base moment [EI/L], counter-clockwise positive.
    min_force : float, optional
        A reading with a force magnitude f <= ``min_force`` has no usable contact.

    Returns
    -------
    ContactEstimate or None
        The estimate, carrying the pose with its heading in (-pi, pi], like the trackers'
        states; None when there is no usable contact: f <= ``min_force``, m0 = 0 (a force
        through the foot), or a reading no single frictionless contact can produce.

    """
    f = math.hypot(fx, fy)
    if not (math.isfinite(f) and math.isfinite(m0)) or f <= min_force or f == 0.0 or m0 == 0.0:
        return None
    pose = canonical_pose(pose)
    alpha_w = math.atan2(fx, -fy)
    side = 1 if m0 < 0.0 else -1
    beta = pose.heading - HALF_PI
    alpha = math.remainder(side * (alpha_w - beta), 2.0 * math.pi)  # contact frame
    if not -HALF_PI < alpha < HALF_PI:
        return None
    sin_delta = math.cos(alpha) - m0 * m0 / (2.0 * f)
    if not -1.0 <= sin_delta < 1.0:  # no elastica under this force has this base moment
        return None
    delta = max(0.0, math.asin(sin_delta))  # noise can push a tangential contact's delta below 0
    gamma = HALF_PI - alpha - delta
    if not family_domain_ok(alpha, gamma):
        return None
    sqrt_f = math.sqrt(f)
    s_star = family(alpha, gamma, False).S / sqrt_f
    if s_star < 1.0 - TIP_TOLERANCE:
        phase, s1 = Phase.TANGENTIAL, s_star
    else:
        phase, s1 = Phase.TIP, 1.0
    px, py = (float(v) for v in family_centerline(alpha, gamma, sqrt_f, [s1])[0])
    contact = pose.contact_to_world(px, py, side)
    return ContactEstimate(pose, phase, contact, alpha_w, s1, side, delta)


def reconstruct(readings: Iterable[Tuple[FootPose, float, float, float]],
                min_force: float = 0.0) -> List[ContactEstimate]:
    """
    Estimate the contacts along a sweep: one per reading with a usable contact.

    Parameters
    ----------
    readings : iterable of tuple
        The readings (pose, fx, fy, m0), as taken by :func:`estimate_contact`.
    min_force : float, optional
        Readings with a force magnitude <= ``min_force`` are left out.

    Returns
    -------
    list of ContactEstimate
        The estimates in reading order; readings without a usable contact are skipped.

    """
    out = []
    for pose, fx, fy, m0 in readings:
        est = estimate_contact(pose, fx, fy, m0, min_force)
        if est is not None:
            out.append(est)
    return out


def covered_intervals(values: Sequence[float], gap: float) -> List[Tuple[float, float]]:
    """Merge sorted positions into intervals, broken where neighbours are over ``gap`` apart."""
    xs = sorted(values)
    if not xs:
        return []
    out = [[xs[0], xs[0]]]
    for v in xs[1:]:
        if v - out[-1][1] <= gap:
            out[-1][1] = v
        else:
            out.append([v, v])
    return [(a, b) for a, b in out]


__all__ = ["ContactEstimate", "estimate_contact", "reconstruct", "covered_intervals",
           "TIP_TOLERANCE"]
