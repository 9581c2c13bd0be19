"""The node's pose path without ROS: checks in order, drop reasons, state kept, reset, counting."""

import math
from pathlib import Path

import numpy as np
import pytest

from vibrissa_ros.core import ConvergenceError, InvalidPoseError, ModelAssumptionError, run_scan
from vibrissa_ros.core.rod3d import BasePose, RodTracker
from vibrissa_ros.core.rod3d.pose import quat_about, quat_matrix, quat_multiply
from vibrissa_ros.node.edge import (BadInput, decode_event, encode_event, event_record,
                                    sensor_reading, yaw_quaternion)
from vibrissa_ros.node.config import build_config
from vibrissa_ros.core.errors import interrupted
from vibrissa_ros.node.pipeline import DROP_REASONS, PosePipeline, PoseStats, drop_reason

HALF_PI = math.pi / 2
CATENARY = {"obstacle.type": "catenary", "obstacle.c": 0.06, "obstacle.apex_y": 0.05}
Q = yaw_quaternion(HALF_PI)


def _pipeline(**values):
    return PosePipeline(build_config(dict(CATENARY, **values)))


def test_a_sweep_through_the_pipeline_equals_the_core_scan():
    pipe = _pipeline()
    xs = [0.15 - 0.005 * i for i in range(61)]
    states = [pipe.handle("world", i, (x, 0.0, 0.0), Q)[0] for i, x in enumerate(xs)]
    scan = run_scan(pipe.config.profile, [x / 0.1 for x in xs]).states
    assert [s.m0 for s in states] == pytest.approx([s.m0 for s in scan], rel=1e-12, abs=1e-15)
    assert {int(s.phase) for s in states} == {0, 1, 2}
    reading, sensed = pipe.reading(states[30])
    assert reading == sensor_reading(states[30], pipe.config.units)
    assert sensed == (reading.force_base[0], reading.force_base[1], reading.torque_z)


@pytest.mark.parametrize(
    "frame, stamp, position, quaternion, reason",
    [
        ("map", 10, (0.1, 0.0, 0.0), Q, "wrong_frame_id"),
        ("world", 4, (0.1, 0.0, 0.0), Q, "stamp_backwards"),
        ("world", 10, (math.nan, 0.0, 0.0), Q, "not_finite"),
        ("world", 10, (0.1, 0.0, 0.0), (0.0, 0.0, 0.0, 2.0), "quaternion_not_unit"),
        ("world", 10, (0.1, 0.0, 0.5), Q, "out_of_plane"),
        ("world", 10, (1e308, 0.0, 0.0), Q, "not_finite"),  # overflows in whisker lengths
        ("world", 10, (0.0, -1e6, 0.0), Q, "out_of_range"),  # absurd for the model
    ],
)
def test_bad_poses_are_dropped_with_their_reason_and_the_state_is_kept(frame, stamp, position,
                                                                       quaternion, reason):
    pipe = _pipeline()
    pipe.handle("world", 5, (0.15, 0.0, 0.0), Q)
    before = pipe.state
    with pytest.raises(BadInput) as info:
        pipe.handle(frame, stamp, position, quaternion)
    assert drop_reason(info.value) == reason and pipe.state is before
    assert pipe.last_stamp_ns == 5


def test_the_frame_check_comes_first_then_the_stamp():
    pipe = _pipeline()
    pipe.handle("world", 5, (0.15, 0.0, 0.0), Q)
    with pytest.raises(BadInput, match="frame"):
        pipe.handle("map", 1, (math.nan, 0.0, 0.0), Q)
    with pytest.raises(BadInput, match="older"):
        pipe.handle("world", 1, (math.nan, 0.0, 0.0), Q)


def test_a_first_pose_inside_the_obstacle_is_dropped_and_the_next_free_one_places_it():
    pipe = _pipeline()
    with pytest.raises(InvalidPoseError) as info:
        pipe.handle("world", 1, (0.0, 0.0, 0.0), Q)  # the straight whisker would cut the catenary
    assert drop_reason(info.value) == "inside_obstacle" and pipe.state is None
    state, events = pipe.handle("world", 2, (0.2, 0.0, 0.0), Q)
    assert int(state.phase) == 0 and events == ()


def test_reconfigure_resets_only_when_asked():
    pipe = _pipeline()
    pipe.handle("world", 1, (0.15, 0.0, 0.0), Q)
    pipe.handle("world", 2, (0.0, 0.0, 0.0), Q)
    assert int(pipe.state.phase) > 0
    pipe.reconfigure(build_config(dict(CATENARY, **{"centerline.points": 5})), reset=False)
    assert int(pipe.state.phase) > 0
    pipe.reconfigure(build_config(CATENARY), reset=True)
    assert pipe.state is None


