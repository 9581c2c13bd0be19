"""
ROS 2 whisker array (the rat's mystacial pad): head pose and whisking in, all wrenches out.

In: ``~/head_pose`` (geometry_msgs/PoseStamped in ``world_frame``, metres) and, with
``whisk.source: external``, ``~/whisk`` (sensor_msgs/JointState: protraction angles [rad] by
whisker name, ``row_<A-E>`` or ``whisk``). Which input ticks: the built-in whisk's timer
(``rate``), or with ``external`` every accepted JointState and every accepted head pose.
Out every tick: ``~/wrenches`` (sensor_msgs/PointCloud2, one point per whisker, the fields of
:data:`~vibrissa_ros.node.array.ARRAY_FIELDS`), ``~/events`` (std_msgs/String, JSON) and, with
the built-in whisk, ``~/protraction`` (sensor_msgs/JointState, joint ``whisk``); latched
``~/whiskers`` (names and frames, JSON) and ``~/obstacles``; at ``display.rate``: ``~/shapes``
(MarkerArray of LINE_STRIPs) and ``~/contacts`` (PointCloud2); at ``wrench.rate``:
``~/<name>/wrench``; ``/diagnostics`` (a status per whisker and one for the node). Recorded
besides, in the log only: ``/tf`` at ``display.rate`` (the head's and every whisker's base frame
in the world; no tf2_msgs wheel here to publish it, :mod:`.transforms`). Service:
``~/reset`` (std_srvs/Trigger: before the next tick every whisker is re-placed unloaded at its
pose of the last tick; recorded, so that a re-simulation resets at the same tick).
doc/guide/node.md, "array_node", has the tables. This module only wires: checks and the tick
are :mod:`vibrissa_ros.node.array`'s, messages :mod:`.array_messages`', recording
:mod:`.recorder`'s.
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections import Counter
from typing import Dict, Optional

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import String
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from ..core.rod3d.model import warm_up
from ..logs.mcap_log import LogError
from ..node.array import (
    ARRAY_PARAMETERS,
    ArrayConfig,
    ArrayPipeline,
    build_array_config,
    finite,
    output_rows,
)
from ..node.edge import BadInput
from ..core.errors import VibrissaError, interrupted
from ..node.pipeline import drop_reason
from . import array_messages as am
from . import messages as m
from .cdr import wrench_cdr
from .params import NodeParameters
from .recorder import Recorder
from .run import RCLError, run_node
from .transforms import TF_SPEC, tf_message_cdr
from .topics import LATCHED, output_publisher

LOG_THROTTLE_S = 1.0  # seconds between two log lines of the same drop reason
#: inputs: keep the last few (a slow tick never builds an unbounded backlog; older ones are
#: superseded by newer ones anyway)
INPUTS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                    reliability=ReliabilityPolicy.RELIABLE)
#: per-tick outputs
OUTPUT = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                    reliability=ReliabilityPolicy.RELIABLE)
#: the size of the window of tick times quoted on /diagnostics
TICK_WINDOW = 2000


class ArrayNode(Node):
    """A whisker array: each tick steps every whisker to the head pose and protraction."""

    def __init__(self, node_name: str = "array_node", **kwargs):
        super().__init__(node_name, **kwargs)
        self._params = NodeParameters(self, ARRAY_PARAMETERS, build_array_config)
        cfg = self.config
        self._pipeline = ArrayPipeline(cfg)
        self._scene = cfg.scene
        self._names = cfg.array.names
        self._head_frame = cfg.values["head_frame"]
        self._frames = [f"{self._head_frame}/{n}" for n in self._names]
        self._world = cfg.values["world_frame"]
        self._recorder: Optional[Recorder] = None
        self._record_error = ""
        self._log_ns = 0
        self._last_log: Dict[str, float] = {}
        # counters
        self._ticks = 0
        self._skipped = 0
        self._received: Counter = Counter()
        self._dropped: Counter = Counter()
        self._last_drop = ""
        self._tick_ns: list = []
        self._slowest_ns = 0
        k = len(self._names)
        self._contact_ticks = np.zeros(k, dtype=np.int64)
        self._touches = np.zeros(k, dtype=np.int64)
        self._errors = np.zeros(k, dtype=np.int64)
        self._last_error = [""] * k
        self._last_rows = None
        self._last_step = None
        # publishers
        self._pub = {
            "wrenches": output_publisher(self, PointCloud2, "~/wrenches", OUTPUT),
            "events": output_publisher(self, String, "~/events", OUTPUT),
            "whiskers": output_publisher(self, String, "~/whiskers", LATCHED),
            "obstacles": output_publisher(self, MarkerArray, "~/obstacles", LATCHED),
            "shapes": output_publisher(self, MarkerArray, "~/shapes", 10),
            "contacts": output_publisher(self, PointCloud2, "~/contacts", 10),
            "diagnostics": output_publisher(self, DiagnosticArray, "/diagnostics", 10),
        }
        self._sub = {"head_pose": self.create_subscription(PoseStamped, "~/head_pose",
                                                           self._on_head, INPUTS)}
        if cfg.builtin:
            self._pub["protraction"] = output_publisher(self, JointState, "~/protraction", OUTPUT)
            self._period_ns = int(round(1e9 / cfg.values["rate"]))
            self._start_ns = time.monotonic_ns()
            self._k = 0
            self.create_timer(1.0 / cfg.values["rate"], self._on_timer)
        else:
            self._sub["whisk"] = self.create_subscription(JointState, "~/whisk", self._on_whisk,
                                                          INPUTS)
        #: the keys of the per-whisker ~/<name>/wrench publishers in _pub (none: off)
        self._wrench_keys = []
        self._wrench_period = 0.0
        self._last_wrench = -math.inf
        if cfg.values["wrench.rate"] > 0.0:
            self._wrench_period = 1.0 / cfg.values["wrench.rate"]
            self._wrench_keys = [f"wrench/{n}" for n in self._names]
            for key, n in zip(self._wrench_keys, self._names):
                self._pub[key] = output_publisher(self, WrenchStamped, f"~/{n}/wrench", 10)
        rate = cfg.values["display.rate"]
        self._display_period = 1.0 / rate if rate > 0.0 else math.inf
        self._last_display = -math.inf
        self.create_timer(cfg.values["diagnostics.period"], self._publish_diagnostics)
        self.create_service(Trigger, "~/reset", self._on_reset)
        self._start_recording(cfg.values["record.path"])
        self._publish_latched()
        # the compiled kernels: loaded from numba's cache (~0.3 s) or, the first time on a
        # machine, compiled (~20 s), before the first contact needs them (a tick waits for it)
        threading.Thread(target=warm_up, name="rod3d_warm_up", daemon=True).start()
        self.get_logger().info(f"ready: {cfg.describe()}")

    @property
    def config(self) -> ArrayConfig:
        return self._params.config

    # -- recording (thin: the recorder's public interface only) -----------------------------------
    def _start_recording(self, path: str) -> None:
        if not path:
            return
        # and, recorded only: the frames (tf2_msgs has no wheel here, so no /tf is published)
        # and every whisker's WrenchStamped, where they are published
        endpoints = {**self._pub, **self._sub, "tf": TF_SPEC}
        try:
            self._recorder = Recorder(path, endpoints, self.config.record_values,
                                      self.get_fully_qualified_name(), self._recording_failed)
        except LogError as exc:
            self._recording_failed(str(exc))
            return
        self.get_logger().info(f"recording to {path}")

    def _recording_failed(self, reason: str) -> None:
        self._record_error = reason
        if self.context.ok():
            self.get_logger().error(f"recording stopped: {reason}; the array keeps running "
                                    "without recording")

    def _record(self, key: str, msg) -> None:
        recorder = self._recorder
        if recorder is not None and recorder.error is None:
            recorder.write(key, msg, self._next_log_ns())

    def _next_log_ns(self) -> int:
        """Return the next log time: the clock's, strictly increasing (resim reads in order)."""
        self._log_ns = max(self.get_clock().now().nanoseconds, self._log_ns + 1)
        return self._log_ns

    def _send(self, key: str, msg) -> None:
        """Record, then publish: all the node published is in its log, even after a signal."""
        self._record(key, msg)
        self._publish(key, msg)

    def _send_serialized(self, key: str, data: bytes) -> None:
        """:meth:`_send` of a message already serialized (the same bytes recorded and sent)."""
        recorder = self._recorder
        if recorder is not None and recorder.error is None:
            recorder.write_serialized(key, data, self._next_log_ns())
        self._publish(key, data)

    def _publish(self, key: str, msg) -> None:
        try:
            self._pub[key].publish(msg)
        except RCLError:
            if self.context.ok():
                raise

    def destroy_node(self):
        recorder, self._recorder = self._recorder, None
        try:
            if recorder is not None:  # the log first: it is what a second Ctrl-C would cost
                recorder.close()
                if recorder.error is None and self.context.ok():
                    self.get_logger().info(f"recording finished: {recorder.path} "
                                           f"({recorder.written} messages)")
        finally:
            self._pipeline.close()  # the worker processes, if any
        return super().destroy_node()

    # -- input ------------------------------------------------------------------------------------
    def _drop(self, what: str, exc: Exception) -> None:
        reason = drop_reason(exc)
        self._dropped[reason] += 1
        self._last_drop = f"{what} dropped ({reason}): {exc}"
        now = time.monotonic()
        if now - self._last_log.get(reason, -math.inf) >= LOG_THROTTLE_S:
            self._last_log[reason] = now
            self.get_logger().warning(f"{self._last_drop}; state kept "
                                      f"({self._dropped[reason]} so far)")

    def _on_head(self, msg: PoseStamped) -> None:
        self._received["head_pose"] += 1
        self._record("head_pose", msg)
        p, q = msg.pose.position, msg.pose.orientation
        try:
            self._pipeline.set_head(msg.header.frame_id, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
        except BadInput as exc:
            self._drop("head pose", exc)
            return
        if not self.config.builtin:
            self._tick(msg.header.stamp)

    def _on_whisk(self, msg: JointState) -> None:
        self._received["whisk"] += 1
        self._record("whisk", msg)
        try:
            self._pipeline.set_joints(msg.name, msg.position)
        except BadInput as exc:
            self._drop("joint state", exc)
            return
        self._tick(msg.header.stamp)

    def _on_timer(self) -> None:
        """Tick the built-in whisk at k / rate (ticks missed by an overrun are skipped)."""
        k = self._k + 1
        if self.config.values["whisk.realtime"]:
            k = (time.monotonic_ns() - self._start_ns) // self._period_ns
        if k <= self._k:
            k = self._k + 1
        self._skipped += k - self._k - 1
        self._k = k
        stamp = self.get_clock().now().to_msg()
        angle = self.config.whisk.angle(k * self._period_ns / 1e9)
        msg = am.protraction_msg(stamp, angle)
        self._send("protraction", msg)
        self._pipeline.set_joints(msg.name, msg.position)
        self._tick(stamp)

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response):
        """``~/reset``: every whisker re-placed unloaded before the next tick."""
        recorder = self._recorder
        if recorder is not None and recorder.error is None:
            # applied before the tick whose ~/wrenches is the next one recorded
            recorder.reset(self._next_log_ns(), pose_key="wrenches")
        self._pipeline.request_reset()
        response.success = True
        if getattr(self._pipeline.tracker, "failed", None) is not None:
            response.message = (
                "the array's worker processes start again before the next tick, every whisker "
                "unloaded at that tick's pose (where one would cut an obstacle there, that "
                "tick fails saying so: ask again once the whisk has taken it off)")
        else:
            response.message = (
                "before the next tick every whisker is re-placed unloaded at its pose of the "
                "last tick, forgetting its history (a whisker that would cut an obstacle "
                "there, one pressed on it, keeps its state and reports an error)")
        self.get_logger().info(f"~/reset: {response.message}")
        return response

    # -- the tick ---------------------------------------------------------------------------------
    def _tick(self, stamp) -> None:
        t0 = time.perf_counter_ns()
        try:
            step = self._pipeline.tick()
        except Exception as exc:  # noqa: BLE001 - nothing from the core may kill the node
            if interrupted(exc):  # Ctrl-C inside a compiled kernel: stop, as on any other
                raise KeyboardInterrupt from exc
            self._drop("tick", exc)
            return
        rows = output_rows(step, self._scene)
        if not finite(rows):  # never happens; never publish it if it does
            self._drop("tick", BadInput("nonfinite_output", "a whisker's result is not finite"))
            return
        spent = time.perf_counter_ns() - t0
        self._ticks += 1
        self._tick_ns.append(spent)
        if len(self._tick_ns) > TICK_WINDOW:
            del self._tick_ns[:-TICK_WINDOW]
        self._slowest_ns = max(self._slowest_ns, spent)
        self._contact_ticks += step.contacts > 0
        for error in step.errors:
            i = step.index(error.whisker)
            self._errors[i] += 1
            self._last_error[i] = error.message
        self._last_rows, self._last_step = rows, step
        self._send_serialized("wrenches", am.wrenches_cdr(stamp, self._world, rows))
        for event in step.events:
            if event.kind == "touch":
                self._touches[step.index(event.whisker)] += 1
            self._send("events", String(data=json.dumps(
                {"whisker": event.whisker, "kind": event.kind, "obstacle": event.obstacle,
                 "s": event.s, "contacts_before": event.contacts_before,
                 "contacts_after": event.contacts_after, "reason": event.reason})))
        now = time.monotonic()
        if now - self._last_display >= self._display_period:
            self._last_display = now
            self._display(stamp, step, rows)
        if self._wrench_keys and now - self._last_wrench >= self._wrench_period:
            self._last_wrench = now
            for i, key in enumerate(self._wrench_keys):
                # serialized from a template, as ~/wrenches (~3 us a whisker, ~30 as an object)
                row = rows[i]
                self._send_serialized(key, wrench_cdr(
                    stamp, self._frames[i], (row["fx"], row["fy"], row["fz"]),
                    (row["mx"], row["my"], row["mz"])))

    def _display(self, stamp, step, rows) -> None:
        recording = self._recorder is not None
        if recording and self._recorder.error is None:
            # the head's and every whisker's base frame in the world, for the log's readers
            # (Foxglove's 3D panel places ~/<name>/wrench and the frames by them)
            head = step.head
            self._recorder.write_serialized("tf", tf_message_cdr(
                stamp.sec, stamp.nanosec, self._world,
                [self._head_frame] + self._frames,
                np.vstack(([head.position], step.base_position)),
                np.vstack(([head.quaternion], step.base_quaternion))), self._next_log_ns())
        if recording or self._pub["shapes"].get_subscription_count():
            try:
                lines = self._pipeline.tracker.centerlines(
                    int(self.config.values["display.points"]))
            except VibrissaError:
                # (a worker process of the array ended since the tick's step: no shapes this
                # time, and the next tick is dropped saying so)
                lines = None
            if lines is not None:
                self._send_serialized("shapes", am.shapes_cdr(stamp, self._world, self._names,
                                                              lines, step.contacts))
        if recording or self._pub["contacts"].get_subscription_count():
            self._send("contacts", am.contacts_cloud(stamp, self._world, step, rows))

    # -- latched and periodic outputs -------------------------------------------------------------
    def _publish_latched(self) -> None:
        cfg = self.config
        self._send("whiskers", am.whiskers_msg(cfg.array, cfg.values["head_frame"]))
        stamp = self.get_clock().now().to_msg()
        if cfg.scene is None:  # whisking in the air: nothing to draw
            self._send("obstacles", MarkerArray())
        else:
            self._send("obstacles", m.scene3d_markers(cfg.scene, 1.0, self._world, stamp,
                                                      size=0.1))

    def _publish_diagnostics(self) -> None:
        name = self.get_fully_qualified_name()
        times = np.array(self._tick_ns, dtype=float) / 1e6
        recorder = self._recorder
        values = {
            "ticks": self._ticks,
            "ticks_skipped": self._skipped,
            "tick_ms_median": f"{np.median(times):.3f}" if len(times) else "",
            "tick_ms_p99": f"{np.percentile(times, 99):.3f}" if len(times) else "",
            "tick_ms_max": f"{self._slowest_ns / 1e6:.3f}",
            "whiskers": len(self._names),
            "whiskers_in_contact": 0 if self._last_step is None else self._last_step.in_contact,
            **{f"received_{k}": v for k, v in sorted(self._received.items())},
            "dropped": sum(self._dropped.values()),
            **{f"dropped_{k}": v for k, v in sorted(self._dropped.items())},
            "last_drop": self._last_drop,
            "configuration": self.config.describe(),
            "recording": recorder.path if recorder is not None else "",
            "recorded_messages": recorder.written if recorder is not None else 0,
            "recording_error": self._record_error,
        }
        problems = []
        if self._skipped:
            problems.append(f"{self._skipped} timer tick(s) skipped: a tick took longer than "
                            "1/rate")
        if self._dropped:
            problems.append(f"{sum(self._dropped.values())} input(s) dropped; last: "
                            f"{self._last_drop}")
        statuses = [am.node_status(name, values, problems)]
        contacts = (np.zeros(len(self._names), int) if self._last_step is None
                    else self._last_step.contacts)
        for i, whisker in enumerate(self._names):
            statuses.append(am.whisker_status(name, whisker, {
                "contacts": int(contacts[i]), "contact_ticks": int(self._contact_ticks[i]),
                "touches": int(self._touches[i]), "errors": int(self._errors[i]),
                "frame": self._frames[i]}, self._last_error[i]))
        self._send("diagnostics", m.diagnostic_array(self.get_clock().now().to_msg(), statuses))


def _executor(node: ArrayNode):
    """Return the executor the ``executor`` parameter names."""
    if node.config.values["executor"] == "events":
        from rclpy.experimental import EventsExecutor

        return EventsExecutor()
    return None


def main(args=None) -> int:
    """Entry point of ``ros2 run vibrissa_ros array_node``."""
    return run_node(ArrayNode, "array_node", args, make_executor=_executor)


if __name__ == "__main__":  # pragma: no cover
    import sys

    sys.exit(main())
