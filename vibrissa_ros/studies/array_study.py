"""
An array study: a whisker array against many objects and head placements (one task = one run).

A study file of ``kind: array`` (the other kind, the default, scans one planar whisker: see
:mod:`vibrissa_ros.studies.study`) names the array, the objects, the head placements and the
motions; the tasks are their product. Units are SI (metres, seconds, degrees where the key says
``_deg``)::

    kind: array
    seed: 4                                 # the random draws (default 0)
    array: rat_array.yaml                   # an array file, relative to the study file
    side: right                             # optional: one side's whiskers
    points_tolerance: 1.0e-8                # optional: each whisker's discretization error
                                            # (in its length; default 1e-11, exact; coarser
                                            # is faster, vibrissa scan --points-tolerance)
    objects:                                # a list of object blocks
      - scene: [scene_peg_array_m.yaml]       # 3D scene files in metres (a list: a grid axis)
      - cylinder: {x: {uniform: [0.02, 0.035]}, y: -0.016, z: 0, r: [0.001, 0.002],
                   axis: [0, 0, 1]}         # a solid infinite cylinder through (x, y, z)
        samples: 3                          # 3 random draws of each grid point
      - sphere: {x: 0.03, y: -0.02, z: 0, r: {uniform: [0.002, 0.004]}}
    head:                                   # the head's placement at t = 0
      x: 0                                  # [m]; y, z likewise
      yaw_deg: [-10, 0, 10]                 # about z, then pitch_deg about y, roll_deg about x
      samples: 1                            # random draws (of random keys) per object
    motion:                                 # a block or a list of blocks
      - whisk: {frequency: 8, retraction_deg: -20, protraction_deg: 20}
        duration: 0.125                     # [s] (default: one whisk period)
        rate: 1000                          # ticks per second (default 1000)
      - velocity: [0, -0.1, 0]              # the head sweeps at [m/s] (world frame)
        duration: 0.1

Every number may be a scalar, a list (a grid axis) or, in ``objects`` and ``head``, a seeded
random draw ``{uniform: [lo, hi]}`` / ``{loguniform: [lo, hi]}``. A vector (``axis``,
``velocity``) is three numbers; a list of vectors is a grid axis. A motion whisks (every whisker
the same cosine, fully retracted at t = 0), moves the head at a constant velocity, or both; the
head's orientation is kept. Random draws are made once per object (the same object meets every
placement and motion), placements once per object and sample.

A task runs what ``vibrissa scan --array`` runs (:mod:`vibrissa_ros.scan.array_scan`) and its
rows are that command's: one row per whisker and tick. The array file and the scene files are
read with the study (their text is part of the study's digest and travels to the workers: no
shared file system). A task whose array cannot be placed (a whisker cuts the object at t = 0) is
a failed task; a whisker step that fails within a run is that row's ``error``.
"""

from __future__ import annotations

import functools
import hashlib
import itertools
import math
import os
import shlex
from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple

import numpy as np

from ..core.errors import VibrissaError
from ..core.rod3d.model import POINTS_TOLERANCE, _points_tolerance
from .study import (StudyError, _axis, _block, _draw, _grid, _integer, _keys, _number, _Random,
                    _show, _values)

#: the keys of an array study
TOP_KEYS = ("kind", "description", "seed", "array", "side", "points_tolerance", "objects",
            "head", "motion")
OBJECT_KINDS = {"cylinder": ("x", "y", "z", "r", "axis"), "sphere": ("x", "y", "z", "r")}
HEAD_KEYS = ("x", "y", "z", "yaw_deg", "pitch_deg", "roll_deg", "samples")
MOTION_KEYS = ("whisk", "velocity", "duration", "rate")
WHISK_KEYS = ("frequency", "retraction_deg", "protraction_deg")
#: at most this many tasks in one study
MAX_TASKS = 10_000_000
#: the parameters of a task, its dataset columns
PARAMETERS = (
    "object", "scene", "object_x", "object_y", "object_z", "object_r", "object_axis_x",
    "object_axis_y", "object_axis_z", "head_x", "head_y", "head_z", "head_yaw_deg",
    "head_pitch_deg", "head_roll_deg", "duration", "rate", "velocity_x", "velocity_y",
    "velocity_z", "whisk_frequency", "whisk_retraction_deg", "whisk_protraction_deg",
)
_TEXT = ("object", "scene")


