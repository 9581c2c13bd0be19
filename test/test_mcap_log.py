"""The MCAP layout, written and read back by two independent readers (values, never bytes)."""

import math
import os
import shutil
from pathlib import Path

import pytest
from geometry_msgs.msg import PoseStamped, WrenchStamped
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from nav_msgs.msg import Path as PathMsg
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import Reader as RosbagsReader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from std_msgs.msg import Float64, String

from vibrissa_ros.logs.mcap_log import (
    LogError,
    LogReader,
    LogWriter,
    TopicSpec,
    message_definition,
    qos_yaml,
    read_log,
    repair,
    type_hash,
)

TYPES = {
    "/w/foot_pose": "geometry_msgs/msg/PoseStamped",
    "/w/wrench": "geometry_msgs/msg/WrenchStamped",
    "/w/centerline": "nav_msgs/msg/Path",
    "/w/force": "std_msgs/msg/Float64",
    "/w/events": "std_msgs/msg/String",
}


def _messages(n=50):
    out = []
    for i in range(n):
        pose = PoseStamped()
        pose.header.frame_id = "world"
        pose.header.stamp.sec, pose.header.stamp.nanosec = 10 + i, 123 * i
        pose.pose.position.x = 0.1 - 0.001 * i
        pose.pose.orientation.z, pose.pose.orientation.w = math.sin(0.7), math.cos(0.7)
        wrench = WrenchStamped()
        wrench.header = pose.header
        wrench.header.frame_id = "whisker_base"
        wrench.wrench.force.x, wrench.wrench.force.y = -0.3 * i, 0.01 * i
        wrench.wrench.torque.z = -1e-3 * i
        path = PathMsg()
        path.header.frame_id = "world"
        for k in range(5):
            p = PoseStamped()
            p.pose.position.x, p.pose.position.y = 0.01 * k, 0.02 * k * i
            path.poses.append(p)
        out += [("/w/foot_pose", pose), ("/w/wrench", wrench), ("/w/centerline", path),
                ("/w/force", Float64(data=1.5 * i)),
                ("/w/events", String(data=f'{{"kind": "touch", "i": {i}}}'))]
    return out


def _write(path, msgs, finish=True, flush_period=0.5):
    log = LogWriter(str(path), flush_period=flush_period)
    ids = {t: log.channel(TopicSpec(t, ty, transient_local=t.endswith("events")))
           for t, ty in TYPES.items()}
    log.metadata("vibrissa_ros.configuration", {"whisker.length": "0.1"})
    for i, (topic, msg) in enumerate(msgs):
        log.write(ids[topic], serialize_message(msg), 1_000_000_000 + i * 1000)
    if finish:
        log.close()
    return log


def _fields(msg):
    """Return comparable values of our test messages, from either reader's decoded objects."""
    if hasattr(msg, "wrench"):
        return (msg.header.stamp.sec, msg.header.frame_id, msg.wrench.force.x, msg.wrench.force.y,
                msg.wrench.torque.z)
    if hasattr(msg, "poses"):
        return tuple((p.pose.position.x, p.pose.position.y) for p in msg.poses)
    if hasattr(msg, "pose"):
        return (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.pose.position.x,
                msg.pose.orientation.z)
    return (msg.data,)


def test_layout_is_rosbag2s(tmp_path):
    path = tmp_path / "a.mcap"
    _write(path, _messages(5))
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        header = reader.get_header()
        summary = reader.get_summary()
    assert header.profile == "ros2"
    assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
    # one per type
    assert sorted(s.name for s in summary.schemas.values()) == sorted(set(TYPES.values()))
    for channel in summary.channels.values():
        assert channel.message_encoding == "cdr"
        assert set(channel.metadata) == {"offered_qos_profiles", "topic_type_hash"}
        assert channel.metadata["topic_type_hash"].startswith("RIHS01_")
        assert channel.metadata["offered_qos_profiles"].startswith(
            "- history: keep_last\n  depth: ")
    assert {c.compression for c in summary.chunk_indexes} == {"zstd"}
    schema = next(s for s in summary.schemas.values()
                  if s.name == "nav_msgs/msg/Path").data.decode()
    blocks = schema.split("=" * 80 + "\n")
    assert blocks[0].startswith("# An array of poses") or ("geometry_msgs/PoseStamped[] "
                                                           "poses") in blocks[0]
    names = [b.split("\n", 1)[0] for b in blocks[1:]]
    assert names[0].startswith("MSG: ")
    assert set(names) == {"MSG: geometry_msgs/PoseStamped", "MSG: geometry_msgs/Pose",
                          "MSG: geometry_msgs/Point", "MSG: geometry_msgs/Quaternion",
                          "MSG: std_msgs/Header", "MSG: builtin_interfaces/Time"}


