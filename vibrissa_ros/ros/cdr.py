"""
The per-pose messages of whisker_node straight to CDR bytes (``publisher.publish`` takes them).

Building a message object and serializing it costs 5 to 40 us a message in Python; at 1 kHz and
seven messages a pose that is more than the solve. Each encoder here serializes one template
message with rclpy once (per type and frame), finds where its stamp and values lie by writing
marker values into it, and then only packs the new numbers into a copy: the bytes are those
rclpy writes, padding and all, and every reader decodes them as the message the builders of
:mod:`.messages` return (``test/test_cdr.py`` checks each against them).
"""

from __future__ import annotations

import struct
from functools import lru_cache
from typing import Optional, Sequence, Tuple

from geometry_msgs.msg import PointStamped, Vector3Stamped, WrenchStamped
from rclpy.serialization import serialize_message
from builtin_interfaces.msg import Time
from std_msgs.msg import Float64, UInt8

from ..node.edge import ContactRecord
from .messages import contact_points, contacts_cloud, fill_wrench6, point_stamped, vector_stamped

#: a header's stamp (builtin_interfaces/Time) as CDR lays it out
STAMP = struct.Struct("<iI")
#: the stamp a template carries, to be found in its bytes: no other field holds it
MARK_SEC, MARK_NSEC = 0x1A2B3C4D, 0x2B3C4D5E
_MARKS = (1.0e-301, 2.0e-302, 3.0e-303, 4.0e-304, 5.0e-305, 6.0e-306)  # values nobody writes


def find_marker(data: bytes, marker: bytes) -> int:
    """
    Return where ``marker`` lies in a serialized template, once and only once.

    Raises RuntimeError where it is not there, or more than once (the template's layout is not
    the one expected).
    """
    at = data.find(marker)
    if at < 0 or data.find(marker, at + 1) >= 0:
        raise RuntimeError("the serialized template does not have the expected layout")
    return at


def _stamped_template(msg) -> Tuple[bytes, int]:
    """Serialize ``msg`` (its stamp set to the markers); return it and the stamp's offset."""
    msg.header.stamp.sec, msg.header.stamp.nanosec = MARK_SEC, MARK_NSEC
    data = serialize_message(msg)
    return data, find_marker(data, STAMP.pack(MARK_SEC, MARK_NSEC))


class _Doubles:
    """A message of fixed layout whose stamp (if any) and n float64 values change."""

    def __init__(self, msg, set_values, n: int, stamped: bool = True):
        set_values(msg, _MARKS[:n])
        if stamped:
            data, self._stamp_at = _stamped_template(msg)
        else:
            data, self._stamp_at = serialize_message(msg), -1
        self._values = struct.Struct(f"<{n}d")
        self._values_at = find_marker(data, self._values.pack(*_MARKS[:n]))
        self._template = data

    def encode(self, stamp, values: Sequence[float]) -> bytes:
        out = bytearray(self._template)
        if self._stamp_at >= 0:
            STAMP.pack_into(out, self._stamp_at, stamp.sec, stamp.nanosec)
        self._values.pack_into(out, self._values_at, *values)
        return bytes(out)


def _set_wrench(msg, v):
    f, t = msg.wrench.force, msg.wrench.torque
    f.x, f.y, f.z, t.x, t.y, t.z = v


def _set_vector(msg, v):
    msg.vector.x, msg.vector.y, msg.vector.z = v


def _set_point(msg, v):
    msg.point.x, msg.point.y, msg.point.z = v


def _set_data(msg, v):
    msg.data = v[0]


def template_or_none(make):
    """
    Return the template ``make()`` builds, or None where its layout is not found.

    A frame name that holds a marker's bytes (a contrived name; frames and whisker names are
    otherwise free) leaves no unique marker: the encoder then serializes the builder's message.
    """
    try:
        return make()
    except RuntimeError:
        return None


@lru_cache(maxsize=None)
def _wrench(frame: str) -> Optional[_Doubles]:
    msg = WrenchStamped()
    msg.header.frame_id = frame
    return template_or_none(lambda: _Doubles(msg, _set_wrench, 6))


@lru_cache(maxsize=None)
def _vector(frame: str) -> Optional[_Doubles]:
    msg = Vector3Stamped()
    msg.header.frame_id = frame
    return template_or_none(lambda: _Doubles(msg, _set_vector, 3))


@lru_cache(maxsize=None)
def _point(frame: str) -> Optional[_Doubles]:
    msg = PointStamped()
    msg.header.frame_id = frame
    return template_or_none(lambda: _Doubles(msg, _set_point, 3))


