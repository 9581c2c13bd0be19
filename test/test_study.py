"""
Study files: expansion into tasks, seeded draws, bad files refused with one line.

A bad file is refused before anything runs.
"""

import math
import re
from pathlib import Path

import pytest

from vibrissa_ros.cli import main
from vibrissa_ros.studies.study import StudyError, load_study, parse_study, place_obstacle
from vibrissa_ros.core import make_profile

pytest.importorskip("yaml")  # the modules above import it only where a study file is read

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
    assert {(t.model, t.spring_stiffness) for t in study.tasks} == {("elastica", None),
                                                                    ("rigid", 2.0), ("rigid", 3.0)}
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
    # the same objects and placements for every whisker
    assert all(v == first for v in circles.values())


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
    ("unknown key", "obstacles: [{profile: circle, params: {p0: 0.3, R: 2}}]\nmotion: {from: 1, "
     "to: -1, step: 0.1}\ncolour: red\n", "unknown key 'colour'"),
    ("unknown parameter", "obstacles: [{profile: circle, params: {p0: 0.3, r: 2}}]\nmotion: "
     "{from: 1, to: -1, step: 0.1}\n",
     "obstacles[0].params: unknown key 'r'; allowed: p0, R"),
    ("empty list", "obstacles: [{profile: circle, params: {p0: [], R: 2}}]\nmotion: {from: 1, "
     "to: -1, step: 0.1}\n",
     "obstacles[0].params.p0 is an empty list"),
    ("empty random range", "obstacles: [{profile: circle, params: {p0: {uniform: "
     "[0.4, 0.2]}, R: 2}}]\nmotion: {from: 1, to: -1, step: 0.1}\n", "is an empty range"),
    ("wrong type", "obstacles: [{profile: circle, params: {p0: 0.3, R: 2}}]\nmotion: {from: 1, "
     "to: -1, step: fast}\n",
     "motion.step = 'fast' must be a number"),
    ("zero step", "obstacles: [{profile: circle, params: {p0: 0.3, R: 2}}]\nmotion: {from: 1, "
     "to: -1, step: 0}\n",
     "motion.step = 0.0 must be > 0"),
    ("bool as number", "obstacles: [{profile: circle, params: {p0: 0.3, R: true}}]\nmotion: "
     "{from: 1, to: -1, step: 0.1}\n",
     "must be a number"),
    ("out of range", "obstacles: [{profile: circle, params: {p0: 1.5, R: 2}}]\nmotion: {from: 1, "
     "to: -1, step: 0.1}\n",
     "p0 = 1.5 is not allowed"),
    ("random draw out of range", "obstacles: [{profile: circle, samples: 50, params: {p0: 0.3, R: "
     "{uniform: [0.2, 2]}}}]\nmotion: {from: 1, to: -1, step: 0.1}\n", "must exceed 1"),
    ("unknown profile", "obstacles: [{profile: square}]\nmotion: {from: 1, to: -1, step: 0.1}\n",
     "allowed: parabola"),
    ("unknown model", "whisker: {model: steel}\nobstacles: [{profile: parabola, "
     "params: {p0: 0.3}}]\nmotion: {from: 1, to: -1, step: 0.1}\n",
     "whisker.model = 'steel' is not allowed"),
    ("stiffness without rigid", "whisker: {spring_stiffness: 3}\nobstacles: [{profile: parabola, "
     "params: {p0: 0.3}}]\nmotion: {from: 1, to: -1, step: 0.1}\n", "applies to the rigid model"),
    ("samples without random", "obstacles: [{profile: parabola, samples: 3, params: {p0: 0.3}}]\n"
     "motion: {from: 1, to: -1, step: 0.1}\n", "samples > 1 needs a random parameter"),
    ("missing motion", "obstacles: [{profile: parabola, params: {p0: 0.3}}]\n",
     "key 'motion' is required"),
    ("negative noise", "obstacles: [{profile: parabola, params: {p0: 0.3}}]\nmotion: {from: 1, "
     "to: -1, step: 0.1}\nnoise: {force_stddev: -1}\n", "noise.force_stddev = -1.0 must be >= 0"),
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
    assert main(["batch", str(ROOT / "config" / "study_small.yaml"), "--out", "unused",
                 "--dry-run"]) == 0
    assert "336 tasks" in capsys.readouterr().out


