"""
The array under any history: every whisker as its own single-whisker tracker gives it.

Hypothesis draws a few of the rat's right whiskers, an obstacle within their reach (a vertical
peg, a tilted cylinder, a ball or a wall) and a history of ticks: the head moved and turned a
little, the protraction changed for all and for each whisker, far jumps of both, and resets.
At every tick the array (its clearance test skipping the whiskers it certifies free, and placing
them again when they are stepped) must give what a RodTracker per whisker gives, stepped to
every tick's pose of that whisker (:meth:`ArrayTracker.whisker_poses`):

* a whisker whose tracker refuses the step (a VibrissaError) is listed in the tick's errors with
  that message, and the array's other whiskers go on;
* every other whisker's contacts, contact kind, base force and moment (SI) and tip equal the
  single tracker's to 1e-12 relative, and its events are the same, in the same order;
* ``reset()`` places every whisker as the single tracker's ``reset`` at the last tick's pose.

The settings are derandomized (no example database); the explicit examples make sure that
every run holds touches, snaps and releases whatever the draws.
"""

import math
from collections import Counter

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

from vibrissa_ros.core.arrays import WhiskerArray
from vibrissa_ros.core.arrays.rat import rat_array
from vibrissa_ros.core.arrays.tracker import ArrayTracker
from vibrissa_ros.core.errors import InvalidPoseError, VibrissaError
from vibrissa_ros.core.rod3d import BasePose, Cylinder, Plane, RodTracker, Scene3D, Sphere
from vibrissa_ros.core.rod3d.pose import quat_about, quat_multiply
from vibrissa_ros.core.units import convert_lengths

RIGHT = rat_array("right")
#: whiskers of every row and of the columns that reach the obstacles below
NAMES = ("RA1", "RB1", "RC1", "RD1", "RE1", "RB2", "RC2", "RC0", "RD0", "RB0")
TALLY: Counter = Counter()

unit = st.floats(-1.0, 1.0)


@st.composite
def obstacles(draw):
    """Draw one obstacle [m] where the whiskers above meet it while whisking."""
    kind = draw(st.sampled_from(["peg", "peg", "cylinder", "ball", "wall"]))
    u, v, w = draw(unit), draw(unit), draw(unit)
    x, y = 0.028 + 0.012 * u, -0.016 + 0.008 * v
    if kind == "peg":
        return Cylinder((x, y, 0.0), (0, 0, 1), draw(st.floats(0.0008, 0.003)), "peg")
    if kind == "cylinder":
        axis = (0.4 * draw(unit), 0.4 * draw(unit), 1.0)
        return Cylinder((x, y, 0.0), axis, draw(st.floats(0.001, 0.004)), "cylinder")
    if kind == "ball":
        return Sphere((x, y, 0.006 * w), draw(st.floats(0.002, 0.006)), "ball")
    # a wall across the pad's rostral side, facing it
    return Plane((x + 0.01, y, 0.0), (-1.0, 0.3 * v, 0.2 * w), "wall")


@st.composite
def ticks(draw):
    """Draw one tick: a small move (head and protraction), a far jump, or a reset."""
    kind = draw(st.sampled_from(["move"] * 8 + ["jump", "reset"]))
    if kind == "reset":
        return ("reset",)
    scale = 1.0 if kind == "move" else 6.0
    shift = np.array([draw(unit), draw(unit), draw(unit)]) * 4e-4 * scale
    axis = np.array([draw(unit), draw(unit), 1.0])
    turn = math.radians(1.0) * scale * draw(unit)
    dtheta = math.radians(1.5 + 3.5 * draw(unit)) * scale  # (a sweep forward, on average)
    spread = math.radians(0.5) * draw(unit)
    return ("move", shift, axis, turn, dtheta, spread)


def _apply(head, theta, tick):
    _, shift, axis, turn, dtheta, spread = tick
    q = quat_multiply(quat_about(axis / np.linalg.norm(axis), turn), head.q)
    head = BasePose(tuple(head.p + shift), tuple(q / np.linalg.norm(q)))
    theta = np.clip(theta + dtheta + spread * np.linspace(-1.0, 1.0, len(theta)),
                    math.radians(-40.0), math.radians(35.0))
    return head, theta


def _singles(array, scene, poses):
    out = []
    for i, pose in enumerate(poses):
        rod = array.rod(i)
        own = Scene3D.from_dict(convert_lengths(scene.to_dict(), rod.length))
        out.append(RodTracker(own, pose, shape=rod.shape))
    return out


