"""
tf2_msgs/msg/TFMessage without its wheel: frames for a log, as CDR bytes.

No tf2_msgs package is installed with these wheels, so no node here can publish ``/tf``. The
array node's recording carries its whiskers' base frames on ``/tf`` all the same, because
Foxglove's 3D panel and ``ros2 bag play`` into RViz place frames by it: the channel's schema is
composed of installed types (:mod:`vibrissa_ros.logs.mcap_log`), and its messages are encoded
here field by field, as rmw's CDR (XCDR1, little endian) lays them out: 4-byte encapsulation
header, then every field aligned to its size counted from the end of that header.
"""

from __future__ import annotations

import struct
from typing import Sequence

from ..logs.mcap_log import TopicSpec

#: the frames' topic and type (tf2's)
TF_TOPIC = "/tf"
TF_TYPE = "tf2_msgs/msg/TFMessage"
#: the recording's /tf channel: as tf2_ros's TransformBroadcaster offers it (reliable, depth 100)
TF_SPEC = TopicSpec(TF_TOPIC, TF_TYPE, reliable=True, transient_local=False, depth=100)

_HEADER = b"\x00\x01\x00\x00"  # CDR, little endian, no options
_U32 = struct.Struct("<I")
_STAMP = struct.Struct("<iI")
_POSE = struct.Struct("<7d")


class _Writer:
    """CDR writer: little endian, alignment counted from the end of the encapsulation header."""

    def __init__(self):
        self.buf = bytearray(_HEADER)

    def align(self, n: int) -> None:
        self.buf.extend(b"\0" * (-(len(self.buf) - len(_HEADER)) % n))

    def u32(self, value: int) -> None:
        self.align(4)
        self.buf.extend(_U32.pack(value))

    def string(self, text: str) -> None:
        data = text.encode("utf-8")
        self.u32(len(data) + 1)  # the length counts the terminating NUL
        self.buf.extend(data + b"\0")


def tf_message_cdr(sec: int, nanosec: int, parent: str, children: Sequence[str],
                   positions, quaternions) -> bytes:
    """
    Return the CDR bytes of a TFMessage: one transform from ``parent`` to each child frame.

    Parameters
    ----------
    sec, nanosec : int
        The transforms' stamp (builtin_interfaces/Time).
    parent : str
        The parent frame of every transform (header.frame_id).
    children : sequence of str
        The child frames (child_frame_id), one per transform.
    positions : array_like
        (k, 3): each child frame's origin in the parent frame [m].
    quaternions : array_like
        (k, 4): each child frame's orientation in the parent frame, (w, x, y, z) (scalar first,
        as :class:`~vibrissa_ros.core.rod3d.pose.BasePose`); written x, y, z, w as
        geometry_msgs/Quaternion orders them.

    Returns
    -------
    bytes
        The serialized message.

    """
    out = _Writer()
    out.u32(len(children))
    for child, p, q in zip(children, positions, quaternions):
        out.align(4)
        out.buf.extend(_STAMP.pack(int(sec), int(nanosec)))
        out.string(parent)
        out.string(child)
        out.align(8)
        w, x, y, z = (float(v) for v in q)
        out.buf.extend(_POSE.pack(float(p[0]), float(p[1]), float(p[2]), x, y, z, w))
    return bytes(out.buf)
