"""
Tools on recorded runs: info, resim, export (the ``vibrissa`` verbs of the same names).

Decoding uses rclpy's serialization with the installed message classes (imported when a log is
read, from :mod:`vibrissa_ros.ros.serialization`); the logs themselves carry their full schemas,
so other tools (Foxglove, rosbags, mcap-ros2-support) need none of this. ``vibrissa replay`` is
:mod:`vibrissa_ros.ros.replay`.
"""

from __future__ import annotations

import json
import math
from collections import Counter, deque
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

from ..core.errors import VibrissaError
from ..core.rod3d import RodState
from ..core.state import WhiskerState
from ..node.edge import contact_records, decode_event, encode_event, event_record, header_ns
from .array_resim import is_array_log, resimulate_array
from .mcap_log import CONFIGURATION_METADATA, RESET_METADATA, LogError, LogMessage, LogReader
from ..node.config import build_config
from ..node.pipeline import PosePipeline, drop_reason


def decode(message: LogMessage):
    """Return the message object of a logged message (needs ROS 2's message packages)."""
    from ..ros.serialization import decode as decode_cdr

    return decode_cdr(message)


def configurations(metadata) -> List[Tuple[int, Dict[str, object]]]:
    """
    Return (log_time, parameter values) of every configuration record, in time order.

    The values carry ``node`` and ``resets`` besides the parameters.
    """
    out = []
    for record in metadata:
        if record.name == CONFIGURATION_METADATA:
            values = {k: json.loads(v) for k, v in record.metadata.items()}
            out.append((int(values.pop("log_time", 0)), values))
    if not out:
        raise LogError("the log has no recorded configuration (was it written by whisker_node?)")
    return sorted(out, key=lambda item: item[0])


def reset_requests(metadata) -> List[Tuple[int, int]]:
    """
    Return every ``~/reset`` request: (foot poses recorded before it, its log time).

    Sorted; empty for logs without requests (and logs made before the node had ``~/reset``).
    """
    return sorted((int(json.loads(record.metadata["poses_before"])),
                   int(json.loads(record.metadata["log_time"])))
                  for record in metadata if record.name == RESET_METADATA)


# -- info --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class LogInfo:
    topics: Dict[str, Tuple[str, int]]  # topic -> (type, count)
    start_ns: int
    end_ns: int
    configurations: List[Tuple[int, Dict[str, object]]]
    phases: Dict[int, int]
    events: List[dict]  # the fields of each ~/events payload

    @property
    def duration(self) -> float:
        return (self.end_ns - self.start_ns) / 1e9


def log_info(path: str) -> LogInfo:
    """
    Summarize a recorded log: what ``vibrissa info`` prints.

    Parameters
    ----------
    path : str
        The MCAP file.

    Returns
    -------
    LogInfo
        Topics, types, counts, duration, the recorded configurations, phases and events.

    """
    with LogReader(path) as log:
        channels, metadata = log.channels, log.metadata
        recorded = configurations(metadata)
        array = bool(recorded) and is_array_log(recorded[0][1])
        # one pass over the messages, keeping counts, not messages: an array log holds ~5 kB
        # per tick (300 MB a minute at 1 kHz)
        counts: Counter = Counter()
        types: Dict[str, str] = {}
        phases: Counter = Counter()
        events = []
        start = end = None
        for m in log.messages():  # in log-time order: the first and the last bound it
            counts[m.topic] += 1
            types.setdefault(m.topic, m.type_name)
            if start is None:
                start = m.log_time
            end = m.log_time
            if m.topic.endswith("/phase"):
                phases[decode(m).data] += 1
            elif m.topic.endswith("/events"):
                if array:  # array_node's: whisker, kind, obstacle, s, contacts before and after
                    events.append(json.loads(decode(m).data))
                else:
                    # the payload's fields (a scene's event has no phases, a profile's no
                    # obstacle)
                    events.append(json.loads(encode_event(decode_event(decode(m).data))))
    types = {c.topic: types.get(c.topic, "") for c in channels.values()}
    return LogInfo(
        topics={t: (types.get(t, ""), counts.get(t, 0)) for t in sorted(types)},
        start_ns=0 if start is None else start,
        end_ns=0 if end is None else end,
        configurations=recorded,
        phases=dict(sorted(phases.items())),
        events=events,
    )


