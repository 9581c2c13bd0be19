"""
The tracker's commonest step taken in one compiled call (RodSolver.trusted_step).

A pose stream's next pose within the sub-step bound, solved from the stream's extrapolation:
the tangent, its bound, the Newton and chord steps and the accepted solution's data in one
kernel, with the same operations as the general path, so the same states to the last bit.
"""

import math

import numpy as np
import pytest
from rat_pad import HEAD, rb1_whisk

from vibrissa_ros.core.arrays.rat import rat_array
from vibrissa_ros.core.arrays.tracker import ArrayTracker
from vibrissa_ros.core.arrays.whisking import CosineWhisk
from vibrissa_ros.core.errors import ConvergenceError
from vibrissa_ros.core.rod3d import Cylinder, RodSolver, RodTracker, Scene3D, _jit
from vibrissa_ros.core.rod3d import tracker as tracker_module

pytestmark = pytest.mark.skipif(not _jit.LAPACK, reason="the compiled kernels are off")


@pytest.fixture(scope="module")
def rb1_cycle():
    """RB1's base poses over two whisk cycles (250 ticks of 1 ms), and its scene and shape."""
    return rb1_whisk(250)


def _run(rb1_cycle, steps=None):
    poses, obstacles, shape = rb1_cycle
    tracker = RodTracker(obstacles, poses[0], shape=shape)
    out = []
    for pose in poses[1:]:
        result = tracker.step(pose)
        load = np.concatenate((result.state.force, result.state.moment))
        fold = tracker._fold_prev  # (path, modes, t, 1 / |tangent|^2) of the last sub-step
        out.append((tracker._vec.copy(), load, [(e.kind, e.s) for e in result.events],
                    tracker.solver.evaluations, tracker.solver.factorizations,
                    None if fold is None else (fold[1], fold[2], fold[3])))
        if steps is not None:
            steps.append(tracker._last_step is not None)
    return out


def _kernel_steps(monkeypatch):
    """
    Record what RodSolver.trusted_step does at each call, in the list returned.

    ``failed`` (it raised ConvergenceError), ``bounded`` (None: the general path takes the
    step), ``whole`` (a step the bound would shorten, taken whole) or ``solved`` (from the
    stream's prediction, or ``solved, no stream`` from the tangent's with the second-order
    term).
    """
    steps = []
    real = RodSolver.trusted_step

    def recorded(self, *args, **kwargs):
        try:
            result = real(self, *args, **kwargs)
        except ConvergenceError:
            steps.append("failed")
            raise
        steps.append("bounded" if result is None else "whole" if result.whole
                     else "solved" if kwargs.get("whole") else "solved, no stream")
        return result

    monkeypatch.setattr(RodSolver, "trusted_step", recorded)
    return steps


@pytest.mark.parametrize("announced", [True, False])
def test_the_compiled_step_gives_the_general_paths_states_to_the_last_bit(rb1_cycle,
                                                                          monkeypatch,
                                                                          announced):
    if not announced:
        # no tangent recorded before a step: the fold RB1 snaps at is not announced there
        monkeypatch.setattr(RodTracker, "_tangent_before", lambda self, path: None)
    taken = _kernel_steps(monkeypatch)
    fast = _run(rb1_cycle)
    monkeypatch.setattr(RodSolver, "trusted_step", lambda self, *a, **k: None)
    general = _run(rb1_cycle)
    # most steps in contact went through the kernel (the others: an event's sub-steps); at
    # the snap the tangent announces the fold from the step before it, and the kernel leaves
    # that step to the general path, which locates the fold; where it is not announced, the
    # trusted solve fails there (Newton not contracting: the general path's shorter sub-steps
    # follow, without trying that solve again)
    assert taken.count("solved") >= 120
    # and the first steps after each touch (no stream yet) from the tangent's prediction
    assert taken.count("solved, no stream") >= 3
    if announced:
        assert taken.count("bounded") == 1 and "failed" not in taken
    else:
        assert taken.count("failed") >= 1 and "bounded" not in taken
    assert len(fast) == len(general)
    for a, b in zip(fast, general):
        (vec_a, load_a, events_a, ev_a, lu_a, fold_a) = a
        (vec_b, load_b, events_b, ev_b, lu_b, fold_b) = b
        assert np.array_equal(vec_a, vec_b) and np.array_equal(load_a, load_b)
        assert events_a == events_b and fold_a == fold_b
        # the same work: a solve that fails in the kernel is not tried again
        assert (ev_a, lu_a) == (ev_b, lu_b)
    assert [e[0] for events in (f[2] for f in fast) for e in events][:3] == ["touch", "snap",
                                                                             "touch"]


