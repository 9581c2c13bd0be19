"""
vibrissa batch on a real Dask LocalCluster of 2 worker processes.

Results equal serial ``vibrissa scan`` runs value for value; a lost worker and a killed driver lose
nothing and duplicate nothing; a resumed run computes only what is missing and ends with the very
dataset of an uninterrupted run.
"""

import csv
import io
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed")
pytest.importorskip("pyarrow")

# the imports need pyarrow and Dask: after the skips above
import pyarrow.parquet as pq  # noqa: E402

from vibrissa_ros.studies import dataset  # noqa: E402
from vibrissa_ros.studies.batch import run_study  # noqa: E402
from vibrissa_ros.cli import main  # noqa: E402
from vibrissa_ros.node.noise import NoiseSpec, SensorNoise  # noqa: E402
from vibrissa_ros.scan.scan_io import CSV_COLUMNS, POSE_CSV_COLUMNS  # noqa: E402
from vibrissa_ros.studies.study import parse_study  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
# dask.dataframe's own parquet reader calls a pandas API that pandas 3.1 deprecates: not ours
# to fix
pytestmark = pytest.mark.filterwarnings("ignore:The inplace keyword:DeprecationWarning")

# 32 tasks of 81-161 poses: two whiskers, parabolas and random ellipses, tilted, swept both ways;
# two of them fail (the tilted flat parabola is cut by the straight whisker at the start)
STUDY = """
seed: 2
whisker: {model: [elastica, rigid], spring_stiffness: 3}
obstacles:
  - profile: parabola
    params: {p0: 0.3, k: [0.5, 2]}
  - profile: ellipse
    samples: 2
    params: {p0: {uniform: [0.2, 0.4]}, a: {uniform: [0.4, 0.8]}, b: 1.5}
placement: {rotation_deg: [0, 15]}
motion:
  - {from: 2.0, to: -2.0, step: 0.05}
  - {from: -2.0, to: 2.0, step: 0.05, back: true}
noise: {force_stddev: 0.002, torque_stddev: 0.001}
"""


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=":0", silence_logs=50)
    with Client(cluster) as c:
        yield c
    cluster.close()


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    path = tmp_path_factory.mktemp("study") / "study.yaml"
    path.write_text(STUDY)
    return path, parse_study(STUDY)


@pytest.fixture(scope="module")
def reference(client, study, tmp_path_factory):
    """Run the study uninterrupted: the dataset the other runs must end with."""
    out = tmp_path_factory.mktemp("reference") / "ds"
    report = run_study(study[1], str(out), client=client, progress=None)
    assert report.complete and report.computed == 32 and report.failed == 2 and not report.errors
    return out


def _tables(path):
    ds = dataset.open(str(path))
    return {name: ds.table(name) for name in ("tasks", "poses", "events", "failures")}


def _float(text):
    return None if text == "" else float(text)


def test_every_task_equals_vibrissa_scan_of_it_value_for_value(reference, study, tmp_path, capsys):
    ds = dataset.open(str(reference))
    assert ds.complete and ds.version and ds.study_text == STUDY
    _assert_equals_vibrissa_scan(ds, study[1], tmp_path, capsys)


def test_a_study_of_tapered_and_curved_whiskers_equals_vibrissa_scan(client, tmp_path, capsys):
    """
    Whisker geometry as study axes: the general solver, picked as --solver auto picks it.

    Every task equals ``vibrissa scan --taper --curvature`` value for value.
    """
    text = """
whisker: {taper: [1, 0.3], curvature_k0: [0, 0.5]}
obstacles: [{profile: parabola, params: {p0: 0.35}}]
motion: {from: 1.6, to: -1.6, step: 0.1}
"""
    sub = parse_study(text)
    assert {(t.taper, t.curvature_k0) for t in sub.tasks} == {(1.0, 0.0), (1.0, 0.5), (0.3, 0.0),
                                                              (0.3, 0.5)}
    out = tmp_path / "ds"
    report = run_study(sub, str(out), client=client, progress=None)
    assert report.complete and report.computed == 4 and report.failed == 0
    ds = dataset.open(str(out))
    assert set(ds.poses.taper) == {1.0, 0.3} and set(ds.tasks.curvature_k0) == {0.0, 0.5}
    _assert_equals_vibrissa_scan(ds, sub, tmp_path, capsys)


# 18 tasks: two whiskers, two pegs and a parabola, a slide and two whisks (from beside the
# parabola, and from the origin); the rigid model fails where a peg meets the whisker's side, the
# whisk from the origin cannot start inside the parabola
WHISK_AND_PEG = """
seed: 4
whisker: {model: [elastica, rigid], spring_stiffness: 3}
obstacles:
  - profile: peg
    params: {x: [-0.3, 0.3], y: 0.6, r: 0.05}
  - profile: parabola
    params: {p0: 0.3}
motion:
  - {from: 1.5, to: -1.5, step: 0.05}
  - whisk: {x: 1.5, from_deg: 90, to_deg: 150, step_deg: 2, back: true}
  - whisk: {from_deg: 50, to_deg: 130, step_deg: 2, back: true}
noise: {force_stddev: 0.002}
"""


