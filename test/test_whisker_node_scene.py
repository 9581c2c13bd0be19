"""Launch-free integration tests of whisker_node with a scene over real DDS (issue 13)."""

import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from ros_harness import (
    ROOT, Probe, pose_msg, read_params, stamp_of, start_installed_node, stop, write_params,
)
from visualization_msgs.msg import Marker

from vibrissa_ros.core.scenes.tracker import SceneTracker
from vibrissa_ros.node.edge import contact_records, planar_pose, sensor_reading
from vibrissa_ros.logs.tools import log_info, resimulate
from vibrissa_ros.node.config import build_config
from vibrissa_ros.ros.messages import decode_contacts

HALF_PI = math.pi / 2
SHIPPED = ROOT / "config" / "scene_two_pegs_node.yaml"
SCENE_M = ROOT / "config" / "scene_two_pegs_m.yaml"
VIBRISSA = str(Path(sys.executable).with_name("vibrissa"))


def _shipped_values():
    """Read the shipped parameter file's values, its package:// scene named by its source path."""
    values = read_params(SHIPPED)
    assert values["obstacle.scene_file"] == "package://vibrissa_ros/config/scene_two_pegs_m.yaml"
    return dict(values, **{"obstacle.scene_file": str(SCENE_M)})


def _poses():
    """Foot along x past peg0 onto both pegs and back (yaw +90 deg): one, two, one, no contacts."""
    xs = list(np.linspace(-0.0045, 0.0075, 49)) + list(np.linspace(0.0075, -0.0045, 49))[1:]
    return [pose_msg(float(x), 0.0, HALF_PI, 1_000_000_000 + i * 1_000_000)
            for i, x in enumerate(xs)]


def _expected(values, msgs):
    """Compute the scene tracker's answers for the same poses, converted as the node does."""
    cfg = build_config(values)
    assert cfg.multi_contact
    tracker, out = None, []
    for msg in msgs:
        p, q = msg.pose.position, msg.pose.orientation
        pose = cfg.units.foot_pose(*planar_pose((p.x, p.y, p.z), (q.x, q.y, q.z, q.w), 1e-6,
                                                1e-6))
        if tracker is None:
            tracker = SceneTracker(list(cfg.scene), pose, shape=cfg.shape, friction=cfg.friction)
            state, events = tracker.state, ()
        else:
            result = tracker.step(pose)
            state, events = result.state, result.events
        out.append((state, sensor_reading(state, cfg.units), contact_records(state, cfg.units),
                    events))
    return cfg, out


def _rel(a, b, scale):
    return a == pytest.approx(b, rel=1e-9, abs=1e-9 * scale)


def _set(probe, name, **value):
    client = probe.node.create_client(SetParameters, "/scene/whisker_node/set_parameters")
    assert client.wait_for_service(timeout_sec=10.0)
    kind = ParameterType.PARAMETER_STRING
    req = SetParameters.Request(parameters=[Parameter(name=name, value=ParameterValue(
        type=kind, **value))])
    future = client.call_async(req)
    probe.spin_until(future.done, 10.0)
    return future.result().results[0]


def test_shipped_two_peg_scene_equals_the_scene_tracker(installed, ros_env, rcl_context):
    """The shipped files (package:// scene): wrench and every contact == the core, 1e-9."""
    proc = start_installed_node(installed, SHIPPED, ros_env, namespace="/scene")
    probe = Probe(rcl_context, "/scene/whisker_node", name="probe_scene")
    try:
        msgs = _poses()
        probe.handshake(msgs[0])
        wrenches = [probe.step(m) for m in msgs[1:]]
        n = len(wrenches)
        assert probe.spin_until(lambda: len(probe.got["contacts"]) >= n, 10.0)
        assert probe.spin_until(lambda: probe.got["obstacles"], 5.0)
        cfg, expected = _expected(_shipped_values(), msgs)
        expected = expected[1:]
        force = cfg.units.force
        counts = []
        for msg, w, cloud, (state, reading, contacts, _) in zip(msgs[1:], wrenches,
                                                                probe.got["contacts"], expected):
            assert stamp_of(w) == stamp_of(msg) == stamp_of(cloud)
            assert w.header.frame_id == "whisker_base" and cloud.header.frame_id == "world"
            assert _rel(w.wrench.force.x, reading.force_base[0], force)
            assert _rel(w.wrench.force.y, reading.force_base[1], force)
            assert _rel(w.wrench.torque.z, reading.torque_z, force * 0.03)
            got = decode_contacts(cloud)
            assert len(got) == len(contacts)
            counts.append(len(got))
            for g, c in zip(got, contacts):
                assert (g.kind, g.state, g.obstacle) == (c.kind, c.state, c.obstacle)
                for a, b, scale in ((g.x, c.x, 0.03), (g.y, c.y, 0.03), (g.s, c.s, 0.03),
                                    (g.fx, c.fx, force), (g.fy, c.fy, force)):
                    assert _rel(a, b, scale)
        assert {0, 1, 2} <= set(counts)  # free, one peg, both pegs
        # the single-contact topics describe the contact nearest the foot
        near = [r for _, r, _, _ in expected if r.contact_world is not None]
        assert len(probe.got["contact_point"]) == len(near)
        for point, r in zip(probe.got["contact_point"], near):
            assert _rel(point.point.x, r.contact_world[0], 0.03)
            assert _rel(point.point.y, r.contact_world[1], 0.03)
        assert [p.data for p in probe.got["phase"]] == [r.phase for _, r, _, _ in expected]
        events = [json.loads(e.data) for e in probe.got["events"]]
        want = [e for *_, evs in expected for e in evs]
        assert [(e["kind"], e["contact"], e.get("obstacle")) for e in events] == [
            (e.kind, e.contact_kind, e.obstacle) for e in want]
        assert [e["kind"] for e in events].count("touch") == 2
        for got_e, e in zip(events, want):
            assert _rel(got_e["x"], e.pose.x * 0.03, 0.03)
        # all obstacles, latched: a subscriber that comes late still gets them
        late = Probe(rcl_context, "/scene/whisker_node", name="probe_scene_late")
        try:
            assert late.spin_until(lambda: late.got["obstacles"] and late.got["obstacle"], 10.0)
            array = late.got["obstacles"][-1]
            assert array.markers[0].action == Marker.DELETEALL
            strips = [mk for mk in array.markers if mk.type == Marker.LINE_STRIP]
            assert [mk.text for mk in strips] == ["peg0", "peg1"]
            for mk, (x, y) in zip(strips, ((0.0, 0.012), (-0.006, 0.0255))):
                assert mk.header.frame_id == "world"
                ring = np.array([(p.x, p.y) for p in mk.points])
                assert np.hypot(ring[:, 0] - x, ring[:, 1] - y) == pytest.approx(5e-4, rel=1e-9)
            assert late.got["obstacle"][-1].type == Marker.LINE_LIST
        finally:
            late.destroy()
        assert proc.poll() is None
    finally:
        probe.destroy()
        assert stop(proc) == 0


