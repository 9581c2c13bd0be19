"""The whole array in one call: whisking, the clearance test, per-whisker equality."""

import math
from pathlib import Path

import numpy as np
import pytest

from vibrissa_ros.core.arrays import WhiskerArray
from vibrissa_ros.core.arrays.rat import emergence_rotation, mirror_rotation, rat_array
from vibrissa_ros.core.arrays.tracker import ArrayTracker, describe, quats_from_matrices
from vibrissa_ros.core.arrays import whisking as whisking_module
from vibrissa_ros.core.arrays.whisking import (
    ROW_SLOPES, CosineWhisk, Whisking, emergence_angles,
)
from vibrissa_ros.core.errors import ConvergenceError, InvalidPoseError, ParameterError
from vibrissa_ros.core.rod3d import BasePose, Cylinder, RodTracker, Scene3D, Sphere
from vibrissa_ros.core.rod3d.pose import quat_about, quat_from_matrix, quat_matrix

from rat_pad import SOAK_PEGS, soak_head

RIGHT = rat_array("right")
#: a vertical peg that the right pad's whiskers of columns 0-2 hit while whisking
PEG = Cylinder((0.03, -0.016, 0.0), (0, 0, 1), 0.0015, "peg")
HEAD = BasePose((0.0, 0.0, 0.0))


def _subset(array, names):
    return WhiskerArray(tuple(array[n] for n in names), "subset")


def test_emergence_angles_invert_the_rest_orientation():
    for theta, phi, zeta in ((32.79, 51.60, 43.56), (120.0, -10.0, -70.0), (90.0, 0.0, 0.0)):
        R = emergence_rotation(theta, phi, zeta)
        got = np.degrees(emergence_angles(R, "right"))
        assert got == pytest.approx((theta, phi, zeta), abs=1e-12)
        assert np.degrees(emergence_angles(mirror_rotation(R), "left")) == pytest.approx(
            (theta, phi, zeta), abs=1e-12)
    with pytest.raises(ParameterError, match="side"):
        emergence_angles(np.eye(3), "top")


def test_zero_protraction_is_the_rest_orientation_on_both_sides():
    both = rat_array("both")
    w = Whisking([r.pose.rotation for r in both.rods()], [s.side for s in both],
                 [s.whisking for s in both])
    R = w.rotations(0.0)
    for Ri, spec in zip(R, both):
        assert np.abs(Ri - BasePose((0, 0, 0), spec.base_quaternion).rotation).max() < 1e-14


def test_protraction_turns_the_tangent_rostrally_and_follows_the_row_slopes():
    both = rat_array("both")
    w = Whisking([r.pose.rotation for r in both.rods()], [s.side for s in both],
                 [s.whisking for s in both])
    h = 1e-6
    R0, R1 = w.rotations(0.0), w.rotations(h)
    for spec, a, b in zip(both, R0, R1):
        assert b[1, 0] > a[1, 0]  # the base tangent gains +y (rostral) on both sides
        side = spec.side
        d = (np.array(emergence_angles(b, side)) - np.array(emergence_angles(a, side))) / h
        assert d == pytest.approx((1.0, *ROW_SLOPES[spec.row]), abs=1e-6)
    # the left side is the mirror image of the right at every protraction
    k = len(both) // 2
    for th in (-0.3, 0.2):
        R = w.rotations(th)
        for i in range(k):
            assert np.abs(R[k + i] - mirror_rotation(R[i])).max() < 1e-14


def test_protraction_is_checked():
    w = Whisking([np.eye(3)], ["right"], [(0.0, 0.0)])
    for bad in (math.nan, [0.1, 0.2], math.inf):
        with pytest.raises(ParameterError, match="protraction"):
            w.rotations(bad)
    with pytest.raises(ParameterError, match="one of each"):
        Whisking([np.eye(3)], ["right", "left"], [(0.0, 0.0)])


def test_cosine_whisk():
    w = CosineWhisk(frequency=8.0, retraction=-0.3, protraction=0.5)
    assert w.angle(0.0) == pytest.approx(-0.3)
    assert w.angle(1 / 16) == pytest.approx(0.5)
    assert w.angle(1 / 32) == pytest.approx(0.1)
    for kwargs, key in (({"frequency": 0.0}, "frequency"), ({"frequency": math.nan}, "frequency"),
                        ({"retraction": 0.6, "protraction": 0.5}, "protraction"),
                        ({"start": "x"}, "start")):
        with pytest.raises(ParameterError, match=key):
            CosineWhisk(**kwargs)


