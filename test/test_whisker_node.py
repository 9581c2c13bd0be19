"""Launch-free integration tests of the installed whisker_node over real DDS."""

import json
import math
import signal

import numpy as np
import pytest
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from ros_harness import ROOT, Probe, pose_msg, stamp_of, start_installed_node, stop, write_params

from vibrissa_ros.core import QuasistaticTracker
from vibrissa_ros.node.edge import planar_pose, sensor_reading
from vibrissa_ros.node.config import build_config

HALF_PI = math.pi / 2
CATENARY = {
    "model": "elastica",
    "whisker.length": 0.1,
    "whisker.bending_stiffness": 5e-4,
    "obstacle.type": "catenary",
    "obstacle.c": 0.06,
    "obstacle.apex_x": 0.0,
    "obstacle.apex_y": 0.05,
    "diagnostics.period": 0.2,
    "centerline.max_rate": 0.0,
}


def _expected(values, msgs):
    """Compute the core's answers for the same poses, converted exactly as the node does."""
    cfg = build_config(values)
    tracker, out = None, []
    for m in msgs:
        p, q = m.pose.position, m.pose.orientation
        x, y, yaw = planar_pose((p.x, p.y, p.z), (q.x, q.y, q.z, q.w), 1e-6, 1e-6)
        pose = cfg.units.foot_pose(x, y, yaw)
        if tracker is None:
            tracker = QuasistaticTracker(cfg.profile, pose, model=cfg.model)
            state, events = tracker.state, ()
        else:
            res = tracker.step(pose)
            state, events = res.state, res.events
        out.append((state, sensor_reading(state, cfg.units), events))
    return out


@pytest.fixture
def node(installed, ros_env, rcl_context, tmp_path, request):
    """Start whisker_node with the parameters of the test's ``params`` marker (or catenary)."""
    marker = request.node.get_closest_marker("params")
    values = dict(marker.args[0]) if marker else dict(getattr(request, "param", CATENARY))
    params = write_params(tmp_path / "params.yaml", values)
    proc = start_installed_node(installed, params, ros_env)
    probe = Probe(rcl_context, "/whisker_node")
    yield proc, probe, values
    probe.destroy()
    stop(proc)


def _close(a, b, scale):
    return a == pytest.approx(b, rel=1e-12, abs=1e-14 * scale)


def test_installed_node_comes_up_and_answers(node):
    proc, probe, values = node
    probe.handshake(pose_msg(0.2, 0.0, HALF_PI, 1))
    wrench = probe.step(pose_msg(0.19, 0.0, HALF_PI, 2))
    assert wrench.header.frame_id == "whisker_base"
    assert (wrench.wrench.force.x, wrench.wrench.force.y, wrench.wrench.torque.z) == (0.0, 0.0,
                                                                                      0.0)
    probe.spin_until(lambda: probe.got["obstacle"], 5.0)
    marker = probe.got["obstacle"][-1]
    assert marker.header.frame_id == "world" and len(marker.points) > 100
    apex = min(marker.points, key=lambda p: p.y)
    assert (apex.x, apex.y) == pytest.approx((0.0, 0.05), abs=1e-4)
    # the handshake's repeats and the step
    assert int(probe.diagnostics_value("poses_processed")) >= 2
    assert probe.diagnostics_value("phase") == "0"
    assert proc.poll() is None


