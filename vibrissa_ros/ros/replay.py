"""
``vibrissa replay``: publish a log's messages into ROS with their recorded timing.

At ``rate`` 0 the messages go out as fast as DDS takes them: every publisher keeps all of its
topic's messages in its history (depth = their number), so none is overwritten before every
subscriber has acknowledged it, and the replay waits for the acknowledgements once, at the end
(waiting every few messages costs a DDS heartbeat period, ~3 s, each time).
"""

from __future__ import annotations

import time
from collections import Counter
from typing import Optional, Sequence

import rclpy
from rclpy.duration import Duration
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..logs.mcap_log import LogError, read_log
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
    _, channels, _, messages = read_log(path)
    wanted = set(topics) if topics else None
    chosen = [m for m in messages if wanted is None or m.topic in wanted]
    if wanted:
        missing = wanted - {m.topic for m in messages}
        if missing:
            raise LogError(f"topics not in the log: {', '.join(sorted(missing))}")
    # a channel whose type has no Python package here cannot be published (an array log's /tf:
    # tf2_msgs has no wheel): left out, unless asked for by name
    types = {m.topic: m.type_name for m in chosen}
    absent = {topic for topic, name in types.items() if not _installed(name)}
    if absent and wanted:
        raise LogError(f"cannot publish {', '.join(sorted(absent))}: type "
                       f"{', '.join(sorted({types[t] for t in absent}))} is not installed")
    chosen = [m for m in chosen if m.topic not in absent]
    counts = Counter(m.topic for m in chosen)
    offered = {c.topic: c.metadata.get("offered_qos_profiles", "") for c in channels.values()}
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("vibrissa_replay", context=context)
    try:
        publishers = {}
        for m in chosen:
            if m.topic not in publishers:
                publishers[m.topic] = node.create_publisher(
                    message_class(m.type_name),
                    m.topic,
                    _qos(offered.get(m.topic, ""), counts[m.topic]),
                )
        end = time.monotonic() + wait_subscribers
        while time.monotonic() < end and not all(p.get_subscription_count()
                                                 for p in publishers.values()):
            time.sleep(0.05)
        time.sleep(0.2)  # matched in the graph is not yet matched in DDS for every reader
        if not chosen:
            return 0
        t0_log, t0 = chosen[0].log_time, time.monotonic()
        for i, m in enumerate(chosen):
            if rate > 0:
                delay = t0 + (m.log_time - t0_log) / 1e9 / rate - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
            publishers[m.topic].publish(m.data)  # serialized CDR, published as is
            if progress is not None and i % 1000 == 999:
                progress.update(1000)
        if progress is not None:
            progress.update(len(chosen) % 1000)
        timeout = Duration(seconds=max(ACK_MIN_SECONDS, ACK_SECONDS_PER_MESSAGE * len(chosen)))
        for topic, pub in publishers.items():
            if pub.get_subscription_count() and not pub.wait_for_all_acked(timeout):
                raise LogError(f"{topic}: the subscribers did not acknowledge every message "
                               f"within {timeout.nanoseconds / 1e9:.0f} s")
        return len(chosen)
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)
