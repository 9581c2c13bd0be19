"""
The 3D scan's files (adapter: files; the core never writes files).

``vibrissa scan --scene S.yaml --poses P.csv`` with a poses file of columns
``x,y,z,qw,qx,qy,qz`` runs the 3D whisker (:mod:`vibrissa_ros.scan.scene_scan3d`). Everything
is dimensionless and in the world frame: lengths in whisker lengths L, forces in EI_b/L^2,
moments in EI_b/L; quaternions scalar first (Hamilton), rotating base-frame vectors into the
world.

CSV columns, exactly: ``x,y,z,qw,qx,qy,qz,contacts,kind,obstacle,s1,f,fx,fy,fz,mx,my,mz,
contact_x,contact_y,contact_z,tip_x,tip_y,tip_z``: the base pose (its quaternion normalised),
the number of contacts, the contact nearest the base (kind ``side`` or ``tip``, the obstacle's
name, its arc length s1, normal force f and point), the total contact force on the whisker
(fx, fy, fz) and the moment of the contact forces about the base point (mx, my, mz), and the
tip's position. A free row has contacts = 0, zero force and moment, and empty kind, obstacle,
s1, f and contact point (empty, never NaN). Numbers are written with 17 significant digits.
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass
from typing import IO, Iterable, List, Sequence, Tuple

from ..core.errors import InvalidPoseError, ParameterError
from ..core.rod3d.pose import BasePose

#: the columns of a 3D poses file (``vibrissa scan --poses``)
POSE3D_COLUMNS = ("x", "y", "z", "qw", "qx", "qy", "qz")
#: the columns only a 3D poses file has: one of them makes a poses file 3D
_ONLY_3D = ("z", "qw", "qx", "qy", "qz")
#: the 3D scan CSV's columns, in order
SCAN3D_COLUMNS = POSE3D_COLUMNS + (
    "contacts", "kind", "obstacle", "s1", "f", "fx", "fy", "fz", "mx", "my", "mz",
    "contact_x", "contact_y", "contact_z", "tip_x", "tip_y", "tip_z",
)


@dataclass(frozen=True)
class Poses3D:
    """
    The base poses of a 3D poses file, with the file's line of each.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    path : str
        The file read.
    poses : tuple of BasePose
        The poses in row order.
    lines : tuple of int
        The file's line number of each pose (the header is line 1).

    """

    path: str
    poses: Tuple[BasePose, ...]
    lines: Tuple[int, ...]

    def where(self, index: int) -> str:
        """
        Return where pose ``index`` comes from, e.g. ``--poses P.csv, line 5``.

        Parameters
        ----------
        index : int
            The pose's index in :attr:`poses`.

        Returns
        -------
        str
            The file and line, for error messages.

        """
        return f"--poses {self.path}, line {self.lines[index]}"


def _header(path: str) -> List[str]:
    try:
        with open(path, newline="") as stream:
            return [c.strip() for c in next(csv.reader(stream), [])]
    except OSError as exc:
        raise ParameterError(f"--poses {path}: {exc.strerror}") from None


def is_3d_poses_csv(path: str) -> bool:
    """
    Tell whether a poses file is 3D: its header names one of the columns z, qw, qx, qy, qz.

    Parameters
    ----------
    path : str
        The poses file (``vibrissa scan --poses``).

    Returns
    -------
    bool
        True for a 3D poses file (columns x,y,z,qw,qx,qy,qz); False for a planar one
        (x,y,heading).

    Raises
    ------
    ParameterError
        When the file cannot be read.

    """
    return any(c in _ONLY_3D for c in _header(path))


def read_poses3d_csv(path: str) -> Poses3D:
    """
    Read the base poses of a 3D poses file: columns x, y, z [L] and qw, qx, qy, qz, in order.

    Parameters
    ----------
    path : str
        The CSV file (``vibrissa scan --poses``); other columns are ignored.

    Returns
    -------
    Poses3D
        The poses (at least one) with their line numbers.

    Raises
    ------
    ParameterError
        Naming the file (and the line): the file cannot be read, a column is missing, a value
        is not a finite number, a quaternion is not of unit length (within 1e-6), or there is
        no pose.

    """
    poses, lines = [], []
    try:
        with open(path, newline="") as stream:
            reader = csv.DictReader(stream, skipinitialspace=True)
            names = [c.strip() for c in (reader.fieldnames or [])]
            reader.fieldnames = names
            missing = [c for c in POSE3D_COLUMNS if c not in names]
            if missing:
                raise ParameterError(f"--poses {path}: missing column(s) {', '.join(missing)}; "
                                     f"a 3D poses file needs {','.join(POSE3D_COLUMNS)}")
            for row in reader:
                line = reader.line_num
                try:
                    values = [float(row[c]) for c in POSE3D_COLUMNS]
                    poses.append(BasePose(tuple(values[:3]), tuple(values[3:])))
                except (TypeError, ValueError) as exc:
                    message = str(exc) if isinstance(exc, InvalidPoseError) else (
                        f"a value is not a number ({exc})")
                    raise ParameterError(f"--poses {path}, line {line}: {message}") from None
                lines.append(line)
    except OSError as exc:
        raise ParameterError(f"--poses {path}: {exc.strerror}") from None
    if not poses:
        raise ParameterError(f"--poses {path}: no poses")
    return Poses3D(str(path), tuple(poses), tuple(lines))


def _num(value) -> str:
    return "" if value is None else repr(float(value))


def _pose_values(pose: BasePose) -> list:
    return [float(v) for v in pose.position + pose.quaternion]


def scan3d_row(state) -> list:
    """
    Return one CSV row of a 3D state (strings, :data:`SCAN3D_COLUMNS` in order).

    Parameters
    ----------
    state : RodState
        The equilibrium.

    Returns
    -------
    list of str
        The row; empty strings for the nearest contact's fields of a free state.

    """
    c = state.nearest
    near = ([c.kind, c.name, _num(c.s), _num(c.f)] if c is not None
            else ["", "", "", ""])
    point = [_num(v) for v in c.point] if c is not None else ["", "", ""]
    return ([_num(v) for v in _pose_values(state.pose)] + [str(len(state.contacts))] + near
            + [_num(v) for v in state.force] + [_num(v) for v in state.moment] + point
            + [_num(v) for v in state.tip])


def write_scan3d_csv(states: Iterable, stream: IO[str]) -> None:
    """
    Write the 3D scan CSV (the module's columns), one row per pose.

    Parameters
    ----------
    states : iterable of RodState
        The states of a 3D scan, in order.
    stream : text stream
        Where the CSV goes.

    """
    writer = csv.writer(stream, lineterminator="\n")
    writer.writerow(SCAN3D_COLUMNS)
    for state in states:
        writer.writerow(scan3d_row(state))


def _where(pose: BasePose) -> dict:
    return dict(zip(POSE3D_COLUMNS, _pose_values(pose)))


def event3d_record(event, names: Sequence[str]) -> dict:
    """
    Describe a 3D event: the base pose where it happened, its kind, obstacle, s and reason.

    Parameters
    ----------
    event : RodEvent
        The event.
    names : sequence of str
        The scene's obstacle names, by index.

    Returns
    -------
    dict
        ``x, y, z, qw, qx, qy, qz, kind, contacts_before, contacts_after`` and, where present,
        ``obstacle`` (its name), ``s`` and ``reason``.

    """
    record = {**_where(event.pose), "kind": event.kind,
              "contacts_before": int(event.contacts_before),
              "contacts_after": int(event.contacts_after)}
    if event.obstacle is not None:
        record["obstacle"] = names[event.obstacle]
    if event.s is not None:
        record["s"] = float(event.s)
    if event.reason:
        record["reason"] = event.reason
    return record


def write_events3d_json(events: Iterable, stream: IO[str], names: Sequence[str]) -> None:
    """
    Write the 3D events as the ``--events`` JSON list, in the order crossed.

    Parameters
    ----------
    events : iterable of RodEvent
        The events of a 3D scan.
    stream : text stream
        Where the JSON goes.
    names : sequence of str
        The scene's obstacle names, by index.

    """
    json.dump([event3d_record(e, names) for e in events], stream, indent=1)
    stream.write("\n")


def contacts3d_record(state) -> dict:
    """
    Return one line of ``--contacts``: the base pose and every contact, from the base to the tip.

    Parameters
    ----------
    state : RodState
        The equilibrium.

    Returns
    -------
    dict
        ``x, y, z, qw, qx, qy, qz`` and ``contacts``: a list of ``{"kind", "obstacle" (name),
        "s", "f", "point": [x, y, z], "force": [fx, fy, fz]}`` (world frame, dimensionless).

    """
    return {
        **_where(state.pose),
        "contacts": [
            {"kind": c.kind, "obstacle": c.name, "s": float(c.s), "f": float(c.f),
             "point": [float(v) for v in c.point], "force": [float(v) for v in c.force]}
            for c in state.contacts
        ],
    }


def write_contacts3d_jsonl(states: Iterable, stream: IO[str]) -> None:
    """
    Write one JSON object per pose and line (``vibrissa scan --contacts`` of a 3D scan).

    Parameters
    ----------
    states : iterable of RodState
        The states of a 3D scan, in order.
    stream : text stream
        Where the lines go.

    """
    for state in states:
        stream.write(json.dumps(contacts3d_record(state)))
        stream.write("\n")
