"""
The 3D whisker under any history: every step returns or raises a VibrissaError, within budget.

Hypothesis draws whiskers (taper, linear or parabolic curvature, Poisson ratio), scenes of one or
two obstacles (spheres, tilted cylinders, half-spaces, prisms of planar obstacles) and histories
of base poses: small random moves, turns about random axes, rolls about the whisker's axis and
far jumps. For every step:

* it returns a state or raises a VibrissaError (never another exception, never a hang: the
  solver evaluations of one step stay within the tracker's budget);
* a failed step keeps the state;
* a returned state is admissible: contact forces >= 0, contact points on their obstacles, the
  centerline outside every obstacle (to the solver's tolerance), nothing NaN;
* after the history, a step to a pose where the unloaded whisker is clear, then a short sweep,
  gives the results of a new tracker placed there (a free whisker carries nothing but its pose).

The settings are derandomized (no example database). Hypothesis also draws literal constants of
the package's loaded modules, so its examples change with the code; the explicit examples below
(presses and jiggles against a sphere, a peg and a catenary wall) make sure every run holds
contacts, touches and releases whatever the draws.
"""

import math
from collections import Counter

import numpy as np
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from vibrissa_ros.core.errors import InvalidPoseError, VibrissaError
from vibrissa_ros.core.rod3d import BasePose, Cylinder, Plane, Prism, RodShape, RodTracker, Sphere
from vibrissa_ros.core.rod3d.pose import quat_about, quat_multiply
from vibrissa_ros.core.scenes.scene import obstacle_from_dict

