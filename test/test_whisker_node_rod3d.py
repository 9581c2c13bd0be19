"""Launch-free integration tests of whisker_node with the 3D whisker (model rod3d), over DDS."""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from ros_harness import (
    ROOT, Probe, read_params, stamp_of, start_installed_node, stop, write_params,
)
from visualization_msgs.msg import Marker

from vibrissa_ros.core.rod3d import BasePose, RodTracker
from vibrissa_ros.core.rod3d.pose import quat_about, quat_matrix, quat_multiply
from vibrissa_ros.logs.tools import log_info, resimulate
from vibrissa_ros.node.config import build_config
from vibrissa_ros.node.edge import contact_records, set_stamp
from vibrissa_ros.ros.messages import decode_contacts

SHIPPED = ROOT / "config" / "rod3d_sphere_node.yaml"
SCENE_M = ROOT / "config" / "scene_sphere_m.yaml"
VIBRISSA = str(Path(sys.executable).with_name("vibrissa"))
PREFIX = "/rod3d/whisker_node"


def _shipped_values():
    """Read the shipped parameter file's values, its package:// scene named by its source path."""
    values = read_params(SHIPPED)
    assert values["model"] == "rod3d"
    assert values["obstacle.scene_file"] == "package://vibrissa_ros/config/scene_sphere_m.yaml"
    return dict(values, **{"obstacle.scene_file": str(SCENE_M)})


def _pose_msg(position, quaternion, stamp_ns, frame="world"):
    """Return a PoseStamped of a position [m] and an orientation (x, y, z, w)."""
    msg = PoseStamped()
    msg.header.frame_id = frame
    set_stamp(msg.header.stamp, stamp_ns)
    p, o = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z = (float(v) for v in position)
    o.x, o.y, o.z, o.w = (float(v) for v in quaternion)
    return msg


def _poses():
    """6-DoF foot poses: along +y into the ball, over it and back, lifted, yawed and pitched."""
    ys = list(np.linspace(0.0, 0.016, 30)) + list(np.linspace(0.016, 0.0, 30))[1:]
    msgs = []
    for i, y in enumerate(ys):
        q = quat_multiply(quat_about((0, 0, 1), 0.1 * math.sin(i / 7)),
                          quat_about((0, 1, 0), 0.05 * math.sin(i / 4)))
        msgs.append(_pose_msg((0.0, y, 0.0005 * math.sin(i / 5)), (q[1], q[2], q[3], q[0]),
                              1_000_000_000 + i * 1_000_000))
    return msgs


def _expected(values, msgs):
    """Compute the RodTracker's answers to the same poses (roll composed), in SI."""
    cfg = build_config(values)
    L, F, M = cfg.units.length, cfg.units.force, cfg.units.moment
    roll = quat_about((1, 0, 0), values["whisker.roll"])
    tracker, out = None, []
    for msg in msgs:
        p, o = msg.pose.position, msg.pose.orientation
        pose = BasePose((p.x / L, p.y / L, p.z / L),
                        tuple(quat_multiply((o.w, o.x, o.y, o.z), roll)))
        if tracker is None:
            tracker = RodTracker(cfg.scene3d, pose, shape=cfg.rod_shape)
            state, events = tracker.state, ()
        else:
            result = tracker.step(pose)
            state, events = result.state, result.events
        # in base_frame, the foot's frame (q_pose): the core's base frame rolled back
        force, moment = state.base_wrench()
        c, s = math.cos(values["whisker.roll"]), math.sin(values["whisker.roll"])
        unroll = np.array(((1.0, 0.0, 0.0), (0.0, c, -s), (0.0, s, c)))
        wrench = tuple(unroll @ force * F) + tuple(unroll @ moment * M)
        out.append((state, wrench, contact_records(state, cfg.units), events))
    return cfg, out


def _rel(a, b, scale):
    return a == pytest.approx(b, rel=1e-9, abs=1e-9 * scale)


def _six(w):
    f, t = w.wrench.force, w.wrench.torque
    return (f.x, f.y, f.z, t.x, t.y, t.z)


