"""The whisker array across processes: the same results as in one, and clear failures."""

import math
import os
import signal
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

from vibrissa_ros.core.arrays import WhiskerArray
from vibrissa_ros.core.arrays.partition import PartitionedArrayTracker
from vibrissa_ros.core.arrays.rat import rat_array
from vibrissa_ros.core.arrays.tracker import ArrayTracker
from vibrissa_ros.core.arrays.whisking import CosineWhisk
from vibrissa_ros.core.errors import ConvergenceError, InvalidPoseError, ParameterError
from vibrissa_ros.core.rod3d import BasePose, Scene3D, Sphere
from vibrissa_ros.scan.array_file import load_array

from rat_pad import HEAD, PEG, SOAK_PEGS, WHISK, soak_head


def _same(a, b):
    """Every field of two ArraySteps equal to the last bit (arrays read-only, same dtype)."""
    for f in fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.shape == y.shape, f.name
            assert np.array_equal(x, y), f.name
            assert not y.flags.writeable, f.name
        elif f.name == "head":
            assert np.array_equal(x.position, y.position) and np.array_equal(x.q, y.q)
        else:
            assert x == y, f.name


@pytest.mark.parametrize("workers", [2, 3])
def test_the_partitioned_array_equals_one_process_to_the_last_bit(workers):
    array = rat_array("right")
    one = ArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0))
    with PartitionedArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0),
                                 workers=workers) as many:
        assert many.workers == workers and len(many) == len(array)
        _same(one.state, many.state)
        events = 0
        for k in range(1, 121):  # RB1 and its column touch, slide and snap off
            theta = WHISK.angle(k * 1e-3)
            a, b = one.step(HEAD, theta), many.step(HEAD, theta)
            _same(a, b)
            events += len(a.events)
        assert events >= 4 and one.state.in_contact >= 1
        assert np.array_equal(one.centerlines(9), many.centerlines(9))
        _same(one.reset(), many.reset())
        theta = np.linspace(-0.2, 0.1, len(array))  # one angle per whisker
        _same(one.step(HEAD, theta), many.step(HEAD, theta))


def test_the_partitioned_array_in_the_soak_scene_with_a_moving_head():
    # bench/soak_array.py's pegs scene: both pads, the head wandering, at a coarse tolerance
    array = load_array(Path(__file__).resolve().parents[1] / "config" / "rat_array.yaml")
    whisk = CosineWhisk(8.0, -math.radians(30.0), math.radians(25.0))
    one = ArrayTracker(array, SOAK_PEGS, soak_head(0.0), whisk.angle(0.0),
                       points_tolerance=1e-8)
    with PartitionedArrayTracker(array, SOAK_PEGS, soak_head(0.0), whisk.angle(0.0),
                                 workers=2, points_tolerance=1e-8) as many:
        touched = 0
        for k in range(1, 81):
            a = one.step(soak_head(k * 1e-3), whisk.angle(k * 1e-3))
            _same(a, many.step(soak_head(k * 1e-3), whisk.angle(k * 1e-3)))
            touched = max(touched, a.in_contact)
        assert touched >= 2


def test_bad_arguments_are_refused_with_what_is_allowed():
    array = rat_array("right")
    for workers in (0, 31, 2.0, True, "2"):
        with pytest.raises(ParameterError, match="workers"):
            PartitionedArrayTracker(array, Scene3D((PEG,)), HEAD, 0.0, workers=workers)
    with PartitionedArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0)) as many:
        one = ArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0))
        for k in range(1, 40):  # RB1 in contact
            _same(one.step(HEAD, WHISK.angle(k * 1e-3)), many.step(HEAD, WHISK.angle(k * 1e-3)))
        assert many.state.in_contact
        for bad in (np.zeros(7), np.r_[math.nan, np.zeros(len(array) - 1)]):
            # refused before any part moves (a part whose angles are fine would have stepped)
            with pytest.raises(ParameterError) as want:
                one.step(HEAD, bad)
            with pytest.raises(ParameterError) as err:
                many.step(HEAD, bad)
            assert str(err.value) == str(want.value)
            assert "one finite angle [rad] or 30 of them" in str(err.value)
        _same(one.step(HEAD, WHISK.angle(0.04)), many.step(HEAD, WHISK.angle(0.04)))


