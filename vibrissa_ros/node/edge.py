"""
Every conversion at the edge between ROS (SI, REP 103) and the core (the paper's units).

No rclpy here: plain numbers and duck-typed message fields in, plain numbers out, so all of it is
testable without ROS. Every node and tool converts through this module and nowhere else.

* Stamps: ``builtin_interfaces/Time`` <-> integer nanoseconds.
* Quaternions: a pose's (x, y, z, w) -> yaw, with the unit and planarity checks of the input;
  for the 3D whisker (model rod3d) -> the core's scalar-first (w, x, y, z), any orientation,
  composed with the whisker's roll about its own axis.
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

import numpy as np

from ..core.errors import VibrissaError
from ..core.rod3d import BasePose, RodEvent, RodState
from ..core.rod3d.pose import quat_about, quat_multiply
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


def spatial_pose(position: Sequence[float], quaternion: Sequence[float]
                 ) -> Tuple[Tuple[float, float, float], Tuple[float, float, float, float]]:
    """
    Return a 6-DoF pose checked: position [m] and the unit quaternion, scalar first.

    Parameters
    ----------
    position : sequence of float
        (x, y, z) [m].
    quaternion : sequence of float
        (x, y, z, w), ROS order (geometry_msgs/Quaternion).

    Returns
    -------
    position : tuple of float
        (x, y, z) [m].
    quaternion : tuple of float
        (w, x, y, z), the core's order, normalised (its norm was within
        :data:`QUATERNION_NORM_TOLERANCE` of 1).

    Raises
    ------
    BadInput
        ``not_finite`` (a NaN or infinite value) or ``quaternion_not_unit`` (``|norm - 1|`` greater
        than :data:`QUATERNION_NORM_TOLERANCE`).

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
            f"orientation quaternion (x, y, z, w) = {tuple(quaternion)} has norm {norm!r}; a "
            f"unit quaternion is required (|norm - 1| <= {QUATERNION_NORM_TOLERANCE})",
        )
    x, y, z = (float(v) for v in position)
    return (x, y, z), (qw / norm, qx / norm, qy / norm, qz / norm)


def roll_quaternion(roll: float) -> np.ndarray:
    """
    Return the rotation by ``roll`` about the whisker's own axis (base frame +x), scalar first.

    Parameters
    ----------
    roll : float
        The angle [rad], right-handed about +x.

    Returns
    -------
    numpy.ndarray
        (w, x, y, z) (4,).

    """
    return quat_about((1.0, 0.0, 0.0), float(roll))


def foot_quaternion(pose: BasePose, roll: float) -> Tuple[float, float, float, float]:
    """
    Return the foot's orientation (x, y, z, w) of a core pose: its roll about +x undone.

    Parameters
    ----------
    pose : BasePose
        The core's base pose (the foot's orientation times the roll).
    roll : float
        The whisker's roll [rad].

    Returns
    -------
    tuple of float
        (x, y, z, w), ROS order.

    """
    w, x, y, z = quat_multiply(pose.q, roll_quaternion(-roll))
    return float(x), float(y), float(z), float(w)


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

    def base_pose(self, position: Sequence[float], quaternion: Sequence[float],
                  roll: float = 0.0) -> BasePose:
        """
        Return a checked 6-DoF pose -> the 3D whisker's base pose (lengths in L).

        Parameters
        ----------
        position : sequence of float
            (x, y, z) [m] in the world frame.
        quaternion : sequence of float
            (w, x, y, z), unit (:func:`spatial_pose`): the foot's orientation.
        roll : float, optional
            The whisker's roll about its own axis [rad]: the core's orientation is
            q_foot * rot_x(roll).

        Returns
        -------
        BasePose
            Position / L and the composed quaternion.

        Raises
        ------
        BadInput
            ``not_finite`` when the position overflows in whisker lengths.

        """
        p = tuple(float(v) / self.length for v in position)
        if not all(math.isfinite(v) for v in p):
            raise BadInput("not_finite", f"pose {tuple(position)} m is not finite in whisker "
                           f"lengths (L = {self.length!r} m)")
        q = quat_multiply(np.asarray(quaternion, dtype=float), roll_quaternion(roll))
        return BasePose(p, tuple(float(v) for v in q))


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


@dataclass(frozen=True)
class RodReading:
    """
    The 3D whisker's sensor reading and contact state, in SI.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    phase : int
        0 free, 1 the contact nearest the base is on the side, 2 it is at the tip.
    force_base : tuple of float
        (x, y, z) [N], base frame: the force the whisker applies to its base (the follicle
        sensor's reading), equal to the total contact force on the whisker.
    torque_base : tuple of float
        (x, y, z) [N m], base frame: the moment the whisker applies to its base, the contact
        forces' moment about the base point.
    force_world : tuple of float
        The total contact force on the whisker [N], world frame.
    force_magnitude : float
        Its magnitude [N].
    contact_world : tuple of float or None
        The contact point nearest the base [m], world frame; None when free.
    s1 : float or None
        Its arc length [m]; None when free.

    """

    phase: int
    force_base: Tuple[float, float, float]
    torque_base: Tuple[float, float, float]
    force_world: Tuple[float, float, float]
    force_magnitude: float
    contact_world: Optional[Tuple[float, float, float]]
    s1: Optional[float]

    @property
    def wrench(self) -> Tuple[float, float, float, float, float, float]:
        """Return (force x, y, z [N], torque x, y, z [N m]), base frame."""
        return self.force_base + self.torque_base


