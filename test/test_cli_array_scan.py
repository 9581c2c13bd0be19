"""`vibrissa scan --array A.yaml --scene S.yaml`: an array's run, its files and figures."""

import csv
import json
import math

import numpy as np
import pyarrow.parquet as pq
import pytest

from vibrissa_ros.cli import main
from vibrissa_ros.core.arrays import CosineWhisk, WhiskerArray, rat_array
from vibrissa_ros.core.arrays.tracker import ArrayTracker
from vibrissa_ros.core.rod3d import BasePose, Cylinder, Scene3D
from vibrissa_ros.scan.array_file import dump_array
from vibrissa_ros.scan.array_scan import ARRAY_COLUMNS, POINTS_TOLERANCE_KEY

#: the right pad's whiskers that hit the peg while whisking (RB1, RC1) and two that do not
NAMES = ("RB1", "RC1", "RC2", "RC5")
PEG = "obstacles:\n  - {type: cylinder, name: peg, point: [0.03, -0.016, 0.0], " \
      "axis: [0.0, 0.0, 1.0], r: 0.0015}\n"
SCENE = Scene3D((Cylinder((0.03, -0.016, 0.0), (0, 0, 1), 0.0015, "peg"),))
#: 8 Hz between -20 and +20 deg, half a period at 1 kHz: 63 ticks
WHISK = ["--whisk=8,-20,20", "--duration", "0.0625", "--rate", "1000"]
FLOATS = [c for c in ARRAY_COLUMNS if c not in ("tick", "whisker", "side", "row", "column",
                                                "contacts", "kind", "obstacle", "error")]


def _subset(names, side="right"):
    both = rat_array("both")
    return WhiskerArray(tuple(both[n] for n in names), "a few of the rat's whiskers")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Write the array and the scene, run the whisk once to CSV, Parquet and figures."""
    d = tmp_path_factory.mktemp("array")
    array, scene = str(d / "four.yaml"), str(d / "peg.yaml")
    dump_array(_subset(NAMES), array)
    (d / "peg.yaml").write_text(PEG)
    out = {"dir": d, "array": array, "scene": scene}
    for name in ("csv", "parquet"):
        out[name] = str(d / f"run.{name}")
        extra = ["--events", str(d / "ev.json"), "--plot", str(d / "fig")] if name == "csv" \
            else []
        assert main(["scan", "--array", array, "--scene", scene, *WHISK, "--out", out[name],
                     *extra]) == 0
    return out


def _main(args):
    """Run the command line; argparse's own refusals (SystemExit) give their status."""
    try:
        return main(args)
    except SystemExit as exc:
        return exc.code


def _rows(path):
    with open(path, newline="") as stream:
        return list(csv.DictReader(stream))


def _steps(names, ticks, head=lambda t: BasePose((0.0, 0.0, 0.0)), theta=None):
    whisk = CosineWhisk(8.0, math.radians(-20), math.radians(20))
    theta = theta or whisk.angle
    tracker = ArrayTracker(_subset(names), SCENE, head(ticks[0]), theta(ticks[0]))
    return [tracker.state] + [tracker.step(head(t), theta(t)) for t in ticks[1:]]