def _in_contact_with_a_stream(rb1_cycle):
    """Return a tracker in contact whose next pose its stream predicts, and that pose."""
    poses, obstacles, shape = rb1_cycle
    tracker = RodTracker(obstacles, poses[0], shape=shape)
    for k, pose in enumerate(poses[1:], 1):
        tracker.step(pose)
        if tracker._modes and len(tracker._history) >= 7:
            path = tracker_module._Path(tracker._pose, poses[k + 1])
            stream = tracker._extrapolate(path)
            if stream is not None:
                return tracker, path, stream
    raise AssertionError("no step in contact with a stream")


def test_trusted_step_solves_as_solve_does(rb1_cycle):
    tracker, path, stream = _in_contact_with_a_stream(rb1_cycle)
    sol, modes, start = tracker.solver, tracker._modes, tracker._solved
    rate = path.rate(path.a)
    before = sol.evaluations, sol.factorizations
    taken = sol.trusted_step(modes, start, rate, stream, path.b, 0.05)
    solved, tan, checked = taken.solved, taken.tangent, taken.checked
    spent = sol.evaluations - before[0], sol.factorizations - before[1]
    kept = sol._accepted_cache[3]
    sol._accepted_cache = None

    before = sol.evaluations, sol.factorizations
    reference = sol.solve(modes, path.b, stream, start=start, max_step=0.5, trusted=True,
                          fail_fast=True)
    assert (sol.evaluations - before[0], sol.factorizations - before[1]) == spent
    assert np.array_equal(solved.vec, reference.vec)
    assert np.array_equal(solved.lu[0], reference.lu[0])
    assert np.array_equal(solved.lu[1], reference.lu[1])
    assert solved.lu[1].dtype == reference.lu[1].dtype
    assert np.array_equal(solved.sens, reference.sens)
    # the tangent at the start, as the general path computes it
    assert np.array_equal(tan, sol.tangent(start, rate))
    # the accepted solution's data, computed in the same call, are _accepted's
    fresh = sol._accepted(modes, reference.vec, path.b)
    assert fresh.above is None
    for name in kept._fields:
        if name != "above":
            assert np.array_equal(np.asarray(getattr(kept, name)),
                                  np.asarray(getattr(fresh, name))), name
    assert kept.clear == taken.clear
    # and the coefficient tail points_needed reads from it, as its own kernel call computes it
    from vibrissa_ros.core.rod3d.model import _POINTS_LADDER, _operators

    n = sol.points_of(modes, reference.vec)
    assert np.array_equal(kept.above, _jit.coefficient_tail(
        _operators(n).Vinv, reference.vec, n, len(modes), _POINTS_LADDER[0] - 2))
    # and the count it asks for, as points_needed finds it from its own kernel call
    sol._accepted_cache = None
    assert taken.needed == sol.points_needed(modes, reference.vec) > 0
    # the checks pass, as the tracker's own find (they raise otherwise)
    assert checked
    tracker._check_tail(modes, reference.vec, path.b)
    tracker._check_between(modes, reference.vec, path.b)
    # what the tracker decides the step by, as its own Python computes it
    line = start.vec + tan
    assert taken.branch_error == float(np.max(np.abs(reference.vec - line)))
    assert taken.branch_change == float(np.max(np.abs(line - start.vec)))
    values = tracker._event_values(path, 1.0, reference.vec, reference.lu)
    assert taken.det == tracker._sign * values[("stable", -1)]
    assert taken.least == min(v for key, v in values.items() if key[0] in ("release", "tip"))
    assert ("tip", len(modes) - 1) in values  # (1 - s of the side contact is among them)


def test_the_kernels_checks_fail_where_the_trackers_do(rb1_cycle, monkeypatch):
    from vibrissa_ros.core.errors import ModelAssumptionError

    tracker, path, stream = _in_contact_with_a_stream(rb1_cycle)
    sol, modes, start = tracker.solver, tracker._modes, tracker._solved
    rate = path.rate(path.a)
    solved = sol.trusted_step(modes, start, rate, stream, path.b, 0.05).solved
    post = sol._accepted(modes, solved.vec, path.b)
    tail, loaded = post.tail_depth, float(post.depth.min())
    # the loaded part touches the peg at its contact (distance 0 to rounding); the tail is
    # clear of it
    assert abs(loaded) < 1e-12 and 1e-3 < tail < math.inf
    # a bound between the two: the loaded part's check refuses, the tail's passes, in the
    # kernel as in the tracker
    cut = 0.5 * tail
    monkeypatch.setattr(tracker_module, "_TAIL_CUT", cut)
    assert not sol.trusted_step(modes, start, rate, stream, path.b, 0.05, tail_cut=cut).checked
    with pytest.raises(ModelAssumptionError):
        tracker._check_between(modes, solved.vec, path.b)
    tracker._check_tail(modes, solved.vec, path.b)
    # above both: both refuse
    cut = 2.0 * tail
    monkeypatch.setattr(tracker_module, "_TAIL_CUT", cut)
    assert not sol.trusted_step(modes, start, rate, stream, path.b, 0.05, tail_cut=cut).checked
    with pytest.raises(ModelAssumptionError):
        tracker._check_tail(modes, solved.vec, path.b)
    # the tracker's own bound: both pass
    monkeypatch.undo()
    assert sol.trusted_step(modes, start, rate, stream, path.b, 0.05,
                            tail_cut=tracker_module._TAIL_CUT).checked


