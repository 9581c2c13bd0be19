"""
A whisker array's run, as ``vibrissa scan --array A.yaml --scene S.yaml`` computes it.

Every whisker of the array (:class:`~vibrissa_ros.core.arrays.tracker.ArrayTracker`) follows
the head along a path of ticks: head poses (position [m], unit quaternion) and protraction
angles [rad], from a poses file (:func:`read_head_poses_csv`), a whisk
(:class:`~vibrissa_ros.core.arrays.whisking.CosineWhisk`) or both. The array is placed unloaded
at the first tick (its row is the initial state) and stepped from tick to tick. A whisker whose
step fails keeps its state and the others go on; the failure is the row's ``error``.

The results are one row per whisker and tick (:func:`array_scan_columns`), written as CSV or
Parquet (:func:`write_array_scan`), SI units: seconds, metres, newtons, newton-metres, radians.

Columns, in order:

``t, tick, whisker, side, row, column, protraction``
    Time [s], tick index, the whisker's name, side, row letter and column (0: the Greek
    column), its protraction [rad].
``contacts, kind, obstacle, s, f``
    Number of contacts; the contact nearest the base: ``side`` or ``tip``, the obstacle's name,
    its arc length from the base [m] and normal force [N].
``fx, fy, fz, mx, my, mz``
    The total contact force on the whisker [N] and the moment of the contact forces about its
    base point [N m], in the whisker's own base frame (x along the base tangent, y toward which
    the unloaded whisker curves): what a follicle sensor measures.
``fx_world, fy_world, fz_world, mx_world, my_world, mz_world``
    The same in the world frame.
``contact_x, contact_y, contact_z, tip_x, tip_y, tip_z``
    The nearest contact's point and the tip, world frame [m].
``error``
    Why the whisker's step failed at this tick (it kept its previous state), else empty.

A free row has contacts = 0, zero force and moment, and empty (None) kind, obstacle, s, f and
contact point, never NaN.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from typing import IO, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..core.arrays.array import WhiskerArray
from ..core.arrays.partition import PartitionedArrayTracker
from ..core.arrays.tracker import ArrayStep, ArrayTracker
from ..core.arrays.whisking import CosineWhisk
from ..core.errors import ParameterError, VibrissaError
from ..core.rod3d.model import POINTS_TOLERANCE, _points_tolerance
from ..core.rod3d.pose import BasePose
from ..core.rod3d.scene import Scene3D

#: the head-pose columns of an array's poses file (``vibrissa scan --array --poses``)
HEAD_COLUMNS = ("t", "x", "y", "z", "qw", "qx", "qy", "qz")
#: the output's columns, in order (see the module)
ARRAY_COLUMNS = (
    "t", "tick", "whisker", "side", "row", "column", "protraction",
    "contacts", "kind", "obstacle", "s", "f",
    "fx", "fy", "fz", "mx", "my", "mz",
    "fx_world", "fy_world", "fz_world", "mx_world", "my_world", "mz_world",
    "contact_x", "contact_y", "contact_z", "tip_x", "tip_y", "tip_z", "error",
)
#: the columns of text (the others are numbers; tick, column and contacts integers)
TEXT_COLUMNS = ("whisker", "side", "row", "kind", "obstacle", "error")
INT_COLUMNS = ("tick", "column", "contacts")
#: the Parquet schema's metadata key of the whiskers' discretization error (points_tolerance)
POINTS_TOLERANCE_KEY = "vibrissa_ros.points_tolerance"
#: the largest number of ticks of one run
MAX_TICKS = 10_000_000


@dataclass(frozen=True)
class HeadPath:
    """
    The ticks of an array run: times, head poses and protraction angles.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    times : tuple of float
        t [s] of every tick, increasing.
    heads : tuple of BasePose
        The head pose of every tick (position [m]).
    protraction : numpy.ndarray or None
        (ticks,) one angle for every whisker, or (ticks, k) one per whisker [rad]; None: given
        later (a whisk) or 0.
    named : tuple of str
        With a (ticks, k) protraction: the whiskers' names its columns belong to (the others
        take ``protraction``'s shared column, or 0).
    where : callable
        ``where(i)`` names tick ``i`` in error messages (e.g. its file and line).

    """

    times: Tuple[float, ...]
    heads: Tuple[BasePose, ...]
    protraction: Optional[np.ndarray] = None
    named: Optional[Dict[str, np.ndarray]] = None
    where: Optional[Callable[[int], str]] = None

    def describe(self, index: int) -> str:
        """
        Return where tick ``index`` comes from (for error messages).

        Parameters
        ----------
        index : int
            The tick.

        Returns
        -------
        str
            E.g. ``--poses P.csv, line 5`` or ``tick 5 (t = 0.005 s)``.

        """
        if self.where is not None:
            return self.where(index)
        return f"tick {index} (t = {self.times[index]:.9g} s)"


def _head_where(path: str, lines: Sequence[int]) -> Callable[[int], str]:
    def where(index: int) -> str:
        return f"--poses {path}, line {lines[index]}"

    return where


def read_head_poses_csv(path: str) -> HeadPath:
    """
    Read an array run's head path: columns t, x, y, z [s, m] and qw, qx, qy, qz.

    An optional column ``protraction`` [rad] gives every whisker's protraction at each tick;
    columns ``protraction_<NAME>`` (e.g. ``protraction_RC2``) give one whisker's, overriding
    ``protraction`` for it. Other columns are ignored.

    Parameters
    ----------
    path : str
        The CSV file.

    Returns
    -------
    HeadPath
        The ticks (at least one), times strictly increasing.

    Raises
    ------
    ParameterError
        One line naming the file (and the line or column): the file cannot be read, a column
        is missing, a value is not a finite number, a quaternion is not of unit length (within
        1e-6), the times do not increase, or there is no row.

    """
    times: List[float] = []
    heads: List[BasePose] = []
    shared: List[float] = []
    lines: List[int] = []
    try:
        with open(path, newline="") as stream:
            reader = csv.DictReader(stream, skipinitialspace=True)
            names = [c.strip() for c in (reader.fieldnames or [])]
            reader.fieldnames = names
            missing = [c for c in HEAD_COLUMNS if c not in names]
            if missing:
                raise ParameterError(f"--poses {path}: missing column(s) {', '.join(missing)}; "
                                     f"an array's poses file needs {','.join(HEAD_COLUMNS)} "
                                     "[s, m] and optionally protraction [rad]")
            has_shared = "protraction" in names
            per = [c for c in names if c.startswith("protraction_")]
            named: Dict[str, List[float]] = {c[len("protraction_"):]: [] for c in per}
            for row in reader:
                line = reader.line_num
                try:
                    values = [_finite(row[c], c) for c in HEAD_COLUMNS]
                    if times and not values[0] > times[-1]:
                        raise ValueError(f"t = {values[0]!r} s does not follow t = {times[-1]!r}"
                                         " s; times must increase")
                    heads.append(BasePose(tuple(values[1:4]), tuple(values[4:])))
                    if has_shared:
                        shared.append(_finite(row["protraction"], "protraction"))
                    for name in named:
                        named[name].append(_finite(row["protraction_" + name],
                                                   "protraction_" + name))
                except (TypeError, ValueError) as exc:
                    raise ParameterError(f"--poses {path}, line {line}: {exc}") from None
                times.append(values[0])
                lines.append(line)
    except OSError as exc:
        raise ParameterError(f"--poses {path}: {exc.strerror or exc}") from None
    if not heads:
        raise ParameterError(f"--poses {path}: no poses")
    return HeadPath(tuple(times), tuple(heads),
                    np.array(shared) if has_shared else None,
                    {k: np.array(v) for k, v in named.items()},
                    _head_where(str(path), tuple(lines)))


def _finite(text, column: str) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise ValueError(f"{column} = {text!r} is not a number") from None
    if not math.isfinite(value):
        raise ValueError(f"{column} = {text!r} is not finite")
    return value


def head_pose(position: Sequence[float], yaw_deg: float = 0.0, pitch_deg: float = 0.0,
              roll_deg: float = 0.0) -> BasePose:
    """
    Return a head pose from a position and yaw, pitch, roll angles.

    The orientation is Rz(yaw) Ry(pitch) Rx(roll): yaw about the world's z, then pitch about
    the turned y, then roll about the turned x (intrinsic z-y-x).

    Parameters
    ----------
    position : sequence of float
        (x, y, z) [m].
    yaw_deg, pitch_deg, roll_deg : float, optional
        [deg].

    Returns
    -------
    BasePose
        The head pose.

    """
    y, p, r = (math.radians(v) / 2.0 for v in (yaw_deg, pitch_deg, roll_deg))
    cy, sy, cp, sp, cr, sr = (math.cos(y), math.sin(y), math.cos(p), math.sin(p), math.cos(r),
                              math.sin(r))
    q = (cy * cp * cr + sy * sp * sr, cy * cp * sr - sy * sp * cr,
         cy * sp * cr + sy * cp * sr, sy * cp * cr - cy * sp * sr)
    return BasePose(tuple(float(v) for v in position), q)


def timed_path(duration: float, rate: float, head: Optional[BasePose] = None,
               velocity: Sequence[float] = (0.0, 0.0, 0.0)) -> HeadPath:
    """
    Return the ticks of a run of ``duration`` at ``rate``: the head fixed, or moving straight.

    Ticks at t = i / rate, i = 0 ... round(duration rate) (the first is the start).

    Parameters
    ----------
    duration : float
        [s], > 0.
    rate : float
        Ticks per second [Hz], > 0.
    head : BasePose, optional
        The head pose at t = 0; default the world's origin.
    velocity : sequence of float, optional
        (vx, vy, vz) [m/s]: the head moves by velocity t, its orientation kept.

    Returns
    -------
    HeadPath
        The ticks.

    Raises
    ------
    ParameterError
        When the duration or rate is not a finite number > 0, there would be fewer than two
        or more than :data:`MAX_TICKS` ticks, or the velocity is not 3 finite numbers.

    """
    for key, value, unit in (("duration", duration, "s"), ("rate", rate, "Hz")):
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(value) or value <= 0.0:
            raise ParameterError(f"{key} = {value!r} is not allowed; it is a number > 0 [{unit}]")
    n = int(round(duration * rate))
    if n < 1 or n >= MAX_TICKS:
        raise ParameterError(f"duration {duration!r} s at rate {rate!r} Hz gives {n + 1} ticks; "
                             f"allowed: 2 to {MAX_TICKS:,}")
    v = np.asarray(velocity, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ParameterError(f"velocity = {list(velocity)!r} is not allowed; it is [vx, vy, vz] "
                             "[m/s], finite")
    head = BasePose((0.0, 0.0, 0.0)) if head is None else head
    times = tuple(i / rate for i in range(n + 1))
    if not v.any():
        return HeadPath(times, (head,) * len(times), None, {})
    p0 = np.asarray(head.position, dtype=float)
    heads = tuple(BasePose(tuple((p0 + v * t).tolist()), head.quaternion) for t in times)
    return HeadPath(times, heads, None, {})


@dataclass(frozen=True)
class ArrayScan:
    """
    An array run, checked and ready to run (:func:`plan_array_scan`).

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    array : WhiskerArray
        The whiskers (SI units, head frame).
    scene : Scene3D
        The obstacles in the world frame [m].
    path : HeadPath
        The ticks.
    protraction : numpy.ndarray
        (ticks, k) every whisker's protraction at every tick [rad].
    points_tolerance : float, optional
        Each whisker's discretization error asked for, in its own length (ArrayTracker's).

    """

    array: WhiskerArray
    scene: Scene3D
    path: HeadPath
    protraction: np.ndarray
    points_tolerance: float = POINTS_TOLERANCE

    def tracker(self, workers: int = 1):
        """
        Return the tracker with every whisker unloaded at the first tick.

        Parameters
        ----------
        workers : int, optional
            Deal the whiskers to this many processes (:class:`PartitionedArrayTracker`, the
            same results; close it when done); 1: an :class:`ArrayTracker` in this process.

        Returns
        -------
        ArrayTracker or PartitionedArrayTracker
            The tracker.

        Raises
        ------
        InvalidPoseError
            When an unloaded whisker cuts an obstacle at the first tick (naming it and the tick).

        """
        try:
            if workers > 1:
                return PartitionedArrayTracker(
                    self.array, self.scene, self.path.heads[0], self.protraction[0],
                    workers=workers, points_tolerance=self.points_tolerance)
            return ArrayTracker(self.array, self.scene, self.path.heads[0], self.protraction[0],
                                points_tolerance=self.points_tolerance)
        except VibrissaError as exc:
            raise type(exc)(f"{self.path.describe(0)}: {exc}") from None

    def run(self, shape_tick: Optional[int] = None, shape_points: int = 41,
            progress: Optional[Callable[[int], None]] = None,
            workers: int = 1) -> "ArrayScanResult":
        """
        Step the array through every tick.

        Parameters
        ----------
        shape_tick : int, optional
            Keep every whisker's centerline at this tick (for figures); -1: at the first tick
            with the most whiskers in contact; None: keep none.
        shape_points : int, optional
            Points per kept centerline.
        progress : callable, optional
            Called with the number of ticks done after each tick.
        workers : int, optional
            Deal the whiskers to this many processes (whisker i to part i mod workers; the
            same results): for a long run on a machine with cores to spare.

        Returns
        -------
        ArrayScanResult
            One :class:`ArrayStep` per tick.

        Raises
        ------
        InvalidPoseError
            When an unloaded whisker cuts an obstacle at the first tick.
        ConvergenceError
            With ``workers`` > 1, when a worker process does not start or ends.

        """
        tracker = self.tracker(workers)
        try:
            steps = [tracker.state]
            best = (-1, None, None)
            if shape_tick is not None:
                best = self._keep(tracker, 0, shape_tick, shape_points, best)
            for i in range(1, len(self.path.times)):
                steps.append(tracker.step(self.path.heads[i], self.protraction[i]))
                if shape_tick is not None:
                    best = self._keep(tracker, i, shape_tick, shape_points, best)
                if progress is not None:
                    progress(i)
        finally:
            if isinstance(tracker, PartitionedArrayTracker):
                tracker.close()
        return ArrayScanResult(self.array, self.path.times, tuple(steps), best[1], best[2],
                               self.points_tolerance)

    @staticmethod
    def _keep(tracker, i, wanted, n, best):
        count = tracker.state.in_contact
        if (wanted == -1 and count > best[0]) or wanted == i:
            return (count, i, tracker.centerlines(n))
        return best


def plan_array_scan(array: WhiskerArray, scene: Scene3D, path: HeadPath,
                    whisk: Optional[CosineWhisk] = None,
                    points_tolerance: float = POINTS_TOLERANCE) -> ArrayScan:
    """
    Check an array run before it runs: every tick's protraction, the array clear at the start.

    Parameters
    ----------
    array : WhiskerArray
        The whiskers.
    scene : Scene3D
        The obstacles (world frame, metres).
    path : HeadPath
        The ticks; its protraction columns, if any, name whiskers of the array.
    whisk : CosineWhisk, optional
        Every whisker's protraction at each tick's time (not with a protraction in ``path``).
    points_tolerance : float, optional
        Each whisker's discretization error asked for, in its own length (default 1e-11: to
        the solver's convergence; coarser, up to 1e-6: fewer points, faster).

    Returns
    -------
    ArrayScan
        The checked run.

    Raises
    ------
    ParameterError
        When a protraction column names no whisker of the array, both a whisk and a
        protraction column are given, or ``points_tolerance`` is out of its range.
    InvalidPoseError
        When an unloaded whisker cuts an obstacle at the first tick.

    """
    points_tolerance = _points_tolerance(points_tolerance)
    names = array.names
    k, n = len(names), len(path.times)
    theta = np.zeros((n, k))
    given = path.protraction is not None or bool(path.named)
    if whisk is not None and given:
        raise ParameterError(f"{path.describe(0).split(',')[0]}: has protraction columns; give "
                             "either them or --whisk, not both")
    if whisk is not None:
        theta[:] = np.array([whisk.angle(t) for t in path.times])[:, None]
    if path.protraction is not None:
        theta[:] = np.asarray(path.protraction, dtype=float)[:, None]
    for name, values in (path.named or {}).items():
        if name not in names:
            raise ParameterError(f"{path.describe(0).split(',')[0]}: column protraction_{name} "
                                 f"names no whisker of the array (it has {', '.join(names)})")
        theta[:, names.index(name)] = values
    plan = ArrayScan(array, scene, path, theta, points_tolerance)
    plan.tracker()
    return plan


@dataclass(frozen=True)
class ArrayScanResult:
    """
    The outcome of an array run: one :class:`ArrayStep` per tick.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    array : WhiskerArray
        The whiskers.
    times : tuple of float
        t [s] of every tick.
    steps : tuple of ArrayStep
        Every tick's result (the first: the unloaded array at the start).
    shape_tick : int or None
        The tick whose centerlines are kept.
    shapes : numpy.ndarray or None
        (k, n, 3) every whisker's centerline at ``shape_tick`` [m].
    points_tolerance : float, optional
        The discretization error the whiskers were solved to, in their lengths.

    """

    array: WhiskerArray
    times: Tuple[float, ...]
    steps: Tuple[ArrayStep, ...]
    shape_tick: Optional[int] = None
    shapes: Optional[np.ndarray] = None
    points_tolerance: float = POINTS_TOLERANCE

    @property
    def errors(self) -> int:
        """Return the number of failed whisker steps."""
        return sum(len(s.errors) for s in self.steps)

    def stacked(self, name: str) -> np.ndarray:
        """
        Return one field of every tick stacked: (ticks, k, ...).

        Parameters
        ----------
        name : str
            An :class:`ArrayStep` array field, e.g. ``force_base`` or ``contacts``.

        Returns
        -------
        numpy.ndarray
            The field, one row per tick.

        """
        return np.stack([np.asarray(getattr(s, name)) for s in self.steps])


def array_scan_columns(result: ArrayScanResult) -> Dict[str, list]:
    """
    Return the run's rows as columns (:data:`ARRAY_COLUMNS`), one row per tick and whisker.

    Rows are in tick order, whiskers in the array's order within a tick.

    Parameters
    ----------
    result : ArrayScanResult
        The run.

    Returns
    -------
    dict
        Column name -> list of values (Python numbers, text or None).

    """
    specs = result.array.whiskers
    k, n = len(specs), len(result.steps)
    contacts = result.stacked("contacts").astype(int)
    free = (contacts == 0).reshape(-1)
    cols: Dict[str, list] = {
        "t": np.repeat(np.asarray(result.times, dtype=float), k).tolist(),
        "tick": np.repeat(np.arange(n), k).tolist(),
        "whisker": [w.name for w in specs] * n,
        "side": [w.side for w in specs] * n,
        "row": [w.row for w in specs] * n,
        "column": [w.column for w in specs] * n,
        "protraction": result.stacked("protraction").reshape(-1).tolist(),
        "contacts": contacts.reshape(-1).tolist(),
    }
    kind = [v for s in result.steps for v in s.contact_kind]
    obstacle = [v for s in result.steps for v in s.contact_obstacle]
    cols["kind"] = [None if f else v for v, f in zip(kind, free)]
    cols["obstacle"] = [None if f else v for v, f in zip(obstacle, free)]
    for name, field in (("s", "contact_s"), ("f", "contact_f")):
        values = result.stacked(field).reshape(-1).tolist()
        cols[name] = [None if f else v for v, f in zip(values, free)]
    for prefix, suffix, force, moment in (("", "", "force_base", "moment_base"),
                                          ("", "_world", "force", "moment")):
        F = result.stacked(force).reshape(-1, 3)
        M = result.stacked(moment).reshape(-1, 3)
        for j, axis in enumerate("xyz"):
            cols[f"f{axis}{suffix}"] = F[:, j].tolist()
        for j, axis in enumerate("xyz"):
            cols[f"m{axis}{suffix}"] = M[:, j].tolist()
    point = result.stacked("contact_point").reshape(-1, 3)
    tip = result.stacked("tip").reshape(-1, 3)
    for j, axis in enumerate("xyz"):
        cols[f"contact_{axis}"] = [None if f else v for v, f in zip(point[:, j].tolist(), free)]
    for j, axis in enumerate("xyz"):
        cols[f"tip_{axis}"] = tip[:, j].tolist()
    errors: List[Optional[str]] = [None] * (n * k)
    index = {name: i for i, name in enumerate(result.array.names)}
    for t, step in enumerate(result.steps):
        for e in step.errors:
            errors[t * k + index[e.whisker]] = e.message
    cols["error"] = errors
    return {c: cols[c] for c in ARRAY_COLUMNS}


def arrow_schema():
    """
    Return the pyarrow schema of the run's table (:data:`ARRAY_COLUMNS`).

    Returns
    -------
    pyarrow.Schema
        Text columns string, tick int64, column and contacts int32, the others float64; the
        columns that are empty for a free row are nullable.

    """
    import pyarrow as pa

    nullable = ("kind", "obstacle", "s", "f", "contact_x", "contact_y", "contact_z", "error")
    fields = []
    for name in ARRAY_COLUMNS:
        if name in TEXT_COLUMNS:
            kind = pa.string()
        elif name == "tick":
            kind = pa.int64()
        elif name in INT_COLUMNS:
            kind = pa.int32()
        else:
            kind = pa.float64()
        fields.append(pa.field(name, kind, nullable=name in nullable))
    return pa.schema(fields)


def array_scan_table(result: ArrayScanResult):
    """
    Return the run's rows as a pyarrow Table (:func:`arrow_schema`; free fields null).

    The schema's metadata records how the rows were computed: ``vibrissa_ros.points_tolerance``
    (the whiskers' discretization error, ``repr`` of the float).

    Parameters
    ----------
    result : ArrayScanResult
        The run.

    Returns
    -------
    pyarrow.Table
        One row per tick and whisker.

    """
    import pyarrow as pa

    table = pa.Table.from_pydict(array_scan_columns(result), schema=arrow_schema())
    return table.replace_schema_metadata(
        {POINTS_TOLERANCE_KEY: repr(float(result.points_tolerance))})


def _text(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def write_array_scan(result: ArrayScanResult, path: str) -> None:
    """
    Write the run's rows to a CSV (``-``: standard output) or, for ``*.parquet``, Parquet.

    CSV numbers are written to full precision (repr), None as an empty field; Parquet (zstd)
    holds nulls. Parquet needs pyarrow (``pip install vibrissa_ros[batch]``).

    Parameters
    ----------
    result : ArrayScanResult
        The run.
    path : str
        The file (``.parquet``: Parquet; anything else: CSV).

    """
    if path.endswith(".parquet"):
        import pyarrow.parquet as pq

        pq.write_table(array_scan_table(result), path, compression="zstd")
        return
    cols = array_scan_columns(result)
    rows = zip(*(cols[c] for c in ARRAY_COLUMNS))
    if path == "-":
        import sys

        _write_csv(rows, sys.stdout)
        return
    with open(path, "w", newline="") as stream:
        _write_csv(rows, stream)


def _write_csv(rows, stream: IO[str]) -> None:
    writer = csv.writer(stream, lineterminator="\n")
    writer.writerow(ARRAY_COLUMNS)
    for row in rows:
        writer.writerow([_text(v) for v in row])


def array_event_records(result: ArrayScanResult) -> List[dict]:
    """
    Return the run's events and failed steps, in the order they happened.

    Parameters
    ----------
    result : ArrayScanResult
        The run.

    Returns
    -------
    list of dict
        ``{"t", "tick", "whisker", "kind", "contacts_before", "contacts_after"}`` and, where
        present, ``obstacle`` (its name), ``s`` [m] and ``reason``; a failed step is
        ``{"t", "tick", "whisker", "kind": "error", "reason"}``.

    """
    out = []
    for i, (t, step) in enumerate(zip(result.times, result.steps)):
        for e in step.events:
            record = {"t": float(t), "tick": i, "whisker": e.whisker, "kind": e.kind,
                      "contacts_before": int(e.contacts_before),
                      "contacts_after": int(e.contacts_after)}
            if e.obstacle is not None:
                record["obstacle"] = e.obstacle
            if e.s is not None:
                record["s"] = float(e.s)
            if e.reason:
                record["reason"] = e.reason
            out.append(record)
        for e in step.errors:
            out.append({"t": float(t), "tick": i, "whisker": e.whisker, "kind": "error",
                        "reason": e.message})
    return out


def write_array_events_json(result: ArrayScanResult, stream: IO[str]) -> None:
    """
    Write the run's events (:func:`array_event_records`) as a JSON list.

    Parameters
    ----------
    result : ArrayScanResult
        The run.
    stream : text stream
        Where the JSON goes.

    """
    json.dump(array_event_records(result), stream, indent=1)
    stream.write("\n")


__all__ = ["ARRAY_COLUMNS", "POINTS_TOLERANCE_KEY", "ArrayScan", "ArrayScanResult", "HeadPath",
           "array_event_records", "array_scan_columns", "array_scan_table", "head_pose",
           "plan_array_scan", "read_head_poses_csv", "timed_path", "write_array_events_json",
           "write_array_scan"]
