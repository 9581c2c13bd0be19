"""
The 3D shooting check (core/checks/rod3d_shooting.py) against answers it does not compute itself.

Closed forms (linear beam theory, pure twist, pure bending, the large-deflection cantilever by
quadrature), the planar scene tracker on pegs (a peg is a cylinder along z), and for genuinely 3D
contacts: the moment along the whisker recomputed from the sampled frames, and the symmetries
(a rotation or a mirror of the whole configuration maps the solution onto the solution).
"""

import math
from dataclasses import dataclass

import numpy as np
import pytest
from scipy.integrate import quad

from vibrissa_ros.core.checks.rod3d_shooting import shoot_contacts, shoot_tip_load
from vibrissa_ros.core.errors import ParameterError
from vibrissa_ros.core.general.model import WhiskerShape
from vibrissa_ros.core.rod3d import BasePose, RodShape
from vibrissa_ros.core.rod3d.pose import quat_about, quat_from_matrix, quat_matrix, quat_multiply
from vibrissa_ros.core.scenes.scene import PegObstacle
from vibrissa_ros.core.scenes.tracker import SceneTracker

STRAIGHT = RodShape()
ORIGIN = BasePose((0.0, 0.0, 0.0))
EXACT = 1e-11


# -- minimal obstacles (the shape of core/rod3d/obstacles.py's surface queries) ------------------
@dataclass(frozen=True)
class SurfacePoint:
    distance: float
    point: np.ndarray
    normal: np.ndarray


@dataclass(frozen=True)
class Sphere:
    center: tuple
    r: float

    def surface(self, x):
        d = np.asarray(x, dtype=float) - np.asarray(self.center)
        rho = np.linalg.norm(d)
        n = d / rho
        return SurfacePoint(rho - self.r, np.asarray(self.center) + self.r * n, n)


@dataclass(frozen=True)
class Cylinder:
    point: tuple
    axis: tuple
    r: float

    def surface(self, x):
        e = np.asarray(self.axis, dtype=float) / np.linalg.norm(self.axis)
        d = np.asarray(x, dtype=float) - np.asarray(self.point)
        d = d - (d @ e) * e
        rho = np.linalg.norm(d)
        n = d / rho
        return SurfacePoint(rho - self.r, x - (rho - self.r) * n, n)


@dataclass(frozen=True)
class Plane:
    point: tuple
    normal: tuple

    def surface(self, x):
        n = np.asarray(self.normal, dtype=float) / np.linalg.norm(self.normal)
        d = (np.asarray(x, dtype=float) - np.asarray(self.point)) @ n
        return SurfacePoint(d, x - d * n, n)


# -- a tip load: closed forms --------------------------------------------------------------------
@pytest.mark.parametrize("direction", [(0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.6, -0.8)])
def test_a_small_tip_force_deflects_as_linear_beam_theory(direction):
    f = 1e-4  # the nonlinear correction is O(f^3) ~ 1e-13 here
    d = np.array(direction)
    res = shoot_tip_load(STRAIGHT, ORIGIN, f * d, (0.0, 0.0, 0.0))
    assert res.success, res.message
    np.testing.assert_allclose(res.tip[1:], f / 3.0 * d[1:], rtol=0, atol=1e-13)
    # the centerline: y(s) = f s^2 (3 - s) / 6 along the force
    s = res.s
    np.testing.assert_allclose(res.centerline[:, 1:], np.outer(f * s * s * (3 - s) / 6, d[1:]),
                               rtol=0, atol=1e-13)
    np.testing.assert_allclose(res.force, f * d, rtol=0, atol=0)
    np.testing.assert_allclose(res.moment, np.cross(res.tip, f * d), rtol=0, atol=1e-15)
    np.testing.assert_allclose(res.internal_moment, res.moment, rtol=0, atol=1e-14)


@pytest.mark.parametrize("shape", [STRAIGHT, RodShape(taper=0.3, poisson=0.5)],
                         ids=["uniform", "tapered"])
