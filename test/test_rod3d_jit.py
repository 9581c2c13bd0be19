"""
The 3D whisker's compiled kernels against the numpy reference (vibrissa_ros.core.rod3d._jit).

The residual, its Jacobian and its pose sensitivities of every kind of configuration agree with
the numpy code to rounding, the sampled solutions too, and whole tracked paths stay within 1e-12
of the reference's. VIBRISSA_NO_JIT=1 selects the reference.
"""

import math
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vibrissa_ros.core.rod3d import BasePose, Cylinder, Plane, RodShape, RodTracker, Sphere
from vibrissa_ros.core.rod3d import _jit
from vibrissa_ros.core.rod3d.model import RodContactMode, RodSolver
from vibrissa_ros.core.rod3d.pose import quat_about, quat_multiply

pytestmark = pytest.mark.skipif(not _jit.ENABLED, reason="the compiled kernels are off")


def _pose(x, y, z, yaw, roll, pitch=0.0):
    q = quat_multiply(quat_about((0, 0, 1), yaw),
                      quat_multiply(quat_about((0, 1, 0), pitch), quat_about((1, 0, 0), roll)))
    return BasePose((x, y, z), tuple(q))


SHAPES = {
    "uniform": RodShape(),
    "cone, parabola": RodShape(taper=0.3, parabola=0.5),
    "cone, linear curvature": RodShape(taper=0.5, k0=1.0, k1=-0.5),
}
OBSTACLES = (Sphere((0.55, 0.2, 0.05), 0.12, "ball"),
             Cylinder((0.3, 0.1, 0.0), (0, 0, 1), 0.04, "peg"),
             Plane((0.0, 0.0, -0.05), (0.0, 0.0, 1.0), "floor"))
CONFIGURATIONS = {
    "side": ((RodContactMode("side", 0),), (0.6,), (0.3,)),
    "tip": ((RodContactMode("tip", 0),), (1.0,), (0.2,)),
    "side, side": ((RodContactMode("side", 1), RodContactMode("side", 0)), (0.35, 0.7),
                   (0.4, 0.1)),
    "side, tip": ((RodContactMode("side", 2), RodContactMode("tip", 0)), (0.5, 1.0),
                  (0.05, 0.3)),
}


def _vector(solver, modes, breaks, forces, pose):
    vec = solver.guess(modes, breaks, forces, lambda s: solver.free_quaternions(pose, s))
    # off the unloaded whisker in every component, forces nonzero
    return vec + 1e-2 * np.sin(1.7 * np.arange(vec.size))


@pytest.mark.parametrize("shape", sorted(SHAPES))
@pytest.mark.parametrize("config", sorted(CONFIGURATIONS))
def test_the_residual_jacobian_and_sensitivities_equal_the_numpy_reference(shape, config):
    solver = RodSolver(SHAPES[shape], OBSTACLES, n=12)
    modes, breaks, forces = CONFIGURATIONS[config]
    pose = _pose(0.01, -0.02, 0.03, 0.2, 0.3, 0.1)
    vec = _vector(solver, modes, breaks, forces, pose)
    want = solver._residual_numpy(modes, vec, pose, True, True)
    got = solver._residual_compiled(modes, vec, pose, True, True)
    for a, b in zip(want, got):
        assert a.shape == b.shape
        assert np.max(np.abs(a - b)) <= 1e-13 * max(1.0, np.max(np.abs(a)))
    res, J, sens = solver._residual_compiled(modes, vec, pose, False, False)
    assert J is None and sens is None and np.array_equal(res, got[0])