def test_a_whisker_cutting_an_obstacle_at_the_start_is_named_from_its_worker():
    array = WhiskerArray(tuple(rat_array("right"))[:4])
    on_rb = Scene3D((Sphere(tuple(array[1].base_position), 0.0003, "bead"),))
    with pytest.raises(InvalidPoseError, match=f"^whisker {array.names[1]}:"):
        PartitionedArrayTracker(array, on_rb, HEAD, 0.0, workers=2)
    # two cut (one in this process's part, one in the worker's): the first is named, as by one
    beads = Scene3D((Sphere(tuple(array[1].base_position), 0.0003, "bead_1"),
                     Sphere(tuple(array[2].base_position), 0.0003, "bead_2")))
    with pytest.raises(InvalidPoseError) as want:
        ArrayTracker(array, beads, HEAD, 0.0)
    with pytest.raises(InvalidPoseError) as got:
        PartitionedArrayTracker(array, beads, HEAD, 0.0, workers=2)
    assert str(got.value) == str(want.value) and str(got.value).startswith("whisker RA1:")


def test_an_interrupted_tick_leaves_no_answer_to_the_next_call(monkeypatch):
    # a Ctrl-C in this process's part while the worker steps: the worker's answer to that
    # tick is skipped, and every later call gets its own answer
    array = rat_array("right")
    with PartitionedArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0),
                                 workers=2) as many:
        many.step(HEAD, WHISK.angle(1e-3))

        def ctrl_c(*args):
            raise KeyboardInterrupt

        monkeypatch.setattr(many._local, "step", ctrl_c)
        with pytest.raises(KeyboardInterrupt):
            many.step(HEAD, WHISK.angle(2e-3))
        monkeypatch.undo()
        for k in range(3, 8):
            step = many.step(HEAD, WHISK.angle(k * 1e-3))
            assert np.all(step.protraction == WHISK.angle(k * 1e-3))
        assert many.centerlines(5).shape == (len(array), 5, 3)


def test_a_worker_that_ends_makes_every_later_tick_fail_naming_its_whiskers():
    array = rat_array("right")
    many = PartitionedArrayTracker(array, Scene3D((PEG,)), BasePose((0.0, 0.0, 0.0)),
                                   WHISK.angle(0.0), workers=2)
    try:
        many.step(HEAD, WHISK.angle(1e-3))
        os.kill(many._procs[0].pid, signal.SIGKILL)
        many._procs[0].wait()
        for _ in range(2):
            with pytest.raises(ConvergenceError, match=r"worker process 1 \(whiskers RA1, "):
                many.step(HEAD, WHISK.angle(2e-3))
    finally:
        many.close()
    with pytest.raises(ConvergenceError, match="worker process 1"):
        many.step(HEAD, WHISK.angle(3e-3))


def test_the_workers_end_with_the_tracker_even_unclosed():
    import gc

    many = PartitionedArrayTracker(rat_array("right"), Scene3D((PEG,)), HEAD, WHISK.angle(0.0),
                                   workers=3)
    procs = list(many._procs)
    assert all(p.poll() is None for p in procs)
    del many
    gc.collect()
    assert all(p.poll() is not None for p in procs)


def test_restart_after_a_worker_ended_places_every_whisker_unloaded_at_the_pose_given():
    array = rat_array("right")
    many = PartitionedArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0), workers=2)
    try:
        for k in range(1, 30):  # RB1 in contact
            many.step(HEAD, WHISK.angle(k * 1e-3))
        contacts = many.state.contacts.copy()
        assert many.failed is None and contacts.any()
        os.kill(many._procs[0].pid, signal.SIGKILL)
        many._procs[0].wait()
        failure = r"whiskers RA1, .*; the array cannot go on: restart\(\) it"
        with pytest.raises(ConvergenceError, match=failure):
            many.step(HEAD, WHISK.angle(0.030))
        assert many.failed.startswith("the array's worker process 1 (whiskers RA1, ")
        # where a whisker would cut the peg unloaded, nothing changes: still failed
        pressed = WHISK.angle(0.037)
        with pytest.raises(InvalidPoseError, match="^whisker RB1:"):
            many.restart(HEAD, pressed)
        assert many.failed is not None and many._procs[0].poll() is not None
        with pytest.raises(ConvergenceError, match="worker process 1"):
            many.step(HEAD, WHISK.angle(0.031))
        # off the peg: every whisker unloaded there, as a new array placed there
        theta = WHISK.angle(0.0)
        old = list(many._procs)
        placed = many.restart(HEAD, theta, reason="back")
        assert many.failed is None and all(p.poll() is not None for p in old)
        fresh = ArrayTracker(array, Scene3D((PEG,)), HEAD, theta)
        _same(replace(fresh.state, events=placed.events), placed)
        want = [(n, "reset", int(c), 0, "back") for n, c in zip(array.names, contacts)]
        assert [(e.whisker, e.kind, e.contacts_before, e.contacts_after, e.reason)
                for e in placed.events] == want
        for k in range(1, 40):  # and it goes on as that array does
            theta = WHISK.angle(k * 1e-3)
            _same(fresh.step(HEAD, theta), many.step(HEAD, theta))
        assert fresh.state.in_contact
    finally:
        many.close()
    with pytest.raises(ConvergenceError, match="closed; .* start it again"):
        many.restart(HEAD, 0.0)