@pytest.mark.parametrize("torque", [0.3, 2.0])
def test_a_tip_torque_twists_a_straight_rod_by_the_integral_of_one_over_c(shape, torque):
    pose = BasePose((0.2, -0.1, 0.5), tuple(quat_about((0.0, 0.6, 0.8), 0.9)))
    axis = pose.rotation[:, 0]
    res = shoot_tip_load(shape, pose, (0.0, 0.0, 0.0), torque * axis)
    assert res.success, res.message
    a = 1.0 - shape.taper
    # int_0^1 ds / C(s), C = (1 - a s)^4 / (1 + nu)
    flexibility = (1.0 + shape.poisson) * (1.0 if a == 0 else ((1 - a) ** -3 - 1) / (3 * a))
    rel = pose.rotation.T @ res.tip_frame
    angle = math.atan2(rel[2, 1], rel[1, 1])
    assert abs(math.remainder(angle - torque * flexibility, 2 * math.pi)) < EXACT
    np.testing.assert_allclose(res.tip, pose.p + axis, rtol=0, atol=EXACT)
    assert res.drift < 1e-13


@pytest.mark.parametrize("moment, k0", [((0.0, 0.0, 1.5), 0.0), ((0.0, -2.5, 0.0), 0.0),
                                        ((0.0, 0.6, 0.8), 0.0), ((0.0, 0.0, -1.0), 0.7)])
def test_a_tip_moment_bends_a_uniform_rod_into_a_circular_arc(moment, k0):
    shape = RodShape(k0=k0)
    res = shoot_tip_load(shape, ORIGIN, (0.0, 0.0, 0.0), moment)
    assert res.success, res.message
    m = np.array(moment)
    # the arc turns about the moment's direction (the intrinsic curvature about z adds to it)
    omega = m + np.array([0.0, 0.0, k0])
    k = np.linalg.norm(omega)
    e = omega / k
    b = np.cross(e, (1.0, 0.0, 0.0))  # toward the centre of the circle
    s = res.s[:, None]
    want = np.sin(k * s) / k * np.array([1.0, 0.0, 0.0]) + (1 - np.cos(k * s)) / k * b
    np.testing.assert_allclose(res.centerline, want, rtol=0, atol=EXACT)
    np.testing.assert_allclose(res.moment, m, rtol=0, atol=EXACT)


def _cantilever(theta_tip):
    """Return F (along +y) and tip (x, y) of the uniform cantilever turned theta_tip at the tip."""
    st = math.sin(theta_tip)

    def integral(g):
        return quad(lambda t: g(st - t * t) / math.sqrt(1.0 - (st - t * t) ** 2), 0.0,
                    math.sqrt(st), epsabs=0.0, epsrel=1e-13, limit=200)[0]

    # s' = 1 / theta' with theta'^2 = 2 F (sin theta_tip - sin theta), sin theta = st - t^2
    root_2f = 2.0 * integral(lambda u: 1.0)  # the length 1 = (2 / sqrt(2F)) int dt / cos
    force = 0.5 * root_2f ** 2
    return force, math.sqrt(2.0 * st / force), 2.0 * integral(lambda u: u) / root_2f


@pytest.mark.parametrize("theta_tip", [0.4, 1.2])
def test_a_large_tip_force_matches_the_elastica_and_stays_in_its_plane(theta_tip):
    force, x_tip, y_tip = _cantilever(theta_tip)
    # the same cantilever in a rotated frame: its plane is the base frame's (x, y) plane
    q = quat_multiply(quat_about((0.0, 0.0, 1.0), 0.8), quat_about((1.0, 0.0, 0.0), 0.5))
    pose = BasePose((0.3, 0.1, -0.2), tuple(q))
    rot = pose.rotation
    res = shoot_tip_load(STRAIGHT, pose, force * rot[:, 1], (0.0, 0.0, 0.0), points=51)
    assert res.success, res.message
    local = (res.centerline - pose.p) @ rot
    assert np.abs(local[:, 2]).max() < 1e-14
    np.testing.assert_allclose(local[-1, :2], (x_tip, y_tip), rtol=0, atol=EXACT)
    tip = rot.T @ res.tip_frame[:, 0]
    assert abs(math.atan2(tip[1], tip[0]) - theta_tip) < EXACT


def test_an_in_plane_load_on_a_curved_tapered_rod_stays_in_its_plane():
    shape = RodShape(taper=0.4, k0=1.5, k1=-1.0)
    res = shoot_tip_load(shape, ORIGIN, (-1.0, 2.5, 0.0), (0.0, 0.0, 0.4))
    assert res.success, res.message
    assert np.abs(res.centerline[:, 2]).max() == 0.0
    assert np.abs(res.moment[:2]).max() == 0.0


