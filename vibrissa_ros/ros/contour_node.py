"""
ROS 2 node: the scanned contour, live, from a foot pose stream and a base wrench stream.

Works with any source of the two topics (whisker_node, a real sensor, ``vibrissa replay``): remap
``~/foot_pose`` and ``~/wrench``, e.g. ``-r ~/foot_pose:=/whisker_node/foot_pose
-r ~/wrench:=/whisker_node/wrench``. Each wrench is paired with the pose of the same stamp (as
whisker_node stamps it) or else the latest pose not newer than it (at most ``max_pose_age``
older). Poses are checked like whisker_node checks them (finite, unit quaternion, in the plane).

Out: ``~/contact_point`` geometry_msgs/PointStamped (world frame, each estimate), ``~/contour``
visualization_msgs/Marker (POINTS, the accumulated estimates coloured by phase, at most 10 Hz).
"""

from __future__ import annotations

import bisect
import math
from collections import OrderedDict
from typing import Dict, List, Optional, Tuple

from geometry_msgs.msg import PointStamped, PoseStamped, WrenchStamped
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from visualization_msgs.msg import Marker

from ..core.errors import VibrissaError
from ..node.edge import BadInput, header_ns, pose_of
from ..node.config import CONTOUR_PARAMETERS, ContourConfig, build_contour_config
from ..node.reconstruction import estimate_from_wrench
from . import messages as m
from .params import NodeParameters
from .run import run_node
from .topics import output_publisher

POSES_KEPT = 10000  # recent poses kept for pairing
WRENCHES_WAITING = 1000  # wrenches kept waiting for the pose of their stamp
QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE
)


class ContourNode(Node):
    """Estimates one contact point per wrench reading and accumulates the contour."""

    def __init__(self, node_name: str = "contour_node", **kwargs):
        super().__init__(node_name, **kwargs)
        self._params = NodeParameters(self, CONTOUR_PARAMETERS, build_contour_config)
        self._poses: "OrderedDict[int, Tuple[float, float, float]]" = OrderedDict()
        self._stamps: List[int] = []
        self._pending: Dict[int, WrenchStamped] = {}
        self._points: List[Tuple[float, float, int]] = []
        self._dirty = False
        self.estimates = 0
        self._pub_point = output_publisher(self, PointStamped, "~/contact_point", QOS)
        self._pub_contour = output_publisher(self, Marker, "~/contour", 10)
        self._sub_pose = self.create_subscription(PoseStamped, "~/foot_pose", self._on_pose, QOS)
        self._sub_wrench = self.create_subscription(WrenchStamped, "~/wrench", self._on_wrench,
                                                    QOS)
        self.create_timer(0.1, self._publish_contour)
        self.get_logger().info(f"{self.config.describe()}; contour from "
                               f"{self._sub_pose.topic_name} and {self._sub_wrench.topic_name}")

    @property
    def config(self) -> ContourConfig:
        return self._params.config

    def _ignore(self, what: str, why: str) -> None:
        self.get_logger().warning(f"{what} ignored: {why}", throttle_duration_sec=1.0)

    def _on_pose(self, msg: PoseStamped) -> None:
        cfg = self.config
        if msg.header.frame_id != cfg.world_frame:
            self._ignore("pose", f"frame '{msg.header.frame_id}', not '{cfg.world_frame}'")
            return
        try:
            pose = pose_of(msg, cfg.values["input.z_tolerance"],
                           cfg.values["input.angle_tolerance"])
        except BadInput as exc:
            self._ignore("pose", str(exc))
            return
        stamp = header_ns(msg)
        self._poses[stamp] = pose
        bisect.insort(self._stamps, stamp)
        while len(self._poses) > POSES_KEPT:
            old, _ = self._poses.popitem(last=False)
            self._stamps.remove(old)
        waiting = self._pending.pop(stamp, None)
        if waiting is not None:
            self._estimate(waiting, pose)

    def _pose_for(self, stamp: int) -> Optional[Tuple[float, float, float]]:
        if stamp in self._poses:
            return self._poses[stamp]
        i = bisect.bisect_right(self._stamps, stamp)
        if i and stamp - self._stamps[i - 1] <= self.config.max_pose_age_ns:
            return self._poses[self._stamps[i - 1]]
        return None

    def _on_wrench(self, msg: WrenchStamped) -> None:
        if msg.header.frame_id != self.config.base_frame:
            self._ignore("wrench", f"frame '{msg.header.frame_id}', not "
                         f"'{self.config.base_frame}'")
            return
        stamp = header_ns(msg)
        pose = self._poses.get(stamp)
        if pose is None:
            if not self._stamps or stamp > self._stamps[-1]:
                self._pending[stamp] = msg  # its pose may still be on the way
                while len(self._pending) > WRENCHES_WAITING:
                    self._pending.pop(next(iter(self._pending)))
                return
            pose = self._pose_for(stamp)
            if pose is None:
                return
        self._estimate(msg, pose)

    def _estimate(self, msg: WrenchStamped, pose) -> None:
        cfg, w = self.config, msg.wrench
        if not all(math.isfinite(v) for v in (w.force.x, w.force.y, w.torque.z)):
            self._ignore("wrench", "a non-finite value")
            return
        try:
            est = estimate_from_wrench(*pose, w.force.x, w.force.y, w.torque.z, cfg.units,
                                       cfg.values["min_force"], cfg.shape)
        except VibrissaError as exc:
            self._ignore("wrench", str(exc))
            return
        if est is None:
            return
        length = cfg.units.length
        point = m.point_stamped(msg.header.stamp, cfg.world_frame,
                                (est.contact[0] * length, est.contact[1] * length))
        self._pub_point.publish(point)
        self.estimates += 1
        self._points.append((point.point.x, point.point.y, int(est.phase)))
        excess = len(self._points) - cfg.values["max_points"]
        if excess > 0:
            del self._points[:excess]
        self._dirty = True

    def _publish_contour(self) -> None:
        if not self._dirty:
            return
        self._dirty = False
        cfg = self.config
        self._pub_contour.publish(m.contour_marker(self._points, cfg.world_frame,
                                                   self.get_clock().now().to_msg(),
                                                   cfg.units.length))


def main(args=None) -> int:
    """Entry point of ``ros2 run vibrissa_ros contour_node``."""
    return run_node(ContourNode, "contour_node", args)


if __name__ == "__main__":  # pragma: no cover
    import sys

    sys.exit(main())
