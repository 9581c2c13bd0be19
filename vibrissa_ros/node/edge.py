"""
Every conversion at the edge between ROS (SI, REP 103) and the core (the paper's units).

No rclpy here: plain numbers and duck-typed message fields in, plain numbers out, so all of it is
testable without ROS. Every node and tool converts through this module and nowhere else.

* Stamps: ``builtin_interfaces/Time`` <-> integer nanoseconds.
* Quaternions: a pose's (x, y, z, w) -> yaw, with the unit and planarity checks of the input.
* Frames: the world frame (``world_frame``) holds the obstacle and the poses; the base frame
  (``base_frame``, REP 103) has its origin at the whisker's foot, +x along the undeformed whisker
  and z out of the plane of bending. Its yaw in the world is the core's heading; the paper's set-up
  is a base at (x0, 0) with yaw = +90 degrees.
* SI units: the core works in length L, force EI/L^2 and moment EI/L (elastica) or c/L and c
  (rigid model).
* Event payloads: the JSON object of ``~/events``, encoded and decoded here only.
* Contacts: every contact of a state in SI (``~/contacts``).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

from ..core.errors import VibrissaError
from ..core.state import FootPose, WhiskerState

NS_PER_S = 1_000_000_000
#: how far a quaternion's norm may be from 1
QUATERNION_NORM_TOLERANCE = 1e-6


class BadInput(VibrissaError, ValueError):
    """An input message that is dropped; ``reason`` is a short key counted on /diagnostics."""

    def __init__(self, reason: str, message: str):
        super().__init__(message)
        self.reason = reason


# -- stamps -------------------------------------------------------------------------------------
def stamp_ns(stamp) -> int:
    """Integer nanoseconds of a ``builtin_interfaces/Time`` (anything with sec and nanosec)."""
    return int(stamp.sec) * NS_PER_S + int(stamp.nanosec)


def header_ns(msg) -> int:
    """Integer nanoseconds of a stamped message's ``header.stamp``."""
    return stamp_ns(msg.header.stamp)


def stamp_parts(ns: int) -> Tuple[int, int]:
    """(sec, nanosec) of integer nanoseconds, as ``builtin_interfaces/Time`` holds them."""
    sec, nanosec = divmod(int(ns), NS_PER_S)
    return sec, nanosec


def set_stamp(stamp, ns: int) -> None:
    """Write integer nanoseconds into a ``builtin_interfaces/Time`` in place."""
    stamp.sec, stamp.nanosec = stamp_parts(ns)