_FLOAT = _Doubles(Float64(), _set_data, 1, stamped=False)
_UINT8 = serialize_message(UInt8(data=0x5A))
_UINT8_AT = 4  # right after the encapsulation header; padding follows
if _UINT8[_UINT8_AT] != 0x5A:  # pragma: no cover - a layout rclpy does not write
    raise RuntimeError("the serialized std_msgs/UInt8 does not have the expected layout")


def _xyz(v: Sequence[float]) -> Tuple[float, float, float]:
    return float(v[0]), float(v[1]), float(v[2]) if len(v) > 2 else 0.0


def wrench_cdr(stamp, frame: str, force: Sequence[float], torque: Sequence[float]) -> bytes:
    """Return a geometry_msgs/WrenchStamped: force (x, y, z) [N], torque (x, y, z) [N m]."""
    encoder = _wrench(frame)
    if encoder is None:
        return serialize_message(fill_wrench6(WrenchStamped(), stamp, frame, _xyz(force),
                                              _xyz(torque)))
    return encoder.encode(stamp, (*_xyz(force), *_xyz(torque)))


def vector_cdr(stamp, frame: str, xy: Sequence[float]) -> bytes:
    """Return a geometry_msgs/Vector3Stamped of (x, y) (z = 0) or (x, y, z), as vector_stamped."""
    encoder = _vector(frame)
    if encoder is None:
        return serialize_message(vector_stamped(stamp, frame, _xyz(xy)))
    return encoder.encode(stamp, _xyz(xy))


def point_cdr(stamp, frame: str, xy: Sequence[float]) -> bytes:
    """Return a geometry_msgs/PointStamped of (x, y) (z = 0) or (x, y, z), as point_stamped."""
    encoder = _point(frame)
    if encoder is None:
        return serialize_message(point_stamped(stamp, frame, _xyz(xy)))
    return encoder.encode(stamp, _xyz(xy))


def float_cdr(value: float) -> bytes:
    """Return a std_msgs/Float64."""
    return _FLOAT.encode(None, (float(value),))


def uint8_cdr(value: int) -> bytes:
    """Return a std_msgs/UInt8 (the phase)."""
    out = bytearray(_UINT8)
    out[_UINT8_AT] = int(value)
    return bytes(out)


class CloudEncoder:
    """
    A PointCloud2 of fixed fields and frame (one row): stamp, width, row_step and data change.

    Parameters
    ----------
    msg : sensor_msgs.msg.PointCloud2
        The template: its frame, fields, point_step and flags (no points; height 1, dense).

    """

    _MARK_WIDTH, _MARK_ROW = 0x3C4D5E6F, 0x4D5E6F70

    def __init__(self, msg):
        msg.width, msg.row_step = self._MARK_WIDTH, self._MARK_ROW
        data, self._stamp_at = _stamped_template(msg)
        self._width_at = find_marker(data, struct.pack("<I", self._MARK_WIDTH))
        # row_step, then the data's length 0
        row_at = find_marker(data, struct.pack("<II", self._MARK_ROW, 0))
        self._head = data[:row_at]
        self._tail = data[row_at + 8:]  # is_dense and what follows

    def encode(self, stamp, n: int, points: bytes) -> bytes:
        """
        Return the cloud of ``n`` points: ``points`` are their bytes (n times point_step).

        Parameters
        ----------
        stamp : builtin_interfaces.msg.Time
            The header's stamp.
        n : int
            The number of points (width; row_step is the data's length).
        points : bytes
            The points' data.

        Returns
        -------
        bytes
            The serialized message (what ``publisher.publish`` takes).

        """
        head = bytearray(self._head)
        STAMP.pack_into(head, self._stamp_at, stamp.sec, stamp.nanosec)
        struct.pack_into("<I", head, self._width_at, n)
        return b"".join((head, struct.pack("<II", len(points), len(points)), points, self._tail))


@lru_cache(maxsize=None)
def _cloud(frame: str) -> Optional[CloudEncoder]:
    return template_or_none(lambda: CloudEncoder(contacts_cloud(Time(), frame, ())))


def contacts_cdr(stamp, frame: str, contacts: Sequence[ContactRecord]) -> bytes:
    """Return the ``~/contacts`` sensor_msgs/PointCloud2 of :func:`.messages.contacts_cloud`."""
    encoder = _cloud(frame)
    if encoder is None:
        return serialize_message(contacts_cloud(stamp, frame, contacts))
    points = contact_points(contacts) if contacts else b""
    return encoder.encode(stamp, len(contacts), points)