def test_a_bound_that_shortens_the_step_leaves_it_to_the_general_path(rb1_cycle):
    tracker, path, stream = _in_contact_with_a_stream(rb1_cycle)
    sol = tracker.solver
    before = sol.evaluations
    # a bound no tangent meets: nothing solved, nothing spent
    assert sol.trusted_step(tracker._modes, tracker._solved, path.rate(path.a), stream, path.b,
                            1e-12) is None
    assert sol.evaluations == before


def test_a_failed_trusted_solve_raises_as_solve_does(rb1_cycle):
    tracker, path, stream = _in_contact_with_a_stream(rb1_cycle)
    sol, modes, start = tracker.solver, tracker._modes, tracker._solved
    far = stream.copy()
    far[:-2] += 0.3  # no Newton step from here is shorter than max_step
    spent = []
    for attempt in (lambda: sol.trusted_step(modes, start, np.zeros(7), far, path.b, 0.05,
                                             max_step=0.01),
                    lambda: sol.solve(modes, path.b, far, start=start, max_step=0.01,
                                      trusted=True, fail_fast=True)):
        before = sol.evaluations, sol.factorizations
        with pytest.raises(ConvergenceError):
            attempt()
        spent.append((sol.evaluations - before[0], sol.factorizations - before[1]))
    assert spent[0] == spent[1] == (1, 1)


def test_a_tangent_that_is_not_finite_leaves_the_step_to_the_general_path(rb1_cycle):
    tracker, path, stream = _in_contact_with_a_stream(rb1_cycle)
    sol, start = tracker.solver, tracker._solved
    sens = start.sens.copy()
    sens[0, 0] = math.nan
    rate = path.rate(path.a)
    rate[0] = 1.0  # (so that the NaN reaches the tangent)
    broken = start._replace(sens=sens)
    before = sol.evaluations
    assert sol.trusted_step(tracker._modes, broken, rate, stream, path.b, 0.05) is None
    assert sol.evaluations == before


@pytest.mark.parametrize("scene", ["wall", "pegs"])
def test_the_arrays_soak_scenes_give_the_same_ticks_with_and_without_the_kernel(scene,
                                                                                monkeypatch):
    # bench/soak_array.py's scenes, the right pad: planes, spheres and tilted cylinders, tip
    # contacts and their tangential changes, several contacts per whisker, and (the wall) a
    # whisker's steps refused by the loaded part's check, tick after tick
    from vibrissa_ros.core.rod3d import Plane, Sphere

    scenes = {
        "wall": (Scene3D((Plane((0.032, 0.0, 0.0), (-1.0, -0.3, 0.2), "wall"),
                          Sphere((-0.03, 0.0, 0.01), 0.008, "ball_left"),
                          Cylinder((0.0, 0.035, 0.0), (1.0, 0.0, 0.3), 0.0015, "bar"))),
                 CosineWhisk(8.0, math.radians(-25.0), math.radians(20.0))),
        "pegs": (Scene3D((Cylinder((0.025, -0.012, 0.0), (0, 0.2, 1), 0.002, "peg_right"),
                          Sphere((0.0, 0.045, -0.005), 0.006, "ball"))),
                 CosineWhisk(7.0, math.radians(-30.0), math.radians(25.0))),
    }
    obstacles, whisk = scenes[scene]
    array = rat_array("right")

    def run():
        tracker = ArrayTracker(array, obstacles, HEAD, whisk.angle(0.0))
        ticks = []
        for k in range(1, 121 if scene == "wall" else 201):
            step = tracker.step(HEAD, whisk.angle(k * 1e-3))
            ticks.append((step.force_base.copy(), step.moment_base.copy(), step.contacts.copy(),
                          [(e.whisker, e.kind) for e in step.events],
                          [(e.whisker, e.message) for e in step.errors]))
        work = [(tracker.tracker(n).solver.evaluations, tracker.tracker(n).solver.factorizations)
                for n in tracker.names]
        return ticks, work

    solved = _kernel_steps(monkeypatch)
    fast = run()
    assert solved.count("solved") >= 100  # the kernel took most steps in contact
    # and steps the bound would shorten, taken whole as _whole_step takes them
    assert solved.count("whole") >= 3
    monkeypatch.setattr(RodSolver, "trusted_step", lambda self, *a, **k: None)
    general = run()
    assert fast[1] == general[1]
    kinds = set()
    for a, b in zip(fast[0], general[0]):
        assert all(np.array_equal(u, v) for u, v in zip(a[:3], b[:3]))
        assert a[3:] == b[3:]
        kinds |= {kind for _, kind in a[3]} | ({"refused"} if a[4] else set())
    assert {"touch", "tip"} <= kinds
    if scene == "wall":
        assert "refused" in kinds