def test_the_kernels_surface_data_equal_the_obstacles_own():
    # spheres, cylinders and planes: the kernels compute the surface data at the contacts
    # themselves, with the obstacles' formulas in the same order: equal to the last bit,
    # including the degenerate points (a sphere's centre, a cylinder's axis)
    from vibrissa_ros.core.rod3d.model import kernel_geometry
    obstacles = OBSTACLES + (Sphere((-0.2, 0.3, 0.4), 0.5), Cylinder((0, 0, 0), (1, 2, 3), 0.2),
                             Cylinder((0, 0, 0), (0.1, 0.0, 1.0), 0.2),
                             Plane((0.1, 0.2, 0.3), (-1.0, 2.0, 0.5)))
    rng = np.random.default_rng(3)
    points = np.concatenate((rng.normal(scale=0.7, size=(200, 3)),
                             [(0.55, 0.2, 0.05), (0.3, 0.1, 0.7), (0.0, 0.0, 0.0)]))
    normal, hess = np.empty((1, 3)), np.empty((1, 3, 3))
    for ob in obstacles:
        code, prm = kernel_geometry(ob)
        for x in points:
            want = ob.surface(x)
            got = _jit.surface(code, np.array(prm), x[0], x[1], x[2], normal, hess, 0)
            assert got == want.distance
            assert np.array_equal(normal[0], want.normal)
            assert np.array_equal(hess[0], want.hessian)


def test_the_kernels_least_distance_equals_the_scenes():
    # the array's clearance test: the least distance of many points to a scene's obstacles
    from vibrissa_ros.core.rod3d import Scene3D
    from vibrissa_ros.core.rod3d.model import kernel_obstacles
    scene = Scene3D((Sphere((0.55, 0.2, 0.05), 0.12, "ball"),
                     Cylinder((0.3, -0.3, 0.0), (0, 0, 1), 0.04, "peg"),
                     Plane((0.0, 0.0, -0.5), (0.0, 0.0, 1.0), "floor"),
                     Cylinder((-0.5, 0, 0), (1, 2, 3), 0.2, "slant")))
    codes, prm = kernel_obstacles(scene.obstacles)
    points = np.random.default_rng(5).normal(scale=0.7, size=(500, 3))
    want = scene.signed_distances(points).min(axis=0)
    assert np.max(np.abs(_jit.least_distance(codes, prm, points) - want)) <= 1e-15


def test_the_free_whiskers_compiled_least_distance_equals_the_python_one(monkeypatch):
    # the free whisker's distance minimized near its nearest sample (the touch search): the
    # kernel's Newton against the tracker's own (_newton_minimum, then the same candidates),
    # for straight and parabolic whiskers, each kind of obstacle, many placements; where the
    # kernel's Newton does not settle the Python one (and its Brent search) takes over
    from vibrissa_ros.core.rod3d import tracker as tracker_module
    obstacles = (Sphere((0.55, 0.2, 0.05), 0.12, "ball"),
                 Cylinder((0.5, -0.1, 0.0), (0.1, 0.2, 1.0), 0.04, "peg"),
                 Plane((0.0, 0.0, -0.3), (0.1, 0.0, 1.0), "floor"))
    rng = np.random.default_rng(11)
    compiled = checked = 0
    for shape in (RodShape(), RodShape(parabola=0.8), RodShape(parabola=-1.5)):
        tracker = RodTracker(obstacles, _pose(-2.0, 0.0, 0.0, 0.0, 0.0), shape=shape)
        assert tracker._free_kernels is not None
        for _ in range(60):
            axis = rng.normal(size=3)
            pose = BasePose(tuple(rng.normal(0.0, 0.3, 3)),
                            tuple(quat_about(axis / np.linalg.norm(axis), rng.uniform(0, 6))))
            pts = np.array(pose.position) + tracker._free_points @ pose.rotation.T
            for k, ob in enumerate(obstacles):
                d = ob.signed_distance(pts)
                j = int(np.argmin(d))
                got = tracker._refine_free(k, pose, j, float(d[j]), tracker_module._FREE_SAMPLES)
                want = tracker._refine(ob, lambda s: tracker._free_point(pose, s), j,
                                       float(d[j]), tracker_module._FREE_SAMPLES,
                                       lambda s: tracker._free_geometry(pose, s))
                samples = tracker_module._FREE_SAMPLES
                newton = tracker_module._newton_minimum(
                    ob, lambda s: tracker._free_geometry(pose, s), float(samples[j]),
                    float(samples[max(j - 1, 0)]), float(samples[min(j + 1, samples.size - 1)]))
                # not settled (a straight whisker along a plane: d'' = 0) where Python's is not
                assert (got is None) == (newton is None)
                checked += 1
                if got is not None:
                    compiled += 1
                    assert abs(got[0] - want[0]) <= 1e-15 and abs(got[1] - want[1]) <= 1e-12
    assert compiled >= 0.7 * checked


