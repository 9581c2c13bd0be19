"""
A study's results as a Parquet dataset: the layout, its tables, atomic writes and :func:`open`.

Layout of a study directory (every ``*.parquet`` folder is a Parquet dataset that pandas, polars,
pyarrow and dask.dataframe read as one table)::

    DIR/study.yaml            the study file, verbatim
    DIR/manifest.json         format, vibrissa_ros version, the study's sha256, task count, columns
    DIR/tasks.parquet         one row per task: its index and parameters, its reproducing command
    DIR/poses/task-*.parquet  one row per pose: task, step, the scan contract's columns, parameters
    DIR/events/task-*.parquet one row per event: task, step (the pose whose step crossed it), x0,
                              kind, from_phase, to_phase

A study with whisking motions adds the foot pose of every row, ``foot_x``, ``foot_y``,
``heading`` [L, L, rad] (the columns x, y, heading of ``vibrissa scan --whisk``'s CSV and events;
a slide's rows: x0, 0, pi/2), after ``step`` in poses and events, and the motion's columns
``motion`` (sweep or whisk) and ``whisk_x``, ``whisk_y``, ``whisk_from_deg``, ``whisk_to_deg``,
``whisk_step_deg`` (null for a slide, as ``sweep_*`` are for a whisk) to the parameters::

    DIR/failures/task-*.parquet  one row per failed task: task, error (class), reason, parameters

A study with scene files (``vibrissa scan --scene``) adds the parameters ``scene`` (the file as the
study gives it) and ``friction`` (the scene's global Coulomb coefficient of the task; obstacles
with their own coefficient keep theirs), both null for a profile task, whose ``profile`` is then
the profile's name (a scene task's is ``scene``); the poses' ``contacts`` (how many contacts hold
the whisker, after contact_y: the scan CSV's last column); and the events' ``obstacle`` (index in
the scene file), ``contact`` (side, tip or corner) and ``s`` (the contact's arc length, null when
not located), after to_phase. A scene task's events have the scene kinds (touch, release, tip,
tangential, corner, edge, slip, stick, merge, snap; doc/guide/scenes.md) and null from_phase and
to_phase (several contacts have no one phase: the poses' ``phase`` is the contact nearest the
foot's); a profile task's keep their kinds and phases. A study without scene files has none of
these columns (its datasets are unchanged).

A task is done when its ``poses`` (or ``failures``) file exists. Every file is written to a
temporary name and renamed, events before poses, so a killed run leaves only whole files and a task
is either done with all its rows or not done at all.
"""

from __future__ import annotations

import builtins
import functools
import json
import os
from dataclasses import dataclass
from typing import Dict, Iterable, List, Optional, Set, Tuple

import pyarrow as pa
import pyarrow.parquet as pq

from .. import __version__
from ..core.errors import VibrissaError
from ..core.scan import ScanResult
from ..node.noise import NoiseSpec, SensorNoise
from ..scan.scan_io import CSV_COLUMNS
from .study import NOISE_KEYS as _NOISE_FIELDS
from .study import Study, Task

FORMAT = "vibrissa-batch/1"
TABLES = ("poses", "events", "failures")
_NOISY = ("fx_noisy", "fy_noisy", "m0_noisy")
#: a whisking study's per-pose columns: the foot pose (x, y, heading of ``vibrissa scan --whisk``)
POSE_FIELDS = ("foot_x", "foot_y", "heading")
_WHISK_FIELDS = ("whisk_x", "whisk_y", "whisk_from_deg", "whisk_to_deg", "whisk_step_deg")


class DatasetError(VibrissaError):
    """A directory is not a study dataset, or holds another study's results."""


# -- schema ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Layout:
    """
    What decides a study's columns.

    Its profile parameter columns (in order), whether it has noise, whether a task whisks.

    Small, so that it travels with every task to the workers; the schemas are built there, once.
    """

    param_names: Tuple[str, ...]
    noise: bool
    whisking: bool = False
    scenes: bool = False

    @classmethod
    def of(cls, study: Study) -> "Layout":
        return cls(
            tuple(study.param_names),
            bool(study.has_noise),
            bool(study.has_whisking),
            bool(study.has_scenes),
        )

    @property
    def schemas(self) -> Dict[str, pa.Schema]:
        return _schemas(self)