# -- resim / export ---------------------------------------------------------------------------
@dataclass
class Resimulation:
    """
    The recorded poses run again through the node's pipeline, next to the recorded outputs.

    ``states`` holds (stamp, state) per accepted pose of a whisker_node log; a log of
    array_node keeps no states (a long one would not fit in memory): its ``states`` is empty and
    ``ticks`` counts the ticks re-run (None for a whisker_node log).
    """

    states: List[Tuple[int, WhiskerState]] = field(
        default_factory=list
    )  # (stamp, state) per accepted pose
    ticks: Optional[int] = None  # an array log's ticks re-run (its states are not kept)
    events: list = field(default_factory=list)  # the events crossed, in order
    event_steps: List[int] = field(
        default_factory=list
    )  # index into states of the step that crossed each
    dropped: Counter = field(default_factory=Counter)
    deviations: Dict[str, float] = field(
        default_factory=dict
    )  # field -> largest relative deviation
    compared: Counter = field(default_factory=Counter)
    mismatches: List[str] = field(default_factory=list)

    def worst(self) -> float:
        return max(self.deviations.values(), default=0.0)


def _relative(a: float, b: float) -> float:
    if a == b:
        return 0.0
    if not (math.isfinite(a) and math.isfinite(b)):
        return math.inf
    return abs(a - b) / max(abs(a), abs(b))


#: the compared values of one contact of ``~/contacts`` (one point of its cloud)
CONTACT_VALUES = ("x", "y", "z", "fx", "fy", "fz", "s", "kind", "state", "obstacle")
#: the compared values of one event of ``~/events`` (None where an event kind has none; z: the
#: 3D whisker's only)
EVENT_VALUES = ("kind", "from_phase", "to_phase", "x", "y", "z", "obstacle", "contact", "s")
#: the compared components of ``~/wrench`` (planar models: force z and torque x, y are 0)
WRENCH_VALUES = ("force.x", "force.y", "force.z", "torque.x", "torque.y", "torque.z")


def _wrench6(sensed: Tuple[float, ...]) -> Tuple[float, ...]:
    """Return the six components of a reported wrench (planar: fx, fy, mz -> 0 elsewhere)."""
    if len(sensed) == 6:
        return tuple(sensed)
    fx, fy, mz = sensed
    return fx, fy, 0.0, 0.0, 0.0, mz


def _xyz(v) -> Tuple[float, ...]:
    """Return a planar (x, y) or 3D vector as (x, y, z)."""
    return tuple(v) if len(v) == 3 else (v[0], v[1], 0.0)


def _contact_values(contact) -> tuple:
    return tuple(getattr(contact, name) for name in CONTACT_VALUES)


def _event_values(record) -> tuple:
    return tuple(getattr(record, name) for name in EVENT_VALUES)


def decode_contacts(cloud):
    """Return the contacts of a logged ``~/contacts`` cloud (needs ROS 2's message packages)."""
    from ..ros.messages import decode_contacts as decode_cloud

    return decode_cloud(cloud)


def resimulate(path: str) -> Resimulation:
    """
    Re-run every recorded foot pose with the recorded configuration(s), compare each field.

    The log is streamed: each re-simulated output is compared with its recorded one as soon as
    both have been read (topic by topic, in order), so only the outputs of the few poses between
    the two are held, whatever the log's length; ``states`` keeps every state computed. A log of
    array_node is re-run tick by tick (:func:`.array_resim.resimulate_array`) in the same way:
    the fields compared are every whisker's ``wrenches.*``, ``ticks`` counts the ticks and
    ``states`` stays empty, so that memory does not grow with the log.

    Parameters
    ----------
    path : str or path-like
        A finished log written by the whisker node (see :func:`~.mcap_log.read_log`).

    Returns
    -------
    Resimulation
        The states computed again, next to the recorded outputs: the largest relative deviation
        per field, the number compared, the mismatches.

    Raises
    ------
    LogError
        When the log cannot be read or has no recorded configuration.

    """
    with LogReader(path) as log:
        configs = configurations(log.metadata)
        if is_array_log(configs[0][1]):  # array_node's: every whisker's row of every tick
            return resimulate_array(configs, log.messages(), Resimulation(),
                                    resets=reset_requests(log.metadata))
        node = configs[0][1].get("node", "/whisker_node")
        # logs made before the node had ~/contacts: nothing of it to compare
        has_contacts = any(c.topic == f"{node}/contacts" for c in log.channels.values())
        return resimulate_poses(configs, log.messages(), reset_requests(log.metadata),
                                has_contacts)