def test_the_studies_guide_shows_the_example_study():
    import re

    section = (ROOT / "doc" / "guide" / "studies.md").read_text()
    shown = re.search(r"```yaml\n(.+?)```", section, re.S).group(1)
    assert parse_study(shown).tasks == load_study(str(ROOT / "config" / "study_small.yaml")).tasks


def test_scan_place_takes_three_numbers(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["scan", "--profile", "parabola", "--param", "p0=0.3", "--place", "0,1", "--from",
              "1", "--to", "-1", "--step", "0.5", "--csv", str(tmp_path / "x.csv")])
    assert exc.value.code == 2 and "is not X,Y,DEG" in capsys.readouterr().err


def test_out_must_be_a_new_or_a_study_directory(tmp_path, capsys):
    study = tmp_path / "s.yaml"
    study.write_text("obstacles: [{profile: parabola, params: {p0: 0.3}}]\nmotion: {from: 2, "
                     "to: -2, step: 0.5}\n")
    (tmp_path / "file").write_text("x")
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "notes.txt").write_text("mine")
    for out, expected in (("file", "is a file"), ("full", "is not a study dataset")):
        assert main(["batch", str(study), "--out", str(tmp_path / out), "--quiet"]) == 2
        assert expected in capsys.readouterr().err
    assert ((tmp_path / "full" / "notes.txt").read_text() == "mine"
            and len(list((tmp_path / "full").iterdir())) == 1)


def test_whisker_geometry_axes_pick_the_general_solver_and_are_refused_for_the_rigid_model():
    from vibrissa_ros.core.general.model import GeneralWhiskerModel
    from vibrissa_ros.core.exact.models import ElasticaModel

    study = parse_study(
        "whisker: {taper: [1, 0.0667], curvature_k0: 0.5, curvature_k1: -0.2}\n"
        "obstacles: [{profile: parabola, params: {p0: 0.3}}]\nmotion: {from: 2, "
        "to: -2, step: 0.5}\n"
    )
    shapes = [(t.taper, t.curvature_k0, t.curvature_k1) for t in study.tasks]
    assert shapes == [(1.0, 0.5, -0.2), (0.0667, 0.5, -0.2)]
    assert all(isinstance(t.whisker_model(), GeneralWhiskerModel) for t in study.tasks)
    assert "--taper=0.0667 --curvature=0.5,-0.2" in study.tasks[1].scan_command()
    paper = parse_study("obstacles: [{profile: parabola, params: {p0: 0.3}}]\nmotion: {from: 2, "
                        "to: -2, step: 0.5}\n")
    assert isinstance(paper.tasks[0].whisker_model(), ElasticaModel)
    assert "--taper" not in paper.tasks[0].scan_command()
    for bad, words in [
        ("whisker: {model: rigid, taper: 0.5}", "rigid model is a straight rod"),
        ("whisker: {taper: 1.5}", "(0, 1]"),
        ("whisker: {taper: 0}", "must be > 0"),
    ]:
        with pytest.raises(StudyError, match=re.escape(words)):
            parse_study(bad + "\nobstacles: [{profile: parabola, params: {p0: 0.3}}]\nmotion: "
                        "{from: 2, to: -2, step: 0.5}\n")


WHISK_AND_PEG = """
whisker: {model: [elastica, rigid], spring_stiffness: 3}
obstacles:
  - profile: peg
    params: {x: [-0.3, 0.3], y: 0.6, r: 0.05}
  - profile: parabola
    params: {p0: 0.3}
motion:
  - {from: 1.5, to: -1.5, step: 0.05}
  - whisk: {x: [1.5, -1.5], from_deg: 90, to_deg: 150, step_deg: 2, back: true}
"""


def test_whisking_motions_keep_the_foot_and_sweep_the_heading():
    from vibrissa_ros.studies.study import Whisk

    study = parse_study(WHISK_AND_PEG)
    assert study.has_whisking and len(study.tasks) == 2 * 3 * 3
    whisks = [t for t in study.tasks if t.motion == "whisk"]
    assert {t.whisk for t in whisks} == {Whisk(1.5, 0.0, 90.0, 150.0, 2.0),
                                         Whisk(-1.5, 0.0, 90.0, 150.0, 2.0)}
    task = whisks[0]
    assert task.sweep_from is None and task.back
    poses = task.foot_poses()
    assert len(poses) == len(task.grid()) == 61 and study.poses == sum(len(t.grid())
                                                                       for t in study.tasks)
    assert {(p.x, p.y) for p in poses} == {(task.whisk.x, 0.0)}
    headings = [p.heading for p in poses]
    assert (headings[0] == math.pi / 2 and headings[30] == math.radians(150.0)
            and headings[-1] == math.pi / 2)
    assert headings[:31] == headings[30:][::-1]  # the retraction retraces the protraction
    assert "--whisk=1.5,0.0 --from=90.0 --to=150.0 --step=2.0 --back --csv" in task.scan_command()
    sweep = study.tasks[0]
    assert sweep.motion == "sweep" and sweep.whisk is None and sweep.foot_poses() is None
    assert not parse_study("obstacles: [{profile: parabola, params: {p0: 0.3}}]\n"
                           "motion: {from: 2, to: -2, step: 0.5}\n").has_whisking


