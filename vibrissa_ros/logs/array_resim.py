"""
``vibrissa resim`` of a log recorded by array_node: every tick again, every whisker compared.

The log's configuration record carries every parameter and the array and scene files' text, so
the array is rebuilt whatever became of the files. The recorded inputs (``~/head_pose``,
``~/whisk`` or the built-in whisk's ``~/protraction``) are taken in log order through the node's
own :class:`~vibrissa_ros.node.array.ArrayPipeline` (bad ones dropped as the node dropped them),
each tick's rows are compared with the recorded ``~/wrenches`` field by field: the six wrench
components, the contact and the base frame of every whisker.
"""

from __future__ import annotations

from collections import deque
from typing import Dict, Iterable, List, Sequence, Tuple

import numpy as np

from ..node.array import ARRAY_TEXT, SCENE_TEXT, ArrayPipeline, build_array_config, output_rows
from ..node.edge import BadInput, header_ns
from .mcap_log import LogError

#: the compared fields of each whisker's row of ``~/wrenches``
COMPARED = ("fx", "fy", "fz", "mx", "my", "mz", "theta", "s", "f", "cx", "cy", "cz", "x", "y",
            "z", "qx", "qy", "qz", "qw", "contacts", "kind", "obstacle", "error")
#: how many ticks may wait, with their rows, for their counterpart (re-simulated or recorded)
WINDOW = 1000


def is_array_log(values: Dict[str, object]) -> bool:
    """
    Return whether a recorded configuration is array_node's.

    Parameters
    ----------
    values : dict
        A configuration record's values.

    Returns
    -------
    bool
        True when it carries the array file's text.

    """
    return ARRAY_TEXT in values


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = np.maximum(np.abs(a), np.abs(b))
    diff = np.abs(a - b)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(diff == 0.0, 0.0, diff / scale)
    return float(np.max(rel, initial=0.0))


class _Pairing:
    """
    The re-simulated ticks and the recorded ``~/wrenches``, paired in order as they come.

    The n-th re-simulated tick goes with the n-th recorded cloud, as the two lists zipped once
    the log is read; each pair is compared as soon as both exist, and only the side that is
    ahead waits, with its rows, in a queue. A queue longer than ``window`` gives up the rows of
    its oldest entries (their count is kept); a counterpart that arrives for one of them is a
    mismatch (not compared) and ends the comparison, as a stamp mismatch does.
    """

    def __init__(self, result, window: int):
        self.result = result
        self.window = window
        self.start = len(result.mismatches)  # where the count mismatch goes, first
        self.counts = [0, 0]  # re-simulated, recorded
        self.waiting: Tuple[deque, deque] = (deque(), deque())  # (stamp, rows) not paired yet
        self.lost = [0, 0]  # entries before the queue's whose rows were given up
        self.stopped = False

    def add(self, side: int, stamp: int, rows: np.ndarray) -> None:
        """Take a re-simulated (side 0) or recorded (side 1) tick; compare it if it can be."""
        self.counts[side] += 1
        if self.stopped:
            return
        other = 1 - side
        if self.lost[other]:
            self._stop(f"wrenches: the recorded tick stamped {stamp} comes more than "
                       f"{self.window} ticks after its input in the log: not compared"
                       if side else
                       f"wrenches: the input stamped {stamp} comes more than {self.window} "
                       "ticks after its recorded output in the log: not compared")
        elif self.waiting[other]:
            s_other, rows_other = self.waiting[other].popleft()
            if side == 0:
                self._compare(stamp, rows, s_other, rows_other)
            else:
                self._compare(s_other, rows_other, stamp, rows)
        else:
            queue = self.waiting[side]
            queue.append((stamp, rows))
            if len(queue) > self.window:
                queue.popleft()
                self.lost[side] += 1

    def _stop(self, why: str) -> None:
        self.result.mismatches.append(why)
        self.stopped = True
        for queue in self.waiting:
            queue.clear()

    def _compare(self, s_want: int, want: np.ndarray, s_have: int, have: np.ndarray) -> None:
        if s_want != s_have:
            self._stop(f"wrenches: stamp {s_have} recorded where {s_want} was expected")
            return
        if len(want) != len(have):
            self._stop(f"wrenches: {len(have)} whiskers recorded, {len(want)} re-simulated")
            return
        result = self.result
        for name in COMPARED:
            key = f"wrenches.{name}"
            dev = _relative(have[name], want[name])
            result.deviations[key] = max(result.deviations.get(key, 0.0), dev)
            result.compared[key] += len(want)

    def finish(self) -> None:
        """Report a count mismatch (before the others, as ever); the last tick may lack output."""
        expected, got = self.counts
        if expected == got + 1:
            expected -= 1  # the run stopped during its last tick: that input has no output
        if expected != got:
            self.result.mismatches.insert(
                self.start, f"wrenches: {got} recorded, {expected} re-simulated")