def test_the_free_whiskers_compiled_sampled_distances_equal_numpys():
    # the free whisker's 321 samples placed at a pose: each obstacle's least distance and the
    # first sample there, as numpy's min and argmin of the obstacle's signed_distance
    from vibrissa_ros.core.rod3d import tracker as tracker_module
    from vibrissa_ros.core.rod3d.model import kernel_obstacles
    obstacles = (Sphere((0.55, 0.2, 0.05), 0.12, "ball"),
                 Cylinder((0.5, -0.1, 0.0), (0.1, 0.2, 1.0), 0.04, "peg"),
                 Plane((0.0, 0.0, -0.3), (0.1, 0.0, 1.0), "floor"))
    codes, prm = kernel_obstacles(obstacles)
    points = RodShape(parabola=0.8).free_centerline(tracker_module._FREE_SAMPLES)
    rng = np.random.default_rng(13)
    for _ in range(100):
        axis = rng.normal(size=3)
        pose = BasePose(tuple(rng.normal(0.0, 0.3, 3)),
                        tuple(quat_about(axis / np.linalg.norm(axis), rng.uniform(0, 6))))
        dmin, index = _jit.free_samples(codes, prm, np.array(pose.rotation), pose.p, points)
        placed = np.array(pose.position) + points @ pose.rotation.T
        for k, ob in enumerate(obstacles):
            d = ob.signed_distance(placed)
            assert abs(dmin[k] - d.min()) <= 1e-15
            assert index[k] == np.argmin(d) or abs(d[index[k]] - d.min()) <= 1e-15


def test_the_one_call_evaluation_equals_prepare_and_equations():
    # the analytic obstacles' path (one kernel call) and the Python objects' (their surface
    # data from Python, as for an obstacle the kernels do not know): bitwise equal
    solver = RodSolver(SHAPES["cone, parabola"], OBSTACLES, n=12)
    pose = _pose(0.01, -0.02, 0.03, 0.2, 0.3, 0.1)
    for modes, breaks, forces in CONFIGURATIONS.values():
        vec = _vector(solver, modes, breaks, forces, pose)
        assert solver._geometry_of(modes) is not None
        fused = solver._residual_compiled(modes, vec, pose, True, True)
        solver._config(modes).geometry = None
        apart = solver._residual_compiled(modes, vec, pose, True, True)
        for a, b in zip(fused, apart):
            assert np.array_equal(a, b)

    class Peg(Cylinder):  # a subclass may answer otherwise: its own surface() is asked
        pass

    solver = RodSolver(RodShape(), (Peg((0.3, 0.1, 0.0), (0, 0, 1), 0.04, "peg"),), n=12)
    assert solver._geometry_of((RodContactMode("side", 0),)) is None


