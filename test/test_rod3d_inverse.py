"""
The 3D inverse problem: the contact from the 6-axis base wrench of a known whisker.

Readings are made by the forward model (:func:`tip_loaded_rod`) and by the planar general
whisker's scans, then inverted: noise-free data give back the contact to 1e-9 L or better.
"""

import math
import re

import numpy as np
import pytest

from vibrissa_ros.core import FootPose, GeneralWhiskerModel, Parabola, Peg, Phase, WhiskerShape
from vibrissa_ros.core.errors import ParameterError
from vibrissa_ros.core.general.inverse import estimate_contact_general
from vibrissa_ros.core.rod3d import (BasePose, ContactEstimate3D, RodShape, contact_from_wrench,
                                     tip_loaded_rod)
from vibrissa_ros.core.rod3d.inverse import MIN_ARC_LENGTH
from vibrissa_ros.core.scan import run_poses

TOL = 1e-9

SHAPES = {
    "straight": RodShape(),
    "straight-tapered": RodShape(taper=0.4),
    "parabola-tapered": RodShape(taper=0.3, parabola=0.6),
    "k0k1-tapered": RodShape(taper=0.5, k0=0.8, k1=-0.5),
}


def _unit(q):
    q = np.asarray(q, dtype=float)
    return tuple(q / np.linalg.norm(q))


POSES = {
    "identity": BasePose((0.0, 0.0, 0.0)),
    "planar": BasePose.from_planar(0.3, -0.2, 1.1),
    # turned about its own axis: the whisker's plane is tilted out of the world's xy plane
    "rolled": BasePose((0.0, 0.1, -0.2), (math.cos(0.45), math.sin(0.45), 0.0, 0.0)),
    "general": BasePose((0.2, -0.1, 0.4), _unit((0.8, -0.2, 0.35, 0.4))),
}

#: forces in the base frame: in the whisker's plane (base xy), out of it (base z), both
FORCES = {
    "in-plane": (0.4, -1.2, 0.0),
    "out-of-plane": (0.0, 0.0, 1.5),
    "oblique": (-0.5, 0.7, -0.9),
}

ARC_LENGTHS = (0.2, 0.45, 0.7, 1.0)


def _reading(shape, pose, force_base, s):
    """Return the forward model's load point and its wrench (world frame)."""
    loaded = tip_loaded_rod(shape, pose, pose.rotation @ np.asarray(force_base), s=s)
    return loaded, np.array(loaded.base_force), np.array(loaded.base_moment)


def _check_exact(est, loaded, s):
    assert isinstance(est, ContactEstimate3D)
    assert abs(est.s - s) <= TOL
    assert np.linalg.norm(np.subtract(est.point, loaded.load_point)) <= TOL
    assert np.allclose(est.force, loaded.base_force, rtol=1e-15, atol=1e-15)
    assert est.residual <= 1e-10
    assert est.consistency <= 1e-12
    assert est.tip == (s == 1.0)
    assert np.allclose(est.fitted_moment, loaded.base_moment, atol=1e-10)
    assert abs(np.linalg.norm(est.tangent) - 1.0) <= 1e-9
    assert est.moment_slope > 0.0


@pytest.mark.parametrize("pose_name", sorted(POSES))
@pytest.mark.parametrize("shape_name", sorted(SHAPES))
def test_noise_free_readings_are_inverted_exactly(shape_name, pose_name):
    shape, pose = SHAPES[shape_name], POSES[pose_name]
    R = pose.rotation
    for k, (force_name, force) in enumerate(sorted(FORCES.items())):
        for j, s in enumerate(ARC_LENGTHS):
            loaded, F, M = _reading(shape, pose, force, s)
            if (j + k) % 2:  # as a sensor at the base reports it
                est = contact_from_wrench(shape, pose, R.T @ F, R.T @ M, frame="base")
            else:
                est = contact_from_wrench(shape, pose, F, M)
            _check_exact(est, loaded, s)