def test_sweep_outputs_equal_the_core_in_si_and_the_base_frame(node):
    proc, probe, values = node
    xs = list(np.round(np.arange(0.15, -0.15, -0.0025), 10)) + list(
        np.round(np.arange(-0.15, 0.1501, 0.0025), 10))
    msgs = [pose_msg(x, 0.0, HALF_PI, 1_000_000_000 + i * 1_000_000) for i, x in enumerate(xs)]
    probe.handshake(msgs[0])
    wrenches = [probe.step(m, centerline=True) for m in msgs[1:]]
    expected = _expected(values, msgs)[1:]
    force_scale = 5e-4 / 0.1**2
    in_contact = 0
    for m, w, (state, reading, _) in zip(msgs[1:], wrenches, expected):
        assert stamp_of(w) == stamp_of(m)
        assert _close(w.wrench.force.x, reading.force_base[0], force_scale)
        assert _close(w.wrench.force.y, reading.force_base[1], force_scale)
        assert _close(w.wrench.torque.z, reading.torque_z, force_scale * 0.1)
        assert (w.wrench.force.z, w.wrench.torque.x, w.wrench.torque.y) == (0.0, 0.0, 0.0)
        in_contact += state.phase > 0
    assert in_contact > 50
    n = len(wrenches)
    assert [p.data for p in probe.got["phase"]] == [r.phase for _, r, _ in expected]
    for msg, (_, r, _) in zip(probe.got["contact_force"], expected):
        assert msg.header.frame_id == "world"
        assert _close(msg.vector.x, r.force_world[0], force_scale) and _close(msg.vector.y,
                                                                              r.force_world[1],
                                                                              force_scale)
    mags = [m.data for m in probe.got["contact_force_magnitude"]]
    assert len(mags) == n and all(_close(a, r.force_magnitude, force_scale)
                                  for a, (_, r, _) in zip(mags, expected))
    contacts = [(r.contact_world, r.s1) for _, r, _ in expected if r.contact_world is not None]
    assert len(probe.got["contact_point"]) == len(contacts) == len(probe.got["arc_length"])
    for msg, s1_msg, (c, s1) in zip(probe.got["contact_point"], probe.got["arc_length"], contacts):
        assert _close(msg.point.x, c[0], 0.1) and _close(msg.point.y, c[1], 0.1)
        assert _close(s1_msg.data, s1, 0.1)
    events = [json.loads(e.data) for e in probe.got["events"]]
    want = [(e.kind, int(e.from_phase), int(e.to_phase), e.pose.x * 0.1) for _, _, evs in expected
            for e in evs]
    assert [(e["kind"], e["from_phase"], e["to_phase"]) for e in events] == [w[:3] for w in want]
    assert [e["kind"] for e in events].count("snap") == 2  # hysteresis: one snap each way
    for got, w in zip(events, want):
        assert got["x"] == pytest.approx(w[3], rel=1e-12, abs=1e-15)
    for path, m, (state, _, _) in zip(probe.got["centerline"], msgs[1:], expected):
        assert stamp_of(path) == stamp_of(m) and path.header.frame_id == "world"
        first, last = path.poses[0].pose.position, path.poses[-1].pose.position
        assert (first.x, first.y) == pytest.approx((m.pose.position.x, 0.0), abs=1e-15)
        assert (last.x, last.y) == pytest.approx((state.tip[0] * 0.1, state.tip[1] * 0.1),
                                                 abs=1e-13)
    numbers = [v for w in wrenches for v in (w.wrench.force.x, w.wrench.force.y,
                                             w.wrench.torque.z)]
    assert all(math.isfinite(v) for v in numbers)


