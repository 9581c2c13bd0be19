"""
Every message the nodes publish, built by pure functions (no node, no DDS: unit-testable).

Numbers come in SI and in the frame named (conversions are :mod:`vibrissa_ros.node.edge`'s); each
builder converts to ``float`` explicitly, as ROS_PYTHON_CHECK_FIELDS requires.
"""

from __future__ import annotations

import copy
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
from ..core.rod3d import Cylinder, Plane, Sphere
from ..core.rod3d.pose import quat_from_matrix
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
    """
    Write a planar wrench [N, N m] into ``msg`` (reused: building one costs a step's time).

    Force z and torque x, y are 0 (a message that carried a 3D wrench is cleared).
    """
    msg.header.stamp = stamp
    msg.header.frame_id = frame
    msg.wrench.force.x, msg.wrench.force.y = float(force[0]), float(force[1])
    msg.wrench.torque.z = float(torque_z)
    msg.wrench.force.z = msg.wrench.torque.x = msg.wrench.torque.y = 0.0
    return msg


def fill_wrench6(msg: WrenchStamped, stamp, frame: str, force: Sequence[float],
                 torque: Sequence[float]) -> WrenchStamped:
    """Write a full wrench, force (x, y, z) [N] and torque (x, y, z) [N m], into ``msg``."""
    msg.header.stamp = stamp
    msg.header.frame_id = frame
    f, t = msg.wrench.force, msg.wrench.torque
    f.x, f.y, f.z = float(force[0]), float(force[1]), float(force[2])
    t.x, t.y, t.z = float(torque[0]), float(torque[1]), float(torque[2])
    return msg


def vector_stamped(stamp, frame: str, xy: Sequence[float]) -> Vector3Stamped:
    """Return a vector (x, y) (z = 0: planar) or (x, y, z) in ``frame``."""
    msg = Vector3Stamped()
    msg.header.stamp, msg.header.frame_id = stamp, frame
    msg.vector.x, msg.vector.y = float(xy[0]), float(xy[1])
    if len(xy) > 2:
        msg.vector.z = float(xy[2])
    return msg


def point_stamped(stamp, frame: str, xy: Sequence[float]) -> PointStamped:
    """Return a point (x, y) (z = 0: planar) or (x, y, z) in ``frame``."""
    msg = PointStamped()
    msg.header.stamp, msg.header.frame_id = stamp, frame
    msg.point.x, msg.point.y = float(xy[0]), float(xy[1])
    if len(xy) > 2:
        msg.point.z = float(xy[2])
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


def centerline_path3d(stamp, frame: str, points: np.ndarray, frames: np.ndarray) -> Path:
    """
    Return the 3D whisker's shape: points (n, 3) [m], foot to tip, with its body frames.

    ``frames`` (n, 3, 3) are the rotations whose columns are (d1, d2, d3): each pose's x axis is
    the tangent, its y axis the direction the intrinsic curvature bends toward.
    """
    path = Path()
    path.header.stamp, path.header.frame_id = stamp, frame
    for (x, y, z), R in zip(points, frames):
        pose = PoseStamped()
        pose.header = path.header
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = (
            float(x), float(y), float(z))
        qw, qx, qy, qz = quat_from_matrix(R)
        o = pose.pose.orientation
        o.x, o.y, o.z, o.w = float(qx), float(qy), float(qz), float(qw)
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
    array = _cleared(frame, stamp)
    corners = []
    for index, ob in enumerate(scene):
        array.markers.append(_outline(ob, index + 1, length, frame, stamp, window, n))
        corners.extend((v.x, v.y) for v in ob.vertices)
    array.markers.append(_corners(corners, len(scene) + 1, length, frame, stamp))
    return array


def _cleared(frame: str, stamp) -> MarkerArray:
    """Return a MarkerArray that starts with a DELETEALL of the namespace ``scene``."""
    array = MarkerArray()
    clear = Marker()
    clear.header.frame_id, clear.header.stamp = frame, stamp
    clear.ns, clear.id, clear.action = "scene", 0, Marker.DELETEALL
    array.markers.append(clear)
    return array


def _scene_marker(kind: int, marker_id: int, name: str, frame: str, stamp) -> Marker:
    marker = Marker()
    marker.header.frame_id, marker.header.stamp = frame, stamp
    marker.ns, marker.id = "scene", marker_id
    marker.type, marker.action = kind, Marker.ADD
    marker.pose.orientation.w = 1.0
    marker.color.r, marker.color.g, marker.color.b, marker.color.a = OBSTACLE_COLOR
    marker.text = name
    return marker