@pytest.mark.parametrize("s", [0.3, 1.0])
def test_world_and_base_frames_agree(s):
    shape, pose = SHAPES["parabola-tapered"], POSES["general"]
    loaded, F, M = _reading(shape, pose, FORCES["oblique"], s)
    R = pose.rotation
    world = contact_from_wrench(shape, pose, F, M, frame="world")
    base = contact_from_wrench(shape, pose, R.T @ F, R.T @ M, frame="base")
    assert np.allclose(world.point, base.point, atol=1e-12)
    assert abs(world.s - base.s) <= 1e-12
    assert np.allclose(base.force, F, atol=1e-15) and np.allclose(base.moment, M, atol=1e-15)


def test_large_deflection_follows_the_readings_branch():
    """A strongly bent whisker: the shot from the base picks the reading's own equilibrium."""
    shape = RodShape(taper=0.5, k0=0.4, k1=-0.3)
    pose = BasePose((0.0, 0.0, 0.0), _unit((0.9, 0.2, -0.1, 0.3)))
    for s, force in ((0.6, (1.0, -6.0, 2.0)), (1.0, (0.0, -2.5, 2.5))):
        loaded, F, M = _reading(shape, pose, force, s)
        _check_exact(contact_from_wrench(shape, pose, F, M), loaded, s)


def test_two_contacts_on_the_line_of_action_nearest_base_first():
    """A curled whisker crossed twice by the force's line: both explain the reading exactly."""
    shape = RodShape(parabola=2.0)
    pose = POSES["identity"]
    chord = shape.free_centerline([0.5])[0] - shape.free_centerline([1.0])[0]
    F = 0.05 * chord / np.linalg.norm(chord)
    loaded = tip_loaded_rod(shape, pose, F, s=1.0)
    est = contact_from_wrench(shape, pose, F, loaded.base_moment)
    assert est.s < 0.9 and est.residual <= 1e-10
    assert any(abs(s - 1.0) <= TOL and r <= 1e-10 for s, r in est.alternatives)
    # the nearer contact is a true solution of the forward model too
    other = tip_loaded_rod(shape, pose, F, s=est.s)
    assert np.allclose(other.base_moment, loaded.base_moment, atol=1e-10)
    assert np.linalg.norm(np.subtract(other.load_point, est.point)) <= TOL


def _planar_states(shape, obstacle, poses):
    scan = run_poses(obstacle, poses, model=GeneralWhiskerModel(shape))
    return [st for st in scan.states if st.phase != Phase.FREE and st.f >= 1e-6]


@pytest.mark.parametrize("case", ["peg-translating", "peg-whisking", "profile-tip"])
def test_planar_readings_agree_with_the_planar_general_inverse(case):
    if case == "peg-translating":
        planar = WhiskerShape(0.5, 0.4, -0.3)
        states = _planar_states(planar, Peg(0.1, 0.6, 0.1),
                                [FootPose(1.2 - 0.04 * i, 0.0) for i in range(60)])
    elif case == "peg-whisking":
        planar = WhiskerShape(0.3, -0.6, 0.4)
        states = _planar_states(planar, Peg(-0.2, 0.7, 0.05),
                                [FootPose(0.0, 0.0, math.pi / 2 + 0.8 - 0.04 * i)
                                 for i in range(40)])
    else:
        planar = WhiskerShape(0.5)
        states = _planar_states(planar, Parabola(0.35, 1.3),
                                [FootPose(2.0 - 0.05 * i, 0.0) for i in range(80)])[::3]
    shape = RodShape(taper=planar.taper, k0=planar.k0, k1=planar.k1)
    phases = set()
    for st in states:
        flat = estimate_contact_general(st.pose, st.fx, st.fy, st.m0, planar)
        pose = BasePose.from_planar(st.pose.x, st.pose.y, st.pose.heading)
        est = contact_from_wrench(shape, pose, (st.fx, st.fy, 0.0), (0.0, 0.0, st.m0))
        assert abs(est.s - flat.s1) <= 1e-9 and abs(est.s - st.s1) <= 1e-9
        assert math.dist(est.point[:2], flat.contact) <= 1e-9
        assert math.dist(est.point[:2], st.contact) <= 1e-9
        assert est.point[2] == 0.0 and est.residual <= 1e-10
        assert est.tip == (st.phase == Phase.TIP)
        if not est.tip:  # a frictionless side contact: the tangent is normal to the force
            assert abs(np.dot(est.tangent, (st.fx, st.fy, 0.0))) <= 1e-9 * st.f
        phases.add(st.phase)
    assert len(states) >= 5
    if case == "profile-tip":
        assert phases == {Phase.TANGENTIAL, Phase.TIP}