def test_bad_inputs_are_dropped_counted_and_the_state_is_kept(node, rcl_context):
    proc, probe, values = node
    probe.handshake(pose_msg(0.15, 0.0, HALF_PI, 1_000))
    good = [pose_msg(x, 0.0, HALF_PI, 2_000 + i) for i, x in enumerate((0.1, 0.05, 0.0))]
    for m in good:
        probe.step(m)
    bad_quat = pose_msg(-0.01, 0.0, HALF_PI, 3_000)
    bad_quat.pose.orientation.w *= 1.5
    rolled = pose_msg(-0.01, 0.0, HALF_PI, 3_001)
    rolled.pose.orientation.x = math.sin(0.05)
    rolled.pose.orientation.w = math.cos(0.05)
    rolled.pose.orientation.z = 0.0
    cases = {
        "not_finite": pose_msg(float("nan"), 0.0, HALF_PI, 3_002),
        "quaternion_not_unit": bad_quat,
        "out_of_plane": pose_msg(-0.01, 0.0, HALF_PI, 3_003, z=0.01),
        "wrong_frame_id": pose_msg(-0.01, 0.0, HALF_PI, 3_004, frame="map"),
        "stamp_backwards": pose_msg(-0.01, 0.0, HALF_PI, 10),
    }
    for reason, msg in cases.items():
        probe.expect_no_answer(msg)
        assert probe.diagnostics_value(f"dropped_{reason}") == "1", reason
    probe.expect_no_answer(rolled)
    assert probe.diagnostics_value("dropped_out_of_plane") == "2"
    # the state was kept: the next good pose continues the branch as if nothing had come in between
    after = pose_msg(-0.01, 0.0, HALF_PI, 4_000)
    wrench = probe.step(after)
    expected = _expected(values, [pose_msg(0.15, 0.0, HALF_PI, 1_000)] + good + [after])[-1][1]
    assert _close(wrench.wrench.torque.z, expected.torque_z, 5e-3)
    assert proc.poll() is None
    # a reset by a runtime change, then a first pose that puts the straight whisker inside the
    # obstacle
    client = probe.node.create_client(SetParameters, "/whisker_node/set_parameters")
    assert client.wait_for_service(timeout_sec=10.0)
    change = Parameter(name="obstacle.apex_y",
                       value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE,
                                            double_value=0.045))
    future = client.call_async(SetParameters.Request(parameters=[change]))
    probe.spin_until(future.done, 10.0)
    assert future.result().results[0].successful
    probe.expect_no_answer(pose_msg(0.0, 0.0, HALF_PI, 5_000))
    assert probe.diagnostics_value("dropped_inside_obstacle") == "1"
    assert probe.diagnostics_value("phase") == "none"
    wrench = probe.step(pose_msg(0.2, 0.0, HALF_PI, 5_001))  # a free first pose places it
    assert wrench.wrench.torque.z == 0.0


def test_runtime_parameter_changes_are_validated_with_a_reason(node):
    proc, probe, values = node
    probe.handshake(pose_msg(0.15, 0.0, HALF_PI, 1))
    probe.step(pose_msg(0.05, 0.0, HALF_PI, 2))
    client = probe.node.create_client(SetParameters, "/whisker_node/set_parameters")
    assert client.wait_for_service(timeout_sec=10.0)

    def set_(name, kind, **value):
        req = SetParameters.Request(
            parameters=[Parameter(name=name, value=ParameterValue(type=kind, **value))])
        future = client.call_async(req)
        probe.spin_until(future.done, 10.0)
        return future.result().results[0]

    bad = set_("whisker.length", ParameterType.PARAMETER_DOUBLE, double_value=-0.1)
    assert not bad.successful and "whisker.length" in bad.reason
    bad = set_("obstacle.type", ParameterType.PARAMETER_STRING, string_value="cone")
    assert not bad.successful and "allowed" in bad.reason and "parabola" in bad.reason
    bad = set_("world_frame", ParameterType.PARAMETER_STRING, string_value="map")
    assert not bad.successful and "read-only" in bad.reason.lower().replace("read only",
                                                                            "read-only")
    probe.got["obstacle"].clear()
    good = set_("obstacle.type", ParameterType.PARAMETER_STRING, string_value="parabola")
    assert good.successful
    probe.spin_until(lambda: probe.got["obstacle"], 5.0)  # the new obstacle is re-published
    apex = min(probe.got["obstacle"][-1].points, key=lambda p: p.y)
    assert apex.y == pytest.approx(0.05, abs=1e-6)
    # reset: the next pose places a straight whisker (free there), whatever the previous state
    wrench = probe.step(pose_msg(0.2, 0.0, HALF_PI, 3))
    assert wrench.wrench.torque.z == 0.0
    assert probe.got["phase"][-1].data == 0


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_clean_exit_on_signals(installed, ros_env, tmp_path, sig, rcl_context):
    proc = start_installed_node(installed, write_params(tmp_path / "p.yaml", CATENARY), ros_env)
    probe = Probe(rcl_context, "/whisker_node", name="probe_signal")
    try:
        probe.handshake(pose_msg(0.2, 0.0, HALF_PI, 1))
    finally:
        probe.destroy()
    code = stop(proc, sig)
    out = proc.stdout.read()
    assert code == 0, out
    assert "Traceback" not in out


@pytest.mark.parametrize("config", ["default", "catenary", "two_circles", "parabola_rigid",
                                    "rat_pole"])