@pytest.mark.parametrize("shape", ["uniform", "cone, parabola"])
@pytest.mark.parametrize("config", sorted(CONFIGURATIONS))
def test_the_one_call_checks_and_state_equal_the_python_ones(shape, config, monkeypatch):
    # RodSolver._accepted (one kernel call: the contact points and normals, the tip and its
    # frame, the tail's and the nodes' least distances) against the same taken apart in Python
    solver = RodSolver(SHAPES[shape], OBSTACLES, n=12)
    modes, breaks, forces = CONFIGURATIONS[config]
    pose = _pose(0.01, -0.02, 0.03, 0.2, 0.3, 0.1)
    vec = _vector(solver, modes, breaks, forces, pose)
    tracker = RodTracker(OBSTACLES, BasePose((-5.0, 0.0, 0.0)), shape=SHAPES[shape], n=12)
    tracker.solver = solver
    post = solver._accepted(modes, vec, pose)
    assert post is not None
    fast = (solver.equilibrium(modes, vec, pose), tracker._touched_depth(modes, vec, pose))
    monkeypatch.setattr(solver, "_accepted", lambda *args: None)
    slow = (solver.equilibrium(modes, vec, pose), tracker._touched_depth(modes, vec, pose))
    for name in ("points", "forces", "force", "moment", "tip", "tip_frame"):
        a, b = getattr(fast[0], name), getattr(slow[0], name)
        assert np.max(np.abs(np.asarray(a) - np.asarray(b)), initial=0.0) <= 1e-15, name
    assert fast[1][1:] == slow[1][1:] and abs(fast[1][0] - slow[1][0]) <= 1e-15
    end = solver.breaks_of(modes, vec)[-1]
    if modes[-1].kind == "side" and end < 1.0:
        s = end + (1.0 - end) * np.linspace(0.125, 1.0, 8)
        want = np.min(OBSTACLES[modes[-1].obstacle].signed_distance(
            solver.centerline(modes, vec, pose, s)))
        assert abs(post.tail_depth - want) <= 1e-15
    else:
        assert post.tail_depth == math.inf


def test_the_one_call_checks_are_for_straight_and_parabolic_whiskers_on_analytic_obstacles():
    modes = (RodContactMode("side", 0),)
    vec = np.zeros(4 * 12 + 2)
    pose = BasePose((0.0, 0.0, 0.0))
    assert RodSolver(SHAPES["cone, linear curvature"], OBSTACLES, n=12)._accepted(
        modes, vec, pose) is None

    class Peg(Cylinder):
        pass

    solver = RodSolver(RodShape(), (Peg((0.3, 0.1, 0.0), (0, 0, 1), 0.04, "peg"),), n=12)
    assert solver._accepted(modes, vec, pose) is None


@pytest.mark.parametrize("shape", sorted(SHAPES))
def test_the_sampled_solution_equals_the_numpy_reference(shape, monkeypatch):
    solver = RodSolver(SHAPES[shape], OBSTACLES, n=12)
    modes, breaks, forces = CONFIGURATIONS["side, side"]
    pose = _pose(0.01, -0.02, 0.03, 0.2, 0.3, 0.1)
    vec = _vector(solver, modes, breaks, forces, pose)
    s = np.linspace(0.0, 1.0, 41)
    got = (solver.centerline(modes, vec, pose, s), solver.equilibrium(modes, vec, pose))
    monkeypatch.setattr(_jit, "ENABLED", False)
    want = (solver.centerline(modes, vec, pose, s), solver.equilibrium(modes, vec, pose))
    assert np.max(np.abs(got[0] - want[0])) <= 1e-14
    for name in ("points", "forces", "force", "moment", "tip", "tip_frame"):
        assert np.max(np.abs(getattr(got[1], name) - getattr(want[1], name))) <= 1e-14, name


@pytest.mark.parametrize("shape", sorted(SHAPES))
@pytest.mark.parametrize("config", sorted(CONFIGURATIONS))
def test_the_tip_gap_equals_the_sampled_centerlines(shape, config):
    # RodSolver.tip_gap (each segment's integrated tangent as Chebyshev coefficients once, then
    # a recurrence per point) against the least d(s) / (1 - s) of the centerline sampled as
    # RodTracker._gap_behind_tip samples it, to the last contact's obstacle
    solver = RodSolver(SHAPES[shape], OBSTACLES, n=12)
    modes, breaks, forces = CONFIGURATIONS[config]
    pose = _pose(0.01, -0.02, 0.03, 0.2, 0.3, 0.1)
    vec = _vector(solver, modes, breaks, forces, pose)
    ends = solver.breaks_of(modes, vec)
    lo = ends[-2] if len(modes) > 1 else 0.0
    s = np.linspace(0.0, 1.0, 81)
    s = np.ascontiguousarray(s[(s > lo) & (s < min(ends[-1], 1.0))])
    assert s.size > 10
    got = solver.tip_gap(modes, vec, pose, s)
    points = solver.centerline(modes, vec, pose, s)
    want = np.min(OBSTACLES[modes[-1].obstacle].signed_distance(points) / (1.0 - s))
    assert abs(got - want) <= 1e-14 * max(1.0, abs(want))
    assert solver.tip_gap(modes, vec, pose, np.zeros(0)) == math.inf
    bad = vec.copy()
    bad[5] = math.nan
    assert solver.tip_gap(modes, bad, pose, s) is None