def rod_phase(state: RodState) -> int:
    """
    Return the ``~/phase`` code of a 3D state: 0 free, 1 side or 2 tip contact nearest the base.

    Parameters
    ----------
    state : RodState
        The 3D whisker's state.

    Returns
    -------
    int
        The code.

    """
    c = state.nearest
    if c is None:
        return 0
    return 2 if c.kind == "tip" else 1


def rod_reading(state: RodState, units: Units, roll: float = 0.0) -> RodReading:
    """
    Convert a 3D state (dimensionless, world frame) to SI and the base frame.

    Parameters
    ----------
    state : RodState
        The 3D whisker's state.
    units : Units
        The elastica's units: force EI/L^2, moment EI/L.
    roll : float, optional
        The whisker's roll [rad] about its own axis relative to the base frame: the core's base
        frame (``state.base_wrench()``'s) is the base frame rotated by it about +x.

    Returns
    -------
    RodReading
        rot_x(roll) ``state.base_wrench()`` times EI/L^2 and EI/L (the base frame: that of the
        foot pose), and the contact nearest the base.

    """
    force, moment = state.base_wrench()
    if roll != 0.0:
        c, s = math.cos(roll), math.sin(roll)
        rx = np.array(((1.0, 0.0, 0.0), (0.0, c, -s), (0.0, s, c)))
        force, moment = rx @ force, rx @ moment
    world = tuple(float(v) * units.force for v in state.force)
    c = state.nearest
    return RodReading(
        phase=rod_phase(state),
        force_base=tuple(float(v) * units.force for v in force),
        torque_base=tuple(float(v) * units.moment for v in moment),
        force_world=world,
        force_magnitude=math.sqrt(sum(v * v for v in world)),
        contact_world=None if c is None else tuple(float(v) * units.length for v in c.point),
        s1=None if c is None else c.s * units.length,
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
    one obstacle of a profile or peg); ``z`` [m] and ``fz`` [N] are 0 but for the 3D whisker.
    """

    x: float
    y: float
    fx: float
    fy: float
    s: float
    kind: int
    state: int
    obstacle: int
    z: float = 0.0
    fz: float = 0.0


def contact_records(state, units: Units) -> Tuple[ContactRecord, ...]:
    """
    Return every contact of a state, foot to tip, in SI.

    A scene state lists its contacts; a single-contact state has one (frictionless: ``slip``)
    while in contact, side or tip by its phase.
    """
    contacts = getattr(state, "contacts", None)
    L, F = units.length, units.force
    if isinstance(state, RodState):  # the 3D whisker: frictionless, side or tip
        return tuple(ContactRecord(c.point[0] * L, c.point[1] * L, c.force[0] * F,
                                   c.force[1] * F, c.s * L, CONTACT_KINDS[c.kind],
                                   CONTACT_STATES["slip"], int(c.obstacle), c.point[2] * L,
                                   c.force[2] * F) for c in contacts)
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
    arc length ``s`` [m] where known. An event of the 3D whisker is a scene event with the
    foot's ``z`` [m] and ``orientation`` (x, y, z, w) besides (``yaw``: its heading).
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
    z: Optional[float] = None
    orientation: Optional[Tuple[float, float, float, float]] = None

    @property
    def scene(self) -> bool:
        return self.from_phase is None


def _rod_contact_kind(event: RodEvent) -> Optional[str]:
    """Return the kind of the contact a 3D event concerns (None: a snap or a reset)."""
    if event.kind in ("tip", "tangential"):
        return "tip" if event.kind == "tip" else "side"
    if event.kind in ("touch", "release") and event.s is not None:
        return "tip" if event.s >= 1.0 else "side"
    return None


def event_record(event, units: Units, roll: float = 0.0) -> EventRecord:
    """
    Return the SI payload of a core event (an Event, a SceneEvent or a 3D RodEvent).

    ``roll`` [rad] is the 3D whisker's roll, undone to give the foot's orientation.
    """
    if isinstance(event, RodEvent):
        (x, y, z), L = event.pose.position, units.length
        return EventRecord(event.kind, None, None, x * L, y * L, event.pose.heading,
                           None if event.obstacle is None else int(event.obstacle),
                           _rod_contact_kind(event),
                           None if event.s is None else float(event.s) * L, z * L,
                           foot_quaternion(event.pose, roll))
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
    only where known); the 3D whisker's add ``"z"`` and ``"orientation"`` ([x, y, z, w]).
    """
    data = {"kind": record.kind}
    if not record.scene:
        data.update(from_phase=record.from_phase, to_phase=record.to_phase)
    data.update(x=record.x, y=record.y, yaw=record.yaw)
    if record.z is not None:
        data.update(z=record.z, orientation=list(record.orientation))
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
            obstacle, s, z = data.get("obstacle"), data.get("s"), data.get("z")
            orientation = None
            if z is not None:
                z = float(z)
                orientation = tuple(float(v) for v in data["orientation"])
                if len(orientation) != 4:
                    raise ValueError("an orientation has 4 values (x, y, z, w)")
            record = EventRecord(str(data["kind"]), None, None, *where,
                                 None if obstacle is None else int(obstacle),
                                 str(data["contact"]) or None, None if s is None else float(s),
                                 z, orientation)
            kinds = SCENE_EVENT_KINDS
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise BadInput("bad_event", f"not an event payload ({exc}): {text!r}") from None
    if record.kind not in kinds:
        raise BadInput("bad_event", f"event kind {record.kind!r} is not one of {kinds}")
    return record
