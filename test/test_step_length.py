"""
One long step ends where the same path walked in many short steps ends (issue 18).

``step`` moves the foot linearly in (x, y, heading) and follows the equilibrium branch
continuously, so a touch anywhere inside a step is an event inside that step. Hypothesis
(derandomized) draws obstacles of every kind and foot paths that pass them; the path is walked in
one step and in N short steps, and the two must end in the same phase with every observable equal
to 1e-9 and the same events at the same poses. Where either walk meets a contact the model cannot
follow further (an error, or the recovery's reset event), both must meet it alike, else the walk
is counted and left out: the paths are drawn so that this is rare (a test below bounds it).
"""

import csv
import io
import json
import math

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import Phase as Stage
from hypothesis import strategies as st

from vibrissa_ros.cli import main
from vibrissa_ros.core import (
    Catenary,
    Circle,
    Ellipse,
    FootPose,
    GeneralWhiskerModel,
    Parabola,
    Peg,
    Phase,
    QuasistaticTracker,
    TwoCircles,
    VibrissaError,
    WhiskerShape,
)
from vibrissa_ros.core.scenes.scene import PegObstacle, PolygonObstacle
from vibrissa_ros.core.scenes.tracker import SceneTracker

HALF_PI = 0.5 * math.pi
TOL = 1e-9

SETTINGS = dict(derandomize=True, database=None, deadline=None,
                phases=(Stage.explicit, Stage.generate),
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])

FIELDS = ("alpha", "s1", "tip_slope", "f", "fx", "fy", "m0")


def _lerp(a, b, u):
    return FootPose(a.x + u * (b.x - a.x), a.y + u * (b.y - a.y),
                    a.heading + u * (b.heading - a.heading))


def _walk(make, start, target, n):
    """Walk start -> target in n equal steps: ("ok", state, events) or ("error", type)."""
    tracker = make(start)
    events = []
    try:
        for k in range(1, n + 1):
            events += tracker.step(_lerp(start, target, k / n)).events
    except VibrissaError as exc:
        return "error", type(exc).__name__, None
    return "ok", tracker.state, events


#: the scene tracker locates a snap where Newton stops finding the configuration beyond it (not
#: by root finding on the fold): to ~1e-6 L, and what follows a snap inherits that
SCENE_SNAP_TOL = 1e-5


def _close(a, b, tol=TOL):
    if a is None or b is None:
        return a is None and b is None
    return abs(a - b) <= tol * max(1.0, abs(a))


def _same_walk(long, short, scene=False):
    """Assert that the two walks end alike; return the largest difference found."""
    assert long[0] == short[0], (long, short)
    tol = TOL
    if scene and long[0] == "ok" and any(e.kind == "snap" for e in long[2]):
        tol = SCENE_SNAP_TOL
    if long[0] == "error":
        assert long[1] == short[1]
        return 0.0
    a, b = long[1], short[1]
    worst = 0.0
    if scene:
        assert len(a.contacts) == len(b.contacts)
        pairs = [(a.fx, b.fx), (a.fy, b.fy), (a.m0, b.m0)]
        for ca, cb in zip(a.contacts, b.contacts):
            assert (ca.kind, ca.obstacle, ca.state) == (cb.kind, cb.obstacle, cb.state)
            pairs += [(ca.s, cb.s), (ca.fx, cb.fx), (ca.fy, cb.fy)]
    else:
        assert a.phase == b.phase
        pairs = [(getattr(a, k), getattr(b, k)) for k in FIELDS]
    for x, y in pairs:
        assert _close(x, y, tol), (pairs, long, short)
        if x is not None:
            worst = max(worst, abs(x - y) / max(1.0, abs(x)))
    ea, eb = long[2], short[2]
    assert [e.kind for e in ea] == [e.kind for e in eb], (ea, eb)
    for u, v in zip(ea, eb):
        if scene:
            assert u.obstacle == v.obstacle
        for x, y in ((u.pose.x, v.pose.x), (u.pose.y, v.pose.y),
                     (u.pose.heading, v.pose.heading)):
            assert _close(x, y, tol), (ea, eb)
            worst = max(worst, abs(x - y))
    if tol > TOL:
        WORST["scene_after_snap"] = max(WORST["scene_after_snap"], worst)
        return 0.0
    return worst