#: the outputs of whisker_node that resim compares, and their values' names
COMPARED = {
    "wrench": WRENCH_VALUES,
    "phase": ("data",),
    "contact_force": ("x", "y", "z"),
    "contact_force_magnitude": ("data",),
    "contact_point": ("x", "y", "z"),
    "arc_length": ("data",),
    "contacts": CONTACT_VALUES,
    "events": EVENT_VALUES,
}


def _recorded_values(key: str, m: LogMessage):
    """Return the (stamp or None, values) entries of one recorded output message."""
    msg = decode(m)
    if key == "wrench":
        w = msg.wrench
        return [(header_ns(msg), (w.force.x, w.force.y, w.force.z,
                                  w.torque.x, w.torque.y, w.torque.z))]
    if key in ("phase",):
        return [(None, (float(msg.data),))]
    if key in ("contact_force_magnitude", "arc_length"):
        return [(None, (msg.data,))]
    if key == "contact_force":
        return [(header_ns(msg), (msg.vector.x, msg.vector.y, msg.vector.z))]
    if key == "contact_point":
        return [(header_ns(msg), (msg.point.x, msg.point.y, msg.point.z))]
    if key == "contacts":
        return [(header_ns(msg), _contact_values(c)) for c in decode_contacts(msg)]
    return [(None, _event_values(decode_event(msg.data)))]  # events


class _Pairs:
    """
    Each compared topic's re-simulated and recorded values, paired in order as both arrive.

    A pair's stamps must agree (where the value has one): the first that does not is reported
    and ends that topic's comparison; the counts are compared at the end (:meth:`finish`), and
    the mismatches listed topic by topic.
    """

    def __init__(self, result: Resimulation, topics):
        self.result = result
        self.topics = dict(topics)
        self.want = {t: deque() for t in self.topics}
        self.have = {t: deque() for t in self.topics}
        self.count_want: Counter = Counter()
        self.count_have: Counter = Counter()
        self.stamp_error: Dict[str, str] = {}

    def expected(self, topic: str, stamp, values) -> None:
        if topic in self.topics:
            self.want[topic].append((stamp, values))
            self.count_want[topic] += 1
            self._drain(topic)

    def recorded(self, topic: str, entries) -> None:
        self.have[topic].extend(entries)
        self.count_have[topic] += len(entries)
        self._drain(topic)

    def _drain(self, topic: str) -> None:
        want, have = self.want[topic], self.have[topic]
        result = self.result
        while want and have:
            (s_want, v_want), (s_have, v_have) = want.popleft(), have.popleft()
            if topic in self.stamp_error:
                continue
            if s_want is not None and s_want != s_have:
                self.stamp_error[topic] = (f"{topic}: stamp {s_have} recorded where {s_want} "
                                           "was expected")
                continue
            for name, a, b in zip(self.topics[topic], v_have, v_want):
                key = f"{topic}.{name}"
                dev = (
                    _relative(float(a), float(b))
                    if isinstance(a, (int, float)) and isinstance(b, (int, float))
                    else (0.0 if a == b else math.inf)
                )
                result.deviations[key] = max(result.deviations.get(key, 0.0), dev)
                result.compared[key] += 1

    def finish(self) -> None:
        for topic in self.topics:
            if self.count_want[topic] != self.count_have[topic]:
                self.result.mismatches.append(f"{topic}: {self.count_have[topic]} recorded, "
                                              f"{self.count_want[topic]} re-simulated")
            if topic in self.stamp_error:
                self.result.mismatches.append(self.stamp_error[topic])


