"""Scenes in whisker_node without DDS: parameters, pipeline, ~/contacts, ~/obstacles, events."""

import os

os.environ.setdefault("ROS_PYTHON_CHECK_FIELDS", "1")  # before the message modules are imported

# E402 below: the imports must follow that setting
import json  # noqa: E402
import math  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402
from sensor_msgs.msg import PointCloud2, PointField  # noqa: E402
from visualization_msgs.msg import Marker  # noqa: E402

from vibrissa_ros.core import FootPose, ParameterError, QuasistaticTracker  # noqa: E402
from vibrissa_ros.core.scenes.tracker import SceneTracker  # noqa: E402
from vibrissa_ros.node.edge import (  # noqa: E402
    ContactRecord, contact_records, decode_event, encode_event, event_record, planar_pose,
    sensor_reading,
)
from vibrissa_ros.node.config import SCENE_TEXT, build_config  # noqa: E402
from vibrissa_ros.node.pipeline import PosePipeline  # noqa: E402
from vibrissa_ros.ros import messages as m  # noqa: E402
from vibrissa_ros.scan.scene_file import load_scene  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENE_M = ROOT / "config" / "scene_two_pegs_m.yaml"
HALF_PI = math.pi / 2
Q = (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))
TWO_PEGS = {
    "whisker.length": 0.03, "whisker.youngs_modulus": 3.3e9, "whisker.base_radius": 5e-5,
    "obstacle.type": "scene", "obstacle.scene_file": str(SCENE_M),
}


@pytest.fixture
def check_fields(monkeypatch):
    """Make every message built here check its field types (whatever imported them first)."""
    import builtin_interfaces.msg._time as time_module
    import sensor_msgs.msg._point_cloud2 as cloud_module
    import sensor_msgs.msg._point_field as field_module
    import std_msgs.msg._header as header_module

    for module in (cloud_module, field_module, header_module, time_module):
        monkeypatch.setattr(module, "ros_python_check_fields", "1")
    assert PointCloud2()._check_fields and PointField()._check_fields