def test_a_study_of_whisks_and_pegs_equals_vibrissa_scan(client, tmp_path, capsys):
    """
    Whisking and pegs as study axes.

    Every task equals ``vibrissa scan --whisk`` / ``--profile peg``.
    """
    sub = parse_study(WHISK_AND_PEG)
    out = tmp_path / "ds"
    report = run_study(sub, str(out), client=client, progress=None)
    assert report.complete and report.computed == 18 and not report.errors
    ds = dataset.open(str(out))
    poses, tasks, failures = ds.poses, ds.tasks, ds.failures
    assert set(failures.error) == {"ModelAssumptionError", "InvalidPoseError"}
    assert set(failures[failures.error == "ModelAssumptionError"].model) == {"rigid"}
    assert set(failures[failures.error == "InvalidPoseError"].whisk_x) == {0.0}
    assert len(poses) > 0 and set(poses.motion) == {"sweep", "whisk"}
    # the foot pose of every row; a slide's: (x0, 0, pi/2)
    slides, whisks = poses[poses.motion == "sweep"], poses[poses.motion == "whisk"]
    assert (slides.foot_x == slides.x0).all() and (slides.foot_y == 0).all()
    assert (slides.heading == math.pi / 2).all() and slides.whisk_x.isna().all()
    assert (whisks.foot_x == whisks.whisk_x).all() and whisks.sweep_from.isna().all()
    assert whisks.heading.min() == math.radians(50) and whisks.heading.max() == math.radians(150)
    # the peg's parameters are its own columns, beside the placement's x, y
    pegs = tasks[tasks.profile == "peg"]
    assert set(pegs.peg_x) == {-0.3, 0.3} and set(pegs.peg_r) == {0.05} and pegs.p0.isna().all()
    assert (tasks.x == 0).all() and tasks[tasks.profile == "parabola"].peg_x.isna().all()
    assert set(ds.events.columns[:6]) == {"task", "step", "foot_x", "foot_y", "heading", "x0"}
    _assert_equals_vibrissa_scan(ds, sub, tmp_path, capsys)


def _assert_equals_vibrissa_scan(ds, study, tmp_path, capsys):
    poses = ds.poses
    events = ds.events
    failures = ds.failures.set_index("task")
    for task in study.tasks:
        args = task.scan_command().split()[1:]
        csv_path, ev_path = tmp_path / f"{task.index}.csv", tmp_path / f"{task.index}.json"
        args[args.index("--csv") + 1] = str(csv_path)
        code = main(args + ["--events", str(ev_path)])
        err = capsys.readouterr().err
        if task.index in failures.index:
            assert code != 0 and failures.loc[task.index, "reason"] in err
            assert (poses.task == task.index).sum() == 0
            continue
        assert code == 0, err
        rows = list(csv.DictReader(io.StringIO(csv_path.read_text())))
        mine = poses[poses.task == task.index]
        assert list(mine.step) == list(range(len(rows)))
        # a whisk is written as foot poses (x, y, heading): the dataset's foot_x, foot_y, heading
        whisk = task.whisk is not None
        columns = POSE_CSV_COLUMNS if whisk else CSV_COLUMNS
        assert list(rows[0]) == list(columns)
        for row, (_, got) in zip(rows, mine.iterrows()):
            for col in columns:
                want = int(row[col]) if col == "phase" else _float(row[col])
                value = got[{"x": "foot_x", "y": "foot_y"}.get(col, col)]
                value = None if value != value else value  # NaN is the DataFrame's null
                assert value == want, (task.index, col)
        want_events = json.loads(ev_path.read_text())
        got_events = events[events.task == task.index]
        where = ("x", "y", "heading") if whisk else ("x0",)
        got_where = ([got_events.foot_x, got_events.foot_y, got_events.heading] if whisk
                     else [got_events.x0])
        assert [tuple(e[k] for k in where + ("kind", "from_phase", "to_phase"))
                for e in want_events] == \
            list(zip(*got_where, got_events.kind, got_events.from_phase, got_events.to_phase))
        assert len(want_events) == len(got_events)
        # the task's parameters ride along on every row
        assert (set(mine.profile) == {task.profile}
                and set(mine.rotation_deg) == {task.rotation_deg})
        assert set(mine.model) == {task.model}


