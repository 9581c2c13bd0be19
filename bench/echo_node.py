"""
The baseline for bench_node.py and bench_array_node.py: a trivial node that answers each input.

Default: each foot pose with an empty wrench (whisker_node's topics). ``--array``: each JointState
on /array_node/whisk with a PointCloud2 of 30 zero rows of array_node's layout on
/array_node/wrenches (array_node's topics and QoS). Same executor and publishers
(``output_publisher``) as the nodes, no mechanics: what rclpy and DDS cost on their own.
"""

import sys

import numpy as np
from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState, PointCloud2

from vibrissa_ros.node.array import ARRAY_DTYPE
from vibrissa_ros.ros.array_messages import wrenches_cdr
from vibrissa_ros.ros.run import run_node
from vibrissa_ros.ros.topics import output_publisher


class EchoNode(Node):
    def __init__(self):
        super().__init__("whisker_node")
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                         reliability=ReliabilityPolicy.RELIABLE)
        self._pub = output_publisher(self, WrenchStamped, "~/wrench", qos)
        self.create_subscription(PoseStamped, "~/foot_pose", self._on_pose, qos)

    def _on_pose(self, msg):
        out = WrenchStamped()
        out.header.stamp = msg.header.stamp
        out.header.frame_id = "whisker_base"
        self._pub.publish(out)


class ArrayEchoNode(Node):
    def __init__(self, whiskers: int = 30):
        super().__init__("array_node")
        inputs = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                            reliability=ReliabilityPolicy.RELIABLE)
        outputs = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                             reliability=ReliabilityPolicy.RELIABLE)
        self._rows = np.zeros(whiskers, dtype=ARRAY_DTYPE)
        self._pub = output_publisher(self, PointCloud2, "~/wrenches", outputs)
        self.create_subscription(JointState, "~/whisk", self._on_whisk, inputs)

    def _on_whisk(self, msg):
        # serialized from the template, as array_node's (the floor of the same work)
        self._pub.publish(wrenches_cdr(msg.header.stamp, "world", self._rows))


def main():
    if "--array" in sys.argv:
        return run_node(ArrayEchoNode, "echo_node")
    return run_node(EchoNode, "echo_node")  # the same executor and life cycle as whisker_node


if __name__ == "__main__":
    main()