def test_the_contact_loads_are_equilibriums_numpy_formulas_to_the_last_bit():
    # the forces f n, their sum over the contacts (numpy's, from +0.0: a -0.0 component sums
    # to +0.0) and their moment about the base point (a loop in floats from the first contact's),
    # as RodSolver.equilibrium computed them in numpy before the kernel did; compared as bytes,
    # so that the sign of a zero counts
    rng = np.random.default_rng(7)
    n = 4
    for k in (1, 2, 3):
        for trial in range(40):
            kinds = rng.integers(0, 2, k).astype(np.int64)
            vec = rng.normal(size=4 * n * k + int(kinds.sum()) + k)
            points = rng.normal(size=(k, 3))
            normals = rng.normal(size=(k, 3))
            p = rng.normal(size=3)
            if trial % 2:
                # zeros of both signs, in the normals, the forces and the lever arms
                normals[rng.random((k, 3)) < 0.5] = -0.0
                points[:, 1] = p[1]
            o, fs, ss = 4 * n * k, [], []
            for c in range(k):
                size = 2 if kinds[c] == 1 else 1
                if trial % 4 == 1:
                    vec[o + size - 1] = -0.0
                ss.append(float(vec[o]) if kinds[c] == 1 else 1.0)
                fs.append(float(vec[o + size - 1]))
                o += size
            s_c, f_c, forces, force, moment = _jit.contact_loads(vec, n, kinds, points, normals, p)
            old_forces = normals * np.array(fs)[:, None]
            old_moment = None
            px, py, pz = p.tolist()
            for (x, y, z), (fx, fy, fz) in zip(points.tolist(), old_forces.tolist()):
                ax, ay, az = x - px, y - py, z - pz
                mc = (ay * fz - az * fy, az * fx - ax * fz, ax * fy - ay * fx)
                old_moment = mc if old_moment is None else tuple(
                    u + v for u, v in zip(old_moment, mc))
            assert s_c.tolist() == ss and f_c.tobytes() == np.array(fs).tobytes()
            assert forces.tobytes() == old_forces.tobytes()
            assert force.tobytes() == old_forces.sum(axis=0).tobytes()
            assert moment.tobytes() == np.array(old_moment).tobytes()


def test_the_kernels_measures_of_a_solution():
    # _solution_measures on made-up values: the branch check's two max norms (as _off_branch
    # computes them), the least of the forces and of 1 - s at the last side contact, and the
    # determinant measure
    vec0 = np.array([0.0, 1.0, 2.0, 0.5, 0.25])
    tan = np.array([0.1, -0.2, 0.0, 0.05, 0.0])
    vec = np.array([0.1, 0.75, 2.0, 0.5, 0.3])
    forces = np.array([4], dtype=np.int64)
    lu, piv = np.asfortranarray(np.diag([2.0, -3.0, 4.0, 1.0, 5.0])), np.arange(5, dtype=np.int32)
    error, change, least, det = _jit._solution_measures(vec, vec0, tan, forces, -1, lu, piv)
    line = vec0 + tan
    assert error == float(np.max(np.abs(vec - line)))
    assert change == float(np.max(np.abs(line - vec0)))
    assert least == 0.3
    assert det == pytest.approx(-(120.0 ** 0.2), rel=1e-15)  # one negative pivot, no swap
    # the last contact's arc length past the tip: 1 - s is the least value
    vec[3] = 1.5
    assert _jit._solution_measures(vec, vec0, tan, forces, 3, lu, piv)[2] == -0.5
    vec[4] = -0.25  # a force below zero, and lower
    assert _jit._solution_measures(vec, vec0, tan, forces, 3, lu, piv)[2] == -0.5
    vec[4] = -0.75
    assert _jit._solution_measures(vec, vec0, tan, forces, 3, lu, piv)[2] == -0.75


