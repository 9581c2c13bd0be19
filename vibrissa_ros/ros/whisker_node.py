"""
ROS 2 virtual whisker: foot poses in, the follicle sensor's wrench and the contact state out.

In: ``~/foot_pose`` (geometry_msgs/PoseStamped in ``world_frame``; planar models: in z = 0 without
roll or pitch, model rod3d: any 6-DoF pose). Out: ``~/wrench`` (base frame; rod3d: all six),
``~/phase``, ``~/contact_force``, ``~/contact_force_magnitude``, ``~/contact_point``,
``~/arc_length``, ``~/contacts``, ``~/events``, ``~/centerline``, ``~/obstacle`` and
``~/obstacles`` (latched) and ``/diagnostics``. Service: ``~/reset`` (std_srvs/Trigger: the next
pose places the whisker unloaded, doc/mechanics/decisions.md, "Recovery"); the topic table of
doc/guide/node.md says what each carries. Every message with a header carries the stamp of the
pose that produced it; the wrench and events are always published, the other per-pose
topics only while somebody subscribes (while recording, all of them are recorded). This module
only wires: checks and steps are :mod:`vibrissa_ros.node.pipeline`'s, conversions
:mod:`vibrissa_ros.node.edge`'s, messages :mod:`.messages`' (the per-pose ones as CDR bytes:
:mod:`.cdr`'s), recording :mod:`.recorder`'s and queueing :mod:`.backlog`'s.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Dict, Optional

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.serialization import deserialize_message, serialize_message
from std_srvs.srv import Trigger

from ..core.rod3d.model import warm_up
from ..node.edge import contact_records, event_record, header_ns, rod_phase
from ..logs.mcap_log import LogError
from ..node.config import PARAMETERS, WhiskerConfig, build_config
from ..core.errors import interrupted
from ..node.pipeline import PosePipeline, PoseStats, drop_reason
from . import cdr
from . import messages as m
from .backlog import PoseBacklog
from .params import NodeParameters
from .recorder import Recorder
from .run import RCLError, run_node
from .topics import OPTIONAL, OUTPUTS, POSES, output_publisher

LOG_THROTTLE_S = 1.0  # seconds between two log lines of the same drop reason
BATCH = 100  # poses processed per executor callback at most (timers and services get a turn)
TAKE_EVERY = 10  # poses processed between two takes of what DDS holds


class WhiskerNode(Node):
    """A virtual whisker: each foot pose is a quasistatic step from the previous one."""

    def __init__(self, node_name: str = "whisker_node", **kwargs):
        super().__init__(node_name, **kwargs)
        self._params = NodeParameters(self, PARAMETERS, build_config, self._apply_parameters)
        self._pipeline = PosePipeline(self.config)
        self._stats = PoseStats()
        self._recorder: Optional[Recorder] = None
        self._record_error = ""
        self._last_log: Dict[str, float] = {}
        self._last_centerline = -math.inf
        self._listened: Dict[str, bool] = {}
        self._listened_at = -math.inf
        self._pub = {key: output_publisher(self, kind, f"~/{key}", qos)
                     for key, (kind, qos) in OUTPUTS.items()}
        self._pub["diagnostics"] = output_publisher(self, DiagnosticArray, "/diagnostics", 10)
        # raw: the poses arrive serialized, as they are recorded (deserialized once, here)
        self._sub = self.create_subscription(PoseStamped, "~/foot_pose", self._on_pose, POSES,
                                             raw=True)
        self._backlog = PoseBacklog(self._sub)
        self._more = self.create_guard_condition(self._work)
        self.create_service(Trigger, "~/reset", self._on_reset)
        period = float(self.config.values["diagnostics.period"])
        self.create_timer(period, self._publish_diagnostics)
        self.create_timer(0.25, self._watch_recording)
        self._start_recording(self.config.values["record.path"])
        self._publish_obstacle()
        if self.config.rod3d:
            # the 3D whisker's compiled kernels: loaded from numba's cache (~0.2 s) or, the first
            # time, compiled (~10 s) while the first poses (free ones need no kernel) arrive
            threading.Thread(target=warm_up, name="rod3d_warm_up", daemon=True).start()
        self.get_logger().info(f"ready: {self.config.describe()}; poses on {self._sub.topic_name}")

    @property
    def config(self) -> WhiskerConfig:
        return self._params.config

    def _now_ns(self) -> int:
        """Log times: the node's clock, like every header the node stamps (sim time too)."""
        return self.get_clock().now().nanoseconds

    def _apply_parameters(self, config: WhiskerConfig, names) -> None:
        if "record.path" in names:
            self._stop_recording()
            self._start_recording(config.values["record.path"])
        resets = self._params.resets(names)
        if self._recorder is not None:
            self._recorder.configuration(config.record_values, self._now_ns(), resets)
        self._pipeline.reconfigure(config, resets)
        if resets:
            self.get_logger().info(
                f"parameters changed ({', '.join(sorted(names))}): the whisker is reset to free; "
                f"the next pose places it. Now: {config.describe()}")
            self._publish_obstacle()

    # -- recording ------------------------------------------------------------------------------
    def _start_recording(self, path: str) -> None:
        if not path:
            return
        endpoints = {**self._pub, "foot_pose": self._sub}
        try:
            self._recorder = Recorder(path, endpoints, self.config.record_values,
                                      self.get_fully_qualified_name(), self._recording_failed)
        except LogError as exc:
            self._recording_failed(str(exc))
            return
        self._record_error = ""
        self.get_logger().info(f"recording to {path}")

    def _recording_failed(self, reason: str) -> None:
        """Report a failed recording, once (from the recorder's thread, possibly)."""
        self._record_error = reason
        if self.context.ok():
            self.get_logger().error(f"recording stopped: {reason}; the whisker keeps running "
                                    "without recording")

    def _watch_recording(self) -> None:
        """Let go of a recorder that failed (its error stays on /diagnostics)."""
        if self._recorder is not None and self._recorder.error is not None:
            self._recorder = None

    def _stop_recording(self) -> None:
        recorder, self._recorder = self._recorder, None
        if recorder is None:
            return
        recorder.close()
        if recorder.error is None and self.context.ok():  # /rosout is gone while shutting down
            self.get_logger().info(f"recording finished: {recorder.path} "
                                   f"({recorder.written} messages)")

    def _record(self, key: str, msg, log_time: int):
        """Record a message; return it serialized (None when not recording)."""
        if self._recorder is not None:
            return self._recorder.write(key, msg, log_time)
        return None

    def _send(self, key: str, msg, log_time: int) -> None:
        """
        Record, then publish: all the node published is in its log, even after a signal.

        Recording serializes the message: the same bytes are published (serialized once).
        """
        data = self._record(key, msg, log_time)
        try:
            self._pub[key].publish(msg if data is None else data)
        except RCLError:
            if self.context.ok():
                raise

    def destroy_node(self):
        self._stop_recording()
        return super().destroy_node()

    # -- input ----------------------------------------------------------------------------------
    def _on_reset(self, request: Trigger.Request, response: Trigger.Response):
        """``~/reset``: forget the whisker; the next accepted pose places it unloaded."""
        if self._recorder is not None:
            self._recorder.reset(self._now_ns())
        self._pipeline.request_reset()
        response.success = True
        response.message = ("the whisker is reset: the next foot pose places it unloaded (a pose "
                            "where it would cut an obstacle is dropped until one is free)")
        self.get_logger().info(f"~/reset: {response.message}")
        return response

    def _on_pose(self, data: bytes) -> None:
        if self._backlog:  # older poses are still waiting: this one goes behind them (and
            self._backlog.append(data)  # before those still in DDS, which are newer)
        else:
            self._process_pose(deserialize_message(data, PoseStamped), data)
        self._work()

    def _work(self) -> None:
        """Process up to BATCH waiting poses; if more wait, come back after the executor's turn."""
        self._backlog.take_available()
        for i in range(BATCH):
            if not self._backlog:
                return
            self._stats.waiting(len(self._backlog))
            self._process_pose(*self._backlog.pop_serialized())
            if i % TAKE_EVERY == TAKE_EVERY - 1:
                self._backlog.take_available()
        if self._backlog:
            self._more.trigger()

    def _process_pose(self, msg: PoseStamped, data: Optional[bytes] = None) -> None:
        """Step to a pose (``data``: its CDR bytes when it arrived serialized)."""
        self._stats.received += 1
        now = self._now_ns()
        if data is not None and self._recorder is not None:
            self._recorder.write_serialized("foot_pose", data, now)
        else:
            self._record("foot_pose", msg, now)
        p, q = msg.pose.position, msg.pose.orientation
        t0 = time.perf_counter_ns()
        try:
            state, events = self._pipeline.handle(msg.header.frame_id, header_ns(msg),
                                                  (p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
        except Exception as exc:  # noqa: BLE001 - nothing from the core may kill the node
            if interrupted(exc):  # Ctrl-C inside a compiled kernel: stop, as on any other
                raise KeyboardInterrupt from exc
            self._drop(drop_reason(exc), f"{type(exc).__name__}: {exc}")
            return
        self._stats.accepted(time.perf_counter_ns() - t0, events)
        self._publish_state(msg.header.stamp, state, events, now)

    def _drop(self, reason: str, message: str) -> None:
        count = self._stats.drop(reason, message)
        now = time.monotonic()
        if now - self._last_log.get(reason, -math.inf) >= LOG_THROTTLE_S:
            self._last_log[reason] = now
            self.get_logger().warning(
                f"dropped a foot pose ({reason}, {count} so far): {message}; state kept")

    # -- output ---------------------------------------------------------------------------------
    def _listening(self) -> Dict[str, bool]:
        """Return which optional topics have subscribers (a graph query, made every 0.1 s)."""
        now = time.monotonic()
        if now - self._listened_at > 0.1:
            self._listened_at = now
            self._listened = {k: self._pub[k].get_subscription_count() > 0 for k in OPTIONAL}
        return self._listened

    def _send_serialized(self, key: str, data: bytes, log_time: int, publish: bool = True):
        """Record CDR bytes (when recording), then publish them (unless ``publish`` is False)."""
        if self._recorder is not None:
            self._recorder.write_serialized(key, data, log_time)
        if publish:
            try:
                self._pub[key].publish(data)
            except RCLError:
                if self.context.ok():
                    raise

    def _emit(self, key: str, make, now: int, listening: Dict[str, bool]) -> None:
        """Publish an optional topic only when someone takes it; record it whenever recording."""
        if listening[key] or self._recorder is not None:
            self._send_serialized(key, make(), now, listening[key])

    def _publish_state(self, stamp, state, events, now: int) -> None:
        """Publish (and record) a pose's answer; the per-pose messages go out as CDR bytes."""
        cfg = self.config
        reading, sensed = self._pipeline.reading(state)
        if cfg.rod3d:  # all six components
            force, torque = sensed[:3], sensed[3:]
        else:
            force, torque = (sensed[0], sensed[1], 0.0), (0.0, 0.0, sensed[2])
        self._send_serialized("wrench", cdr.wrench_cdr(stamp, cfg.base_frame, force, torque), now)
        listening = self._listening()
        world = cfg.world_frame
        self._emit("phase", lambda: cdr.uint8_cdr(reading.phase), now, listening)
        self._emit("contact_force", lambda: cdr.vector_cdr(stamp, world, reading.force_world),
                   now, listening)
        self._emit("contact_force_magnitude", lambda: cdr.float_cdr(reading.force_magnitude),
                   now, listening)
        if reading.contact_world is not None:
            self._emit("contact_point",
                       lambda: cdr.point_cdr(stamp, world, reading.contact_world), now,
                       listening)
            self._emit("arc_length", lambda: cdr.float_cdr(reading.s1), now, listening)
        self._emit("contacts",
                   lambda: cdr.contacts_cdr(stamp, world, contact_records(state, cfg.units)),
                   now, listening)
        for event in events:
            record = event_record(event, cfg.units, cfg.roll)
            msg = m.event_msg(record)
            self._send("events", msg, now)
            if event.kind == "reset":
                self.get_logger().warning(f"event: {msg.data}: the whisker was placed unloaded "
                                          f"at the pose ({event.reason})")
            else:
                self.get_logger().info(f"event: {msg.data}")
        max_rate = cfg.values["centerline.max_rate"]
        tick = time.monotonic()
        if max_rate <= 0.0 or tick - self._last_centerline >= 1.0 / max_rate:
            n = int(cfg.values["centerline.points"])
            self._last_centerline = tick
            if listening["centerline"] or self._recorder is not None:
                msg = self._centerline(stamp, state, n)
                data = serialize_message(msg)
                self._send_serialized("centerline", data, now, listening["centerline"])

    def _centerline(self, stamp, state, n: int):
        """Return the ~/centerline of a state: n points [m] (3D: with the body frames)."""
        cfg = self.config
        if cfg.rod3d:
            s = np.linspace(0.0, 1.0, n)
            return m.centerline_path3d(stamp, cfg.world_frame,
                                       state.equilibrium.centerline(s) * cfg.units.length,
                                       state.equilibrium.frames(s))
        return m.centerline_path(stamp, cfg.world_frame, state.centerline(n) * cfg.units.length)

    def _publish_obstacle(self) -> None:
        """Publish the obstacles (latched): all of them, and as one marker for ~/obstacle."""
        cfg = self.config
        stamp = self.get_clock().now().to_msg()
        if cfg.scene3d is not None:
            array = m.scene3d_markers(cfg.scene3d, cfg.units.length, cfg.world_frame, stamp)
            marker = m.outline_marker(array)
        elif cfg.scene is not None:
            array = m.scene_markers(cfg.scene, cfg.units.length, cfg.world_frame, stamp)
            marker = m.outline_marker(array)
        else:
            marker = m.obstacle_marker(cfg.profile, cfg.units.length, cfg.world_frame, stamp)
            array = m.profile_markers(cfg.profile, cfg.units.length, cfg.world_frame, stamp)
        now = self._now_ns()
        self._send("obstacle", marker, now)
        self._send("obstacles", array, now)

    def _publish_diagnostics(self) -> None:
        stats, recorder = self._stats, self._recorder
        if recorder is not None and recorder.error is not None:
            recorder = None
        state = self._pipeline.state
        if state is None:
            phase = None
        else:
            phase = rod_phase(state) if self.config.rod3d else int(state.phase)
        contacts = "" if state is None else len(contact_records(state, self.config.units))
        values = {
            "phase": "none" if phase is None else str(phase),
            "contacts": contacts,
            **stats.values(),
            "configuration": self.config.describe(),
            "recording": recorder.path if recorder is not None else "",
            "recorded_messages": recorder.written if recorder is not None else 0,
            "recording_error": self._record_error,
        }
        status = m.whisker_status(self.get_fully_qualified_name(), phase, values["poses_dropped"],
                                  stats.last_error, self._record_error, values)
        array = m.diagnostic_array(self.get_clock().now().to_msg(), [status])
        self._send("diagnostics", array, self._now_ns())


def main(args=None) -> int:
    """Entry point of ``ros2 run vibrissa_ros whisker_node``."""
    return run_node(WhiskerNode, "whisker_node", args)


if __name__ == "__main__":  # pragma: no cover
    import sys

    sys.exit(main())
