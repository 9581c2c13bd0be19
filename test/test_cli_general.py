"""`vibrissa scan` with the general whisker: pegs, taper, curvature, solver choice, foot poses."""

import csv
import io
import json
import math

import numpy as np
import pytest

from vibrissa_ros.cli import main


def _run(args, capsys):
    try:
        code = main(args)
    except SystemExit as exc:  # argparse reports bad arguments by exiting with status 2
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


def _rows(text):
    return list(csv.DictReader(io.StringIO(text)))


def test_peg_scan_with_taper_and_negative_curvature(tmp_path, capsys):
    csv_path, ev_path = tmp_path / "scan.csv", tmp_path / "events.json"
    code, _, err = _run(
        ["scan", "--profile", "peg", "--param", "x=0", "--param", "y=0.6", "--param", "r=0.05",
         "--taper", "0.0667", "--curvature=-1,0", "--from", "1", "--to", "-1", "--step", "0.02",
         "--back", "--csv", str(csv_path), "--events", str(ev_path)],
        capsys,
    )
    assert code == 0, err
    text = csv_path.read_text()
    assert text.splitlines()[0] == "x0,phase,alpha,s1,tip_slope,f,fx,fy,m0,contact_x,contact_y"
    assert "nan" not in text.lower()
    rows = _rows(text)
    assert len(rows) == 201
    assert {r["phase"] for r in rows} >= {"0", "1"}
    events = json.loads(ev_path.read_text())
    assert events[0]["kind"] == "touch" and events[0]["to_phase"] == 1
    assert set(events[0]) == {"x0", "kind", "from_phase", "to_phase"}
    # free rows carry the curved whisker's tip slope: heading + k0
    assert float(rows[0]["tip_slope"]) == pytest.approx(math.pi / 2 - 1.0)


def test_numeric_solver_reproduces_the_exact_csv(tmp_path, capsys):
    out = {}
    for solver in ("exact", "numeric"):
        path = tmp_path / f"{solver}.csv"
        code, _, err = _run(
            ["scan", "--profile", "parabola", "--param", "p0=0.3", "--solver", solver,
             "--from", "2", "--to", "-2", "--step", "0.05", "--csv", str(path)],
            capsys,
        )
        assert code == 0, err
        out[solver] = _rows(path.read_text())
    for a, b in zip(out["exact"], out["numeric"]):
        assert a["phase"] == b["phase"]
        for key in ("alpha", "s1", "tip_slope", "f", "fx", "fy", "m0", "contact_x", "contact_y"):
            if a[key] == "":
                assert b[key] == ""
            else:
                assert abs(float(a[key]) - float(b[key])) <= 1e-9 * max(1.0, abs(float(a[key])))


def test_poses_csv_drives_translation_and_whisking(tmp_path, capsys):
    poses = tmp_path / "poses.csv"
    lines = ["x,y,heading"] + [f"0,0,{math.pi / 2 + 0.6 - 0.02 * i!r}" for i in range(61)]
    poses.write_text("\n".join(lines) + "\n")
    csv_path, ev_path = tmp_path / "scan.csv", tmp_path / "events.json"
    code, _, err = _run(
        ["scan", "--profile", "peg", "--param", "x=0.2", "--param", "y=0.5", "--param", "r=0.02",
         "--taper", "0.1", "--curvature", "0.5", "--poses", str(poses), "--csv", str(csv_path),
         "--events", str(ev_path)],
        capsys,
    )
    assert code == 0, err
    text = csv_path.read_text()
    assert (text.splitlines()[0]
            == "x,y,heading,phase,alpha,s1,tip_slope,f,fx,fy,m0,contact_x,contact_y")
    rows = _rows(text)
    assert len(rows) == 61
    assert float(rows[-1]["heading"]) == pytest.approx(math.pi / 2 - 0.6)
    events = json.loads(ev_path.read_text())
    assert events and set(events[0]) == {"x", "y", "heading", "kind", "from_phase", "to_phase"}
    assert events[0]["kind"] == "touch"