class _Rerun:
    """
    A whisker_node log's poses run again in order, under the configurations and resets recorded.

    :meth:`pose` takes each recorded ``~/foot_pose`` in turn, adds its state and events to the
    result (or counts it dropped) and returns the outputs the node published for it, as the
    compared (topic, stamp or None, values).
    """

    def __init__(self, configs, resets, result: Resimulation):
        self.pipeline = PosePipeline(build_config(configs[0][1]))
        self.pending = list(configs[1:])
        self.resets = list(resets)
        self.result = result
        self.index = -1

    def pose(self, m: LogMessage) -> list:
        self.index += 1
        pipeline, result = self.pipeline, self.result
        # what happened before this pose: configurations (by log time) and ~/reset requests (by
        # the poses recorded before them), applied in their log-time order
        due = []
        while self.pending and self.pending[0][0] <= m.log_time:
            due.append(self.pending.pop(0))
        while self.resets and self.resets[0][0] <= self.index:
            due.append((self.resets.pop(0)[1], None))
        for _, values in sorted(due, key=lambda item: item[0]):
            if values is None:
                pipeline.request_reset()
            else:
                pipeline.reconfigure(build_config(values), bool(values.get("resets", True)))
        msg = decode(m)
        p, q = msg.pose.position, msg.pose.orientation
        stamp = header_ns(msg)
        try:
            state, events = pipeline.handle(msg.header.frame_id, stamp, (p.x, p.y, p.z),
                                            (q.x, q.y, q.z, q.w))
        except VibrissaError as exc:
            result.dropped[drop_reason(exc)] += 1
            return []
        result.states.append((stamp, state))
        result.events.extend(events)
        result.event_steps.extend([len(result.states) - 1] * len(events))
        r, sensed = pipeline.reading(state)
        units, roll = pipeline.config.units, pipeline.config.roll
        out = [("wrench", stamp, _wrench6(sensed)),
               ("phase", None, (float(r.phase),)),
               ("contact_force", stamp, _xyz(r.force_world)),
               ("contact_force_magnitude", None, (r.force_magnitude,))]
        if r.contact_world is not None:
            out += [("contact_point", stamp, _xyz(r.contact_world)),
                    ("arc_length", None, (r.s1,))]
        out += [("contacts", stamp, _contact_values(c)) for c in contact_records(state, units)]
        out += [("events", None, _event_values(event_record(e, units, roll))) for e in events]
        return out


def resimulate_poses(configs, messages, resets, has_contacts: bool = True) -> Resimulation:
    """
    Re-run a whisker_node log's poses as its messages arrive, comparing every output at once.

    Parameters
    ----------
    configs : list
        The recorded configurations, (log time, values) (:func:`configurations`).
    messages : iterable of LogMessage
        The log's messages in log-time order (:meth:`.mcap_log.LogReader.messages`).
    resets : list
        The ``~/reset`` requests, (poses before, log time) (:func:`reset_requests`).
    has_contacts : bool, optional
        The log has ``~/contacts`` (logs made before the node had it do not).

    Returns
    -------
    Resimulation
        As :func:`resimulate`.

    """
    node = configs[0][1].get("node", "/whisker_node")
    prefix = f"{node}/"
    result = Resimulation()
    pairs = _Pairs(result, {k: v for k, v in COMPARED.items()
                            if has_contacts or k != "contacts"})
    rerun = _Rerun(configs, resets, result)
    for m in messages:
        if not m.topic.startswith(prefix):
            continue
        key = m.topic[len(prefix):]
        if key in pairs.topics:
            pairs.recorded(key, _recorded_values(key, m))
        elif key == "foot_pose":
            for topic, stamp, values in rerun.pose(m):
                pairs.expected(topic, stamp, values)
    pairs.finish()
    return result


def export_rows(path: str):
    """
    (time [s], state) per accepted pose of a log, from the recorded poses and configuration.

    Parameters
    ----------
    path : str or path-like
        A finished log written by the whisker node.

    Returns
    -------
    rows : list of tuple
        (time [s], :class:`~vibrissa_ros.core.state.WhiskerState`) per accepted pose, in order.
    resimulation : Resimulation
        The :func:`resimulate` result the rows come from.

    Raises
    ------
    LogError
        When the log cannot be read or has no recorded configuration, or is a run of the 3D
        whisker (model rod3d) or of array_node: the rows are the planar scan contract;
        ``vibrissa resim`` checks such a log.

    """
    with LogReader(path) as log:
        if is_array_log(configurations(log.metadata)[0][1]):
            raise LogError(f"{path}: a run of array_node: export and plot write the planar scan "
                           "contract of one whisker; 'vibrissa resim' re-simulates it, and the "
                           "log itself holds every whisker's row of every tick (~/wrenches)")
    sim = resimulate(path)
    if any(isinstance(state, RodState) for _, state in sim.states):
        raise LogError(f"{path}: a run of the 3D whisker (model rod3d): export and plot write "
                       "the planar scan contract, which has no 3D columns yet; 'vibrissa resim' "
                       "re-simulates it, and the log itself holds every topic")
    return [(stamp / 1e9, state) for stamp, state in sim.states], sim