@pytest.mark.parametrize("change, concluded, taken_whole", [
    ({}, False, True),                       # nothing crossed: accepted as it is
    ({"least": -1e-3}, True, False),         # a force (or 1 - s) below zero: an event
    ("unstable", True, False),               # the stability value's sign changed: an event
    ({"branch_error": 0.5, "branch_change": 0.01}, False, False),  # off the branch: refused
])
def test_the_plain_step_decides_by_the_kernels_values(rb1_cycle, monkeypatch, change, concluded,
                                                      taken_whole):
    tracker, path, stream = _in_contact_with_a_stream(rb1_cycle)
    assert not tracker.solver._config(tracker._modes).tips
    real = RodSolver.trusted_step

    def altered(self, *args, **kwargs):
        taken = real(self, *args, **kwargs)
        if change == "unstable":
            return taken._replace(det=-tracker._sign * abs(taken.det))
        return taken._replace(**change)

    conclusions = []
    monkeypatch.setattr(RodSolver, "trusted_step", altered)
    monkeypatch.setattr(RodTracker, "_conclude",
                        lambda self, *args, **kwargs: conclusions.append(args) or (0.5, 0.5))
    result = tracker._plain_step(path, [])
    assert bool(conclusions) == concluded
    assert (result == (1.0, 1.0)) == taken_whole
    if change and not concluded:
        assert result is False  # (the general path takes shorter sub-steps from the start)


def _states_in_contact(tracker, poses, every=1):
    """Step ``tracker`` along ``poses``; return (modes, vec, pose) where it is in contact."""
    out = []
    for k, pose in enumerate(poses):
        tracker.step(pose)
        if tracker._modes and k % every == 0:
            out.append((tracker._modes, tracker._vec.copy(), tracker._pose))
    return out


def _bounded_cases(rb1_cycle):
    """Solutions in contact: side and tip contacts on parabolic whiskers, a tip on a straight."""
    from vibrissa_ros.core.rod3d import BasePose, Plane

    poses, obstacles, shape = rb1_cycle
    cases = [(shape, obstacles, state)
             for state in _states_in_contact(RodTracker(obstacles, poses[0], shape=shape),
                                             poses[1:], every=10)]
    floor = Plane((0.0, 0.0, -0.3), (0.0, 0.0, 1.0), "floor")
    pole = Cylinder((0.5, 0.0, 0.0), (0.0, 1.0, 0.3), 0.05, "pole")
    q = (math.cos(0.175), 0.0, math.sin(0.175), 0.0)
    walk = [BasePose((-0.2, 0.0, float(z)), q) for z in np.linspace(0.1, -0.1, 41)]
    straight = RodTracker([floor, pole], walk[0])
    cases += [(straight.shape, straight.obstacles, state)
              for state in _states_in_contact(straight, walk[1:], every=4)]
    # the rat's (parabolic) whiskers pressing their tips on a wall, then a side and the tip
    wall = Plane((0.032, 0.0, 0.0), (-1.0, -0.3, 0.2), "wall")
    whisk = CosineWhisk(8.0, math.radians(-25.0), math.radians(20.0))
    pad = ArrayTracker(rat_array("right"), Scene3D((wall,)), HEAD, whisk.angle(0.0))
    for k in range(1, 49):
        pad.step(HEAD, whisk.angle(k * 1e-3))
        for name in ("RC0", "RC1", "RB0"):
            rod = pad.tracker(name)
            if k % 3 == 0 and any(m.kind == "tip" for m in rod._modes):
                cases.append((rod.shape, rod.obstacles, (rod._modes, rod._vec.copy(), rod._pose)))
    return cases


def test_the_kernels_bound_of_the_distance_to_the_obstacles_not_touched(rb1_cycle):
    # _jit.clear_of: below the least distance of the whole centerline (sampled densely) to the
    # obstacles no contact is on, within the nodes' spacing of it, and below 0 where one of
    # them cuts the whisker: what lets the plain step skip _contact_gap's sampling
    from vibrissa_ros.core.rod3d import Plane, Sphere

    s = np.linspace(0.0, 1.0, 4001)
    seen = set()
    far = []
    for shape, obstacles, (modes, vec, pose) in _bounded_cases(rb1_cycle):
        seen.add(tuple(m.kind for m in modes))
        pts = RodSolver(shape, obstacles).centerline(modes, vec, pose, s)
        mid, tip = pts[2000], pts[-1]
        others = [Sphere(tuple(mid + (0.0, 0.0, 0.08)), 0.05, "near ball"),
                  Plane(tuple(tip + (0.0, 0.0, -0.2)), (0.0, 0.0, 1.0), "under"),
                  Cylinder(tuple(mid + (0.3, 0.3, 0.0)), (0.0, 0.0, 1.0), 0.1, "post"),
                  Sphere(tuple(pts[3700]), 0.01, "cutting")]
        for extra in (others[1:3], others[:1], others[3:], others):
            sol = RodSolver(shape, tuple(obstacles) + tuple(extra))
            clear = sol._accepted(modes, vec, pose).clear
            untouched = [ob for k, ob in enumerate(sol.obstacles)
                         if k not in {m.obstacle for m in modes}]
            least = min(float(ob.signed_distance(pts).min()) for ob in untouched)
            assert least - 0.1 <= clear <= least
            if least > 0.1:
                assert clear > 0.0
                far.append(least)
            if others[3] in extra:
                assert clear < 0.0
        # no other obstacle: nothing to bound (inf); one the kernels do not know: -inf
        if len(obstacles) == 1:
            assert RodSolver(shape, obstacles)._accepted(modes, vec, pose).clear == math.inf

        class Ball(Sphere):
            pass

        unknown = RodSolver(shape, tuple(obstacles) + (Ball((5.0, 0.0, 0.0), 0.1),))
        assert unknown._accepted(modes, vec, pose).clear == -math.inf
    assert {("side",), ("tip",), ("side", "tip")} <= seen
    assert len(far) >= 5


