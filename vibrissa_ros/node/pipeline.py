"""
What the whisker node does with one foot pose, without ROS: check it, step the whisker, count.

Shared by ``whisker_node`` and the log tools (``vibrissa resim``/``export``), so that a log
re-simulated offline goes through exactly the node's path, rejections included.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ..core.errors import ConvergenceError, InvalidPoseError, VibrissaError
from ..core.rod3d import BasePose, RodEvent, RodTracker
from ..core.scenes.tracker import SceneEvent, SceneTracker
from ..core.state import Event, FootPose, Phase, WhiskerState
from ..core.exact.tracker import MAX_POSE_MAGNITUDE, QuasistaticTracker
from .edge import (BadInput, SensorReading, planar_pose, rod_phase, rod_reading, sensor_reading,
                   spatial_pose)
from .config import WhiskerConfig
from .noise import NoiseSpec, SensorNoise

#: every reason a foot pose can be dropped for, as counted on /diagnostics (``dropped_<reason>``)
DROP_REASONS = (
    "not_finite",
    "quaternion_not_unit",
    "out_of_plane",
    "out_of_range",
    "wrong_frame_id",
    "stamp_backwards",
    "inside_obstacle",
    "model_assumption",
    "not_converged",
    "internal_error",
)


def drop_reason(exc: BaseException) -> str:
    """
    Return the /diagnostics key of a rejected pose.

    ``internal_error`` is an exception the core should never raise (not a VibrissaError): the
    node survives it, drops the pose and counts it here.
    """
    if isinstance(exc, BadInput):
        return exc.reason
    if isinstance(exc, InvalidPoseError):
        return "inside_obstacle"
    if isinstance(exc, ConvergenceError):
        return "not_converged"
    if isinstance(exc, VibrissaError):
        return "model_assumption"
    return "internal_error"


#: the reason a ``reset`` event carries when the whisker was reset on request (``~/reset``)
RESET_ON_REQUEST = "reset on request"


class PosePipeline:
    """
    Validates foot poses and steps the whisker; the first accepted pose places it.

    A step that cannot be followed re-places the whisker when it is free at the new pose (the
    core's recovery: an event ``reset``); :meth:`request_reset` makes the next accepted pose
    place it, with an event ``reset`` too. With ``model`` rod3d the 3D whisker
    (:class:`~vibrissa_ros.core.rod3d.RodTracker`) takes any 6-DoF pose.

    Parameters
    ----------
    config : WhiskerConfig
        The node's validated configuration (:func:`~vibrissa_ros.node.config.build_config`): the
        obstacle, model and units, and the sensor noise added to the published wrench.

    """

    def __init__(self, config: WhiskerConfig):
        self.config = config
        self.tracker: Optional[QuasistaticTracker] = None
        self.last_stamp_ns: Optional[int] = None
        self.noise = SensorNoise(NoiseSpec.from_parameters(config.values))
        #: the phase the whisker had when a reset was requested (None: no reset pending)
        self._reset_from: Optional[Phase] = None

    def request_reset(self) -> None:
        """
        Forget the whisker (``~/reset``): the next accepted pose places it unloaded.

        That pose's answer carries an event ``reset``. A pose where the unloaded whisker would
        cut an obstacle is dropped (``inside_obstacle``) and the reset stays pending.
        """
        if self._reset_from is None:
            state = self.state
            if state is None:
                self._reset_from = Phase.FREE
            elif self.config.rod3d:
                self._reset_from = Phase(rod_phase(state))
            else:
                self._reset_from = Phase(int(state.phase))
        self.tracker = None

    def reconfigure(self, config: WhiskerConfig, reset: bool) -> None:
        """
        Take a new configuration.

        ``reset``: the whisker is free again and the next pose places it. The sensor-noise
        generator restarts from its seed.
        """
        self.config = config
        if reset:
            self.tracker = None
        self.noise = SensorNoise(NoiseSpec.from_parameters(config.values))

    def reading(self, state: WhiskerState) -> Tuple[SensorReading, Tuple[float, ...]]:
        """
        Return the exact reading of a state (SI, base frame) and the wrench the sensor reports.

        The reported wrench has the noise model applied, if enabled: call once per accepted
        pose, in order. Planar: (force x, force y, torque z); the 3D whisker (a
        :class:`~vibrissa_ros.node.edge.RodReading`, no noise model): all six components,
        (force x, y, z, torque x, y, z).
        """
        if self.config.rod3d:
            r = rod_reading(state, self.config.units, self.config.roll)
            return r, r.wrench
        r = sensor_reading(state, self.config.units)
        return r, self.noise.apply(r.force_base[0], r.force_base[1], r.torque_z)

    @property
    def state(self) -> Optional[WhiskerState]:
        return None if self.tracker is None else self.tracker.state

    def handle(
        self,
        frame_id: str,
        stamp_ns: int,
        position: Sequence[float],
        quaternion: Sequence[float],
    ) -> Tuple[WhiskerState, Tuple[Event, ...]]:
        """
        Check a pose and take the quasistatic step to it.

        A scene with several obstacles or friction steps the
        :class:`~vibrissa_ros.core.scenes.tracker.SceneTracker` (its states and events instead);
        the 3D whisker (``model`` rod3d) takes any 6-DoF pose (no planarity check) and steps the
        :class:`~vibrissa_ros.core.rod3d.RodTracker`.

        Raises :class:`BadInput` (with a ``reason``) or another :class:`VibrissaError`; the
        pipeline then keeps its state.
        """
        cfg = self.config
        if frame_id != cfg.world_frame:
            raise BadInput("wrong_frame_id",
                           f"frame_id '{frame_id}' is not the world frame '{cfg.world_frame}'")
        if self.last_stamp_ns is not None and stamp_ns < self.last_stamp_ns:
            raise BadInput("stamp_backwards", f"stamp {stamp_ns} ns is older than the last "
                           f"accepted {self.last_stamp_ns} ns")
        if cfg.rod3d:
            pose = self._base_pose(position, quaternion)
        else:
            pose = self._foot_pose(position, quaternion)
        if self.tracker is None:
            tracker = self._place(pose)
            state, events = tracker.state, self._reset_events(pose)
            self._reset_from = None
        else:
            tracker = self.tracker
            result = tracker.step(pose)
            state, events = result.state, result.events
        self.tracker = tracker
        self.last_stamp_ns = stamp_ns
        return state, events

    def _base_pose(self, position, quaternion) -> BasePose:
        """Return the 3D whisker's base pose of a checked 6-DoF pose (any orientation)."""
        cfg = self.config
        (x, y, z), q = spatial_pose(position, quaternion)
        pose = cfg.units.base_pose((x, y, z), q, cfg.roll)
        if max(abs(v) for v in pose.position) > MAX_POSE_MAGNITUDE:
            limit = MAX_POSE_MAGNITUDE * cfg.units.length
            raise BadInput("out_of_range", f"pose ({x!r}, {y!r}, {z!r}) m is farther than the "
                           f"model allows from the world origin (|x|, |y|, |z| <= {limit:g} m)")
        return pose

    def _foot_pose(self, position, quaternion) -> FootPose:
        """Return the planar foot pose of a pose that must lie in the plane."""
        cfg = self.config
        x, y, yaw = planar_pose(position, quaternion, cfg.values["input.z_tolerance"],
                                cfg.values["input.angle_tolerance"])
        pose = cfg.units.foot_pose(x, y, yaw)
        if max(abs(pose.x), abs(pose.y)) > MAX_POSE_MAGNITUDE:
            limit = MAX_POSE_MAGNITUDE * cfg.units.length
            raise BadInput("out_of_range", f"pose ({x!r}, {y!r}) m is farther than the model "
                           f"allows from the world origin (|x|, |y| <= {limit:g} m)")
        return pose

    def _reset_events(self, pose: FootPose) -> tuple:
        """Return the event of a requested reset at the pose that places the whisker, if any."""
        if self._reset_from is None:
            return ()
        if self.config.rod3d:
            return (RodEvent("reset", pose, reason=RESET_ON_REQUEST),)
        if self.config.multi_contact:
            return (SceneEvent("reset", pose, reason=RESET_ON_REQUEST),)
        return (Event("reset", self._reset_from, Phase.FREE, pose, None, RESET_ON_REQUEST),)

    def _place(self, pose):
        """Return a new tracker with the whisker unloaded at ``pose`` (it must be free there)."""
        cfg = self.config
        if cfg.rod3d:
            return RodTracker(cfg.scene3d, pose, shape=cfg.rod_shape, recover=True,
                              points_tolerance=cfg.values["solver.points_tolerance"])
        if cfg.multi_contact:
            return SceneTracker(list(cfg.scene), pose, shape=cfg.shape, friction=cfg.friction)
        return QuasistaticTracker(cfg.profile, pose, model=cfg.fresh_model())


class PoseStats:
    """
    What the node counts between and across /diagnostics periods (no ROS).

    ``backlog``: poses found already waiting behind the one being processed, largest per period
    (0 when the node keeps up); a step slower than ``slow_step_s`` is counted in ``slow_steps``.
    """

    def __init__(self, slow_step_s: float = 0.1):
        self.received = 0
        self.processed = 0
        self.snaps = 0
        self.resets = 0
        self.dropped: Counter = Counter()
        self.last_error = ""
        self.slow_steps = 0
        self.slowest_step_s = 0.0
        self.slow_step_s = slow_step_s
        self.backlog_max = 0
        self._period_backlog = 0
        self._solve_times_ns: List[int] = []

    def accepted(self, solve_ns: int, events: Sequence[Event]) -> None:
        self.processed += 1
        self._solve_times_ns.append(solve_ns)
        self.snaps += sum(1 for e in events if e.kind == "snap")
        self.resets += sum(1 for e in events if e.kind == "reset")
        seconds = solve_ns / 1e9
        self.slowest_step_s = max(self.slowest_step_s, seconds)
        if seconds > self.slow_step_s:
            self.slow_steps += 1

    def drop(self, reason: str, message: str) -> int:
        """Count a dropped pose; returns how many were dropped for that reason so far."""
        self.dropped[reason] += 1
        self.last_error = f"{reason}: {message}"
        return self.dropped[reason]

    def waiting(self, n: int) -> None:
        """``n`` poses were already queued behind the one just taken."""
        self._period_backlog = max(self._period_backlog, n)
        self.backlog_max = max(self.backlog_max, n)

    def values(self) -> dict:
        """Return the /diagnostics values of the counters (and of the period now ending)."""
        return {
            "poses_received": self.received,
            "poses_processed": self.processed,
            "poses_dropped": sum(self.dropped.values()),
            "snaps": self.snaps,
            "resets": self.resets,
            **self.period(),
            "backlog_max": self.backlog_max,
            "slow_steps": self.slow_steps,
            "slowest_step_ms": f"{self.slowest_step_s * 1e3:.1f}",
            **{f"dropped_{reason}": self.dropped[reason] for reason in DROP_REASONS},
        }

    def period(self) -> dict:
        """Solve-time figures [us] and the backlog of the period now ending; starts a new one."""
        times = np.array(self._solve_times_ns, dtype=float) / 1e3
        backlog, self._period_backlog = self._period_backlog, 0
        self._solve_times_ns = []
        fmt = (lambda v: f"{v:.1f}") if len(times) else (lambda v: "")
        return {
            "solves_in_period": len(times),
            "solve_time_median_us": fmt(np.median(times) if len(times) else math.nan),
            "solve_time_p99_us": fmt(np.percentile(times, 99) if len(times) else math.nan),
            "solve_time_max_us": fmt(times.max() if len(times) else math.nan),
            "backlog_in_period": backlog,
        }