def _outline(ob, marker_id: int, length: float, frame: str, stamp, window, n: int) -> Marker:
    """Return a planar obstacle's outline (LINE_STRIP, z = 0) [m]; ``ob`` in L."""
    marker = _scene_marker(Marker.LINE_STRIP, marker_id, ob.name, frame, stamp)
    marker.scale.x = 0.01 * length
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
    return marker


def _corners(corners, marker_id: int, length: float, frame: str, stamp) -> Marker:
    """Return the POINTS marker of corners and point pegs (x, y in L)."""
    dots = _scene_marker(Marker.POINTS, marker_id, "", frame, stamp)
    dots.scale.x = dots.scale.y = 0.02 * length
    for x, y in corners:
        dots.points.append(Point(x=float(x * length), y=float(y * length)))
    return dots


def _orient_z(marker: Marker, direction) -> None:
    """Turn a marker so that its local z axis points along the unit ``direction``."""
    z = np.asarray(direction, dtype=float)
    helper = np.array((1.0, 0.0, 0.0)) if abs(z[0]) < 0.9 else np.array((0.0, 1.0, 0.0))
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    qw, qx, qy, qz = quat_from_matrix(np.column_stack((x, np.cross(z, x), z)))
    o = marker.pose.orientation
    o.x, o.y, o.z, o.w = float(qx), float(qy), float(qz), float(qw)


def _solid_marker(ob, marker_id: int, length: float, size: float, frame: str,
                  stamp) -> Marker:
    """Return a SPHERE, CYLINDER or CUBE marker of a 3D solid [m]; ``ob`` and ``size`` in L."""
    p = np.asarray(ob.center if isinstance(ob, Sphere) else ob.point, dtype=float)
    if isinstance(ob, Sphere):
        marker = _scene_marker(Marker.SPHERE, marker_id, ob.name, frame, stamp)
        marker.scale.x = marker.scale.y = marker.scale.z = float(2.0 * ob.r * length)
    elif isinstance(ob, Cylinder):
        marker = _scene_marker(Marker.CYLINDER, marker_id, ob.name, frame, stamp)
        _orient_z(marker, ob.axis)
        marker.scale.x = marker.scale.y = float(2.0 * ob.r * length)
        marker.scale.z = float(size * length)
    else:  # a plane: a thin slab whose top face is the surface
        marker = _scene_marker(Marker.CUBE, marker_id, ob.name, frame, stamp)
        _orient_z(marker, ob.normal)
        thickness = 0.01
        p = p - 0.5 * thickness * np.asarray(ob.normal)
        marker.scale.x = marker.scale.y = float(size * length)
        marker.scale.z = float(thickness * length)
    marker.color.a = 0.6
    marker.pose.position.x, marker.pose.position.y, marker.pose.position.z = (
        float(v * length) for v in p)
    return marker


