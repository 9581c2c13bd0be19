"""
History does not matter: whole turns, refusals, jumps and resets leave no trace.

The recovery rule (doc/mechanics/decisions.md, "Recovery"): a step that cannot be
followed re-places the whisker unloaded at the new pose when it is free there (an event
``reset``), else it is refused and the state kept. A free whisker carries nothing but its pose,
and every pose is taken with its heading in (-pi, pi]. So, in every obstacle family:

* after ANY history, a step to a free pose and a clean sweep from there give exactly (==) the
  results a new tracker placed at that pose gives on the sweep;
* every result is invariant under heading + 2 pi k, k chosen anew for every pose.

Plus the reproductions of the issue ("the whisker gets stuck, and a whisker that has turned
around is not the same whisker") as plain regression tests.
"""

import math
import random
import time
from collections import Counter

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vibrissa_ros.core import (
    Catenary,
    Circle,
    FootPose,
    GeneralWhiskerModel,
    InvalidPoseError,
    ModelAssumptionError,
    Parabola,
    Peg,
    Phase,
    PlacedProfile,
    QuasistaticTracker,
    TrackerOptions,
    VibrissaError,
    WhiskerShape,
)
from vibrissa_ros.core.exact.inverse import estimate_contact
from vibrissa_ros.core.general.inverse import estimate_contact_general
from vibrissa_ros.core.scenes.scene import PegObstacle, ProfileObstacle
from vibrissa_ros.core.scenes.tracker import SceneTracker

HALF_PI = math.pi / 2
TWO_PI = 2 * math.pi
#: a pose where no obstacle of any family is within the whisker's reach (one length)
FREE = FootPose(3.0, 0.0, HALF_PI)
GENERAL_SHAPE = WhiskerShape(0.4, 0.8, 0.0)
FAMILIES = {
    "catenary": lambda pose: QuasistaticTracker(Catenary(0.5, 0.6, scan_checks=False), pose),
    "placed_circle": lambda pose: QuasistaticTracker(
        PlacedProfile(Circle(0.5, 0.6, scan_checks=False), 0.1, 0.0, 0.3), pose),
    "peg": lambda pose: QuasistaticTracker(Peg(0.0, 1.05, 0.15), pose),
    "point_peg": lambda pose: QuasistaticTracker(
        Peg(0.0137, 0.7, 0.0), pose, model=GeneralWhiskerModel(WhiskerShape(0.3, 0.0, 0.0))),
    # (against a peg: a curved whisker's touch search along a convex profile samples the path
    # every 1e-3 L, which makes the long steps of these histories cost seconds each)
    "general": lambda pose: QuasistaticTracker(
        Peg(0.0137, 0.9, 0.1), pose, model=GeneralWhiskerModel(GENERAL_SHAPE)),
    "scene": lambda pose: SceneTracker(
        [ProfileObstacle("catenary", {"p0": 0.5, "c": 0.6}), PegObstacle(-0.7, 0.75, 0.1)], pose,
        friction=[0.3, 0.2]),
}
#: the numeric families cost ~50 ms a contact step: shorter histories and fewer of them
SLOW = {"point_peg", "general", "scene"}
#: a clean sweep under the obstacles: a new tracker placed at FREE answers every pose
SWEEP = tuple(FootPose(round(1.6 - 0.1 * i, 10), 0.0, HALF_PI) for i in range(33))
SLOW_SWEEP = tuple(FootPose(round(1.2 - 0.1 * i, 10), 0.0, HALF_PI) for i in range(25))
#: what the property tests met (printed by the last test of this file)
TALLY: Counter = Counter()


def sweep_of(family):
    return SLOW_SWEEP if family in SLOW else SWEEP


_FRESH = {}


def fresh_results(family):
    """Return a new tracker's results on the family's clean sweep from FREE (computed once)."""
    if family not in _FRESH:
        tracker = FAMILIES[family](FREE)
        _FRESH[family] = [tracker.step(pose) for pose in sweep_of(family)]
    return _FRESH[family]


# -- histories --------------------------------------------------------------------------------
angle = st.floats(-math.pi, math.pi, allow_nan=False)
move = st.one_of(
    # a random valid pose of the issue's walk (x in [-2, 2], y in [-1, 0.5], any heading)
    st.tuples(st.just("pose"), st.floats(-2.0, 2.0), st.floats(-1.0, 0.5), angle),
    # a small step from the last pose
    st.tuples(st.just("nudge"), st.floats(-0.2, 0.2), st.floats(-0.1, 0.1),
              st.floats(-0.5, 0.5)),
    # the same pose after whole turns (a robot turning in place)
    st.tuples(st.just("turn"), st.integers(-20, 20), st.just(0.0), st.just(0.0)),
    # a jump of the pose stream, anywhere
    st.tuples(st.just("jump"), st.floats(-50.0, 50.0), st.floats(-50.0, 50.0),
              st.floats(-100.0, 100.0)),
    # a pose with the foot in or next to the obstacles (mostly refused)
    st.tuples(st.just("into"), st.floats(-0.3, 0.3), st.floats(0.4, 1.2), angle),
    # an explicit reset (refused where the whisker would cut an obstacle)
    st.tuples(st.just("reset"), st.floats(-2.0, 2.0), st.floats(-1.0, 0.5), angle),
)


