"""The figures: what was drawn (the artists' data) against the scan, never pixels."""

import hashlib

import numpy as np
import pytest

from vibrissa_ros.core import Catenary, Parabola, run_scan, scan_grid
from vibrissa_ros.core.exact.models import make_model
from vibrissa_ros.scan.plots import (PlotRun, direction_segments, plot_runs, si_units,
                                     sketch_selection)


@pytest.fixture(scope="module")
def loop():
    profile = Catenary(0.5, 0.6)
    return profile, run_scan(profile, scan_grid(1.5, -1.5, 0.01, back=True))


def _line(ax, gid):
    lines = [line for line in ax.get_lines() if line.get_gid() == gid]
    assert len(lines) == 1, gid
    return lines[0].get_xydata()


def test_observables_are_the_scan_values_one_curve_per_direction(loop):
    profile, scan = loop
    fig = plot_runs([PlotRun("elastica", scan.states, scan.events, scan.event_steps)], profile)
    segments = direction_segments(scan.states)
    assert len(segments) == 2
    for d, (a, b) in enumerate(segments):
        st = scan.states[a:b]
        x = [s.x0 for s in st]
        np.testing.assert_array_equal(_line(fig.axes["m0"], f"elastica:m0:{d}"),
                                      np.column_stack((x, [s.m0 for s in st])))
        np.testing.assert_array_equal(_line(fig.axes["f"], f"elastica:f:{d}"),
                                      np.column_stack((x, [s.f for s in st])))
        np.testing.assert_array_equal(_line(fig.axes["fxy"], f"elastica:fx:{d}")[:, 1],
                                      [s.fx for s in st])
        np.testing.assert_array_equal(_line(fig.axes["fxy"], f"elastica:fy:{d}")[:, 1],
                                      [s.fy for s in st])
        s1 = _line(fig.axes["s1"], f"elastica:s1:{d}")[:, 1]
        np.testing.assert_array_equal(np.isnan(s1), [s.s1 is None for s in st])
    # the hysteresis loop: each direction carries arrows along its travel
    arrows = [t for t in fig.axes["m0"].texts if t.get_gid() == "arrow"]
    assert len(arrows) >= 4
    for arrow in arrows:
        (x_from, _), (x_to, _) = arrow.xyann, arrow.xy
        assert x_from != x_to
    # the events are marked where they happened
    marks = sorted(line.get_xdata()[0] for line in fig.axes["m0"].get_lines()
                   if str(line.get_gid()).startswith("event:"))
    assert marks == pytest.approx(sorted(e.x0 for e in scan.events))
    # phases shaded
    assert {p.get_gid() for p in fig.axes["m0"].patches} >= {"phase1", "phase2"}
    fig.save("/dev/null")


def test_sketch_draws_the_chosen_centerlines_with_touch_events_and_the_state_before_the_snap(loop):
    profile, scan = loop
    fig = plot_runs([PlotRun("elastica", scan.states, scan.events, scan.event_steps)], profile)
    drawn = [line for line in fig.axes["sketch"].get_lines() if line.get_gid() == "centerline"]
    assert 12 <= len(drawn) == len(fig.sketch_states) <= 16
    for line, state in zip(drawn, fig.sketch_states):
        np.testing.assert_allclose(line.get_xydata(), state.centerline(81), atol=0)
        assert line.get_color() == {1: "#1f77b4", 2: "#d62728"}[int(state.phase)]
    contacts = [line.get_xydata()[0] for line in fig.axes["sketch"].get_lines()
                if line.get_gid() == "contact"]
    assert len(contacts) == len(fig.sketch_states)
    first = scan.states[: direction_segments(scan.states)[0][1]]
    snap = next(e for e in scan.events if e.kind == "snap")
    last_before_snap = [s for s in first if s.phase and s.x0 > snap.x0][-1]
    assert any(s is last_before_snap for s in fig.sketch_states)
    touch = next(e for e in scan.events if e.kind == "touch")
    first_contact = next(s for s in first if s.phase)
    assert first_contact.x0 <= touch.x0 and any(s is first_contact for s in fig.sketch_states)
    outline = _line(fig.axes["sketch"], "obstacle")
    assert np.allclose(outline[:, 1], [profile.eta(profile.alpha_at_x(x)) for x in outline[:, 0]],
                       atol=1e-9)
    assert fig.axes["sketch"].get_aspect() == 1.0
    fig.save("/dev/null")


def test_two_models_share_the_axes_dashed(tmp_path):
    profile = Parabola(0.6)
    grid = scan_grid(1.8, -1.8, 0.02)
    el = run_scan(profile, grid)
    rg = run_scan(profile, grid, model=make_model("rigid", stiffness=3.0))
    fig = plot_runs([PlotRun("elastica", el.states, el.events),
                     PlotRun("rigid", rg.states, rg.events)], profile)
    solid = [line for line in fig.axes["m0"].get_lines() if line.get_gid() == "elastica:m0:0"][0]
    dashed = [line for line in fig.axes["m0"].get_lines() if line.get_gid() == "rigid:m0:0"][0]
    assert solid.get_linestyle() == "-" and dashed.get_linestyle() == "--"
    np.testing.assert_array_equal(dashed.get_ydata(), [s.m0 for s in rg.states])
    fig.save(str(tmp_path / "both.png"))


def test_si_labels_name_units_and_frame():
    profile = Parabola(0.3)
    scan = run_scan(profile, scan_grid(2.0, -2.0, 0.05))
    fig = plot_runs([PlotRun("elastica", scan.states, scan.events)], profile,
                    si_units(0.1, 0.05, 0.005, "world"))
    assert fig.axes["m0"].get_ylabel() == "m0 [N·m]"
    assert fig.axes["fxy"].get_ylabel() == "fx, fy [N] (frame 'world')"
    assert fig.axes["s1"].get_xlabel() == "foot position x0 [m]"
    np.testing.assert_allclose(_line(fig.axes["m0"], "elastica:m0:0")[:, 1],
                               [s.m0 * 0.005 for s in scan.states])
    fig.save("/dev/null")


def test_output_is_deterministic(tmp_path):
    profile = Parabola(0.3)
    scan = run_scan(profile, scan_grid(2.0, -2.0, 0.05))
    digests = []
    for name in ("a.png", "b.png"):
        plot_runs([PlotRun("elastica", scan.states, scan.events)], profile).save(
            str(tmp_path / name), small=True)
        digests.append(hashlib.sha256((tmp_path / name).read_bytes()).hexdigest())
    assert digests[0] == digests[1]


def test_selection_prefers_events_and_stays_within_count():
    profile = Parabola(0.3)
    scan = run_scan(profile, scan_grid(2.0, -2.0, 0.01))
    picks = sketch_selection(scan.states, scan.events, 15)
    assert len(picks) <= 15
    assert all(scan.states[i].phase for i in picks)
