"""The baseline for bench_node.py: a trivial node that answers each foot pose with an empty wrench.

Same topics, QoS and executor as whisker_node, no mechanics: what rclpy and DDS cost on their own.
"""

import rclpy
from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from vibrissa_ros.whisker_node import make_executor


class EchoNode(Node):
    def __init__(self):
        super().__init__("whisker_node")
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self._pub = self.create_publisher(WrenchStamped, "~/wrench", qos)
        self.create_subscription(PoseStamped, "~/foot_pose", self._on_pose, qos)

    def _on_pose(self, msg):
        out = WrenchStamped()
        out.header.stamp = msg.header.stamp
        out.header.frame_id = "whisker_base"
        self._pub.publish(out)


def main():
    rclpy.init()
    node = EchoNode()
    executor = make_executor()  # the same executor as whisker_node
    executor.add_node(node)
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