@pytest.mark.parametrize(
    "exc, reason",
    [
        (BadInput("out_of_plane", "z"), "out_of_plane"),
        (InvalidPoseError("inside"), "inside_obstacle"),
        (ConvergenceError("no"), "not_converged"),
        (ModelAssumptionError("WH1"), "model_assumption"),
        (OverflowError("math range error"), "internal_error"),
        (ZeroDivisionError(), "internal_error"),
    ],
)
def test_drop_reasons(exc, reason):
    assert drop_reason(exc) == reason and reason in DROP_REASONS


def test_stats_count_and_summarize_a_period():
    stats = PoseStats(slow_step_s=0.01)
    stats.received = 4
    stats.accepted(2_000, ())
    stats.accepted(50_000_000, ())
    assert stats.drop("not_finite", "nan") == 1 and stats.drop("not_finite", "inf") == 2
    stats.waiting(3)
    stats.waiting(1)
    period = stats.period()
    assert period["solves_in_period"] == 2 and period["backlog_in_period"] == 3
    assert float(period["solve_time_max_us"]) == 50_000.0
    assert stats.slow_steps == 1 and stats.slowest_step_s == 0.05 and stats.backlog_max == 3
    assert stats.last_error == "not_finite: inf" and stats.processed == 2
    empty = stats.period()
    assert empty["solves_in_period"] == 0 and empty["solve_time_median_us"] == ""
    assert empty["backlog_in_period"] == 0 and stats.backlog_max == 3
    values = stats.values()
    assert values["poses_received"] == 4 and values["poses_dropped"] == 2
    assert values["dropped_not_finite"] == 2 and values["slowest_step_ms"] == "50.0"
    assert {f"dropped_{r}" for r in DROP_REASONS} <= set(values)


# -- the 3D whisker (model rod3d) -----------------------------------------------------------------
SPHERE_M = Path(__file__).resolve().parents[1] / "config" / "scene_sphere_m.yaml"
ROD3D = {"model": "rod3d", "whisker.length": 0.03, "whisker.youngs_modulus": 3.3e9,
         "whisker.base_radius": 5e-5, "whisker.taper": 0.5, "whisker.parabola": 10.0,
         "whisker.roll": 0.5, "obstacle.type": "scene", "obstacle.scene_file": str(SPHERE_M)}


def _tilted(y, i):
    """Return a 6-DoF pose (position [m], quaternion x, y, z, w) near the ball, tilted."""
    q = quat_multiply(quat_about((0, 0, 1), 0.1 * math.sin(i / 7)),
                      quat_about((0, 1, 0), 0.05 * math.sin(i / 4)))
    return (0.0, y, 0.0005 * math.sin(i / 5)), (q[1], q[2], q[3], q[0])


def test_a_6dof_sweep_equals_the_rod_tracker_in_si_with_the_roll_composed():
    pipe = PosePipeline(build_config(ROD3D))
    cfg = pipe.config
    ys = [0.0005 * i for i in range(21)]
    tracker = None
    for i, y in enumerate(ys):
        p, (qx, qy, qz, qw) = _tilted(y, i)
        state, events = pipe.handle("world", i, p, (qx, qy, qz, qw))
        core_q = quat_multiply((qw, qx, qy, qz), quat_about((1, 0, 0), 0.5))
        pose = BasePose(tuple(v / 0.03 for v in p), tuple(core_q))
        if tracker is None:
            tracker = RodTracker(cfg.scene3d, pose, shape=cfg.rod_shape)
            want, want_events = tracker.state, ()
        else:
            result = tracker.step(pose)
            want, want_events = result.state, result.events
        assert state.pose.quaternion == pytest.approx(pose.quaternion, rel=0, abs=1e-15)
        # the base frame is the foot's (q_pose): the world load seen in it
        foot = quat_matrix((qw, qx, qy, qz))
        force, moment = foot.T @ np.array(want.force), foot.T @ np.array(want.moment)
        reading, sensed = pipe.reading(state)
        scale = (cfg.units.force,) * 3 + (cfg.units.moment,) * 3
        for a, b, unit in zip(sensed, tuple(force * cfg.units.force)
                              + tuple(moment * cfg.units.moment), scale):
            assert a == pytest.approx(b, rel=1e-12, abs=1e-14 * unit)
        assert [e.kind for e in events] == [e.kind for e in want_events]
    assert reading.phase == 1 and len(state.contacts) == 1 and sensed[2] != 0.0


