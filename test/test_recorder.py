"""The recorder without a node or DDS: channels from endpoints, failures reported, data kept."""

import os
import threading
import time
from types import SimpleNamespace

import pytest
from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64
from visualization_msgs.msg import Marker

from vibrissa_ros.logs.mcap_log import LogWriter, read_log
from vibrissa_ros.node.config import build_config
from vibrissa_ros.ros.messages import pose_stamped
from vibrissa_ros.ros.recorder import Recorder

ENDPOINTS = {
    "foot_pose": SimpleNamespace(
        topic_name="/w/foot_pose", msg_type=PoseStamped, qos_profile=QoSProfile(
            history=HistoryPolicy.KEEP_ALL, depth=1000, reliability=ReliabilityPolicy.RELIABLE)),
    "wrench": SimpleNamespace(
        topic_name="/w/wrench", msg_type=WrenchStamped, qos_profile=QoSProfile(
            depth=1000, reliability=ReliabilityPolicy.RELIABLE)),
    "force": SimpleNamespace(topic_name="/w/force", msg_type=Float64, qos_profile=QoSProfile(
        depth=7, reliability=ReliabilityPolicy.BEST_EFFORT)),
    "obstacle": SimpleNamespace(topic_name="/w/obstacle", msg_type=Marker, qos_profile=QoSProfile(
        depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)),
}
VALUES = dict(build_config({}).values)


class Errors:
    def __init__(self):
        self.reasons = []
        self.threads = []

    def __call__(self, reason):
        self.reasons.append(reason)
        self.threads.append(threading.current_thread().name)


def _record(recorder, n, start=0):
    for i in range(start, start + n):
        recorder.write("foot_pose", pose_stamped(0.001 * i, 0.0, 1.0, 10**9 + i), 10**9 + i)
        recorder.write("force", Float64(data=float(i)), 10**9 + i)


def test_channels_take_topic_type_and_qos_from_the_endpoints(tmp_path):
    path = tmp_path / "a.mcap"
    errors = Errors()
    recorder = Recorder(str(path), ENDPOINTS, VALUES, "/w", errors)
    _record(recorder, 20)
    recorder.close()
    assert errors.reasons == [] and recorder.error is None
    assert recorder.queued == 40 and recorder.written == 40
    _, channels, metadata, messages = read_log(str(path))
    by_topic = {c.topic: c for c in channels.values()}
    assert set(by_topic) == {"/w/foot_pose", "/w/wrench", "/w/force", "/w/obstacle"}
    qos = {t: c.metadata["offered_qos_profiles"] for t, c in by_topic.items()}
    assert "history: keep_all" in qos["/w/foot_pose"] and "depth: 1000" in qos["/w/foot_pose"]
    assert "history: keep_last" in qos["/w/wrench"] and "reliability: reliable" in qos["/w/wrench"]
    assert "reliability: best_effort" in qos["/w/force"] and "depth: 7" in qos["/w/force"]
    assert "durability: transient_local" in qos["/w/obstacle"] and "depth: 1" in qos["/w/obstacle"]
    assert [m.type_name for m in messages[:2]] == ["geometry_msgs/msg/PoseStamped",
                                                   "std_msgs/msg/Float64"]
    assert metadata[0].metadata["node"] == '"/w"'


def test_a_writer_thread_that_fails_for_any_reason_reports_it_and_keeps_what_was_written(tmp_path):
    """E.g. an mcap without Writer.flush (before 1.5): an AttributeError in the writer thread."""
    path = tmp_path / "b.mcap"
    writer = LogWriter(str(path), flush_period=0.0)  # every write closes its chunk
    errors = Errors()
    recorder = Recorder(str(path), ENDPOINTS, VALUES, "/w", errors, writer=writer)
    _record(recorder, 30)
    deadline = time.monotonic() + 10
    while recorder.written < 60 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert recorder.written == 60

    def broken():
        raise AttributeError("'Writer' object has no attribute 'flush'")

    writer._writer.flush = broken
    _record(recorder, 30, start=30)
    deadline = time.monotonic() + 10
    while recorder.error is None and time.monotonic() < deadline:
        time.sleep(0.01)
    assert recorder.error is not None and "AttributeError" in recorder.error
    assert str(path) in recorder.error
    _record(recorder, 5, start=60)  # after a failure: nothing happens, nothing raises
    recorder.close()
    assert errors.reasons == [recorder.error]  # reported once
    assert errors.threads == ["vibrissa-recorder"]
    _, _, metadata, messages = read_log(str(path))  # finished: the ordinary readers open it
    poses = [m for m in messages if m.topic == "/w/foot_pose"]
    assert len(poses) >= 30  # everything written before the failure is there
    assert metadata and metadata[0].name == "vibrissa_ros.configuration"


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_a_full_disk_stops_the_recording_with_the_reason_and_never_raises():
    errors = Errors()
    recorder = Recorder("/dev/full", ENDPOINTS, VALUES, "/w", errors,
                        writer=LogWriter("/dev/full", flush_period=0.0))
    _record(recorder, 200)
    deadline = time.monotonic() + 10
    while recorder.error is None and time.monotonic() < deadline:
        time.sleep(0.01)
    recorder.close()
    assert recorder.error is not None and "No space" in recorder.error
    assert errors.reasons == [recorder.error]