@pytest.mark.parametrize("scene", ["wall", "pegs"])
def test_the_kernels_bound_spares_the_touch_search_without_changing_a_tick(scene, monkeypatch):
    # the soak scenes (two and three obstacles): every tick the same, to the last bit, with the
    # touch test sampling the centerline at every step, and it samples far less often
    from vibrissa_ros.core.rod3d import Plane, Sphere

    scenes = {
        "wall": Scene3D((Plane((0.032, 0.0, 0.0), (-1.0, -0.3, 0.2), "wall"),
                         Sphere((-0.03, 0.0, 0.01), 0.008, "ball_left"),
                         Cylinder((0.0, 0.035, 0.0), (1.0, 0.0, 0.3), 0.0015, "bar"))),
        "pegs": Scene3D((Cylinder((0.025, -0.012, 0.0), (0, 0.2, 1), 0.002, "peg_right"),
                         Sphere((0.0, 0.045, -0.005), 0.006, "ball"))),
    }
    whisk = CosineWhisk(8.0, math.radians(-25.0), math.radians(20.0))
    array = rat_array("right")
    sampled = []
    real = RodTracker._contact_gap

    def counted(self, *args, **kwargs):
        sampled.append(1)
        return real(self, *args, **kwargs)

    def run():
        sampled.clear()
        tracker = ArrayTracker(array, scenes[scene], HEAD, whisk.angle(0.0))
        ticks = [tracker.step(HEAD, whisk.angle(k * 1e-3)) for k in range(1, 121)]
        work = [(tracker.tracker(n).solver.evaluations, tracker.tracker(n).solver.factorizations)
                for n in tracker.names]
        rows = [(t.force_base, t.moment_base, t.contacts,
                 [(e.whisker, e.kind, e.s) for e in t.events],
                 [(e.whisker, e.message) for e in t.errors]) for t in ticks]
        return rows, work, len(sampled)

    monkeypatch.setattr(RodTracker, "_contact_gap", counted)
    bounded = run()
    monkeypatch.setattr(RodTracker, "_touches", lambda self, path, t, vec, clear=None:
                        self._contact_gap(path, t, vec)[0] < tracker_module._CUT)
    sampling = run()
    assert bounded[1] == sampling[1]
    events = set()
    for a, b in zip(bounded[0], sampling[0]):
        assert all(np.array_equal(u, v) for u, v in zip(a[:3], b[:3]))
        assert a[3:] == b[3:]
        events |= {kind for _, kind, _ in a[3]}
    assert "touch" in events
    assert bounded[2] < 0.5 * sampling[2]


def test_the_compiled_stream_extrapolation_is_the_numpy_rule(rb1_cycle):
    # _jit.stream_guess on the history's arrays: the same degree taken (or none) at every step
    # of RB1's whisk, a guess within rounding of numpy's (another order of summation), and
    # the arrays kept up to date across resampled and reset histories
    poses, obstacles, shape = rb1_cycle
    tracker = RodTracker(obstacles, poses[0], shape=shape)
    taken = declined = 0
    for k, pose in enumerate(poses[1:-3], 1):
        tracker.step(pose)
        # the next pose, and the one three ticks on (not a uniform stream: declined)
        jump = poses[k + 3]
        for target in (jump, poses[k + 1]):
            path = tracker_module._Path(tracker._pose, target)
            compiled, reference = tracker._extrapolate(path), tracker._extrapolate_numpy(path)
            assert (compiled is None) == (reference is None)
        if tracker._modes and len(tracker._history) >= 3:
            declined += tracker._extrapolate(tracker_module._Path(tracker._pose, jump)) is None
        if compiled is None:
            continue
        taken += 1
        assert compiled.shape == reference.shape
        # (weights up to 70 on values ~1: 256 ulp of the sum's terms at most)
        assert np.max(np.abs(compiled - reference)) <= 256 * 2.3e-16 * max(
            1.0, np.abs(reference).max())
        stream = tracker._stream
        assert stream[0] is tracker._history
        assert np.array_equal(stream[2], np.array([v for _, v in tracker._history]))
    assert taken >= 120 and declined >= 100