@dataclass(frozen=True)
class ArrayTask:
    """
    One run of an array study: an object, a head placement and a motion.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    index : int
        The task's index in the study.
    object : str
        ``scene``, ``cylinder`` or ``sphere``.
    scene_file : str or None
        A scene object's file as the study gives it.
    scene_path : str or None
        The file read.
    scene_text : str
        The task's scene as YAML in metres (a scene file's text, or the object's own scene).
    shape : tuple of float
        A cylinder's (x, y, z, r, ax, ay, az) or a sphere's (x, y, z, r) [m]; () for a scene.
    head : tuple of float
        (x, y, z [m], yaw, pitch, roll [deg]) at t = 0.
    duration, rate : float
        [s], [Hz].
    velocity : tuple of float
        The head's (vx, vy, vz) [m/s].
    whisk : tuple of float or None
        (frequency [Hz], retraction [deg], protraction [deg]); None: protraction 0.

    """

    index: int
    object: str
    scene_file: Optional[str]
    scene_path: Optional[str]
    scene_text: str
    shape: Tuple[float, ...]
    head: Tuple[float, ...]
    duration: float
    rate: float
    velocity: Tuple[float, float, float]
    whisk: Optional[Tuple[float, float, float]]

    @property
    def ticks(self) -> int:
        """Return how many ticks the run has, the start included."""
        return int(round(self.duration * self.rate)) + 1

    def parameters(self) -> Dict[str, object]:
        """
        Return the task's parameter columns (:data:`PARAMETERS`).

        Returns
        -------
        dict
            Column -> value (None where it does not apply).

        """
        row: Dict[str, object] = {k: None for k in PARAMETERS}
        row["object"] = self.object
        row["scene"] = self.scene_file
        keys = ("object_x", "object_y", "object_z", "object_r", "object_axis_x",
                "object_axis_y", "object_axis_z")
        row.update(zip(keys, self.shape))
        row.update(zip(("head_x", "head_y", "head_z", "head_yaw_deg", "head_pitch_deg",
                        "head_roll_deg"), self.head))
        row.update(duration=self.duration, rate=self.rate)
        row.update(zip(("velocity_x", "velocity_y", "velocity_z"), self.velocity))
        if self.whisk is not None:
            row.update(zip(("whisk_frequency", "whisk_retraction_deg",
                            "whisk_protraction_deg"), self.whisk))
        return row

    def run(self, array_text: str, array_label: str, side: Optional[str],
            points_tolerance: float = POINTS_TOLERANCE):
        """
        Compute the run with the functions ``vibrissa scan --array`` calls.

        Parameters
        ----------
        array_text : str
            The array file's text.
        array_label : str
            Its name, for error messages.
        side : str or None
            One side's whiskers, or all.
        points_tolerance : float, optional
            Each whisker's discretization error asked for (the study's).

        Returns
        -------
        ArrayScanResult
            The run.

        """
        from ..core.arrays.whisking import CosineWhisk
        from ..scan.array_scan import head_pose, plan_array_scan, timed_path

        array = _array(array_text, array_label, side)
        scene = _scene(self.scene_text, self.scene_path or "the task's object")
        x, y, z, yaw, pitch, roll = self.head
        path = timed_path(self.duration, self.rate, head_pose((x, y, z), yaw, pitch, roll),
                          self.velocity)
        whisk = None
        if self.whisk is not None:
            f, ret, pro = self.whisk
            whisk = CosineWhisk(f, math.radians(ret), math.radians(pro))
        return plan_array_scan(array, scene, path, whisk, points_tolerance).run()

    def scan_command(self, array_path: str, side: Optional[str],
                     points_tolerance: float = POINTS_TOLERANCE) -> str:
        """
        Return the ``vibrissa scan --array`` command that computes this task's rows.

        A generated object's scene is the tasks table's ``scene_yaml``, written to
        ``task-<index>.scene.yaml``.

        Parameters
        ----------
        array_path : str
            The array file as ``vibrissa batch`` read it.
        side : str or None
            The study's side.
        points_tolerance : float, optional
            The study's (``--points-tolerance`` where it is not the default).

        Returns
        -------
        str
            The command.

        """
        scene = self.scene_path if self.scene_path else f"task-{self.index}.scene.yaml"
        words = ["vibrissa", "scan", "--array", shlex.quote(array_path)]
        if side is not None:
            words += ["--side", side]
        words += ["--scene", shlex.quote(scene)]
        if self.whisk is not None:
            words.append("--whisk=" + ",".join(repr(v) for v in self.whisk))
        words += [f"--duration={self.duration!r}", f"--rate={self.rate!r}",
                  "--head=" + ",".join(repr(v) for v in self.head)]
        if any(self.velocity):
            words.append("--velocity=" + ",".join(repr(v) for v in self.velocity))
        if points_tolerance != POINTS_TOLERANCE:
            words.append(f"--points-tolerance={points_tolerance!r}")
        return " ".join(words + ["--out", f"task-{self.index}.parquet"])