def test_rod3d_points_tolerance_reaches_the_rod_tracker_and_moves_the_wrench_within_it():
    """solver.points_tolerance: the tracker of that tolerance's answers; near the default's."""
    def sweep(tolerance):
        pipe = PosePipeline(build_config(dict(ROD3D, **{"solver.points_tolerance": tolerance})))
        wrenches = []
        for i in range(21):
            p, q = _tilted(0.0005 * i, i)
            state, _ = pipe.handle("world", i, p, q)
            wrenches.append(pipe.reading(state)[1])
        return pipe, np.array(wrenches)

    _, exact = sweep(1e-11)
    pipe, coarse = sweep(1e-6)
    cfg = pipe.config
    assert pipe.tracker.solver.points_tolerance == 1e-6
    assert "points_tolerance=1e-06 L" in cfg.describe()
    tracker = None
    for i in range(21):
        p, (qx, qy, qz, qw) = _tilted(0.0005 * i, i)
        core_q = quat_multiply((qw, qx, qy, qz), quat_about((1, 0, 0), 0.5))
        pose = BasePose(tuple(v / 0.03 for v in p), tuple(core_q))
        if tracker is None:
            tracker = RodTracker(cfg.scene3d, pose, shape=cfg.rod_shape, points_tolerance=1e-6)
        else:
            tracker.step(pose)
    want = pipe.reading(tracker.state)[1]
    assert coarse[-1] == pytest.approx(want, rel=1e-12, abs=1e-20)
    # in contact at the end; every component within a few tolerances of the default's largest
    largest = np.abs(exact).max(axis=0)
    assert np.all(largest > 0.0)
    error = np.abs(coarse - exact).max(axis=0) / largest
    assert np.all(error < 1e-6) and np.any(error > 1e-12)


def test_rod3d_takes_any_orientation_but_drops_a_non_unit_quaternion_keeping_the_state():
    pipe = PosePipeline(build_config(ROD3D))
    pipe.handle("world", 1, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    pitched = quat_about((0, 1, 0), 0.3)  # out of the plane: refused by planar models only
    state, _ = pipe.handle("world", 2, (0.0, 0.0, 0.001),
                           (pitched[1], pitched[2], pitched[3], pitched[0]))
    for quaternion, reason in (((0.0, 0.0, 0.0, 1.01), "quaternion_not_unit"),
                               ((0.0, 0.0, 0.0, 1.0 + 2e-6), "quaternion_not_unit"),
                               ((0.0, math.nan, 0.0, 1.0), "not_finite")):
        with pytest.raises(BadInput) as info:
            pipe.handle("world", 3, (0.0, 0.0, 0.0), quaternion)
        assert drop_reason(info.value) == reason and pipe.state is state
    with pytest.raises(BadInput) as info:
        pipe.handle("world", 3, (0.0, 0.0, 1e5), (0.0, 0.0, 0.0, 1.0))
    assert drop_reason(info.value) == "out_of_range" and pipe.state is state
    # within 1e-6 of unit length: normalised and taken
    state, _ = pipe.handle("world", 3, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0 + 5e-7))
    assert state.pose.quaternion == pytest.approx(tuple(quat_about((1, 0, 0), 0.5)), abs=1e-15)


def test_rod3d_reset_on_request_and_its_event_payload():
    pipe = PosePipeline(build_config(ROD3D))
    pipe.handle("world", 1, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    pipe.request_reset()
    q = quat_about((0, 0, 1), 0.2)
    _, events = pipe.handle("world", 2, (0.001, -0.002, 0.0005), (q[1], q[2], q[3], q[0]))
    assert [e.kind for e in events] == ["reset"]
    record = decode_event(encode_event(event_record(events[0], pipe.config.units, 0.5)))
    assert (record.x, record.y, record.z) == pytest.approx((0.001, -0.002, 0.0005), rel=1e-12)
    assert record.orientation == pytest.approx((q[1], q[2], q[3], q[0]), abs=1e-15)
    assert record.yaw == pytest.approx(0.2, rel=1e-12) and record.contact is None


def test_a_ctrl_c_inside_a_compiled_kernel_stops_the_node_rather_than_dropping_a_pose():
    # numba hands a KeyboardInterrupt that arrived during a kernel back as a SystemError caused
    # by it (seen when array_node was stopped with SIGINT mid-tick): the nodes stop on it
    def kernel_interrupted():
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as ctrl_c:
            raise SystemError("CPUDispatcher(<function equations>) returned a result with an "
                              "exception set") from ctrl_c

    with pytest.raises(SystemError) as caught:
        kernel_interrupted()
    assert interrupted(caught.value) and drop_reason(caught.value) == "internal_error"
    try:
        try:
            1 / 0
        except ZeroDivisionError:
            raise ValueError("a bug in the core")
    except ValueError as exc:
        assert not interrupted(exc)
    assert interrupted(KeyboardInterrupt()) and not interrupted(RuntimeError())
