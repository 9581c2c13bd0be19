"""The nodes' outputs keep the executor's wait set small: no publisher-side QoS event handlers."""

import rclpy
from std_msgs.msg import Float64

from vibrissa_ros.ros.topics import OUTPUTS, output_publisher


def _waitables(node) -> int:
    return len(list(node.waitables))


def test_output_publishers_add_nothing_to_the_wait_set(rcl_context):
    node = rclpy.create_node("topics_probe", context=rcl_context)
    try:
        bare = _waitables(node)
        pubs = [output_publisher(node, Float64, f"~/out_{i}", 10) for i in range(12)]
        assert _waitables(node) == bare
        # rclpy's default: two handlers each (incompatible QoS and type), every executor turn
        node.create_publisher(Float64, "~/default", 10)
        assert _waitables(node) == bare + 2
        assert all(p.topic_name.startswith("/topics_probe/out_") for p in pubs)
    finally:
        node.destroy_node()


def test_whisker_node_waits_on_its_input_and_nothing_per_output(rcl_context):
    from vibrissa_ros.ros.whisker_node import WhiskerNode

    bare = rclpy.create_node("bare_probe", context=rcl_context)
    node = WhiskerNode(context=rcl_context)
    try:
        assert len(OUTPUTS) >= 10
        # the input subscription keeps its two default handlers (a robot's incompatible QoS is
        # reported here); the node's 12 publishers add none (they added 24)
        assert _waitables(node) == _waitables(bare) + 2
    finally:
        node.destroy_node()
        bare.destroy_node()
