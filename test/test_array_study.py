"""
Array studies (``kind: array``): validation, expansion, and a run on a Dask LocalCluster.

Every task's rows equal its own ``vibrissa scan --array`` command's value for value.
"""

import json
import math
from pathlib import Path

import pytest

pytest.importorskip("distributed")
pytest.importorskip("pyarrow")

import pyarrow.parquet as pq  # noqa: E402

from vibrissa_ros.cli import main  # noqa: E402
from vibrissa_ros.core.arrays import WhiskerArray, rat_array  # noqa: E402
from vibrissa_ros.scan.array_file import dump_array  # noqa: E402
from vibrissa_ros.scan.array_scan import ARRAY_COLUMNS  # noqa: E402
from vibrissa_ros.studies import dataset  # noqa: E402
from vibrissa_ros.studies.array_study import PARAMETERS, ArrayStudy  # noqa: E402
from vibrissa_ros.studies.batch import run_study  # noqa: E402
from vibrissa_ros.studies.study import load_study, parse_study  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PEG = ("obstacles:\n  - {type: cylinder, name: peg, point: [0.03, -0.016, 0.0], "
       "axis: [0.0, 0.0, 1.0], r: 0.0015}\n")
#: 6 tasks of 3 whiskers: a scene file and two random pegs, whisking and the head advancing;
#: (a start that puts a whisker inside the object would be a failed task)
STUDY = """
kind: array
seed: 3
array: three.yaml
side: right
objects:
  - scene: peg.yaml
  - cylinder: {x: {uniform: [0.027, 0.031]}, y: -0.016, z: 0, r: 0.0015}
    samples: 2
head:
  y: 0.004
motion:
  - whisk: {frequency: 8, retraction_deg: -20, protraction_deg: 20}
    duration: 0.012
    rate: 1000
  - velocity: [0, -0.2, 0]                 # the peg comes into the whiskers
    duration: 0.01
    rate: 500
"""


@pytest.fixture(scope="module")
def study_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("array_study")
    both = rat_array("both")
    dump_array(WhiskerArray(tuple(both[n] for n in ("RB1", "RC1", "RC5", "LC1")), "four"),
               d / "three.yaml")
    (d / "peg.yaml").write_text(PEG)
    (d / "study.yaml").write_text(STUDY)
    return d


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=":0", silence_logs=50)
    with Client(cluster) as c:
        yield c
    cluster.close()


def test_an_array_study_expands_into_objects_heads_and_motions(study_dir):
    study = load_study(str(study_dir / "study.yaml"))
    assert isinstance(study, ArrayStudy) and len(study.tasks) == 6 and study.whiskers == 3
    assert [t.object for t in study.tasks] == ["scene"] * 2 + ["cylinder"] * 4
    xs = {t.shape[0] for t in study.tasks if t.object == "cylinder"}
    assert len(xs) == 2 and all(0.027 <= x <= 0.031 for x in xs)
    assert study.poses == 3 * (13 + 6) * 3
    again = load_study(str(study_dir / "study.yaml"))
    assert again.digest == study.digest and again.tasks == study.tasks
    # the array file's text is part of the digest
    (study_dir / "copy").mkdir(exist_ok=True)
    (study_dir / "copy" / "three.yaml").write_text(
        (study_dir / "three.yaml").read_text() + "# edited\n")
    (study_dir / "copy" / "peg.yaml").write_text(PEG)
    other = parse_study(STUDY, str(study_dir / "copy"))
    assert other.digest != study.digest


def test_the_example_array_study(capsys):
    study = load_study(str(ROOT / "config" / "study_array.yaml"))
    assert len(study.tasks) == 16 and study.whiskers == 30
    assert main(["batch", str(ROOT / "config" / "study_array.yaml"), "--out", "unused",
                 "--dry-run"]) == 0
    assert "16 tasks (array runs of 30 whiskers)" in capsys.readouterr().out
    guide = (ROOT / "doc" / "guide" / "studies.md").read_text()
    assert (ROOT / "config" / "study_array.yaml").read_text().split("kind: array", 1)[1] in guide


