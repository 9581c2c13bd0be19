"""Units and frames at the ROS edge (no ROS needed)."""

import math

import pytest

from vibrissa_ros.core import FootPose, Parabola, QuasistaticTracker
from vibrissa_ros.node.edge import BadInput, Units, planar_pose, sensor_reading, yaw_quaternion

HALF_PI = math.pi / 2


def test_worked_example_of_the_papers_set_up():
    """At yaw = +90 deg: force.x = fy EI/L^2, force.y = -fx EI/L^2, torque.z = m0 EI/L."""
    L, EI = 0.1, 5e-4
    units = Units.elastica(L, EI)
    tracker = QuasistaticTracker(Parabola(0.3), FootPose(2.0))
    state = tracker.step(FootPose(0.0)).state
    assert state.phase == 1
    r = sensor_reading(state, units)
    assert r.force_base[0] == pytest.approx(state.fy * EI / L**2, rel=1e-15)
    assert r.force_base[1] == pytest.approx(-state.fx * EI / L**2, rel=1e-15)
    assert r.torque_z == pytest.approx(state.m0 * EI / L, rel=1e-15)
    assert r.force_world == pytest.approx((state.fx * EI / L**2, state.fy * EI / L**2), rel=1e-15)
    assert r.contact_world == pytest.approx((state.contact[0] * L, state.contact[1] * L),
                                            rel=1e-15)
    assert r.s1 == pytest.approx(state.s1 * L, rel=1e-15)
    assert r.force_magnitude == pytest.approx(math.hypot(*r.force_base), rel=1e-14)


def test_rigid_units_use_the_spring_stiffness():
    u = Units.rigid(0.2, 0.03)
    assert (u.length, u.force, u.moment) == (0.2, 0.03 / 0.2, 0.03)


@pytest.mark.parametrize("yaw", [0.0, 0.3, HALF_PI, 2.0, -2.9, math.pi])
def test_base_frame_rotates_with_the_yaw(yaw):
    """
    The base-frame force is the world force seen from axes turned by yaw.

    REP 103: x along the whisker.
    """
    profile = Parabola(0.3).placed(0.0, 0.0, yaw - HALF_PI)
    c, s = math.cos(yaw - HALF_PI), math.sin(yaw - HALF_PI)

    def foot(x):
        return FootPose(c * x, s * x, yaw)

    state = QuasistaticTracker(profile, foot(2.0)).step(foot(0.3)).state
    r = sensor_reading(state, Units(1.0, 1.0, 1.0))
    along = math.cos(yaw) * state.fx + math.sin(yaw) * state.fy
    across = -math.sin(yaw) * state.fx + math.cos(yaw) * state.fy
    assert r.force_base == pytest.approx((along, across), abs=1e-14)
    # the same relative set-up gives the same base-frame reading at every yaw
    ref = sensor_reading(
        QuasistaticTracker(Parabola(0.3), FootPose(2.0)).step(FootPose(0.3)).state,
        Units(1, 1, 1))
    assert r.force_base == pytest.approx(ref.force_base, abs=1e-11)
    assert r.torque_z == pytest.approx(ref.torque_z, abs=1e-11)


@pytest.mark.parametrize("yaw", [0.0, 0.7, HALF_PI, -1.2, 3.1])
def test_planar_pose_round_trips_the_yaw(yaw):
    x, y, got = planar_pose((1.0, -2.0, 0.0), yaw_quaternion(yaw), 1e-6, 1e-6)
    assert (x, y) == (1.0, -2.0)
    assert math.remainder(got - yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize(
    "position, quaternion, reason",
    [
        ((float("nan"), 0.0, 0.0), (0, 0, 0, 1), "not_finite"),
        ((0.0, 0.0, 0.0), (0, 0, float("inf"), 1), "not_finite"),
        ((0.0, 0.0, 0.0), (0, 0, 0, 0.9), "quaternion_not_unit"),
        ((0.0, 0.0, 0.0), (0, 0, 0, 0), "quaternion_not_unit"),
        ((0.0, 0.0, 1e-3), (0, 0, 0, 1), "out_of_plane"),
        ((0.0, 0.0, 0.0), (math.sin(0.01), 0, 0, math.cos(0.01)), "out_of_plane"),
        ((0.0, 0.0, 0.0), (0, math.sin(0.01), 0, math.cos(0.01)), "out_of_plane"),
    ],
)
def test_bad_poses_name_their_reason(position, quaternion, reason):
    with pytest.raises(BadInput) as info:
        planar_pose(position, quaternion, 1e-6, 1e-6)
    assert info.value.reason == reason
    assert isinstance(info.value, ValueError)