@functools.lru_cache(maxsize=4)
def _array(text: str, label: str, side: Optional[str]):
    from ..scan.array_file import parse_array

    array = parse_array(text, label)
    if side is not None and not any(w.side == side for w in array):
        raise VibrissaError(f"{label}: no whisker on the {side} side (side = {side})")
    return array if side is None else array.side(side)


@functools.lru_cache(maxsize=64)
def _scene(text: str, label: str):
    from ..scan.scene_file import load_scene3d

    try:
        return load_scene3d(text)
    except VibrissaError as exc:
        raise type(exc)(f"{label}: {str(exc).split(': ', 1)[-1]}") from None


def object_scene_text(kind: str, shape: Tuple[float, ...]) -> str:
    """
    Return the scene YAML (metres) of a generated object.

    Parameters
    ----------
    kind : str
        ``cylinder`` or ``sphere``.
    shape : tuple of float
        (x, y, z, r, ax, ay, az) or (x, y, z, r).

    Returns
    -------
    str
        A scene file's text with one obstacle named ``object``.

    """
    x, y, z, r = (repr(float(v)) for v in shape[:4])
    if kind == "cylinder":
        axis = ", ".join(repr(float(v)) for v in shape[4:])
        return (f"obstacles:\n  - {{type: cylinder, name: object, point: [{x}, {y}, {z}], "
                f"axis: [{axis}], r: {r}}}\n")
    return f"obstacles:\n  - {{type: sphere, name: object, center: [{x}, {y}, {z}], r: {r}}}\n"


@dataclass(frozen=True)
class ArrayStudy:
    """
    A validated array study: its text, digest, array and tasks.

    Made by :func:`parse_array_study`; the parameters are the dataclass's fields, kept as
    attributes of the same names.

    Parameters
    ----------
    text : str
        The study's YAML text.
    digest : str
        SHA-256 of the text, the array file's and the scene files' texts.
    seed : int
        The random draws' seed.
    tasks : tuple of ArrayTask
        The runs, in order.
    array_file : str
        The array file as the study gives it.
    array_path : str
        The file read.
    array_text : str
        Its text.
    side : str or None
        One side's whiskers, or all.
    whiskers : int
        How many whiskers a run has (0 when the array file was not read).
    points_tolerance : float, optional
        Each whisker's discretization error asked for, in its length (default 1e-11).

    """

    text: str
    digest: str
    seed: int
    tasks: Tuple[ArrayTask, ...]
    array_file: str
    array_path: str
    array_text: str
    side: Optional[str]
    whiskers: int
    points_tolerance: float = POINTS_TOLERANCE

    @property
    def poses(self) -> int:
        """Return the number of rows the study writes (ticks x whiskers, summed over tasks)."""
        return sum(t.ticks for t in self.tasks) * self.whiskers