def scene3d_markers(scene, length: float, frame: str, stamp, size: float = 4.0,
                    n: int = 200) -> MarkerArray:
    """
    Return every obstacle of a 3D scene as a MarkerArray [m] (latched; model rod3d).

    A DELETEALL first (namespace ``scene``), then per obstacle (id = 1 + its index, ``text`` =
    its name): a SPHERE; a CYLINDER along its axis, ``size`` whisker lengths long, centred at its
    ``point``; a plane as a thin CUBE (``size`` L square, 0.01 L thick, its top face the surface,
    centred below its ``point``); a prism as the planar obstacle's LINE_STRIP in z = 0 (as
    :func:`scene_markers` draws it); then one POINTS marker of the prisms' corners.
    ``length`` [m] is the whisker's length (the scene's lengths are in L).
    """
    array = _cleared(frame, stamp)
    prisms = [ob.planar for ob in scene if not isinstance(ob, (Sphere, Cylinder, Plane))]
    window = None
    if prisms:
        boxes = np.array([ob.extent() for ob in prisms])
        window = (float(boxes[:, 0].min() - 2.0), float(boxes[:, 1].min() - 2.0),
                  float(boxes[:, 2].max() + 2.0), float(boxes[:, 3].max() + 2.0))
    corners = []
    for index, ob in enumerate(scene):
        if isinstance(ob, (Sphere, Cylinder, Plane)):
            array.markers.append(_solid_marker(ob, index + 1, length, size, frame, stamp))
        else:
            array.markers.append(_outline(ob.planar, index + 1, length, frame, stamp, window, n))
            corners.extend((v.x, v.y) for v in ob.planar.vertices)
    array.markers.append(_corners(corners, len(scene) + 1, length, frame, stamp))
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
    first strip's. A 3D scene without planar outlines (only spheres, cylinders, planes): its
    first solid's marker instead.
    """
    strips = [mk for mk in array.markers
              if mk.action == Marker.ADD and mk.type == Marker.LINE_STRIP]
    kinds = (Marker.SPHERE, Marker.CYLINDER, Marker.CUBE)
    solids = [mk for mk in array.markers if mk.action == Marker.ADD and mk.type in kinds]
    if solids and not strips:  # a 3D scene of solids only: its first one
        marker = copy.deepcopy(solids[0])
        marker.ns, marker.id = "obstacle", 0
        return marker
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
    ("obstacle", PointField.UINT32, "<u4", 52), ("fz", PointField.FLOAT64, "<f8", 56),
)
#: fields a cloud may lack (clouds recorded before the 3D whisker): read as 0
OPTIONAL_CONTACT_FIELDS = ("fz",)
CONTACT_POINT_STEP = 64
CONTACT_DTYPE = np.dtype({"names": [f[0] for f in CONTACT_FIELDS],
                          "formats": [f[2] for f in CONTACT_FIELDS],
                          "offsets": [f[3] for f in CONTACT_FIELDS],
                          "itemsize": CONTACT_POINT_STEP})

_CONTACT_POINT_FIELDS = [PointField(name=name, offset=offset, datatype=kind, count=1)
                         for name, kind, _, offset in CONTACT_FIELDS]


def contact_points(contacts: Sequence[ContactRecord]) -> bytes:
    """Return the data of a ``~/contacts`` cloud: one CONTACT_POINT_STEP-byte point a contact."""
    points = np.zeros(len(contacts), dtype=CONTACT_DTYPE)
    for i, c in enumerate(contacts):
        points[i] = (float(c.x), float(c.y), float(c.z), float(c.fx), float(c.fy), float(c.s),
                     int(c.kind), int(c.state), int(c.obstacle), float(c.fz))
    return points.tobytes()


def contacts_cloud(stamp, frame: str, contacts: Sequence[ContactRecord]) -> PointCloud2:
    """
    Return every contact of a pose as a PointCloud2 (one point per contact, foot to tip).

    Fields (little-endian; float64 so that nothing is lost to rounding): x, y, z [m] (z = 0 but
    for the 3D whisker), fx, fy [N] (the obstacle's force on the whisker, world frame), s [m]
    (arc length), kind (uint8: 0 side, 1 tip, 2 corner), state (uint8: 0 slip, 1 stick),
    obstacle (uint32, its index), fz [N] (0 but for the 3D whisker). No contact: an empty cloud
    (width 0).
    """
    cloud = PointCloud2()
    cloud.header.stamp, cloud.header.frame_id = stamp, frame
    cloud.height, cloud.width = 1, len(contacts)
    cloud.fields = _CONTACT_POINT_FIELDS  # shared: never changed once built
    cloud.is_bigendian = False
    cloud.point_step = CONTACT_POINT_STEP
    cloud.row_step = CONTACT_POINT_STEP * len(contacts)
    cloud.data = contact_points(contacts)
    cloud.is_dense = True
    return cloud


def decode_contacts(cloud) -> Tuple[ContactRecord, ...]:
    """
    Read the contacts back from a ``~/contacts`` cloud (by its field table, not by position).

    Raises ValueError if a field is missing or the cloud is not little-endian (``fz``, which
    older recordings lack, reads as 0).
    """
    if cloud.is_bigendian:
        raise ValueError("a big-endian contacts cloud")
    names, formats, offsets = [], [], []
    types = {PointField.FLOAT64: "<f8", PointField.UINT8: "u1", PointField.UINT32: "<u4"}
    by_name = {f.name: f for f in cloud.fields}
    for name, _, _, _ in CONTACT_FIELDS:
        if name in OPTIONAL_CONTACT_FIELDS and name not in by_name:
            continue
        if name not in by_name or by_name[name].datatype not in types:
            raise ValueError(f"the contacts cloud has no field {name!r} of a known type")
        names.append(name)
        formats.append(types[by_name[name].datatype])
        offsets.append(by_name[name].offset)
    dtype = np.dtype({"names": names, "formats": formats, "offsets": offsets,
                      "itemsize": cloud.point_step})
    n = cloud.width * cloud.height
    points = np.frombuffer(bytes(cloud.data), dtype=dtype, count=n)
    fz = "fz" in names
    return tuple(ContactRecord(float(p["x"]), float(p["y"]), float(p["fx"]), float(p["fy"]),
                               float(p["s"]), int(p["kind"]), int(p["state"]),
                               int(p["obstacle"]), float(p["z"]),
                               float(p["fz"]) if fz else 0.0) for p in points)


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
