"""The per-pose messages as CDR bytes decode as the messages the builders return."""

import pytest
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PointStamped, Vector3Stamped, WrenchStamped
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Float64, UInt8

from vibrissa_ros.logs.mcap_log import message_definition
from vibrissa_ros.node.edge import ContactRecord
from vibrissa_ros.ros import cdr
from vibrissa_ros.ros import messages as m

STAMP = Time(sec=1_795_000_123, nanosec=987_654_321)
CONTACTS = (ContactRecord(0.01, -0.02, 0.3, -0.4, 0.05, 1, 0, 2, 0.001, 0.5),
            ContactRecord(-1e-300, 2.5, 1e300, -0.0, 0.07, 0, 1, 0, 0.0, 0.0))


def _same(got, want):
    assert serialize_message(got) == serialize_message(want) or repr(got) == repr(want)
    assert repr(got) == repr(want)


@pytest.mark.parametrize("frame", ["world", "whisker_base", "a/longer_frame_name", ""])
def test_stamped_messages_decode_as_the_builders_messages(frame):
    force, torque = (1.25, -2.5e-7, 3.0), (-4.0, 5e9, -6.125)
    want = m.fill_wrench6(WrenchStamped(), STAMP, frame, force, torque)
    _same(deserialize_message(cdr.wrench_cdr(STAMP, frame, force, torque), WrenchStamped), want)
    planar = m.fill_wrench(WrenchStamped(), STAMP, frame, force[:2], torque[2])
    got = cdr.wrench_cdr(STAMP, frame, force[:2] + (0.0,), (0.0, 0.0, torque[2]))
    _same(deserialize_message(got, WrenchStamped), planar)
    for xy in ((0.1, -0.2), (0.1, -0.2, 0.3)):
        _same(deserialize_message(cdr.vector_cdr(STAMP, frame, xy), Vector3Stamped),
              m.vector_stamped(STAMP, frame, xy))
        _same(deserialize_message(cdr.point_cdr(STAMP, frame, xy), PointStamped),
              m.point_stamped(STAMP, frame, xy))


@pytest.mark.parametrize("n", [0, 1, 2])
def test_the_contacts_cloud_decodes_as_the_builders_cloud(n):
    want = m.contacts_cloud(STAMP, "world", CONTACTS[:n])
    got = deserialize_message(cdr.contacts_cdr(STAMP, "world", CONTACTS[:n]), PointCloud2)
    _same(got, want)
    assert m.decode_contacts(got) == m.decode_contacts(want)


@pytest.mark.parametrize("k", [0, 1, 30, 60])
def test_the_array_wrenches_cloud_decodes_as_the_builders_cloud(k):
    import numpy as np

    from vibrissa_ros.node.array import ARRAY_DTYPE
    from vibrissa_ros.ros import array_messages as am

    rng = np.random.default_rng(k)
    rows = np.zeros(k, dtype=ARRAY_DTYPE)
    for name in ARRAY_DTYPE.names:
        rows[name] = (rng.normal(size=k) * 1e-3 if ARRAY_DTYPE[name].kind == "f"
                      else rng.integers(0, 3, size=k))
    want = am.wrenches_cloud(PointCloud2(), STAMP, "world", rows)
    got = deserialize_message(am.wrenches_cdr(STAMP, "world", rows), PointCloud2)
    _same(got, want)
    assert np.array_equal(am.decode_cloud(got), rows)


@pytest.mark.parametrize("k, n", [(1, 2), (30, 21), (60, 5)])
def test_the_array_shapes_decode_as_the_builders_markers(k, n):
    import numpy as np
    from visualization_msgs.msg import MarkerArray

    from vibrissa_ros.ros import array_messages as am

    rng = np.random.default_rng(k)
    names = [f"W{i}" for i in range(k)]
    for contacts in (rng.integers(0, 3, size=k), np.zeros(k, int)):
        lines = rng.normal(size=(k, n, 3)) * 0.01
        want = am.shapes_markers(STAMP, "world", names, lines, contacts)
        data = am.shapes_cdr(STAMP, "world", names, lines, contacts)
        # as rclpy writes it, decoded (padding bytes are not compared: Fast CDR leaves them
        # as they were; a colour is float32: the builder's own message has its doubles)
        got = deserialize_message(data, MarkerArray)
        assert repr(got) == repr(deserialize_message(serialize_message(want), MarkerArray))
        assert [m.text for m in got.markers] == names
        assert np.array_equal([[(p.x, p.y, p.z) for p in m.points] for m in got.markers], lines)


