"""
The scan CSV and events JSON contract (adapter: files; the core never writes files).

CSV columns, exactly: x0,phase,alpha,s1,tip_slope,f,fx,fy,m0,contact_x,contact_y (dimensionless,
the paper's frame). A free row has phase 0, f = fx = fy = m0 = 0 and empty alpha, s1, contact_x,
contact_y. Numbers are written with 17 significant digits (round-trip exact).
"""

from __future__ import annotations

import csv
import json
from typing import IO, Iterable

from .core.state import Event, WhiskerState

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


def _num(value) -> str:
    if value is None:
        return ""
    return repr(float(value))


def state_row(state: WhiskerState) -> list:
    contact = state.contact or (None, None)
    return [
        _num(state.x0),
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


def write_scan_csv(states: Iterable[WhiskerState], stream: IO[str]) -> None:
    writer = csv.writer(stream, lineterminator="\n")
    writer.writerow(CSV_COLUMNS)
    for state in states:
        writer.writerow(state_row(state))


def event_record(event: Event) -> dict:
    return {
        "x0": float(event.x0),
        "kind": event.kind,
        "from_phase": int(event.from_phase),
        "to_phase": int(event.to_phase),
    }


def write_events_json(events: Iterable[Event], stream: IO[str]) -> None:
    json.dump([event_record(e) for e in events], stream, indent=1)
    stream.write("\n")
