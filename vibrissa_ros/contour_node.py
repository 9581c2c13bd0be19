"""ROS 2 node: the scanned contour, live, from a foot pose stream and a base wrench stream.

Works with any source of the two topics (whisker_node, a real sensor, ``vibrissa replay``): remap
``foot_pose`` and ``wrench``, e.g. ``-r foot_pose:=/whisker_node/foot_pose -r
wrench:=/whisker_node/wrench``. Each wrench is paired with the pose of the same stamp (as
whisker_node stamps it) or else the latest pose not newer than it (at most ``max_pose_age`` older).

Out: ``~/contact_point`` geometry_msgs/PointStamped (world frame, each estimate), ``~/contour``
visualization_msgs/Marker (POINTS, the accumulated estimates coloured by phase, at most 10 Hz).
"""

from __future__ import annotations

import bisect
import math
from collections import OrderedDict
from typing import Dict, List, Optional, Tuple

from geometry_msgs.msg import Point, PointStamped, PoseStamped, WrenchStamped
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker

from .core.errors import ParameterError, VibrissaError
from .frames import Units
from .reconstruction import estimate_from_wrench
from .ros_main import run_node

PARAMETERS = {
    "whisker.length": (0.1, "length L of the whisker [m]"),
    "whisker.bending_stiffness": (5e-4, "bending stiffness EI [N m^2]"),
    "world_frame": ("world", "frame of the poses and of the published contour"),
    "base_frame": ("whisker_base", "frame_id the wrenches must carry (the base frame, REP 103)"),
    "min_force": (0.0, "readings with a smaller force are taken as no contact [N] (noisy sensors)"),
    "max_pose_age": (0.1, "largest age of the pose paired with a wrench that has no pose of its own stamp [s]"),
    "max_points": (100000, "points kept in the accumulated contour"),
}
_PHASE_COLOR = {1: (0.12, 0.47, 0.71), 2: (0.84, 0.15, 0.16)}


def _ns(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


class ContourNode(Node):
    def __init__(self):
        super().__init__("contour_node")
        for name, (default, text) in PARAMETERS.items():
            self.declare_parameter(name, default, ParameterDescriptor(description=text, read_only=True))
        v = {name: self.get_parameter(name).value for name in PARAMETERS}
        for name in ("whisker.length", "whisker.bending_stiffness"):
            if not (isinstance(v[name], float) and math.isfinite(v[name]) and v[name] > 0.0):
                raise ParameterError(f"{name} = {v[name]!r} must be > 0")
        self._units = Units.elastica(v["whisker.length"], v["whisker.bending_stiffness"])
        self._world = v["world_frame"]
        self._base = v["base_frame"]
        self._min_force = float(v["min_force"])
        self._max_age = int(float(v["max_pose_age"]) * 1e9)
        self._max_points = int(v["max_points"])
        self._poses: "OrderedDict[int, Tuple[float, float, float]]" = OrderedDict()
        self._stamps: List[int] = []
        self._pending: Dict[int, WrenchStamped] = {}
        self._points: List[Tuple[float, float, int]] = []
        self._dirty = False
        self.estimates = 0
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self._pub_point = self.create_publisher(PointStamped, "~/contact_point", qos)
        self._pub_contour = self.create_publisher(Marker, "~/contour", 10)
        self.create_subscription(PoseStamped, "foot_pose", self._on_pose, qos)
        self.create_subscription(WrenchStamped, "wrench", self._on_wrench, qos)
        self.create_timer(0.1, self._publish_contour)
        self.get_logger().info(f"contour from {self.resolve_topic_name('foot_pose')} and {self.resolve_topic_name('wrench')}")

    def _on_pose(self, msg: PoseStamped) -> None:
        if msg.header.frame_id != self._world:
            self.get_logger().warning(f"pose in frame '{msg.header.frame_id}', not '{self._world}': ignored",
                                      throttle_duration_sec=1.0)
            return
        q = msg.pose.orientation
        yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
        stamp = _ns(msg)
        self._poses[stamp] = (msg.pose.position.x, msg.pose.position.y, yaw)
        bisect.insort(self._stamps, stamp)
        while len(self._poses) > 10000:
            old, _ = self._poses.popitem(last=False)
            self._stamps.remove(old)
        waiting = self._pending.pop(stamp, None)
        if waiting is not None:
            self._estimate(waiting, self._poses[stamp])

    def _pose_for(self, stamp: int) -> Optional[Tuple[float, float, float]]:
        if stamp in self._poses:
            return self._poses[stamp]
        i = bisect.bisect_right(self._stamps, stamp)
        if i and stamp - self._stamps[i - 1] <= self._max_age:
            return self._poses[self._stamps[i - 1]]
        return None

    def _on_wrench(self, msg: WrenchStamped) -> None:
        if msg.header.frame_id != self._base:
            self.get_logger().warning(f"wrench in frame '{msg.header.frame_id}', not '{self._base}': ignored",
                                      throttle_duration_sec=1.0)
            return
        stamp = _ns(msg)
        pose = self._poses.get(stamp)
        if pose is None:
            if not self._stamps or stamp > self._stamps[-1]:
                self._pending[stamp] = msg  # its pose may still be on the way
                while len(self._pending) > 1000:
                    self._pending.pop(next(iter(self._pending)))
                return
            pose = self._pose_for(stamp)
            if pose is None:
                return
        self._estimate(msg, pose)

    def _estimate(self, msg: WrenchStamped, pose) -> None:
        w = msg.wrench
        values = (w.force.x, w.force.y, w.torque.z, *pose)
        if not all(math.isfinite(v) for v in values):
            return
        try:
            est = estimate_from_wrench(pose[0], pose[1], pose[2], w.force.x, w.force.y, w.torque.z, self._units,
                                       self._min_force)
        except VibrissaError:
            return
        if est is None:
            return
        L = self._units.length
        point = PointStamped()
        point.header.stamp = msg.header.stamp
        point.header.frame_id = self._world
        point.point.x, point.point.y = float(est.contact[0] * L), float(est.contact[1] * L)
        self._pub_point.publish(point)
        self.estimates += 1
        self._points.append((point.point.x, point.point.y, int(est.phase)))
        if len(self._points) > self._max_points:
            del self._points[: len(self._points) - self._max_points]
        self._dirty = True

    def _publish_contour(self) -> None:
        if not self._dirty:
            return
        self._dirty = False
        marker = Marker()
        marker.header.frame_id = self._world
        marker.header.stamp = self.get_clock().now().to_msg()
        marker.ns = "contour"
        marker.type = Marker.POINTS
        marker.action = Marker.ADD
        marker.pose.orientation.w = 1.0
        marker.scale.x = marker.scale.y = 0.005 * self._units.length
        for x, y, phase in self._points:
            marker.points.append(Point(x=x, y=y))
            r, g, b = _PHASE_COLOR[phase]
            marker.colors.append(ColorRGBA(r=r, g=g, b=b, a=1.0))
        self._pub_contour.publish(marker)


def main(args=None) -> int:
    """Entry point of ``ros2 run vibrissa_ros contour_node``."""
    return run_node(ContourNode, "contour_node", args)


if __name__ == "__main__":  # pragma: no cover
    import sys

    sys.exit(main())