def _check(make, start, target, n, scene=False):
    try:
        make(start)
    except VibrissaError:
        assume(False)  # the start must be a free pose
    long = _walk(make, start, target, 1)
    short = _walk(make, start, target, n)
    WORST["cases"] += 1
    reset = any(w[0] == "ok" and any(e.kind == "reset" for e in w[2]) for w in (long, short))
    if reset or long[0] != short[0] or (long[0] == "error" and long[1] != short[1]):
        # a contact that the model cannot follow on one of the walks (not a touch): counted
        WORST["followed_differently"] += 1
        assume(False)
    WORST["diff"] = max(WORST["diff"], _same_walk(long, short, scene))
    if long[0] == "ok" and long[2]:
        WORST["with_events"] += 1


WORST = {"cases": 0, "followed_differently": 0, "diff": 0.0, "scene_after_snap": 0.0,
         "with_events": 0}

poses = st.builds(FootPose, st.floats(-1.3, 1.3), st.floats(-0.5, 0.2),
                  st.floats(HALF_PI - 0.4, HALF_PI + 0.4))
starts = st.builds(FootPose, st.sampled_from([-1.3, 1.3]), st.floats(-0.5, 0.2),
                   st.floats(HALF_PI - 0.3, HALF_PI + 0.3))
steps = st.integers(2, 12)


# -- the issue --------------------------------------------------------------------------------
def test_the_issue_point_peg_is_touched_in_one_step_as_in_many():
    peg = Peg(0.0, 0.7, 0.0)
    start, target = FootPose(0.5, -0.5, HALF_PI), FootPose(-0.1, 0.0, HALF_PI)
    model = GeneralWhiskerModel()
    long = QuasistaticTracker(peg, start, model=model).step(target)
    assert long.state.phase == Phase.TANGENTIAL
    (touch,) = long.events
    # the straight whisker's line crosses the point where the foot is at x = 0
    assert touch.kind == "touch" and touch.pose.x == pytest.approx(0.0, abs=1e-12)
    assert touch.pose.y == pytest.approx(-0.5 + 0.5 * 5.0 / 6.0, abs=1e-12)
    short = _walk(lambda p: QuasistaticTracker(peg, p, model=model), start, target, 100)
    _same_walk(("ok", long.state, list(long.events)), short)


def test_the_issue_cli_scan_with_two_poses_ends_in_contact(tmp_path, capsys):
    poses = tmp_path / "P.csv"
    poses.write_text(f"x,y,heading\n0.5,-0.5,{HALF_PI!r}\n-0.1,0,{HALF_PI!r}\n")
    out, events = tmp_path / "out.csv", tmp_path / "ev.json"
    code = main(["scan", "--profile", "peg", "--param", "x=0", "--param", "y=0.7", "--param",
                 "r=0", "--poses", str(poses), "--csv", str(out), "--events", str(events)])
    capsys.readouterr()
    assert code == 0
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    assert [int(r["phase"]) for r in rows] == [0, 1]
    # the whisker presses on the point from x = 0 to x = -0.1 (with r = 0.001: f = 0.858)
    assert float(rows[1]["f"]) == pytest.approx(0.858, abs=0.01)
    assert float(rows[1]["contact_x"]) == pytest.approx(0.0, abs=1e-12)
    assert float(rows[1]["contact_y"]) == pytest.approx(0.7, abs=1e-12)
    (touch,) = json.loads(events.read_text())
    assert touch["kind"] == "touch" and touch["x"] == pytest.approx(0.0, abs=1e-12)


def test_a_whisker_passing_a_point_beyond_its_tip_does_not_touch_it():
    # the point lies just beyond the tip's path: no touch in one step or in many
    peg = Peg(0.0, 1.0 + 1e-9, 0.0)
    start, target = FootPose(0.5, 0.0, HALF_PI), FootPose(-0.5, 0.0, HALF_PI)
    make = lambda p: QuasistaticTracker(peg, p, model=GeneralWhiskerModel())  # noqa: E731
    for n in (1, 7):
        result = _walk(make, start, target, n)
        assert result[0] == "ok" and result[1].phase == Phase.FREE and result[2] == []


def test_a_rotated_closed_profile_is_touched_in_one_long_step():
    # the tip's distance to the lower arc was overestimated from the arc's ends
    prof = TwoCircles(0.40182799930038193, 1.9567031614227302, 0.6702047680053523).placed(
        0.16543305242479778, -0.23248259676209432, 0.3097512097804772)
    start = FootPose(-2.799276405215579, -0.08338688489219159, 1.6912177812881066)
    target = FootPose(1.0705699669906164, -0.14209691785181816, 1.521208065961976)
    for model in ("elastica", "rigid"):
        make = lambda p: QuasistaticTracker(prof, p, model=model)  # noqa: E731
        long, short = _walk(make, start, target, 1), _walk(make, start, target, 5)
        assert long[0] == "ok" and long[2][0].kind == "touch"
        _same_walk(long, short)


