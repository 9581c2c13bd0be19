"""
The 3D whisker's collocation model: Jacobians, closed forms, linear theory, the planar limit.

The independent shooting solver's comparisons are in test_rod3d_shooting.py; the tracker's
planar golden tests (every event of the paper's scan and of the two-peg scene) in
test_rod3d_tracker.py.
"""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from vibrissa_ros.core.errors import InvalidPoseError, ParameterError
from vibrissa_ros.core.exact.elastica import tip_loaded_elastica
from vibrissa_ros.core.rod3d import (
    BasePose, Cylinder, Plane, Prism, RodContactMode, RodShape, RodSolver, Sphere,
    tip_loaded_rod,
)
from vibrissa_ros.core.rod3d.pose import quat_about, quat_multiply
from vibrissa_ros.core.scenes.scene import obstacle_from_dict

SHAPES = [RodShape(), RodShape(taper=0.4, k0=0.5, k1=0.3), RodShape(parabola=0.6, taper=0.5),
          RodShape(taper=0.07, parabola=-0.8, poisson=0.3)]
SHAPE_IDS = ["uniform", "tapered-linear", "tapered-parabola", "rat-like"]


def _random_pose(rng):
    q = rng.normal(size=4)
    return BasePose(tuple(rng.normal(size=3) * 0.1), tuple(q / np.linalg.norm(q)))


def _obstacles():
    catenary = obstacle_from_dict({"type": "catenary", "p0": 0.5, "c": 0.6}, "catenary0")
    return [Sphere((0.5, 0.3, 0.1), 0.2), Cylinder((0.9, -0.2, 0.0), (0.3, 0.2, 1.0), 0.1),
            Plane((0.0, 0.0, -0.5), (0.1, 0.2, 1.0)), Prism(catenary)]


CONFIGS = [
    ((RodContactMode("side", 0),), [0.45]),
    ((RodContactMode("tip", 1),), [1.0]),
    ((RodContactMode("side", 2),), [0.6]),
    ((RodContactMode("side", 3),), [0.5]),
    ((RodContactMode("side", 0), RodContactMode("side", 1)), [0.45, 0.8]),
    ((RodContactMode("side", 0), RodContactMode("tip", 1)), [0.45, 1.0]),
]


@pytest.mark.parametrize("shape", SHAPES, ids=SHAPE_IDS)
@pytest.mark.parametrize("modes,breaks", CONFIGS, ids=lambda v: str(v)[:40])
def test_the_analytic_jacobian_and_pose_sensitivities_match_finite_differences(
        shape, modes, breaks):
    rng = np.random.default_rng(7)
    solver = RodSolver(shape, _obstacles(), n=10)
    pose = _random_pose(rng)
    forces = [0.3, 0.2][:len(modes)]

    def quats(s):
        return solver.free_quaternions(pose, s) + 0.05 * rng.normal(size=(len(s), 4))

    vec = solver.guess(modes, breaks, forces, quats)
    _, J, S = solver.residual(modes, vec, pose, pose_sensitivity=True)
    h = 1e-6
    Jn = np.empty_like(J)
    for j in range(vec.size):
        vp, vm = vec.copy(), vec.copy()
        vp[j] += h
        vm[j] -= h
        Jn[:, j] = (solver.residual(modes, vp, pose, False)[0]
                    - solver.residual(modes, vm, pose, False)[0]) / (2 * h)
    assert np.max(np.abs(J - Jn)) < 2e-8 * max(1.0, np.max(np.abs(J)))

    class _Pose:
        def __init__(self, p, q):
            self.p, self.q = p, q

    Sn = np.empty_like(S)
    for j in range(7):
        d = np.zeros(7)
        d[j] = h
        plus = _Pose(pose.p + d[:3], pose.q + d[3:])
        minus = _Pose(pose.p - d[:3], pose.q - d[3:])
        Sn[:, j] = (solver.residual(modes, vec, plus, False)[0]
                    - solver.residual(modes, vec, minus, False)[0]) / (2 * h)
    assert np.max(np.abs(S - Sn)) < 2e-8 * max(1.0, np.max(np.abs(S)))


# -- the whisker under a given load: closed forms -------------------------------------------------

@pytest.mark.parametrize("M", [0.5, 2.0, 6.0])
def test_a_pure_couple_bends_a_uniform_rod_into_a_circle(M):
    rod = tip_loaded_rod(RodShape(), BasePose((0, 0, 0)), (0, 0, 0), (0, 0, M))
    exact = (math.sin(M) / M, (1 - math.cos(M)) / M, 0.0)
    assert np.allclose(rod.tip, exact, rtol=0, atol=1e-12)
    s = np.linspace(0, 1, 7)
    pts = rod.centerline(s)
    assert np.allclose(pts[:, 0], np.sin(M * s) / M, atol=1e-12)
    assert np.allclose(pts[:, 1], (1 - np.cos(M * s)) / M, atol=1e-12)