_MOTION = "motion: {whisk: {retraction_deg: -20, protraction_deg: 20}}\n"
BAD = [
    ("kind: arrays\n", "kind = 'arrays'"),
    ("kind: array\nobjects: [{scene: peg.yaml}]\n" + _MOTION, "'array' is required"),
    ("kind: array\narray: nope.yaml\nobjects: [{scene: peg.yaml}]\n" + _MOTION,
     "array = 'nope.yaml'"),
    ("kind: array\narray: three.yaml\nside: top\nobjects: [{scene: peg.yaml}]\n" + _MOTION,
     "side = 'top'"),
    ("kind: array\narray: three.yaml\nobjects: [{cube: {x: 1}}]\n" + _MOTION,
     "objects[0] must be a mapping with one of the keys"),
    ("kind: array\narray: three.yaml\nobjects: [{sphere: {x: 0, y: 0, z: 0, r: -1}}]\n"
     + _MOTION, "objects[0].sphere.r = -1.0 must be > 0"),
    ("kind: array\narray: three.yaml\nobjects: [{cylinder: {x: 0, y: 0, z: 0, r: 1, "
     "axis: [0, 0]}}]\n" + _MOTION, "objects[0].cylinder.axis"),
    ("kind: array\narray: three.yaml\nobjects: [{scene: peg.yaml}]\nhead: {yaw: 3}\n" + _MOTION,
     "head: unknown key 'yaw'"),
    ("kind: array\narray: three.yaml\nobjects: [{scene: peg.yaml}]\n"
     "motion: {velocity: [0, 0, 0], duration: 0.1}\n", "neither whisks nor moves"),
    ("kind: array\narray: three.yaml\nobjects: [{scene: peg.yaml}]\n"
     "motion: {velocity: [0, 1, 0]}\n", "'duration' is required"),
    ("kind: array\narray: three.yaml\nobjects: [{scene: peg.yaml}]\n"
     "motion: {whisk: {retraction_deg: 20, protraction_deg: -20}}\n", "must be >= retraction"),
    ("kind: array\narray: three.yaml\nobjects: [{scene: missing.yaml}]\n" + _MOTION,
     "objects[0].scene = 'missing.yaml'"),
    ("kind: array\narray: three.yaml\npoints_tolerance: 1.0e-3\nobjects: [{scene: peg.yaml}]\n"
     + _MOTION, "points_tolerance = 0.001: need a number from 1e-12 to 1e-06"),
    ("kind: array\narray: three.yaml\npoints_tolerance: [1.0e-8, 1.0e-9]\n"
     "objects: [{scene: peg.yaml}]\n" + _MOTION, "points_tolerance = [1e-08, 1e-09] must be one "
     "number"),
]


