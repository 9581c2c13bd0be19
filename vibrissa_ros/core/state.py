"""
Immutable values the core returns: foot poses, whisker states, events.

Frame ("world", the paper's frame for a scan): the obstacle is placed in it; a foot pose is the
position of the whisker's base and the heading of the undeformed whisker. The paper's set-up is
the foot at (x0, 0) with heading pi/2 (whisker along +y). Units: length L, force EI/L^2 (elastica)
or c/L (rigid model), moment EI/L (or c).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any, Optional, Tuple

import numpy as np

from .errors import InvalidPoseError

HALF_PI = 0.5 * math.pi
TWO_PI = 2.0 * math.pi


def wrap_heading(heading: float) -> float:
    """
    Return ``heading`` [rad] as the trackers carry and report it: in (-pi, pi].

    A heading and the same heading plus whole turns are one whisker; the trackers keep the
    representative in (-pi, pi] so that nothing downstream depends on how often the foot turned.
    """
    wrapped = math.remainder(heading, TWO_PI)
    return math.pi if wrapped == -math.pi else wrapped


class Phase(IntEnum):
    """Contact phase (paper §2): 0 free, 1 tangential contact at s1 < 1, 2 tip contact."""

    FREE = 0
    TANGENTIAL = 1
    TIP = 2


@dataclass(frozen=True)
class FootPose:
    """
    Planar pose of the whisker's base.

    Position (x, y) [L] and heading [rad] of the undeformed whisker, counter-clockwise from +x.
    The paper's scan is ``FootPose(x0, 0.0, pi/2)``. The parameters are the dataclass's fields,
    kept as attributes of the same names.

    Parameters
    ----------
    x : float
        The base's x [L].
    y : float, optional
        The base's y [L].
    heading : float, optional
        The undeformed whisker's heading [rad], counter-clockwise from +x; pi/2: along +y.

    Raises
    ------
    InvalidPoseError
        When a value is not a number or not finite.

    """

    x: float
    y: float = 0.0
    heading: float = HALF_PI

    def __post_init__(self):
        for key in ("x", "y", "heading"):
            value = getattr(self, key)
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise InvalidPoseError(f"foot pose {key} = {value!r} is not a number") from None
            if not math.isfinite(value):
                raise InvalidPoseError(f"foot pose {key} = {value!r} must be finite")
            object.__setattr__(self, key, value)

    def contact_to_world(self, x, y, side: int = 1):
        """
        Map points of this pose's *contact frame* to the world frame.

        The contact frame has the foot at the origin and the undeformed whisker along +y, mirrored
        (x -> -x) when the whisker bends counter-clockwise (``side`` = -1), so that the models only
        ever solve the clockwise case. This is the one place where the core rotates by the heading
        (beta = heading - pi/2) and mirrors by the side. ``x``, ``y``: floats or arrays of one
        shape.
        """
        beta = self.heading - HALF_PI
        c, s = math.cos(beta), math.sin(beta)
        x = x * (-1.0 if side < 0 else 1.0)
        return self.x + c * x - s * y, self.y + s * x + c * y


@dataclass(frozen=True)
class Event:
    """
    Something that happened during a step, located by root finding on the equilibrium branch.

    ``kind`` is ``touch`` (first contact), ``phase`` (tangential <-> tip), ``snap`` (the branch
    folds: criterion (c) of paper §2.2, the whisker jumps), ``release`` (the contact force
    returns to zero and the whisker leaves the obstacle smoothly) or ``reset`` (the step could not
    be followed and the whisker was placed unloaded at the new pose, or it was reset on request;
    doc/mechanics/decisions.md, "Recovery"). The parameters are the dataclass's
    fields, kept as attributes of the same names.

    Parameters
    ----------
    kind : {'touch', 'phase', 'snap', 'release', 'reset'}
        What happened (above).
    from_phase, to_phase : Phase
        The phase before and after the event.
    pose : FootPose
        The foot pose where it happened.
    alpha : float or None, optional
        The profile's slope at the contact [rad] (world frame), where there is one.
    reason : str, optional
        Why a ``reset`` happened (empty for the other kinds; not compared).

    """

    kind: str
    from_phase: Phase
    to_phase: Phase
    pose: FootPose
    alpha: Optional[float] = None
    reason: str = field(default="", compare=False)

    @property
    def x0(self) -> float:
        return self.pose.x


@dataclass(frozen=True)
class WhiskerState:
    """
    One quasistatic equilibrium of the whisker (all quantities dimensionless, world frame).

    Units: length L, force EI/L^2, moment EI/L (the rigid model: c/L and c). The parameters are
    the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    phase : Phase
        The contact phase: free, tangential contact (s1 < 1) or tip contact.
    pose : FootPose
        The foot pose.
    side : int
        +1 when bent clockwise (contact on the obstacle's flank to the right of the whisker,
        kappa <= 0), -1 when bent counter-clockwise, 0 when free.
    alpha : float or None
        Profile slope at the contact point [rad] (world frame).
    s1 : float or None
        Arc length of the contact point on the whisker [L] (1 in phase 2).
    tip_slope : float
        phi(1), the whisker's slope at its tip [rad] (world frame).
    f : float
        Magnitude of the contact force.
    fx, fy : float
        Force of the obstacle on the whisker, f (sin alpha, -cos alpha) (world frame).
    m0 : float
        Bending moment at the base, kappa(0) = moment of the contact force about the foot,
        counter-clockwise positive (negative when bent clockwise).
    contact : tuple of float or None
        Contact point (xi(alpha), eta(alpha)) (world frame).
    tip : tuple of float
        Position (x, y) of the whisker's tip (world frame).
    shape : tuple of float, optional
        Internal description of the shape for centerline sampling (contact-frame variables).
    model : object, optional
        The model that computed this state (it samples the centerline); None for a free whisker.

    """

    phase: Phase
    pose: FootPose
    side: int
    alpha: Optional[float]
    s1: Optional[float]
    tip_slope: float
    f: float
    fx: float
    fy: float
    m0: float
    contact: Optional[Tuple[float, float]]
    tip: Tuple[float, float]
    # internal description of the shape for centerline sampling (contact-frame variables)
    shape: Tuple[float, ...] = ()
    #: the model that computed this state (it samples the centerline); None for a free whisker
    model: Any = field(default=None, compare=False, repr=False)

    @property
    def x0(self) -> float:
        return self.pose.x

    def centerline(self, n: int = 101) -> np.ndarray:
        """Return ``n`` >= 2 centerline points from foot to tip, shape (n, 2), world frame."""
        n = int(n)
        if n < 2:
            raise ValueError(f"n = {n} points: need at least 2")
        if self.phase == Phase.FREE:
            free = getattr(self.model, "free_centerline", None)  # an intrinsically curved whisker
            if free is None:
                x, y = np.zeros(n), np.linspace(0.0, 1.0, n)
            else:
                pts = free(n)
                x, y = pts[:, 0], pts[:, 1]
            return np.column_stack(self.pose.contact_to_world(x, y, 1))
        else:
            phase, z = Phase(int(self.shape[0])), (self.shape[1], self.shape[2])
            pts = self.model.centerline_contact_frame(phase, z, n)
            x, y = pts[:, 0], pts[:, 1]
        return np.column_stack(self.pose.contact_to_world(x, y, self.side))


@dataclass(frozen=True)
class StepResult:
    """
    What a tracker step returns: the new state and the events crossed, in order.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    state : WhiskerState
        The new state.
    events : tuple of Event
        The events crossed, in order.
    substeps : int, optional
        The number of continuation steps.
    evaluations : int, optional
        The model and profile evaluations the step used (bounded by
        ``TrackerOptions.max_evaluations``).

    """

    state: WhiskerState
    events: Tuple[Event, ...]
    substeps: int = 0
    evaluations: int = 0
