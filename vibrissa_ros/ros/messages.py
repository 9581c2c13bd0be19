"""
Every message the nodes publish, built by pure functions (no node, no DDS: unit-testable).

Numbers come in SI and in the frame named (conversions are :mod:`vibrissa_ros.node.edge`'s); each
builder converts to ``float`` explicitly, as ROS_PYTHON_CHECK_FIELDS requires.
"""

from __future__ import annotations

import math
from typing import Iterable, Mapping, Optional, Sequence, Tuple

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, PointStamped, PoseStamped, Vector3Stamped, WrenchStamped
from nav_msgs.msg import Path
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import ColorRGBA, Float64, String, UInt8
from visualization_msgs.msg import Marker, MarkerArray

from ..core.errors import VibrissaError
from ..core.profiles import Peg
from ..node.edge import ContactRecord, EventRecord, encode_event, set_stamp, yaw_quaternion

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


def profile_markers(profile, length: float, frame: str, stamp) -> MarkerArray:
    """Return a single obstacle as ``~/obstacles`` carries it: a DELETEALL, then its strip."""
    array = MarkerArray()
    clear = Marker()
    clear.header.frame_id, clear.header.stamp = frame, stamp
    clear.ns, clear.id, clear.action = "scene", 0, Marker.DELETEALL
    array.markers.append(clear)
    marker = obstacle_marker(profile, length, frame, stamp)
    marker.ns, marker.id = "scene", 1
    array.markers.append(marker)
    return array


def outline_marker(array: MarkerArray) -> Marker:
    """
    Return every LINE_STRIP of a MarkerArray as one LINE_LIST (``~/obstacle`` of a scene).

    Each strip's consecutive points become segments; frame, stamp, width and colour are the
    first strip's.
    """
    strips = [mk for mk in array.markers
              if mk.action == Marker.ADD and mk.type == Marker.LINE_STRIP]
    marker = Marker()
    if strips:
        first = strips[0]
        marker.header = first.header
        marker.scale.x = first.scale.x
        marker.color = first.color
    marker.ns, marker.id = "obstacle", 0
    marker.type, marker.action = Marker.LINE_LIST, Marker.ADD
    marker.pose.orientation.w = 1.0
    for strip in strips:
        points = list(strip.points)
        for a, b in zip(points[:-1], points[1:]):
            marker.points.extend((a, b))
    return marker


#: the fields of one ``~/contacts`` point: name, PointField datatype, numpy type, offset
CONTACT_FIELDS = (
    ("x", PointField.FLOAT64, "<f8", 0), ("y", PointField.FLOAT64, "<f8", 8),
    ("z", PointField.FLOAT64, "<f8", 16), ("fx", PointField.FLOAT64, "<f8", 24),
    ("fy", PointField.FLOAT64, "<f8", 32), ("s", PointField.FLOAT64, "<f8", 40),
    ("kind", PointField.UINT8, "u1", 48), ("state", PointField.UINT8, "u1", 49),
    ("obstacle", PointField.UINT32, "<u4", 52),
)
CONTACT_POINT_STEP = 56
CONTACT_DTYPE = np.dtype({"names": [f[0] for f in CONTACT_FIELDS],
                          "formats": [f[2] for f in CONTACT_FIELDS],
                          "offsets": [f[3] for f in CONTACT_FIELDS],
                          "itemsize": CONTACT_POINT_STEP})


def contacts_cloud(stamp, frame: str, contacts: Sequence[ContactRecord]) -> PointCloud2:
    """
    Return every contact of a pose as a PointCloud2 (one point per contact, foot to tip).

    Fields (little-endian; float64 so that nothing is lost to rounding): x, y, z [m] (z = 0),
    fx, fy [N] (the obstacle's force on the whisker, world frame), s [m] (arc length), kind
    (uint8: 0 side, 1 tip, 2 corner), state (uint8: 0 slip, 1 stick), obstacle (uint32, its
    index). No contact: an empty cloud (width 0).
    """
    points = np.zeros(len(contacts), dtype=CONTACT_DTYPE)
    for i, c in enumerate(contacts):
        points[i] = (float(c.x), float(c.y), 0.0, float(c.fx), float(c.fy), float(c.s),
                     int(c.kind), int(c.state), int(c.obstacle))
    cloud = PointCloud2()
    cloud.header.stamp, cloud.header.frame_id = stamp, frame
    cloud.height, cloud.width = 1, len(contacts)
    cloud.fields = [PointField(name=name, offset=offset, datatype=kind, count=1)
                    for name, kind, _, offset in CONTACT_FIELDS]
    cloud.is_bigendian = False
    cloud.point_step = CONTACT_POINT_STEP
    cloud.row_step = CONTACT_POINT_STEP * len(contacts)
    cloud.data = points.tobytes()
    cloud.is_dense = True
    return cloud


def decode_contacts(cloud) -> Tuple[ContactRecord, ...]:
    """
    Read the contacts back from a ``~/contacts`` cloud (by its field table, not by position).

    Raises ValueError if a field is missing or the cloud is not little-endian.
    """
    if cloud.is_bigendian:
        raise ValueError("a big-endian contacts cloud")
    names, formats, offsets = [], [], []
    types = {PointField.FLOAT64: "<f8", PointField.UINT8: "u1", PointField.UINT32: "<u4"}
    by_name = {f.name: f for f in cloud.fields}
    for name, _, _, _ in CONTACT_FIELDS:
        if name not in by_name or by_name[name].datatype not in types:
            raise ValueError(f"the contacts cloud has no field {name!r} of a known type")
        names.append(name)
        formats.append(types[by_name[name].datatype])
        offsets.append(by_name[name].offset)
    dtype = np.dtype({"names": names, "formats": formats, "offsets": offsets,
                      "itemsize": cloud.point_step})
    n = cloud.width * cloud.height
    points = np.frombuffer(bytes(cloud.data), dtype=dtype, count=n)
    return tuple(ContactRecord(float(p["x"]), float(p["y"]), float(p["fx"]), float(p["fy"]),
                               float(p["s"]), int(p["kind"]), int(p["state"]),
                               int(p["obstacle"])) for p in points)


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