def test_a_pose_repeated_at_a_whisks_turning_point_is_a_sample_of_the_stream(monkeypatch):
    # the whisk turns at 62.5 ms: the 62 ms and 63 ms poses are the same, and RC1 is pressed
    # on the peg. The repeated pose changes nothing but is a sample of the stream (its history
    # stays uniform in time), so the next steps are still extrapolated and taken in one
    # kernel call each
    from rat_pad import PEG, WHISK

    from vibrissa_ros.core.arrays import WhiskerArray

    pad = ArrayTracker(WhiskerArray((rat_array("right")["RC1"],), "RC1"), Scene3D((PEG,)), HEAD,
                       WHISK.angle(0.0))
    rod = pad.tracker("RC1")
    obstacles, shape = rod.obstacles, rod.shape
    poses = [pad.whisker_poses(HEAD, WHISK.angle(k * 1e-3))[0] for k in range(70)]
    assert poses[62] == poses[63]
    tracker = RodTracker(obstacles, poses[0], shape=shape)
    for pose in poses[1:63]:
        tracker.step(pose)
    assert tracker._modes and len(tracker._history) == 7
    state, history = tracker.state, tracker._history
    result = tracker.step(poses[63])
    assert result.state is state and result.events == () and result.evaluations == 0
    assert len(tracker._history) == 7 and tracker._history[-1][0] == poses[62]
    assert tracker._history[:-1] == history[1:]
    steps = _kernel_steps(monkeypatch)
    for pose in poses[64:68]:
        assert tracker.step(pose).events == ()
    solved = [step in ("solved", "whole") for step in steps]
    assert solved == [True] * 4


def test_a_pose_held_or_sent_twice_keeps_the_stream(monkeypatch):
    # RC1 whisked into the peg, every pose given twice (a held input, or a head pose that ticks
    # the array between two whisks): each repeat costs nothing and changes nothing, and the
    # stream's extrapolation goes on without the repeats, so the steps are the kernel's as
    # often as with every pose given once, to the same equilibria
    from rat_pad import PEG, WHISK

    from vibrissa_ros.core.arrays import WhiskerArray

    pad = ArrayTracker(WhiskerArray((rat_array("right")["RC1"],), "RC1"), Scene3D((PEG,)), HEAD,
                       WHISK.angle(0.0))
    rod = pad.tracker("RC1")
    poses = [pad.whisker_poses(HEAD, WHISK.angle(k * 1e-3))[0] for k in range(121)]
    steps = _kernel_steps(monkeypatch)

    def run(times):
        steps.clear()
        tracker = RodTracker(rod.obstacles, poses[0], shape=rod.shape)
        out = []
        for k, pose in enumerate(poses[1:], 1):
            for repeat in range(times):
                if repeat:
                    state, before = tracker.state, tracker.solver.evaluations
                    path = tracker_module._Path(tracker._pose, poses[min(k + 1, 120)])
                    compiled = tracker._extrapolate(path)
                    reference = tracker._extrapolate_numpy(path)
                    assert (compiled is None) == (reference is None)
                result = tracker.step(pose)
                if repeat:
                    assert result.state is state and result.events == ()
                    assert tracker.solver.evaluations == before
            out.append(result.state)
        return out, sum(step in ("solved", "whole") for step in steps)

    once, kernel_once = run(1)
    twice, kernel_twice = run(2)
    assert kernel_once >= 60 and kernel_twice >= kernel_once - 5
    for a, b in zip(once, twice):
        assert len(a.contacts) == len(b.contacts)
        assert np.abs(np.subtract(a.force, b.force)).max() <= 1e-12
        assert np.abs(np.subtract(a.tip, b.tip)).max() <= 1e-12


def test_a_solve_the_kernel_failed_is_not_tried_again(rb1_cycle, monkeypatch):
    # where the kernel's trusted solve fails (a step within the bound, or one taken whole),
    # the general path goes on with shorter sub-steps and never solves from that guess again
    # at that pose: counted directly, solve by solve (RB1 with its fold not announced, so that
    # the trusted solve fails there, and the rat's right pad)
    monkeypatch.setattr(RodTracker, "_tangent_before", lambda self, path: None)
    failed, repeated = [], []
    real_step, real_solve = RodSolver.trusted_step, RodSolver.solve

    def step(self, modes, start, rate, guess, pose, *args, **kwargs):
        try:
            return real_step(self, modes, start, rate, guess, pose, *args, **kwargs)
        except ConvergenceError:
            failed.append((guess.tobytes(), pose, kwargs.get("whole")))
            raise

    def solve(self, modes, pose, guess, *args, **kwargs):
        if any(guess.tobytes() == g and pose == p for g, p, _ in failed):
            repeated.append(pose)
        return real_solve(self, modes, pose, guess, *args, **kwargs)

    monkeypatch.setattr(RodSolver, "trusted_step", step)
    monkeypatch.setattr(RodSolver, "solve", solve)
    _run(rb1_cycle)
    whisk = CosineWhisk(8.0, math.radians(-20.0), math.radians(20.0))
    peg = Cylinder((0.03, -0.016, 0.0), (0, 0, 1), 0.0015, "peg_right")
    pad = ArrayTracker(rat_array("right"), Scene3D((peg,)), HEAD, whisk.angle(0.0))
    for k in range(1, 251):
        pad.step(HEAD, whisk.angle(k * 1e-3))
    assert len(failed) >= 5 and repeated == []