def test_two_independent_readers_decode_every_value(tmp_path):
    path = tmp_path / "b.mcap"
    msgs = _messages(40)
    _write(path, msgs)
    # mcap-ros2-support: decodes from the embedded schema text
    with open(path, "rb") as stream:
        decoded = [(c.topic, m)
                   for _, c, _, m in make_reader(stream, decoder_factories=[DecoderFactory()])
                   .iter_decoded_messages(log_time_order=True)]
    assert [t for t, _ in decoded] == [t for t, _ in msgs]
    for (_, want), (_, got) in zip(msgs, decoded):
        assert _fields(got) == _fields(want)
    # rosbags with an EMPTY type store: every type rebuilt from our schemas
    store = get_typestore(Stores.EMPTY)
    with RosbagsReader(Path(path)) as reader:
        for conn in reader.connections:
            store.register(get_types_from_msg(conn.msgdef.data, conn.msgtype))
        got = [(c.topic, store.deserialize_cdr(raw, c.msgtype)) for c, _, raw in reader.messages()]
        assert reader.message_count == len(msgs)
    assert [t for t, _ in got] == [t for t, _ in msgs]
    for (_, want), (_, got_msg) in zip(msgs, got):
        assert _fields(got_msg) == _fields(want)


def test_definitions_and_hashes_come_from_the_installed_packages():
    text = message_definition("geometry_msgs/msg/WrenchStamped")
    assert text.startswith("# A wrench with reference coordinate frame and timestamp")
    assert text.count("=" * 80) == 4  # Wrench, Vector3, Header, Time
    assert (type_hash("std_msgs/msg/Float64").startswith("RIHS01_")
            and len(type_hash("std_msgs/msg/Float64")) == 71)
    assert ("reliability: reliable" in qos_yaml()
            and "durability: transient_local" in qos_yaml(transient_local=True))
    with pytest.raises(LogError, match="not installed"):
        message_definition("no_such_msgs/msg/Thing")


def _summary_or_none(path):
    try:
        with open(path, "rb") as stream:
            return make_reader(stream).get_summary()
    except Exception:  # noqa: BLE001 - the reader reads a cut tail as a footer and fails
        return None


def test_unfinished_log_is_repaired_keeping_every_flushed_chunk(tmp_path):
    msgs = _messages(60)
    path = tmp_path / "c.mcap"
    log = _write(path, msgs[:200], finish=False, flush_period=0.0)  # every write closes its chunk
    log._stream.flush()
    killed = tmp_path / "killed.mcap"
    shutil.copy(path, killed)  # the file as a kill -9 leaves it: no summary, no footer
    assert _summary_or_none(killed) is None  # the ordinary readers cannot use it
    assert _summary_or_none(path.with_name("b.mcap")) is None
    with pytest.raises(LogError, match="repair"):
        read_log(str(killed))
    fixed = tmp_path / "fixed.mcap"
    assert repair(str(killed), str(fixed)) == 200
    _, channels, metadata, messages = read_log(str(fixed))
    assert len(messages) == 200 and metadata[0].metadata == {"whisker.length": "0.1"}
    with open(fixed, "rb") as stream:
        decoded = [m for _, _, _, m in make_reader(stream, decoder_factories=[DecoderFactory()])
                   .iter_decoded_messages()]
    assert [_fields(m) for m in decoded] == [_fields(m) for _, m in msgs[:200]]
    # a cut in the middle of a chunk loses that chunk only
    data = killed.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) - 37])
    kept = repair(str(cut), str(tmp_path / "cut_fixed.mcap"))
    assert 190 <= kept < 200