def test_pegs_are_study_obstacles_solved_by_the_general_model():
    from vibrissa_ros.core.general.model import GeneralWhiskerModel
    from vibrissa_ros.core.exact.models import RigidModel

    study = parse_study(WHISK_AND_PEG)
    assert study.param_names == ("p0", "k", "peg_x", "peg_y", "peg_r")
    pegs = [t for t in study.tasks if t.profile == "peg"]
    assert {t.params for t in pegs} == {(("x", -0.3), ("y", 0.6), ("r", 0.05)),
                                        (("x", 0.3), ("y", 0.6), ("r", 0.05))}
    assert pegs[0].param_columns() == {"peg_x": -0.3, "peg_y": 0.6, "peg_r": 0.05}
    assert all(isinstance(t.whisker_model(), GeneralWhiskerModel) for t in pegs
               if t.model == "elastica")
    assert all(isinstance(t.whisker_model(), RigidModel) for t in pegs if t.model == "rigid")
    assert "--profile peg --param x=-0.3 --param y=0.6 --param r=0.05 --model elastica --from" in \
        pegs[0].scan_command()
    # random pegs: the centre anywhere, the radius >= 0 (0: a point)
    random = parse_study("obstacles: [{profile: peg, samples: 5, params: {x: "
                         "{uniform: [-0.5, 0.5]}, y: {uniform: [0.4, 0.9]}, r: {uniform: [0, "
                         "0.1]}}}]\nmotion: {from: 1, to: -1, step: 0.5}\n")
    assert len({t.params for t in random.tasks}) == 5
    assert all(-0.5 <= dict(t.params)["x"] <= 0.5 and 0 <= dict(t.params)["r"] <= 0.1
               for t in random.tasks)


def test_the_whisking_example_study_is_small():
    study = load_study(str(ROOT / "config" / "study_whisk.yaml"))
    assert study.has_whisking and 50 <= len(study.tasks) <= 200 and study.poses < 20_000
    assert {t.profile for t in study.tasks} == {"peg"}


def test_the_studies_guide_shows_the_whisking_example_study():
    section = (ROOT / "doc" / "guide" / "studies.md").read_text()
    # scene files are found beside the example studies
    shown = [parse_study(block, str(ROOT / "config")) for block in re.findall(r"```yaml\n(.+?)```",
                                                                              section, re.S)]
    assert any(s.tasks == load_study(str(ROOT / "config" / "study_whisk.yaml")).tasks
               for s in shown)
    assert any(s.tasks == load_study(str(ROOT / "config" / "study_scenes.yaml")).tasks
               for s in shown)


_PARABOLA = "obstacles: [{profile: parabola, params: {p0: 0.3}}]\n"
_PEG = ("obstacles: [{profile: peg, params: {x: 0.2, y: 0.6, r: 0.05}}]\nmotion: {from: 1, to: "
        "-1, step: 0.1}\n")