def test_noisy_columns_are_the_node_noise_model_seeded_per_task(reference):
    poses = dataset.open(str(reference)).poses
    for task in (0, 17):
        rows = poses[poses.task == task]
        seed = int(rows.noise_seed.iloc[0])
        noise = SensorNoise(NoiseSpec(enabled=True, seed=seed, force_stddev=0.002,
                                      torque_stddev=0.001))
        for _, r in rows.iterrows():
            assert noise.apply(r.fx, r.fy, r.m0) == (r.fx_noisy, r.fy_noisy, r.m0_noisy)
    assert poses.groupby("task").noise_seed.first().nunique() == 30


def test_the_dataset_reads_the_same_in_pandas_pyarrow_dask_and_polars(reference):
    import pandas as pd
    import pyarrow.dataset as pads

    want = dataset.open(str(reference)).table("poses").to_pandas()
    assert len(want) == sum(len(t.grid()) for t in parse_study(STUDY).tasks
                            if t.index not in (3, 19))
    by_pandas = pd.read_parquet(reference / "poses")
    by_arrow = pads.dataset(str(reference / "poses"), format="parquet").to_table().to_pandas()
    for got in (by_pandas, by_arrow):
        pd.testing.assert_frame_equal(got.sort_values(["task", "step"]).reset_index(drop=True),
                                      want)
    dd = pytest.importorskip("dask.dataframe")
    by_dask = dd.read_parquet(str(reference / "poses")).compute(scheduler="sync")
    assert len(by_dask) == len(want)
    assert by_dask.m0.sum() == pytest.approx(want.m0.sum(), rel=1e-12)
    pl = pytest.importorskip("polars")
    by_polars = pl.read_parquet(str(reference / "poses" / "*.parquet")).sort(["task", "step"])
    assert by_polars.height == len(want) and by_polars["m0"].to_list() == want.m0.tolist()
    assert len(pd.read_parquet(reference / "events")) == len(dataset.open(str(reference)).events)
    assert sorted(pd.read_parquet(reference / "failures").task) == [3, 19]


def test_running_a_finished_study_again_computes_nothing(reference, study, client):
    report = run_study(study[1], str(reference), client=client, progress=None)
    assert report.computed == 0 and report.already_done == 32


def test_another_study_into_the_same_directory_is_refused(reference, study, tmp_path, capsys):
    other = tmp_path / "other.yaml"
    other.write_text(STUDY.replace("seed: 2", "seed: 3"))
    assert main(["batch", str(other), "--out", str(reference), "--quiet"]) == 2
    assert "another study" in capsys.readouterr().err


def test_a_worker_killed_mid_study_loses_and_duplicates_nothing(client, study, reference,
                                                                tmp_path):
    out = tmp_path / "ds"
    pids = list(client.run(os.getpid).values())
    killed = []

    def kill_one_worker_mid_study():
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if (out / "poses").is_dir() and len(os.listdir(out / "poses")) >= 4:
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])
                return
            time.sleep(0.005)

    killer = threading.Thread(target=kill_one_worker_mid_study)
    killer.start()
    # refilled as tasks end
    report = run_study(study[1], str(out), client=client, progress=None, window=6)
    killer.join()
    assert killed, "the study ended before a worker could be killed"
    assert report.complete and report.computed == 32 and not report.errors
    got, want = _tables(out), _tables(reference)
    for name in want:
        assert got[name].equals(want[name]), name
    poses = got["poses"].to_pandas()
    assert not poses.duplicated(["task", "step"]).any()
    # the nanny restarted it: the next tests have two workers again
    client.wait_for_workers(2, timeout=60)


def test_a_killed_driver_resumed_computes_only_the_missing_tasks(client, study, reference,
                                                                 tmp_path):
    out = tmp_path / "ds"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "vibrissa_ros", "batch", str(study[0]), "--out",
                             str(out), "--workers", "2", "--quiet"], env=env,
                            start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 90
        while time.monotonic() < deadline and proc.poll() is None:
            if (out / "poses").is_dir() and len(os.listdir(out / "poses")) >= 6:
                break
            time.sleep(0.005)
        assert proc.poll() is None, proc.stderr.read().decode()
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the driver and its embedded cluster's processes
        proc.wait()
        proc.stderr.close()
    done = dataset.open(str(out)).done()
    assert 6 <= len(done) < 32
    for name in os.listdir(out / "poses"):  # only whole files count as results
        if name.startswith("task-"):
            pq.read_table(out / "poses" / name)
    report = run_study(study[1], str(out), client=client, progress=None)
    assert report.already_done == len(done) and report.computed == 32 - len(done)
    got, want = _tables(out), _tables(reference)
    for name in want:
        assert got[name].equals(want[name]), name


