"""ROS 2 CDR (de)serialization of logged messages, with the installed message classes."""

from __future__ import annotations

import importlib

from rclpy.serialization import deserialize_message


def message_class(type_name: str):
    """'geometry_msgs/msg/PoseStamped' -> the installed Python message class."""
    package, _, name = type_name.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


def decode(message):
    """Return the message object of a :class:`~vibrissa_ros.logs.mcap_log.LogMessage`."""
    return deserialize_message(message.data, message_class(message.type_name))