BAD_WHISK_AND_PEG = [
    ("whisk: unknown key", _PARABOLA + "motion: [{whisk: {x: 1.5, from_deg: 90, to_deg: 150, "
     "step_deg: 1, speed: 2}}]\n",
     "motion[0].whisk: unknown key 'speed'; allowed: x, y, from_deg, to_deg, step_deg, back"),
    ("whisk: a key beside it", _PARABOLA + "motion: {whisk: {x: 1.5, from_deg: 90, to_deg: 150, "
     "step_deg: 1}, step: 1}\n",
     "motion: unknown key 'step' beside 'whisk'"),
    ("whisk: missing key", _PARABOLA + "motion: [{whisk: {x: 1.5, from_deg: 90, to_deg: 150}}]\n",
     "motion[0].whisk: key 'step_deg' is required"),
    ("whisk: not a mapping", _PARABOLA + "motion: [{whisk: 90}]\n",
     "motion[0].whisk must be a mapping"),
    ("whisk: empty range", _PARABOLA + "motion: [{whisk: {x: 1.5, from_deg: 90, to_deg: "
     "90, step_deg: 1}}]\n",
     "motion[0].whisk: from_deg = to_deg = 90.0 is an empty range"),
    ("whisk: empty list", _PARABOLA + "motion: [{whisk: {x: [], from_deg: 90, to_deg: "
     "150, step_deg: 1}}]\n",
     "motion[0].whisk.x is an empty list"),
    ("whisk: wrong type", _PARABOLA + "motion: [{whisk: {x: 1.5, from_deg: 90, to_deg: 150, "
     "step_deg: fast}}]\n",
     "motion[0].whisk.step_deg = 'fast' must be a number"),
    ("whisk: zero step", _PARABOLA + "motion: [{whisk: {x: 1.5, from_deg: 90, to_deg: "
     "150, step_deg: 0}}]\n",
     "motion[0].whisk.step_deg = 0.0 must be > 0"),
    ("whisk: back not a bool", _PARABOLA + "motion: [{whisk: {x: 1.5, from_deg: 90, to_deg: 150, "
     "step_deg: 1, back: 1}}]\n",
     "motion[0].whisk.back = 1 must be true or false"),
    ("whisk: too many headings", _PARABOLA + "motion: [{whisk: {from_deg: 0, to_deg: 90, "
     "step_deg: 0.000000001}}]\n",
     "motion[0].whisk: --step = 1e-09 gives"),
    ("number YAML reads as text", _PARABOLA + "motion: [{whisk: {from_deg: 60, to_deg: 120, "
     "step_deg: 5e-1}}]\n",
     "motion[0].whisk.step_deg = '5e-1' must be a number (YAML reads 5e-1 as text: write 0.5)"),
    ("sweep: empty range", _PARABOLA + "motion: {from: 1, to: 1, step: 0.1}\n",
     "motion: from = to = 1.0 is an empty range"),
    ("peg: unknown parameter", "obstacles: [{profile: peg, params: {x: 0, y: 0.6, R: 0.1}}]\n"
     "motion: {from: 1, to: -1, step: 0.1}\n", "obstacles[0].params: unknown key 'R'; "
     "allowed: x, y, r"),
    ("peg: missing centre", "obstacles: [{profile: peg, params: {x: 0}}]\nmotion: {from: 1, "
     "to: -1, step: 0.1}\n",
     "obstacles[0].params: key 'y' is required"),
    ("peg: negative radius", "obstacles: [{profile: peg, params: {x: 0, y: 0.6, r: -0.1}}]\n"
     "motion: {from: 1, to: -1, step: 0.1}\n", "obstacles[0].params.r = -0.1 must be >= 0"),
    ("peg: random radius below 0", "obstacles: [{profile: peg, samples: 3, params: {x: 0, y: 0.6, "
     "r: {uniform: [-0.1, 0.1]}}}]\nmotion: {from: 1, to: -1, step: 0.1}\n",
     "obstacles[0].params.r.uniform = -0.1 must be >= 0"),
    ("peg: placed", _PEG + "placement: {rotation_deg: [0, 10]}\n",
     "obstacles[0] is a peg, placed by its own params x, y"),
    ("peg: placed at random", _PEG + "placement: {x: {uniform: [-0.1, 0.1]}, samples: 2}\n",
     "is a peg"),
]


@pytest.mark.parametrize("case", BAD_WHISK_AND_PEG, ids=[c[0] for c in BAD_WHISK_AND_PEG])
def test_a_bad_whisk_or_peg_is_refused_with_one_line_before_anything_runs(case, tmp_path, capsys):
    test_a_bad_study_is_refused_with_one_line_before_anything_runs(case, tmp_path, capsys)


def test_a_peg_with_placement_zero_is_allowed():
    assert len(parse_study(_PEG + "placement: {x: 0, rotation_deg: 0}\n").tasks) == 1


def _scan_csv(tmp_path, name, args):
    path = tmp_path / name
    assert main(["scan", "--profile", "parabola", "--param", "p0=0.3"] + args
                + ["--csv", str(path), "--events", str(path) + ".json"]) == 0
    return path.read_text(), (tmp_path / (name + ".json")).read_text()