# -- every obstacle kind ------------------------------------------------------------------------
@settings(max_examples=40, **SETTINGS)
@given(x=st.floats(-0.5, 0.5), y=st.floats(0.3, 0.95),
       r=st.sampled_from([0.0, 0.0, 1e-3, 0.01, 0.05]), taper=st.sampled_from([1.0, 0.2]),
       k0=st.sampled_from([0.0, 0.5, -0.5]), start=starts, target=poses, n=steps)
def test_pegs_one_long_step_equals_many_short(x, y, r, taper, k0, start, target, n):
    model = GeneralWhiskerModel(WhiskerShape(taper, k0, 0.0))
    peg = Peg(x, y, r)
    _check(lambda p: QuasistaticTracker(peg, p, model=model), start, target, n)


@st.composite
def profiles(draw):
    family = draw(st.sampled_from(["parabola", "catenary", "circle", "two_circles", "ellipse"]))
    p0 = draw(st.floats(0.05, 0.95))
    size = lambda: 10.0 ** draw(st.floats(-1.5, 1.5))  # noqa: E731
    reach = 1.0 - p0
    prof = {"parabola": lambda: Parabola(p0, size()), "catenary": lambda: Catenary(p0, size()),
            "circle": lambda: Circle(p0, reach + size()),
            "two_circles": lambda: TwoCircles(p0, reach + size(), reach + size()),
            "ellipse": lambda: Ellipse(p0, size(), reach + size())}[family]()
    if draw(st.booleans()):
        prof = prof.placed(draw(st.floats(-0.5, 0.5)), draw(st.floats(-0.3, 0.3)),
                           draw(st.floats(-0.4, 0.4)))
    return prof


@settings(max_examples=40, **SETTINGS)
@given(profile=profiles(), model=st.sampled_from(["elastica", "rigid"]), start=starts,
       target=poses, n=steps)
def test_profiles_one_long_step_equals_many_short(profile, model, start, target, n):
    start = FootPose(2.0 * start.x, start.y, start.heading)  # beyond the widest profiles
    target = FootPose(2.0 * target.x, target.y, target.heading)
    _check(lambda p: QuasistaticTracker(profile, p, model=model), start, target, n)


@settings(max_examples=6, **SETTINGS)
@given(profile=profiles(), k0=st.floats(-0.8, 0.8), start=starts, target=poses, n=steps)
def test_curved_whisker_against_profiles_one_long_step_equals_many_short(profile, k0, start,
                                                                         target, n):
    model = GeneralWhiskerModel(WhiskerShape(0.3, k0, 0.0))
    start = FootPose(2.0 * start.x, start.y, start.heading)
    target = FootPose(2.0 * target.x, target.y, target.heading)
    _check(lambda p: QuasistaticTracker(profile, p, model=model), start, target, n)


@settings(max_examples=12, **SETTINGS)
@given(px=st.floats(-0.6, -0.1), py=st.floats(0.3, 0.9), r=st.sampled_from([0.003, 0.02]),
       triangle=st.booleans(), mu=st.sampled_from([0.0, 0.3]), start=starts, target=poses,
       n=st.integers(2, 8))
def test_scene_one_long_step_equals_many_short(px, py, r, triangle, mu, start, target, n):
    corners = (((0.2, 0.5), (0.45, 0.62), (0.3, 0.7)) if triangle
               else ((0.15, 0.7), (0.5, 0.65), (0.5, 0.9), (0.3, 0.95)))
    obstacles = [PegObstacle(px, py, r), PolygonObstacle(corners)]
    _check(lambda p: SceneTracker(obstacles, p, friction=[mu, mu]), start, target, n,
           scene=True)


def test_the_property_tests_compared_most_of_their_walks():
    # (runs after the property tests in this file) a walk followed differently in contact is
    # discarded, not compared: it must stay the exception
    if WORST["cases"] < 50:
        pytest.skip("run with the property tests of this file")
    assert WORST["followed_differently"] <= 0.15 * WORST["cases"]
    assert WORST["diff"] <= TOL
    print(f"step length: {WORST}")
