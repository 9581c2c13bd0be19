"""
Every message the nodes publish, built by pure functions (no node, no DDS: unit-testable).

Numbers come in SI and in the frame named (conversions are :mod:`vibrissa_ros.edge`'s); each
builder converts to ``float`` explicitly, as ROS_PYTHON_CHECK_FIELDS requires.
"""

from __future__ import annotations

import math
from typing import Iterable, Mapping, Optional, Sequence, Tuple

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, PointStamped, PoseStamped, Vector3Stamped, WrenchStamped
from nav_msgs.msg import Path
from std_msgs.msg import ColorRGBA, Float64, String, UInt8
from visualization_msgs.msg import Marker, MarkerArray

from ..core.errors import VibrissaError
from ..core.profiles import Peg
from ..edge import EventRecord, encode_event, set_stamp, yaw_quaternion

OBSTACLE_COLOR = (0.85, 0.35, 0.1, 1.0)
PHASE_COLORS = {1: (0.12, 0.47, 0.71), 2: (0.84, 0.15, 0.16)}


def pose_stamped(x: float, y: float, yaw: float, stamp_ns: int, frame: str = "world",
                 z: float = 0.0) -> PoseStamped:
    """Return a planar foot pose [m, m, rad] in ``frame``."""
    msg = PoseStamped()
    msg.header.frame_id = frame
    set_stamp(msg.header.stamp, stamp_ns)
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = float(x), float(y), float(z)
    _, _, msg.pose.orientation.z, msg.pose.orientation.w = yaw_quaternion(float(yaw))
    return msg


def fill_wrench(msg: WrenchStamped, stamp, frame: str, force: Tuple[float, float],
                torque_z: float) -> WrenchStamped:
    """Write a planar wrench [N, N m] into ``msg`` (reused: building one costs a step's time)."""
    msg.header.stamp = stamp
    msg.header.frame_id = frame
    msg.wrench.force.x, msg.wrench.force.y = float(force[0]), float(force[1])
    msg.wrench.torque.z = float(torque_z)
    return msg


def vector_stamped(stamp, frame: str, xy: Tuple[float, float]) -> Vector3Stamped:
    """Return a planar vector (z = 0) in ``frame``."""
    msg = Vector3Stamped()
    msg.header.stamp, msg.header.frame_id = stamp, frame
    msg.vector.x, msg.vector.y = float(xy[0]), float(xy[1])
    return msg


def point_stamped(stamp, frame: str, xy: Tuple[float, float]) -> PointStamped:
    """Return a planar point (z = 0) in ``frame``."""
    msg = PointStamped()
    msg.header.stamp, msg.header.frame_id = stamp, frame
    msg.point.x, msg.point.y = float(xy[0]), float(xy[1])
    return msg


def phase_msg(phase: int) -> UInt8:
    return UInt8(data=int(phase))


def float_msg(value: float) -> Float64:
    return Float64(data=float(value))


def event_msg(record: EventRecord) -> String:
    """Return the ``~/events`` message of an event (JSON, see ``edge.encode_event``)."""
    return String(data=encode_event(record))


def centerline_path(stamp, frame: str, points: np.ndarray) -> Path:
    """Return the whisker's shape: points (n, 2) [m], foot to tip, each facing along the rod."""
    tangent = np.diff(points, axis=0)
    yaws = np.arctan2(tangent[:, 1], tangent[:, 0])
    yaws = np.append(yaws, yaws[-1])
    path = Path()
    path.header.stamp, path.header.frame_id = stamp, frame
    for (x, y), yaw in zip(points, yaws):
        pose = PoseStamped()
        pose.header = path.header
        pose.pose.position.x, pose.pose.position.y = float(x), float(y)
        _, _, pose.pose.orientation.z, pose.pose.orientation.w = yaw_quaternion(float(yaw))
        path.poses.append(pose)
    return path


def obstacle_points(profile, reach: float = 2.0, n: int = 400) -> np.ndarray:
    """
    Points (m, 2) of a profile (dimensionless) up to ``reach`` above its apex, apex included.

    A peg: its whole circle, closed (a point peg: a circle of 0.005 L, to be seen).
    """
    if isinstance(profile, Peg):
        t = np.linspace(0.0, 2.0 * math.pi, n)
        r = max(profile.r, 0.005)
        return np.column_stack((profile.x + r * np.cos(t), profile.y + r * np.sin(t)))
    apex_y = profile.point(profile.lowest_alpha())[1]
    ends = []
    for side in (-1, 1):
        try:
            ends.append(profile.alpha_at_height(apex_y + reach, side))
        except VibrissaError:  # the profile ends below that height: up to its end
            ends.append((profile.alpha_min if side < 0 else profile.alpha_max) - side * 1e-6)
    alphas = np.union1d(np.linspace(ends[0], ends[1], n), [profile.lowest_alpha()])
    return np.array([profile.point(float(a)) for a in alphas])


def obstacle_marker(profile, length: float, frame: str, stamp) -> Marker:
    """Return the obstacle's profile as a LINE_STRIP [m], up to 2 whisker lengths above it."""
    marker = Marker()
    marker.header.frame_id, marker.header.stamp = frame, stamp
    marker.ns, marker.id = "obstacle", 0
    marker.type, marker.action = Marker.LINE_STRIP, Marker.ADD
    marker.pose.orientation.w = 1.0
    marker.scale.x = 0.01 * length
    marker.color.r, marker.color.g, marker.color.b, marker.color.a = OBSTACLE_COLOR
    for x, y in obstacle_points(profile) * length:
        marker.points.append(Point(x=float(x), y=float(y)))
    return marker


