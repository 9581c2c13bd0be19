"""`vibrissa scan --scene S.yaml --poses P.csv` with 3D poses: the 3D whisker's scan and files."""

import csv
import json
import math

import pytest

from vibrissa_ros.cli import main

#: the whisker along +y (the paper's set-up): a quarter turn about z
TURN = (math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4))
BALL = "obstacles:\n  - {type: sphere, name: ball, center: [0.0, 0.6, 0.04], r: 0.1}\n"
CATENARY = "obstacles:\n  - {type: catenary, p0: 0.3, c: 0.5}\n"
TWO_PEGS = """
obstacles:
  - {type: peg, name: near, x: 0.0, y: 0.45, r: 0.04}
  - {type: peg, name: far, x: 0.105, y: 0.85, r: 0.04}
"""
COLUMNS = ("x,y,z,qw,qx,qy,qz,contacts,kind,obstacle,s1,f,fx,fy,fz,mx,my,mz,contact_x,"
           "contact_y,contact_z,tip_x,tip_y,tip_z").split(",")
#: the planar scan's event kinds and the 3D ones (doc/guide/cli.md, "3D scans")
KINDS = {"touch", "release", "tip", "tangential", "snap", "reset"}


def _sweep(a, b, n, back=False):
    xs = [a + (b - a) * i / (n - 1) for i in range(n)]
    return xs + xs[-2::-1] if back else xs


def _poses3d(path, xs, q=TURN, z=0.0):
    with open(path, "w") as stream:
        stream.write("x,y,z,qw,qx,qy,qz\n")
        for x in xs:
            stream.write(",".join(repr(float(v)) for v in (x, 0.0, z, *q)) + "\n")
    return str(path)


def _poses2d(path, xs):
    with open(path, "w") as stream:
        stream.write("x,y,heading\n")
        for x in xs:
            stream.write(f"{x!r},0.0,{math.pi / 2!r}\n")
    return str(path)


def _dicts(path):
    with open(path, newline="") as stream:
        return list(csv.DictReader(stream))


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_a_straight_whisker_past_a_sphere(tmp_path):
    """Touch and release, force rows (pushed down and aside), contacts and events consistent."""
    scene = _write(tmp_path, "ball.yaml", BALL)
    poses = _poses3d(tmp_path / "p.csv", _sweep(0.3, -0.3, 25))
    out, ev, jl, png = (str(tmp_path / n) for n in ("o.csv", "e.json", "c.jsonl", "p.png"))
    assert main(["scan", "--scene", scene, "--poses", poses, "--csv", out, "--events", ev,
                 "--contacts", jl, "--plot", png]) == 0
    with open(out, newline="") as stream:
        assert next(csv.reader(stream)) == COLUMNS
    rows = _dicts(out)
    lines = [json.loads(line) for line in open(jl).read().splitlines()]
    assert len(rows) == len(lines) == 25
    loaded = [r for r in rows if r["contacts"] != "0"]
    assert 0 < len(loaded) < len(rows)
    for row, line in zip(rows, lines):
        assert "nan" not in ",".join(row.values()).lower()
        assert [float(row[k]) for k in ("x", "y", "z", "qw", "qx", "qy", "qz")] == pytest.approx(
            [line[k] for k in ("x", "y", "z", "qw", "qx", "qy", "qz")], abs=0.0)
        assert int(row["contacts"]) == len(line["contacts"])
        if row["contacts"] == "0":
            assert all(row[k] == "" for k in ("kind", "obstacle", "s1", "f", "contact_x",
                                              "contact_y", "contact_z"))
            assert all(float(row[k]) == 0.0 for k in ("fx", "fy", "fz", "mx", "my", "mz"))
            assert float(row["tip_y"]) == pytest.approx(1.0)
            continue
        c = line["contacts"][0]
        assert (row["kind"], row["obstacle"]) == (c["kind"], "ball") and c["kind"] == "side"
        assert float(row["s1"]) == c["s"] and float(row["f"]) == c["f"] > 0.0
        assert [float(row[f"contact_{k}"]) for k in "xyz"] == c["point"]
        assert [float(row[f"f{k}"]) for k in "xyz"] == pytest.approx(
            [sum(d["force"][j] for d in line["contacts"]) for j in range(3)], abs=1e-14)
        # the moment about the base point of the contact forces
        base = [float(row[k]) for k in "xyz"]
        r = [c["point"][j] - base[j] for j in range(3)]
        f = c["force"]
        m = (r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0])
        assert [float(row[f"m{k}"]) for k in "xyz"] == pytest.approx(m, abs=1e-12)
        # the ball is above the whisker's plane: it pushes the whisker down
        assert float(row["fz"]) < 0.0
    events = json.loads(open(ev).read())
    assert [e["kind"] for e in events] == ["touch", "release"]
    for e in events:
        assert e["obstacle"] == "ball" and 0.0 < e["s"] < 1.0
        assert set("x y z qw qx qy qz".split()) <= set(e)
    # touch and release where the straight whisker grazes the ball: |x| = sqrt(0.1^2 - 0.04^2)
    assert events[0]["x"] == pytest.approx(math.sqrt(0.01 - 0.0016), abs=1e-9)
    assert events[1]["x"] == pytest.approx(-math.sqrt(0.01 - 0.0016), abs=1e-9)
    assert open(png, "rb").read(8) == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("text,sweep", [
    (CATENARY, (1.0, -0.3, 66)),   # one profile: the planar scan runs the exact closed forms
    (TWO_PEGS, (0.3, -0.5, 41)),   # two pegs: the planar scene tracker, up to two contacts
])
def test_the_planar_special_case_gives_the_planar_scan(tmp_path, text, sweep):
    """Base z = 0, rotation about z, prisms: (fx, fy, mz) = the planar (fx, fy, m0)."""
    scene = _write(tmp_path, "scene.yaml", text)
    xs = _sweep(*sweep, back=True)
    flat, space = tmp_path / "flat.csv", tmp_path / "space.csv"
    ev2, ev3 = tmp_path / "flat.json", tmp_path / "space.json"
    assert main(["scan", "--scene", scene, "--poses", _poses2d(tmp_path / "p2.csv", xs),
                 "--csv", str(flat), "--events", str(ev2)]) == 0
    assert main(["scan", "--scene", scene, "--poses", _poses3d(tmp_path / "p3.csv", xs),
                 "--csv", str(space), "--events", str(ev3)]) == 0
    planar, rows = _dicts(flat), _dicts(space)
    assert len(planar) == len(rows) == len(xs)
    for p, r in zip(planar, rows):
        assert float(r["fx"]) == pytest.approx(float(p["fx"]), abs=1e-9)
        assert float(r["fy"]) == pytest.approx(float(p["fy"]), abs=1e-9)
        assert float(r["mz"]) == pytest.approx(float(p["m0"]), abs=1e-9)
        assert max(abs(float(r[k])) for k in ("fz", "mx", "my")) <= 1e-12
        assert r["contacts"] == p["contacts"]
        if p["contacts"] != "0":
            assert float(r["s1"]) == pytest.approx(float(p["s1"]), abs=1e-9)
    flat_events, events = json.loads(ev2.read_text()), json.loads(ev3.read_text())
    assert {e["kind"] for e in events} <= KINDS
    assert [e["kind"] for e in events] == [e["kind"] for e in flat_events]
    assert len({e["kind"] for e in events}) >= 2
    for e, f in zip(events, flat_events):
        assert e["x"] == pytest.approx(f["x"], abs=1e-9)
        assert (e["y"], e["z"], e["qx"], e["qy"]) == (0.0, 0.0, 0.0, 0.0)