@pytest.mark.parametrize("nu", [0.0, 0.38, 0.5])
def test_a_tip_torque_twists_a_straight_rod_by_m_over_c(nu):
    M = 0.7
    rod = tip_loaded_rod(RodShape(poisson=nu), BasePose((0, 0, 0)), (0, 0, 0), (M, 0, 0))
    angle = math.atan2(rod.tip_frame[2, 1], rod.tip_frame[1, 1])
    assert angle == pytest.approx(M * (1 + nu), abs=1e-12)
    assert np.allclose(rod.tip, (1, 0, 0), atol=1e-14)


def test_a_twisted_tapered_rod_turns_by_the_integral_of_m_over_c():
    shape = RodShape(taper=0.3)
    M = 0.02
    rod = tip_loaded_rod(shape, BasePose((0, 0, 0)), (0, 0, 0), (M, 0, 0))
    x, w = np.polynomial.legendre.leggauss(40)
    s = 0.5 * (x + 1)
    exact = M * (1 + shape.poisson) * 0.5 * np.sum(w / shape.stiffness(s))
    assert math.atan2(rod.tip_frame[2, 1], rod.tip_frame[1, 1]) == pytest.approx(exact, abs=1e-12)


@pytest.mark.parametrize("direction", [(0, 1, 0), (0, 0, 1)])
def test_a_small_tip_force_deflects_a_uniform_rod_by_f_over_3_in_either_plane(direction):
    F = 1e-6
    rod = tip_loaded_rod(RodShape(), BasePose((0, 0, 0)), F * np.array(direction), (0, 0, 0))
    deflection = np.array(rod.tip) - np.array([1.0, 0.0, 0.0])
    assert deflection @ np.array(direction) == pytest.approx(F / 3, rel=1e-5)


def test_out_of_plane_compliance_of_a_curved_tapered_whisker_is_the_linear_theorys():
    """Castigliano: a tip force normal to the plane bends and twists a curved whisker."""
    shape = RodShape(taper=0.5, parabola=0.8, poisson=0.38)
    F = 1e-7
    rod = tip_loaded_rod(shape, BasePose((0, 0, 0)), (0, 0, F), (0, 0, 0))
    x, w = np.polynomial.legendre.leggauss(60)
    s = 0.5 * (x + 1)
    w = 0.5 * w
    free = shape.free_centerline(np.append(s, 1.0))
    tip, pts = free[-1], free[:-1]
    phi = shape.intrinsic_slope(s)
    d1 = np.column_stack((np.cos(phi), np.sin(phi), 0 * s))
    d2 = np.column_stack((-np.sin(phi), np.cos(phi), 0 * s))
    moment = np.cross(tip - pts, np.array([0.0, 0.0, 1.0]))   # per unit force
    B = shape.stiffness(s)
    C = B / (1 + shape.poisson)
    compliance = np.sum(w * ((moment * d1).sum(1) ** 2 / C + (moment * d2).sum(1) ** 2 / B))
    assert (rod.tip[2]) / F == pytest.approx(compliance, rel=1e-5)


@pytest.mark.parametrize("f,alpha", [(0.5, 1.2), (3.0, 1.2), (8.0, 2.5), (2.0, 0.4)])
def test_an_in_plane_tip_force_gives_the_planar_elastica_exactly(f, alpha):
    exact = tip_loaded_elastica(f, alpha)
    pose = BasePose.from_planar(0.0, 0.0, math.pi / 2)
    rod = tip_loaded_rod(RodShape(), pose, (f * math.sin(alpha), -f * math.cos(alpha), 0.0))
    assert rod.tip[0] == pytest.approx(exact.tip_x, abs=1e-11)
    assert rod.tip[1] == pytest.approx(exact.tip_y, abs=1e-11)
    assert rod.tip[2] == 0.0
    assert rod.base_moment[2] == pytest.approx(exact.m0, abs=1e-10)
    assert rod.base_moment[0] == rod.base_moment[1] == 0.0