@pytest.mark.parametrize("text, expected", BAD)
def test_a_bad_array_study_is_refused_with_one_line(study_dir, tmp_path, capsys, text,
                                                    expected):
    path = study_dir / "bad.yaml"
    path.write_text(text)
    assert main(["batch", str(path), "--out", str(tmp_path / "ds"), "--dry-run"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and expected in err, err


def _float(text):
    return None if text == "" else float(text)


def test_every_task_equals_vibrissa_scan_array_of_it(study_dir, client, tmp_path, capsys):
    study = load_study(str(study_dir / "study.yaml"))
    out = tmp_path / "ds"
    report = run_study(study, str(out), client=client, progress=None)
    assert report.complete and report.computed == 6 and not report.errors
    ds = dataset.open(str(out))
    poses, tasks, failures = ds.poses, ds.tasks, ds.failures
    assert list(poses.columns) == ["task"] + list(ARRAY_COLUMNS) + list(PARAMETERS)
    assert json.loads((out / "manifest.json").read_text())["kind"] == "array"
    assert (poses.contacts > 0).any() and set(poses.side) == {"right"}
    assert len(pq.ParquetDataset(str(out / "poses")).files) == 6 - len(failures)
    for task in study.tasks:
        row = tasks[tasks.task == task.index].iloc[0]
        args = row.command.split()[1:]
        csv_path = tmp_path / f"{task.index}.csv"
        args[args.index("--out") + 1] = str(csv_path)
        if isinstance(row.scene_yaml, str):
            scene = tmp_path / f"task-{task.index}.scene.yaml"
            scene.write_text(row.scene_yaml)
            args[args.index("--scene") + 1] = str(scene)
        code = main(args)
        err = capsys.readouterr().err
        if task.index in set(failures.task):
            reason = failures[failures.task == task.index].reason.iloc[0]
            assert code == 2 and reason.split("whisker", 1)[1] in err
            continue
        assert code == 0, err
        import csv

        rows = list(csv.DictReader(csv_path.open()))
        mine = poses[poses.task == task.index]
        assert len(rows) == len(mine) == 3 * task.ticks
        for want, (_, got) in zip(rows, mine.iterrows()):
            for col in ARRAY_COLUMNS:
                value = got[col]
                value = None if value is None or value != value else value
                if col in ("tick", "column", "contacts"):
                    assert int(value) == int(want[col]), (task.index, col)
                elif col in ("whisker", "side", "row", "kind", "obstacle", "error"):
                    assert (value or "") == want[col], (task.index, col)
                else:
                    assert value == _float(want[col]), (task.index, col)
        assert set(mine.object) == {task.object}
        if task.whisk is None:
            assert mine.protraction.eq(0).all() and mine.whisk_frequency.isna().all()
            assert mine.velocity_y.eq(-0.2).all()
        else:
            assert mine.protraction.iloc[0] == pytest.approx(math.radians(-20))
    again = run_study(study, str(out), client=client, progress=None)
    assert again.computed == 0 and again.already_done == 6


def test_a_study_passes_its_points_tolerance_to_every_run(study_dir, client, tmp_path, capsys):
    # points_tolerance: the runs on the workers and the tasks' commands take it, and a task's
    # rows equal its command's
    text = STUDY.replace("side: right\n", "side: right\npoints_tolerance: 1.0e-8\n")
    text = text.split("  - velocity:")[0]  # the whisk alone: two tasks of the peg file
    text = text.replace("  - cylinder: {x: {uniform: [0.027, 0.031]}, y: -0.016, z: 0, "
                        "r: 0.0015}\n    samples: 2\n", "")
    text = text.replace("duration: 0.012", "duration: 0.05")
    (study_dir / "coarse.yaml").write_text(text)
    study = load_study(str(study_dir / "coarse.yaml"))
    assert study.points_tolerance == 1e-8 and len(study.tasks) == 1
    assert load_study(str(study_dir / "study.yaml")).points_tolerance == 1e-11
    out = tmp_path / "ds"
    report = run_study(study, str(out), client=client, progress=None)
    assert report.complete and report.computed == 1 and not report.errors
    ds = dataset.open(str(out))
    command = ds.tasks.command.iloc[0]
    assert "--points-tolerance=1e-08" in command
    args = command.split()[1:]
    args[args.index("--out") + 1] = str(tmp_path / "run.csv")
    assert main(args) == 0, capsys.readouterr().err
    import csv

    rows = list(csv.DictReader((tmp_path / "run.csv").open()))
    mine = ds.poses
    assert (mine.contacts > 0).any() and len(rows) == len(mine)
    for want, (_, got) in zip(rows, mine.iterrows()):
        for col in ("fx", "fy", "fz", "mx", "my", "mz"):
            assert got[col] == _float(want[col]), col
    # and not the default's: the run was made at 1e-8
    args.remove("--points-tolerance=1e-08")
    args[args.index("--out") + 1] = str(tmp_path / "exact.csv")
    assert main(args) == 0
    exact = list(csv.DictReader((tmp_path / "exact.csv").open()))
    assert any(a["fx"] != b["fx"] for a, b in zip(rows, exact) if a["fx"])
