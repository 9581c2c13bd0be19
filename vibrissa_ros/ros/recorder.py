"""
Records a node's endpoints into an MCAP log (rosbag2 layout), failures handled here.

The recorder is given ``{key: endpoint}`` (publishers and subscriptions) and takes each channel's
topic, type and offered QoS from the endpoint itself. Messages are serialized in the caller's
thread (they may be reused right after) and written, chunked and compressed by a writer thread,
so closing a chunk never stalls the whisker.

A failure of any kind (the disk is full, the file is gone, the mcap library misbehaves) stops the
recording, never the node: the recorder finishes the file as far as it can (whatever was written
stays readable), keeps the reason in :attr:`Recorder.error` and reports it once through
``on_error``. Calls after a failure do nothing.
"""

from __future__ import annotations

import json
import queue
import threading
from collections import Counter
from typing import Callable, Dict, Mapping, Optional

from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy
from rclpy.serialization import serialize_message

from .. import __version__
from ..logs.mcap_log import CONFIGURATION_METADATA, RESET_METADATA, LogError, LogWriter, TopicSpec


def configuration_record(values: Mapping[str, object], node_name: str, log_time: int,
                         resets: bool) -> Dict[str, str]:
    """
    Return the metadata that says how a log was made.

    Every parameter (JSON-encoded), from which log time on it holds, and whether taking it reset
    the whisker.
    """
    record = {name: json.dumps(value) for name, value in values.items()}
    record["node"] = json.dumps(node_name)
    record["vibrissa_ros_version"] = json.dumps(__version__)
    record["log_time"] = json.dumps(int(log_time))
    record["resets"] = json.dumps(bool(resets))
    return record


def type_name(msg_type) -> str:
    """'geometry_msgs/msg/PoseStamped' of a message class."""
    return f"{msg_type.__module__.split('.')[0]}/msg/{msg_type.__name__}"


def topic_spec(endpoint) -> TopicSpec:
    """Return the channel of a publisher or subscription: its topic, type and QoS as offered."""
    qos = endpoint.qos_profile
    return TopicSpec(
        endpoint.topic_name,
        type_name(endpoint.msg_type),
        reliable=qos.reliability != ReliabilityPolicy.BEST_EFFORT,
        transient_local=qos.durability == DurabilityPolicy.TRANSIENT_LOCAL,
        depth=int(qos.depth),
        keep_all=qos.history == HistoryPolicy.KEEP_ALL,
    )


class Recorder:
    """Records one run of one node; see the module's docstring for what happens on failure."""

    _STOP = object()

    def __init__(self, path: str, endpoints: Mapping[str, object], values: Mapping[str, object],
                 node_name: str, on_error: Callable[[str], None] = lambda reason: None,
                 writer: Optional[LogWriter] = None):
        """Open ``path`` and register a channel per endpoint; raises LogError if it cannot."""
        self.path = path
        self.error: Optional[str] = None
        self._on_error = on_error
        self._node_name = node_name
        self._writer = writer if writer is not None else LogWriter(path)
        self._queue: "queue.SimpleQueue" = queue.SimpleQueue()
        self._queued = 0
        self._counts: Counter = Counter()  # messages handed over, by endpoint key
        self._lock = threading.Lock()
        try:
            self._channels = {key: self._writer.channel(topic_spec(endpoint))
                              for key, endpoint in endpoints.items()}
        except LogError:
            self._writer.abandon()
            raise
        self._thread = threading.Thread(target=self._run, name="vibrissa-recorder", daemon=True)
        self._thread.start()
        self.configuration(values, 0, resets=True)  # the start: holds from the beginning

    @property
    def queued(self) -> int:
        """Messages handed to the recorder."""
        return self._queued

    @property
    def written(self) -> int:
        """Messages the writer thread has written to the file."""
        return self._writer.messages

    def _fail(self, reason: str) -> None:
        with self._lock:
            if self.error is not None:
                return
            self.error = reason
        self._on_error(reason)

    def _run(self) -> None:
        writer = self._writer
        try:
            while True:
                try:
                    item = self._queue.get(timeout=0.1)
                except queue.Empty:
                    item = None
                if item is self._STOP:
                    return
                if item is not None:
                    if item[0] == "meta":
                        writer.metadata(item[1], item[2])
                    else:
                        writer.write(item[0], item[1], item[2])
                writer.flush_if_due()
        except LogError as exc:
            self._fail(str(exc))
            writer.abandon()
        except Exception as exc:  # noqa: BLE001 - any failure of this thread must be reported
            self._fail(f"writing {self.path!r} failed: {type(exc).__name__}: {exc}")
            writer.abandon()  # finish the file as far as possible: what was written stays

    def configuration(self, values: Mapping[str, object], log_time: int, resets: bool) -> None:
        """Record a (new) configuration, holding from ``log_time`` on."""
        if self.error is None:
            self._queue.put(("meta", CONFIGURATION_METADATA,
                             configuration_record(values, self._node_name, log_time, resets)))

    def reset(self, log_time: int, pose_key: str = "foot_pose") -> None:
        """
        Record a ``~/reset`` request.

        It holds before the next message of ``pose_key``: the record counts those recorded
        before it (``poses_before``), so a re-simulation applies it exactly there, whatever the
        clock did.
        """
        if self.error is None:
            self._queue.put(("meta", RESET_METADATA, {
                "log_time": json.dumps(int(log_time)),
                "poses_before": json.dumps(int(self._counts[pose_key])),
                "node": json.dumps(self._node_name),
            }))

    def write(self, key: str, msg, log_time: int) -> None:
        """Queue a message of the endpoint ``key`` (serialized now: ``msg`` may be reused)."""
        if self.error is None:
            self._queue.put((self._channels[key], serialize_message(msg), log_time))
            self._queued += 1
            self._counts[key] += 1

    def close(self) -> None:
        """
        Write what is queued, then the summary: a finished, indexed MCAP.

        After a failure: as much of it as could be saved.
        """
        if self._thread.is_alive():
            self._queue.put(self._STOP)
            self._thread.join()
        if self.error is None:
            try:
                self._writer.close()
            except LogError as exc:
                self._fail(str(exc))