def test_vectorized_quaternions_equal_the_scalar_ones():
    from vibrissa_ros.core.arrays.tracker import _quats_numpy

    rng = np.random.default_rng(3)
    q = rng.normal(size=(200, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    # and the ties of the four candidates: the identity, half turns about the axes and a
    # diagonal (the first of the tied candidates is taken)
    R = np.array([BasePose((0, 0, 0), tuple(v)).rotation for v in q]
                 + [np.eye(3), np.diag((1.0, -1.0, -1.0)), np.diag((-1.0, 1.0, -1.0)),
                    np.diag((-1.0, -1.0, 1.0)), np.array(((0.0, 1.0, 0.0), (1.0, 0.0, 0.0),
                                                          (0.0, 0.0, -1.0)))])
    want = np.array([quat_from_matrix(r) for r in R])
    # compiled where numba is (read-only input, as a tick's frames are): the same operations
    frozen = R.copy()
    frozen.flags.writeable = False
    assert np.array_equal(quats_from_matrices(frozen), want)
    assert np.abs(_quats_numpy(R) - want).max() < 1e-15


def test_whisking_key_of_the_array_file():
    spec = RIGHT["RC1"].to_dict()
    assert spec["whisking"] == list(ROW_SLOPES["C"])
    for bad in ([0.1], [0.1, math.nan], [0.0, 7.0], "x"):
        with pytest.raises(ParameterError, match="whisker RC1: whisking"):
            WhiskerArray.from_dict({"whiskers": [dict(spec, whisking=bad)]})
    plain = dict(spec)
    del plain["whisking"]
    assert WhiskerArray.from_dict({"whiskers": [plain]})[0].whisking == (0.0, 0.0)
    assert "whisking" not in WhiskerArray.from_dict({"whiskers": [plain]})[0].to_dict()


def _whisk_run(names, ticks, dt=1e-3):
    array = _subset(RIGHT, names)
    whisk = CosineWhisk(8.0)
    tracker = ArrayTracker(array, Scene3D((PEG,)), HEAD, whisk.angle(0.0))
    return array, whisk, tracker, [tracker.step(HEAD, whisk.angle(k * dt))
                                   for k in range(1, ticks)]


def test_every_whisker_equals_the_single_whisker_solver():
    names = ("RA1", "RB1", "RC1", "RD1", "RE1", "RC5", "RB2")
    array, whisk, tracker, steps = _whisk_run(names, 60)
    assert max(s.in_contact for s in steps) >= 3
    assert sum(s.solved.sum() for s in steps) < len(names) * len(steps)  # some were skipped
    scenes = [Scene3D((Cylinder((0.03 / L, -0.016 / L, 0.0), (0, 0, 1), 0.0015 / L, "peg"),))
              for L in (w.length for w in array)]
    for i, spec in enumerate(array):
        rod = array.rod(i)
        single = RodTracker(scenes[i], tracker.whisker_poses(HEAD, whisk.angle(0.0))[i],
                            shape=rod.shape)
        kinds = []
        for k, step in enumerate(steps, start=1):
            result = single.step(tracker.whisker_poses(HEAD, whisk.angle(k * 1e-3))[i])
            st = result.state
            kinds += [e.kind for e in result.events]
            fs, ms = rod.bending_stiffness / rod.length ** 2, rod.bending_stiffness / rod.length
            scale_f = max(1e-12, np.abs(step.force).max())
            assert step.contacts[i] == len(st.contacts)
            assert np.abs(step.force[i] - np.array(st.force) * fs).max() <= 1e-12 * scale_f
            assert np.abs(step.moment[i] - np.array(st.moment) * ms).max() <= (
                1e-12 * max(1e-15, np.abs(step.moment).max()))
            assert np.abs(step.tip[i] - np.array(st.tip) * rod.length).max() <= 1e-12 * rod.length
            if st.contacts:
                assert step.contact_s[i] == pytest.approx(st.contacts[0].s * rod.length,
                                                          abs=1e-12 * rod.length)
                assert step.contact_kind[i] == st.contacts[0].kind
                assert step.contact_obstacle[i] == "peg"
                Rb = step.base_rotation[i]
                assert np.abs(Rb @ step.force_base[i] - step.force[i]).max() <= 1e-14 * scale_f
        array_kinds = [e.kind for s in steps for e in s.events if e.whisker == spec.name]
        assert array_kinds == kinds, spec.name
    assert "whiskers in contact" in describe(steps[-1])


@pytest.mark.skipif(not whisking_module._jit.ENABLED,
                    reason="the compiled kernels are off (VIBRISSA_NO_JIT=1 or no numba)")
def test_the_compiled_frames_and_clearance_equal_the_numpy_code(monkeypatch):
    both = rat_array("both")
    pegs = Scene3D((PEG, Cylinder((-0.03, -0.016, 0.0), (0, 0, 1), 0.0015, "peg_left"),
                    Sphere((0.0, 0.0, 0.05), 0.01, "ball")))
    tracker = ArrayTracker(both, pegs, HEAD, -0.35)
    assert tracker._geometry is not None  # the compiled path
    rng = np.random.default_rng(7)
    outcomes = set()
    for _ in range(200):
        axis = rng.normal(size=3)
        head = BasePose(tuple(rng.normal(0.0, 0.004, 3)),
                        tuple(quat_about(axis / np.linalg.norm(axis), rng.normal(0.0, 0.2))))
        theta = rng.uniform(-0.6, 0.6, len(both))
        R, p = tracker._frames(head, theta)
        with monkeypatch.context() as m:
            m.setattr(whisking_module._jit, "ENABLED", False)
            R_ref = tracker.whisking.rotations(theta, head=head.rotation)
        assert np.abs(R - R_ref).max() <= 1e-15
        # the tick from the last frames to these: compiled, then numpy (no kernel geometry)
        step = rng.uniform(0.0, 0.02)
        tracker._R, tracker._p = R, p
        R2, p2 = tracker._frames(head, theta + step)
        got = tracker._clear(R2, p2)
        geometry, tracker._geometry = tracker._geometry, None
        want = tracker._clear(R2, p2)
        tracker._geometry = geometry
        assert np.array_equal(got, want)
        outcomes.update(got.tolist())
    assert outcomes == {True, False}


@pytest.mark.skipif(not whisking_module._jit.ENABLED,
                    reason="the compiled kernels are off (VIBRISSA_NO_JIT=1 or no numba)")
def test_the_compiled_rows_of_a_tick_equal_the_numpy_code():
    from vibrissa_ros.core.arrays import _jit as arrays_jit
    from vibrissa_ros.core.arrays.tracker import _collect_numpy

    rng = np.random.default_rng(3)
    k = 30
    R = np.array([BasePose((0, 0, 0), tuple(q / np.linalg.norm(q))).rotation
                  for q in rng.normal(size=(k, 4))])
    p, free_tip = rng.normal(size=(k, 3)), rng.normal(size=(k, 3))
    length, fs, ms = rng.uniform(0.01, 0.05, (3, k))
    moved = np.array([2, 3, 7, 20], dtype=np.int64)
    loaded = np.array([3, 20], dtype=np.int64)
    quats = rng.normal(size=(4, 4))
    quats /= np.linalg.norm(quats, axis=1)[:, None]
    mrows = np.concatenate((quats, rng.normal(size=(4, 6))), axis=1)
    lrows = rng.normal(size=(2, 11))
    for none in (False, True):
        args = (moved[:0], mrows[:0], loaded[:0], lrows[:0]) if none else (moved, mrows,
                                                                           loaded, lrows)
        got = arrays_jit.collect(R, p, free_tip, length, fs, ms, *args)
        want = _collect_numpy(R, p, free_tip, length, fs, ms, *args)
        for a, b in zip(got, want):
            assert a.shape == b.shape
            assert np.abs(a - b).max() <= 4e-16 * max(1.0, np.abs(b).max())
    assert np.array_equal(got[1][7], R[7]) and not got[3].any()
    # a moved whisker's frame is its quaternion's rotation matrix, as its pose's, to the bit
    got = arrays_jit.collect(R, p, free_tip, length, fs, ms, moved, mrows, loaded, lrows)
    for j, i in enumerate(moved):
        assert np.array_equal(got[1][i], quat_matrix(quats[j]))


def test_the_poses_kernel_gives_each_whiskers_base_pose_to_the_last_bit():
    from vibrissa_ros.core.arrays import _jit as arrays_jit

    if not arrays_jit.ENABLED:
        pytest.skip("the compiled kernels are off")
    tracker = ArrayTracker(RIGHT, None, HEAD)
    rng = np.random.default_rng(5)
    # head poses and protractions all round, and frames where each of the quaternion's four
    # candidates is the largest (a turn of nearly 180 deg about each axis, and none)
    frames = []
    for q in list(rng.normal(size=(40, 4))) + [(0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1),
                                               (1, 0, 0, 0)]:
        head = BasePose(tuple(rng.normal(size=3) * 0.01), tuple(q / np.linalg.norm(q)))
        frames.append(tracker._frames(head, tracker._protraction(rng.uniform(-1.5, 1.5, 30))))
    which = [0, 3, 4, 17, 29]
    for R, p in frames:
        poses = tracker._poses(R, p, which)
        assert sorted(poses) == which
        for i in which:
            want = tracker._pose(R, p, i)
            assert poses[i].position == want.position and poses[i].quaternion == want.quaternion
    assert tracker._poses(R, p, []) == {}


def test_free_whiskers_are_skipped_and_unloaded():
    far = Sphere((1.0, 1.0, 1.0), 0.01, "far")
    tracker = ArrayTracker(RIGHT, Scene3D((far,)), HEAD)
    step = tracker.step(BasePose((0.001, 0.0, 0.0), tuple(quat_about((0, 0, 1), 0.01))), 0.1)
    assert not step.solved.any() and step.in_contact == 0
    assert not step.force.any() and not step.moment_base.any()
    poses = tracker.whisker_poses(BasePose((0.001, 0.0, 0.0), tuple(quat_about((0, 0, 1), 0.01))),
                                  0.1)
    for i, spec in enumerate(RIGHT):
        rod = RIGHT.rod(i)
        free = RodTracker(Scene3D((Sphere((1 / rod.length,) * 3, 0.01 / rod.length),)), poses[i],
                          shape=rod.shape)
        assert np.abs(step.tip[i] - np.array(free.state.tip) * rod.length).max() < 1e-15
        assert np.abs(step.base_quaternion[i] - np.array(poses[i].quaternion)
                      * np.sign(poses[i].quaternion[0])).max() < 1e-15
    lines = tracker.centerlines(5)
    assert lines.shape == (len(RIGHT), 5, 3)
    assert np.abs(lines[:, -1] - step.tip).max() < 1e-15
    assert np.abs(lines[:, 0] - step.base_position).max() < 1e-15
    assert step.in_contact == 0 and "0 of 30 whiskers in contact" in describe(step)


@pytest.mark.parametrize("error, said", [
    (ConvergenceError("the step failed on purpose"), "the step failed on purpose"),
    # an error of the code itself (the randomized robustness run once met a KeyError): said
    # as such, and the other whiskers go on all the same
    (KeyError("on purpose"), "internal error (KeyError: 'on purpose')"),
])
def test_one_failing_whisker_does_not_stop_the_others(monkeypatch, error, said):
    names = ("RB1", "RC1", "RD1")
    array = _subset(RIGHT, names)
    whisk = CosineWhisk(8.0)
    tracker = ArrayTracker(array, Scene3D((PEG,)), HEAD, whisk.angle(0.0))
    steps = [tracker.step(HEAD, whisk.angle(k * 1e-3)) for k in range(1, 36)]
    assert steps[-1].contacts.all(), steps[-1].contacts
    broken = tracker.tracker("RC1")
    kept = broken.state

    def fail(pose):
        raise error

    monkeypatch.setattr(broken, "step", fail)
    step = tracker.step(HEAD, whisk.angle(36e-3))
    assert [e.whisker for e in step.errors] == ["RC1"]
    assert said in step.errors[0].message
    i = step.index("RC1")
    fs = array.rod(i).bending_stiffness / array.rod(i).length ** 2
    assert np.abs(step.force[i] - np.array(kept.force) * fs).max() == 0.0
    others = [step.index(n) for n in ("RB1", "RD1")]
    assert step.solved[others].all() and step.contacts[others].all()
    assert not np.allclose(step.force[others], steps[-1].force[others])
    # a Ctrl-C inside a compiled kernel (a SystemError caused by it) stops the tick

    def interrupt(pose):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise SystemError("returned a result with an exception set") from exc

    monkeypatch.setattr(broken, "step", interrupt)
    with pytest.raises(SystemError):
        tracker.step(HEAD, whisk.angle(36e-3))
    monkeypatch.undo()
    again = tracker.step(HEAD, whisk.angle(37e-3))
    assert not again.errors and again.contacts[i] == 1


def test_bad_input():
    tracker = ArrayTracker(_subset(RIGHT, ("RC1", "RC2")), Scene3D((PEG,)), HEAD,
                           -math.radians(20.0))
    with pytest.raises(ParameterError, match="protraction"):
        tracker.step(HEAD, [0.1, 0.2, 0.3])
    with pytest.raises(InvalidPoseError, match="head pose"):
        tracker.step((0.0, 0.0, 0.0))
    with pytest.raises(KeyError, match="RZ9"):
        tracker.state.index("RZ9")
    with pytest.raises(ParameterError, match="samples"):
        ArrayTracker(RIGHT, Scene3D((PEG,)), samples=3)
    with pytest.raises(ParameterError, match="WhiskerArray"):
        ArrayTracker([RIGHT["RC1"]], Scene3D((PEG,)))
    # a whisker placed inside an obstacle is named (here: the peg at rest protraction)
    with pytest.raises(InvalidPoseError, match="whisker RC1: .*inside peg"):
        ArrayTracker(_subset(RIGHT, ("RC2", "RC1")), Scene3D((PEG,)), HEAD)
    inside = Sphere(tuple(np.array(RIGHT["RC1"].base_position) + 0.004 * quat_dir("RC1")), 0.002)
    with pytest.raises(InvalidPoseError, match="whisker RC1"):
        ArrayTracker(_subset(RIGHT, ("RC1",)), Scene3D((inside,)), HEAD)


def quat_dir(name):
    """Return the whisker's base tangent in the head frame."""
    return BasePose((0, 0, 0), RIGHT[name].base_quaternion).rotation[:, 0]


def test_reset_and_centerlines_in_contact():
    names = ("RB1", "RC1", "RC5")
    array, whisk, tracker, steps = _whisk_run(names, 36)
    last = steps[-1]
    i = last.index("RC1")
    assert last.contacts[i] == 1
    lines = tracker.centerlines(41)
    single = tracker.tracker("RC1").state.centerline(41) * array["RC1"].length
    assert np.abs(lines[i] - single).max() == 0.0
    assert np.abs(lines[:, -1] - last.tip).max() < 1e-15
    # the pressed whiskers cannot be placed unloaded there (they would cut the peg): they keep
    # their state and are named; the free one is re-placed
    after = tracker.reset()
    assert {e.whisker for e in after.errors} == {n for n in names if last.contacts[last.index(n)]}
    assert all("inside peg" in e.message for e in after.errors)
    assert after.contacts[i] == 1 and np.array_equal(after.force[i], last.force[i])
    with pytest.raises(ParameterError, match="n = 1"):
        tracker.centerlines(1)


def test_whisking_in_the_air():
    for scene in (None, ()):
        tracker = ArrayTracker(_subset(RIGHT, ("RA0", "RE6")), scene, HEAD)
        step = tracker.step(HEAD, 0.3)
        assert not step.solved.any() and not step.force.any()
        R = tracker.whisking.rotations(0.3)
        assert np.abs(step.base_rotation - R).max() < 1e-15
    with pytest.raises(ParameterError, match="scene"):
        ArrayTracker(_subset(RIGHT, ("RA0",)), 3.0, HEAD)


def test_the_two_sides_whisk_as_mirror_images():
    """Twins of the two pads against mirrored pegs feel mirrored loads, tick by tick."""
    # the left C0 whisker's base quaternion (w >= 0 from its rotation matrix) changes sign at
    # ticks 56 and 70; the tracker follows such a pose with the sign nearest the last one's
    # (before, it could not reach the flipped target and called it a fold)
    both = rat_array("both")
    pegs = (Cylinder((0.03, -0.016, 0.0), (0, 0, 1), 0.0015, "peg_right"),
            Cylinder((-0.03, -0.016, 0.0), (0, 0, 1), 0.0015, "peg_left"))
    names = ("RC0", "RD1", "LC0", "LD1")
    whisk = CosineWhisk(8.0)
    tracker = ArrayTracker(_subset(both, names), Scene3D(pegs), HEAD, whisk.angle(0.0))
    flip = np.diag((1.0, 1.0, -1.0))  # a left base frame is its right twin's mirror, z flipped
    flips, events = [], []
    last = tracker.whisker_poses(HEAD, whisk.angle(0.0))[2].q
    for k in range(1, 90):
        q = tracker.whisker_poses(HEAD, whisk.angle(k * 1e-3))[2].q
        if q @ last < 0.0:
            flips.append(k)
        last = q
        step = tracker.step(HEAD, whisk.angle(k * 1e-3))
        assert not step.errors
        events += [(k, e.whisker[1:], e.kind) for e in step.events]
        for right, left in ((0, 2), (1, 3)):
            scale = max(np.abs(step.force_base[right]).max(), 1e-9)
            assert np.abs(flip @ step.force_base[right] - step.force_base[left]).max() <= (
                1e-9 * scale)
            assert np.abs(-flip @ step.moment_base[right] - step.moment_base[left]).max() <= (
                1e-9 * max(np.abs(step.moment_base[right]).max(), 1e-12))
    assert flips == [56, 70]  # its quaternion changes sign twice on the way, in contact
    assert [e for e in events if e[1] == "C0"][:2] == [(46, "C0", "touch")] * 2
    assert sorted(events) == sorted(events[0::2] + events[1::2])  # every event twice


def test_a_snap_that_lands_where_it_left_is_an_error_not_a_loop(monkeypatch):
    """A fold whose only destination is the lost equilibrium itself: an error, not a loop."""
    # the right D1 whisker slips off the peg at tick 44; here the unloaded whisker is made to cut
    # the peg (no free landing) and the swing-in to land back on the lost equilibrium: the step
    # fails (ConvergenceError), and the whisker, clear of the peg at the tick's pose, is re-placed
    # there (RodTracker's recover)
    whisk = CosineWhisk(8.0)
    tracker = ArrayTracker(_subset(RIGHT, ("RD1", "RC1")), Scene3D((PEG,)), HEAD,
                           whisk.angle(0.0))
    single = tracker.tracker("RD1")
    real_snap = RodTracker._snap

    def snap(self, *args, **kwargs):
        if self is not single:
            return real_snap(self, *args, **kwargs)
        self._free_gap = lambda *a, **k: (-1.0, 0, 0.5)
        self._swing_in = lambda pose: (self._modes, self._solved)
        try:
            return real_snap(self, *args, **kwargs)
        finally:
            del self._free_gap, self._swing_in

    monkeypatch.setattr(RodTracker, "_snap", snap)
    events = []
    for k in range(1, 46):
        step = tracker.step(HEAD, whisk.angle(k * 1e-3))
        assert not step.errors
        events += [(k, e) for e in step.events if e.whisker == "RD1"]
    k, reset = events[-1]
    assert k == 44 and reset.kind == "reset" and reset.contacts_before == 1
    assert "leads straight back to the lost one" in reset.reason
    assert step.contacts[step.index("RD1")] == 0


def test_a_trial_step_on_the_unstable_sibling_branch_is_not_a_loss_of_stability():
    """Short of a fold, Newton may land on the unstable branch: a shorter sub-step, no event."""
    # the right B2 whisker's tip slides off the peg every whisk cycle; at tick 33114 of the
    # built-in whisk (8 Hz, 1 kHz) a trial sub-step within 1e-12 of the fold converged to the
    # unstable sibling of the tip contact's branch: the determinant's sign changed, no event could
    # be located between the two branches and the whisker was reset (twice in a 60-s recording).
    # A free whisker has no history, so the replay from a free pose before the touch is exact
    whisk = CosineWhisk(8.0)
    tracker = ArrayTracker(_subset(RIGHT, ("RB2",)), Scene3D((PEG,)), HEAD,
                           whisk.angle(33084 / 1000.0))
    events = []
    for k in range(33085, 33117):
        step = tracker.step(HEAD, whisk.angle(k / 1000.0))
        assert not step.errors
        events += [(k, e.kind, e.reason) for e in step.events]
    assert [e[:2] for e in events] == [(33105, "touch"), (33114, "snap")]
    assert events[1][2] == "the equilibrium branch folds (no solution beyond this pose)"


def _rb2_to_its_first_snap(monkeypatch, extended: bool):
    """Return RB2's events (with its evaluations), tracker and folds located, to its snap."""
    found = []
    locate = RodTracker._locate_fold

    def spy(self, path, *args):
        fold = locate(self, path, *args) if extended else None
        if fold is not None:
            found.append((path, self._modes, fold))
        return fold

    monkeypatch.setattr(RodTracker, "_locate_fold", spy)
    whisk = CosineWhisk(8.0)
    array = ArrayTracker(_subset(RIGHT, ("RB2",)), Scene3D((PEG,)), HEAD, whisk.angle(0.0))
    single = RodTracker(array._scenes[0], array.whisker_poses(HEAD, whisk.angle(0.0))[0],
                        shape=RIGHT.rod(RIGHT.names.index("RB2")).shape)
    events = []
    for k in range(1, 27):
        before = single.solver.evaluations
        result = single.step(array.whisker_poses(HEAD, whisk.angle(k * 1e-3))[0])
        events += [(k, e, single.solver.evaluations - before) for e in result.events]
    return events, single, found


def test_a_fold_located_by_its_extended_system_is_where_the_sub_steps_find_it(monkeypatch):
    """The fold found at once (Newton on R = 0, g = 0) is the one closing in on it finds."""
    events, single, folds = _rb2_to_its_first_snap(monkeypatch, extended=True)
    with monkeypatch.context() as m:
        ref_events, ref_single, _ = _rb2_to_its_first_snap(m, extended=False)
    assert [(k, e.kind) for k, e, _ in events] == [(k, e.kind) for k, e, _ in ref_events]
    snap = [(k, e, n) for k, e, n in events if e.kind == "snap"]
    ref_snap = [(k, e, n) for k, e, n in ref_events if e.kind == "snap"]
    assert len(snap) == 1 and snap[0][0] == 23 and snap[0][1].reason == (
        "the equilibrium branch folds (no solution beyond this pose)")
    assert single.state.contacts == ref_single.state.contacts == ()
    # the same pose, to the sub-steps' few 1e-12 of the tick's path (the base turns by ~5e-3
    # rad in the tick): 9e-15 apart
    (_, e, n), (_, e_ref, n_ref) = snap[0], ref_snap[0]
    assert e.pose.position == e_ref.pose.position
    assert np.abs(np.subtract(e.pose.quaternion, e_ref.pose.quaternion)).max() < 3e-14
    # at a third of the work, or less, in the tick that snaps (45 evaluations against 139)
    assert n < 0.4 * n_ref
    # the point located: an equilibrium where the Jacobian is singular
    path, modes, (t_f, v_f) = folds[-1]
    res, J, _ = single.solver.residual(modes, v_f, path.pose(t_f))
    sv = np.linalg.svd(J, compute_uv=False)
    assert np.abs(res).max() < 1e-12 and sv[-1] < 1e-10 * sv[0] and sv[-2] > 1e-6 * sv[0]


def test_a_located_fold_is_lost_only_where_no_solution_follows_it(monkeypatch):
    """Just past the fold a solve must fail; where it does not, the sub-steps close in."""
    answers = []
    lost_beyond = RodTracker._lost_beyond

    def spy(self, path, t):
        answers.append(lost_beyond(self, path, t))
        return answers[-1]

    monkeypatch.setattr(RodTracker, "_lost_beyond", spy)
    events, single, folds = _rb2_to_its_first_snap(monkeypatch, extended=True)
    assert answers == [True] and len(folds) == 1
    # told that the branch goes on there: the sub-steps close in on the fold as before, and
    # find the same snap (the fold is looked for once per path and contacts)
    monkeypatch.setattr(RodTracker, "_lost_beyond", lambda self, path, t: False)
    forced, forced_single, forced_folds = _rb2_to_its_first_snap(monkeypatch, extended=True)
    assert [(k, e.kind) for k, e, _ in forced] == [(k, e.kind) for k, e, _ in events]
    snap = [e for _, e, _ in events if e.kind == "snap"][0]
    forced_snap = [e for _, e, _ in forced if e.kind == "snap"][0]
    assert np.abs(np.subtract(snap.pose.quaternion, forced_snap.pose.quaternion)).max() < 3e-14
    assert forced_single.state.contacts == single.state.contacts == ()
    # and where the branch goes on, the solve just past it converges: RC1 pressed on the peg
    from vibrissa_ros.core.rod3d.tracker import _Path
    _, pressed = _single_whisker_run("RC1", 40)
    assert pressed.state.contacts
    array = ArrayTracker(_subset(RIGHT, ("RC1",)), Scene3D((PEG,)), HEAD,
                         CosineWhisk(8.0).angle(0.0))
    ahead = array.whisker_poses(HEAD, CosineWhisk(8.0).angle(0.041))[0]
    assert lost_beyond(pressed, _Path(pressed.state.pose, ahead), 0.0) is False


def _single_whisker_run(name, ticks, states=None):
    """Return one right-pad whisker's events (with its evaluations) and tracker, alone."""
    whisk = CosineWhisk(8.0)
    array = ArrayTracker(_subset(RIGHT, (name,)), Scene3D((PEG,)), HEAD, whisk.angle(0.0))
    single = RodTracker(array._scenes[0], array.whisker_poses(HEAD, whisk.angle(0.0))[0],
                        shape=RIGHT.rod(RIGHT.names.index(name)).shape)
    events = []
    for k in range(1, ticks + 1):
        before = single.solver.evaluations
        result = single.step(array.whisker_poses(HEAD, whisk.angle(k * 1e-3))[0])
        events += [(k, e, single.solver.evaluations - before) for e in result.events]
        if states is not None:
            states.append(result.state)
    return events, single


def test_a_stream_step_beyond_the_sub_step_bound_is_taken_whole_where_newton_allows(
        monkeypatch):
    """RD0's steps that change the unknowns most are solved whole from the stream's guess."""
    from vibrissa_ros.core.rod3d import RodSolver

    # the plain step's kernel takes such steps whole as _whole_step does: the same states to
    # the last bit, at the same evaluations, with the kernel and on the general path alone
    kernel, kernel_states = [], []
    real = RodSolver.trusted_step

    def counted(self, *args, **kwargs):
        result = real(self, *args, **kwargs)
        kernel.append(result is not None and result.whole)
        return result

    monkeypatch.setattr(RodSolver, "trusted_step", counted)
    kernel_events, kernel_single = _single_whisker_run("RD0", 90, kernel_states)
    assert sum(kernel) >= 5
    monkeypatch.setattr(RodSolver, "trusted_step", lambda self, *a, **k: None)
    taken = []
    whole = RodTracker._whole_step

    def spy(self, path):
        solved = whole(self, path)
        taken.append(solved is not None)
        return solved

    monkeypatch.setattr(RodTracker, "_whole_step", spy)
    states = []
    events, single = _single_whisker_run("RD0", 90, states)
    assert kernel_single.solver.evaluations == single.solver.evaluations
    for got, want in zip(kernel_states, states):
        assert np.array_equal(got.force, want.force) and np.array_equal(got.tip, want.tip)
    monkeypatch.setattr(RodTracker, "_whole_step", lambda self, path: None)
    ref_states = []
    ref_events, ref_single = _single_whisker_run("RD0", 90, ref_states)
    assert sum(taken) >= 5 and not all(taken)  # (and where one Newton step is not enough, not)
    assert [(k, e.kind) for k, e, _ in events] == [(k, e.kind) for k, e, _ in ref_events] == [
        (43, "touch"), (83, "release")]
    # the same equilibria, tick by tick, at fewer evaluations
    for got, want in zip(states, ref_states):
        assert len(got.contacts) == len(want.contacts)
        assert np.abs(np.subtract(got.force, want.force)).max() <= 1e-12
        assert np.abs(np.subtract(got.tip, want.tip)).max() <= 1e-12
        for a, b in zip(got.contacts, want.contacts):
            assert abs(a.s - b.s) <= 1e-12
    assert single.solver.evaluations < ref_single.solver.evaluations


def test_a_release_located_on_the_bordered_system_is_where_brents_search_finds_it(monkeypatch):
    """Newton on R = 0, f = 0 finds the release Brent's search on f(t) finds, at less work."""
    located = []
    locate = RodTracker._locate_linear

    def spy(self, *args):
        found = locate(self, *args)
        located.append(found)
        return found

    monkeypatch.setattr(RodTracker, "_locate_linear", spy)
    events, single = _single_whisker_run("RC2", 21)
    monkeypatch.setattr(RodTracker, "_linear_event", lambda self, key: None)
    ref_events, ref_single = _single_whisker_run("RC2", 21)
    assert [(k, e.kind) for k, e, _ in events] == [(k, e.kind) for k, e, _ in ref_events] == [
        (15, "touch"), (20, "release")]
    assert len(located) == 1 and located[0] is not None
    (_, e, n), (_, e_ref, n_ref) = events[1], ref_events[1]
    assert np.abs(np.subtract(e.pose.quaternion, e_ref.pose.quaternion)).max() < 1e-15
    assert e.s == pytest.approx(e_ref.s, abs=1e-12)
    assert n < 0.5 * n_ref
    assert single.state.contacts == ref_single.state.contacts == ()
    # the contact's force at the located pose is zero to rounding
    t, solved = located[0]
    assert abs(solved.vec[-1]) < 1e-15


def _tilted_scene_run(name, first, last, frequency=7.0):
    """
    Return the events and errors of one whisker of the shipped pad, ticks first+1..last.

    The pad whisks (7 Hz unless told, -30 to +25 deg) while the head moves and turns slowly,
    against two tilted pegs and a ball: soaks of 4,000 and 6,000 ticks of both sides (7 and
    9.5 Hz) found the whiskers below failing there. Each replay starts from a tick where the
    whisker is free: a free whisker has no history, so the replay is exact.
    """
    from vibrissa_ros.scan.array_file import load_array

    array = load_array(Path(__file__).resolve().parents[1] / "config" / "rat_array.yaml")
    scene, head = SOAK_PEGS, soak_head
    whisk = CosineWhisk(frequency, -math.radians(30.0), math.radians(25.0))
    tracker = ArrayTracker(_subset(array, (name,)), scene, head(first / 1000.0),
                           whisk.angle(first / 1000.0))
    events, errors = [], []
    for k in range(first + 1, last + 1):
        step = tracker.step(head(k / 1000.0), whisk.angle(k / 1000.0))
        events += [(k, e.kind, e.contacts_after, e.reason) for e in step.events]
        errors += [(k, e.message) for e in step.errors]
    return events, errors


def test_a_snap_lands_past_the_fold_not_back_on_the_lost_branch():
    """The helper that swings the whisker in goes to just past the fold, where the branch ends."""
    # at the fold itself the lost branch still exists: the helper arrived on it, the step
    # snapped again where it left and the whisker failed for three ticks (RC2, tick 1023)
    events, errors = _tilted_scene_run("RC2", 1000, 1026)
    assert not errors
    assert [e[:3] for e in events] == [(1017, "touch", 1), (1021, "tangential", 1),
                                       (1023, "snap", 1), (1026, "release", 0)]
    # the tip passes the peg in the jump: said in the reason
    assert events[2][3].endswith("it swings out of its plane and lands on the other side of "
                                 "peg_right")


def test_a_snap_tries_more_turns_when_the_quarter_turns_about_y_find_nothing():
    """Both +-90 deg helpers meet folds of their own: a turn about z finds the landing (RA2)."""
    events, errors = _tilted_scene_run("RA2", 530, 555)
    assert not errors
    assert [e[:3] for e in events] == [(543, "touch", 1), (554, "snap", 1), (555, "release", 0)]


def test_a_contact_that_can_go_on_neither_at_the_side_nor_at_the_tip_slips_off():
    """A contact turned tip and at once side again slips off: a snap, not 64 events (LE1)."""
    events, errors = _tilted_scene_run("LE1", 1740, 1762)
    assert not errors
    assert [e[:3] for e in events] == [(1759, "touch", 1), (1759, "tangential", 1),
                                       (1761, "tip", 1), (1761, "snap", 1),
                                       (1762, "release", 0)]
    assert events[3][3].startswith("the contact reaches the tip and can go on neither")


def test_an_event_that_cannot_be_located_from_a_long_trial_step_gets_a_shorter_one():
    """A long trial step converged beyond a fold: shorter sub-steps find the fold (RC2)."""
    # the trial step's determinant had the other sign, but no solution between could be
    # followed from the step's start: 'could not be located', and the whisker was reset
    events, errors = _tilted_scene_run("RC2", 3590, 3627)
    assert not errors
    assert [e[:3] for e in events] == [(3596, "touch", 1), (3626, "snap", 0)]
    assert events[1][3] == "the equilibrium branch folds (no solution beyond this pose)"


def test_a_force_zero_by_construction_is_not_a_release_by_its_rounding():
    """A tip touch's force starts at -3e-16: not released at once, but where it crosses zero."""
    # the release was located at the touch itself, the free whisker then cut the thin peg and
    # touched again at the same pose: 64 events, and the whisker was reset (LE1, tick 5707)
    events, errors = _tilted_scene_run("LE1", 5690, 5708, frequency=9.5)
    assert not errors
    assert [e[:3] for e in events] == [(5707, "touch", 1), (5707, "release", 0)]