def test_scalars_decode_as_the_builders_messages():
    for value in (0.0, -1.5, 1e-300, float("inf")):
        _same(deserialize_message(cdr.float_cdr(value), Float64), m.float_msg(value))
    for phase in (0, 1, 2, 255):
        _same(deserialize_message(cdr.uint8_cdr(phase), UInt8), m.phase_msg(phase))


def test_the_other_ros2_decoder_reads_them_too():
    """mcap-ros2-support, which Foxglove's tools use, decodes the bytes from the schema."""
    factory = DecoderFactory()
    ids = {}

    def decode(type_name, data):
        schema = Schema(id=ids.setdefault(type_name, len(ids) + 1), name=type_name,
                        encoding="ros2msg", data=message_definition(type_name).encode())
        return factory.decoder_for("cdr", schema)(data)

    wrench = decode("geometry_msgs/msg/WrenchStamped",
                    cdr.wrench_cdr(STAMP, "whisker_base", (1.0, 2.0, 0.0), (0.0, 0.0, 3.0)))
    assert wrench.header.frame_id == "whisker_base" and wrench.wrench.torque.z == 3.0
    assert wrench.header.stamp.nanosec == STAMP.nanosec
    cloud = decode("sensor_msgs/msg/PointCloud2", cdr.contacts_cdr(STAMP, "world", CONTACTS))
    assert cloud.width == 2 and cloud.point_step == m.CONTACT_POINT_STEP and cloud.is_dense
    assert decode("std_msgs/msg/UInt8", cdr.uint8_cdr(2)).data == 2


def test_a_name_holding_a_markers_bytes_gets_the_builders_message():
    """A frame or whisker name with a template's marker bytes: serialized from the builder."""
    import numpy as np
    from visualization_msgs.msg import MarkerArray

    from vibrissa_ros.node.array import ARRAY_DTYPE
    from vibrissa_ros.ros import array_messages as am

    odd = "M<+\x1a^M<+"  # the stamp marker's bytes (a contrived but allowed name)
    force, torque = (1.0, -2.0, 3.0), (4.0, 5.0, -6.0)
    want = m.fill_wrench6(WrenchStamped(), STAMP, odd, force, torque)
    _same(deserialize_message(cdr.wrench_cdr(STAMP, odd, force, torque), WrenchStamped), want)
    _same(deserialize_message(cdr.contacts_cdr(STAMP, odd, CONTACTS), PointCloud2),
          m.contacts_cloud(STAMP, odd, CONTACTS))
    rows = np.zeros(3, dtype=ARRAY_DTYPE)
    rows["fx"] = (1.0, 2.0, 3.0)
    got = deserialize_message(am.wrenches_cdr(STAMP, odd, rows), PointCloud2)
    assert got.header.frame_id == odd and np.array_equal(am.decode_cloud(got), rows)
    lines = np.arange(2 * 4 * 3, dtype=float).reshape(2, 4, 3)
    for frame, names in ((odd, ["A", "B"]), ("world", ["A", odd])):
        got = deserialize_message(am.shapes_cdr(STAMP, frame, names, lines, [0, 1]),
                                  MarkerArray)
        want = am.shapes_markers(STAMP, frame, names, lines, [0, 1])
        assert repr(got) == repr(deserialize_message(serialize_message(want), MarkerArray))
    # lines that do not match the names are refused, not cut
    with pytest.raises(ValueError, match="3 whiskers"):
        am.shapes_cdr(STAMP, "world", ["A", "B", "C"], lines, [0, 1, 0])