def test_a_bad_scene_file_is_refused_at_startup_and_at_runtime(installed, ros_env, rcl_context,
                                                               tmp_path):
    bad = tmp_path / "overlap.yaml"
    bad.write_text("obstacles:\n  - {type: peg, x: 0.0, y: 0.012, r: 0.001}\n"
                   "  - {type: peg, x: 0.0005, y: 0.012, r: 0.001}\n")
    values = dict(_shipped_values(), **{"obstacle.scene_file": str(bad)})
    proc = start_installed_node(installed, write_params(tmp_path / "bad.yaml", values), ros_env,
                                namespace="/scene")
    code = proc.wait(timeout=30)
    out = proc.stdout.read()
    assert code != 0
    assert f"obstacle.scene_file = {str(bad)!r}" in out and "overlap" in out
    # a running node refuses a bad file with the reason and keeps its scene
    values = dict(_shipped_values(), **{"diagnostics.period": 0.2})
    proc = start_installed_node(installed, write_params(tmp_path / "good.yaml", values), ros_env,
                                namespace="/scene")
    probe = Probe(rcl_context, "/scene/whisker_node", name="probe_scene_bad")
    try:
        msgs = _poses()[:30]
        probe.handshake(msgs[0])
        first = [probe.step(m) for m in msgs[1:15]]
        for path, reason in ((bad, "overlap"), (tmp_path / "missing.yaml", "cannot read")):
            result = _set(probe, "obstacle.scene_file", string_value=str(path))
            assert not result.successful
            assert result.reason.startswith(f"obstacle.scene_file = {str(path)!r}")
            assert reason in result.reason
        rest = [probe.step(m) for m in msgs[15:]]
        _, expected = _expected(values, msgs)
        for w, (_, r, _, _) in zip(first + rest, expected[1:]):
            assert _rel(w.wrench.torque.z, r.torque_z, 1e-6)
        assert "scene of 2 obstacle(s)" in probe.diagnostics_value("configuration")
        assert probe.diagnostics_value("contacts") == str(len(expected[-1][2]))
    finally:
        probe.destroy()
        assert stop(proc) == 0


def test_a_recorded_scene_run_is_reproduced_by_resim(installed, ros_env, rcl_context, tmp_path):
    scene = tmp_path / "two_pegs.yaml"
    shutil.copy(SCENE_M, scene)
    log = tmp_path / "scene.mcap"
    values = dict(_shipped_values(), **{"obstacle.scene_file": str(scene),
                                        "record.path": str(log)})
    proc = start_installed_node(installed, write_params(tmp_path / "rec.yaml", values), ros_env,
                                namespace="/scene")
    probe = Probe(rcl_context, "/scene/whisker_node", name="probe_scene_rec")
    try:
        msgs = _poses()
        probe.handshake(msgs[0])
        for m in msgs[1:]:
            probe.step(m)
    finally:
        probe.destroy()
    assert stop(proc) == 0
    scene.unlink()  # resim rebuilds the scene from the log, not from the file
    info = log_info(str(log))
    for topic in ("contacts", "obstacles", "obstacle", "events", "wrench"):
        assert f"/scene/whisker_node/{topic}" in info.topics, topic
    assert info.topics["/scene/whisker_node/obstacles"] == ("visualization_msgs/msg/MarkerArray",
                                                            1)
    assert info.configurations[0][1]["obstacle.scene_text"] == SCENE_M.read_text()
    assert [e["kind"] for e in info.events].count("touch") == 2
    sim = resimulate(str(log))
    assert not sim.mismatches
    assert sim.worst() <= 1e-12
    assert sim.compared["wrench.torque.z"] >= len(msgs) - 1
    assert sim.compared["contacts.fx"] > len(msgs) and sim.compared["events.kind"] >= 3
    assert max(len(s.contacts) for _, s in sim.states) == 2
    proc = subprocess.run([VIBRISSA, "resim", str(log)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "contacts.fx" in proc.stdout and "OK" in proc.stdout
    out = tmp_path / "scene.csv"
    proc = subprocess.run([VIBRISSA, "export", str(log), "--csv", str(out)], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0 and not proc.stderr, proc.stderr
    lines = out.read_text().splitlines()
    assert lines[0].endswith(",contacts,time") and len(lines) == 1 + len(sim.states)
    assert {line.split(",")[-2] for line in lines[1:]} == {"0", "1", "2"}
    proc = subprocess.run([VIBRISSA, "info", str(log)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "touch    side on obstacle 1" in proc.stdout