def parse_array_study(doc: dict, text: str, base_dir: Optional[str] = None,
                      read_files: bool = True) -> ArrayStudy:
    """
    Validate an array study (its YAML mapping) and expand it into its tasks.

    Parameters
    ----------
    doc : dict
        The study's YAML mapping (``kind: array``).
    text : str
        Its text (for the digest).
    base_dir : str, optional
        Where the array and scene files are found relative to.
    read_files : bool, optional
        With False the array and scene files are not read: enough for the dataset's columns,
        not to run the tasks.

    Returns
    -------
    ArrayStudy
        The validated study.

    Raises
    ------
    StudyError
        In one line, what is invalid.

    """
    _keys("study", doc, TOP_KEYS, required=("array", "objects", "motion"))
    seed = _integer("seed", doc.get("seed", 0), minimum=0)
    if "description" in doc and not isinstance(doc["description"], str):
        raise StudyError("description must be a string")
    side = doc.get("side")
    if side is not None and side not in ("left", "right"):
        raise StudyError(f"side = {_show(side)} is not allowed; side is left or right")
    points_tolerance = doc.get("points_tolerance", POINTS_TOLERANCE)
    if isinstance(points_tolerance, bool) or not isinstance(points_tolerance, (int, float)):
        raise StudyError(f"points_tolerance = {_show(points_tolerance)} must be one number "
                         "(each whisker's discretization error, in its length)")
    try:
        points_tolerance = _points_tolerance(points_tolerance)
    except VibrissaError as exc:
        raise StudyError(str(exc)) from None
    name = doc["array"]
    if not isinstance(name, str) or not name.strip():
        raise StudyError(f"array = {_show(name)} must be an array file's path")
    array_path = os.path.normpath(os.path.join(base_dir or "", os.path.expanduser(name)))
    array_text, whiskers = "", 0
    if read_files:
        array_text = _read(f"array = {name!r}", array_path)
        try:
            whiskers = len(_array(array_text, array_path, side))
        except VibrissaError as exc:
            raise StudyError(f"array = {name!r}: {exc}") from None
    objects = _objects(doc["objects"], seed, base_dir, read_files)
    placements = _heads(doc.get("head", {}), seed, len(objects))
    motions = _motions(doc["motion"])
    count = sum(len(p) for p in placements) * len(motions)
    if count > MAX_TASKS:
        raise StudyError(f"the study expands to {count:,} tasks; at most {MAX_TASKS:,} are "
                         "allowed")
    tasks: List[ArrayTask] = []
    for (kind, file, path, scene_text, shape), heads in zip(objects, placements):
        for head in heads:
            for duration, rate, velocity, whisk in motions:
                tasks.append(ArrayTask(len(tasks), kind, file, path, scene_text, shape, head,
                                       duration, rate, velocity, whisk))
    digest = hashlib.sha256(text.encode("utf-8"))
    digest.update(f"\0{name}\0{array_text}".encode("utf-8"))
    seen = set()
    for kind, file, path, scene_text, _ in objects:
        if file is not None and path not in seen:
            seen.add(path)
            digest.update(f"\0{file}\0{scene_text}".encode("utf-8"))
    return ArrayStudy(text, digest.hexdigest(), seed, tuple(tasks), name, array_path,
                      array_text, side, whiskers, points_tolerance)


def _read(where: str, path: str) -> str:
    try:
        with open(path, encoding="utf-8") as stream:
            return stream.read()
    except OSError as exc:
        raise StudyError(f"{where}: {path} cannot be read ({exc.strerror or exc})") from None
    except UnicodeDecodeError as exc:
        raise StudyError(f"{where}: {path} is not text ({exc})") from None


_Object = Tuple[str, Optional[str], Optional[str], str, Tuple[float, ...]]