def parameter_fields(layout: Layout) -> List[pa.Field]:
    """
    Return the task-parameter columns, in order.

    The profile parameters are the union of the study's profiles'.
    """
    fields = [
        pa.field("model", pa.string(), nullable=False),
        pa.field("spring_stiffness", pa.float64()),
        pa.field("taper", pa.float64(), nullable=False),
        pa.field("curvature_k0", pa.float64(), nullable=False),
        pa.field("curvature_k1", pa.float64(), nullable=False),
        pa.field("profile", pa.string(), nullable=False),
    ]
    if layout.scenes:
        fields += [pa.field("scene", pa.string()), pa.field("friction", pa.float64())]
    fields += [pa.field(name, pa.float64()) for name in layout.param_names]
    fields += [pa.field(k, pa.float64(), nullable=False) for k in ("x", "y", "rotation_deg")]
    if layout.whisking:
        fields.append(pa.field("motion", pa.string(), nullable=False))
    fields += [
        pa.field(k, pa.float64(), nullable=layout.whisking)
        for k in ("sweep_from", "sweep_to", "sweep_step")
    ]
    if layout.whisking:
        fields += [pa.field(k, pa.float64()) for k in _WHISK_FIELDS]
    fields.append(pa.field("back", pa.bool_(), nullable=False))
    if layout.noise:
        fields += [pa.field(k, pa.float64(), nullable=False) for k in _NOISE_FIELDS]
        fields.append(pa.field("noise_seed", pa.uint64(), nullable=False))
    return fields


def layout_of(study):
    """Return a study's layout: a :class:`Layout`, or an array study's ``ArrayLayout``."""
    from .array_study import ArrayLayout, ArrayStudy

    return ArrayLayout() if isinstance(study, ArrayStudy) else Layout.of(study)


def schemas(study: Study) -> Dict[str, pa.Schema]:
    """Return the schema of each table of this study's dataset."""
    return layout_of(study).schemas


@functools.lru_cache(maxsize=8)
def _schemas(layout: Layout) -> Dict[str, pa.Schema]:
    params = parameter_fields(layout)
    task = pa.field("task", pa.int64(), nullable=False)
    step = pa.field("step", pa.int32(), nullable=False)
    contract = []
    for name in CSV_COLUMNS:
        if name == "phase":
            contract.append(pa.field(name, pa.int8(), nullable=False))
        else:
            nullable = name in ("alpha", "s1", "contact_x", "contact_y")
            contract.append(pa.field(name, pa.float64(), nullable=nullable))
    noisy = [pa.field(k, pa.float64(), nullable=False) for k in _NOISY] if layout.noise else []
    pose = (
        [pa.field(k, pa.float64(), nullable=False) for k in POSE_FIELDS] if layout.whisking else []
    )
    if layout.scenes:
        contract.append(pa.field("contacts", pa.int32(), nullable=False))
    scene_events = (
        [
            pa.field("obstacle", pa.int32()),
            pa.field("contact", pa.string()),
            pa.field("s", pa.float64()),
        ]
        if layout.scenes
        else []
    )
    return {
        "tasks": pa.schema([task] + params + [pa.field("command", pa.string(), nullable=False)]),
        "poses": pa.schema([task, step] + pose + contract + noisy + params),
        "events": pa.schema(
            [task, step]
            + pose
            + [
                pa.field("x0", pa.float64(), nullable=False),
                pa.field("kind", pa.string(), nullable=False),
                pa.field("from_phase", pa.int8(), nullable=layout.scenes),
                pa.field("to_phase", pa.int8(), nullable=layout.scenes),
            ]
            + scene_events
        ),
        "failures": pa.schema(
            [
                task,
                pa.field("error", pa.string(), nullable=False),
                pa.field("reason", pa.string(), nullable=False),
            ]
            + params
        ),
    }