@pytest.fixture(scope="module")
def run(installed, ros_env, rcl_context, tmp_path_factory):
    """Drive the shipped 3D configuration (recording) with 6-DoF poses and a non-unit one."""
    tmp = tmp_path_factory.mktemp("rod3d")
    log = tmp / "rod3d.mcap"
    values = dict(_shipped_values(), **{"record.path": str(log), "diagnostics.period": 0.2,
                                        "centerline.max_rate": 0.0})
    # the shipped file itself, its scene by package:// (plus the test's recording)
    params = write_params(tmp / "rod3d.yaml", dict(values, **{
        "obstacle.scene_file": "package://vibrissa_ros/config/scene_sphere_m.yaml"}))
    proc = start_installed_node(installed, params, ros_env, namespace="/rod3d")
    probe = Probe(rcl_context, PREFIX, name="probe_rod3d")
    msgs = _poses()
    bad = 15  # a non-unit quaternion while in contact: dropped, the state kept
    try:
        probe.handshake(msgs[0])
        answers = []
        for i, m in enumerate(msgs[1:], start=1):
            if i == bad:
                o = m.pose.orientation
                wrong = _pose_msg((m.pose.position.x, m.pose.position.y, m.pose.position.z),
                                  (o.x * 1.01, o.y * 1.01, o.z * 1.01, o.w * 1.01),
                                  stamp_of(m) - 1)
                probe.expect_no_answer(wrong)
                dropped = probe.diagnostics_value("dropped_quaternion_not_unit")
                in_contact = probe.diagnostics_value("contacts")
            answers.append(probe.step(m, centerline=True))
        n = len(answers)
        assert probe.spin_until(lambda: len(probe.got["contacts"]) >= n, 10.0)
        assert probe.spin_until(lambda: probe.got["obstacles"] and probe.got["obstacle"], 10.0)
        got = {key: list(value) for key, value in probe.got.items()}
        alive = proc.poll() is None
    finally:
        probe.destroy()
        code = stop(proc)
    return dict(values=values, msgs=msgs, answers=answers, got=got, alive=alive, code=code,
                dropped=dropped, contacts_at_drop=in_contact, log=log)


def test_the_base_frame_is_the_foot_frame_the_core_frame_is_rolled():
    """The wrench in base_frame = the world load seen from the foot's orientation (q_pose)."""
    values = _shipped_values()
    msgs = _poses()[:12]
    _, expected = _expected(values, msgs)
    cfg = build_config(values)
    state, wrench, _, _ = expected[-1]
    o = msgs[-1].pose.orientation
    foot = quat_matrix((o.w, o.x, o.y, o.z))
    want = (tuple(foot.T @ np.array(state.force) * cfg.units.force)
            + tuple(foot.T @ np.array(state.moment) * cfg.units.moment))
    assert state.contacts and wrench == pytest.approx(want, rel=1e-12)


def test_the_wrench_has_six_components_equal_to_the_rod_tracker(run):
    assert run["alive"] and run["code"] == 0
    msgs, answers = run["msgs"], run["answers"]
    cfg, expected = _expected(run["values"], msgs)
    force, moment = cfg.units.force, cfg.units.moment
    assert len(answers) == len(msgs) - 1
    for msg, w, (_, want, _, _) in zip(msgs[1:], answers, expected[1:]):
        assert stamp_of(w) == stamp_of(msg) and w.header.frame_id == "whisker_base"
        got = _six(w)
        assert all(math.isfinite(v) for v in got)
        for a, b, scale in zip(got, want, (force,) * 3 + (moment,) * 3):
            assert _rel(a, b, scale)
    # in 3D: every component is loaded at some pose (the roll tilts the bending out of x-y)
    loaded = np.array([_six(w) for w in answers])
    assert (np.abs(loaded).max(axis=0) > 1e-3 * np.array([force] * 3 + [moment] * 3)).all()


def test_a_non_unit_quaternion_is_dropped_reported_and_the_state_kept(run):
    assert run["dropped"] == "1"
    assert run["contacts_at_drop"] == "1"  # in contact with the ball when it came
    # the answers after it equal the core's, which never saw it (checked pose for pose above)
    statuses = [s for a in run["got"]["diagnostics"] for s in a.status
                if s.hardware_id == PREFIX]
    assert any("quaternion_not_unit" in s.message for s in statuses)