def _objects(block, seed: int, base_dir: Optional[str], read: bool) -> List[_Object]:
    """Return (kind, scene file, path, scene text, shape) of every object."""
    if isinstance(block, dict):
        block = [block]
    if not isinstance(block, list) or not block:
        raise StudyError("objects must be a non-empty list of {scene}, {cylinder, samples} or "
                         "{sphere, samples} blocks")
    out: List[_Object] = []
    for i, entry in enumerate(block):
        where = f"objects[{i}]"
        kinds = [k for k in ("scene",) + tuple(OBJECT_KINDS) if isinstance(entry, dict)
                 and k in entry]
        if len(kinds) != 1:
            raise StudyError(f"{where} must be a mapping with one of the keys scene, cylinder, "
                             f"sphere, not {_show(entry)}")
        kind = kinds[0]
        if kind == "scene":
            _block(where, entry, ("scene",))
            files = entry["scene"] if isinstance(entry["scene"], list) else [entry["scene"]]
            if not files:
                raise StudyError(f"{where}.scene is an empty list; give at least one scene file")
            for name in files:
                if not isinstance(name, str) or not name.strip():
                    raise StudyError(f"{where}.scene = {_show(name)} must be a scene file's path")
            if len(set(files)) != len(files):
                raise StudyError(f"{where}.scene lists a file twice")
            for name in files:
                path = os.path.normpath(os.path.join(base_dir or "", os.path.expanduser(name)))
                text = ""
                if read:
                    text = _read(f"{where}.scene = {name!r}", path)
                    try:
                        _scene(text, path)
                    except VibrissaError as exc:
                        raise StudyError(f"{where}.scene = {name!r}: {exc}") from None
                out.append(("scene", name, path, text, ()))
            continue
        _block(where, entry, (kind, "samples"))
        keys = OBJECT_KINDS[kind]
        params = _block(f"{where}.{kind}", entry[kind], keys,
                        required=tuple(k for k in keys if k != "axis"))
        axes = {k: _axis(f"{where}.{kind}.{k}", params[k], positive=(k == "r"))
                for k in keys if k != "axis"}
        if kind == "cylinder":
            axes["axis"] = _vectors(f"{where}.cylinder.axis", params.get("axis", [0, 0, 1]))
        samples = _integer(f"{where}.samples", entry.get("samples", 1), minimum=1)
        random = any(isinstance(v, _Random) for axis in axes.values() for v in axis)
        if samples > 1 and not random:
            raise StudyError(f"{where}.samples > 1 needs a random parameter "
                             "({uniform: [lo, hi]})")
        for combo_index, combo in enumerate(_grid(f"{where}.{kind}", axes)):
            for sample in range(samples):
                rng = np.random.default_rng([seed, 11, i, combo_index, sample])
                shape = tuple(_draw(combo[k], rng) for k in keys if k != "axis")
                if kind == "cylinder":
                    shape += tuple(combo["axis"])
                text = object_scene_text(kind, shape)
                try:
                    _scene(text, where)
                except VibrissaError as exc:
                    raise StudyError(f"{where} {kind} {list(shape)}: {exc}") from None
                out.append((kind, None, None, text, shape))
    return out


def _vectors(where: str, value) -> List[Tuple[float, float, float]]:
    """Return a vector [x, y, z] or a list of them (a grid axis)."""
    items = value if isinstance(value, list) and value and isinstance(value[0], list) \
        else [value]
    out = []
    for item in items:
        if not isinstance(item, list) or len(item) != 3:
            raise StudyError(f"{where} = {_show(item)} must be a vector [x, y, z] or a list of "
                             "them")
        out.append(tuple(_number(where, v) for v in item))
    if len(set(out)) != len(out):
        raise StudyError(f"{where} lists a value twice")
    return out


def _heads(block, seed: int, n_objects: int) -> List[List[Tuple[float, ...]]]:
    """Return, per object, the head placements (x, y, z, yaw, pitch, roll)."""
    block = _block("head", block, HEAD_KEYS)
    keys = HEAD_KEYS[:-1]
    axes = {k: _axis(f"head.{k}", block.get(k, 0.0)) for k in keys}
    samples = _integer("head.samples", block.get("samples", 1), minimum=1)
    random = any(isinstance(v, _Random) for axis in axes.values() for v in axis)
    if samples > 1 and not random:
        raise StudyError("head.samples > 1 needs a random placement ({uniform: [lo, hi]})")
    out = []
    for ob in range(n_objects):
        rows = []
        for combo_index, combo in enumerate(_grid("head", axes)):
            for sample in range(samples):
                rng = np.random.default_rng([seed, 12, ob, combo_index, sample])
                rows.append(tuple(_draw(combo[k], rng) for k in keys))
        out.append(rows)
    return out


