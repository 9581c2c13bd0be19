"""The whisker node's recorder: serializes what the node receives and publishes into an MCAP log."""

from __future__ import annotations

import json
import queue
import threading
from typing import Dict, Mapping, Optional

from rclpy.serialization import serialize_message

from . import __version__
from .mcap_log import CONFIGURATION_METADATA, LogError, LogWriter, TopicSpec

#: recorded topics: key -> (attribute of the node holding the publisher or subscription, type)
RECORDED = {
    "foot_pose": ("_sub", "geometry_msgs/msg/PoseStamped"),
    "wrench": ("_pub_wrench", "geometry_msgs/msg/WrenchStamped"),
    "phase": ("_pub_phase", "std_msgs/msg/UInt8"),
    "contact_force": ("_pub_force", "geometry_msgs/msg/Vector3Stamped"),
    "contact_force_magnitude": ("_pub_force_mag", "std_msgs/msg/Float64"),
    "contact_point": ("_pub_contact", "geometry_msgs/msg/PointStamped"),
    "arc_length": ("_pub_s1", "std_msgs/msg/Float64"),
    "events": ("_pub_events", "std_msgs/msg/String"),
    "centerline": ("_pub_centerline", "nav_msgs/msg/Path"),
    "obstacle": ("_pub_obstacle", "visualization_msgs/msg/Marker"),
    "diagnostics": ("_pub_diag", "diagnostic_msgs/msg/DiagnosticArray"),
}


def configuration_record(values: Mapping[str, object], node_name: str, log_time: int, resets: bool) -> Dict[str, str]:
    """The metadata that says how a log was made: every parameter (JSON-encoded), from which log time
    on it holds, and whether taking it reset the whisker (a runtime change of the whisker or obstacle)."""
    record = {name: json.dumps(value) for name, value in values.items()}
    record["node"] = json.dumps(node_name)
    record["vibrissa_ros_version"] = json.dumps(__version__)
    record["log_time"] = json.dumps(int(log_time))
    record["resets"] = json.dumps(bool(resets))
    return record


class Recorder:
    """Records one run. Messages are serialized in the caller's thread (they may be reused right
    after) and written, chunked and compressed by a writer thread, so that closing a chunk never
    stalls the whisker. Every error surfaces as :class:`~vibrissa_ros.mcap_log.LogError`, from
    the next call after it happened."""

    _STOP = object()

    def __init__(self, path: str, node, values: Mapping[str, object]):
        self.path = path
        self._node_name = node.get_fully_qualified_name()
        self._writer = LogWriter(path)
        self._channels: Dict[str, int] = {}
        self._queue: "queue.SimpleQueue" = queue.SimpleQueue()
        self._error: Optional[str] = None
        self._queued = 0
        try:
            for key, (attr, type_name) in RECORDED.items():
                endpoint = getattr(node, attr)
                transient = key == "obstacle"
                depth = 1 if transient else (10 if key == "diagnostics" else 1000)
                self._channels[key] = self._writer.channel(
                    TopicSpec(endpoint.topic_name, type_name, reliable=True, transient_local=transient, depth=depth)
                )
        except Exception:
            self.abandon()
            raise
        self._thread = threading.Thread(target=self._run, name="vibrissa-recorder", daemon=True)
        self._thread.start()
        self.configuration(values, 0, resets=True)  # the start: holds from the beginning

    @property
    def messages(self) -> int:
        return self._queued

    def _check(self) -> None:
        if self._error is not None:
            raise LogError(self._error)

    def _run(self) -> None:
        writer = self._writer
        while True:
            try:
                item = self._queue.get(timeout=0.1)
            except queue.Empty:
                item = None
            if item is self._STOP:
                return
            if self._error is not None:
                continue  # drain: the file is lost, the whisker goes on
            try:
                if item is not None:
                    if item[0] == "meta":
                        writer.metadata(item[1], item[2])
                    else:
                        writer.write(item[0], item[1], item[2])
                writer.maybe_flush()
            except LogError as exc:
                self._error = str(exc)

    def configuration(self, values: Mapping[str, object], log_time: int, resets: bool) -> None:
        self._check()
        self._queue.put(("meta", CONFIGURATION_METADATA, configuration_record(values, self._node_name, log_time, resets)))

    def write(self, key: str, msg, log_time: int) -> None:
        self._check()
        self._queue.put((self._channels[key], serialize_message(msg), log_time))
        self._queued += 1

    def maybe_flush(self) -> None:
        """The writer thread flushes on its own; this reports its errors."""
        self._check()

    def close(self) -> None:
        """Write what is queued, then the summary: a finished, indexed MCAP."""
        self._queue.put(self._STOP)
        self._thread.join()
        self._check()
        self._writer.close()

    def abandon(self) -> None:
        """Give up after an error: close the file as far as possible."""
        thread = getattr(self, "_thread", None)
        if thread is not None and thread.is_alive():
            self._queue.put(self._STOP)
            thread.join()
        try:
            self._writer.close()
        except Exception:  # noqa: BLE001 - the disk is full or gone: nothing more to save
            pass
