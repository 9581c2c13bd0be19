"""Writing logs in the background: the writer process and the writer thread, without ROS."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from vibrissa_ros.logs.background import LogProcess, LogThread
from vibrissa_ros.logs.mcap_log import LogError, LogWriter, TopicSpec, read_log, repair

SPEC = TopicSpec("/w/value", "std_msgs/msg/Float64", depth=7, reliable=False)


def _cdr(value: float) -> bytes:
    """Return a std_msgs/Float64 in CDR (little endian)."""
    import struct

    return b"\x00\x01\x00\x00" + struct.pack("<d", value)


class Errors(list):
    def __call__(self, reason):
        self.append(reason)


@pytest.mark.parametrize("kind", ["process", "thread"])
def test_messages_and_metadata_come_back_in_order(tmp_path, kind):
    path = tmp_path / "a.mcap"
    errors = Errors()
    sink = LogProcess(str(path), errors) if kind == "process" else LogThread(
        LogWriter(str(path)), errors)
    channel = sink.channel(SPEC)
    assert sink.channel(SPEC) == channel  # once per topic
    sink.metadata("first", {"a": "1"})
    for i in range(500):
        sink.write(channel, _cdr(float(i)), 1000 + i)
    sink.metadata("second", {"b": "2"})
    sink.close()
    assert errors == [] and sink.error is None and sink.messages == 500
    _, channels, metadata, messages = read_log(str(path))
    (only,) = channels.values()
    assert only.topic == "/w/value" and "depth: 7" in only.metadata["offered_qos_profiles"]
    assert "reliability: best_effort" in only.metadata["offered_qos_profiles"]
    assert [m.name for m in metadata] == ["first", "second"]
    assert [m.data for m in messages] == [_cdr(float(i)) for i in range(500)]
    assert [m.log_time for m in messages] == list(range(1000, 1500))
    assert {m.type_name for m in messages} == {"std_msgs/msg/Float64"}


def test_an_unwritable_path_or_an_unknown_type_raises_at_once(tmp_path):
    with pytest.raises(LogError, match="cannot open"):
        LogProcess(str(tmp_path / "missing" / "x.mcap"))
    sink = LogProcess(str(tmp_path / "b.mcap"))
    with pytest.raises(LogError, match="no_such_msgs"):
        sink.channel(TopicSpec("/x", "no_such_msgs/msg/Nothing"))
    sink.close()


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_a_full_disk_is_reported_once_from_the_writer_process():
    errors = Errors()
    sink = LogProcess("/dev/full", errors, flush_period=0.0)
    channel = sink.channel(SPEC)
    for i in range(2000):
        sink.write(channel, _cdr(float(i)), i)
    deadline = time.monotonic() + 10
    while sink.error is None and time.monotonic() < deadline:
        time.sleep(0.01)
    for i in range(10):  # after the failure: nothing happens, nothing raises
        sink.write(channel, _cdr(float(i)), i)
    sink.close()
    assert sink.error is not None and "No space" in sink.error
    assert errors == [sink.error]


CALLER = textwrap.dedent("""
    import sys, time
    from vibrissa_ros.logs.background import LogProcess
    from vibrissa_ros.logs.mcap_log import TopicSpec
    sink = LogProcess(sys.argv[1], flush_period=0.1)
    channel = sink.channel(TopicSpec("/w/value", "std_msgs/msg/Float64"))
    for i in range(200):
        sink.write(channel, b"\\x00\\x01\\x00\\x00" + bytes(8), i)
    while sink.messages < 200:  # written by the writer process (which takes a while to start)
        time.sleep(0.01)
    print(sink._proc.pid, flush=True)
    time.sleep(60)
""")


def _caller(path):
    proc = subprocess.Popen([sys.executable, "-c", CALLER, str(path)], stdout=subprocess.PIPE,
                            text=True, start_new_session=True)
    writer_pid = int(proc.stdout.readline())
    return proc, writer_pid


def _gone(pid, timeout=20.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.05)
    return False


def test_the_writer_finishes_the_log_when_its_caller_is_killed_alone(tmp_path):
    path = tmp_path / "c.mcap"
    proc, writer = _caller(path)
    os.killpg(proc.pid, signal.SIGINT)  # a Ctrl-C reaches the whole group: the writer stays
    os.killpg(proc.pid, signal.SIGTERM)
    time.sleep(0.3)
    os.kill(writer, 0)  # still there
    proc.kill()  # the caller alone, kill -9: the writer's input ends, it finishes the file
    proc.wait()
    assert _gone(writer)
    _, _, _, messages = read_log(str(path))
    assert len(messages) == 200


def test_a_kill_9_of_the_group_leaves_a_log_repair_restores(tmp_path):
    path = tmp_path / "d.mcap"
    proc, writer = _caller(path)
    time.sleep(0.3)  # a chunk is closed every flush_period (0.1 s)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    assert _gone(writer)
    with pytest.raises(LogError):
        read_log(str(path))
    assert repair(str(path), str(tmp_path / "fixed.mcap")) == 200