def _motions(block) -> list:
    """Return (duration, rate, velocity, whisk) of every motion."""
    blocks = block if isinstance(block, list) else [block]
    if not blocks:
        raise StudyError("motion must be a {whisk, velocity, duration, rate} block or a "
                         "non-empty list of them")
    out = []
    for i, entry in enumerate(blocks):
        where = "motion" if not isinstance(block, list) else f"motion[{i}]"
        entry = _block(where, entry, MOTION_KEYS)
        whisks: List[Optional[Tuple[float, float, float]]] = [None]
        if "whisk" in entry:
            w = _block(f"{where}.whisk", entry["whisk"], WHISK_KEYS,
                       required=("retraction_deg", "protraction_deg"))
            axes = {"frequency": _values(f"{where}.whisk.frequency", w.get("frequency", 8.0),
                                         positive=True),
                    "retraction_deg": _values(f"{where}.whisk.retraction_deg",
                                              w["retraction_deg"]),
                    "protraction_deg": _values(f"{where}.whisk.protraction_deg",
                                               w["protraction_deg"])}
            whisks = []
            for combo in _grid(f"{where}.whisk", axes):
                if combo["protraction_deg"] < combo["retraction_deg"]:
                    raise StudyError(f"{where}.whisk: protraction_deg = "
                                     f"{combo['protraction_deg']!r} must be >= retraction_deg = "
                                     f"{combo['retraction_deg']!r}")
                whisks.append(tuple(combo[k] for k in WHISK_KEYS))
        velocities = _vectors(f"{where}.velocity", entry.get("velocity", [0.0, 0.0, 0.0]))
        if "duration" in entry:
            durations = _values(f"{where}.duration", entry["duration"], positive=True)
        elif whisks != [None] and len({w[0] for w in whisks}) == 1:
            durations = [1.0 / whisks[0][0]]
        else:
            raise StudyError(f"{where}: key 'duration' is required (without a whisk of one "
                             "frequency, whose period is the default)")
        rates = _values(f"{where}.rate", entry.get("rate", 1000.0), positive=True)
        for duration, rate, velocity, whisk in itertools.product(durations, rates, velocities,
                                                                 whisks):
            if whisk is None and not any(velocity):
                raise StudyError(f"{where}: the motion neither whisks nor moves the head; give "
                                 "whisk and/or a velocity other than 0")
            ticks = int(round(duration * rate)) + 1
            if not 2 <= ticks <= 10_000_000:
                raise StudyError(f"{where}: duration {duration!r} s at rate {rate!r} Hz gives "
                                 f"{ticks} ticks; allowed: 2 to 10,000,000")
            out.append((duration, rate, velocity, whisk))
    return out


# -- the dataset ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class ArrayLayout:
    """
    The columns of an array study's dataset (the same for every array study).

    Small, so that it travels with every task to the workers.
    """

    kind: str = "array"

    @property
    def schemas(self):
        """Return the schema of each table (tasks, poses, events, failures)."""
        return _schemas()


@functools.lru_cache(maxsize=1)
def _schemas():
    import pyarrow as pa

    from ..scan.array_scan import arrow_schema

    params = [pa.field(k, pa.string() if k in _TEXT else pa.float64(),
                       nullable=k not in ("object", "head_x", "head_y", "head_z", "duration",
                                          "rate"))
              for k in PARAMETERS]
    task = pa.field("task", pa.int64(), nullable=False)
    rows = list(arrow_schema())
    return {
        "tasks": pa.schema([task] + params + [pa.field("scene_yaml", pa.string()),
                                              pa.field("command", pa.string(),
                                                       nullable=False)]),
        "poses": pa.schema([task] + rows + params),
        "events": pa.schema([
            task, pa.field("tick", pa.int64(), nullable=False),
            pa.field("t", pa.float64(), nullable=False),
            pa.field("whisker", pa.string(), nullable=False),
            pa.field("kind", pa.string(), nullable=False),
            pa.field("obstacle", pa.string()), pa.field("s", pa.float64()),
            pa.field("contacts_before", pa.int32()), pa.field("contacts_after", pa.int32()),
            pa.field("reason", pa.string())]),
        "failures": pa.schema([task, pa.field("error", pa.string(), nullable=False),
                               pa.field("reason", pa.string(), nullable=False)] + params),
    }


