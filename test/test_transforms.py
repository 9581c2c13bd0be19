"""
/tf in logs without tf2_msgs: the composed schema, its type hash, the CDR bytes, and replay.

No tf2_msgs wheel exists here; the array node's recording carries the frames on /tf anyway
(vibrissa_ros.ros.transforms). Read back by two independent readers from the log's own schema.
"""

import json
import math

import pytest
from mcap.reader import make_reader
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import Reader as RosbagsReader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from std_msgs.msg import String

from vibrissa_ros.logs.mcap_log import (
    LogError,
    LogWriter,
    TopicSpec,
    message_definition,
    rihs01,
    type_hash,
)
from vibrissa_ros.ros.replay import replay
from vibrissa_ros.ros.transforms import TF_SPEC, TF_TYPE, tf_message_cdr

#: tf2_msgs/msg/TFMessage's RIHS01 hash as ROS 2 Jazzy publishes it (ros2 topic info -v /tf)
JAZZY_TF_HASH = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"


def test_the_composed_type_has_tf2s_text_and_hash():
    assert type_hash(TF_TYPE) == JAZZY_TF_HASH
    text = message_definition(TF_TYPE)
    assert text.startswith("geometry_msgs/TransformStamped[] transforms\n")
    for dep in ("geometry_msgs/TransformStamped", "std_msgs/Header", "builtin_interfaces/Time",
                "geometry_msgs/Transform", "geometry_msgs/Vector3", "geometry_msgs/Quaternion"):
        assert f"MSG: {dep}\n" in text
    # the hash function itself, on an installed type that holds a sequence of another
    from vibrissa_ros.logs.mcap_log import _msg_file
    data = json.loads(_msg_file("visualization_msgs", "MarkerArray", ".json").read_text())
    assert rihs01(data["type_description_msg"]) == data["type_hashes"][0]["hash_string"]


def _frames(k):
    names = [f"head/W{i}" for i in range(k)]
    positions = [(0.01 * i, -0.02 * i, 0.003) for i in range(k)]
    angles = [0.3 * i for i in range(k)]
    quats = [(math.cos(a / 2), 0.0, math.sin(a / 2) * 0.6, math.sin(a / 2) * 0.8) for a in angles]
    return names, positions, quats


def _write_log(path, n=6, k=3):
    log = LogWriter(str(path))
    tf = log.channel(TF_SPEC)
    text = log.channel(TopicSpec("/x/events", "std_msgs/msg/String"))
    names, positions, quats = _frames(k)
    for i in range(n):
        log.write(tf, tf_message_cdr(7 + i, 1000 * i, "world", names, positions, quats),
                  1_000_000_000 + 2 * i)
        log.write(text, serialize_message(String(data=f"tick {i}")), 1_000_000_001 + 2 * i)
    log.close()


def test_tf_messages_read_back_by_two_readers(tmp_path):
    path = tmp_path / "tf.mcap"
    _write_log(path)
    names, positions, quats = _frames(3)
    with open(path, "rb") as stream:
        got = [m for _, c, _, m in make_reader(stream, decoder_factories=[DecoderFactory()])
               .iter_decoded_messages(topics=["/tf"], log_time_order=True)]
    store = get_typestore(Stores.EMPTY)
    with RosbagsReader(path) as reader:
        conn = [c for c in reader.connections if c.topic == "/tf"]
        assert conn[0].msgtype == TF_TYPE
        store.register(get_types_from_msg(conn[0].msgdef.data, conn[0].msgtype))
        again = [store.deserialize_cdr(raw, c.msgtype) for c, _, raw in reader.messages(conn)]
    assert len(got) == len(again) == 6
    for i, msgs in enumerate(zip(got, again)):
        for msg in msgs:
            assert len(msg.transforms) == 3
            for t, name, p, q in zip(msg.transforms, names, positions, quats):
                assert (t.header.stamp.sec, t.header.stamp.nanosec) == (7 + i, 1000 * i)
                assert (t.header.frame_id, t.child_frame_id) == ("world", name)
                v, r = t.transform.translation, t.transform.rotation
                assert (v.x, v.y, v.z) == p
                assert (r.w, r.x, r.y, r.z) == q


def test_an_empty_tf_message_and_odd_frame_names_align():
    # the strings' lengths shift every later field: 1 to 8 characters, each alignment once
    schema = Schema(id=1, name=TF_TYPE, encoding="ros2msg",
                    data=message_definition(TF_TYPE).encode())
    decoder = DecoderFactory().decoder_for("cdr", schema)
    assert decoder(tf_message_cdr(1, 2, "w", [], [], [])).transforms == []
    for n in range(1, 9):
        child = "c" * n
        msg = decoder(tf_message_cdr(1, 2, "p" * (9 - n), [child, child + "x"],
                                     [(1.5, -2.5, 3.5)] * 2, [(0.5, 0.5, -0.5, 0.5)] * 2))
        assert [t.child_frame_id for t in msg.transforms] == [child, child + "x"]
        for t in msg.transforms:
            r = t.transform.rotation
            assert t.transform.translation.z == 3.5
            assert (r.w, r.x, r.y, r.z) == (0.5, 0.5, -0.5, 0.5)


def test_replay_leaves_out_a_type_that_is_not_installed(tmp_path):
    path = tmp_path / "tf.mcap"
    _write_log(path)
    assert replay(str(path), rate=0.0, wait_subscribers=0.0) == 6  # the String messages only
    with pytest.raises(LogError, match="cannot publish /tf: type tf2_msgs/msg/TFMessage is not"):
        replay(str(path), rate=0.0, topics=["/tf"], wait_subscribers=0.0)


def test_the_message_counts_come_from_the_summary_or_one_pass(tmp_path):
    # replay streams a log: its per-topic counts (the QoS depth at rate 0) are the summary's
    # statistics, or counted in one pass where a writer left them out
    from mcap.writer import Writer

    from vibrissa_ros.logs.mcap_log import LogReader

    path = tmp_path / "tf.mcap"
    _write_log(path, n=5)
    with LogReader(str(path)) as log:
        assert log.counts() == {"/tf": 5, "/x/events": 5}
    bare = tmp_path / "bare.mcap"
    with open(bare, "wb") as stream:
        writer = Writer(stream, use_statistics=False)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema("std_msgs/msg/String", "ros2msg",
                                        message_definition("std_msgs/msg/String").encode())
        a = writer.register_channel("/a", "cdr", schema)
        writer.register_channel("/b", "cdr", schema)
        for i in range(3):
            writer.add_message(a, i, serialize_message(String(data=str(i))), i)
        writer.finish()
    with LogReader(str(bare)) as log:
        assert log.counts() == {"/a": 3, "/b": 0}
