"""
Phase switches are decided by the direction of the branches.

The contact reaching the tip, the tip turning tangent: never by the rounding of an event function
that sits at zero.

At a switch both phases' branches meet. If the new phase goes on forwards the tracker switches;
if its admissible part lies behind the switch too, no equilibrium exists just ahead (the branch
of equilibria folds at the switch, a corner) and the whisker snaps there, e.g. a tapered whisker
slipping off a peg over its tip. The independent shooting solver is the reference: at every
switch the event function of the phase that ends there is zero to 1e-8 and the contact slopes
agree to 1e-8 (measured ~1e-13), and just beyond a switch the shooting equilibria say which phase
exists.
"""

import math

import numpy as np
import pytest

from vibrissa_ros.core import FootPose, Parabola, Peg, Phase, QuasistaticTracker
from vibrissa_ros.core.general import GeneralWhiskerModel, WhiskerShape
from vibrissa_ros.core.checks.general_shooting import ShotState, _integrate, shoot


def _peg_scene(seed, shift=0.0, radius_scale=1.0):
    """Build the scenes of test_inverse_general's random pegs (even seeds: foot translating)."""
    rng = np.random.default_rng(seed)
    shape = WhiskerShape(rng.uniform(0.1, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-0.5, 0.5))
    peg = Peg(rng.uniform(-0.3, 0.3), rng.uniform(0.4, 0.9), rng.uniform(0.0, 0.2) * radius_scale)
    xs = [1.2 - 0.04 * i + shift for i in range(60)]
    return shape, peg, xs


def _run(profile, model, xs):
    tracker = QuasistaticTracker(profile, FootPose(xs[0], 0.0), model=model)
    events = []
    for x in xs[1:]:
        events.extend(tracker.step(FootPose(x, 0.0)).events)
    return events


def _state_before(profile, model, xs, x_event, gap=1e-7):
    """Track to the state a little before x_event (the foot moves towards -x)."""
    tracker = QuasistaticTracker(profile, FootPose(xs[0], 0.0), model=model)
    for x in xs[1:]:
        if x <= x_event + gap:
            break
        tracker.step(FootPose(x, 0.0))
    return tracker.step(FootPose(x_event + gap, 0.0)).state


def _shoot(shape, profile, x, phase, state):
    """Shooting equilibrium of ``phase`` at foot x, started from a tracker state nearby."""
    guess = ShotState(phase, state.m0, state.f, state.alpha,
                      min(state.s1, 0.9999) if phase == Phase.TANGENTIAL else 1.0)
    for tol in (1e-13, 1e-12):  # hybr may stop a few ulps short of the tighter tolerance
        try:
            return shoot(shape, profile, FootPose(x, 0.0), phase, guess, right=state.side < 0,
                         tol=tol)
        except Exception:  # noqa: BLE001 - the next tolerance
            continue
    raise AssertionError(f"shooting did not converge at x0 = {x!r}, phase {int(phase)}")


def _inside(shape, x, shot, side):
    """Evaluate the phase's inequality at a shooting equilibrium (> 0 inside the phase)."""
    if shot.phase == Phase.TANGENTIAL:
        return 1.0 - shot.s1
    theta1 = _integrate(shape, FootPose(x, 0.0), shot.m0, shot.f, shot.alpha, 1.0)[2]
    # theta(1) - alpha in the contact frame (mirrored when the obstacle is on the right)
    return math.remainder(side * (theta1 - shot.alpha) + (0.0 if side > 0 else math.pi),
                          2.0 * math.pi)


def _check_switches(shape, profile, model, xs, events):
    """Check every switch among ``events`` against shooting; return how many were checked."""
    checked = 0
    for ev in events:
        if ev.kind not in ("phase", "snap"):
            continue
        x = ev.pose.x
        before = _state_before(profile, model, xs, x)
        old = before.phase
        if ev.kind == "snap" and (old == Phase.TIP or before.s1 < 1.0 - 1e-5):
            continue  # a smooth fold, not a switch
        checked += 1
        # the switch: the old phase's inequality is an equality there, the slopes agree
        at = _shoot(shape, profile, x, old, before)
        assert abs(_inside(shape, x, at, before.side)) < 1e-8
        assert abs(at.alpha - ev.alpha) < 1e-8
        # just beyond it: the old phase has ended; the new one exists for a phase event, and
        # neither does for a snap (the corner)
        new = Phase.TIP if old == Phase.TANGENTIAL else Phase.TANGENTIAL
        beyond = x - 1e-6
        assert _inside(shape, beyond, _shoot(shape, profile, beyond, old, before), before.side) < 0
        assert (_inside(shape, beyond, _shoot(shape, profile, beyond, new, before), before.side)
                > 0) == (ev.kind == "phase")
    return checked


@pytest.fixture(scope="module")
def seed_1000():
    shape, peg, xs = _peg_scene(1000)
    return shape, peg, xs, _run(peg, GeneralWhiskerModel(shape), xs)


def test_the_tapered_whisker_slips_off_the_peg_over_its_tip(seed_1000):
    # the contact slides to the tip at x0 = -0.787259; the tip contact that begins there exists
    # only behind it (shooting: theta(1) < alpha ahead), so the whisker snaps free there
    shape, peg, xs, events = seed_1000
    assert [(e.kind, e.from_phase, e.to_phase) for e in events] == [
        ("touch", Phase.FREE, Phase.TANGENTIAL), ("snap", Phase.TANGENTIAL, Phase.FREE)]
    assert events[1].pose.x == pytest.approx(-0.7872587570074, abs=1e-12)
    assert _check_switches(shape, peg, GeneralWhiskerModel(shape), xs, events) == 1