def test_a_coarser_points_tolerance_moves_the_rows_within_it(tmp_path):
    """--points-tolerance: the same contacts and events, the loads within the tolerance."""
    scene = _write(tmp_path, "ball.yaml", BALL)
    poses = _poses3d(tmp_path / "p.csv", _sweep(0.3, -0.3, 25))
    keys = ("fx", "fy", "fz", "mx", "my", "mz", "tip_x", "tip_y", "tip_z")
    runs = {}
    for tolerance in ("1e-11", "1e-6"):
        out, ev = str(tmp_path / f"{tolerance}.csv"), str(tmp_path / f"{tolerance}.json")
        assert main(["scan", "--scene", scene, "--poses", poses, "--csv", out, "--events", ev,
                     "--points-tolerance", tolerance]) == 0
        rows = _dicts(out)
        runs[tolerance] = ([r["contacts"] for r in rows],
                           [[float(r[k]) for k in keys] for r in rows],
                           [e["kind"] for e in json.loads(open(ev).read())])
    (contacts, exact, events), (coarse_contacts, coarse, coarse_events) = runs.values()
    assert coarse_contacts == contacts and coarse_events == events == ["touch", "release"]
    largest = max(abs(v) for row in exact for v in row[:6])
    error = max(abs(a - b) for r, q in zip(exact, coarse) for a, b in zip(r, q))
    assert 0.0 < error < 1e-6 * largest


def _run(args, capsys):
    try:
        code = main(["scan", *args])
    except SystemExit as exc:  # argparse
        code = exc.code
    return code, capsys.readouterr().err


