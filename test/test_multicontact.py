"""
Several contacts at once, with friction: the collocation solver and the scene tracker.

The one-contact results must equal the single-contact tracker (issue 10/12's general model, and
through it the paper's closed forms); two pegs must give a physically consistent sequence of
events; friction must stay in its cone, oppose the slip and dissipate over a closed sweep.
"""

import math
from pathlib import Path

import numpy as np
import pytest

from vibrissa_ros.core.scenes.boundary import CircleArc
from vibrissa_ros.core.general.model import GeneralWhiskerModel, WhiskerShape
from vibrissa_ros.core.profiles import Peg
from vibrissa_ros.core.scenes.tracker import SceneTracker
from vibrissa_ros.core.exact.tracker import QuasistaticTracker


class _Disk:
    """A minimal obstacle (the tracker's interface): a disk."""

    def __init__(self, x, y, r):
        self.x, self.y, self.r = x, y, r
        self.arcs = (CircleArc(x, y, r),)
        self.vertices = ()

    def signed_distance(self, points):
        p = np.asarray(points, dtype=float)
        return np.hypot(p[:, 0] - self.x, p[:, 1] - self.y) - self.r


def _sweep(x_from, x_to, step=0.01, back=False):
    n = int(round(abs(x_to - x_from) / step))
    grid = x_from + np.sign(x_to - x_from) * step * np.arange(n + 1)
    if back:
        grid = np.concatenate((grid, grid[-2::-1]))
    return [float(x) for x in grid]


@pytest.mark.parametrize("shape", [WhiskerShape(), WhiskerShape(0.3, 0.8, 0.5)])
def test_one_peg_equals_the_single_contact_tracker(shape):
    grid = _sweep(0.6, -0.78)
    single = QuasistaticTracker(Peg(0.0, 0.3, 0.03), grid[0], model=GeneralWhiskerModel(shape))
    scene = SceneTracker([_Disk(0.0, 0.3, 0.03)], grid[0], shape=shape)
    worst = 0.0
    events_a, events_b = [], []
    for x0 in grid[1:]:
        a, b = single.step(x0), scene.step(x0)
        events_a += [(e.kind, e.x0) for e in a.events]
        events_b += [(e.kind, e.x0) for e in b.events]
        sa, sb = a.state, b.state
        if sa.f > 0.0 and sb.f > 0.0:
            assert int(sa.phase) == int(sb.phase)
            worst = max(worst, abs(sa.s1 - sb.s1), abs(sa.alpha - sb.alpha))
        worst = max(worst, abs(sa.fx - sb.fx), abs(sa.fy - sb.fy), abs(sa.m0 - sb.m0),
                    abs(sa.tip[0] - sb.tip[0]), abs(sa.tip[1] - sb.tip[1]))
    assert worst < 1e-10
    assert [k for k, _ in events_a] == [k for k, _ in events_b]
    for (_, xa), (_, xb) in zip(events_a, events_b):
        assert abs(xa - xb) < 1e-10


def _check_state(state, obstacles, mu=0.0):
    """Equilibrium bookkeeping, unilateral forces, friction cone, no cut into an obstacle."""
    fx = sum(c.fx for c in state.contacts)
    fy = sum(c.fy for c in state.contacts)
    m0 = sum((c.x - state.pose.x) * c.fy - (c.y - state.pose.y) * c.fx for c in state.contacts)
    assert abs(state.fx - fx) < 1e-12 and abs(state.fy - fy) < 1e-12
    assert abs(state.m0 - m0) < 1e-12
    for c in state.contacts:
        assert c.N >= -1e-9
        assert abs(c.T) <= mu * c.N + 1e-9
        assert math.isclose(math.hypot(c.fx, c.fy), math.hypot(c.N, c.T), rel_tol=1e-12,
                            abs_tol=1e-12)
    points = state.centerline(401)
    for ob in obstacles:
        assert ob.signed_distance(points).min() > -1e-7


def test_two_pegs_touch_one_after_the_other_and_release():
    obstacles = [_Disk(0.0, 0.3, 0.03), _Disk(0.1, 0.7, 0.05)]
    tracker = SceneTracker(obstacles, 0.6)
    events, counts = [], []
    for x0 in _sweep(0.6, -0.1):
        result = tracker.step(x0)
        events += [(e.kind, e.obstacle, round(e.x0, 9)) for e in result.events]
        counts.append(len(result.state.contacts))
        _check_state(result.state, obstacles)
    # the straight whisker meets the upper peg's flank at x0 = 0.1 + 0.05 exactly, then the
    # lower peg while still touching the upper one, and leaves the upper one smoothly
    assert events[0] == ("touch", 1, 0.15)
    assert [e[:2] for e in events] == [("touch", 1), ("touch", 0), ("release", 1)]
    assert events[1][2] > events[2][2]
    assert max(counts) == 2


def test_no_friction_equals_mu_zero_exactly():
    obstacles = [_Disk(0.0, 0.3, 0.03), _Disk(0.1, 0.7, 0.05)]
    a = SceneTracker(obstacles, 0.6)
    b = SceneTracker(obstacles, 0.6, friction=[0.0, 0.0])
    for x0 in _sweep(0.6, 0.0, 0.02):
        sa, sb = a.step(x0).state, b.step(x0).state
        assert (sa.fx, sa.fy, sa.m0) == (sb.fx, sb.fy, sb.m0)