SETTINGS = settings(derandomize=True, database=None, deadline=None, max_examples=40,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
#: a pose where the unloaded whisker is clear of every obstacle drawn below
FREE = BasePose((-2.5, -2.5, 0.0))
BUDGET = 20000
TALLY: Counter = Counter()

unit = st.floats(-1.0, 1.0)


@st.composite
def shapes(draw):
    taper = draw(st.sampled_from([1.0, 0.6, 0.3, 0.1]))
    nu = draw(st.sampled_from([0.0, 0.38, 0.5]))
    kind = draw(st.sampled_from(["straight", "linear", "parabola"]))
    if kind == "linear":
        return RodShape(taper=taper, k0=draw(st.floats(-2.0, 2.0)), k1=draw(st.floats(-2, 2)),
                        poisson=nu)
    if kind == "parabola":
        return RodShape(taper=taper, parabola=draw(st.floats(-1.5, 1.5)), poisson=nu)
    return RodShape(taper=taper, poisson=nu)


@st.composite
def obstacles(draw, index):
    kind = draw(st.sampled_from(["sphere", "cylinder", "plane", "peg", "catenary"]))
    cx, cy, cz = draw(unit), draw(unit), draw(unit)
    name = f"{kind}{index}"
    if kind == "sphere":
        return Sphere((0.8 * cx, 0.8 * cy, 0.3 * cz), draw(st.floats(0.05, 0.3)), name)
    if kind == "cylinder":
        axis = (draw(unit), draw(unit), 1.0)
        return Cylinder((0.8 * cx, 0.8 * cy, 0.0), axis, draw(st.floats(0.03, 0.2)), name)
    if kind == "plane":
        normal = (0.3 * draw(unit), 0.3 * draw(unit), 1.0)
        return Plane((0.0, 0.0, -0.2 - 0.5 * abs(cz)), normal, name)
    if kind == "peg":
        planar = obstacle_from_dict({"type": "peg", "x": 0.8 * cx, "y": 0.8 * cy,
                                     "r": draw(st.floats(0.03, 0.2))}, name)
        return Prism(planar)
    planar = obstacle_from_dict({"type": "catenary", "p0": 0.5 + 0.2 * abs(cy), "c": 0.6},
                                name)
    return Prism(planar)


@st.composite
def moves(draw):
    """Draw a new base pose relative to the last: a nudge, a turn, a roll or a far jump."""
    kind = draw(st.sampled_from(["nudge", "nudge", "nudge", "turn", "roll", "jump"]))
    d = np.array([draw(unit), draw(unit), draw(unit)])
    return kind, d, draw(st.floats(-math.pi, math.pi))


def _apply(pose, move):
    kind, d, angle = move
    if kind == "nudge":
        return BasePose(tuple(pose.p + 0.08 * d), pose.quaternion)
    if kind == "jump":
        return BasePose(tuple(1.2 * d), pose.quaternion)
    if kind == "roll":
        q = quat_multiply(pose.q, quat_about((1.0, 0.0, 0.0), 0.5 * angle))
        return BasePose(pose.position, tuple(q))
    axis = d / max(float(np.linalg.norm(d)), 1e-9)
    if not np.any(d):
        axis = np.array([0.0, 0.0, 1.0])
    q = quat_multiply(quat_about(axis, 0.4 * angle), pose.q)
    return BasePose(pose.position, tuple(q / np.linalg.norm(q)))


def _check_state(tracker, state):
    for v in state.force + state.moment + state.tip:
        assert math.isfinite(v)
    for c in state.contacts:
        assert c.f >= -1e-9
        ob = tracker.obstacles[c.obstacle]
        assert abs(ob.signed_distance(np.array([c.point]))[0]) < 1e-9
    pts = state.centerline(61)
    for ob in tracker.obstacles:
        assert np.min(ob.signed_distance(pts)) > -1e-6


def _press(dy, count, angle=0.0):
    return [("nudge", np.array([0.0, dy, 0.0]), angle)] * count


#: in and out of contact: 0.08 L toward the obstacle, then back, seven times
_JIGGLE = (_press(1.0, 1) + _press(-1.0, 1)) * 7


@SETTINGS
@example(shape=RodShape(), first=Sphere((0.6, 0.3, 0.0), 0.2, "ob0"), second=None,
         history=_press(0.5, 12), start=(0.0, 0.0))
@example(shape=RodShape(), first=Sphere((0.6, 0.15, 0.0), 0.1, "ob0"), second=None,
         history=_JIGGLE, start=(0.0, 0.0))
@example(shape=RodShape(taper=0.3, poisson=0.5),
         first=Cylinder((0.7, 0.1, 0.0), (0, 0, 1), 0.05, "ob0"),
         second=Prism(obstacle_from_dict({"type": "peg", "x": 0.4, "y": -0.5, "r": 0.08}, "ob1")),
         history=_JIGGLE, start=(0.0, 0.0))
@given(shape=shapes(), first=obstacles(0), second=st.one_of(st.none(), obstacles(1)),
       history=st.lists(moves(), min_size=3, max_size=14), start=st.tuples(unit, unit))
def test_every_step_returns_or_refuses_within_budget_and_leaves_no_trace(
        shape, first, second, history, start):
    scene = [first] if second is None else [first, second]
    try:
        tracker = RodTracker(scene, BasePose((1.5 * start[0], 1.5 * start[1], 0.0)),
                             shape=shape, max_evaluations=BUDGET)
    except InvalidPoseError:
        TALLY["unplaceable start"] += 1
        return
    pose = tracker.pose
    for move in history:
        pose = _apply(pose, move)
        before = tracker.state
        start_evals = tracker.solver.evaluations
        try:
            result = tracker.step(pose)
        except VibrissaError:
            TALLY["refused"] += 1
            assert tracker.state is before
            continue
        finally:
            # the budget bounds a step (swing-in helpers add theirs to the count)
            assert tracker.solver.evaluations - start_evals <= 3 * BUDGET
        TALLY["steps"] += 1
        TALLY.update(e.kind for e in result.events)
        TALLY["contacts %d" % len(result.state.contacts)] += 1
        _check_state(tracker, result.state)
    # no trace: free, then a sweep, equals a new tracker's (where the unloaded whisker is
    # clear along the whole sweep: a tilted half-space may reach there)
    sweep = [BasePose((-2.5 + 0.2 * k, -2.5, 0.0)) for k in range(4)]
    free = np.vstack([p.p + shape.free_centerline(np.linspace(0, 1, 41)) for p in sweep])
    if min(float(np.min(ob.signed_distance(free))) for ob in scene) < 0.2:
        return
    TALLY["no-trace checks"] += 1
    try:
        tracker.step(FREE)
    except VibrissaError:
        tracker.reset(FREE)
    fresh = RodTracker(scene, FREE, shape=shape)
    for target in sweep[1:]:
        assert tracker.step(target).state == fresh.step(target).state


def test_the_property_run_met_contacts_and_events():
    """What the runs above met (a run that never touches anything would prove little)."""
    print(dict(TALLY))
    assert TALLY["steps"] > 100
    assert TALLY["touch"] > 5
    assert TALLY["contacts 1"] > 10
    assert TALLY["no-trace checks"] > 10