def test_a_cluster_worker_needs_no_ros():
    code = ("import sys, vibrissa_ros.studies.batch, vibrissa_ros.studies.dataset, "
            "vibrissa_ros.studies.study, vibrissa_ros.cli; print(sorted(m for m in sys.modules if "
            "m.split('.')[0] in ('rclpy', 'rosidl_runtime_py', 'mcap')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env=dict(os.environ, PYTHONPATH=str(ROOT))).stdout
    assert out.strip() == "[]"


# scene files in a study: two pegs (peg1 with its own coefficient) and one peg, each with friction
# 0 and 0.3 (the frictionless one-peg scene is the single-contact problem), beside a peg profile; a
# slide and a whisk
SCENE_STUDY = """
whisker: {model: elastica}
obstacles:
  - scene: [pegs.yaml, one_peg.yaml]
    friction: [0, 0.3]
  - profile: peg
    params: {x: 0.2, y: 0.6, r: 0.05}
motion:
  - {from: -0.15, to: 0.25, step: 0.01}
  - whisk: {x: 0, y: 0, from_deg: 120, to_deg: 60, step_deg: 3}
"""


def test_a_scene_study_equals_vibrissa_scan_scene_friction_value_for_value(client, tmp_path,
                                                                           capsys):
    (tmp_path / "pegs.yaml").write_text((ROOT / "config" / "scene_two_pegs.yaml").read_text())
    (tmp_path / "one_peg.yaml").write_text(
        "obstacles:\n  - {type: peg, x: 0.0, y: 0.45, r: 0.05}\n")
    path = tmp_path / "study.yaml"
    path.write_text(SCENE_STUDY)
    from vibrissa_ros.studies.study import load_study

    sub = load_study(str(path))
    out = tmp_path / "ds"
    report = run_study(sub, str(out), client=client, progress=None)
    assert report.complete and report.computed == 10 and report.failed == 0 and not report.errors
    ds = dataset.open(str(out))
    poses, events, tasks = ds.poses, ds.events, ds.tasks
    assert list(tasks.scene[:8:2]) == ["pegs.yaml", "pegs.yaml", "one_peg.yaml", "one_peg.yaml"]
    assert (list(tasks.friction[:8:2]) == [0.0, 0.3, 0.0, 0.3]
            and tasks.scene.isna()[8] and tasks.friction.isna()[8])
    assert (list(tasks.profile) == ["scene"] * 8 + ["peg"] * 2
            and list(tasks.peg_x.isna()) == [True] * 8 + [False] * 2)
    assert poses[poses.task == 0].contacts.max() == 2
    assert set(poses[poses.task == 8].contacts) == {0, 1}  # a profile: one contact or none
    assert list(events.columns[-3:]) == ["obstacle", "contact", "s"]
    for task in sub.tasks:
        args = task.scan_command().split()[1:]
        csv_path, ev_path = tmp_path / f"{task.index}.csv", tmp_path / f"{task.index}.json"
        args[args.index("--csv") + 1] = str(csv_path)
        assert main(args + ["--events", str(ev_path)]) == 0, capsys.readouterr().err
        rows = list(csv.DictReader(io.StringIO(csv_path.read_text())))
        mine = poses[poses.task == task.index]
        scene, whisk = task.scene is not None, task.whisk is not None
        columns = (POSE_CSV_COLUMNS if whisk else CSV_COLUMNS) + (("contacts",) if scene else ())
        assert list(rows[0]) == list(columns) and len(rows) == len(mine) == (21 if whisk else 41)
        for row, (_, got) in zip(rows, mine.iterrows()):
            for col in columns:
                want = int(row[col]) if col in ("phase", "contacts") else _float(row[col])
                value = got[{"x": "foot_x", "y": "foot_y"}.get(col, col)]
                value = None if value != value else value
                assert value == want, (task.index, col)
        want_events = json.loads(ev_path.read_text())
        got_events = events[events.task == task.index]
        assert len(want_events) == len(got_events) > 0
        for want, (_, got) in zip(want_events, got_events.iterrows()):
            if whisk:
                assert (got.foot_x, got.foot_y, got.heading, got.kind) == \
                    tuple(want[k] for k in ("x", "y", "heading", "kind"))
            else:
                assert (got.x0, got.kind) == (want["x0"], want["kind"])
            if scene:
                assert got.contact == want["contact"] and got.from_phase != got.from_phase  # null
                assert got.obstacle == want.get("obstacle") and _none(got.s) == want.get("s")
            else:
                assert (got.from_phase, got.to_phase) == (want["from_phase"], want["to_phase"])
                assert (_none(got.contact) is None and _none(got.s) is None
                        and _none(got.obstacle) is None)
    # friction changes what the two pegs do; the one-peg scene without friction is the
    # single-contact problem
    assert not poses[poses.task == 0].fx.equals(poses[poses.task == 2].fx)
    assert set(events[events.task == 0].kind) <= {"touch", "release", "tip", "tangential", "slip",
                                                  "stick", "snap"}


def _none(value):
    return None if value is None or value != value else value
