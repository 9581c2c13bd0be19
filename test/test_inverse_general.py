"""
The inverse problem for the general whisker: the contact point from foot pose and wrench alone.

On random pegs, profiles and whiskers (noise-free: within 1e-8 L).
"""

import math

import numpy as np
import pytest

from vibrissa_ros.core import (Catenary, FootPose, GeneralWhiskerModel, Parabola, Peg, Phase,
                               WhiskerShape)
from vibrissa_ros.core.general.inverse import estimate_contact_general
from vibrissa_ros.core.scan import run_poses


def _check(scan, shape):
    checked = 0
    phases = set()
    for st in scan.states:
        if st.phase == Phase.FREE or st.f < 1e-6:
            continue
        est = estimate_contact_general(st.pose, st.fx, st.fy, st.m0, shape)
        assert est is not None
        assert est.phase == st.phase
        assert math.hypot(est.contact[0] - st.contact[0], est.contact[1] - st.contact[1]) < 1e-8
        assert abs(est.s1 - st.s1) < 1e-8
        checked += 1
        phases.add(st.phase)
    return checked, phases


@pytest.mark.parametrize("seed", range(6))
def test_random_pegs_and_whiskers(seed):
    rng = np.random.default_rng(1000 + seed)
    shape = WhiskerShape(rng.uniform(0.1, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-0.5, 0.5))
    peg = Peg(rng.uniform(-0.3, 0.3), rng.uniform(0.4, 0.9), rng.uniform(0.0, 0.2))
    if seed % 2:  # whisking about a fixed foot
        poses = [FootPose(0.0, 0.0, math.pi / 2 + 0.8 - 0.02 * i) for i in range(60)]
    else:  # translating
        poses = [FootPose(1.2 - 0.04 * i, 0.0) for i in range(60)]
    scan = run_poses(peg, poses, model=GeneralWhiskerModel(shape))
    checked, _ = _check(scan, shape)
    assert checked >= 3


@pytest.mark.parametrize("profile", [Parabola(0.35, 1.3), Catenary(0.45, 0.7)],
                         ids=lambda p: p.describe())
def test_tapered_whisker_against_convex_profiles_in_both_phases(profile):
    shape = WhiskerShape(0.5)
    poses = [FootPose(2.0 - 0.02 * i, 0.0) for i in range(200)]
    scan = run_poses(profile, poses, model=GeneralWhiskerModel(shape))
    checked, phases = _check(scan, shape)
    assert checked >= 20 and phases == {Phase.TANGENTIAL, Phase.TIP}


def test_unusable_readings():
    shape = WhiskerShape(0.5, 0.3)
    assert estimate_contact_general(FootPose(0.0), 0.0, 0.0, -0.1, shape) is None
    assert estimate_contact_general(FootPose(0.0), 0.1, -0.2, 0.0, shape) is None
    # a moment far too large for the force: it does not vanish along the whisker
    assert estimate_contact_general(FootPose(0.0), 0.01, -0.01, -5.0, shape) is None