@pytest.mark.parametrize("scene,rows,extra,needles", [
    # a non-unit quaternion: its line
    (BALL, ["0.3,0,0,1,0,0,0", "0.2,0,0,1,0,0,0.1"], [], ["p.csv, line 3", "unit quaternion"]),
    # non-finite values
    (BALL, ["nan,0,0,1,0,0,0"], [], ["p.csv, line 2", "x = nan must be finite"]),
    (BALL, ["0.3,0,0,1,0,0,0", "0.3,0,inf,1,0,0,0"], [], ["line 3", "z = inf must be finite"]),
    (BALL, ["0.3,0,0,1,zero,0,0"], [], ["line 2", "not a number"]),
    # the scene: an axis of length 0, an unknown key, friction
    ("obstacles:\n  - {type: cylinder, point: [0, 0.5, 0], axis: [0, 0, 0], r: 0.1}\n",
     ["0.3,0,0,1,0,0,0"], [], ["bad.yaml: ", "axis"]),
    ("obstacles:\n  - {type: sphere, center: [0, 0.5, 0], r: 0.1, colour: red}\n",
     ["0.3,0,0,1,0,0,0"], [], ["bad.yaml: ", "colour"]),
    ("friction: 0.2\nobstacles:\n  - {type: peg, x: 0, y: 0.5, r: 0.1}\n",
     ["0.3,0,0,1,0,0,0"], [], ["bad.yaml: ", "frictionless"]),
    (BALL, ["0.3,0,0,1,0,0,0"], ["--friction", "0.1"], ["--friction", "frictionless"]),
    # the base inside an obstacle at the first pose: the tracker's refusal, with its line
    (BALL, ["0.0,0.6,0.04,1,0,0,0", "0.3,0,0,1,0,0,0"], [], ["p.csv, line 2", "inside ball"]),
    # the whisker's shape given twice
    (BALL, ["0.3,0,0,1,0,0,0"], ["--curvature=1,0", "--parabola", "0.5"],
     ["--curvature", "--parabola", "not both"]),
    (BALL, ["0.3,0,0,1,0,0,0"], ["--poisson", "0.7"], ["--poisson", "[0, 0.5]"]),
    (BALL, ["0.3,0,0,1,0,0,0"], ["--points-tolerance", "1e-4"],
     ["--points-tolerance 0.0001: need a number", "1e-12 to 1e-06"]),
    # options of the planar scan
    (BALL, ["0.3,0,0,1,0,0,0"], ["--from", "0", "--to", "1", "--step", "0.1"], ["--from"]),
    (BALL, ["0.3,0,0,1,0,0,0"], ["--model", "rigid"], ["--model elastica"]),
])
def test_bad_input_exits_2_with_one_line(tmp_path, capsys, scene, rows, extra, needles):
    scene_path = _write(tmp_path, "bad.yaml", scene)
    poses = _write(tmp_path, "p.csv", "x,y,z,qw,qx,qy,qz\n" + "\n".join(rows) + "\n")
    out = tmp_path / "o.csv"
    code, err = _run(["--scene", scene_path, "--poses", poses, *extra, "--csv", str(out)],
                     capsys)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert all(n in lines[0] for n in needles), err
    assert not out.exists()


@pytest.mark.parametrize("args,needles", [
    # a 3D poses file needs a scene; --parabola and --poisson need a 3D run
    (["--profile", "peg", "--param", "x=0", "--param", "y=0.5", "--param", "r=0.1",
      "--poses", "P3"], ["3D poses", "--scene"]),
    (["--scene", "S", "--poses", "P2", "--parabola", "0.5"], ["--parabola", "3D run"]),
    (["--scene", "S", "--poses", "P2", "--points-tolerance", "1e-8"],
     ["--points-tolerance applies to the 3D whisker"]),
    # a poses file with some 3D columns names the missing ones
    (["--scene", "S", "--poses", "PQ"], ["missing column(s) qz"]),
    # a 3D scene with planar poses says how to run it
    (["--scene", "S", "--poses", "P2"], ["3D obstacles", "x,y,z,qw,qx,qy,qz"]),
])
def test_mismatched_runs_exit_2_with_one_line(tmp_path, capsys, args, needles):
    files = {"S": _write(tmp_path, "ball.yaml", BALL),
             "P3": _poses3d(tmp_path / "p3.csv", [0.3]),
             "P2": _poses2d(tmp_path / "p2.csv", [0.3]),
             "PQ": _write(tmp_path, "pq.csv", "x,y,z,qw,qx,qy\n0,0,0,1,0,0\n")}
    code, err = _run([files.get(a, a) for a in args] + ["--csv", str(tmp_path / "o.csv")],
                     capsys)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert all(n in lines[0] for n in needles), err


def test_a_pose_that_cannot_be_followed_stops_the_scan_naming_its_line(tmp_path, capsys):
    """
    As the planar scene scan: status 1, one line naming the pose, nothing written.

    The whisker runs into a block's corner (edges are not modelled in 3D) and cannot be re-placed
    there: the unloaded whisker would cut the block.
    """
    scene = _write(tmp_path, "block.yaml", "obstacles:\n  - {type: polygon, name: block, "
                   "vertices: [[-0.1, 0.6], [0.3, 0.6], [0.3, 0.9], [-0.1, 0.9]]}\n")
    poses = _poses3d(tmp_path / "p.csv", _sweep(-0.4, 0.2, 9))
    out = tmp_path / "o.csv"
    code, err = _run(["--scene", scene, "--poses", poses, "--csv", str(out)], capsys)
    lines = err.strip().splitlines()
    assert code == 1 and len(lines) == 1, err
    assert "p.csv, line " in lines[0]
    assert not out.exists()