def test_shipped_parameter_files_start_the_node(installed, ros_env, rcl_context, config):
    params = ROOT / "config" / f"{config}.yaml"
    proc = start_installed_node(installed, params, ros_env, namespace=f"/{config}")
    probe = Probe(rcl_context, f"/{config}/whisker_node", name=f"probe_{config}")
    try:
        probe.handshake(pose_msg(0.25, 0.0, HALF_PI, 1))
        wrench = probe.step(pose_msg(0.0, 0.0, HALF_PI, 2))
        assert wrench.wrench.torque.z < 0.0  # bent clockwise against the obstacle
    finally:
        probe.destroy()
        assert stop(proc) == 0


def test_two_whiskers_run_side_by_side_in_their_own_namespaces(installed, ros_env, rcl_context,
                                                               tmp_path):
    left = dict(CATENARY)
    right = dict(CATENARY, **{"obstacle.type": "parabola", "obstacle.k": 10.0,
                              "obstacle.apex_y": 0.03})
    procs = [
        start_installed_node(installed, write_params(tmp_path / "l.yaml", left), ros_env,
                             namespace="/left"),
        start_installed_node(installed, write_params(tmp_path / "r.yaml", right), ros_env,
                             namespace="/right"),
    ]
    probes = [Probe(rcl_context, "/left/whisker_node", "probe_l"),
              Probe(rcl_context, "/right/whisker_node", "probe_r")]
    try:
        msgs = [pose_msg(x, 0.0, HALF_PI, 10 + i) for i, x in enumerate((0.2, 0.1, 0.05, 0.0))]
        for probe in probes:
            probe.handshake(msgs[0])
        for values, probe in zip((left, right), probes):
            got = [probe.step(m) for m in msgs[1:]]
            want = _expected(values, msgs)[1:]
            for w, (_, r, _) in zip(got, want):
                assert _close(w.wrench.torque.z, r.torque_z, 5e-3)
        assert (probes[0].got["wrench"][-1].wrench.torque.z
                != probes[1].got["wrench"][-1].wrench.torque.z)
    finally:
        for probe in probes:
            probe.destroy()
        assert [stop(p) for p in procs] == [0, 0]


def test_invalid_startup_parameters_exit_with_the_reason(installed, ros_env, tmp_path):
    bad = dict(CATENARY, **{"obstacle.c": -0.06})
    proc = start_installed_node(installed, write_params(tmp_path / "bad.yaml", bad), ros_env)
    code = proc.wait(timeout=30)
    out = proc.stdout.read()
    assert code != 0
    assert "obstacle.c" in out and "> 0" in out


def test_vibrissa_sweep_drives_the_node_and_records_si_rows(node):
    from vibrissa_ros.ros.sweep import run_sweep

    proc, probe, values = node
    poses = [(float(x), 0.0, HALF_PI) for x in np.round(np.arange(0.12, -0.12, -0.004), 10)]
    rows = run_sweep(poses, node="/whisker_node", timeout=10.0)
    assert len(rows) == len(poses)
    expected = _expected(values,
                         [pose_msg(x, y, yaw, i + 1) for i, (x, y, yaw) in enumerate(poses)])
    assert [r.phase for r in rows] == [r.phase for _, r, _ in expected]
    for row, (_, r, _) in zip(rows, expected):
        assert _close(row.torque_z, r.torque_z, 5e-3)
        assert _close(row.force_x, r.force_base[0], 5e-2) and _close(row.contact_force,
                                                                     r.force_magnitude, 5e-2)
        assert (row.contact_x is None) == (r.contact_world is None)
        if r.contact_world is not None:
            assert _close(row.contact_x, r.contact_world[0], 0.1) and _close(row.arc_length, r.s1,
                                                                             0.1)


def test_vibrissa_sweep_command_launches_the_node(tmp_path, ros_env):
    import subprocess
    import sys
    from pathlib import Path

    out = tmp_path / "sweep.csv"
    exe = Path(sys.executable).with_name("vibrissa")
    proc = subprocess.run(
        [str(exe), "sweep", "--launch", str(ROOT / "config" / "default.yaml"), "--from", "0.2",
         "--to", "-0.2", "--step", "0.01", "--back", "--csv", str(out)],
        env=ros_env, capture_output=True, text=True, timeout=180,
    )
    assert proc.returncode == 0, proc.stderr
    lines = out.read_text().splitlines()
    assert lines[0] == ("x,y,yaw,phase,force_x,force_y,torque_z,contact_force,contact_x,contact_y,"
                        "arc_length")
    assert len(lines) == 1 + 81
    phases = [int(line.split(",")[3]) for line in lines[1:]]
    assert set(phases) == {0, 1, 2}
    assert "nan" not in out.read_text().lower()


