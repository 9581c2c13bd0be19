"""ROS 2 virtual whisker: foot poses in, the follicle sensor's wrench and the contact state out.

Topics (relative to the node, remappable):

* ``~/foot_pose`` (in) geometry_msgs/PoseStamped: the whisker's base in ``world_frame``; x, y and
  yaw are used, the pose must lie in the plane z = 0 (no roll, no pitch).
* ``~/wrench`` geometry_msgs/WrenchStamped in ``base_frame``: force (x, y) [N] and torque z [N m]
  that the whisker applies to its base (with the optional sensor-noise model ``noise.*``; every other
  topic is exact).
* ``~/phase`` std_msgs/UInt8: 0 free, 1 tangential contact, 2 tip contact.
* ``~/contact_force`` geometry_msgs/Vector3Stamped in ``world_frame``: the obstacle's force on the
  whisker [N] (zero when free); ``~/contact_force_magnitude`` std_msgs/Float64 [N].
* ``~/contact_point`` geometry_msgs/PointStamped in ``world_frame`` [m] and ``~/arc_length``
  std_msgs/Float64 (s1 [m] from the base): only while in contact.
* ``~/events`` std_msgs/String: one JSON object per event (touch, phase, snap, release).
* ``~/centerline`` nav_msgs/Path in ``world_frame`` (at most ``centerline.max_rate`` Hz);
  ``~/obstacle`` visualization_msgs/Marker (latched: transient local).
* ``/diagnostics`` diagnostic_msgs/DiagnosticArray every ``diagnostics.period`` seconds.

Every message with a header carries the stamp of the pose that produced it. The wrench and events
are always published; the other per-pose topics only while somebody subscribes to them.
"""

from __future__ import annotations

import json
import math
import time
from collections import Counter
from typing import Dict, List, Optional

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, PointStamped, PoseStamped, Vector3Stamped, WrenchStamped
from nav_msgs.msg import Path
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64, String, UInt8
from visualization_msgs.msg import Marker

from .core.errors import VibrissaError
from .frames import yaw_quaternion
from .node_config import PARAMETERS, SPECS, WhiskerConfig, build_config
from .pipeline import PosePipeline, drop_reason
from .recorder import Recorder
from .ros_main import run_node

DROP_REASONS = (
    "not_finite",
    "quaternion_not_unit",
    "out_of_plane",
    "wrong_frame_id",
    "stamp_backwards",
    "inside_obstacle",
    "model_assumption",
    "not_converged",
)
_LOG_THROTTLE_S = 1.0  # seconds between two log lines of the same drop reason
_DRAIN_LIMIT = 100  # poses taken per executor callback at most


def _stamp_ns(stamp) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _descriptor(spec) -> ParameterDescriptor:
    text = spec.description + (f" [{spec.unit}]" if spec.unit else "")
    desc = ParameterDescriptor(description=text, read_only=spec.read_only)
    bounded = spec.minimum is not None and spec.maximum is not None
    if isinstance(spec.default, float) and bounded:
        desc.floating_point_range = [
            FloatingPointRange(from_value=float(spec.minimum), to_value=float(spec.maximum), step=0.0)
        ]
    elif isinstance(spec.default, int) and not isinstance(spec.default, bool) and bounded:
        desc.integer_range = [IntegerRange(from_value=int(spec.minimum), to_value=int(spec.maximum), step=1)]
    return desc