def _loop_work(mu):
    """Work the foot does over a closed back-and-forth sweep past a peg, and the states."""
    obstacles = [_Disk(0.0, 0.3, 0.03)]
    tracker = SceneTracker(obstacles, 0.6, friction=[mu])
    work, prev, states, events = 0.0, tracker.state, [], []
    opposed = []
    for x0 in _sweep(0.6, -0.4, back=True)[1:]:
        result = tracker.step(x0)
        st = result.state
        cfg = st.configuration
        if cfg.modes:  # the slip rate along this step's motion, and the friction force
            rates = tracker._slip_rates(cfg.modes, cfg.vector, st.pose, (x0 - prev.pose.x, 0, 0))
            opposed += [c.T * r for c, r in zip(st.contacts, rates) if c.state == "slip"]
        # the foot pushes on the whisker with minus the obstacles' total force
        work += -0.5 * (st.fx + prev.fx) * (st.pose.x - prev.pose.x)
        prev = st
        states.append(st)
        events += [e.kind for e in result.events]
    return work, states, events, obstacles, opposed


def test_friction_stays_in_its_cone_and_dissipates():
    w0 = _loop_work(0.0)[0]
    assert abs(w0) < 1e-10  # frictionless: conservative
    w1 = _loop_work(0.1)[0]
    w3, states3, ev3, obstacles, opposed = _loop_work(0.3)
    assert 0.0 < w1 < w3
    for st in states3:
        _check_state(st, obstacles, mu=0.3)
    # the reversal makes the contact stick, then slip the other way
    assert "stick" in ev3 and "slip" in ev3
    # while slipping, friction opposes the slip: T has the sign opposite to dq/dt
    assert len(opposed) > 50 and max(opposed) <= 0.0


def _whisk_events(taper, mu):
    """Whisk a whisker (foot fixed, heading 100 -> -10 deg) into a pole, with friction."""
    from vibrissa_ros.core.state import FootPose

    tracker = SceneTracker([_Disk(0.25, 0.45, 0.02)], FootPose(0.0, 0.0, math.radians(100)),
                           shape=WhiskerShape(taper), friction=[mu])
    events = []
    for deg in np.arange(99.5, -10.0, -0.5):
        result = tracker.step(FootPose(0.0, 0.0, math.radians(float(deg))))
        events += [(e.kind, math.degrees(e.pose.heading)) for e in result.events]
    return events


def test_conical_whiskers_slip_off_a_pole_later_with_friction_cylinders_never():
    # Hires et al. 2013: pushed into a pole, a conical whisker slips off at a critical angle, a
    # cylindrical one does not; Coulomb friction holds the cone on longer
    snaps = []
    for mu in (0.0, 0.2, 0.48):
        events = _whisk_events(1.0 / 15.0, mu)
        assert events[0][0] == "touch" and events[-1][0] == "snap"
        snaps.append(events[0][1] - events[-1][1])  # the push angle at the slip-off
        assert [k for k, _ in _whisk_events(1.0, mu)] == ["touch"]
    assert 35.0 < snaps[0] < snaps[1] < snaps[2] < 60.0


@pytest.mark.parametrize("recover", [False, True])
def test_a_foot_driven_into_or_through_an_obstacle_is_reported_as_such(recover):
    # such a step fails on the budget (~1.5 s); the failure then names the foot's path
    from vibrissa_ros.core import FootPose
    from vibrissa_ros.core.errors import InvalidPoseError, ModelAssumptionError
    from vibrissa_ros.scan.scene_file import load_scene

    scene = load_scene(str(Path(__file__).resolve().parents[1] / "config"
                           / "scene_two_pegs.yaml"))
    tracker = SceneTracker(scene.obstacles, FootPose(0.1, 0.0), recover=recover)
    tracker.step(FootPose(0.05, 0.0))
    before = tracker.state
    with pytest.raises(InvalidPoseError, match="inside peg0"):
        tracker.step(FootPose(0.0, 0.4))
    assert tracker.state is before
    through = FootPose(-0.2, 0.9)
    if not recover:
        with pytest.raises(ModelAssumptionError, match="passes through peg1"):
            tracker.step(through)
        assert tracker.state is before
        return
    result = tracker.step(through)  # re-placed unloaded at the target, where it is clear
    assert [e.kind for e in result.events] == ["reset"]
    assert "foot's path" in result.events[0].reason


@pytest.mark.parametrize("recover", [False, True])
def test_a_foot_ending_inside_an_obstacle_is_invalid_whatever_it_crossed_before(recover):
    from vibrissa_ros.core import FootPose
    from vibrissa_ros.core.errors import InvalidPoseError
    from vibrissa_ros.core.scenes.scene import PegObstacle

    pegs = [PegObstacle(0.0, -0.3, 0.05, "A"), PegObstacle(0.0, -0.6, 0.05, "B")]
    tracker = SceneTracker(pegs, FootPose(0.0, 0.0), recover=recover)
    with pytest.raises(InvalidPoseError, match="inside B"):
        tracker.step(FootPose(0.0, -0.6))