def run_history(tracker, moves):
    """Apply the moves; count what happened (a refusal keeps the state, as promised)."""
    last = tracker.pose
    for kind, a, b, c in moves:
        if kind == "nudge":
            target = FootPose(last.x + a, last.y + b, last.heading + c)
        elif kind == "turn":
            target = FootPose(last.x, last.y, last.heading + TWO_PI * a)
        else:
            target = FootPose(a, b, c)
        before = tracker.state
        try:
            result = tracker.reset(target) if kind == "reset" else tracker.step(target)
        except VibrissaError:
            TALLY["refusals"] += 1
            assert tracker.state is before
            continue
        TALLY["steps"] += 1
        TALLY["resets"] += sum(1 for e in result.events if e.kind == "reset")
        last = target
        assert -math.pi < tracker.pose.heading <= math.pi


def check_history_is_forgotten(family, moves):
    tracker = FAMILIES[family](FootPose(2.0, 0.0, HALF_PI))
    run_history(tracker, moves)
    TALLY["histories"] += 1
    result = tracker.step(FREE)
    TALLY["resets"] += sum(1 for e in result.events if e.kind == "reset")
    assert result.state.pose == FREE and not getattr(result.state, "contacts", ())
    assert result.state.phase == Phase.FREE
    for pose, want in zip(sweep_of(family), fresh_results(family)):
        got = tracker.step(pose)
        assert got.state == want.state, pose
        assert got.events == want.events, pose