def test_noisy_reading_is_close_and_its_residual_shows_the_noise():
    shape, pose = SHAPES["k0k1-tapered"], POSES["general"]
    loaded, F, M = _reading(shape, pose, FORCES["oblique"], 0.6)
    rng = np.random.default_rng(7)
    noisy_F = F * (1.0 + 0.01 * rng.standard_normal(3))
    noisy_M = M * (1.0 + 0.01 * rng.standard_normal(3))
    est = contact_from_wrench(shape, pose, noisy_F, noisy_M)
    assert np.linalg.norm(np.subtract(est.point, loaded.load_point)) < 0.05
    assert 1e-6 < est.residual < 0.05 * np.linalg.norm(M)
    assert 0.0 < est.consistency < 0.05


def test_no_force_is_no_contact():
    shape, pose = SHAPES["straight"], POSES["identity"]
    assert contact_from_wrench(shape, pose, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)) is None
    # a couple without a force: no point contact produces it
    assert contact_from_wrench(shape, pose, (0.0, 0.0, 0.0), (0.1, 0.0, 0.3)) is None
    assert contact_from_wrench(shape, pose, (0.0, 0.01, 0.0), (0.0, 0.0, 0.005),
                               min_force=0.02) is None


@pytest.mark.parametrize("force, moment, label", [
    ((0.0, 1.0, 0.0), (0.0, 0.7, 0.0), "moment along the force"),
    ((0.0, 1e-3, 0.0), (0.0, 0.0, 5.0), "moment too large for the force"),
    ((0.0, -0.5, 0.0), (0.0, 0.0, 0.5), "moment of the wrong sign"),
])
def test_inconsistent_readings_give_a_finite_best_fit(force, moment, label):
    shape, pose = SHAPES["parabola-tapered"], POSES["identity"]
    est = contact_from_wrench(shape, pose, force, moment)
    values = [est.s, est.residual, est.consistency, est.moment_slope, *est.point, *est.tangent,
              *est.fitted_moment]
    assert all(math.isfinite(v) for v in values), label
    assert MIN_ARC_LENGTH <= est.s <= 1.0
    assert est.residual > 0.1 * np.linalg.norm(moment), label
    if label == "moment along the force":
        assert est.consistency == pytest.approx(1.0)


def test_an_axial_force_leaves_the_arc_length_undetermined():
    est = contact_from_wrench(RodShape(), POSES["identity"], (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert est.residual == 0.0 and est.moment_slope == 0.0 and est.consistency == 0.0


@pytest.mark.parametrize("kwargs, words", [
    (dict(force=(math.nan, 0.0, 1.0)), "force[0] = nan"),
    (dict(force=(0.0, math.inf, 1.0)), "force[1] = inf"),
    (dict(moment=(0.0, 0.0, -math.inf)), "moment[2] = -inf"),
    (dict(moment=(0.0, 1.0)), "moment"),
    (dict(force="abc"), "force"),
    (dict(force=None), "force"),
    (dict(frame="sensor"), "frame"),
    (dict(min_force=-1.0), "min_force"),
    (dict(min_force=math.nan), "min_force"),
    (dict(shape=WhiskerShape(0.5)), "RodShape"),
    (dict(pose=FootPose(0.0, 0.0)), "BasePose"),
])
def test_bad_input_is_refused_by_name(kwargs, words):
    args = dict(shape=RodShape(), pose=POSES["identity"], force=(0.0, 1.0, 0.0),
                moment=(0.0, 0.0, 0.5))
    args.update(kwargs)
    with pytest.raises(ParameterError, match=re.escape(words)):
        contact_from_wrench(**args)


def test_estimate_is_immutable():
    shape, pose = SHAPES["straight"], POSES["identity"]
    est = contact_from_wrench(shape, pose, (0.0, 1.0, 0.0), (0.0, 0.0, 0.5))
    with pytest.raises(AttributeError):
        est.s = 0.5
