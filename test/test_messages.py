"""The message builders, without a node or DDS: every field the nodes publish."""

import json
import math

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import WrenchStamped
from rclpy.serialization import deserialize_message, serialize_message
from visualization_msgs.msg import Marker

from vibrissa_ros.core import FootPose, Parabola, QuasistaticTracker
from vibrissa_ros.node.edge import EventRecord, decode_event, header_ns, stamp_parts
from vibrissa_ros.node.config import build_config
from vibrissa_ros.ros import messages as m


def _stamp(ns):
    from builtin_interfaces.msg import Time

    sec, nanosec = stamp_parts(ns)
    return Time(sec=sec, nanosec=nanosec)


def _round_trip(msg):
    """Serialize and read back: a wrong field type would fail here (or publish garbage)."""
    return deserialize_message(serialize_message(msg), type(msg))


def test_pose_stamped_carries_the_planar_pose():
    msg = _round_trip(m.pose_stamped(0.25, -0.5, 2.0, 3_000_000_007, "map"))
    assert header_ns(msg) == 3_000_000_007 and msg.header.frame_id == "map"
    assert (msg.pose.position.x, msg.pose.position.y, msg.pose.position.z) == (0.25, -0.5, 0.0)
    q = msg.pose.orientation
    assert (q.x, q.y) == (0.0, 0.0)
    assert 2.0 * math.atan2(q.z, q.w) == pytest.approx(2.0, abs=1e-15)


def test_wrench_is_filled_in_place_and_stamped():
    reused = WrenchStamped()
    out = m.fill_wrench(reused, _stamp(12), "whisker_base", (1, -2.5), 3e-3)
    assert out is reused
    got = _round_trip(out)
    assert header_ns(got) == 12 and got.header.frame_id == "whisker_base"
    assert (got.wrench.force.x, got.wrench.force.y, got.wrench.torque.z) == (1.0, -2.5, 3e-3)
    assert (got.wrench.force.z, got.wrench.torque.x, got.wrench.torque.y) == (0.0, 0.0, 0.0)


def test_stamped_vector_point_and_scalars():
    v = _round_trip(m.vector_stamped(_stamp(5), "world", (0.5, -0.25)))
    p = _round_trip(m.point_stamped(_stamp(6), "world", (1, 2)))
    assert (header_ns(v), v.vector.x, v.vector.y, v.vector.z) == (5, 0.5, -0.25, 0.0)
    assert (header_ns(p), p.point.x, p.point.y, p.header.frame_id) == (6, 1.0, 2.0, "world")
    assert _round_trip(m.phase_msg(2)).data == 2
    assert _round_trip(m.float_msg(np.float64(0.5))).data == 0.5


def test_event_message_round_trips_through_the_one_decoder():
    record = EventRecord("snap", 2, 0, -0.0123, 0.0, math.pi / 2)
    msg = _round_trip(m.event_msg(record))
    assert set(json.loads(msg.data)) == {"kind", "from_phase", "to_phase", "x", "y", "yaw"}
    assert decode_event(msg.data) == record


def test_centerline_follows_the_state_from_foot_to_tip():
    state = QuasistaticTracker(Parabola(0.3), FootPose(2.0)).step(FootPose(0.0)).state
    points = state.centerline(21) * 0.1
    path = _round_trip(m.centerline_path(_stamp(9), "world", points))
    assert len(path.poses) == 21 and header_ns(path) == 9
    xy = np.array([(p.pose.position.x, p.pose.position.y) for p in path.poses])
    assert np.array_equal(xy, points)
    assert all(header_ns(p) == 9 and p.header.frame_id == "world" for p in path.poses)
    heading = [2.0 * math.atan2(p.pose.orientation.z, p.pose.orientation.w) for p in path.poses]
    chords = np.diff(points, axis=0)
    assert heading[:-1] == pytest.approx(np.arctan2(chords[:, 1], chords[:, 0]), abs=1e-14)
    assert heading[-1] == heading[-2]  # the tip faces like the last chord


def test_obstacle_marker_draws_the_profile_in_metres():
    cfg = build_config({"obstacle.type": "catenary", "obstacle.c": 0.06, "obstacle.apex_y": 0.05,
                        "obstacle.apex_x": 0.02})
    marker = _round_trip(m.obstacle_marker(cfg.profile, 0.1, "world", _stamp(1)))
    assert marker.type == Marker.LINE_STRIP and marker.header.frame_id == "world"
    assert len(marker.points) > 100 and marker.scale.x == pytest.approx(0.001)
    apex = min(marker.points, key=lambda p: p.y)
    assert (apex.x, apex.y) == pytest.approx((0.02, 0.05), abs=1e-12)
    assert max(p.y for p in marker.points) == pytest.approx(0.05 + 0.2, rel=1e-9)
    for p in marker.points:  # every point lies on the catenary
        assert p.y == pytest.approx(0.05 + 0.06 * (math.cosh((p.x - 0.02) / 0.06) - 1), abs=1e-12)


def test_contour_marker_colours_points_by_phase():
    marker = _round_trip(m.contour_marker([(0.1, 0.2, 1), (0.3, 0.4, 2)], "world", _stamp(1), 0.1))
    assert marker.type == Marker.POINTS and len(marker.points) == len(marker.colors) == 2
    assert (marker.points[1].x, marker.points[1].y) == (0.3, 0.4)
    assert marker.colors[0].b > marker.colors[0].r and marker.colors[1].r > marker.colors[1].b


@pytest.mark.parametrize(
    "phase, dropped, last, record_error, level, words",
    [
        (None, 0, "", "", DiagnosticStatus.OK, "not placed"),
        (2, 0, "", "", DiagnosticStatus.OK, "phase 2"),
        (1, 3, "not_finite: nan", "", DiagnosticStatus.WARN,
         "3 pose(s) dropped; last: not_finite"),
        (1, 3, "not_finite: nan", "No space left", DiagnosticStatus.ERROR,
         "not recording: No space"),
    ],
)
def test_whisker_status_levels(phase, dropped, last, record_error, level, words):
    status = m.whisker_status("/ns/whisker_node", phase, dropped, last, record_error,
                              {"poses_received": 5, "phase": "x"})
    array = _round_trip(m.diagnostic_array(_stamp(3), [status]))
    got = array.status[0]
    assert got.level == level and words in got.message
    assert got.hardware_id == "/ns/whisker_node" and got.name == "vibrissa_ros: /ns/whisker_node"
    assert {kv.key: kv.value for kv in got.values} == {"poses_received": "5", "phase": "x"}