def _stamp(ns):
    from builtin_interfaces.msg import Time

    return Time(sec=ns // 10**9, nanosec=ns % 10**9)


def _sweep_x():
    return list(np.linspace(-0.0045, 0.0075, 41)) + list(np.linspace(0.0075, -0.0045, 41))[1:]


# -- ~/contacts -----------------------------------------------------------------------------------
def test_contacts_cloud_decodes_to_the_values_it_was_built_from(check_fields):
    contacts = (ContactRecord(0.001, 0.012, -0.25, 1e-3, 0.0125, 0, 0, 0),
                ContactRecord(-0.0061, 0.0249, 3e-5, -2.5e-4, 0.03, 2, 1, 7),
                ContactRecord(1.0 / 3.0, -2.0 / 7.0, math.pi, -math.e, 0.1, 1, 1, 4_000_000_000))
    cloud = m.contacts_cloud(_stamp(5_000_000_123), "world", contacts)
    cloud = deserialize_message(serialize_message(cloud), PointCloud2)
    assert cloud.header.frame_id == "world"
    assert (cloud.header.stamp.sec, cloud.header.stamp.nanosec) == (5, 123)
    assert (cloud.height, cloud.width, cloud.point_step, cloud.row_step) == (1, 3, 64, 192)
    assert not cloud.is_bigendian and cloud.is_dense
    fields = {f.name: (f.offset, f.datatype, f.count) for f in cloud.fields}
    assert fields == {
        "x": (0, PointField.FLOAT64, 1), "y": (8, PointField.FLOAT64, 1),
        "z": (16, PointField.FLOAT64, 1), "fx": (24, PointField.FLOAT64, 1),
        "fy": (32, PointField.FLOAT64, 1), "s": (40, PointField.FLOAT64, 1),
        "kind": (48, PointField.UINT8, 1), "state": (49, PointField.UINT8, 1),
        "obstacle": (52, PointField.UINT32, 1), "fz": (56, PointField.FLOAT64, 1)}
    assert m.decode_contacts(cloud) == contacts  # exact: float64 throughout
    # read as any PointCloud2 consumer does, by the field table (z is 0: the plane of bending)
    raw = bytes(cloud.data)
    for i, c in enumerate(contacts):
        base = i * cloud.point_step
        row = {name: np.frombuffer(raw, dtype={PointField.FLOAT64: "<f8", PointField.UINT8: "u1",
                                               PointField.UINT32: "<u4"}[kind],
                                   count=1, offset=base + off)[0]
               for name, (off, kind, _) in fields.items()}
        assert float(row["z"]) == 0.0 and float(row["fz"]) == 0.0
        assert (float(row["x"]), float(row["y"]), float(row["fx"]), float(row["fy"]),
                float(row["s"])) == (c.x, c.y, c.fx, c.fy, c.s)
        assert (int(row["kind"]), int(row["state"]), int(row["obstacle"])) == (
            c.kind, c.state, c.obstacle)


def test_a_3d_contact_round_trips_and_an_old_cloud_without_fz_reads_as_zero(check_fields):
    contact = ContactRecord(0.02, 0.011, -0.5, 0.25, 0.021, 1, 0, 1, -0.003, 0.125)
    cloud = deserialize_message(serialize_message(
        m.contacts_cloud(_stamp(1), "world", (contact,))), PointCloud2)
    assert m.decode_contacts(cloud) == (contact,)
    cloud.fields = [f for f in cloud.fields if f.name != "fz"]  # as recorded before fz
    assert m.decode_contacts(cloud) == (ContactRecord(0.02, 0.011, -0.5, 0.25, 0.021, 1, 0, 1,
                                                      -0.003, 0.0),)


def test_an_empty_cloud_when_free(check_fields):
    cloud = deserialize_message(serialize_message(m.contacts_cloud(_stamp(1), "map", ())),
                                PointCloud2)
    assert (cloud.width, cloud.height, cloud.row_step, len(cloud.data)) == (0, 1, 0, 0)
    assert len(cloud.fields) == 10 and m.decode_contacts(cloud) == ()


def test_a_cloud_without_a_field_is_refused(check_fields):
    cloud = m.contacts_cloud(_stamp(1), "world", (ContactRecord(0, 0, 0, 0, 0, 0, 0, 0),))
    cloud.fields = [f for f in cloud.fields if f.name != "state"]
    with pytest.raises(ValueError, match="state"):
        m.decode_contacts(cloud)


def test_contact_records_of_a_scene_state_are_si_with_the_codes(check_fields):
    cfg = build_config(dict(TWO_PEGS, **{"obstacle.scene_file": str(SCENE_M)}))
    tracker = SceneTracker(list(cfg.scene), FootPose(-0.1, 0.0, HALF_PI), shape=cfg.shape,
                           friction=cfg.friction)
    state = tracker.step(FootPose(0.2, 0.0, HALF_PI)).state
    assert len(state.contacts) == 2
    L, F = cfg.units.length, cfg.units.force
    records = contact_records(state, cfg.units)
    for c, r in zip(state.contacts, records):
        assert (r.x, r.y, r.fx, r.fy, r.s) == (c.x * L, c.y * L, c.fx * F, c.fy * F, c.s * L)
        assert r.kind == {"side": 0, "tip": 1, "corner": 2}[c.report_kind]
        assert r.state == {"slip": 0, "stick": 1}[c.state] and r.obstacle == c.obstacle
    assert [r.obstacle for r in records] == [0, 1]


def test_contact_records_of_a_single_contact_state():
    cfg = build_config({"obstacle.type": "catenary", "obstacle.apex_y": 0.05})
    tracker = QuasistaticTracker(cfg.profile, FootPose(0.2 / 0.1, 0.0, HALF_PI), model=cfg.model)
    assert contact_records(tracker.state, cfg.units) == ()
    state = tracker.step(FootPose(0.0, 0.0, HALF_PI)).state
    (r,) = contact_records(state, cfg.units)
    reading = sensor_reading(state, cfg.units)
    assert (r.x, r.y) == reading.contact_world and r.s == reading.s1
    assert (r.fx, r.fy) == reading.force_world
    assert (r.kind, r.state, r.obstacle) == ((0 if int(state.phase) == 1 else 1), 0, 0)


# -- parameters -----------------------------------------------------------------------------------
def test_the_scene_file_is_read_in_metres_with_its_friction():
    cfg = build_config(TWO_PEGS)
    assert cfg.multi_contact and cfg.profile is None
    assert cfg.scene == load_scene(SCENE_M, length_scale=0.03)
    assert cfg.scene[0].x == 0.0 and cfg.scene[0].y == pytest.approx(0.4, rel=1e-15)
    assert cfg.friction == (0.0, 0.3)
    assert (cfg.units.length == 0.03
            and cfg.units.moment * 0.03 == pytest.approx(3.3e9 * math.pi * 5e-5**4 / 4, rel=1e-15))
    assert "scene of 2 obstacle(s)" in cfg.describe() and "scene tracker" in cfg.describe()
    record = cfg.record_values
    assert record[SCENE_TEXT] == SCENE_M.read_text()
    # a log's configuration rebuilds the same scene from the recorded text, without the file
    again = build_config(dict(record, **{"obstacle.scene_file": "/nonexistent/scene.yaml"}))
    assert again.scene == cfg.scene and again.friction == cfg.friction


def test_a_package_path_finds_the_shipped_scene():
    """package://vibrissa_ros/...: the ament index, else the install prefix or the checkout."""
    cfg = build_config(dict(TWO_PEGS, **{
        "obstacle.scene_file": "package://vibrissa_ros/config/scene_two_pegs_m.yaml"}))
    assert cfg.scene == build_config(TWO_PEGS).scene


def test_taper_and_curvature_go_to_the_scene_tracker():
    cfg = build_config(dict(TWO_PEGS, **{"whisker.taper": 0.2, "whisker.curvature_k0": 10.0,
                                         "whisker.curvature_k1": -100.0}))
    assert (cfg.shape.taper, cfg.shape.k0, cfg.shape.k1) == pytest.approx((0.2, 0.3, -0.09),
                                                                          rel=1e-15)


def test_one_profile_without_friction_runs_the_single_contact_path(tmp_path):
    one = tmp_path / "one.yaml"
    one.write_text("obstacles:\n  - {type: peg, x: 0.0, y: 0.015, r: 0.00025}\n")
    scene_cfg = build_config(dict(TWO_PEGS, **{"obstacle.scene_file": str(one)}))
    peg_cfg = build_config(dict(TWO_PEGS, **{"obstacle.type": "peg", "obstacle.peg_x": 0.0,
                                             "obstacle.peg_y": 0.015,
                                             "obstacle.peg_radius": 0.00025}))
    assert not scene_cfg.multi_contact and scene_cfg.profile == peg_cfg.profile
    a, b = PosePipeline(scene_cfg), PosePipeline(peg_cfg)
    for i, x in enumerate(np.linspace(0.006, -0.006, 25)):
        sa, _ = a.handle("world", i, (float(x), 0.0, 0.0), Q)
        sb, _ = b.handle("world", i, (float(x), 0.0, 0.0), Q)
        assert (sa.fx, sa.fy, sa.m0) == (sb.fx, sb.fy, sb.m0)
    one.write_text("friction: 0.2\nobstacles:\n  - {type: peg, x: 0.0, y: 0.015, r: 0.00025}\n")
    assert build_config(dict(TWO_PEGS, **{"obstacle.scene_file": str(one)})).multi_contact


@pytest.mark.parametrize("text, reason", [
    (None, "cannot read"),
    ("obstacles: [{type: peg, x: 0.0, y: 0.01, r: -0.001}]", "obstacle 0"),
    ("obstacles: [{type: peg, x: 0.0, y: 0.01, r: 0.001}, {type: peg, x: 0.0005, y: 0.01, "
     "r: 0.001}]", "overlap"),
    ("friction: -0.1\nobstacles: [{type: peg, x: 0.0, y: 0.01, r: 0.001}]", "friction"),
    ("obstacles: [{type: polygon, vertices: [[0, 0.01], [0.01, 0.02], [0.01, 0.01], "
     "[0, 0.02]]}]", "intersect"),
    ("obstacles: [{type: peg, x: 0.0, y: 0.01", "not valid YAML"),
    ("obstacles: []", "non-empty"),
])
def test_a_bad_scene_file_is_refused_with_a_one_line_reason(tmp_path, text, reason):
    path = tmp_path / "bad.yaml"
    if text is not None:
        path.write_text(text + "\n")
    with pytest.raises(ParameterError) as info:
        build_config(dict(TWO_PEGS, **{"obstacle.scene_file": str(path)}))
    message = str(info.value)
    assert message.startswith(f"obstacle.scene_file = {str(path)!r}: ")
    assert reason in message and "\n" not in message


def test_a_scene_needs_a_file_and_the_elastica():
    with pytest.raises(ParameterError, match="needs obstacle.scene_file"):
        build_config(dict(TWO_PEGS, **{"obstacle.scene_file": ""}))
    with pytest.raises(ParameterError, match="model 'elastica'"):
        build_config(dict(TWO_PEGS, model="rigid"))
    with pytest.raises(ParameterError, match="package"):
        build_config(dict(TWO_PEGS, **{"obstacle.scene_file": "package://no_such_pkg_xyz/a.yaml"}))


# -- the pipeline ---------------------------------------------------------------------------------
def test_the_pipeline_steps_the_scene_tracker_exactly():
    cfg = build_config(TWO_PEGS)
    pipeline = PosePipeline(cfg)
    xs = _sweep_x()
    tracker = None
    kinds, most = [], 0
    for i, x in enumerate(xs):
        state, events = pipeline.handle("world", i, (float(x), 0.0, 0.0), Q)
        pose = cfg.units.foot_pose(*planar_pose((float(x), 0.0, 0.0), Q, 1e-6, 1e-6))
        if tracker is None:
            tracker = SceneTracker(list(cfg.scene), pose, shape=cfg.shape, friction=cfg.friction)
            want, want_events = tracker.state, ()
        else:
            result = tracker.step(pose)
            want, want_events = result.state, result.events
        assert (state.contacts == want.contacts
                and (state.fx, state.fy, state.m0) == (want.fx, want.fy, want.m0))
        assert events == want_events
        kinds += [e.kind for e in events]
        most = max(most, len(state.contacts))
        reading, sensed = pipeline.reading(state)
        assert sensed == (reading.force_base[0], reading.force_base[1], reading.torque_z)
        assert reading.torque_z == state.m0 * cfg.units.moment
        if state.contacts:  # the single-contact topics describe the contact nearest the foot
            near = state.contacts[0]
            assert (reading.s1 == near.s * 0.03
                    and reading.contact_world == (near.x * 0.03, near.y * 0.03))
    assert most == 2 and kinds.count("touch") == 2 and "release" in kinds


def test_scene_events_round_trip_through_the_payload():
    cfg = build_config(TWO_PEGS)
    pipeline = PosePipeline(cfg)
    events = []
    for i, x in enumerate(_sweep_x()):
        events += pipeline.handle("world", i, (float(x), 0.0, 0.0), Q)[1]
    assert events
    for e in events:
        record = event_record(e, cfg.units)
        payload = json.loads(encode_event(record))
        assert "from_phase" not in payload and payload["kind"] == e.kind
        assert payload["x"] == e.pose.x * 0.03 and payload["contact"] == e.contact_kind
        assert payload["obstacle"] == e.obstacle
        assert decode_event(encode_event(record)) == record


# -- ~/obstacles and ~/obstacle -------------------------------------------------------------------
def test_obstacle_markers_of_a_scene_and_of_a_profile():
    cfg = build_config(TWO_PEGS)
    array = m.scene_markers(cfg.scene, 0.03, "world", _stamp(1))
    strips = [mk for mk in array.markers if mk.type == Marker.LINE_STRIP]
    assert [mk.text for mk in strips] == ["peg0", "peg1"]
    outline = m.outline_marker(array)
    assert outline.type == Marker.LINE_LIST and outline.header.frame_id == "world"
    assert len(outline.points) == sum(2 * (len(mk.points) - 1) for mk in strips)
    ring = np.array([(p.x, p.y) for p in outline.points])
    near0 = np.hypot(ring[:, 0], ring[:, 1] - 0.012)
    near1 = np.hypot(ring[:, 0] + 0.006, ring[:, 1] - 0.0255)
    assert np.minimum(near0, near1) == pytest.approx(0.0005, rel=1e-9)
    single = build_config({"obstacle.type": "catenary"})
    array = m.profile_markers(single.profile, 0.1, "world", _stamp(1))
    assert [mk.action for mk in array.markers] == [Marker.DELETEALL, Marker.ADD]
    assert list(array.markers[1].points) == list(
        m.obstacle_marker(single.profile, 0.1, "world", _stamp(1)).points)