def test_a_tangent_recorded_on_the_step_before_carries_over_where_the_stream_goes_on():
    # _Path.continuing: the record's t and g on the next step's parameter, only where that step
    # starts at this one's end (the same pose object) at about its speed and direction
    from vibrissa_ros.core.rod3d import BasePose
    from vibrissa_ros.core.rod3d.pose import quat_about

    def pose(k):
        return BasePose((0.01 * k, 0.002 * k, 0.0), quat_about((0.0, 0.0, 1.0), 0.05 * k))

    a, b = pose(0), pose(1)
    before = tracker_module._Path(a, b)
    tan = np.array([3.0, 4.0])
    record = (before, ("modes",), 0.25, 1.0 / 25.0, tan)
    c = pose(2)
    after = tracker_module._Path(b, c)
    carried = after.continuing(record)
    r = before.speed / after.speed
    assert carried[0] is after and carried[1] == ("modes",) and carried[4] is tan
    assert carried[2] == pytest.approx(-0.75 * r) and carried[3] == pytest.approx(r * r / 25.0)
    assert r == pytest.approx(1.0, rel=1e-9)
    # twice as far (the same direction): not a uniform stream
    assert tracker_module._Path(b, pose(3)).continuing(record) is None
    # back the way it came (a whisk's turning point): not going on
    assert tracker_module._Path(b, a).continuing(record) is None
    # from an equal pose that is not the step's end: not its continuation
    assert tracker_module._Path(pose(1), c).continuing(record) is None
    # a held pose: no speed
    assert tracker_module._Path(b, b).continuing(record) is None


def test_the_recorded_tangents_follow_a_change_of_the_point_count(rb1_cycle):
    # _resolve_points resamples the tangents recorded for _fold_limit with the solution (a fold
    # is then still announced from the step before), and g stays 1 / norm(tangent)^2
    poses, obstacles, shape = rb1_cycle
    tracker = RodTracker(obstacles, poses[0], shape=shape)
    changed = 0
    for pose in poses[1:]:
        n = len(tracker._vec)
        tracker.step(pose)
        record = tracker._fold_prev
        if tracker._modes and n and len(tracker._vec) != n and record is not None:
            if record[1] == tracker._modes:
                changed += 1
                assert record[4].size == tracker._vec.size
                assert record[3] == tracker_module._fold_g(record[4])
                assert record[3] == pytest.approx(1.0 / float(record[4] @ record[4]), rel=1e-14)
    assert changed >= 3


def test_a_trusted_solve_from_a_far_guess_still_converges_to_the_tolerance(rb1_cycle):
    # Newton's quadratic prediction of the next step is believed only from a last step of at
    # most 1e-4 (model._settled): from a tangent's guess 8 to 32 poses ahead (1e-3 to 1e-2
    # away) the solution is within ~1e-13 of Newton's limit (it stopped up to 6.7e-13 from it
    # when a first step of ~1e-2 followed by one of ~1e-6 was taken for convergence)
    poses, obstacles, shape = rb1_cycle
    tracker = RodTracker(obstacles, poses[0], shape=shape)
    sol = tracker.solver
    errors = []
    for k in range(1, 240):
        tracker.step(poses[k])
        if not tracker._modes or k % 2:
            continue
        for ahead in (8, 12, 16, 24, 32):
            if k + ahead >= len(poses):
                break
            path = tracker_module._Path(tracker._pose, poses[k + ahead])
            guess = tracker._vec + sol.tangent(tracker._solved, path.rate(path.a))
            try:
                solved = sol.solve(tracker._modes, path.b, guess, start=tracker._solved,
                                   max_step=0.5, trusted=True, fail_fast=True)
            except ConvergenceError:
                continue
            limit = solved.vec
            for _ in range(4):
                res, J, _ = sol.residual(tracker._modes, limit, path.b)
                limit = limit - np.linalg.solve(J, res)
            errors.append(float(np.abs(solved.vec - limit).max()))
    assert len(errors) >= 200 and max(errors) <= 2.5e-13