def _compare(array, step, states, errors):
    """Compare a tick's rows with the single trackers' states and refusals (name: message)."""
    got = {e.whisker: e.message for e in step.errors}
    assert set(got) == set(errors), (got, errors)
    for name, message in errors.items():
        assert got[name] == message
    scale_f = max(1e-12, float(np.abs(step.force).max()))
    scale_m = max(1e-15, float(np.abs(step.moment).max()))
    for i, st_ in enumerate(states):
        rod = array.rod(i)
        fs, ms = rod.bending_stiffness / rod.length ** 2, rod.bending_stiffness / rod.length
        assert step.contacts[i] == len(st_.contacts)
        assert np.abs(step.force[i] - np.array(st_.force) * fs).max() <= 1e-12 * scale_f
        assert np.abs(step.moment[i] - np.array(st_.moment) * ms).max() <= 1e-12 * scale_m
        assert np.abs(step.tip[i] - np.array(st_.tip) * rod.length).max() <= (
            1e-12 * rod.length)
        if st_.contacts:
            assert step.contact_kind[i] == st_.contacts[0].kind
            assert step.contact_s[i] == pytest.approx(st_.contacts[0].s * rod.length,
                                                      abs=1e-12 * rod.length)
    assert np.all(np.isfinite(step.force)) and np.all(np.isfinite(step.moment))


SETTINGS = settings(derandomize=True, database=None, deadline=None, max_examples=100,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.filter_too_much])
_SWEEP = [("move", np.zeros(3), np.array([0.0, 0.0, 1.0]), 0.0, math.radians(3.0), 0.0)] * 18


@SETTINGS
@example(names=("RB1", "RC1", "RD1", "RC2"),
         obstacle=Cylinder((0.03, -0.016, 0.0), (0, 0, 1), 0.0015, "peg"),
         history=_SWEEP[:9] + [("reset",)] + _SWEEP[9:], start=-25.0)
@example(names=("RA1", "RB1", "RB2"),
         obstacle=Sphere((0.027, -0.018, 0.0), 0.004, "ball"),
         history=_SWEEP + [(t[0], t[1], t[2], t[3], -t[4], t[5]) for t in _SWEEP],
         start=-25.0)
@example(names=("RA1", "RB1", "RB0"),  # RB0, skipped and placed, then refused (a line contact)
         obstacle=Plane((0.038, -0.021, 0.0), (-0.9828721869343219, -0.18428853505018536, 0.0),
                        "wall"),
         history=[(t[0], t[1], t[2], t[3], d, t[5])
                  for t, d in zip(_SWEEP, (0.026179938779914945,) * 3 + (
                      -0.004363323129985824, 0.5235987755982988, 0.026179938779914945))],
         start=-12.0)
@given(names=st.lists(st.sampled_from(NAMES), min_size=2, max_size=4, unique=True).map(tuple),
       obstacle=obstacles(), history=st.lists(ticks(), min_size=4, max_size=20),
       start=st.floats(-35.0, 0.0))
def test_the_array_equals_a_single_tracker_per_whisker_under_any_history(
        names, obstacle, history, start):
    array = WhiskerArray(tuple(RIGHT[n] for n in names), "drawn")
    scene = Scene3D((obstacle,))
    head = BasePose((0.0, 0.0, 0.0))
    theta = np.full(len(names), math.radians(start))
    try:
        tracker = ArrayTracker(array, scene, head, theta)
    except InvalidPoseError:
        TALLY["unplaceable start"] += 1
        assume(False)
    singles = _singles(array, scene, tracker.whisker_poses(head, theta))
    last = tracker.whisker_poses(head, theta)
    for tick in history:
        if tick[0] != "reset":
            head, theta = _apply(head, theta, tick)
            last = tracker.whisker_poses(head, theta)
        errors, kinds = {}, {}
        for name, single, pose in zip(names, singles, last):
            try:
                result = single.reset(pose) if tick[0] == "reset" else single.step(pose)
            except VibrissaError as exc:
                errors[name] = str(exc)
                continue
            kinds[name] = [e.kind for e in result.events]
        step = tracker.reset() if tick[0] == "reset" else tracker.step(head, theta)
        _compare(array, step, [s.state for s in singles], errors)
        for name in names:
            assert [e.kind for e in step.events if e.whisker == name] == kinds.get(name, [])
        TALLY["ticks"] += 1
        TALLY["refused"] += len(errors)
        TALLY["skipped"] += int(np.count_nonzero(~step.solved))
        for e in step.events:
            TALLY[e.kind] += 1


def test_the_property_run_met_contacts_and_events():
    """What the histories above met (a run that never touches anything would prove little)."""
    print(dict(TALLY))
    assert TALLY["ticks"] > 200 and TALLY["touch"] >= 5 and TALLY["reset"] >= 5
    assert TALLY["skipped"] > 0 and (TALLY["snap"] + TALLY["release"]) >= 3