def _check_equal(rows, steps, names):
    assert len(rows) == len(names) * len(steps)
    for j, row in enumerate(rows):
        step, i = steps[j // len(names)], j % len(names)
        assert row["whisker"] == names[i] and int(row["tick"]) == j // len(names)
        assert int(row["contacts"]) == step.contacts[i]
        got = [float(row[k]) for k in ("fx", "fy", "fz", "mx", "my", "mz")]
        assert got == list(step.force_base[i]) + list(step.moment_base[i])
        got = [float(row[k]) for k in ("fx_world", "fy_world", "fz_world", "mx_world",
                                       "my_world", "mz_world")]
        assert got == list(step.force[i]) + list(step.moment[i])
        assert [float(row[f"tip_{a}"]) for a in "xyz"] == list(step.tip[i])
        assert float(row["protraction"]) == step.protraction[i]
        if step.contacts[i]:
            assert row["kind"] == step.contact_kind[i] and row["obstacle"] == "peg"
            assert float(row["s"]) == step.contact_s[i] and float(row["f"]) == step.contact_f[i]
            assert [float(row[f"contact_{a}"]) for a in "xyz"] == list(step.contact_point[i])
        else:
            assert all(row[k] == "" for k in ("kind", "obstacle", "s", "f", "contact_x",
                                              "contact_y", "contact_z"))


def test_a_whisk_equals_the_array_tracker(files):
    """Rows = whiskers x ticks, every value the tracker's; the peg is touched."""
    with open(files["csv"], newline="") as stream:
        assert tuple(next(csv.reader(stream))) == ARRAY_COLUMNS
    rows = _rows(files["csv"])
    times = [k / 1000.0 for k in range(63)]
    assert [float(r["t"]) for r in rows[::len(NAMES)]] == times
    _check_equal(rows, _steps(NAMES, times), NAMES)
    touched = {r["whisker"] for r in rows if r["contacts"] != "0"}
    assert {"RB1", "RC1"} <= touched and "RC5" not in touched
    assert all(r["side"] == "right" and r["error"] == "" for r in rows)
    assert "nan" not in open(files["csv"]).read().lower()
    events = json.load(open(files["dir"] / "ev.json"))
    assert {e["kind"] for e in events} >= {"touch"}
    assert {e["whisker"] for e in events if e["kind"] == "touch"} >= {"RB1", "RC1"}
    assert all(e.get("obstacle", "peg") == "peg" for e in events)


def test_parquet_holds_the_csv_rows_with_nulls(files):
    table = pq.read_table(files["parquet"])
    assert tuple(table.column_names) == ARRAY_COLUMNS
    rows = _rows(files["csv"])
    data = table.to_pylist()
    assert len(data) == len(rows)
    for got, row in zip(data, rows):
        for key in ARRAY_COLUMNS:
            if row[key] == "":
                assert got[key] is None, key
            elif key in FLOATS:
                assert got[key] == float(row[key]), key
            else:
                assert str(got[key]) == row[key], key
    assert table.schema.field("contacts").type == "int32"


def test_figures_are_written(files):
    for name in ("3d", "heatmap", "rows"):
        path = files["dir"] / f"fig-{name}.png"
        assert path.stat().st_size > 10_000, name


def test_a_head_path_with_protraction_columns(tmp_path, files):
    """The head moves and turns; RC1 has its own protraction, the others the shared one."""
    times = [0.001 * k for k in range(12)]

    def head(t):
        yaw = math.radians(200.0 * t)
        return BasePose((0.0, -0.1 * t, 0.0), (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)))

    def theta(t):
        return [-0.35 + 2.0 * t, -0.3 - 5.0 * t, -0.35 + 2.0 * t, -0.35 + 2.0 * t]

    poses = tmp_path / "p.csv"
    with open(poses, "w") as stream:
        stream.write("t,x,y,z,qw,qx,qy,qz,protraction,protraction_RC1,note\n")
        for t in times:
            h = head(t)
            values = (t, *h.position, *h.quaternion, theta(t)[0], theta(t)[1])
            stream.write(",".join(repr(float(v)) for v in values) + ",x\n")
    out = str(tmp_path / "o.csv")
    assert main(["scan", "--array", files["array"], "--scene", files["scene"], "--poses",
                 str(poses), "--out", out]) == 0
    rows = _rows(out)
    _check_equal(rows, _steps(NAMES, times, head, theta), NAMES)
    assert float(rows[len(NAMES) + 1]["protraction"]) == pytest.approx(-0.3 - 5.0 * 0.001)


def test_one_side_of_a_two_sided_array(tmp_path, files):
    array = str(tmp_path / "two.yaml")
    dump_array(_subset(("RC1", "LC1")), array)
    out = str(tmp_path / "o.csv")
    assert main(["scan", "--array", array, "--side", "left", "--scene", files["scene"],
                 "--whisk=8,-20,20", "--duration", "0.003", "--out", out]) == 0
    rows = _rows(out)
    assert len(rows) == 4 and {r["whisker"] for r in rows} == {"LC1"}
    assert {r["side"] for r in rows} == {"left"}


def _poses(tmp_path, text):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    return str(path)


