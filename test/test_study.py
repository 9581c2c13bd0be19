"""Study files: expansion into tasks, seeded draws, and bad files refused with one line before anything runs."""

import math
import re
from pathlib import Path

import pytest

pytest.importorskip("yaml")

from vibrissa_ros.cli import main
from vibrissa_ros.study import StudyError, load_study, parse_study, place_obstacle
from vibrissa_ros.core import make_profile

ROOT = Path(__file__).resolve().parents[1]

GOOD = """
seed: 5
whisker: {model: [elastica, rigid], spring_stiffness: [2, 3]}
obstacles:
  - profile: parabola
    params: {p0: [0.2, 0.3], k: 1}
  - profile: circle
    samples: 3
    params: {p0: {uniform: [0.1, 0.5]}, R: {loguniform: [1.0, 3.0]}}
placement: {x: 0.1, rotation_deg: {uniform: [-10, 10]}, samples: 2}
motion:
  - {from: 2, to: -2, step: 0.1, back: [false, true]}
  - {from: -2, to: 2, step: 0.1}
noise: {force_stddev: 0.01}
"""


def test_a_study_expands_into_the_product_of_its_blocks():
    study = parse_study(GOOD)
    # whiskers: elastica + rigid x 2 stiffnesses = 3; obstacles 2 + 3 = 5; placements 2; motions 3
    assert len(study.tasks) == 3 * 5 * 2 * 3
    assert [t.index for t in study.tasks] == list(range(90))
    assert study.param_names == ("p0", "k", "R")
    assert {(t.model, t.spring_stiffness) for t in study.tasks} == {("elastica", None), ("rigid", 2.0), ("rigid", 3.0)}
    assert study.poses == sum(len(t.grid()) for t in study.tasks)
    assert all(t.x == 0.1 and -10 <= t.rotation_deg <= 10 for t in study.tasks)
    assert all(t.noise.force_stddev == 0.01 for t in study.tasks)
    assert len({t.noise_seed for t in study.tasks}) == 90  # every task its own noise stream


def test_random_draws_are_seeded_and_shared_across_whiskers_and_motions():
    a, b = parse_study(GOOD), parse_study(GOOD)
    assert a.tasks == b.tasks
    other = parse_study(GOOD.replace("seed: 5", "seed: 6"))
    assert [t.params for t in other.tasks] != [t.params for t in a.tasks]
    circles = {(t.model, t.spring_stiffness): [] for t in a.tasks}
    for t in a.tasks:
        if t.profile == "circle":
            circles[(t.model, t.spring_stiffness)].append((t.params, t.rotation_deg))
    first = list(circles.values())[0]
    assert len(set(p for p, _ in first)) == 3  # three random circles
    assert all(v == first for v in circles.values())  # the same objects and placements for every whisker


def test_placement_turns_about_the_apex_then_moves():
    base = make_profile("parabola", {"p0": 0.3, "k": 2.0})
    placed = place_obstacle(base, 0.25, -0.05, 30.0)
    apex = placed.point(math.radians(30.0))  # the apex's tangent turns with the obstacle
    assert apex == pytest.approx((0.25, 0.25), abs=1e-15)
    assert place_obstacle(base, 0.0, 0.0, 0.0) is base


def test_the_example_study_is_a_few_hundred_tasks():
    study = load_study(str(ROOT / "config" / "study_small.yaml"))
    assert 200 <= len(study.tasks) <= 500


BAD = [
    ("unknown key", "obstacles: [{profile: circle, params: {p0: 0.3, R: 2}}]\nmotion: {from: 1, to: -1, step: 0.1}\n"
     "colour: red\n", "unknown key 'colour'"),
    ("unknown parameter", "obstacles: [{profile: circle, params: {p0: 0.3, r: 2}}]\nmotion: {from: 1, to: -1, step: 0.1}\n",
     "obstacles[0].params: unknown key 'r'; allowed: p0, R"),
    ("empty list", "obstacles: [{profile: circle, params: {p0: [], R: 2}}]\nmotion: {from: 1, to: -1, step: 0.1}\n",
     "obstacles[0].params.p0 is an empty list"),
    ("empty random range", "obstacles: [{profile: circle, params: {p0: {uniform: [0.4, 0.2]}, R: 2}}]\n"
     "motion: {from: 1, to: -1, step: 0.1}\n", "is an empty range"),
    ("wrong type", "obstacles: [{profile: circle, params: {p0: 0.3, R: 2}}]\nmotion: {from: 1, to: -1, step: fast}\n",
     "motion.step = 'fast' must be a number"),
    ("zero step", "obstacles: [{profile: circle, params: {p0: 0.3, R: 2}}]\nmotion: {from: 1, to: -1, step: 0}\n",
     "motion.step = 0.0 must be > 0"),
    ("bool as number", "obstacles: [{profile: circle, params: {p0: 0.3, R: true}}]\nmotion: {from: 1, to: -1, step: 0.1}\n",
     "must be a number"),
    ("out of range", "obstacles: [{profile: circle, params: {p0: 1.5, R: 2}}]\nmotion: {from: 1, to: -1, step: 0.1}\n",
     "p0 = 1.5 is not allowed"),
    ("random draw out of range", "obstacles: [{profile: circle, samples: 50, params: {p0: 0.3, R: {uniform: [0.2, 2]}}}]\n"
     "motion: {from: 1, to: -1, step: 0.1}\n", "must exceed 1"),
    ("unknown profile", "obstacles: [{profile: square}]\nmotion: {from: 1, to: -1, step: 0.1}\n", "allowed: parabola"),
    ("unknown model", "whisker: {model: steel}\nobstacles: [{profile: parabola, params: {p0: 0.3}}]\n"
     "motion: {from: 1, to: -1, step: 0.1}\n", "whisker.model = 'steel' is not allowed"),
    ("stiffness without rigid", "whisker: {spring_stiffness: 3}\nobstacles: [{profile: parabola, params: {p0: 0.3}}]\n"
     "motion: {from: 1, to: -1, step: 0.1}\n", "applies to the rigid model"),
    ("samples without random", "obstacles: [{profile: parabola, samples: 3, params: {p0: 0.3}}]\n"
     "motion: {from: 1, to: -1, step: 0.1}\n", "samples > 1 needs a random parameter"),
    ("missing motion", "obstacles: [{profile: parabola, params: {p0: 0.3}}]\n", "key 'motion' is required"),
    ("negative noise", "obstacles: [{profile: parabola, params: {p0: 0.3}}]\nmotion: {from: 1, to: -1, step: 0.1}\n"
     "noise: {force_stddev: -1}\n", "noise.force_stddev = -1.0 must be >= 0"),
    ("not a mapping", "- 1\n- 2\n", "a study is a YAML mapping"),
    ("not YAML", "obstacles: [{profile: parabola\n", "not a YAML study file"),
]


