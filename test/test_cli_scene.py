"""`vibrissa scan --scene`: the scene contract (CSV, contacts column, events, --contacts, plot)."""

import csv
import json
import subprocess
import sys

import pytest

from vibrissa_ros.cli import main

PEG_SCENE = """
obstacles:
  - {type: peg, x: 0.0, y: 0.45, r: 0.05}
"""
PARABOLA_SCENE = """
obstacles:
  - {type: parabola, p0: 0.3, k: 1.5, placement: {x: 0.1, y: 0.0, rotation: 0.2}}
"""


def _rows(path):
    with open(path, newline="") as stream:
        return list(csv.reader(stream))


@pytest.mark.parametrize("text,profile", [
    (PEG_SCENE, ["--profile", "peg", "--param", "x=0", "--param", "y=0.45", "--param", "r=0.05"]),
])
def test_a_one_obstacle_scene_gives_the_profile_numbers(tmp_path, text, profile):
    scene = tmp_path / "scene.yaml"
    scene.write_text(text)
    sweep = ["--from", "0.5", "--to", "-0.6", "--step", "0.01", "--back"]
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert main(["scan", *profile, *sweep, "--csv", str(a)]) == 0
    assert main(["scan", "--scene", str(scene), *sweep, "--csv", str(b),
                 "--contacts", str(tmp_path / "c.jsonl")]) == 0
    ra, rb = _rows(a), _rows(b)
    assert rb[0] == ra[0] + ["contacts"]
    assert len(ra) == len(rb)
    for x, y in zip(ra[1:], rb[1:]):
        assert y[:-1] == x  # identical numbers, digit for digit
        assert y[-1] == ("0" if x[1] == "0" else "1")


def test_placed_profile_scene_equals_profile_with_the_same_placement(tmp_path):
    from vibrissa_ros.core.scan import run_scan
    from vibrissa_ros.scan.scene_file import load_scene

    scene = load_scene(PARABOLA_SCENE)
    profile = scene.single_profile()
    path = tmp_path / "s.yaml"
    path.write_text(PARABOLA_SCENE)
    out = tmp_path / "b.csv"
    assert main(["scan", "--scene", str(path), "--from", "1.5", "--to", "-1.0", "--step", "0.05",
                 "--csv", str(out)]) == 0
    ref = run_scan(profile, [1.5 - 0.05 * i for i in range(51)])
    rows = _rows(out)[1:]
    for row, st in zip(rows, ref.states):
        assert float(row[6]) == st.fx and float(row[8]) == st.m0


def test_two_pegs_write_contacts_events_and_a_figure(tmp_path):
    csv_path, ev, jl, png = (tmp_path / n for n in ("s.csv", "e.json", "c.jsonl", "s.png"))
    assert main(["scan", "--scene", "config/scene_two_pegs.yaml", "--from", "-0.4", "--to",
                 "0.2", "--step", "0.01", "--csv", str(csv_path), "--events", str(ev),
                 "--contacts", str(jl), "--plot", str(png)]) == 0
    rows = _rows(csv_path)
    counts = [int(r[-1]) for r in rows[1:]]
    assert max(counts) == 2 and counts[0] == 0
    lines = [json.loads(line) for line in jl.read_text().splitlines()]
    assert len(lines) == len(rows) - 1
    for row, line in zip(rows[1:], lines):
        assert len(line["contacts"]) == int(row[-1])
        assert float(row[0]) == line["x0"]
        total = sum(c["fx"] for c in line["contacts"])
        assert abs(total - float(row[6])) < 1e-12
        for c in line["contacts"]:
            assert c["kind"] in ("side", "tip", "corner") and c["state"] in ("stick", "slip")
    kinds = [e["kind"] for e in json.loads(ev.read_text())]
    assert kinds[:2] == ["touch", "touch"] and "release" in kinds
    assert png.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("text,needle", [
    ("obstacles:\n  - {type: peg, x: 0, y: 0.5, r: -1}\n", "r"),
    ("friction: -0.1\nobstacles:\n  - {type: peg, x: 0, y: 0.5, r: 0.1}\n", "friction"),
    ("obstacles:\n  - {type: polygon, vertices: [[0, 0.5], [1, 1.5], [1, 0.5], [0, 1.5]]}\n",
     "intersect"),
    ("obstacles:\n  - {type: curve, points: [[0, 1], [-1, 1.2], [1, 1.1]]}\n", "increasing"),
    ("obstacles:\n  - {type: peg, x: 0.0, y: 0.5, r: 0.2}\n", "inside"),
    ("obstacles:\n  - {type: peg, x: 0.05, y: 0.0, r: 0.1}\n", "foot"),
])
def test_bad_scenes_exit_2_with_one_line(tmp_path, text, needle):
    scene = tmp_path / "bad.yaml"
    scene.write_text(text)
    proc = subprocess.run(
        [sys.executable, "-m", "vibrissa_ros", "scan", "--scene", str(scene), "--from", "0",
         "--to", "0.1", "--step", "0.1", "--csv", str(tmp_path / "o.csv")],
        capture_output=True, text=True)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], proc.stderr


def test_friction_overrides_the_scene_coefficient_and_obstacles_keep_their_own(tmp_path):
    """
    --friction MU is the scene file with ``friction: MU``, digit for digit.

    The scene's peg1 keeps its own 0.3.
    """
    text = open("config/scene_two_pegs.yaml").read()
    assert "friction: 0.0\n" in text
    given = tmp_path / "given.yaml"
    given.write_text(text.replace("friction: 0.0\n", "friction: 0.2\n"))
    sweep = ["--from", "-0.1", "--to", "0.2", "--step", "0.02"]
    a, b, c = (tmp_path / n for n in ("a.csv", "b.csv", "c.csv"))
    assert main(["scan", "--scene", "config/scene_two_pegs.yaml", "--friction", "0.2", *sweep,
                 "--csv", str(a)]) == 0
    assert main(["scan", "--scene", str(given), *sweep, "--csv", str(b)]) == 0
    assert main(["scan", "--scene", "config/scene_two_pegs.yaml", *sweep, "--csv", str(c)]) == 0
    assert _rows(a) == _rows(b) and _rows(a) != _rows(c)
    # every obstacle has its own coefficient: the override changes nothing
    scene = tmp_path / "own.yaml"
    scene.write_text(text.replace("r: 0.04}", "r: 0.04, friction: 0.0}"))
    assert main(["scan", "--scene", str(scene), "--friction", "0.2", *sweep, "--csv", str(b)]) == 0
    assert _rows(b) == _rows(c)


@pytest.mark.parametrize("args,needle", [
    (["--profile", "parabola", "--param", "p0=0.3", "--friction", "0.1"],
     "--friction applies to --scene"),
    (["--scene", "config/scene_two_pegs.yaml", "--friction", "-0.1"], "'-0.1'"),
])
def test_friction_is_refused_where_it_does_not_apply(tmp_path, capsys, args, needle):
    try:
        code = main(["scan", *args, "--from", "0", "--to", "0.1", "--step", "0.1", "--csv",
                     str(tmp_path / "o.csv")])
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and needle in err, err