def task_parameters(task: Task, layout: Layout) -> Dict[str, object]:
    """Return the task's parameter columns (a value for each of :func:`parameter_fields`)."""
    params = task.param_columns()
    row: Dict[str, object] = {
        "model": task.model,
        "spring_stiffness": task.spring_stiffness,
        "taper": task.taper,
        "curvature_k0": task.curvature_k0,
        "curvature_k1": task.curvature_k1,
        "profile": task.profile,
    }
    if layout.scenes:
        scene = task.scene
        row["scene"] = None if scene is None else scene.file
        row["friction"] = None if scene is None else scene.friction
    row.update({name: params.get(name) for name in layout.param_names})
    row.update(x=task.x, y=task.y, rotation_deg=task.rotation_deg)
    if layout.whisking:
        row["motion"] = task.motion
    row.update(sweep_from=task.sweep_from, sweep_to=task.sweep_to, sweep_step=task.sweep_step)
    if layout.whisking:
        w = task.whisk
        values = (None,) * 5 if w is None else (w.x, w.y, w.from_deg, w.to_deg, w.step_deg)
        row.update(zip(_WHISK_FIELDS, values))
    row["back"] = task.back
    if task.noise is not None:
        row.update({k: getattr(task.noise, k) for k in _NOISE_FIELDS})
        row["noise_seed"] = task.noise_seed
    return row


# -- one task's tables ----------------------------------------------------------------------------


@dataclass(frozen=True)
class TaskTables:
    """What one task produced: its poses and events, or its failure (the other tables are None)."""

    task: int
    poses: Optional[pa.Table]
    events: Optional[pa.Table]
    failure: Optional[pa.Table]
    version: str = __version__


@dataclass(frozen=True)
class TaskFiles:
    """
    One task's result as the Parquet files to write, ``{table: file bytes}``.

    Encoded on the worker, so that the driver, which writes every task's files, only moves bytes.
    """

    task: int
    files: Dict[str, bytes]
    version: str = __version__

    @property
    def failed(self) -> bool:
        return "failures" in self.files


def encode(tables: TaskTables) -> TaskFiles:
    """Encode a task's tables as Parquet files (zstd)."""
    files = {}
    for name, table in (
        ("events", tables.events),
        ("poses", tables.poses),
        ("failures", tables.failure),
    ):
        if table is not None:
            sink = pa.BufferOutputStream()
            pq.write_table(table, sink, compression="zstd")
            files[name] = sink.getvalue().to_pybytes()
    return TaskFiles(tables.task, files, tables.version)


def _repeat(schema: pa.Schema, columns: Dict[str, object], n: int) -> Dict[str, pa.Array]:
    return {k: pa.array([v] * n, type=schema.field(k).type) for k, v in columns.items()}