def _repeat(schema, values: Dict[str, object], n: int):
    import pyarrow as pa

    return {k: pa.array([v] * n, type=schema.field(k).type) for k, v in values.items()}


def array_result_tables(task: ArrayTask, result):
    """
    Return the poses and events tables of an array task's run.

    Parameters
    ----------
    task : ArrayTask
        The task.
    result : ArrayScanResult
        Its run.

    Returns
    -------
    TaskTables
        Poses (the run's rows, the task's parameters after them) and events (or None).

    """
    import pyarrow as pa

    from ..scan.array_scan import array_event_records, array_scan_columns
    from .dataset import TaskTables

    schema = _schemas()
    cols: Dict[str, object] = dict(array_scan_columns(result))
    n = len(cols["t"])
    cols = {"task": [task.index] * n, **cols}
    cols.update(_repeat(schema["poses"], task.parameters(), n))
    poses = pa.Table.from_pydict(cols, schema=schema["poses"])
    records = array_event_records(result)
    events = None
    if records:
        fields = [f.name for f in schema["events"]][1:]
        ev = {"task": [task.index] * len(records)}
        ev.update({k: [r.get(k) for r in records] for k in fields})
        events = pa.Table.from_pydict(ev, schema=schema["events"])
    return TaskTables(task.index, poses, events, None)


def array_failure_tables(task: ArrayTask, exc: BaseException):
    """
    Return the failures row of an array task whose run raised ``exc``.

    Parameters
    ----------
    task : ArrayTask
        The task.
    exc : BaseException
        What it raised.

    Returns
    -------
    TaskTables
        The failure row.

    """
    import pyarrow as pa

    from .dataset import TaskTables

    schema = _schemas()["failures"]
    cols = {"task": pa.array([task.index], pa.int64()),
            "error": pa.array([type(exc).__name__]),
            "reason": pa.array([str(exc) or type(exc).__name__])}
    cols.update(_repeat(schema, task.parameters(), 1))
    return TaskTables(task.index, None, None, pa.Table.from_pydict(cols, schema=schema))


def array_tasks_table(study: ArrayStudy):
    """
    Return the tasks table: one row per task, its parameters, scene and command.

    Parameters
    ----------
    study : ArrayStudy
        The study.

    Returns
    -------
    pyarrow.Table
        task, the parameters, ``scene_yaml`` (a generated object's scene, metres; null for a
        scene file) and ``command`` (its ``vibrissa scan --array``).

    """
    import pyarrow as pa

    rows = [dict(task=t.index, **t.parameters(),
                 scene_yaml=None if t.scene_file is not None else t.scene_text,
                 command=t.scan_command(study.array_path, study.side,
                                        study.points_tolerance))
            for t in study.tasks]
    return pa.Table.from_pylist(rows, schema=_schemas()["tasks"])


def run_array_task(task: ArrayTask, layout: ArrayLayout, array_text: str, array_label: str,
                   side: Optional[str], points_tolerance: float = POINTS_TOLERANCE):
    """
    Compute one array task (on a worker) and encode its tables as Parquet files.

    Parameters
    ----------
    task : ArrayTask
        The task.
    layout : ArrayLayout
        The dataset's layout.
    array_text : str
        The array file's text (sent to each worker once).
    array_label : str
        Its path, for messages.
    side : str or None
        The study's side.
    points_tolerance : float, optional
        The study's discretization tolerance.

    Returns
    -------
    TaskFiles
        Its poses and events files, or its failure.

    """
    from .dataset import encode

    del layout
    try:
        result = task.run(array_text, array_label, side, points_tolerance)
    except VibrissaError as exc:
        return encode(array_failure_tables(task, exc))
    return encode(array_result_tables(task, result))