def test_a_tip_load_rejects_bad_input():
    with pytest.raises(ParameterError):
        shoot_tip_load(STRAIGHT, ORIGIN, (0.0, 1.0), (0.0, 0.0, 0.0))
    with pytest.raises(ValueError):
        shoot_tip_load(STRAIGHT, ORIGIN, (0.0, math.nan, 0.0), (0.0, 0.0, 0.0))
    with pytest.raises(ValueError):
        shoot_tip_load(STRAIGHT, ORIGIN, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), points=1)
    with pytest.raises(ParameterError):
        shoot_tip_load(WhiskerShape(), ORIGIN, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


# -- planar contacts: today's scene tracker ----------------------------------------------------
PEGS = ((0.0, 0.4, 0.04), (-0.2, 0.85, 0.03))


def _tracked(shape, stops):
    """Step the planar tracker over two pegs from x0 = -0.4; its states at ``stops``."""
    tracker = SceneTracker([PegObstacle(x, y, r) for x, y, r in PEGS], -0.4, shape=shape)
    out = {}
    for x0 in np.linspace(-0.4, 0.2, 31)[1:]:
        state = tracker.step(float(x0)).state
        for stop in stops:
            if abs(x0 - stop) < 1e-9:
                out[stop] = state
    return [out[s] for s in stops]


def _planar_difference(res, state):
    worst = max(abs(res.force[0] - state.fx), abs(res.force[1] - state.fy),
                abs(res.moment[2] - state.m0))
    for a, b in zip(res.contacts, state.contacts):
        worst = max(worst, abs(a.s - b.s), abs(a.point[0] - b.x), abs(a.point[1] - b.y),
                    abs(a.force[0] - b.fx), abs(a.force[1] - b.fy))
    return worst


@pytest.mark.parametrize("planar, shape", [
    (WhiskerShape(), STRAIGHT),
    (WhiskerShape(0.3, -0.5, 0.4), RodShape(taper=0.3, k0=-0.5, k1=0.4)),
], ids=["straight", "tapered-curved"])
def test_planar_peg_contacts_equal_the_planar_scene_tracker(planar, shape):
    cylinders = [Cylinder((x, y, 0.0), (0.0, 0.0, 1.0), r) for x, y, r in PEGS]
    states = _tracked(planar, (-0.14, 0.04, 0.16))
    seen = set()
    for state in states:
        assert state.contacts
        seen.add(len(state.contacts))
        contacts = [(cylinders[c.obstacle], c.kind) for c in state.contacts]
        guess = [(c.s * (1 + 1e-3), math.hypot(c.fx, c.fy) * (1 + 1e-3))
                 for c in state.contacts]
        base = ((state.fx * (1 + 1e-3), state.fy * (1 - 1e-3), 0.0), (0.0, 0.0, state.m0))
        pose = BasePose.from_planar(state.pose.x, state.pose.y, state.pose.heading)
        res = shoot_contacts(shape, pose, contacts, guess, base_guess=base)
        assert res.success and res.admissible, res.message
        assert _planar_difference(res, state) <= 1e-9
        assert np.abs(res.centerline(21)[:, 2]).max() == 0.0
        assert res.force[2] == 0.0 and np.abs(res.moment[:2]).max() == 0.0
    assert seen == {1, 2}


def test_a_small_planar_deflection_needs_no_base_guess():
    (state,) = _tracked(WhiskerShape(), (-0.22,))
    c = state.contacts[0]
    peg = Cylinder(PEGS[c.obstacle][:2] + (0.0,), (0.0, 0.0, 1.0), PEGS[c.obstacle][2])
    pose = BasePose.from_planar(state.pose.x, state.pose.y, state.pose.heading)
    res = shoot_contacts(STRAIGHT, pose, [(peg, "side")], [(0.8, 0.1)])
    assert res.success, res.message
    assert _planar_difference(res, state) <= 1e-9


# -- 3D contacts ---------------------------------------------------------------------------------
def _tilted_pose():
    q = quat_multiply(quat_about((0.0, 0.0, 1.0), 0.4),
                      quat_multiply(quat_about((0.0, 1.0, 0.0), -0.3),
                                    quat_about((1.0, 0.0, 0.0), 0.7)))
    return BasePose((0.1, -0.2, 0.3), tuple(q))


def _sphere_case(shape, local_direction, s=0.6, radius=0.1, depth=0.05):
    """Place a sphere that the unloaded whisker would cut ``depth`` deep near arc length s."""
    pose = _tilted_pose()
    u = pose.rotation @ (np.array(local_direction) / np.linalg.norm(local_direction))
    center = pose.p + pose.rotation @ shape.free_centerline([s])[0] + (radius - depth) * u
    return pose, Sphere(tuple(center), radius), u


CASES = {
    "straight": (STRAIGHT, (0.0, math.cos(1.0), math.sin(1.0))),
    "curved-off-plane": (RodShape(taper=0.4, k0=1.0, k1=0.5, poisson=0.3), (0.0, 0.3, 1.0)),
}


def _frame_moments(shape, res, points=2001):
    """Return the world moment from the sampled frames' curvature and from the contacts."""
    smp = res.sample(points)
    h = smp.s[1] - smp.s[0]
    R = smp.frames
    dR = (-R[4:] + 8 * R[3:-1] - 8 * R[1:-3] + R[:-4]) / (12 * h)  # 4th order
    K = np.einsum("mji,mjk->mik", R[2:-2], dR)  # R^T R' = [kappa]x
    kappa = np.stack((K[:, 2, 1], K[:, 0, 2], K[:, 1, 0]), axis=1)
    s = smp.s[2:-2]
    B = shape.stiffness(s)
    m = np.stack((B / (1 + shape.poisson) * kappa[:, 0], B * kappa[:, 1],
                  B * (kappa[:, 2] - shape.curvature(s))), axis=1)
    from_frames = np.einsum("mij,mj->mi", R[2:-2], m)
    from_forces = np.zeros_like(from_frames)
    far = np.ones(s.size, dtype=bool)
    for c in res.contacts:
        beyond = s < c.s
        from_forces[beyond] += np.cross(c.point - smp.r[2:-2][beyond], c.force)
        far &= np.abs(s - c.s) > 2.5 * h  # no stencil across the kink of kappa'
    return from_frames[far], from_forces[far], smp


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_tilted_whisker_on_a_sphere_is_in_equilibrium(name):
    shape, direction = CASES[name]
    pose, sphere, u = _sphere_case(shape, direction)
    res = shoot_contacts(shape, pose, [(sphere, "side")], [(0.6, 0.1)])
    assert res.success and res.admissible, res.message
    c = res.contacts[0]
    assert abs(c.distance) < 1e-13 and abs(c.tangent @ c.normal) < 1e-13 and c.f > 0
    # the base load is the contact's, and the shooting's n(0), M(0) agree with it
    np.testing.assert_allclose(res.force, c.force, rtol=0, atol=0)
    np.testing.assert_allclose(res.moment, np.cross(c.point - pose.p, c.force), rtol=0, atol=0)
    np.testing.assert_allclose(res.n0, res.force, rtol=0, atol=1e-13)
    np.testing.assert_allclose(res.m0, res.moment, rtol=0, atol=1e-13)
    # the constitutive moment recomputed from the frames balances the contact force all along
    from_frames, from_forces, smp = _frame_moments(shape, res)
    np.testing.assert_allclose(from_frames, from_forces, rtol=0, atol=1e-9)
    assert res.drift < 1e-13
    np.testing.assert_allclose(smp.r[-1], res.tip, rtol=0, atol=1e-13)
    if name == "straight":  # the straight whisker bends in the plane of d1 and the push
        normal = np.cross(pose.rotation[:, 0], u)
        assert np.abs((smp.r - pose.p) @ normal).max() < 1e-14
    else:  # the push out of its plane twists it
        assert abs(res.m0 @ res.tip_frame[:, 0]) > 1e-3


def _transform(pose, matrix):
    """Map a pose and a result through an orthogonal matrix (a rotation or a mirror)."""
    det = np.linalg.det(matrix)
    # the mirrored rod keeps a right-handed frame: d1, d2 mapped, d3 = d1 x d2
    frame = matrix @ pose.rotation @ np.diag((1.0, 1.0, det))
    new_pose = BasePose(tuple(matrix @ pose.p), tuple(quat_from_matrix(frame)))
    return new_pose, det * matrix


@pytest.mark.parametrize("name", sorted(CASES))
@pytest.mark.parametrize("kind", ["rotation", "mirror"])
def test_a_rotated_or_mirrored_configuration_has_the_mapped_solution(name, kind):
    shape, direction = CASES[name]
    pose, sphere, _ = _sphere_case(shape, direction)
    res = shoot_contacts(shape, pose, [(sphere, "side")], [(0.6, 0.1)])
    if kind == "rotation":
        matrix = quat_matrix(quat_about(np.array((1.0, -2.0, 0.5)) / math.sqrt(5.25), 2.1))
    else:
        e = np.array((0.3, -0.5, 0.8)) / math.sqrt(0.98)
        matrix = np.eye(3) - 2.0 * np.outer(e, e)
    new_pose, axial = _transform(pose, matrix)
    new_sphere = Sphere(tuple(matrix @ np.asarray(sphere.center)), sphere.r)
    out = shoot_contacts(shape, new_pose, [(new_sphere, "side")], [(0.6, 0.1)])
    assert res.success and out.success, (res.message, out.message)
    a, b = res.contacts[0], out.contacts[0]
    assert abs(a.s - b.s) < EXACT and abs(a.f - b.f) < EXACT
    np.testing.assert_allclose(b.point, matrix @ a.point, rtol=0, atol=EXACT)
    np.testing.assert_allclose(out.force, matrix @ res.force, rtol=0, atol=EXACT)
    np.testing.assert_allclose(out.moment, axial @ res.moment, rtol=0, atol=EXACT)
    np.testing.assert_allclose(out.tip, matrix @ res.tip, rtol=0, atol=EXACT)


def test_a_tip_on_a_plane_and_a_side_on_a_cylinder_at_once():
    shape = RodShape(taper=0.5, k0=0.8, poisson=0.38)
    pose = _tilted_pose()
    rot = pose.rotation
    free = shape.free_centerline([0.45, 1.0])
    # a wall the unloaded tip would pass 0.03 beyond, facing back along the tip's tangent
    tangent = rot @ np.array((math.cos(0.8), math.sin(0.8), 0.0))
    wall = Plane(tuple(pose.p + rot @ free[1] - 0.03 * tangent), tuple(-tangent + 0.3 * rot[:, 2]))
    # a pole across the whisker at s ~ 0.45 that pushes it out of its plane
    pole = Cylinder(tuple(pose.p + rot @ free[0] + 0.04 * rot[:, 2]), tuple(rot[:, 1]), 0.05)
    contacts = [(wall, "tip"), (pole, "side")]
    res = shoot_contacts(shape, pose, contacts, [(1.0, 0.5), (0.45, 0.5)])
    assert res.success and res.admissible, res.message
    tip, side = res.contacts
    assert tip.s == 1.0 and abs(tip.distance) < 1e-13 and tip.tangent @ tip.normal < 0
    np.testing.assert_allclose(tip.point, res.tip, rtol=0, atol=1e-15)
    assert abs(side.distance) < 1e-13 and abs(side.tangent @ side.normal) < 1e-13
    np.testing.assert_allclose(res.n0, tip.force + side.force, rtol=0, atol=1e-13)
    from_frames, from_forces, _ = _frame_moments(shape, res)
    np.testing.assert_allclose(from_frames, from_forces, rtol=0, atol=1e-9)


def test_an_unreachable_obstacle_is_a_failure_status_not_an_exception():
    far = Sphere((0.5, 3.0, 0.0), 0.1)
    res = shoot_contacts(STRAIGHT, ORIGIN, [(far, "side")], [(0.5, 0.1)])
    assert not res.success and res.message


@pytest.mark.parametrize("contacts, guess", [
    ([(Sphere((0.5, 0.1, 0.0), 0.2), "edge")], [(0.5, 0.1)]),
    ([(object(), "side")], [(0.5, 0.1)]),
    ([(Sphere((0.5, 0.1, 0.0), 0.2), "side")], [(0.5, 0.1), (0.6, 0.1)]),
    ([(Sphere((0.5, 0.1, 0.0), 0.2), "side")], [(1.2, 0.1)]),
    ([(Sphere((0.5, 0.1, 0.0), 0.2), "side")], [(0.5, math.inf)]),
    ([(Plane((1.0, 0, 0), (-1, 0, 0)), "tip"), (Plane((1.0, 0, 0), (-1, 0, 0)), "tip")],
     [(1.0, 0.1), (1.0, 0.1)]),
    ([], []),
])
def test_contacts_reject_bad_input(contacts, guess):
    with pytest.raises(ValueError):
        shoot_contacts(STRAIGHT, ORIGIN, contacts, guess)