def result_tables(task: Task, result: ScanResult, layout: Layout) -> TaskTables:
    """Return the poses and events tables of a task's scan (columns as the scan contract's)."""
    schema = layout.schemas
    states = result.states
    n = len(states)
    cols: Dict[str, object] = {
        "task": pa.array([task.index] * n, pa.int64()),
        "step": pa.array(range(n), pa.int32()),
    }
    if layout.whisking:
        cols.update(_pose_columns([s.pose for s in states]))
    cols.update({
        "x0": pa.array([s.x0 for s in states], pa.float64()),
        "phase": pa.array([int(s.phase) for s in states], pa.int8()),
        "alpha": pa.array([s.alpha for s in states], pa.float64()),
        "s1": pa.array([s.s1 for s in states], pa.float64()),
        "tip_slope": pa.array([s.tip_slope for s in states], pa.float64()),
        "f": pa.array([s.f for s in states], pa.float64()),
        "fx": pa.array([s.fx for s in states], pa.float64()),
        "fy": pa.array([s.fy for s in states], pa.float64()),
        "m0": pa.array([s.m0 for s in states], pa.float64()),
        "contact_x": pa.array([s.contact[0] if s.contact else None for s in states], pa.float64()),
        "contact_y": pa.array([s.contact[1] if s.contact else None for s in states], pa.float64()),
    })
    if layout.scenes:
        cols["contacts"] = pa.array([_contacts(s) for s in states], pa.int32())
    if task.noise is not None:
        noise = SensorNoise(
            NoiseSpec(
                enabled=True,
                seed=task.noise_seed,
                **{k: getattr(task.noise, k) for k in _NOISE_FIELDS},
            )
        )
        readings = [noise.apply(s.fx, s.fy, s.m0) for s in states]
        for i, name in enumerate(_NOISY):
            cols[name] = pa.array([r[i] for r in readings], pa.float64())
    poses_schema = schema["poses"]
    cols.update(_repeat(poses_schema, task_parameters(task, layout), n))
    poses = pa.Table.from_pydict(cols, schema=poses_schema)
    events = None
    if result.events:
        k = len(result.events)
        ev: Dict[str, object] = {
            "task": pa.array([task.index] * k, pa.int64()),
            "step": pa.array(result.event_steps, pa.int32()),
        }
        if layout.whisking:
            ev.update(_pose_columns([e.pose for e in result.events]))
        scene = task.scene is not None
        ev.update(
            {
                "x0": pa.array([float(e.x0) for e in result.events], pa.float64()),
                "kind": pa.array([e.kind for e in result.events], pa.string()),
                "from_phase": pa.array(
                    [None if scene else int(e.from_phase) for e in result.events], pa.int8()
                ),
                "to_phase": pa.array(
                    [None if scene else int(e.to_phase) for e in result.events], pa.int8()
                ),
            }
        )
        if layout.scenes:
            ev.update(
                {
                    "obstacle": pa.array(
                        [e.obstacle if scene else None for e in result.events], pa.int32()
                    ),
                    "contact": pa.array(
                        [e.contact_kind if scene else None for e in result.events], pa.string()
                    ),
                    "s": pa.array([e.s if scene else None for e in result.events], pa.float64()),
                }
            )
        events = pa.Table.from_pydict(ev, schema=schema["events"])
    return TaskTables(task.index, poses, events, None)


def _contacts(state) -> int:
    """How many contacts hold the whisker (a single-contact state: one unless it is free)."""
    contacts = getattr(state, "contacts", None)
    if contacts is not None:
        return len(contacts)
    return 0 if int(state.phase) == 0 else 1


def _pose_columns(poses) -> Dict[str, pa.Array]:
    """Return the columns foot_x, foot_y, heading of these foot poses."""
    return {
        "foot_x": pa.array([float(p.x) for p in poses], pa.float64()),
        "foot_y": pa.array([float(p.y) for p in poses], pa.float64()),
        "heading": pa.array([float(p.heading) for p in poses], pa.float64()),
    }


def failure_tables(task: Task, exc: BaseException, layout: Layout) -> TaskTables:
    """Return the failures row of a task whose scan raised ``exc``."""
    schema = layout.schemas
    cols = {
        "task": pa.array([task.index], pa.int64()),
        "error": pa.array([type(exc).__name__]),
        "reason": pa.array([str(exc) or type(exc).__name__]),
    }
    cols.update(_repeat(schema["failures"], task_parameters(task, layout), 1))
    return TaskTables(
        task.index, None, None, pa.Table.from_pydict(cols, schema=schema["failures"])
    )


# -- the directory --------------------------------------------------------------------------------


def _task_file(study_dir: str, table: str, index: int, width: int) -> str:
    return os.path.join(study_dir, table, f"task-{index:0{width}d}.parquet")


def _task_files(study_dir: str, table: str) -> List[str]:
    """Return the table's task files, sorted (= in task order: the names are zero-padded)."""
    folder = os.path.join(study_dir, table)
    return sorted(
        os.path.join(folder, f)
        for f in os.listdir(folder)
        if f.startswith("task-") and f.endswith(".parquet")
    )


def _done(study_dir: str) -> Set[int]:
    return {
        int(os.path.basename(f)[5:-8])
        for table in ("poses", "failures")
        for f in _task_files(study_dir, table)
    }


def _width(n_tasks: int) -> int:
    return max(6, len(str(n_tasks - 1)))