RAT_POLE = {
    "model": "elastica",
    "whisker.length": 0.03,
    "whisker.youngs_modulus": 3.3e9,
    "whisker.base_radius": 5e-5,
    "whisker.taper": 1.0 / 15.0,
    "whisker.curvature_k0": 1.0 / 0.06,
    "whisker.curvature_k1": -100.0,
    "obstacle.type": "peg",
    "obstacle.peg_x": 0.0,
    "obstacle.peg_y": 0.015,
    "obstacle.peg_radius": 2.5e-4,
    "diagnostics.period": 0.2,
    "centerline.max_rate": 0.0,
}


def _rat_pole_poses():
    """Translate past the pole and back, then whisk (foot fixed, heading sweeping) against it."""
    xs = list(np.linspace(0.008, -0.012, 81)) + list(np.linspace(-0.012, 0.008, 81))[1:]
    poses = [(x, 0.0, HALF_PI) for x in xs]
    poses += [(0.004, 0.0, HALF_PI + a) for a in np.linspace(0.0, 0.6, 61)]
    poses += [(0.004, 0.0, HALF_PI + a) for a in np.linspace(0.6, -0.3, 91)[1:]]
    return [pose_msg(float(x), y, float(h), 1_000_000_000 + i * 1_000_000)
            for i, (x, y, h) in enumerate(poses)]


@pytest.mark.parametrize("node", [RAT_POLE], indirect=True)
def test_tapered_curved_whisker_past_a_peg_equals_the_general_core(node):
    """
    Issue 12: the node's general model (taper, curvature, peg, E and r) == the core.

    In SI units, in the base frame.
    """
    proc, probe, values = node
    assert build_config(values).model.name == "general"
    msgs = _rat_pole_poses()
    probe.handshake(msgs[0])
    wrenches = [probe.step(m) for m in msgs[1:]]
    expected = _expected(values, msgs)[1:]
    ei = 3.3e9 * math.pi * 5e-5**4 / 4.0
    force_scale = ei / 0.03**2
    in_contact = 0
    for m, w, (state, reading, _) in zip(msgs[1:], wrenches, expected):
        assert stamp_of(w) == stamp_of(m) and w.header.frame_id == "whisker_base"
        for got, want, scale in ((w.wrench.force.x, reading.force_base[0], force_scale),
                                 (w.wrench.force.y, reading.force_base[1], force_scale),
                                 (w.wrench.torque.z, reading.torque_z, force_scale * 0.03)):
            assert got == pytest.approx(want, rel=1e-9, abs=1e-9 * scale)
        in_contact += state.phase > 0
    assert in_contact > 50
    assert [p.data for p in probe.got["phase"]] == [r.phase for _, r, _ in expected]
    contacts = [r.contact_world for _, r, _ in expected if r.contact_world is not None]
    probe.spin_until(lambda: len(probe.got["contact_point"]) >= len(contacts), 5.0)  # the last
    assert len(probe.got["contact_point"]) == len(contacts)  # step waits for the wrench only
    for msg, c in zip(probe.got["contact_point"], contacts):
        assert (msg.point.x, msg.point.y) == pytest.approx(c, rel=1e-9, abs=1e-9 * 0.03)
    events = [json.loads(e.data) for e in probe.got["events"]]
    want = [(e.kind, int(e.from_phase), int(e.to_phase)) for _, _, evs in expected for e in evs]
    assert [(e["kind"], e["from_phase"], e["to_phase"]) for e in events] == want
    assert "touch" in [k for k, _, _ in want]
    probe.spin_until(lambda: probe.got["obstacle"], 5.0)
    ring = np.array([(p.x, p.y) for p in probe.got["obstacle"][-1].points])
    assert np.hypot(ring[:, 0], ring[:, 1] - 0.015) == pytest.approx(2.5e-4, rel=1e-9)