def test_scan_whisk_equals_the_same_poses_from_a_file(tmp_path):
    from vibrissa_ros.core.scan import whisk_poses

    poses = whisk_poses(1.5, 0.0, 90.0, 150.0, 1.0, back=True)
    lines = ["x,y,heading"] + [f"{p.x!r},{p.y!r},{p.heading!r}" for p in poses]
    (tmp_path / "poses.csv").write_text("\n".join(lines) + "\n")
    by_file = _scan_csv(tmp_path, "file.csv", ["--poses", str(tmp_path / "poses.csv")])
    by_whisk = _scan_csv(tmp_path, "whisk.csv", ["--whisk=1.5,0", "--from", "90", "--to", "150",
                                                 "--step", "1", "--back"])
    assert by_whisk == by_file
    assert (by_whisk[0].startswith("x,y,heading,phase,")
            and len(by_whisk[0].splitlines()) == 1 + 121)
    assert '"kind": "touch"' in by_whisk[1]


@pytest.mark.parametrize("args, expected", [
    (["--whisk=1.5,0", "--from", "90", "--to", "150"], "--whisk X,Y needs the headings"),
    (["--whisk=1.5,0", "--poses", "p.csv"], "either --poses or --whisk"),
    (["--whisk=1.5,0", "--from", "90", "--to", "150", "--step", "0.5e-8"], "grid points"),
])
def test_scan_whisk_refuses_what_it_cannot_do_in_one_line(args, expected, tmp_path, capsys):
    assert main(["scan", "--profile", "parabola", "--param", "p0=0.3"] + args
                + ["--csv", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and expected in err


def test_scan_whisk_takes_two_numbers(tmp_path, capsys):
    # (three numbers are an array's whisk: vibrissa scan --array, test_cli_array_scan.py)
    assert main(["scan", "--profile", "parabola", "--param", "p0=0.3", "--whisk=1.5", "--from",
                 "90", "--to", "150", "--step", "1", "--csv", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert "is not X,Y" in err and len(err.strip().splitlines()) == 1


# -- scene files as study obstacles ---------------------------------------------------------------

_TWO_PEGS = (ROOT / "config" / "scene_two_pegs.yaml").read_text()
_SLIDE = "motion: {from: -0.15, to: 0.25, step: 0.05}\n"
BAD_SCENES = [
    ("scene: missing file", "obstacles: [{scene: nope.yaml}]\n" + _SLIDE,
     "obstacles[0].scene = 'nope.yaml': "),
    ("scene: bad file", "obstacles: [{scene: bad.yaml}]\n" + _SLIDE,
     "obstacles[0].scene = 'bad.yaml': "),
    ("scene: overlapping obstacles", "obstacles: [{scene: overlap.yaml}]\n" + _SLIDE, "overlap"),
    ("scene: not a path", "obstacles: [{scene: 3}]\n" + _SLIDE,
     "obstacles[0].scene = 3 must be a scene file's path"),
    ("scene: empty list", "obstacles: [{scene: []}]\n" + _SLIDE,
     "obstacles[0].scene is an empty list"),
    ("scene: a file twice", "obstacles: [{scene: [pegs.yaml, pegs.yaml]}]\n" + _SLIDE,
     "lists a file twice"),
    ("scene: unknown key", "obstacles: [{scene: pegs.yaml, params: {p0: 0.3}}]\n" + _SLIDE,
     "obstacles[0]: unknown key 'params'; allowed: scene, friction"),
    ("scene: negative friction", "obstacles: [{scene: pegs.yaml, friction: [0, -0.1]}]\n" + _SLIDE,
     "obstacles[0].friction = -0.1 must be >= 0"),
    ("scene: friction as text", "obstacles: [{scene: pegs.yaml, friction: low}]\n" + _SLIDE,
     "obstacles[0].friction = 'low' must be a number"),
    ("scene: placed", "obstacles: [{scene: pegs.yaml}]\nplacement: {x: [0, 0.1]}\n" + _SLIDE,
     "a scene file (pegs.yaml) places its own obstacles"),
    ("scene: rigid model", "whisker: {model: [elastica, rigid]}\nobstacles: [{scene: pegs.yaml}]\n"
     + _SLIDE,
     "whisker.model 'rigid' cannot scan a scene file"),
]


@pytest.mark.parametrize("case", BAD_SCENES, ids=[c[0] for c in BAD_SCENES])
def test_a_bad_scene_entry_is_refused_with_one_line_before_anything_runs(case, tmp_path, capsys):
    _, text, expected = case
    (tmp_path / "pegs.yaml").write_text(_TWO_PEGS)
    (tmp_path / "bad.yaml").write_text("obstacles:\n  - {type: peg, x: 0, y: 0.5, r: -1}\n")
    (tmp_path / "overlap.yaml").write_text("obstacles:\n  - {type: peg, x: 0, y: 0.5, r: 0.1}\n"
                                           "  - {type: peg, x: 0.05, y: 0.5, r: 0.1}\n")
    path = tmp_path / "study.yaml"
    path.write_text(text)
    with pytest.raises(StudyError) as err:
        load_study(str(path))
    assert expected in str(err.value)
    out = tmp_path / "out"
    assert main(["batch", str(path), "--out", str(out)]) == 2
    stderr = capsys.readouterr().err
    assert len(stderr.strip().splitlines()) == 1 and expected in stderr
    assert not out.exists()


def test_scene_files_are_a_grid_axis_with_friction_found_beside_the_study(tmp_path):
    (tmp_path / "scenes").mkdir()
    (tmp_path / "scenes" / "pegs.yaml").write_text(_TWO_PEGS)
    (tmp_path / "scenes" / "one.yaml").write_text("friction: 0.2\nobstacles:\n  - {type: peg, x: "
                                                  "0, y: 0.5, r: 0.05}\n")
    path = tmp_path / "study.yaml"
    path.write_text("whisker: {taper: [1, 0.5]}\nobstacles:\n  - {scene: "
                    "[scenes/pegs.yaml, scenes/one.yaml], friction: [0, 0.3]}\n  - {scene: "
                    "scenes/one.yaml}\n  - {profile: parabola, params: {p0: 0.3}}\n"
                    + _SLIDE)
    study = load_study(str(path))
    assert study.has_scenes and len(study.tasks) == 2 * (4 + 1 + 1)
    scenes = [(t.scene.file, t.scene.friction, t.taper) for t in study.tasks
              if t.scene is not None]
    assert scenes[:5] == [("scenes/pegs.yaml", 0.0, 1.0), ("scenes/pegs.yaml", 0.3, 1.0),
                          # the file's own coefficient
                          ("scenes/one.yaml", 0.0, 1.0), ("scenes/one.yaml", 0.3, 1.0),
                          ("scenes/one.yaml", 0.2, 1.0)]
    task = study.tasks[1]
    assert task.profile == "scene" and task.params == () and task.model == "elastica"
    assert task.scan_command().split()[:5] == ["vibrissa", "scan", "--scene",
                                               str(tmp_path / "scenes" / "pegs.yaml"),
                                               "--friction=0.3"]
    # a scene file's text is part of the study: edited, it is another study (no resume into old
    # results)
    (tmp_path / "scenes" / "one.yaml").write_text("friction: 0.1\nobstacles:\n  - {type: peg, x: "
                                                  "0, y: 0.5, r: 0.05}\n")
    assert load_study(str(path)).digest != study.digest
    assert parse_study(path.read_text(), read_scenes=False).tasks[4].scene.friction is None


def test_a_study_without_scenes_keeps_its_columns_and_digest():
    """
    Datasets written before scenes were study obstacles still resume.

    Same digest, same columns.
    """
    from vibrissa_ros.studies.dataset import manifest

    found = manifest(parse_study(_PARABOLA + "motion: {from: 1, to: -1, step: 0.1}\n"))
    assert (found["study_sha256"]
            == "0d38f7089440e00fa4f1173b5e8b7489a2ad1cd12132f748ed9af516c33765d5")
    params = ["model", "spring_stiffness", "taper", "curvature_k0", "curvature_k1", "profile",
              "p0", "k", "x", "y", "rotation_deg", "sweep_from", "sweep_to", "sweep_step", "back"]
    assert found["tables"] == {
        "tasks": ["task"] + params + ["command"],
        "poses": ["task", "step", "x0", "phase", "alpha", "s1", "tip_slope", "f", "fx", "fy", "m0",
                  "contact_x", "contact_y"] + params,
        "events": ["task", "step", "x0", "kind", "from_phase", "to_phase"],
        "failures": ["task", "error", "reason"] + params,
    }


def test_the_scene_example_study_is_a_few_dozen_tasks():
    study = load_study(str(ROOT / "config" / "study_scenes.yaml"))
    assert 20 <= len(study.tasks) <= 60 and study.has_scenes
    assert {t.scene.friction for t in study.tasks} == {0.0, 0.1, 0.3}