class WhiskerNode(Node):
    """A virtual whisker: each foot pose is a quasistatic step from the previous one."""

    def __init__(self, node_name: str = "whisker_node", **kwargs):
        super().__init__(node_name, **kwargs)
        for spec in PARAMETERS:
            self.declare_parameter(spec.name, spec.default, _descriptor(spec))
        self._config: WhiskerConfig = build_config(self._parameter_values())  # raises: bad start-up config
        self._pipeline = PosePipeline(self._config)
        self._recorder: Optional[Recorder] = None
        self._record_error = ""
        self._received = 0
        self._processed = 0
        self._snaps = 0
        self._dropped: Counter = Counter()
        self._last_log: Dict[str, float] = {}
        self._solve_times_ns: List[int] = []
        self._last_error = ""
        self._last_centerline = -math.inf
        self._listened: Dict[str, bool] = {}
        self._listened_at = -math.inf
        self._wrench = WrenchStamped()  # reused: building a message costs more than the solve

        reliable = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        latched = QoSProfile(
            history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
        self._pub_wrench = self.create_publisher(WrenchStamped, "~/wrench", reliable)
        self._pub_phase = self.create_publisher(UInt8, "~/phase", reliable)
        self._pub_force = self.create_publisher(Vector3Stamped, "~/contact_force", reliable)
        self._pub_force_mag = self.create_publisher(Float64, "~/contact_force_magnitude", reliable)
        self._pub_contact = self.create_publisher(PointStamped, "~/contact_point", reliable)
        self._pub_s1 = self.create_publisher(Float64, "~/arc_length", reliable)
        self._pub_events = self.create_publisher(String, "~/events", reliable)
        self._pub_centerline = self.create_publisher(Path, "~/centerline", reliable)
        self._pub_obstacle = self.create_publisher(Marker, "~/obstacle", latched)
        self._pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._sub = self.create_subscription(PoseStamped, "~/foot_pose", self._on_pose, reliable)
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self._diag_timer = self.create_timer(float(self._config.values["diagnostics.period"]), self._publish_diagnostics)
        self._flush_timer = self.create_timer(0.25, self._flush_recording)
        self._start_recording(self._config.values["record.path"])
        self._publish_obstacle()
        self.get_logger().info(f"ready: {self._config.describe()}; poses on {self._sub.topic_name}")

    # -- parameters --------------------------------------------------------------------------
    def _parameter_values(self, overrides=None) -> Dict[str, object]:
        values = {spec.name: self.get_parameter(spec.name).value for spec in PARAMETERS}
        if overrides:
            values.update(overrides)
        return values

    def _validate_parameters(self, params) -> SetParametersResult:
        overrides = {p.name: p.value for p in params if p.name in SPECS}
        try:
            build_config(self._parameter_values(overrides))
        except VibrissaError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params) -> None:
        self._config = build_config(self._parameter_values())
        names = {p.name for p in params}
        if "record.path" in names:
            self._stop_recording()
            self._start_recording(self._config.values["record.path"])
        resets = any(SPECS[p.name].resets for p in params if p.name in SPECS)
        if self._recorder is not None:
            now = self._now_ns()
            self._guard_recording(lambda: self._recorder.configuration(self._config.values, now, resets))
        self._pipeline.reconfigure(self._config, resets)
        if resets:
            self.get_logger().info(
                f"parameters changed ({', '.join(sorted(names))}): the whisker is reset to free; "
                f"the next pose places it. Now: {self._config.describe()}"
            )
            self._publish_obstacle()

    # -- recording ---------------------------------------------------------------------------
    @staticmethod
    def _now_ns() -> int:
        return time.time_ns()

    def _start_recording(self, path: str) -> None:
        if not path:
            return
        try:
            self._recorder = Recorder(path, self, self._config.values)
            self._record_error = ""
            self.get_logger().info(f"recording to {path}")
        except VibrissaError as exc:
            self._recording_failed(exc)

    def _recording_failed(self, exc: Exception) -> None:
        self._recorder = None
        self._record_error = str(exc)
        if self.context.ok():
            self.get_logger().error(f"recording stopped: {exc}; the whisker keeps running without recording")

    def _guard_recording(self, action) -> None:
        try:
            action()
        except VibrissaError as exc:
            recorder, self._recorder = self._recorder, None
            if recorder is not None:
                recorder.abandon()
            self._recording_failed(exc)

    def _stop_recording(self) -> None:
        recorder, self._recorder = self._recorder, None
        if recorder is not None:
            try:
                recorder.close()
                if self.context.ok():  # not while shutting down: /rosout is gone by then
                    self.get_logger().info(f"recording finished: {recorder.path} ({recorder.messages} messages)")
            except VibrissaError as exc:
                self._recording_failed(exc)

    def _flush_recording(self) -> None:
        if self._recorder is not None:
            self._guard_recording(self._recorder.maybe_flush)

    def _record(self, topic: str, msg, log_time: int) -> None:
        if self._recorder is not None:
            self._guard_recording(lambda: self._recorder.write(topic, msg, log_time))

    def destroy_node(self):
        self._stop_recording()
        return super().destroy_node()

    # -- input -------------------------------------------------------------------------------
    def _drop(self, reason: str, message: str) -> None:
        self._dropped[reason] += 1
        self._last_error = f"{reason}: {message}"
        now = time.monotonic()
        if now - self._last_log.get(reason, -math.inf) >= _LOG_THROTTLE_S:
            self._last_log[reason] = now
            self.get_logger().warning(
                f"dropped a foot pose ({reason}, {self._dropped[reason]} so far): {message}; state kept"
            )

    def _on_pose(self, msg: PoseStamped) -> None:
        self._process_pose(msg)
        # Take what else is already queued without a round trip through the executor: its
        # per-callback cost is several times the solve's and dominates a kHz pose stream. Bounded,
        # so that timers and parameter services still get their turn.
        for _ in range(_DRAIN_LIMIT):
            try:
                with self._sub.handle:
                    taken = self._sub.handle.take_message(self._sub.msg_type, self._sub.raw)
            except Exception:  # the handle is gone (shutting down)
                return
            if taken is None:
                return
            self._process_pose(taken[0])

    def _process_pose(self, msg: PoseStamped) -> None:
        self._received += 1
        now = self._now_ns()
        self._record("foot_pose", msg, now)
        p, q = msg.pose.position, msg.pose.orientation
        t0 = time.perf_counter_ns()
        try:
            state, events = self._pipeline.handle(
                msg.header.frame_id, _stamp_ns(msg.header.stamp), (p.x, p.y, p.z), (q.x, q.y, q.z, q.w)
            )
        except VibrissaError as exc:
            self._drop(drop_reason(exc), str(exc))
            return
        self._solve_times_ns.append(time.perf_counter_ns() - t0)
        self._processed += 1
        self._publish_state(msg.header.stamp, state, events, now)

    # -- output ------------------------------------------------------------------------------
    def _listening(self) -> Dict[str, bool]:
        """Which optional topics have subscribers, refreshed at most every 0.1 s (it is a graph query)."""
        now = time.monotonic()
        if now - self._listened_at > 0.1:
            self._listened_at = now
            self._listened = {
                name: pub.get_subscription_count() > 0
                for name, pub in (("phase", self._pub_phase), ("force", self._pub_force),
                                  ("force_mag", self._pub_force_mag), ("contact", self._pub_contact),
                                  ("s1", self._pub_s1), ("centerline", self._pub_centerline))
            }
        return self._listened

    def _publish_state(self, stamp, state, events, now: int) -> None:
        cfg = self._config
        recording = self._recorder is not None
        reading, (sensed_x, sensed_y, sensed_z) = self._pipeline.reading(state)
        wrench = self._wrench
        wrench.header.stamp = stamp
        wrench.header.frame_id = cfg.base_frame
        wrench.wrench.force.x = sensed_x
        wrench.wrench.force.y = sensed_y
        wrench.wrench.torque.z = sensed_z
        self._pub_wrench.publish(wrench)
        self._record("wrench", wrench, now)
        listening = self._listening()

        def emit(key, record_key, publisher, make):
            """Publish (and record) an optional topic only when someone takes it."""
            if listening[key] or recording:
                msg = make()
                publisher.publish(msg)
                self._record(record_key, msg, now)

        emit("phase", "phase", self._pub_phase, lambda: UInt8(data=reading.phase))
        emit("force", "contact_force", self._pub_force,
             lambda: self._stamped(Vector3Stamped(), stamp, "vector", reading.force_world))
        emit("force_mag", "contact_force_magnitude", self._pub_force_mag,
             lambda: Float64(data=float(reading.force_magnitude)))
        if reading.contact_world is not None:
            emit("contact", "contact_point", self._pub_contact,
                 lambda: self._stamped(PointStamped(), stamp, "point", reading.contact_world))
            emit("s1", "arc_length", self._pub_s1, lambda: Float64(data=float(reading.s1)))
        for event in events:
            if event.kind == "snap":
                self._snaps += 1
            record = {
                "kind": event.kind,
                "from_phase": int(event.from_phase),
                "to_phase": int(event.to_phase),
                "x": event.pose.x * cfg.units.length,
                "y": event.pose.y * cfg.units.length,
                "yaw": event.pose.heading,
            }
            msg = String(data=json.dumps(record))
            self._pub_events.publish(msg)
            self._record("events", msg, now)
            self.get_logger().info(f"event: {record}")
        max_rate = cfg.values["centerline.max_rate"]
        tick = time.monotonic()
        due = max_rate <= 0.0 or tick - self._last_centerline >= 1.0 / max_rate
        if (listening["centerline"] or recording) and due:
            self._last_centerline = tick
            self._publish_centerline(stamp, state, now)

    def _stamped(self, msg, stamp, field_name: str, xy):
        """A stamped vector or point in the world frame (z = 0)."""
        msg.header.stamp = stamp
        msg.header.frame_id = self._config.world_frame
        inner = getattr(msg, field_name)
        inner.x, inner.y = float(xy[0]), float(xy[1])
        return msg

    def _publish_centerline(self, stamp, state, now: int) -> None:
        cfg = self._config
        pts = state.centerline(int(cfg.values["centerline.points"])) * cfg.units.length
        tangent = np.diff(pts, axis=0)
        yaws = np.arctan2(tangent[:, 1], tangent[:, 0])
        yaws = np.append(yaws, yaws[-1])
        path = Path()
        path.header.stamp = stamp
        path.header.frame_id = cfg.world_frame
        for (x, y), yaw in zip(pts, yaws):
            pose = PoseStamped()
            pose.header = path.header
            pose.pose.position.x = float(x)
            pose.pose.position.y = float(y)
            qx, qy, qz, qw = yaw_quaternion(float(yaw))
            pose.pose.orientation.z = qz
            pose.pose.orientation.w = qw
            path.poses.append(pose)
        self._pub_centerline.publish(path)
        self._record("centerline", path, now)

    def _publish_obstacle(self) -> None:
        """The obstacle's profile as a latched line strip, up to 2 whisker lengths above its apex."""
        cfg = self._config
        prof = cfg.profile
        apex_y = prof.point(prof.lowest_alpha())[1]
        reach = []
        for side in (-1, 1):
            try:
                reach.append(prof.alpha_at_height(apex_y + 2.0, side))
            except VibrissaError:
                reach.append((prof.alpha_min if side < 0 else prof.alpha_max) - side * 1e-6)
        marker = Marker()
        marker.header.frame_id = cfg.world_frame
        marker.header.stamp = self.get_clock().now().to_msg()
        marker.ns = "obstacle"
        marker.id = 0
        marker.type = Marker.LINE_STRIP
        marker.action = Marker.ADD
        marker.pose.orientation.w = 1.0
        marker.scale.x = 0.01 * cfg.units.length
        marker.color.r, marker.color.g, marker.color.b, marker.color.a = 0.85, 0.35, 0.1, 1.0
        for a in np.union1d(np.linspace(reach[0], reach[1], 400), [prof.lowest_alpha()]):
            x, y = prof.point(float(a))
            marker.points.append(Point(x=float(x) * cfg.units.length, y=float(y) * cfg.units.length))
        self._pub_obstacle.publish(marker)
        self._record("obstacle", marker, self._now_ns())

    def _publish_diagnostics(self) -> None:
        times = np.array(self._solve_times_ns, dtype=float) / 1e3
        self._solve_times_ns = []
        dropped = sum(self._dropped.values())
        status = DiagnosticStatus()
        status.name = f"vibrissa_ros: {self.get_fully_qualified_name()}"
        status.hardware_id = self.get_fully_qualified_name()
        state = self._pipeline.state
        phase = "none" if state is None else str(int(state.phase))
        if self._record_error:
            status.level = DiagnosticStatus.ERROR
            status.message = f"not recording: {self._record_error}"
        elif self._last_error and dropped:
            status.level = DiagnosticStatus.WARN
            status.message = f"{dropped} pose(s) dropped; last: {self._last_error}"
        else:
            status.level = DiagnosticStatus.OK
            status.message = "whisker not placed yet" if state is None else f"phase {phase}"
        values = {
            "phase": phase,
            "poses_received": self._received,
            "poses_processed": self._processed,
            "poses_dropped": dropped,
            "snaps": self._snaps,
            "solves_in_period": len(times),
            "solve_time_median_us": f"{np.median(times):.1f}" if len(times) else "",
            "solve_time_p99_us": f"{np.percentile(times, 99):.1f}" if len(times) else "",
            "solve_time_max_us": f"{times.max():.1f}" if len(times) else "",
            "configuration": self._config.describe(),
            "recording": self._recorder.path if self._recorder is not None else "",
            "recorded_messages": self._recorder.messages if self._recorder is not None else 0,
            "recording_error": self._record_error,
        }
        for reason in DROP_REASONS:
            values[f"dropped_{reason}"] = self._dropped[reason]
        status.values = [KeyValue(key=k, value=str(v)) for k, v in values.items()]
        array = DiagnosticArray()
        array.header.stamp = self.get_clock().now().to_msg()
        array.status = [status]
        self._pub_diag.publish(array)
        self._record("diagnostics", array, self._now_ns())


def main(args=None) -> int:
    """Entry point of ``ros2 run vibrissa_ros whisker_node``."""
    return run_node(WhiskerNode, "whisker_node", args)


if __name__ == "__main__":  # pragma: no cover
    import sys

    sys.exit(main())