def test_contacts_events_centerline_and_markers_are_3d_and_finite(run):
    got, msgs = run["got"], run["msgs"]
    cfg, expected = _expected(run["values"], msgs)
    expected = expected[1:]
    clouds = got["contacts"][-len(expected):]
    counts = []
    for cloud, (_, _, contacts, _) in zip(clouds, expected):
        records = decode_contacts(cloud)
        assert len(records) == len(contacts)
        counts.append(len(records))
        for g, c in zip(records, contacts):
            assert (g.kind, g.state, g.obstacle) == (c.kind, c.state, c.obstacle)
            for a, b, scale in ((g.x, c.x, 0.03), (g.y, c.y, 0.03), (g.z, c.z, 0.03),
                                (g.s, c.s, 0.03), (g.fx, c.fx, cfg.units.force),
                                (g.fy, c.fy, cfg.units.force), (g.fz, c.fz, cfg.units.force)):
                assert math.isfinite(a) and _rel(a, b, scale)
    assert {0, 1} <= set(counts)
    assert any(abs(r.fz) > 0 for c in clouds for r in decode_contacts(c))
    events = [json.loads(e.data) for e in got["events"]]
    want = [e for *_, evs in expected for e in evs]
    assert [(e["kind"], e.get("obstacle")) for e in events] == [(e.kind, e.obstacle)
                                                                for e in want]
    assert [e["kind"] for e in events].count("touch") >= 1
    assert "release" in [e["kind"] for e in events]
    for e in events:
        assert all(math.isfinite(v) for v in (e["x"], e["y"], e["z"], e["yaw"]))
        assert len(e["orientation"]) == 4 and e["contact"] in ("side", "tip")
    # the centerline in 3D: from the foot, out of the x-y plane (the roll), finite
    path = got["centerline"][-1]
    points = np.array([(p.pose.position.x, p.pose.position.y, p.pose.position.z)
                       for p in path.poses])
    assert np.isfinite(points).all() and len(points) == 41
    last = msgs[-1].pose.position
    assert points[0] == pytest.approx((last.x, last.y, last.z), abs=1e-12)
    assert np.ptp(points[:, 2]) > 1e-3
    # the obstacles: a SPHERE and a thin CUBE for the floor, latched
    array = got["obstacles"][-1]
    assert array.markers[0].action == Marker.DELETEALL
    ball, floor = array.markers[1:3]
    assert (ball.type, ball.text, ball.header.frame_id) == (Marker.SPHERE, "ball", "world")
    assert (ball.pose.position.x, ball.pose.position.y, ball.pose.position.z) == pytest.approx(
        (0.02, 0.012, 0.002), rel=1e-12)
    assert ball.scale.x == pytest.approx(0.008, rel=1e-12)
    assert (floor.type, floor.text) == (Marker.CUBE, "floor")
    assert floor.pose.position.z + 0.5 * floor.scale.z == pytest.approx(-0.006, rel=1e-12)
    assert got["obstacle"][-1].type == Marker.SPHERE


def test_the_recorded_3d_run_is_reproduced_by_resim(run):
    log = run["log"]
    info = log_info(str(log))
    config = info.configurations[0][1]
    assert config["model"] == "rod3d" and config["whisker.parabola"] == 10.0
    assert config["whisker.roll"] == 0.5 and config["whisker.poisson"] == 0.38
    assert config["obstacle.scene_text"] == SCENE_M.read_text()
    sim = resimulate(str(log))
    assert not sim.mismatches
    assert sim.worst() <= 1e-12
    assert sim.dropped == {"quaternion_not_unit": 1}
    n = len(run["msgs"]) - 1
    for key in ("wrench.force.z", "wrench.torque.x", "wrench.torque.y", "contact_force.z"):
        assert sim.compared[key] >= n, key
    assert sim.compared["contacts.fz"] >= 1 and sim.compared["events.z"] >= 2
    proc = subprocess.run([VIBRISSA, "resim", str(log)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "wrench.torque.x" in proc.stdout and "OK" in proc.stdout