def test_a_rotated_base_rotates_the_solution():
    """Rigid motion: the load and the pose turned together turn the whole equilibrium."""
    shape = RodShape(taper=0.6, k0=1.0)
    F, M = np.array([0.3, -1.2, 0.4]), np.array([0.1, 0.2, -0.3])
    a = tip_loaded_rod(shape, BasePose((0, 0, 0)), F, M)
    q = quat_multiply(quat_about((0, 0, 1), 0.7), quat_about((1, 0, 0), -1.1))
    pose = BasePose((0.2, -0.3, 0.5), tuple(q))
    R = pose.rotation
    b = tip_loaded_rod(shape, pose, R @ F, R @ M)
    assert np.allclose(np.array(b.tip), pose.p + R @ np.array(a.tip), atol=1e-12)
    assert np.allclose(b.tip_frame, R @ a.tip_frame, atol=1e-12)


def test_bad_loads_and_shapes_are_refused_with_the_key():
    with pytest.raises(ParameterError, match="force"):
        tip_loaded_rod(RodShape(), BasePose((0, 0, 0)), (1, 2), (0, 0, 0))
    with pytest.raises(ParameterError, match="arc length"):
        tip_loaded_rod(RodShape(), BasePose((0, 0, 0)), (0, 1, 0), s=1.5)
    with pytest.raises(ParameterError, match="too large"):
        tip_loaded_rod(RodShape(), BasePose((0, 0, 0)), (0, 500, 0))
    with pytest.raises(ParameterError, match="exclusive"):
        RodShape(k0=1.0, parabola=0.5)
    with pytest.raises(ParameterError, match="poisson"):
        RodShape(poisson=0.7)
    with pytest.raises(InvalidPoseError, match="unit quaternion"):
        BasePose((0, 0, 0), (1.0, 0.1, 0.0, 0.0))


def test_the_parabola_shape_is_the_parabola():
    shape = RodShape(parabola=0.7)
    s = np.linspace(0, 1, 11)
    pts = shape.free_centerline(s)
    assert np.allclose(pts[:, 1], 0.7 * pts[:, 0] ** 2, atol=1e-15)
    # arc length of y = A x^2 from 0 to x, by quadrature
    for si, x in zip(s, pts[:, 0]):
        length = quad(lambda u: math.sqrt(1 + (1.4 * u) ** 2), 0.0, x, epsabs=1e-14)[0]
        assert length == pytest.approx(si, abs=1e-13)
    assert shape.intrinsic_slope(1.0) == pytest.approx(math.atan(1.4 * pts[-1, 0]), abs=1e-15)


@pytest.mark.parametrize(
    "load, w, u",
    [(1, 0.30172, 0.05643), (2, 0.49346, 0.16064), (5, 0.71379, 0.38763), (10, 0.81061, 0.55500)],
)
@pytest.mark.parametrize("plane", ["y", "z"])
def test_the_published_cantilever_table_in_either_plane_of_a_rolled_whisker(load, w, u, plane):
    """Bisshopp & Drucker (1945), Mattiasson (1981): 5 published digits, in 3D."""
    roll = quat_about((1.0, 0.0, 0.0), 0.7)
    pose = BasePose((0.1, -0.2, 0.3), tuple(roll))
    across = pose.rotation[:, 1 if plane == "y" else 2]
    rod = tip_loaded_rod(RodShape(), pose, load * across)
    tip = np.array(rod.tip) - pose.p
    axis = pose.rotation[:, 0]
    assert tip @ across == pytest.approx(w, abs=5e-6)
    assert 1.0 - tip @ axis == pytest.approx(u, abs=5e-6)
    assert abs(tip @ np.cross(axis, across)) < 1e-13


def test_newton_takes_an_ill_conditioned_solution_whose_residual_holds_to_rounding():
    # a side contact born 1e-4 L behind a pressed tip (the rat's pad against a wall): the steps
    # of Newton level off at their rounding noise (~1e-10) while the residual is ~1e-15; the
    # stall rule failed the step, it now takes the solution
    import json
    import os

    from vibrissa_ros.core.rod3d import Scene3D

    path = os.path.join(os.path.dirname(__file__), "data", "rod3d_ill_conditioned_touch.json")
    case = json.load(open(path))
    solver = RodSolver(RodShape(**case["shape"]),
                       Scene3D.from_dict(case["scene"]).obstacles, n=case["n"])
    modes = tuple(RodContactMode(kind, k) for kind, k in case["modes"])
    pose = BasePose(tuple(case["pose"][0]), tuple(case["pose"][1]))
    guess = np.array(case["guess"])
    solved = solver.solve(modes, pose, guess)
    assert np.max(np.abs(solver.residual(modes, solved.vec, pose, jacobian=False)[0])) < 1e-13
    assert np.max(np.abs(solved.vec - guess)) < 1e-6
    assert solver.breaks_of(modes, solved.vec)[0] > 1.0 - 1e-3