@pytest.mark.parametrize("shift", [1e-12, -1e-12, 1e-11, -1e-11, 1e-10, -1e-10, 1e-9, -1e-9])
def test_the_switch_does_not_depend_on_the_rounding_of_the_path(seed_1000, shift):
    shape, peg, xs, reference = seed_1000
    events = _run(peg, GeneralWhiskerModel(shape), _peg_scene(1000, shift)[2])
    assert [(e.kind, e.from_phase, e.to_phase) for e in events] == [
        (e.kind, e.from_phase, e.to_phase) for e in reference]
    for ev, ref in zip(events, reference):  # the switch is a pose, not a sample of the path
        assert ev.pose.x == pytest.approx(ref.pose.x, abs=1e-11)


@pytest.mark.parametrize("offset", [0.0, 1e-15, -1e-15, 1e-13, -1e-13])
@pytest.mark.parametrize("then", [0.01, -0.01])
def test_a_step_ending_on_the_switch(seed_1000, offset, then):
    # a pose on the switch to rounding, then on forwards or back: one snap at the switch going
    # forwards, none going back from before it
    shape, peg, _, reference = seed_1000
    x_snap = reference[1].pose.x
    xs = list(np.linspace(0.5, x_snap + 0.02, 8)) + [x_snap + offset, x_snap + offset + then]
    events = _run(peg, GeneralWhiskerModel(shape), [float(x) for x in xs])
    snaps = [e for e in events if e.kind == "snap"]
    if abs(offset) <= 1e-15 and then > 0.0:
        # landing on the switch to the last bits: the snap is located at the target pose to
        # rounding, so whether it fires on landing or not at all is the library's last bit
        # (numpy 1.x and 2.x differ here); never twice, and always at the switch
        assert len(snaps) <= 1
    else:
        expect_snap = offset < 0.0 or then < 0.0
        assert len(snaps) == int(expect_snap)
    if snaps:
        assert snaps[0].pose.x == pytest.approx(x_snap, abs=1e-12)
        assert snaps[0].from_phase == Phase.TANGENTIAL
    assert not [e for e in events if e.kind == "phase"]


@pytest.mark.parametrize("seed, radius_scale", [
    (1000, 0.8), (1000, 1.2), (1006, 1.0), (1014, 1.0), (1020, 0.9),  # corners: snaps
    (1008, 1.0), (1018, 1.0), (1018, 0.8), (1028, 1.0),  # switches that go on
])
def test_switches_of_nearby_scenes_agree_with_shooting(seed, radius_scale):
    shape, peg, xs = _peg_scene(seed, radius_scale=radius_scale)
    model = GeneralWhiskerModel(shape)
    events = _run(peg, model, xs)
    assert _check_switches(shape, peg, model, xs, events) >= 1


@pytest.mark.parametrize("shift", [0.0, 1e-12, -1e-12, 1e-10, -1e-10, 1e-9, -1e-9])
def test_the_closed_forms_switch_phases_the_same_way_on_any_rounding(shift):
    # the paper's parabola p0 = 0.3 runs 0 -> 2 -> 1 -> 2 -> snap; its two switches are
    # ordinary (the new phase goes on), located to ~1e-12 whatever the path's rounding
    xs = [2.0 - 0.01 * i + shift for i in range(401)]
    events = _run(Parabola(0.3), "elastica", xs)
    assert [(e.kind, int(e.from_phase), int(e.to_phase)) for e in events] == [
        ("touch", 0, 2), ("phase", 2, 1), ("phase", 1, 2), ("snap", 2, 0)]
    assert events[1].pose.x == pytest.approx(0.579492006889015, abs=1e-11)
    assert events[2].pose.x == pytest.approx(-1.024338156937058, abs=1e-11)
    if shift == 0.0:  # the uniform straight whisker of the shooting solver is the paper's
        assert _check_switches(WhiskerShape(), Parabola(0.3), "elastica", xs, events) == 2


@pytest.mark.parametrize("x_switch", [0.579492006889015, -1.024338156937058])
@pytest.mark.parametrize("offset", [0.0, 1e-15, -1e-15, 1e-13, -1e-13])
@pytest.mark.parametrize("then", [0.01, -0.01])
def test_the_closed_forms_on_a_pose_at_a_switch(x_switch, offset, then):
    # landing on a switch to rounding and going on or back: the phase of the side the foot ends
    # on, and a switch event only where the foot crosses the switch
    xs = [2.0] + list(np.linspace(1.9, x_switch + 0.02, 8)) + [
        x_switch + offset, x_switch + offset + then]
    tracker = QuasistaticTracker(Parabola(0.3), 2.0)
    events = []
    for x in xs[1:]:
        events.extend(tracker.step(float(x)).events)
    before, after = (Phase.TIP, Phase.TANGENTIAL) if x_switch > 0 else (
        Phase.TANGENTIAL, Phase.TIP)
    assert tracker.state.phase == (after if then < 0 else before)
    crossings = (offset < 0.0) + (offset < 0.0 and then > 0.0) + (offset >= 0.0 and then < 0.0)
    phases = [e for e in events if e.kind == "phase" and abs(e.pose.x - x_switch) < 1e-12]
    assert len(phases) == crossings