@pytest.mark.parametrize("family", [f for f in FAMILIES if f not in SLOW])
@settings(max_examples=25, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(moves=st.lists(move, min_size=1, max_size=12))
def test_after_any_history_a_free_pose_gives_a_fresh_trackers_sweep(family, moves):
    check_history_is_forgotten(family, moves)


@pytest.mark.parametrize("family", sorted(SLOW))
@settings(max_examples=6, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(moves=st.lists(move, min_size=1, max_size=5))
def test_after_any_history_a_free_pose_gives_a_fresh_trackers_sweep_numeric(family, moves):
    check_history_is_forgotten(family, moves)


# -- invariance under whole turns -------------------------------------------------------------
def _close(a, b, tol=1e-9):
    if a is None or b is None:
        return a is b
    if isinstance(a, (tuple, list)):
        return len(a) == len(b) and all(_close(x, y, tol) for x, y in zip(a, b))
    if isinstance(a, float) or isinstance(b, float):
        return a == pytest.approx(b, rel=tol, abs=tol)
    return a == b


STATE_FIELDS = ("phase", "side", "alpha", "s1", "tip_slope", "f", "fx", "fy", "m0", "contact",
                "tip")
SCENE_FIELDS = ("fx", "fy", "m0", "tip", "tip_slope")


def assert_same_result(got, want):
    """Every field of the state and its events, to rounding (the input turned by 2 pi k)."""
    assert _close(got.state.pose.x, want.state.pose.x) and _close(got.state.pose.y,
                                                                  want.state.pose.y)
    assert _close(got.state.pose.heading, want.state.pose.heading)
    if hasattr(want.state, "contacts"):
        for name in SCENE_FIELDS:
            assert _close(getattr(got.state, name), getattr(want.state, name)), name
        assert len(got.state.contacts) == len(want.state.contacts)
        for c, d in zip(got.state.contacts, want.state.contacts):
            assert (c.obstacle, c.kind, c.state) == (d.obstacle, d.kind, d.state)
            for name in ("s", "x", "y", "fx", "fy", "N", "T", "u"):
                assert _close(getattr(c, name), getattr(d, name)), name
    else:
        for name in STATE_FIELDS:
            assert _close(getattr(got.state, name), getattr(want.state, name)), name
    assert [e.kind for e in got.events] == [e.kind for e in want.events]
    for e, f in zip(got.events, want.events):
        assert _close((e.pose.x, e.pose.y, e.pose.heading), (f.pose.x, f.pose.y, f.pose.heading),
                      1e-8)
        for name in ("from_phase", "to_phase", "obstacle", "contact_kind"):
            assert getattr(e, name, None) == getattr(f, name, None)
        for name in ("alpha", "s"):
            assert _close(getattr(e, name, None), getattr(f, name, None), 1e-8), name


def turned(pose, k):
    return FootPose(pose.x, pose.y, pose.heading + TWO_PI * k)


@pytest.mark.parametrize("family", list(FAMILIES))
@settings(max_examples=3, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_every_result_is_invariant_under_whole_turns(family, data):
    sweep = sweep_of(family)
    turns = data.draw(st.lists(st.integers(-30, 30), min_size=len(sweep) + 1,
                               max_size=len(sweep) + 1))
    tracker = FAMILIES[family](turned(FREE, turns[0]))
    assert _close((tracker.pose.x, tracker.pose.y, tracker.pose.heading),
                  (FREE.x, FREE.y, FREE.heading), 1e-12)
    for pose, k, want in zip(sweep, turns[1:], fresh_results(family)):
        assert_same_result(tracker.step(turned(pose, k)), want)
    TALLY["turned sweeps"] += 1


def test_the_inverse_is_invariant_under_whole_turns():
    contacts = [r.state for r in fresh_results("catenary") if r.state.phase != Phase.FREE]
    assert contacts
    for state in contacts:
        want = estimate_contact(state.pose, state.fx, state.fy, state.m0)
        for k in (-8, 3, 40):
            got = estimate_contact(turned(state.pose, k), state.fx, state.fy, state.m0)
            assert got.pose.heading == pytest.approx(want.pose.heading, abs=1e-12)
            assert got.phase == want.phase and got.side == want.side
            assert _close((got.contact, got.alpha, got.s1, got.delta),
                          (want.contact, want.alpha, want.s1, want.delta))
    general = [r.state for r in fresh_results("general") if r.state.phase != Phase.FREE]
    for state in general[:3]:
        want = estimate_contact_general(state.pose, state.fx, state.fy, state.m0, GENERAL_SHAPE)
        got = estimate_contact_general(turned(state.pose, -5), state.fx, state.fy, state.m0,
                                       GENERAL_SHAPE)
        assert got.pose.heading == pytest.approx(want.pose.heading, abs=1e-12)
        assert _close((got.contact, got.alpha, got.s1), (want.contact, want.alpha, want.s1),
                      1e-8)


# -- the rule, directly -----------------------------------------------------------------------
def test_a_step_that_cannot_be_followed_to_a_free_pose_resets_there():
    """
    The whisker's side would sweep into the catenary before its tip: not modelled.

    The target is free: the whisker is placed there, one event reset says why.
    """
    prof = Catenary(0.5, 0.6, scan_checks=False)
    start, target = FootPose(0.14, 0.27, 0.86), FootPose(0.93, 0.05, -3.02)
    strict = QuasistaticTracker(prof, start, options=TrackerOptions(recover=False))
    with pytest.raises(ModelAssumptionError, match="would meet the obstacle") as refusal:
        strict.step(target)
    assert strict.pose == start
    tracker = QuasistaticTracker(prof, start)
    result = tracker.step(target)
    assert [(e.kind, e.from_phase, e.to_phase) for e in result.events] == [
        ("reset", Phase.FREE, Phase.FREE)]
    assert result.events[0].reason == str(refusal.value)
    assert result.events[0].pose == target
    assert result.state == QuasistaticTracker(prof, target).state


def test_a_step_that_cannot_be_followed_to_a_pose_inside_the_obstacle_is_refused():
    tracker = QuasistaticTracker(Parabola(0.3), FootPose(2.0, 0.0, HALF_PI))
    tracker.step(FootPose(0.0, 0.0, HALF_PI))
    before = tracker.state
    assert before.phase != Phase.FREE
    with pytest.raises(ModelAssumptionError, match="slid down to the whisker's foot"):
        tracker.step(FootPose(0.0, 0.35, HALF_PI))  # the foot driven into the obstacle
    assert tracker.state is before


def test_reset_on_request_and_its_refusal():
    prof = Catenary(0.5, 0.6, scan_checks=False)
    tracker = QuasistaticTracker(prof, FootPose(2.0, 0.0, HALF_PI))
    tracker.step(FootPose(0.3, 0.0, HALF_PI))
    in_contact = tracker.state
    with pytest.raises(InvalidPoseError, match="reset pose"):
        tracker.reset()  # here the unloaded whisker would cut the obstacle
    assert tracker.state is in_contact
    result = tracker.reset(FootPose(1.5, 0.0, HALF_PI))
    assert [(e.kind, e.from_phase) for e in result.events] == [("reset", in_contact.phase)]
    assert result.state == QuasistaticTracker(prof, FootPose(1.5, 0.0, HALF_PI)).state
    scene = FAMILIES["scene"](FootPose(2.0, 0.0, HALF_PI))
    scene.step(FootPose(0.3, 0.0, HALF_PI))
    assert scene.state.contacts
    with pytest.raises(InvalidPoseError, match="reset pose"):
        scene.reset()
    result = scene.reset(FootPose(1.5, 0.0, HALF_PI))
    assert [e.kind for e in result.events] == ["reset"] and not result.state.contacts
    assert result.state == FAMILIES["scene"](FootPose(1.5, 0.0, HALF_PI)).state


def test_a_half_turn_goes_the_way_of_the_plain_difference():
    """
    Exactly half a turn: the heading runs linearly between the two headings in (-pi, pi].

    So between -pi/2 and pi/2 (either way) it passes 0 (along +x), never pi. (Whole turns added to
    the input round its heading by ~1e-15, which decides such a tie either way.)
    """
    for peg_x, swept in ((0.7, True), (-0.7, False)):
        for a, b in ((-HALF_PI, HALF_PI), (HALF_PI, -HALF_PI)):
            tracker = QuasistaticTracker(Peg(peg_x, 0.0, 0.1), FootPose(0.0, 0.0, a))
            result = tracker.step(FootPose(0.0, 0.0, b))
            assert bool(result.events) is swept, (peg_x, a, b)
            assert tracker.pose.heading == pytest.approx(math.remainder(b, TWO_PI))


# -- the issue's reproductions ------------------------------------------------------------------
ISSUE_PROFILE = Catenary(0.5, 0.6, scan_checks=False)
ISSUE_SWEEP = [FootPose(2 - 0.02 * i, 0.0, HALF_PI) for i in range(200)]


def issue_walk(n):
    """Return the issue's random walk: n random valid poses, seed 7 of Python's random."""
    rng = random.Random(7)
    return [FootPose(rng.uniform(-2, 2), rng.uniform(-1, 0.5), rng.uniform(0, TWO_PI))
            for _ in range(n)]


@pytest.fixture(scope="module")
def issue_fresh():
    tracker = QuasistaticTracker(ISSUE_PROFILE, FootPose(2.0, 0.0, HALF_PI))
    return [tracker.step(pose) for pose in ISSUE_SWEEP]


def _answers(tracker, sweep):
    out = []
    for pose in sweep:
        try:
            out.append(tracker.step(pose))
        except VibrissaError:
            out.append(None)
    return out


def test_issue_eight_turns_are_forgotten(issue_fresh):
    """
    Eight whole turns in the first heading leave no trace.

    Placed at pi/2 + 16 pi it used to answer 64 poses and refuse the rest ("the contact would
    move to profile slope 51.26 rad").
    """
    tracker = QuasistaticTracker(ISSUE_PROFILE, FootPose(2.0, 0.0, HALF_PI + 16 * math.pi))
    got = _answers(tracker, ISSUE_SWEEP)
    assert all(r is not None for r in got)
    for a, b in zip(got, issue_fresh):
        assert_same_result(a, b)


@pytest.mark.parametrize("n", [29, 300])
def test_issue_random_walk_then_the_sweep(n, issue_fresh):
    """
    After the issue's random walk, the sweep is answered as by a new tracker.

    After 29 poses of the walk the sweep's first 137 poses used to be refused (and the last 63
    answered a turn off); after 300 and a return to (2, 0, pi/2) the state's heading was
    pi/2 - 8 turns and the sweep refused from its touch on.
    """
    tracker = QuasistaticTracker(ISSUE_PROFILE, FootPose(2.0, 0.0, HALF_PI))
    _answers(tracker, issue_walk(n))
    assert -math.pi < tracker.pose.heading <= math.pi
    got = _answers(tracker, ISSUE_SWEEP)
    assert all(r is not None for r in got)
    # the sweep's first pose is free: from then on exactly the fresh tracker's results
    assert got[0].state == issue_fresh[0].state
    for a, b in zip(got[1:], issue_fresh[1:]):
        assert a.state == b.state and a.events == b.events


def test_refusals_speak_of_the_obstacle_and_the_pose():
    """Where the whisker would have met the obstacle, and why the model cannot follow."""
    prof = Catenary(0.5, 0.6, scan_checks=False)
    tracker = QuasistaticTracker(prof, FootPose(0.14, 0.27, 0.86),
                                 options=TrackerOptions(recover=False))
    with pytest.raises(ModelAssumptionError) as refusal:
        tracker.step(FootPose(0.93, 0.05, -3.02))
    message = str(refusal.value)
    assert "foot pose x = " in message and " deg" in message
    assert "catenary(p0=0.5, c=0.6)" in message and "whisker lengths from the foot at (" in message
    assert "rad" not in message and "profile slope" not in message


def test_what_the_properties_met():
    """Runs after the properties above (file order): the figures for the docs."""
    print(f"\nhistory properties: {dict(TALLY)}")
    if TALLY["histories"]:
        assert TALLY["refusals"] > 0 and TALLY["resets"] > 0


@pytest.fixture(autouse=True, scope="module")
def _timing():
    start = time.perf_counter()
    yield
    print(f"\ntest_history: {time.perf_counter() - start:.1f} s")