HEADER = "t,x,y,z,qw,qx,qy,qz\n"
ROW0 = "0,0,0,0,1,0,0,0\n"


@pytest.mark.parametrize("make, args, words", [
    (lambda p: _poses(p, "t,x,y,z,qw\n0,0,0,0,1\n"), ["--poses"], ["bad.csv", "missing",
                                                                   "qx"]),
    (lambda p: _poses(p, HEADER + ROW0 + "0.001,0,0,zero,1,0,0,0\n"), ["--poses"],
     ["bad.csv, line 3", "z"]),
    (lambda p: _poses(p, HEADER + ROW0 + "0.001,0,0,0,1,1,0,0\n"), ["--poses"],
     ["bad.csv, line 3", "unit"]),
    (lambda p: _poses(p, HEADER + ROW0 + "0,0,0,0,1,0,0,0\n"), ["--poses"],
     ["bad.csv, line 3", "increase"]),
    (lambda p: _poses(p, "t,x,y,z,qw,qx,qy,qz,protraction_RZ9\n0,0,0,0,1,0,0,0,0\n"),
     ["--poses"], ["bad.csv", "protraction_RZ9"]),
    (lambda p: _poses(p, "t,x,y,z,qw,qx,qy,qz,protraction\n0,0,0,0,1,0,0,0,0\n"),
     ["--whisk=8,-20,20", "--poses"], ["bad.csv", "--whisk"]),
    (lambda p: _poses(p, HEADER + ROW0), ["--duration", "1", "--poses"], ["--duration"]),
    (None, ["--whisk=8,-20"], ["--whisk", "FREQ,RETRACTION,PROTRACTION"]),
    (None, ["--whisk=8,20,-20"], ["--whisk", "protraction"]),
    (None, [], ["--poses", "--whisk"]),
    (None, ["--whisk=8,-20,20", "--side", "left"], ["--side left", "no whisker"]),
    (None, ["--whisk=8,-20,20", "--rate", "0"], ["--rate", "0"]),
    (None, ["--whisk=8,-20,20", "--taper", "0.5"], ["--taper", "array file"]),
    (None, ["--whisk=8,-20,20", "--points-tolerance", "1e-3"],
     ["--points-tolerance 0.001: need a number", "1e-12 to 1e-06"]),
])
def test_bad_input_exits_2_with_one_line(tmp_path, files, capsys, make, args, words):
    args = list(args)
    if make is not None:
        args.append(make(tmp_path))
    code = _main(["scan", "--array", files["array"], "--scene", files["scene"], *args, "--out",
                 str(tmp_path / "o.csv")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    for word in words:
        assert word in err, err
    assert not (tmp_path / "o.csv").exists()


@pytest.mark.parametrize("args, words", [
    (["--out", "o.csv"], ["--scene"]),
    (["--scene", "SCENE", "--whisk=8,-20,20"], ["--out"]),
    (["--scene", "SCENE", "--whisk=8,-20,20", "--csv", "o.csv", "--out", "o.csv"], ["--out"]),
    (["--scene", "missing.yaml", "--whisk=8,-20,20", "--out", "o.csv"], ["missing.yaml"]),
])
def test_bad_options_exit_2(tmp_path, files, capsys, args, words):
    args = [files["scene"] if a == "SCENE" else a for a in args]
    assert main(["scan", "--array", files["array"], *args]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and all(w in err for w in words), err


def test_a_bad_array_file_names_the_file_whisker_and_key(tmp_path, files, capsys):
    bad = tmp_path / "bad_array.yaml"
    bad.write_text(open(files["array"]).read().replace("taper:", "tapper:", 1))
    assert main(["scan", "--array", str(bad), "--scene", files["scene"], "--whisk=8,-20,20",
                 "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert "bad_array.yaml" in err and "RB1" in err and "tapper" in err
    assert len(err.strip().splitlines()) == 1


def test_a_coarser_points_tolerance_gives_the_rows_to_its_error(tmp_path, files):
    # the same whisk at --points-tolerance 1e-8: the same contacts, the base wrenches within
    # ~1e-9 of the default run's largest
    out = str(tmp_path / "coarse.parquet")
    assert main(["scan", "--array", files["array"], "--scene", files["scene"], *WHISK,
                 "--points-tolerance", "1e-8", "--out", out]) == 0
    table = pq.read_table(out)
    # the file says how it was computed (the default's too)
    assert table.schema.metadata[POINTS_TOLERANCE_KEY.encode()] == b"1e-08"
    default = pq.read_table(files["parquet"]).schema.metadata
    assert default[POINTS_TOLERANCE_KEY.encode()] == b"1e-11"
    rows, exact = table.to_pylist(), _rows(files["csv"])
    assert [str(r["contacts"]) for r in rows] == [r["contacts"] for r in exact]
    keys = ("fx", "fy", "fz", "mx", "my", "mz")
    got = np.array([[float(r[k]) for k in keys] for r in rows])
    want = np.array([[float(r[k]) for k in keys] for r in exact])
    assert np.abs(want).max() > 0 and np.abs(got - want).max() <= 1e-9 * np.abs(want).max()


def test_array_options_need_an_array(capsys):
    assert main(["scan", "--profile", "parabola", "--param", "p0=0.3", "--from", "1", "--to",
                 "-1", "--step", "0.5", "--csv", "-", "--side", "left"]) == 2
    assert "--side applies to a whisker array" in capsys.readouterr().err
    assert main(["scan", "--profile", "parabola", "--param", "p0=0.3", "--from", "1", "--to",
                 "-1", "--step", "0.5", "--csv", "-", "--points-tolerance", "1e-8"]) == 2
    assert "--points-tolerance applies to the 3D whisker" in capsys.readouterr().err
    assert main(["scan", "--profile", "parabola", "--param", "p0=0.3", "--from", "1", "--to",
                 "-1", "--step", "0.5"]) == 2
    assert "--csv" in capsys.readouterr().err
    assert main(["scan", "--profile", "peg", "--param", "x=0", "--param", "y=0.5",
                 "--whisk=8,-20,20", "--from", "60", "--to", "120", "--step", "5", "--csv",
                 "-"]) == 2
    assert "X,Y" in capsys.readouterr().err


def test_the_whisk_start_is_the_retraction(files):
    rows = _rows(files["csv"])
    assert float(rows[0]["protraction"]) == pytest.approx(math.radians(-20))
    assert np.isclose(float(rows[-1]["protraction"]), CosineWhisk(
        8.0, math.radians(-20), math.radians(20)).angle(0.062))


def test_head_pose_is_yaw_then_pitch_then_roll():
    from vibrissa_ros.scan.array_scan import head_pose

    def rot(axis, deg):
        c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
        i, j = [(1, 2), (2, 0), (0, 1)][axis]
        R = np.eye(3)
        R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
        return R

    pose = head_pose((0.01, 0.02, 0.03), 30.0, -20.0, 10.0)
    want = rot(2, 30.0) @ rot(1, -20.0) @ rot(0, 10.0)
    assert np.abs(pose.rotation - want).max() < 1e-15
    assert pose.position == (0.01, 0.02, 0.03)


def test_workers_deal_the_whiskers_to_processes_with_the_same_rows(tmp_path, files, capsys):
    out = str(tmp_path / "two.csv")
    assert main(["scan", "--array", files["array"], "--scene", files["scene"], *WHISK,
                 "--workers", "2", "--out", out]) == 0
    assert open(out).read() == open(files["csv"]).read()
    capsys.readouterr()
    assert _main(["scan", "--array", files["array"], "--scene", files["scene"], *WHISK,
                  "--workers", "5", "--out", out]) == 2
    assert "--workers 5: need 1 to 4 (the array's 4 whiskers" in capsys.readouterr().err
    assert _main(["scan", "--array", files["array"], "--scene", files["scene"], *WHISK,
                  "--workers", "0", "--out", out]) == 2
    assert "--workers" in capsys.readouterr().err
    assert main(["scan", "--profile", "parabola", "--param", "p0=0.3", "--from", "1", "--to",
                 "-1", "--step", "0.5", "--csv", "-", "--workers", "2"]) == 2
    assert "--workers applies to a whisker array" in capsys.readouterr().err
