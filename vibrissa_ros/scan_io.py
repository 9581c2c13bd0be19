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

from .core.errors import ParameterError
from .core.state import Event, FootPose, WhiskerState

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


def write_scan_csv(states: Iterable[WhiskerState], stream: IO[str], by_pose: bool = False) -> None:
    """Write the scan CSV; ``by_pose``: a row starts with the foot pose x,y,heading, not x0."""
    writer = csv.writer(stream, lineterminator="\n")
    writer.writerow(POSE_CSV_COLUMNS if by_pose else CSV_COLUMNS)
    for state in states:
        writer.writerow(state_row(state, by_pose))


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
    json.dump([event_record(e, by_pose) for e in events], stream, indent=1)
    stream.write("\n")


def read_poses_csv(path: str) -> List[FootPose]:
    """Read foot poses from a CSV with (at least) columns x, y, heading [L, L, rad], in order."""
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
