"""
The messages of array_node, built by pure functions (no node, no DDS: unit-testable).

The tick's one message is a ``sensor_msgs/PointCloud2`` with one point per whisker and the named
fields of :data:`~vibrissa_ros.node.array.ARRAY_FIELDS` (:func:`wrenches_cloud`, read back by
:func:`decode_cloud`); the whiskers' names and frames are a latched JSON string
(:func:`whiskers_msg`).
"""

from __future__ import annotations

import json
import struct
from functools import lru_cache
from typing import Mapping, Optional, Sequence, Tuple

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Point
from sensor_msgs.msg import JointState, PointCloud2, PointField
from builtin_interfaces.msg import Time
from rclpy.serialization import serialize_message
from std_msgs.msg import String
from visualization_msgs.msg import Marker, MarkerArray

from ..core.arrays import ArrayStep, WhiskerArray
from ..node.array import ALL_JOINT, ARRAY_DTYPE
from .cdr import MARK_NSEC, MARK_SEC, STAMP, CloudEncoder, find_marker, template_or_none
from .messages import diagnostic_status

_DATATYPES = {"<f8": PointField.FLOAT64, "<u4": PointField.UINT32, "|u1": PointField.UINT8}
_NUMPY = {PointField.FLOAT64: "<f8", PointField.UINT32: "<u4", PointField.UINT8: "u1",
          PointField.FLOAT32: "<f4", PointField.INT32: "<i4"}
#: colours of a whisker's shape: free, in contact
FREE_COLOR = (0.55, 0.55, 0.55, 1.0)
CONTACT_COLOR = (0.84, 0.15, 0.16, 1.0)


def point_fields(dtype: np.dtype) -> list:
    """Return the PointField table of a structured numpy dtype (little-endian)."""
    fields = []
    for name in dtype.names:
        kind, offset = dtype.fields[name][:2]
        fields.append(PointField(name=name, offset=int(offset), datatype=_DATATYPES[kind.str],
                                 count=1))
    return fields


WRENCH_POINT_FIELDS = point_fields(ARRAY_DTYPE)


def wrenches_cloud(msg: PointCloud2, stamp, frame: str, rows: np.ndarray) -> PointCloud2:
    """
    Write a tick's rows into ``msg`` (reused), one point per whisker.

    Parameters
    ----------
    msg : PointCloud2
        The message filled (its field table is set once).
    stamp : builtin_interfaces.msg.Time
        The tick's stamp.
    frame : str
        The world frame (of x, y, z and the contact point; forces are in each base frame).
    rows : numpy.ndarray
        (k,) rows of :data:`~vibrissa_ros.node.array.ARRAY_DTYPE`.

    Returns
    -------
    PointCloud2
        ``msg``.

    """
    msg.header.stamp, msg.header.frame_id = stamp, frame
    if not msg.fields:
        msg.fields = WRENCH_POINT_FIELDS
        msg.is_bigendian, msg.is_dense, msg.height = False, True, 1
        msg.point_step = ARRAY_DTYPE.itemsize
    msg.width = len(rows)
    msg.row_step = ARRAY_DTYPE.itemsize * len(rows)
    msg.data = rows.tobytes()
    return msg


@lru_cache(maxsize=None)
def _wrenches_encoder(frame: str) -> Optional[CloudEncoder]:
    return template_or_none(lambda: CloudEncoder(wrenches_cloud(PointCloud2(), Time(), frame,
                                                                np.zeros(0, ARRAY_DTYPE))))


def wrenches_cdr(stamp, frame: str, rows: np.ndarray) -> bytes:
    """
    Return :func:`wrenches_cloud`'s message serialized, from a template (what publish takes).

    The node's one message per tick: building the PointCloud2 object and serializing it (its
    25 fields every time) cost ~60 us a tick, and as much again to record it; this packs the
    stamp and the rows into a copy of the serialized template (~2 us), and the same bytes are
    published and recorded.

    Parameters
    ----------
    stamp : builtin_interfaces.msg.Time
        The tick's stamp.
    frame : str
        The world frame.
    rows : numpy.ndarray
        (k,) rows of :data:`~vibrissa_ros.node.array.ARRAY_DTYPE`.

    Returns
    -------
    bytes
        The serialized sensor_msgs/PointCloud2.

    """
    rows = np.ascontiguousarray(rows, dtype=ARRAY_DTYPE)
    encoder = _wrenches_encoder(frame)
    if encoder is None:
        return serialize_message(wrenches_cloud(PointCloud2(), stamp, frame, rows))
    return encoder.encode(stamp, len(rows), rows.tobytes())


