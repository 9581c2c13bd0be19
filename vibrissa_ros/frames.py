"""Units and frames at the edge between ROS (SI, REP 103) and the core (the paper's units).

No rclpy here: plain numbers in, plain numbers out, so this is testable without ROS.

* World frame: the frame in which the obstacle is placed (``world_frame``); poses arrive in it.
* Base frame (``base_frame``, REP 103): origin at the whisker's foot, +x along the undeformed
  whisker, bending in the base x-y plane, z up out of the plane. Its yaw in the world is the core's
  heading; the paper's set-up is a base at (x0, 0) with yaw = +90 degrees.
* Core units: length L, force EI/L^2 and moment EI/L (elastica) or c/L and c (rigid model).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Tuple

from .core.errors import VibrissaError
from .core.state import FootPose, WhiskerState

#: how far a quaternion's norm may be from 1
QUATERNION_NORM_TOLERANCE = 1e-6


class BadInput(VibrissaError, ValueError):
    """An input message that is dropped; ``reason`` is a short key counted on /diagnostics."""

    def __init__(self, reason: str, message: str):
        super().__init__(message)
        self.reason = reason


def planar_pose(
    position: Tuple[float, float, float],
    quaternion: Tuple[float, float, float, float],
    z_tolerance: float,
    angle_tolerance: float,
) -> Tuple[float, float, float]:
    """(x, y, yaw) of a pose that must lie in the world's x-y plane (z = 0, no roll, no pitch).

    ``quaternion`` is (x, y, z, w). Raises :class:`BadInput` with reason ``not_finite``,
    ``quaternion_not_unit`` or ``out_of_plane``.
    """
    values = tuple(position) + tuple(quaternion)
    if not all(math.isfinite(v) for v in values):
        raise BadInput("not_finite", f"pose has a non-finite value: position {position}, orientation {quaternion}")
    qx, qy, qz, qw = quaternion
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
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
            f"pose leaves the whisker's plane: z = {z!r} m, roll = {roll!r} rad, pitch = {pitch!r} rad "
            f"(allowed: |z| <= {z_tolerance} m, |roll|, |pitch| <= {angle_tolerance} rad)",
        )
    return float(position[0]), float(position[1]), yaw


def yaw_quaternion(yaw: float) -> Tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by ``yaw`` about z."""
    return 0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw)


@dataclass(frozen=True)
class Units:
    """Scale factors from the core's dimensionless values to SI."""

    length: float  # m
    force: float  # N
    moment: float  # N m

    @classmethod
    def elastica(cls, length: float, bending_stiffness: float) -> "Units":
        return cls(length, bending_stiffness / length**2, bending_stiffness / length)

    @classmethod
    def rigid(cls, length: float, spring_stiffness: float) -> "Units":
        return cls(length, spring_stiffness / length, spring_stiffness)

    def foot_pose(self, x: float, y: float, yaw: float) -> FootPose:
        """A world pose in metres -> the core's foot pose (lengths in L, heading = yaw)."""
        return FootPose(x / self.length, y / self.length, yaw)


@dataclass(frozen=True)
class SensorReading:
    """What the follicle's sensor measures and the contact state, in SI.

    ``force_base``/``torque_z``: the force and moment the whisker applies to its base, in the base
    frame (equal to the contact force on the whisker and to m0, by the whisker's equilibrium).
    ``contact_world``: the contact point in the world frame [m]; ``s1``: its arc length [m].
    """

    phase: int
    force_base: Tuple[float, float]
    torque_z: float
    force_world: Tuple[float, float]
    force_magnitude: float
    contact_world: Tuple[float, float] | None
    s1: float | None
    alpha: float | None


def sensor_reading(state: WhiskerState, units: Units) -> SensorReading:
    """Convert a core state (dimensionless, world frame) to SI and the base frame.

    In the paper's set-up (yaw = pi/2) this is force.x = fy EI/L^2, force.y = -fx EI/L^2,
    torque.z = m0 EI/L.
    """
    yaw = state.pose.heading
    c, s = math.cos(yaw), math.sin(yaw)
    fx, fy = state.fx * units.force, state.fy * units.force
    force_base = (c * fx + s * fy, -s * fx + c * fy)
    contact = None
    if state.contact is not None:
        contact = (state.contact[0] * units.length, state.contact[1] * units.length)
    return SensorReading(
        phase=int(state.phase),
        force_base=force_base,
        torque_z=state.m0 * units.moment,
        force_world=(fx, fy),
        force_magnitude=state.f * units.force,
        contact_world=contact,
        s1=None if state.s1 is None else state.s1 * units.length,
        alpha=state.alpha,
    )