def scene_markers(scene, length: float, frame: str, stamp,
                  window: Optional[Tuple[float, float, float, float]] = None,
                  n: int = 200) -> MarkerArray:
    """
    Return every obstacle of a scene as a MarkerArray [m] (latched on a transient-local topic).

    A DELETEALL first (namespace ``scene``: a new scene replaces the old one), then per obstacle
    one LINE_STRIP (id = 1 + its index; a closed outline, or for an infinite obstacle its
    boundary within ``window`` [L], default the scene's window widened by 1 L; a point peg: a
    circle of 0.005 L), then one POINTS marker of all corners and point pegs (id = obstacles + 1).
    ``length`` [m] is the whisker's length (scene lengths are in L).
    """
    window = scene.window(margin=2.0) if window is None else window
    array = MarkerArray()
    clear = Marker()
    clear.header.frame_id, clear.header.stamp = frame, stamp
    clear.ns, clear.id, clear.action = "scene", 0, Marker.DELETEALL
    array.markers.append(clear)
    corners = []
    for index, ob in enumerate(scene):
        marker = Marker()
        marker.header.frame_id, marker.header.stamp = frame, stamp
        marker.ns, marker.id = "scene", index + 1
        marker.type, marker.action = Marker.LINE_STRIP, Marker.ADD
        marker.pose.orientation.w = 1.0
        marker.scale.x = 0.01 * length
        marker.color.r, marker.color.g, marker.color.b, marker.color.a = OBSTACLE_COLOR
        marker.text = ob.name
        if getattr(ob, "is_point", False):
            t = np.linspace(0.0, 2.0 * math.pi, 33)
            lines = [np.column_stack((ob.x + 0.005 * np.cos(t), ob.y + 0.005 * np.sin(t)))]
        else:
            lines = list(ob.boundary_lines(n, window))
        # one strip per obstacle: the pieces of an infinite boundary cut by the window are
        # joined (the strip may then cross the window's edge once between two pieces)
        for line in lines:
            for x, y in line * length:
                marker.points.append(Point(x=float(x), y=float(y)))
        array.markers.append(marker)
        corners.extend((v.x, v.y) for v in ob.vertices)
    dots = Marker()
    dots.header.frame_id, dots.header.stamp = frame, stamp
    dots.ns, dots.id = "scene", len(scene) + 1
    dots.type, dots.action = Marker.POINTS, Marker.ADD
    dots.pose.orientation.w = 1.0
    dots.scale.x = dots.scale.y = 0.02 * length
    dots.color.r, dots.color.g, dots.color.b, dots.color.a = OBSTACLE_COLOR
    for x, y in corners:
        dots.points.append(Point(x=float(x * length), y=float(y * length)))
    array.markers.append(dots)
    return array


def contour_marker(points: Iterable[Tuple[float, float, int]], frame: str, stamp,
                   length: float) -> Marker:
    """Estimated contact points (x [m], y [m], phase) as POINTS coloured by phase."""
    marker = Marker()
    marker.header.frame_id, marker.header.stamp = frame, stamp
    marker.ns = "contour"
    marker.type, marker.action = Marker.POINTS, Marker.ADD
    marker.pose.orientation.w = 1.0
    marker.scale.x = marker.scale.y = 0.005 * length
    for x, y, phase in points:
        marker.points.append(Point(x=float(x), y=float(y)))
        r, g, b = PHASE_COLORS[int(phase)]
        marker.colors.append(ColorRGBA(r=r, g=g, b=b, a=1.0))
    return marker


def diagnostic_status(node_name: str, level: bytes, message: str,
                      values: Mapping[str, object]) -> DiagnosticStatus:
    """One node's status: name ``vibrissa_ros: <node>``, hardware_id the node's full name."""
    status = DiagnosticStatus()
    status.name = f"vibrissa_ros: {node_name}"
    status.hardware_id = node_name
    status.level = level  # DiagnosticStatus.OK/WARN/ERROR (a byte)
    status.message = message
    status.values = [KeyValue(key=str(k), value=str(v)) for k, v in values.items()]
    return status


def diagnostic_array(stamp, statuses: Sequence[DiagnosticStatus]) -> DiagnosticArray:
    array = DiagnosticArray()
    array.header.stamp = stamp
    array.status = list(statuses)
    return array


def whisker_status(node_name: str, phase: Optional[int], dropped: int, last_error: str,
                   record_error: str, values: Mapping[str, object]) -> DiagnosticStatus:
    """whisker_node's status: ERROR while a recording failed, WARN after drops, else OK."""
    if record_error:
        level, message = DiagnosticStatus.ERROR, f"not recording: {record_error}"
    elif dropped and last_error:
        level, message = DiagnosticStatus.WARN, f"{dropped} pose(s) dropped; last: {last_error}"
    else:
        level = DiagnosticStatus.OK
        message = "whisker not placed yet" if phase is None else f"phase {int(phase)}"
    return diagnostic_status(node_name, level, message, values)