def _atomic(path: str, write) -> None:
    """Write a file through ``write(tmp_path)`` to a temporary name beside it, then rename it."""
    tmp = os.path.join(os.path.dirname(path), f".{os.path.basename(path)}.{os.getpid()}.tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _write_parquet(path: str, table: pa.Table) -> None:
    _atomic(path, lambda tmp: pq.write_table(table, tmp, compression="zstd"))


def _write_bytes(path: str, data: bytes) -> None:
    def write(tmp):
        with builtins.open(tmp, "wb") as stream:
            stream.write(data)

    _atomic(path, write)


def _write_text(path: str, text: str) -> None:
    def write(tmp):
        with builtins.open(tmp, "w", encoding="utf-8") as stream:
            stream.write(text)

    _atomic(path, write)


def manifest(study: Study) -> dict:
    out = {
        "format": FORMAT,
        "vibrissa_ros": __version__,
        "study_sha256": study.digest,
        "tasks": len(study.tasks),
        "seed": study.seed,
        "tables": {name: s.names for name, s in schemas(study).items()},
    }
    if getattr(layout_of(study), "kind", None) == "array":
        out["kind"] = "array"
    return out


def tasks_table(study: Study) -> pa.Table:
    from .array_study import ArrayStudy, array_tasks_table

    if isinstance(study, ArrayStudy):
        return array_tasks_table(study)
    layout = Layout.of(study)
    schema = layout.schemas["tasks"]
    rows = [
        dict(task=t.index, **task_parameters(t, layout), command=t.scan_command())
        for t in study.tasks
    ]
    return pa.Table.from_pylist(rows, schema=schema)


class StudyWriter:
    """Writes a study's results into its directory, task by task; knows which tasks are done."""

    def __init__(self, study_dir: str, study: Study):
        self.dir = study_dir
        self.study = study
        self.width = _width(len(study.tasks))

    @classmethod
    def create(cls, study_dir: str, study: Study) -> "StudyWriter":
        """
        Start the study's directory, or check that it holds this very study (then it is resumed).

        Raises :class:`DatasetError` when the directory holds another study, another version's
        results, or something else.
        """
        path = os.path.join(study_dir, "manifest.json")
        expected = manifest(study)
        if os.path.exists(study_dir) and not os.path.isdir(study_dir):
            raise DatasetError(f"{study_dir} is a file; --out needs a directory")
        if os.path.exists(path):
            try:
                with builtins.open(path, encoding="utf-8") as stream:
                    found = json.load(stream)
            except (OSError, ValueError) as exc:
                raise DatasetError(f"{study_dir}: unreadable manifest.json ({exc})") from None
            if found.get("format") != FORMAT:
                raise DatasetError(f"{study_dir}: not a {FORMAT} dataset")
            if found.get("study_sha256") != study.digest:
                raise DatasetError(
                    f"{study_dir} holds the results of another study file; give a new --out"
                )
            if found.get("vibrissa_ros") != __version__:
                raise DatasetError(
                    f"{study_dir} was computed by vibrissa_ros {found.get('vibrissa_ros')}, "
                    f"this is {__version__}: finish it with that version or give a new --out"
                )
            if found != expected:
                raise DatasetError(
                    f"{study_dir}: the study expands to other tasks than the ones stored "
                    "(another numpy random stream?); give a new --out"
                )
        elif os.path.isdir(study_dir) and os.listdir(study_dir):
            raise DatasetError(
                f"{study_dir} exists and is not a study dataset; give a new or empty --out"
            )
        for table in TABLES:
            os.makedirs(os.path.join(study_dir, table), exist_ok=True)
        writer = cls(study_dir, study)
        tasks_path = os.path.join(study_dir, "tasks.parquet")
        if not os.path.exists(tasks_path):
            _write_parquet(tasks_path, tasks_table(study))
        if not os.path.exists(os.path.join(study_dir, "study.yaml")):
            _write_text(os.path.join(study_dir, "study.yaml"), study.text)
        if not os.path.exists(
            path
        ):  # last: the manifest marks a directory as this study's dataset
            _write_text(path, json.dumps(expected, indent=1) + "\n")
        return writer

    def done(self) -> Set[int]:
        """Return the indices of the tasks whose result (poses or failure) is on disk."""
        return _done(self.dir)

    def failures(self) -> int:
        """How many failed tasks are on disk."""
        return len(_task_files(self.dir, "failures"))

    def write(self, result: TaskFiles) -> None:
        """Write one task's files atomically: events first, the poses (or failure) file last."""
        if result.version != __version__:
            raise DatasetError(
                f"task {result.task} was computed by a worker with vibrissa_ros {result.version}; "
                f"this study runs {__version__}: install the same version on every worker"
            )
        for table in ("events", "poses", "failures"):
            if table in result.files:
                _write_bytes(
                    _task_file(self.dir, table, result.task, self.width), result.files[table]
                )


# -- reading --------------------------------------------------------------------------------------


class StudyDataset:
    """
    A study directory opened for reading (see :func:`open`).

    ``table(name)`` gives a pyarrow Table of ``poses``, ``events``, ``failures`` or ``tasks``
    (rows in task order); the properties of the same names give pandas DataFrames.

    Parameters
    ----------
    path : str
        The study directory written by ``vibrissa batch``.

    Raises
    ------
    DatasetError
        When the directory has no ``manifest.json`` or is not a dataset of this format.

    """

    def __init__(self, path: str):
        self.path = path
        try:
            with builtins.open(os.path.join(path, "manifest.json"), encoding="utf-8") as stream:
                self.manifest = json.load(stream)
        except FileNotFoundError:
            raise DatasetError(f"{path}: not a study dataset (no manifest.json)") from None
        if self.manifest.get("format") != FORMAT:
            raise DatasetError(f"{path}: not a {FORMAT} dataset")
        with builtins.open(os.path.join(path, "study.yaml"), encoding="utf-8") as stream:
            self.study_text = stream.read()

    @property
    def version(self) -> str:
        """Return the vibrissa_ros version that computed the dataset."""
        return self.manifest["vibrissa_ros"]

    @property
    def n_tasks(self) -> int:
        return int(self.manifest["tasks"])

    def schemas(self) -> Dict[str, pa.Schema]:
        """Return the tables' schemas, built from the stored study."""
        from .study import parse_study

        return schemas(parse_study(self.study_text, read_scenes=False))

    def table(self, name: str, columns: Optional[Iterable[str]] = None) -> pa.Table:
        """One table as pyarrow, in task order (and step order within a task)."""
        import pyarrow.dataset as pads

        columns = list(columns) if columns is not None else None
        if name == "tasks":
            return pq.read_table(os.path.join(self.path, "tasks.parquet"), columns=columns)
        if name not in TABLES:
            raise ValueError(f"unknown table {name!r}; allowed: tasks, {', '.join(TABLES)}")
        files = _task_files(self.path, name)
        if (
            name == "events"
        ):  # events of a task killed before its poses were written are not results
            done = set(os.path.basename(f) for f in _task_files(self.path, "poses"))
            files = [f for f in files if os.path.basename(f) in done]
        if not files:
            table = self.schemas()[name].empty_table()
            return table.select(columns) if columns is not None else table
        return pads.dataset(files, format="parquet", schema=pq.read_schema(files[0])).to_table(
            columns=columns
        )

    @property
    def poses(self):
        """One row per pose (pandas DataFrame)."""
        return self.table("poses").to_pandas()

    @property
    def events(self):
        return self.table("events").to_pandas()

    @property
    def failures(self):
        return self.table("failures").to_pandas()

    @property
    def tasks(self):
        return self.table("tasks").to_pandas()

    def done(self) -> Set[int]:
        """Return the indices of the tasks computed (with poses, or failed)."""
        return _done(self.path)

    def missing(self) -> List[int]:
        """Return the tasks not computed yet (the same ``vibrissa batch`` run computes them)."""
        done = self.done()
        return [i for i in range(self.n_tasks) if i not in done]

    @property
    def complete(self) -> bool:
        return not self.missing()


def open(
    path: str,
) -> StudyDataset:  # noqa: A001 - the module's entry point, ``vibrissa_ros.studies.dataset.open``
    """
    Open a study directory written by ``vibrissa batch`` for reading.

    Parameters
    ----------
    path : str
        The study directory.

    Returns
    -------
    StudyDataset
        The dataset, opened for reading.

    Raises
    ------
    DatasetError
        When there is no such directory, or it is not a study dataset.

    """
    if not os.path.isdir(path):
        raise DatasetError(f"{path}: no such study directory")
    return StudyDataset(path)