def test_write_errors_are_log_errors_with_the_reason(tmp_path):
    with pytest.raises(LogError, match="cannot open"):
        LogWriter(str(tmp_path / "no" / "such" / "dir" / "x.mcap"))
    if os.path.exists("/dev/full"):
        log = LogWriter("/dev/full", flush_period=0.0)
        cid = log.channel(TopicSpec("/w/force", "std_msgs/msg/Float64"))
        with pytest.raises(LogError, match="No space left"):
            for i in range(100):
                log.write(cid, serialize_message(Float64(data=float(i))), i)
                log.flush()


def test_the_streamed_messages_are_read_logs_in_log_time_order(tmp_path):
    msgs = _messages(40)
    path = tmp_path / "shuffled.mcap"
    log = LogWriter(str(path), chunk_size=2000)  # many chunks, overlapping in log time
    ids = {t: log.channel(TopicSpec(t, ty)) for t, ty in TYPES.items()}
    log.metadata("vibrissa_ros.configuration", {"whisker.length": "0.1"})
    n = len(msgs)
    times = [1_000_000_000 + (i * 37 % n) * 1000 for i in range(n)]  # a permutation
    times[5] = times[6]  # a tie: file order
    # serialized once: Fast CDR leaves padding bytes uninitialized, so two serializations of a
    # message may differ in them
    written = [serialize_message(msg) for _, msg in msgs]
    for (topic, _), data, t in zip(msgs, written, times):
        log.write(ids[topic], data, t)
    log.close()
    schemas, channels, metadata, listed = read_log(str(path))
    with LogReader(str(path)) as reader:
        assert reader.metadata[0].metadata == {"whisker.length": "0.1"}  # before any message
        assert (reader.schemas, reader.channels) == (schemas, channels)
        stream = reader.messages()
        assert iter(stream) is stream  # an iterator, not a list
        streamed = list(stream)
        wrenches = list(reader.messages(["/w/wrench"]))
    assert streamed == listed and len(streamed) == n
    assert [m.log_time for m in streamed] == sorted(times)
    in_order = sorted(zip(times, written), key=lambda item: item[0])  # stable: ties in file order
    assert [m.data for m in streamed] == [data for _, data in in_order]
    assert wrenches == [m for m in listed if m.topic == "/w/wrench"] and wrenches
    with pytest.raises(FileNotFoundError):
        LogReader(str(tmp_path / "none.mcap"))
    unfinished = _write(tmp_path / "unfinished.mcap", msgs[:10], finish=False, flush_period=0.0)
    unfinished._stream.flush()
    with pytest.raises(LogError, match="repair"):
        LogReader(str(tmp_path / "unfinished.mcap"))


def test_streaming_holds_a_chunk_at_a_time_not_the_log(tmp_path):
    import tracemalloc

    path = tmp_path / "big.mcap"
    log = LogWriter(str(path), chunk_size=1 << 18)
    cid = log.channel(TopicSpec("/w/events", TYPES["/w/events"]))
    payloads = [serialize_message(String(data=os.urandom(4000).hex())) for _ in range(1500)]
    for i, data in enumerate(payloads):
        log.write(cid, data, 1_000_000_000 + i)
    log.close()
    total = sum(len(d) for d in payloads)  # 12 MB of messages
    del payloads

    def peak(read):
        tracemalloc.start()
        try:
            count = read()
            return count, tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    def streamed():
        with LogReader(str(path)) as reader:
            return sum(1 for _ in reader.messages())

    count, streaming = peak(streamed)
    listed, whole = peak(lambda: len(read_log(str(path))[3]))
    assert count == listed == 1500
    assert whole > total and streaming < total / 4, (streaming, whole, total)
