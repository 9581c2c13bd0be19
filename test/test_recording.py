"""Recording in whisker_node, and the log tools on real recordings (integration, over DDS)."""

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from ros_harness import Probe, pose_msg, stamp_of, start_installed_node, stop, write_params
from rosbags.rosbag2 import Reader as RosbagsReader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from vibrissa_ros.core import run_scan
from vibrissa_ros.logs.tools import log_info, resimulate
from vibrissa_ros.logs.mcap_log import LogError, read_log
from vibrissa_ros.node.config import build_config

HALF_PI = math.pi / 2
PARAMS = {
    "obstacle.type": "catenary", "obstacle.c": 0.06, "obstacle.apex_y": 0.05,
    "diagnostics.period": 0.2, "centerline.max_rate": 50.0,
}
VIBRISSA = str(Path(sys.executable).with_name("vibrissa"))


def _sweep(n=240, start=0.15, stop_x=-0.15):
    xs = np.concatenate([np.linspace(start, stop_x, n // 2), np.linspace(stop_x, start, n // 2)])
    return [pose_msg(float(x), 0.0, HALF_PI, 1_000_000_000 + i * 1_000_000)
            for i, x in enumerate(xs)]


def _record(installed, ros_env, rcl_context, tmp_path, name, msgs, params=PARAMS,
            sig=signal.SIGINT):
    log = tmp_path / f"{name}.mcap"
    values = dict(params, **{"record.path": str(log)})
    proc = start_installed_node(installed, write_params(tmp_path / f"{name}.yaml", values),
                                ros_env)
    probe = Probe(rcl_context, "/whisker_node", name=f"probe_{name}")
    try:
        probe.handshake(msgs[0])
        for m in msgs[1:]:
            probe.step(m)
    finally:
        probe.destroy()
    assert stop(proc, sig) == 0
    return log


@pytest.fixture(scope="module")
def recorded(installed, ros_env, rcl_context, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("rec")
    return _record(installed, ros_env, rcl_context, tmp, "sweep", _sweep())


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_stopped_node_leaves_a_finished_log_both_readers_open(installed, ros_env, rcl_context,
                                                                tmp_path, sig):
    msgs = _sweep(40)
    log = _record(installed, ros_env, rcl_context, tmp_path, "short", msgs, sig=sig)
    with open(log, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        poses = [m for _, c, _, m in reader.iter_decoded_messages()
                 if c.topic == "/whisker_node/foot_pose"]
    assert len(poses) >= len(msgs)  # the handshake may repeat the first pose
    store = get_typestore(Stores.EMPTY)
    with RosbagsReader(log) as reader:
        for conn in reader.connections:
            store.register(get_types_from_msg(conn.msgdef.data, conn.msgtype))
        wrenches = [store.deserialize_cdr(raw, c.msgtype) for c, _, raw in reader.messages()
                    if c.topic.endswith("/wrench")]
    stamps = [w.header.stamp.sec * 10**9 + w.header.stamp.nanosec for w in wrenches]
    assert stamps[-(len(msgs) - 1):] == [stamp_of(m) for m in msgs[1:]]


def test_every_input_and_output_topic_and_the_configuration_are_recorded(recorded):
    info = log_info(str(recorded))
    topics = set(info.topics)
    for name in ("foot_pose", "wrench", "phase", "contact_force", "contact_force_magnitude",
                 "contact_point", "arc_length", "events", "centerline", "obstacle"):
        assert f"/whisker_node/{name}" in topics, name
    assert "/diagnostics" in topics
    assert info.topics["/whisker_node/obstacle"][1] == 1
    config = info.configurations[0][1]
    assert config["obstacle.type"] == "catenary" and config["whisker.length"] == 0.1
    assert config["record.path"] == str(recorded)
    assert [e["kind"] for e in info.events].count("snap") == 2
    assert set(info.phases) == {0, 1, 2}


def test_resim_reproduces_the_recorded_outputs(recorded):
    sim = resimulate(str(recorded))
    assert not sim.mismatches
    assert sim.worst() <= 1e-12
    assert sim.compared["wrench.torque.z"] >= 239 and sim.compared["events.kind"] >= 4
    proc = subprocess.run([VIBRISSA, "resim", str(recorded)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "wrench.torque.z" in proc.stdout and "OK" in proc.stdout


def test_resim_fails_on_a_log_that_does_not_match(recorded, tmp_path):
    """Same poses, different recorded configuration: resim must notice (exit 1)."""
    _, channels, metadata, messages = read_log(str(recorded))
    from mcap.writer import Writer

    bad = tmp_path / "tampered.mcap"
    with open(recorded, "rb") as src, open(bad, "wb") as out:
        reader = make_reader(src)
        summary = reader.get_summary()
        writer = Writer(out)
        writer.start(profile="ros2", library="test")
        sids = {sid: writer.register_schema(s.name, s.encoding, s.data)
                for sid, s in summary.schemas.items()}
        cids = {cid: writer.register_channel(c.topic, c.message_encoding, sids[c.schema_id],
                                             dict(c.metadata))
                for cid, c in summary.channels.items()}
        for record in metadata:
            values = dict(record.metadata)
            values["whisker.bending_stiffness"] = json.dumps(6e-4)  # not what was run
            writer.add_metadata(record.name, values)
        for _, channel, message in reader.iter_messages():
            writer.add_message(cids[channel.id], message.log_time, message.data,
                               message.publish_time)
        writer.finish()
    proc = subprocess.run([VIBRISSA, "resim", str(bad)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 1
    assert "FAIL" in proc.stdout


def test_export_is_the_scan_contract_plus_time(recorded, tmp_path):
    out = tmp_path / "export.csv"
    proc = subprocess.run([VIBRISSA, "export", str(recorded), "--csv", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    lines = out.read_text().splitlines()
    assert lines[0] == "x0,phase,alpha,s1,tip_slope,f,fx,fy,m0,contact_x,contact_y,time"
    rows = [line.split(",") for line in lines[1:]]
    # the offline scan over the same foot positions gives the same numbers
    x0 = [float(r[0]) for r in rows]
    cfg = build_config(PARAMS)
    scan = run_scan(cfg.profile, x0).states
    for r, st in zip(rows, scan):
        assert int(r[1]) == int(st.phase)
        assert float(r[8]) == pytest.approx(st.m0, rel=1e-12, abs=1e-15)
    assert float(rows[-1][-1]) > float(rows[0][-1])


def test_info_prints_topics_configuration_phases_and_events(recorded):
    proc = subprocess.run([VIBRISSA, "info", str(recorded)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    for words in ("/whisker_node/wrench", "geometry_msgs/msg/WrenchStamped", "duration:",
                  "obstacle.type = \"catenary\"", "phase 2:", "snap"):
        assert words in proc.stdout
    missing = subprocess.run([VIBRISSA, "info", "/no/such.mcap"], capture_output=True, text=True,
                             timeout=60)
    assert missing.returncode == 2 and len(missing.stderr.strip().splitlines()) == 1


def test_kill_9_loses_at_most_the_last_second_and_repair_restores_a_valid_log(
        installed, ros_env, rcl_context, tmp_path):
    log = tmp_path / "killed.mcap"
    values = dict(PARAMS, **{"record.path": str(log)})
    proc = start_installed_node(installed, write_params(tmp_path / "k.yaml", values), ros_env)
    probe = Probe(rcl_context, "/whisker_node", name="probe_kill")
    sent = []  # (wall time, stamp)
    try:
        msgs = _sweep(400)
        probe.handshake(msgs[0])
        for m in msgs[1:]:
            probe.step(m)
            sent.append((time.monotonic(), stamp_of(m)))
            time.sleep(0.004)
    finally:
        probe.destroy()
    killed_at = time.monotonic()
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    with pytest.raises(LogError):
        read_log(str(log))
    fixed = tmp_path / "fixed.mcap"
    done = subprocess.run([VIBRISSA, "repair", str(log), "-o", str(fixed)], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    _, _, metadata, messages = read_log(str(fixed))
    assert metadata and metadata[0].name == "vibrissa_ros.configuration"
    from vibrissa_ros.ros.serialization import decode

    kept = {stamp_of(decode(m)) for m in messages if m.topic == "/whisker_node/foot_pose"}
    lost = [(killed_at - t) for t, s in sent if s not in kept]
    assert all(age <= 1.0 for age in lost), f"lost poses up to {max(lost):.3f} s before the kill"
    assert len(kept) >= len(sent) - 0.6 * len(sent)  # sanity: most of the run survives
    store = get_typestore(Stores.EMPTY)
    with RosbagsReader(fixed) as reader:  # and the other reader opens the repaired file too
        for conn in reader.connections:
            store.register(get_types_from_msg(conn.msgdef.data, conn.msgtype))
        assert reader.message_count == len(messages)


def test_unwritable_or_full_disk_keeps_the_node_running_and_says_so(installed, ros_env,
                                                                    rcl_context, tmp_path):
    for target, words in ((str(tmp_path / "missing" / "dir" / "x.mcap"), "cannot open"),
                          ("/dev/full", "No space")):
        values = dict(PARAMS, **{"record.path": target})
        proc = start_installed_node(installed, write_params(tmp_path / "u.yaml", values), ros_env)
        probe = Probe(rcl_context, "/whisker_node", name="probe_unwritable")
        try:
            probe.handshake(pose_msg(0.15, 0.0, HALF_PI, 1))
            for i, x in enumerate(np.linspace(0.14, 0.0, 60)):
                probe.step(pose_msg(float(x), 0.0, HALF_PI, 2 + i))
            time.sleep(0.6)  # a flush happens within 0.5 s
            probe.step(pose_msg(-0.01, 0.0, HALF_PI, 100))
            error = probe.diagnostics_value("recording_error")
            deadline = time.monotonic() + 10.0
            while words not in error and time.monotonic() < deadline:
                # on a busy machine the writer process may report after the next status
                error = probe.diagnostics_value("recording_error")
            assert words in error, error
            assert probe.diagnostics_value("recording") == ""
            from diagnostic_msgs.msg import DiagnosticStatus

            levels = [s.level for a in probe.got["diagnostics"][-3:] for s in a.status]
            assert levels and levels[-1] == DiagnosticStatus.ERROR
            assert proc.poll() is None
        finally:
            probe.destroy()
            assert stop(proc) == 0


def test_replay_drives_a_fresh_node_to_the_same_outputs(installed, ros_env, rcl_context, recorded,
                                                        tmp_path):
    second = tmp_path / "second.mcap"
    proc = start_installed_node(
        installed, write_params(tmp_path / "b.yaml", dict(PARAMS, **{"record.path": str(second)})),
        ros_env)
    probe = Probe(rcl_context, "/whisker_node", name="probe_replay")
    try:
        probe.spin_until(lambda: probe.got["obstacle"], 10.0)  # the node is up
        done = subprocess.run([VIBRISSA, "replay", str(recorded), "--rate", "0", "--topics",
                               "/whisker_node/foot_pose"],
                              env=ros_env, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        n_first = len([m for m in read_log(str(recorded))[3] if m.topic == "/whisker_node/wrench"])
        probe.spin_until(lambda: len(probe.got["wrench"]) >= n_first, 30.0)
    finally:
        probe.destroy()
        assert stop(proc) == 0
    for log in (recorded, second):
        sim = resimulate(str(log))
        assert not sim.mismatches and sim.worst() <= 1e-12, log
    from vibrissa_ros.ros.serialization import decode

    def wrenches(log):
        return {stamp_of(w): (w.wrench.force.x, w.wrench.force.y, w.wrench.torque.z)
                for w in (decode(m) for m in read_log(str(log))[3]
                          if m.topic == "/whisker_node/wrench")}

    first, again = wrenches(recorded), wrenches(second)
    assert set(again) == set(first)
    assert all(again[s] == first[s] for s in first)


def test_plot_of_a_log_is_in_si_units(recorded, tmp_path):
    png = tmp_path / "log.png"
    proc = subprocess.run([VIBRISSA, "plot", str(recorded), "-o", str(png), "--small-png"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_contour_node_reconstructs_a_replayed_log(installed, ros_env, rcl_context, recorded):
    """contour_node knows nothing but the two topics: driven by vibrissa replay of a log."""
    from geometry_msgs.msg import PointStamped
    from ros_harness import RELIABLE

    from vibrissa_ros.node.reconstruction import from_log

    proc = start_installed_node(installed, None, ros_env, executable="contour_node",
                                extra="-r '~/foot_pose:=/whisker_node/foot_pose' "
                                "-r '~/wrench:=/whisker_node/wrench'")
    node = __import__("rclpy").create_node("probe_contour", context=rcl_context)
    points = []
    node.create_subscription(PointStamped, "/contour_node/contact_point", points.append, RELIABLE)
    from rclpy.executors import SingleThreadedExecutor

    executor = SingleThreadedExecutor(context=rcl_context)
    executor.add_node(node)
    try:
        end = time.monotonic() + 20
        while time.monotonic() < end and not node.count_publishers("/contour_node/contact_point"):
            executor.spin_once(timeout_sec=0.05)
        done = subprocess.run([VIBRISSA, "replay", str(recorded), "--rate", "0", "--topics",
                               "/whisker_node/foot_pose", "/whisker_node/wrench"], env=ros_env,
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        offline = from_log(str(recorded))
        end = time.monotonic() + 30
        while time.monotonic() < end and len(points) < len(offline.estimates):
            executor.spin_once(timeout_sec=0.05)
    finally:
        executor.remove_node(node)
        node.destroy_node()
        assert stop(proc) == 0
    assert len(points) == len(offline.estimates) > 100
    truth = {stamp_of(m): m
             for m in (__import__("vibrissa_ros.ros.serialization", fromlist=["decode"]).decode(x)
                       for x in read_log(str(recorded))[3]
                       if x.topic == "/whisker_node/contact_point")}
    for p in points:
        true = truth[stamp_of(p)]
        assert math.hypot(p.point.x - true.point.x, p.point.y - true.point.y) < 1e-8 * 0.1


def test_sensor_noise_is_seeded_recorded_and_resimulated(installed, ros_env, rcl_context,
                                                         tmp_path):
    noisy = dict(PARAMS, **{"noise.enabled": True, "noise.seed": 42, "noise.force_stddev": 0.01,
                            "noise.torque_stddev": 1e-4, "noise.force_step": 1e-4})
    msgs = _sweep(60)
    logs = [_record(installed, ros_env, rcl_context, tmp_path, f"noisy{i}", msgs, params=noisy)
            for i in range(2)]
    # (the two runs may answer a different number of handshake poses, so their noise sequences are
    # compared through resim, which replays each log's own poses from the seed)
    from vibrissa_ros.ros.serialization import decode

    def wrenches(log):
        return [(w.wrench.force.x, w.wrench.force.y, w.wrench.torque.z) for w in
                (decode(m) for m in read_log(str(log))[3] if m.topic == "/whisker_node/wrench")]

    first, second = wrenches(logs[0]), wrenches(logs[1])
    for log, got in zip(logs, (first, second)):
        sim = resimulate(str(log))
        # resim reproduces the noise bit for bit
        assert not sim.mismatches and sim.worst() <= 1e-12
        from vibrissa_ros.node.edge import sensor_reading

        cfg = build_config(noisy)
        exact = np.array([(r.force_base[0], r.force_base[1], r.torque_z)
                          for r in (sensor_reading(st, cfg.units) for _, st in sim.states)])
        residual = np.array(got) - exact
        assert 0.005 < residual[:, 0].std() < 0.02 and 0.005 < residual[:, 1].std() < 0.02
        assert 5e-5 < residual[:, 2].std() < 2e-4
        # quantized
        assert np.all(
            np.abs(np.array(got)[:, 0] / 1e-4 - np.round(np.array(got)[:, 0] / 1e-4)) < 1e-6)
    info = log_info(str(logs[0]))
    assert (info.configurations[0][1]["noise.seed"] == 42
            and info.configurations[0][1]["noise.enabled"] is True)


def test_stopping_the_recording_at_runtime_finishes_the_file(installed, ros_env, rcl_context,
                                                             tmp_path):
    log = tmp_path / "runtime.mcap"
    proc = start_installed_node(
        installed, write_params(tmp_path / "r.yaml", dict(PARAMS, **{"record.path": str(log)})),
        ros_env)
    probe = Probe(rcl_context, "/whisker_node", name="probe_stop_recording")
    try:
        msgs = _sweep(30)
        probe.handshake(msgs[0])
        for m in msgs[1:]:
            probe.step(m)
        client = probe.node.create_client(SetParameters, "/whisker_node/set_parameters")
        assert client.wait_for_service(timeout_sec=10.0)
        off = Parameter(name="record.path",
                        value=ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=""))
        future = client.call_async(SetParameters.Request(parameters=[off]))
        probe.spin_until(future.done, 10.0)
        assert future.result().results[0].successful
        # finished while the node keeps running: both readers open it now
        _, _, metadata, messages = read_log(str(log))
        assert sum(1 for m in messages if m.topic == "/whisker_node/wrench") >= len(msgs)
        assert proc.poll() is None
        # and the whisker goes on, unrecorded
        probe.step(pose_msg(0.0, 0.0, HALF_PI, 9_000_000_000))
        assert sum(1 for m in read_log(str(log))[3] if m.topic == "/whisker_node/wrench") == \
            sum(1 for m in messages if m.topic == "/whisker_node/wrench")
    finally:
        probe.destroy()
        assert stop(proc) == 0
