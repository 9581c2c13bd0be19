"""
The poses a node has taken from DDS and not processed yet, in arrival order.

Taking from the subscription's handle directly is cheap (no executor turn) and keeps DDS's own
queue from filling: with a keep-all subscription a fast sender is then never throttled by
retransmissions, and a step that takes long delays the poses behind it without losing any.
Taken poses are kept serialized (a few dozen bytes each) and deserialized when processed.
"""

from __future__ import annotations

from collections import deque
from typing import Deque, Union

from rclpy.exceptions import InvalidHandle
from rclpy.serialization import deserialize_message
from rclpy.subscription import Subscription

MAX_BACKLOG = 200_000  # poses held at most; beyond, DDS holds them (keep all: none lost)


class PoseBacklog:
    """A FIFO of messages of one subscription: the executor's delivery plus what DDS holds."""

    def __init__(self, subscription: Subscription, limit: int = MAX_BACKLOG):
        self._sub = subscription
        self._limit = limit
        self._items: Deque[Union[bytes, object]] = deque()

    def __len__(self) -> int:
        return len(self._items)

    def append(self, msg) -> None:
        """Queue a message the executor delivered (older than any still in DDS), or its bytes."""
        self._items.append(msg)

    def take_available(self) -> None:
        """Move what DDS holds for the subscription into the backlog, serialized."""
        while len(self._items) < self._limit:
            try:
                with self._sub.handle:
                    taken = self._sub.handle.take_message(self._sub.msg_type, True)
            except InvalidHandle:  # the subscription is gone (shutting down)
                return
            if taken is None:
                return
            self._items.append(taken[0])

    def pop(self):
        """Return the oldest message, deserialized."""
        return self.pop_serialized()[0]

    def pop_serialized(self):
        """Return the oldest message, deserialized, and its CDR bytes (None if not taken so)."""
        item = self._items.popleft()
        if isinstance(item, bytes):
            return deserialize_message(item, self._sub.msg_type), item
        return item, None
