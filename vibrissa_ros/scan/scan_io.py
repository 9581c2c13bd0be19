"""
The scan CSV and events JSON contract (adapter: files; the core never writes files).

CSV columns, exactly: x0,phase,alpha,s1,tip_slope,f,fx,fy,m0,contact_x,contact_y (dimensionless,
the paper's frame); a scan driven by foot poses starts with x,y,heading instead of x0. A free
row has phase 0, f = fx = fy = m0 = 0 and empty alpha, s1, contact_x, contact_y. Numbers are
written with 17 significant digits (round-trip exact).
"""

from __future__ import annotations

import csv
import json
from typing import IO, Iterable, List

from ..core.errors import ParameterError
from ..core.state import Event, FootPose, WhiskerState

CSV_COLUMNS = (
    "x0",
    "phase",
    "alpha",
    "s1",
    "tip_slope",
    "f",
    "fx",
    "fy",
    "m0",
    "contact_x",
    "contact_y",
)
#: columns of a scan driven by foot poses (``vibrissa scan --poses``)
POSE_CSV_COLUMNS = ("x", "y", "heading") + CSV_COLUMNS[1:]
#: a scene scan (``vibrissa scan --scene``) adds the number of contacts; fx, fy, m0 are then the
#: total base load and alpha, s1, f, contact_x, contact_y describe the contact nearest the foot
#: (alpha: the direction of its force, f (sin alpha, -cos alpha); f its magnitude)
CONTACTS_COLUMN = "contacts"


def _num(value) -> str:
    if value is None:
        return ""
    return repr(float(value))


def state_row(state: WhiskerState, by_pose: bool = False) -> list:
    contact = state.contact or (None, None)
    pose = state.pose
    lead = [_num(pose.x), _num(pose.y), _num(pose.heading)] if by_pose else [_num(state.x0)]
    return lead + [
        str(int(state.phase)),
        _num(state.alpha),
        _num(state.s1),
        _num(state.tip_slope),
        _num(state.f),
        _num(state.fx),
        _num(state.fy),
        _num(state.m0),
        _num(contact[0]),
        _num(contact[1]),
    ]


def write_scan_csv(states: Iterable[WhiskerState], stream: IO[str], by_pose: bool = False,
                   contacts: bool = False) -> None:
    """
    Write the scan CSV; ``by_pose``: a row starts with the foot pose x,y,heading, not x0.

    Parameters
    ----------
    states : iterable of WhiskerState
        The states of a scan, one row each, in order (dimensionless).
    stream : text stream
        Where the CSV goes.
    by_pose : bool, optional
        A row starts with the foot pose x,y,heading, not x0.
    contacts : bool, optional
        A scene scan, with the last column ``contacts`` (their number, 0 when free).

    """
    writer = csv.writer(stream, lineterminator="\n")
    header = POSE_CSV_COLUMNS if by_pose else CSV_COLUMNS
    writer.writerow(header + ((CONTACTS_COLUMN,) if contacts else ()))
    for state in states:
        row = state_row(state, by_pose)
        if contacts:
            row.append(str(len(state.contacts)))
        writer.writerow(row)


def _where(pose: FootPose, by_pose: bool) -> dict:
    if by_pose:
        return {"x": float(pose.x), "y": float(pose.y), "heading": float(pose.heading)}
    return {"x0": float(pose.x)}


def contacts_record(state, by_pose: bool = False) -> dict:
    """One line of ``--contacts``: the pose and every contact (world frame, dimensionless)."""
    return {
        **_where(state.pose, by_pose),
        "contacts": [
            {"s": float(c.s), "x": float(c.x), "y": float(c.y), "fx": float(c.fx),
             "fy": float(c.fy), "kind": c.report_kind, "state": c.state,
             "obstacle": int(c.obstacle)}
            for c in state.contacts
        ],
    }


def write_contacts_jsonl(states, stream: IO[str], by_pose: bool = False) -> None:
    """Write one JSON object per pose and line (``vibrissa scan --contacts``)."""
    for state in states:
        stream.write(json.dumps(contacts_record(state, by_pose)))
        stream.write("\n")


def scene_event_record(event, by_pose: bool = False) -> dict:
    """Describe a scene event: where, what (doc/guide/scenes.md), which contact."""
    record = {**_where(event.pose, by_pose), "kind": event.kind, "contact": event.contact_kind}
    if event.obstacle is not None:
        record["obstacle"] = int(event.obstacle)
    if event.s is not None:
        record["s"] = float(event.s)
    return record


def write_scene_events_json(events, stream: IO[str], by_pose: bool = False) -> None:
    json.dump([scene_event_record(e, by_pose) for e in events], stream, indent=1)
    stream.write("\n")


def event_record(event: Event, by_pose: bool = False) -> dict:
    where = (
        {"x": float(event.pose.x), "y": float(event.pose.y), "heading": float(event.pose.heading)}
        if by_pose
        else {"x0": float(event.x0)}
    )
    return {
        **where,
        "kind": event.kind,
        "from_phase": int(event.from_phase),
        "to_phase": int(event.to_phase),
    }


def write_events_json(events: Iterable[Event], stream: IO[str], by_pose: bool = False) -> None:
    """
    Write events as the ``--events`` JSON list, in the order crossed.

    Parameters
    ----------
    events : iterable of Event
        The events of a scan.
    stream : text stream
        Where the JSON goes.
    by_pose : bool, optional
        Locate each event by its foot pose (``x``, ``y``, ``heading``) instead of ``x0``.

    """
    json.dump([event_record(e, by_pose) for e in events], stream, indent=1)
    stream.write("\n")


def read_poses_csv(path: str) -> List[FootPose]:
    """
    Read foot poses from a CSV with (at least) columns x, y, heading [L, L, rad], in order.

    Parameters
    ----------
    path : str
        The CSV file (``vibrissa scan --poses``).

    Returns
    -------
    list of FootPose
        The poses in row order, at least one.

    Raises
    ------
    ParameterError
        When the file cannot be read, a column is missing, a value is not a number, or there is
        no pose.

    """
    try:
        with open(path, newline="") as stream:
            reader = csv.DictReader(stream)
            missing = [c for c in ("x", "y", "heading") if c not in (reader.fieldnames or [])]
            if missing:
                raise ParameterError(
                    f"--poses {path}: missing column(s) {', '.join(missing)}; need x,y,heading"
                )
            poses = []
            for line, row in enumerate(reader, start=2):
                try:
                    poses.append(FootPose(float(row["x"]), float(row["y"]), float(row["heading"])))
                except (TypeError, ValueError) as exc:
                    raise ParameterError(f"--poses {path}, line {line}: {exc}") from None
    except OSError as exc:
        raise ParameterError(f"--poses {path}: {exc.strerror}") from None
    if len(poses) < 1:
        raise ParameterError(f"--poses {path}: no poses")
    return poses
