"""
Records a node's endpoints into an MCAP log (rosbag2 layout), failures handled here.

The recorder is given ``{key: endpoint}`` (publishers and subscriptions, or anything with their
``topic_name``, ``msg_type`` and ``qos_profile``) and takes each channel's topic, type and offered
QoS from the endpoint itself; a :class:`~vibrissa_ros.logs.mcap_log.TopicSpec` instead is a
channel only recorded. It takes messages serialized (:meth:`Recorder.write_serialized`:
CDR bytes, e.g. those a node publishes with ``publisher.publish(data)``) or as objects
(:meth:`Recorder.write` serializes them in the caller's thread: they may be reused right after).
Writing, chunking and compressing happen in a writer process of its own
(:class:`~vibrissa_ros.logs.background.LogProcess`), so neither a chunk's compression nor the
MCAP library's Python holds the node's interpreter; given a ``writer``, in a thread instead
(:class:`~vibrissa_ros.logs.background.LogThread`).

A failure of any kind (the disk is full, the file is gone, the mcap library misbehaves) stops the
recording, never the node: the recorder finishes the file as far as it can (whatever was written
stays readable), keeps the reason in :attr:`Recorder.error` and reports it once through
``on_error``. Calls after a failure do nothing.
"""

from __future__ import annotations

import json
import threading
from collections import Counter
from typing import Callable, Dict, Mapping, Optional

from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy
from rclpy.serialization import serialize_message

from .. import __version__
from ..logs.background import LogProcess, LogThread
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
    """
    Records one run of one node; see the module's docstring for what happens on failure.

    Parameters
    ----------
    path : str
        The log file, created or overwritten.
    endpoints : mapping
        ``{key: endpoint}``: a channel per endpoint (its topic, type and offered QoS); ``key``
        names it in :meth:`write` and :meth:`write_serialized`. An endpoint may also be a
        :class:`~vibrissa_ros.logs.mcap_log.TopicSpec`: a channel only recorded (e.g. ``/tf``,
        whose type no wheel here provides, written serialized).
    values : mapping
        The node's parameter values: the first configuration record, holding from the start.
    node_name : str
        The node's fully qualified name, in every configuration record.
    on_error : callable, optional
        Called once with the reason when the recording fails (from the writer's thread).
    writer : LogWriter, optional
        Write this log in a thread of this process instead of a writer process.

    Raises
    ------
    LogError
        When the file cannot be opened or a channel's type is not installed.

    """

    def __init__(self, path: str, endpoints: Mapping[str, object], values: Mapping[str, object],
                 node_name: str, on_error: Callable[[str], None] = lambda reason: None,
                 writer: Optional[LogWriter] = None):
        self.path = path
        self.error: Optional[str] = None
        self._on_error = on_error
        self._node_name = node_name
        self._queued = 0
        self._counts: Counter = Counter()  # messages handed over, by endpoint key
        self._lock = threading.Lock()
        if writer is not None:
            self._sink = LogThread(writer, self._fail)
        else:
            self._sink = LogProcess(path, self._fail)
        try:
            self._channels = {key: self._sink.channel(
                endpoint if isinstance(endpoint, TopicSpec) else topic_spec(endpoint))
                for key, endpoint in endpoints.items()}
        except LogError:
            self._sink.close()
            raise
        self.configuration(values, 0, resets=True)  # the start: holds from the beginning

    @property
    def queued(self) -> int:
        """Messages handed to the recorder."""
        return self._queued

    @property
    def written(self) -> int:
        """Messages the writer has written to the file."""
        return self._sink.messages

    def _fail(self, reason: str) -> None:
        with self._lock:
            if self.error is not None:
                return
            self.error = reason
        self._on_error(reason)

    def configuration(self, values: Mapping[str, object], log_time: int, resets: bool) -> None:
        """Record a (new) configuration, holding from ``log_time`` on."""
        if self.error is None:
            self._sink.metadata(CONFIGURATION_METADATA,
                                configuration_record(values, self._node_name, log_time, resets))

    def reset(self, log_time: int, pose_key: str = "foot_pose") -> None:
        """
        Record a ``~/reset`` request.

        It holds before the next message of ``pose_key``: the record counts those recorded
        before it (``poses_before``), so a re-simulation applies it exactly there, whatever the
        clock did.
        """
        if self.error is None:
            self._sink.metadata(RESET_METADATA, {
                "log_time": json.dumps(int(log_time)),
                "poses_before": json.dumps(int(self._counts[pose_key])),
                "node": json.dumps(self._node_name),
            })

    def write_serialized(self, key: str, data: bytes, log_time: int) -> None:
        """Queue a message of the endpoint ``key``, serialized (CDR), logged at ``log_time``."""
        if self.error is None:
            self._sink.write(self._channels[key], data, log_time)
            self._queued += 1
            self._counts[key] += 1

    def write(self, key: str, msg, log_time: int) -> bytes:
        """Queue a message of the endpoint ``key`` (serialized now: ``msg`` may be reused)."""
        data = serialize_message(msg)
        self.write_serialized(key, data, log_time)
        return data

    def close(self) -> None:
        """
        Write what is queued, then the summary: a finished, indexed MCAP.

        After a failure: as much of it as could be saved.
        """
        self._sink.close()