def test_restart_of_a_running_array_that_fails_leaves_it_running(monkeypatch):
    array = rat_array("right")
    with PartitionedArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0),
                                 workers=2) as many:
        one = ArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0))
        for k in range(1, 35):
            _same(one.step(HEAD, WHISK.angle(k * 1e-3)), many.step(HEAD, WHISK.angle(k * 1e-3)))
        procs = list(many._procs)
        with pytest.raises(InvalidPoseError, match="^whisker RB1:"):
            many.restart(HEAD, WHISK.angle(0.037))
        assert many.failed is None and many._procs == procs and procs[0].poll() is None
        for k in range(35, 45):
            _same(one.step(HEAD, WHISK.angle(k * 1e-3)), many.step(HEAD, WHISK.angle(k * 1e-3)))


def test_poses_clearance_and_trackers_as_one_process_gives_them():
    array = rat_array("right")
    one = ArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0))
    with PartitionedArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0),
                                 workers=3) as many:
        theta = np.linspace(-0.3, 0.2, len(array))
        for a, b in zip(one.whisker_poses(HEAD, theta), many.whisker_poses(HEAD, theta)):
            assert np.array_equal(a.position, b.position) and np.array_equal(a.q, b.q)
        step = one.step(HEAD, WHISK.angle(0.02))
        many.step(HEAD, WHISK.angle(0.02))
        R, p = step.base_rotation, step.base_position
        assert np.array_equal(one.clearance(R, p), many.clearance(R, p))
        with pytest.raises(ParameterError, match=r"need \(30, 3, 3\) and \(30, 3\)"):
            many.clearance(R[:3], p[:3])
        local = many.tracker(array.names[3])  # whisker 3: part 0 of 3
        assert local.pose == one.tracker(array.names[3]).pose
        with pytest.raises(ParameterError, match=f"whisker {array.names[4]} is stepped in the "
                                                 "array's worker process 1"):
            many.tracker(array.names[4])
        with pytest.raises(KeyError):
            many.tracker("ZZ9")


def test_a_worker_that_does_not_start_leaves_the_array_as_it_was(monkeypatch):
    from vibrissa_ros.core.arrays import partition

    array = rat_array("right")
    with PartitionedArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0),
                                 workers=2) as many:
        one = ArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0))
        for k in range(1, 30):
            _same(one.step(HEAD, WHISK.angle(k * 1e-3)), many.step(HEAD, WHISK.angle(k * 1e-3)))
        monkeypatch.setattr(partition, "_WORKER_MAIN", "import sys; sys.exit(3)")
        with pytest.raises(ConvergenceError, match=r"ended \(exit code 3\) while it was being "
                                                   "started; nothing was started$"):
            many.restart(HEAD, WHISK.angle(0.0))
        assert many.failed is None
        for k in range(30, 35):  # the running array goes on
            _same(one.step(HEAD, WHISK.angle(k * 1e-3)), many.step(HEAD, WHISK.angle(k * 1e-3)))
    # nor is an array that cannot start its workers told to restart()
    with pytest.raises(ConvergenceError, match="while it was being started; nothing was"):
        PartitionedArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0), workers=2)


def test_an_interrupt_while_restart_ends_the_old_workers_leaves_the_new_array_whole(
        monkeypatch):
    from vibrissa_ros.core.arrays import partition

    array = rat_array("right")
    with PartitionedArrayTracker(array, Scene3D((PEG,)), HEAD, WHISK.angle(0.0),
                                 workers=2) as many:
        for k in range(1, 30):
            many.step(HEAD, WHISK.angle(k * 1e-3))
        old = list(many._procs)
        real = partition._end_workers

        def ctrl_c(conns, procs):
            raise KeyboardInterrupt

        monkeypatch.setattr(partition, "_end_workers", ctrl_c)
        theta = WHISK.angle(0.0)
        try:
            with pytest.raises(KeyboardInterrupt):
                many.restart(HEAD, theta)
        finally:
            monkeypatch.setattr(partition, "_end_workers", real)
            for proc in old:
                proc.kill()
                proc.wait()
        assert many.failed is None and many._procs[0] not in old
        fresh = ArrayTracker(array, Scene3D((PEG,)), HEAD, theta)
        _same(fresh.state, replace(many.state, events=()))
        for k in range(1, 40):
            _same(fresh.step(HEAD, WHISK.angle(k * 1e-3)), many.step(HEAD, WHISK.angle(k * 1e-3)))