# -- quaternions ----------------------------------------------------------------------------------
def yaw_quaternion(yaw: float) -> Tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by ``yaw`` [rad] about z."""
    return 0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw)


def planar_pose(
    position: Sequence[float],
    quaternion: Sequence[float],
    z_tolerance: float,
    angle_tolerance: float,
) -> Tuple[float, float, float]:
    """
    (x, y, yaw) of a pose that must lie in the world's x-y plane (z = 0, no roll, no pitch).

    ``quaternion`` is (x, y, z, w). Raises :class:`BadInput` with reason ``not_finite``,
    ``quaternion_not_unit`` or ``out_of_plane``.
    """
    values = tuple(position) + tuple(quaternion)
    if not all(math.isfinite(v) for v in values):
        raise BadInput("not_finite", f"pose has a non-finite value: position {tuple(position)}, "
                       f"orientation {tuple(quaternion)}")
    qx, qy, qz, qw = quaternion
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if not abs(norm - 1.0) <= QUATERNION_NORM_TOLERANCE:  # also catches an overflowing norm
        raise BadInput(
            "quaternion_not_unit",
            f"orientation quaternion has norm {norm!r}; a unit quaternion is required "
            f"(|norm - 1| <= {QUATERNION_NORM_TOLERANCE})",
        )
    qx, qy, qz, qw = qx / norm, qy / norm, qz / norm, qw / norm
    roll = math.atan2(2.0 * (qw * qx + qy * qz), 1.0 - 2.0 * (qx * qx + qy * qy))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (qw * qy - qz * qx))))
    yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    z = position[2]
    if abs(z) > z_tolerance or abs(roll) > angle_tolerance or abs(pitch) > angle_tolerance:
        raise BadInput(
            "out_of_plane",
            f"pose leaves the whisker's plane: z = {z!r} m, roll = {roll!r} rad, "
            f"pitch = {pitch!r} rad (allowed: |z| <= {z_tolerance} m, |roll|, |pitch| <= "
            f"{angle_tolerance} rad)",
        )
    return float(position[0]), float(position[1]), yaw


def pose_of(msg, z_tolerance: float, angle_tolerance: float) -> Tuple[float, float, float]:
    """(x [m], y [m], yaw [rad]) of a PoseStamped, checked as :func:`planar_pose` checks."""
    p, q = msg.pose.position, msg.pose.orientation
    return planar_pose((p.x, p.y, p.z), (q.x, q.y, q.z, q.w), z_tolerance, angle_tolerance)


# -- frames ---------------------------------------------------------------------------------------
def world_to_base(yaw: float, vx: float, vy: float) -> Tuple[float, float]:
    """
    Return a world-frame vector seen in the base frame of yaw ``yaw`` (rotated by -yaw).

    Parameters
    ----------
    yaw : float
        The base frame's yaw in the world frame [rad], counter-clockwise.
    vx, vy : float
        The vector's world-frame components (any unit).

    Returns
    -------
    tuple of float
        Its base-frame components (x, y), in the same unit.

    """
    c, s = math.cos(yaw), math.sin(yaw)
    return c * vx + s * vy, -s * vx + c * vy


def base_to_world(yaw: float, vx: float, vy: float) -> Tuple[float, float]:
    """
    Return a base-frame vector seen in the world frame (rotated by +yaw).

    Parameters
    ----------
    yaw : float
        The base frame's yaw in the world frame [rad], counter-clockwise.
    vx, vy : float
        The vector's base-frame components (any unit).

    Returns
    -------
    tuple of float
        Its world-frame components (x, y), in the same unit.

    """
    c, s = math.cos(yaw), math.sin(yaw)
    return c * vx - s * vy, s * vx + c * vy


# -- SI units -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Units:
    """
    Scale factors from the core's dimensionless values to SI.

    The parameters are the dataclass's fields, kept as attributes of the same names; the
    constructors :meth:`elastica` (paper §2) and :meth:`rigid` (paper §3) derive them.

    Parameters
    ----------
    length : float
        The length unit, the whisker's length L [m].
    force : float
        The force unit [N]: EI/L^2 (elastica) or c/L (rigid).
    moment : float
        The moment unit [N m]: EI/L (elastica) or c (rigid).

    """

    length: float  # m
    force: float  # N
    moment: float  # N m

    @classmethod
    def elastica(cls, length: float, bending_stiffness: float) -> "Units":
        """Length L, force EI/L^2, moment EI/L (paper §2)."""
        return cls(length, bending_stiffness / length**2, bending_stiffness / length)

    @classmethod
    def rigid(cls, length: float, spring_stiffness: float) -> "Units":
        """Length L, force c/L, moment c (paper §3)."""
        return cls(length, spring_stiffness / length, spring_stiffness)

    def foot_pose(self, x: float, y: float, yaw: float) -> FootPose:
        """
        Return a world pose in metres -> the core's foot pose (lengths in L, heading = yaw).

        Raises :class:`BadInput` (``not_finite``) when the position overflows in whisker lengths.
        """
        fx, fy = x / self.length, y / self.length
        if not (math.isfinite(fx) and math.isfinite(fy)):
            raise BadInput("not_finite", f"pose ({x!r}, {y!r}) m is not finite in whisker lengths "
                           f"(L = {self.length!r} m)")
        return FootPose(fx, fy, yaw)


@dataclass(frozen=True)
class SensorReading:
    """
    What the follicle's sensor measures and the contact state, in SI.

    ``force_base``/``torque_z``: the force and moment the whisker applies to its base, in the base
    frame (equal to the contact force on the whisker and to m0, by the whisker's equilibrium).
    ``contact_world``: the contact point in the world frame [m]; ``s1``: its arc length [m].
    """

    phase: int
    force_base: Tuple[float, float]
    torque_z: float
    force_world: Tuple[float, float]
    force_magnitude: float
    contact_world: Optional[Tuple[float, float]]
    s1: Optional[float]
    alpha: Optional[float]


def sensor_reading(state: WhiskerState, units: Units) -> SensorReading:
    """
    Convert a core state (dimensionless, world frame) to SI and the base frame.

    In the paper's set-up (yaw = pi/2) this is force.x = fy EI/L^2, force.y = -fx EI/L^2,
    torque.z = m0 EI/L.
    """
    fx, fy = state.fx * units.force, state.fy * units.force
    contact = None
    if state.contact is not None:
        contact = (state.contact[0] * units.length, state.contact[1] * units.length)
    return SensorReading(
        phase=int(state.phase),
        force_base=world_to_base(state.pose.heading, fx, fy),
        torque_z=state.m0 * units.moment,
        force_world=(fx, fy),
        force_magnitude=state.f * units.force,
        contact_world=contact,
        s1=None if state.s1 is None else state.s1 * units.length,
        alpha=state.alpha,
    )


def wrench_to_core(yaw: float, force_x: float, force_y: float, torque_z: float,
                   units: Units) -> Tuple[float, float, float]:
    """Return a base-frame SI wrench -> the core's (fx, fy, m0): world frame, dimensionless."""
    wx, wy = base_to_world(yaw, force_x, force_y)
    return wx / units.force, wy / units.force, torque_z / units.moment


# -- contacts -------------------------------------------------------------------------------------
#: ``~/contacts`` codes of a contact's kind (a corner on the side or at the tip is a corner)
CONTACT_KINDS = {"side": 0, "tip": 1, "corner": 2}
#: ``~/contacts`` codes of a contact's friction state (frictionless contacts slip)
CONTACT_STATES = {"slip": 0, "stick": 1}


@dataclass(frozen=True)
class ContactRecord:
    """
    One contact of ``~/contacts`` in SI: where (world frame), the obstacle's force on the whisker.

    ``s`` [m] is the whisker's arc length at the contact; ``kind`` and ``state`` are the codes of
    :data:`CONTACT_KINDS` and :data:`CONTACT_STATES`; ``obstacle`` the obstacle's index (0 for the
    one obstacle of a profile or peg).
    """

    x: float
    y: float
    fx: float
    fy: float
    s: float
    kind: int
    state: int
    obstacle: int


def contact_records(state, units: Units) -> Tuple[ContactRecord, ...]:
    """
    Return every contact of a state, foot to tip, in SI.

    A scene state lists its contacts; a single-contact state has one (frictionless: ``slip``)
    while in contact, side or tip by its phase.
    """
    contacts = getattr(state, "contacts", None)
    L, F = units.length, units.force
    if contacts is not None:
        return tuple(ContactRecord(c.x * L, c.y * L, c.fx * F, c.fy * F, c.s * L,
                                   CONTACT_KINDS[c.report_kind], CONTACT_STATES[c.state],
                                   int(c.obstacle)) for c in contacts)
    if state.contact is None:
        return ()
    kind = CONTACT_KINDS["tip" if int(state.phase) == 2 else "side"]
    return (ContactRecord(state.contact[0] * L, state.contact[1] * L, state.fx * F,
                          state.fy * F, state.s1 * L, kind, CONTACT_STATES["slip"], 0),)


# -- event payloads -------------------------------------------------------------------------------
#: the single-contact tracker's events (with the phases before and after)
EVENT_KINDS = ("touch", "phase", "snap", "release", "reset")
#: the scene tracker's events (doc/guide/scenes.md; with the obstacle, the contact's kind and s)
SCENE_EVENT_KINDS = ("touch", "release", "tip", "tangential", "corner", "edge", "slip", "stick",
                     "merge", "snap", "reset")


@dataclass(frozen=True)
class EventRecord:
    """
    One ``~/events`` payload: what happened and the pose where it did (m, m, rad).

    A single-contact event has ``from_phase`` and ``to_phase``; a scene event has instead
    ``obstacle`` (its index), ``contact`` (side, corner, tip or tip_corner) and the contact's
    arc length ``s`` [m] where known.
    """

    kind: str
    from_phase: Optional[int]
    to_phase: Optional[int]
    x: float
    y: float
    yaw: float
    obstacle: Optional[int] = None
    contact: Optional[str] = None
    s: Optional[float] = None

    @property
    def scene(self) -> bool:
        return self.from_phase is None


def event_record(event, units: Units) -> EventRecord:
    """Return the SI payload of a core event (a tracker's Event or a scene's SceneEvent)."""
    x, y, yaw = event.pose.x * units.length, event.pose.y * units.length, event.pose.heading
    if hasattr(event, "from_phase"):
        return EventRecord(event.kind, int(event.from_phase), int(event.to_phase), x, y, yaw)
    return EventRecord(event.kind, None, None, x, y, yaw,
                       None if event.obstacle is None else int(event.obstacle),
                       event.contact_kind or None,
                       None if event.s is None else float(event.s) * units.length)


def encode_event(record: EventRecord) -> str:
    """
    Return the JSON of ``~/events``.

    ``{"kind", "from_phase", "to_phase", "x", "y", "yaw"}`` for the single-contact tracker,
    ``{"kind", "x", "y", "yaw", "obstacle", "contact", "s"}`` for a scene (``obstacle`` and ``s``
    only where known).
    """
    data = {"kind": record.kind}
    if not record.scene:
        data.update(from_phase=record.from_phase, to_phase=record.to_phase)
    data.update(x=record.x, y=record.y, yaw=record.yaw)
    if record.scene:
        if record.obstacle is not None:
            data["obstacle"] = record.obstacle
        data["contact"] = record.contact or ""
        if record.s is not None:
            data["s"] = record.s
    return json.dumps(data)


def decode_event(text: str) -> EventRecord:
    """Parse an ``~/events`` payload; raises :class:`BadInput` (``bad_event``) if it is not one."""
    try:
        data = json.loads(text)
        where = (float(data["x"]), float(data["y"]), float(data["yaw"]))
        if "from_phase" in data:
            record = EventRecord(str(data["kind"]), int(data["from_phase"]),
                                 int(data["to_phase"]), *where)
            kinds = EVENT_KINDS
        else:
            obstacle, s = data.get("obstacle"), data.get("s")
            record = EventRecord(str(data["kind"]), None, None, *where,
                                 None if obstacle is None else int(obstacle),
                                 str(data["contact"]) or None, None if s is None else float(s))
            kinds = SCENE_EVENT_KINDS
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise BadInput("bad_event", f"not an event payload ({exc}): {text!r}") from None
    if record.kind not in kinds:
        raise BadInput("bad_event", f"event kind {record.kind!r} is not one of {kinds}")
    return record