def resimulate_array(configs: List[Tuple[int, Dict[str, object]]], messages: Iterable,
                     result, window: int = WINDOW, resets: Sequence[Tuple[int, int]] = ()):
    """
    Re-run an array_node log's ticks and fill ``result`` (a :class:`~.tools.Resimulation`).

    The messages are consumed one at a time (an iterator such as
    :meth:`~.mcap_log.LogReader.messages` is read once, never held): each re-simulated tick is
    compared with its recorded ``~/wrenches`` as soon as both exist, and neither is kept after.
    What stays is the largest deviation and the count per field, the mismatches and at most
    ``window`` ticks waiting for their counterpart, so memory does not grow with the log (a
    60-s, 1 kHz recording of 30 whiskers took 2.5 GB when every tick was kept). The states are
    not kept either: ``result.states`` stays empty and ``result.ticks`` counts the ticks.

    The outcome is the n-th re-simulated tick against the n-th recorded cloud, in log order: a
    recorded run's last input without an output (the run stopped during that tick) is no
    mismatch; otherwise different counts are one mismatch, listed first; the first pair whose
    stamps or numbers of whiskers differ is one and ends the comparison.

    Parameters
    ----------
    configs : list of (int, dict)
        The log's configuration records (the first one is used: every parameter is read-only).
    messages : iterable of LogMessage
        The log's messages in log-time order (other topics than the node's are skipped).
    result : Resimulation
        Filled: ``ticks`` (the number of ticks re-run, the last one included when it has no
        output), ``dropped``, ``deviations``, ``compared``, ``mismatches``.
    window : int, optional
        How many ticks, re-simulated or recorded, may wait with their rows for their
        counterpart (in a log of array_node an output follows its input at once). A tick
        further apart is a mismatch, not compared.
    resets : sequence of (int, int), optional
        The log's ``~/reset`` requests (:func:`~.tools.reset_requests`): (ticks recorded
        before it, log time); each is applied before the tick of that number, as the node did.

    Returns
    -------
    Resimulation
        ``result``.

    Raises
    ------
    LogError
        When the recorded configuration cannot be rebuilt.

    """
    from ..ros.array_messages import decode_cloud
    from .tools import decode

    values = dict(configs[0][1])
    node = values.pop("node", "/array_node")
    recorded = {ARRAY_TEXT: values.pop(ARRAY_TEXT), SCENE_TEXT: values.pop(SCENE_TEXT, "")}
    values = {k: v for k, v in values.items() if k not in ("vibrissa_ros_version", "resets")}
    # in this process: the run's worker processes, if it had any, gave the same results
    values["solver.workers"] = 1
    try:
        config = build_array_config(values, recorded)
        pipeline = ArrayPipeline(config)
    except Exception as exc:  # noqa: BLE001 - any failure to rebuild is the log's problem
        raise LogError(f"the recorded array configuration cannot be rebuilt: {exc}") from None
    prefix = f"{node}/"
    pairs = _Pairing(result, window)
    pending = deque(sorted(resets))
    result.ticks = 0
    for m in messages:
        if not m.topic.startswith(prefix):
            continue
        key = m.topic[len(prefix):]
        if key == "wrenches":
            cloud = decode(m)
            pairs.add(1, header_ns(cloud), decode_cloud(cloud))
            continue
        if key not in ("head_pose", "whisk", "protraction"):
            continue
        msg = decode(m)
        try:
            if key == "head_pose":
                p, q = msg.pose.position, msg.pose.orientation
                pipeline.set_head(msg.header.frame_id, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
                if config.builtin:
                    continue
            else:
                pipeline.set_joints(msg.name, msg.position)
        except BadInput as exc:
            result.dropped[exc.reason] += 1
            continue
        while pending and pending[0][0] <= result.ticks:
            pending.popleft()
            pipeline.request_reset()
        step = pipeline.tick()
        result.ticks += 1
        pairs.add(0, header_ns(msg), output_rows(step, config.scene))
    pairs.finish()
    return result