def decode_cloud(cloud) -> np.ndarray:
    """
    Read a PointCloud2's points by its field table into a structured array.

    Parameters
    ----------
    cloud : PointCloud2
        A little-endian cloud (``~/wrenches``, ``~/contacts``).

    Returns
    -------
    numpy.ndarray
        (width * height,) structured rows, one field per PointField.

    Raises
    ------
    ValueError
        When the cloud is big-endian or has a field of another type.

    """
    if cloud.is_bigendian:
        raise ValueError("a big-endian cloud")
    names, formats, offsets = [], [], []
    for f in cloud.fields:
        if f.datatype not in _NUMPY:
            raise ValueError(f"field {f.name!r} has the PointField datatype {f.datatype}")
        names.append(f.name)
        formats.append(_NUMPY[f.datatype])
        offsets.append(f.offset)
    dtype = np.dtype({"names": names, "formats": formats, "offsets": offsets,
                      "itemsize": cloud.point_step})
    return np.frombuffer(bytes(cloud.data), dtype=dtype, count=cloud.width * cloud.height)


def whiskers_msg(array: WhiskerArray, head_frame: str) -> String:
    """
    Return the latched ``~/whiskers``: the whiskers' order, names, frames and morphology (JSON).

    ``{"names": [...], "frames": ["<head_frame>/<name>", ...], "sides", "rows", "columns",
    "lengths" [m], "fields": [the ~/wrenches field names]}``; a point's ``index`` field is the
    position in these lists.
    """
    data = {
        "names": list(array.names),
        "frames": [f"{head_frame}/{w.name}" for w in array],
        "sides": [w.side for w in array],
        "rows": [w.row for w in array],
        "columns": [w.column for w in array],
        "lengths": [w.length for w in array],
        "fields": list(ARRAY_DTYPE.names),
    }
    return String(data=json.dumps(data))


def protraction_msg(stamp, angle: float) -> JointState:
    """Return the built-in whisk's angle of a tick: one joint, ``whisk`` [rad]."""
    msg = JointState()
    msg.header.stamp = stamp
    msg.name = [ALL_JOINT]
    msg.position = [float(angle)]
    return msg


def shapes_markers(stamp, frame: str, names: Sequence[str], lines: np.ndarray,
                   contacts: np.ndarray, width: float = 1e-4) -> MarkerArray:
    """
    Return every whisker's shape as a LINE_STRIP (namespace ``whiskers``, id = its index) [m].

    ``lines`` (k, n, 3) in the world frame; a whisker in contact is drawn red, a free one grey;
    ``text`` is the whisker's name.
    """
    array = MarkerArray()
    for i, name in enumerate(names):
        marker = Marker()
        marker.header.stamp, marker.header.frame_id = stamp, frame
        marker.ns, marker.id = "whiskers", i
        marker.type, marker.action = Marker.LINE_STRIP, Marker.ADD
        marker.pose.orientation.w = 1.0
        marker.scale.x = float(width)
        c = marker.color
        c.r, c.g, c.b, c.a = CONTACT_COLOR if contacts[i] else FREE_COLOR
        marker.text = name
        marker.points = [Point(x=float(x), y=float(y), z=float(z)) for x, y, z in lines[i]]
        array.markers.append(marker)
    return array


class _ShapesEncoder:
    """:func:`shapes_markers`' MarkerArray of fixed whiskers and points, serialized by template."""

    def __init__(self, frame: str, names: Tuple[str, ...], n: int, width: float):
        k = len(names)
        # every value the encoder writes is a marker value nobody else writes: the stamp, each
        # whisker's first point and its colour
        lines = np.zeros((k, n, 3))
        lines[:, 0, 0] = -1.2345678901234e-290 * (np.arange(k) + 1.0)
        template = shapes_markers(Time(sec=MARK_SEC, nanosec=MARK_NSEC), frame, names, lines,
                                  np.zeros(k), width)
        for i, marker in enumerate(template.markers):
            c = marker.color
            c.r, c.g, c.b, c.a = (float(np.float32(v)) for v in (0.123, 0.456, 0.789, i + 0.5))
        data = serialize_message(template)
        stamp = STAMP.pack(MARK_SEC, MARK_NSEC)
        self._stamps = [at for at in _all(data, stamp)]
        self._points = [find_marker(data, struct.pack("<d", lines[i, 0, 0]))
                        for i in range(k)]
        self._colors = [find_marker(data, _COLOR.pack(0.123, 0.456, 0.789, i + 0.5))
                        for i in range(k)]
        if len(self._stamps) != k or any(data[at - 4:at] != struct.pack("<I", n)
                                         and data[at - 8:at - 4] != struct.pack("<I", n)
                                         for at in self._points):
            raise RuntimeError("the serialized MarkerArray does not have the expected layout")
        self._template = data
        self._n = n

    def encode(self, stamp, lines: np.ndarray, contacts) -> bytes:
        out = bytearray(self._template)
        for at in self._stamps:
            STAMP.pack_into(out, at, stamp.sec, stamp.nanosec)
        lines = np.ascontiguousarray(lines, dtype="<f8")
        size = 24 * self._n
        for i, (at, color) in enumerate(zip(self._points, self._colors)):
            out[at:at + size] = lines[i].tobytes()
            _COLOR.pack_into(out, color, *(CONTACT_COLOR if contacts[i] else FREE_COLOR))
        return bytes(out)