def _stream():
    """Return a rolled, tapered, curved whisker swept past a sphere while its base turns."""
    ball = Sphere((0.55, 0.2, 0.05), 0.12, "ball")
    shape = RodShape(taper=0.3, parabola=0.5)
    poses = [_pose(0.0, -0.35 + 0.55 * t, 0.02 * math.sin(3 * t), 0.1 * t, 0.4 + 0.3 * t)
             for t in np.linspace(0.0, 1.0, 120)]
    return [ball], shape, poses


def _track(obstacles, shape, poses):
    tracker = RodTracker(obstacles, poses[0], shape=shape)
    out = []
    for pose in poses[1:]:
        result = tracker.step(pose)
        st = result.state
        out.append((tuple(e.kind for e in result.events), len(st.contacts),
                    np.array(st.force + st.moment + st.tip + st.tip_tangent),
                    np.array([c.s for c in st.contacts] + [c.f for c in st.contacts])))
    return out


def test_a_tracked_path_equals_the_numpy_reference(monkeypatch):
    obstacles, shape, poses = _stream()
    got = _track(obstacles, shape, poses)
    monkeypatch.setattr(_jit, "ENABLED", False)
    want = _track(obstacles, shape, poses)
    assert sum(n for _, n, _, _ in want) > 30  # the path is in contact for a while
    assert [e for e, _, _, _ in got] == [e for e, _, _, _ in want]
    assert [n for _, n, _, _ in got] == [n for _, n, _, _ in want]
    for (_, _, a, sa), (_, _, b, sb) in zip(got, want):
        assert np.max(np.abs(a - b)) <= 1e-12
        assert np.max(np.abs(sa - sb), initial=0.0) <= 1e-12


def test_two_contacts_tracked_equal_the_numpy_reference(monkeypatch):
    pegs = [Cylinder((0.0, 0.4, 0.0), (0, 0, 1), 0.04, "peg0"),
            Cylinder((-0.2, 0.85, 0.0), (0, 0, 1), 0.03, "peg1")]
    poses = ([_pose(float(x), 0.0, 0.0, 0.5 * math.pi, 0.0) for x in np.linspace(-0.4, 0.03, 40)]
             + [_pose(0.03 + 0.04 * t, 0.0, 0.0, 0.5 * math.pi, 0.0, 0.05 * t)
                for t in np.linspace(0.0, 1.0, 40)[1:]])
    got = _track(pegs, RodShape(), poses)
    monkeypatch.setattr(_jit, "ENABLED", False)
    want = _track(pegs, RodShape(), poses)
    assert max(n for _, n, _, _ in want) == 2
    assert [e for e, n, _, _ in got] == [e for e, n, _, _ in want]
    for (_, _, a, sa), (_, _, b, sb) in zip(got, want):
        assert np.max(np.abs(a - b)) <= 1e-12
        assert np.max(np.abs(sa - sb), initial=0.0) <= 1e-12


def test_vibrissa_no_jit_selects_the_numpy_reference():
    code = "from vibrissa_ros.core.rod3d import _jit; print(_jit.ENABLED)"
    env = dict(os.environ, VIBRISSA_NO_JIT="1")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"


