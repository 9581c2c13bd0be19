"""
The baseline for bench_node.py: a trivial node that answers each foot pose with an empty wrench.

Same topics, QoS and executor as whisker_node, no mechanics: what rclpy and DDS cost on their own.
"""

from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from vibrissa_ros.ros.run import run_node


class EchoNode(Node):
    def __init__(self):
        super().__init__("whisker_node")
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                         reliability=ReliabilityPolicy.RELIABLE)
        self._pub = self.create_publisher(WrenchStamped, "~/wrench", qos)
        self.create_subscription(PoseStamped, "~/foot_pose", self._on_pose, qos)

    def _on_pose(self, msg):
        out = WrenchStamped()
        out.header.stamp = msg.header.stamp
        out.header.frame_id = "whisker_base"
        self._pub.publish(out)


def main():
    return run_node(EchoNode, "echo_node")  # the same executor and life cycle as whisker_node


if __name__ == "__main__":
    main()
