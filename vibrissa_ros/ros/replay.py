"""
``vibrissa replay``: publish a log's messages into ROS with their recorded timing.

At ``rate`` 0 the messages go out as fast as DDS takes them: every publisher keeps all of its
topic's messages in its history (depth = their number), so none is overwritten before every
subscriber has acknowledged it, and the replay waits for the acknowledgements once, at the end
(waiting every few messages costs a DDS heartbeat period, ~3 s, each time). The log is streamed
(:class:`~vibrissa_ros.logs.mcap_log.LogReader`: the counts from its summary, the messages one
chunk at a time), so a long one need not fit in memory.
"""

from __future__ import annotations

import time
from typing import Optional, Sequence

import rclpy
from rclpy.duration import Duration
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..logs.mcap_log import LogError, LogReader
from .serialization import message_class

ACK_SECONDS_PER_MESSAGE = 0.005  # how long the final acknowledgement may take, per message
ACK_MIN_SECONDS = 10.0


def _qos(offered: str, depth: int) -> QoSProfile:
    """Return the QoS to republish a channel with, from rosbag2's ``offered_qos_profiles`` text."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=max(1, depth),
        reliability=(ReliabilityPolicy.BEST_EFFORT if "best_effort" in offered
                     else ReliabilityPolicy.RELIABLE),
        durability=(DurabilityPolicy.TRANSIENT_LOCAL if "transient_local" in offered
                    else DurabilityPolicy.VOLATILE),
    )


def _installed(type_name: str) -> bool:
    """Tell whether a message type's Python class can be imported here."""
    try:
        message_class(type_name)
    except (ImportError, AttributeError, ValueError):
        return False
    return True


def replay(path: str, rate: float = 1.0, topics: Optional[Sequence[str]] = None,
           wait_subscribers: float = 5.0, progress=None) -> int:
    """
    Publish recorded messages with their recorded relative timing divided by ``rate``.

    ``rate`` 0 publishes as fast as DDS takes them, nothing lost (see the module). ``progress``:
    an object with ``update(n)`` (a tqdm bar), or None. Returns the number of messages published;
    raises :class:`LogError` if a subscriber did not acknowledge everything in time. Channels
    whose type is not installed here (an array log's ``/tf``) are left out, or refused when
    named in ``topics``.
    """
    with LogReader(path) as log:
        in_log = log.counts()
        types = {c.topic: log.schemas[c.schema_id].name if c.schema_id in log.schemas else ""
                 for c in log.channels.values()}
        offered = {c.topic: c.metadata.get("offered_qos_profiles", "")
                   for c in log.channels.values()}
        present = {topic for topic, n in in_log.items() if n}
        wanted = set(topics) if topics else None
        if wanted:
            missing = wanted - present
            if missing:
                raise LogError(f"topics not in the log: {', '.join(sorted(missing))}")
        chosen = wanted if wanted else present
        # a channel whose type has no Python package here cannot be published (an array log's
        # /tf: tf2_msgs has no wheel): left out, unless asked for by name
        absent = {topic for topic in chosen if not _installed(types[topic])}
        if absent and wanted:
            raise LogError(f"cannot publish {', '.join(sorted(absent))}: type "
                           f"{', '.join(sorted({types[t] for t in absent}))} is not installed")
        chosen -= absent
        return _publish(log, sorted(chosen), types, offered, in_log, rate, wait_subscribers,
                        progress)


def _publish(log: LogReader, chosen, types, offered, counts, rate, wait_subscribers,
             progress) -> int:
    """Publish the chosen topics' messages of an open log, streamed (see :func:`replay`)."""
    total = sum(counts[t] for t in chosen)
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("vibrissa_replay", context=context)
    try:
        publishers = {
            topic: node.create_publisher(message_class(types[topic]), topic,
                                         _qos(offered.get(topic, ""), counts[topic]))
            for topic in chosen
        }
        end = time.monotonic() + wait_subscribers
        while time.monotonic() < end and not all(p.get_subscription_count()
                                                 for p in publishers.values()):
            time.sleep(0.05)
        time.sleep(0.2)  # matched in the graph is not yet matched in DDS for every reader
        if not total:
            return 0
        t0_log = t0 = None
        sent = 0
        for m in log.messages(topics=chosen):
            if t0_log is None:
                t0_log, t0 = m.log_time, time.monotonic()
            if rate > 0:
                delay = t0 + (m.log_time - t0_log) / 1e9 / rate - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
            publishers[m.topic].publish(m.data)  # serialized CDR, published as is
            sent += 1
            if progress is not None and sent % 1000 == 0:
                progress.update(1000)
        if progress is not None:
            progress.update(sent % 1000)
        timeout = Duration(seconds=max(ACK_MIN_SECONDS, ACK_SECONDS_PER_MESSAGE * sent))
        for topic, pub in publishers.items():
            if pub.get_subscription_count() and not pub.wait_for_all_acked(timeout):
                raise LogError(f"{topic}: the subscribers did not acknowledge every message "
                               f"within {timeout.nanoseconds / 1e9:.0f} s")
        return sent
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)