_NOTHING_COMPILED_LATER = """
import math
from pathlib import Path
from vibrissa_ros.core.arrays import ArrayTracker, CosineWhisk
from vibrissa_ros.core.arrays import _jit as arrays_jit
from vibrissa_ros.core.rod3d import BasePose, Cylinder, Scene3D, _jit
from vibrissa_ros.scan.array_file import load_array
_jit.warm_up()
kernels = {module.__name__ + "." + name: getattr(module, name) for module in (_jit, arrays_jit)
           for name in dir(module) if hasattr(getattr(module, name), "signatures")}
assert any(name.startswith(arrays_jit.__name__) for name in kernels)
before = {name: len(k.signatures) for name, k in kernels.items()}
array = load_array(Path(%r) / "config" / "rat_array.yaml").side("right")
scene = Scene3D((Cylinder((0.03, -0.016, 0.0), (0, 0, 1), 0.0015, "peg"),))
whisk = CosineWhisk(8.0, -math.radians(20.0), math.radians(20.0))
head = BasePose((0.0, 0.0, 0.0))
tracker = ArrayTracker(array, scene, head, whisk.angle(0.0))
for k in range(1, 61):
    step = tracker.step(head, whisk.angle(k * 1e-3))
    if k %% 20 == 0:
        tracker.centerlines(21)  # (array_node's ~/shapes, from the states' read-only vectors)
assert step.in_contact > 0
print(sorted(name for name, k in kernels.items() if len(k.signatures) != before[name]))
"""


def test_warm_up_compiles_every_kernel_an_array_of_whiskers_calls():
    # a kernel first called with argument types warm_up did not use is compiled (or loaded
    # from the cache: ~0.3 s) in the middle of a tick: the array's first contacts must not, nor
    # the whisker shapes array_node publishes
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    out = subprocess.run([sys.executable, "-c", _NOTHING_COMPILED_LATER % root],
                         capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(radius=st.floats(0.05, 2.0), turn=st.floats(-0.999, 0.999), end=st.floats(1.0, 1.25),
       nodes=st.integers(6, 40), tail=st.integers(0, 8), seed=st.integers(0, 2 ** 31 - 1))
def test_clear_of_bounds_a_unit_speed_curve_also_past_the_tip(radius, turn, end, nodes, tail,
                                                              seed):
    # _jit.clear_of on a helix of unit speed (as a resolved centerline's nodes are to 1e-12)
    # sampled at random arc lengths up to ``end``: past 1 as on a side contact's branch continued
    # past the tip while side -> tip is located, where the bound covers more than the whisker.
    # Never above the curve's least distance to the obstacles (sampled densely), and within
    # _SPEED times half the largest spacing of it
    from hypothesis import assume

    from vibrissa_ros.core.rod3d.model import kernel_obstacles

    rng = np.random.default_rng(seed)
    omega = math.sqrt(1.0 - turn * turn) / radius  # (radius omega)^2 + turn^2 = 1: unit speed

    def curve(s):
        s = np.asarray(s, dtype=float)
        return np.stack((radius * np.cos(omega * s), radius * np.sin(omega * s), turn * s), -1)

    arcs = np.sort(np.concatenate(([0.0, end], rng.uniform(0.0, end, nodes + tail - 2))))
    s, tail_s = arcs[:nodes], arcs[nodes:]
    obstacles = [Sphere(tuple(rng.uniform(-1.5, 1.5, 3)), float(rng.uniform(0.01, 0.5)), "ball"),
                 Cylinder(tuple(rng.uniform(-1.5, 1.5, 3)), tuple(rng.normal(size=3)),
                          float(rng.uniform(0.01, 0.3)), "post"),
                 Plane(tuple(rng.uniform(-1.5, 1.5, 3)), tuple(rng.normal(size=3)), "wall")]
    codes, prm = kernel_obstacles(obstacles)
    dense = curve(np.linspace(0.0, end, 20001))
    least = min(float(ob.signed_distance(dense).min()) for ob in obstacles)
    bound = _jit.clear_of(s, curve(s), tail_s, curve(tail_s).reshape(-1, 3), codes, prm)
    assume(math.isfinite(least))
    assert bound <= least + 1e-12
    assert bound >= least - 0.5 * _jit._SPEED * float(np.diff(arcs).max()) - 1e-12