@pytest.mark.parametrize(
    "args, message",
    [
        (["--profile", "parabola", "--param", "p0=0.3", "--taper", "0.5", "--solver", "exact"],
         "tapered or curved"),
        (["--profile", "peg", "--param", "x=0", "--param", "y=0.5", "--solver", "exact"], "peg"),
        (["--profile", "parabola", "--param", "p0=0.3", "--taper", "0"], "taper"),
        (["--profile", "parabola", "--param", "p0=0.3", "--taper", "1.2"], "taper"),
        (["--profile", "parabola", "--param", "p0=0.3", "--curvature", "1,2,3"], "K0"),
        (["--profile", "parabola", "--param", "p0=0.3", "--model", "rigid", "--taper", "0.5"],
         "--model elastica"),
        (["--profile", "peg", "--param", "x=0", "--param", "y=0.5", "--param", "r=-1"], "r"),
        (["--profile", "peg", "--param", "x=0"], "y"),
    ],
)
def test_bad_general_arguments_exit_2_with_one_line(args, message, tmp_path, capsys):
    code, _, err = _run(["scan"] + args + ["--from", "1", "--to", "-1", "--step", "0.5",
                                           "--csv", str(tmp_path / "o.csv")], capsys)
    assert code == 2
    assert len(err.strip().splitlines()) == 1
    assert message in err


def test_poses_and_grid_are_exclusive(tmp_path, capsys):
    poses = tmp_path / "p.csv"
    poses.write_text("x,y,heading\n0,0,1.5\n")
    code, _, err = _run(["scan", "--profile", "peg", "--param", "x=0", "--param", "y=0.5",
                         "--poses", str(poses), "--from", "1", "--to", "0", "--step", "0.1",
                         "--csv", str(tmp_path / "o.csv")], capsys)
    assert code == 2 and "not both" in err
    code, _, err = _run(["scan", "--profile", "peg", "--param", "x=0", "--param", "y=0.5",
                         "--csv", str(tmp_path / "o.csv")], capsys)
    assert code == 2 and "--poses" in err
    bad = tmp_path / "bad.csv"
    bad.write_text("x,heading\n0,1\n")
    code, _, err = _run(["scan", "--profile", "peg", "--param", "x=0", "--param", "y=0.5",
                         "--poses", str(bad), "--csv", str(tmp_path / "o.csv")], capsys)
    assert code == 2 and "y" in err


def test_plot_of_a_whisking_scan_is_drawn_against_the_heading(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    poses = tmp_path / "whisk.csv"
    lines = ["x,y,heading"] + [f"0,0,{math.pi / 2 - 0.3 + 0.03 * i!r}" for i in range(41)]
    poses.write_text("\n".join(lines) + "\n")
    png = tmp_path / "whisk.png"
    code, _, err = _run(
        ["scan", "--profile", "peg", "--param", "x=-0.3", "--param", "y=0.6", "--param", "r=0.04",
         "--taper", "0.0667", "--curvature", "1,0.5", "--poses", str(poses), "--csv",
         str(tmp_path / "o.csv"), "--plot", str(png)],
        capsys,
    )
    assert code == 0, err
    assert png.stat().st_size > 10_000


def test_plot_runs_draws_a_peg_and_heading_axis():
    pytest.importorskip("matplotlib")
    from vibrissa_ros.core import FootPose, GeneralWhiskerModel, Peg, WhiskerShape
    from vibrissa_ros.core.scan import run_poses
    from vibrissa_ros.scan.plots import PlotRun, plot_runs

    peg = Peg(-0.3, 0.6, 0.04)
    poses = [FootPose(0.0, 0.0, math.pi / 2 - 0.3 + 0.03 * i) for i in range(41)]
    scan = run_poses(peg, poses, model=GeneralWhiskerModel(WhiskerShape(0.0667, 1.0, 0.5)))
    fig = plot_runs([PlotRun("general", scan.states, scan.events, scan.event_steps)], peg,
                    abscissa="heading")
    ax = fig.axes["m0"]
    assert ax.get_xlabel() == "foot heading [rad]"
    lines = [line for line in ax.get_lines() if line.get_gid() == "general:m0:0"]
    assert np.allclose(lines[0].get_xdata(), [p.heading for p in poses])
    assert [line for line in fig.axes["sketch"].get_lines() if line.get_gid() == "obstacle"]
    fig.figure.clf()