_COLOR = struct.Struct("<4f")


def _all(data: bytes, marker: bytes):
    at = data.find(marker)
    while at >= 0:
        yield at
        at = data.find(marker, at + 1)


@lru_cache(maxsize=8)
def _shapes_encoder(frame: str, names: Tuple[str, ...], n: int,
                    width: float) -> Optional[_ShapesEncoder]:
    return template_or_none(lambda: _ShapesEncoder(frame, names, n, width))


def shapes_cdr(stamp, frame: str, names: Sequence[str], lines: np.ndarray, contacts: np.ndarray,
               width: float = 1e-4) -> bytes:
    """
    Return :func:`shapes_markers`' MarkerArray serialized, from a template (what publish takes).

    Building 30 markers of 21 points as message objects and serializing them took ~2.5 ms, a
    stall of the solving thread at every display tick; this packs the stamps, the points and
    the colours into a copy of the serialized template (~30 us).

    Parameters
    ----------
    stamp : builtin_interfaces.msg.Time
        The stamp of every marker.
    frame : str
        The world frame.
    names : sequence of str
        The whiskers' names (each marker's text).
    lines : numpy.ndarray
        (k, n, 3) the centerlines in the world frame [m].
    contacts : numpy.ndarray
        (k,) each whisker's number of contacts (drawn red where > 0, else grey).
    width : float, optional
        The line width [m].

    Returns
    -------
    bytes
        The serialized visualization_msgs/MarkerArray.

    """
    lines = np.asarray(lines, dtype=float)
    if lines.ndim != 3 or lines.shape[0] != len(names) or lines.shape[2] != 3:
        raise ValueError(f"lines of shape {lines.shape} for {len(names)} whiskers: (k, n, 3) "
                         "is needed, k the number of names")
    encoder = _shapes_encoder(frame, tuple(names), int(lines.shape[1]), float(width))
    if encoder is None:
        return serialize_message(shapes_markers(stamp, frame, names, lines, contacts, width))
    return encoder.encode(stamp, lines, contacts)


CONTACT_DTYPE = np.dtype([("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("fx", "<f8"),
                          ("fy", "<f8"), ("fz", "<f8"), ("s", "<f8"), ("f", "<f8"),
                          ("index", "<u4"), ("kind", "u1"), ("obstacle", "u1")])
CONTACT_POINT_FIELDS = point_fields(CONTACT_DTYPE)


def contacts_cloud(stamp, frame: str, step: ArrayStep, rows: np.ndarray) -> PointCloud2:
    """
    Return the whiskers in contact as a PointCloud2, one point per whisker at its contact.

    Fields: x, y, z [m] (the contact nearest the base, world frame), fx, fy, fz [N] (the total
    contact force on the whisker, world frame), s [m], f [N], index, kind (1 side, 2 tip),
    obstacle (index + 1). No contact: an empty cloud.
    """
    touching = np.flatnonzero(step.contacts)
    points = np.zeros(len(touching), dtype=CONTACT_DTYPE)
    points["x"], points["y"], points["z"] = step.contact_point[touching].T
    points["fx"], points["fy"], points["fz"] = step.force[touching].T
    for name in ("s", "f", "index", "kind", "obstacle"):
        points[name] = rows[name][touching]
    cloud = PointCloud2()
    cloud.header.stamp, cloud.header.frame_id = stamp, frame
    cloud.fields = CONTACT_POINT_FIELDS
    cloud.is_bigendian, cloud.is_dense, cloud.height = False, True, 1
    cloud.point_step = CONTACT_DTYPE.itemsize
    cloud.width = len(points)
    cloud.row_step = CONTACT_DTYPE.itemsize * len(points)
    cloud.data = points.tobytes()
    return cloud


def whisker_status(node_name: str, name: str, values: Mapping[str, object],
                   last_error: str) -> DiagnosticStatus:
    """Return one whisker's status: WARN after a failed step (the last one said), else OK."""
    if last_error:
        level, message = DiagnosticStatus.WARN, f"step failed: {last_error}"
    else:
        level = DiagnosticStatus.OK
        message = f"{values['contacts']} contact(s)"
    status = diagnostic_status(f"{node_name}/{name}", level, message, values)
    return status


def node_status(node_name: str, values: Mapping[str, object], problems: Sequence[str]
                ) -> DiagnosticStatus:
    """Return the node's status: ERROR if a recording failed, WARN after drops or skips."""
    if values.get("recording_error"):
        level, message = DiagnosticStatus.ERROR, f"not recording: {values['recording_error']}"
    elif problems:
        level, message = DiagnosticStatus.WARN, "; ".join(problems)
    else:
        level, message = DiagnosticStatus.OK, "keeping up"
    return diagnostic_status(node_name, level, message, values)