@pytest.mark.parametrize("case", BAD, ids=[c[0] for c in BAD])
def test_a_bad_study_is_refused_with_one_line_before_anything_runs(case, tmp_path, capsys):
    _, text, expected = case
    with pytest.raises(StudyError) as err:
        parse_study(text)
    assert expected in str(err.value)
    path = tmp_path / "study.yaml"
    path.write_text(text)
    out = tmp_path / "out"
    code = main(["batch", str(path), "--out", str(out)])
    stderr = capsys.readouterr().err
    assert code == 2
    assert len(stderr.strip().splitlines()) == 1 and expected in stderr
    assert not out.exists()


def test_a_missing_study_file_is_one_line(tmp_path, capsys):
    assert main(["batch", str(tmp_path / "nope.yaml"), "--out", str(tmp_path / "o")]) == 2
    assert "no such file" in capsys.readouterr().err


def test_dry_run_prints_the_size(capsys):
    assert main(["batch", str(ROOT / "config" / "study_small.yaml"), "--out", "unused", "--dry-run"]) == 0
    assert "336 tasks" in capsys.readouterr().out


def test_the_readme_shows_the_example_study():
    import re

    section = (ROOT / "README.md").read_text().split("## Studies at scale", 1)[1]
    shown = re.search(r"```yaml\n(.+?)```", section, re.S).group(1)
    assert parse_study(shown).tasks == load_study(str(ROOT / "config" / "study_small.yaml")).tasks


def test_scan_place_takes_three_numbers(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["scan", "--profile", "parabola", "--param", "p0=0.3", "--place", "0,1", "--from", "1", "--to", "-1",
              "--step", "0.5", "--csv", str(tmp_path / "x.csv")])
    assert exc.value.code == 2 and "is not X,Y,DEG" in capsys.readouterr().err


def test_out_must_be_a_new_or_a_study_directory(tmp_path, capsys):
    study = tmp_path / "s.yaml"
    study.write_text("obstacles: [{profile: parabola, params: {p0: 0.3}}]\nmotion: {from: 2, to: -2, step: 0.5}\n")
    (tmp_path / "file").write_text("x")
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "notes.txt").write_text("mine")
    for out, expected in (("file", "is a file"), ("full", "is not a study dataset")):
        assert main(["batch", str(study), "--out", str(tmp_path / out), "--quiet"]) == 2
        assert expected in capsys.readouterr().err
    assert (tmp_path / "full" / "notes.txt").read_text() == "mine" and len(list((tmp_path / "full").iterdir())) == 1


def test_whisker_geometry_axes_pick_the_general_solver_and_are_refused_for_the_rigid_model():
    from vibrissa_ros.core.general import GeneralWhiskerModel
    from vibrissa_ros.core.models import ElasticaModel

    study = parse_study(
        "whisker: {taper: [1, 0.0667], curvature_k0: 0.5, curvature_k1: -0.2}\n"
        "obstacles: [{profile: parabola, params: {p0: 0.3}}]\nmotion: {from: 2, to: -2, step: 0.5}\n"
    )
    shapes = [(t.taper, t.curvature_k0, t.curvature_k1) for t in study.tasks]
    assert shapes == [(1.0, 0.5, -0.2), (0.0667, 0.5, -0.2)]
    assert all(isinstance(t.whisker_model(), GeneralWhiskerModel) for t in study.tasks)
    assert "--taper=0.0667 --curvature=0.5,-0.2" in study.tasks[1].scan_command()
    paper = parse_study("obstacles: [{profile: parabola, params: {p0: 0.3}}]\nmotion: {from: 2, to: -2, step: 0.5}\n")
    assert isinstance(paper.tasks[0].whisker_model(), ElasticaModel)
    assert "--taper" not in paper.tasks[0].scan_command()
    for bad, words in [
        ("whisker: {model: rigid, taper: 0.5}", "rigid model is a straight rod"),
        ("whisker: {taper: 1.5}", "(0, 1]"),
        ("whisker: {taper: 0}", "must be > 0"),
    ]:
        with pytest.raises(StudyError, match=re.escape(words)):
            parse_study(bad + "\nobstacles: [{profile: parabola, params: {p0: 0.3}}]\nmotion: {from: 2, to: -2, step: 0.5}\n")
