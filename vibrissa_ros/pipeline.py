"""What the whisker node does with one foot pose, without ROS: check it, step the whisker.

Shared by ``whisker_node`` and the log tools (``vibrissa resim``/``export``), so that a log
re-simulated offline goes through exactly the node's path, rejections included.
"""

from __future__ import annotations

from typing import Optional, Sequence, Tuple

from .core.errors import InvalidPoseError, VibrissaError
from .core.state import Event, WhiskerState
from .core.tracker import QuasistaticTracker
from .frames import BadInput, SensorReading, planar_pose, sensor_reading
from .node_config import WhiskerConfig
from .noise import NoiseSpec, SensorNoise


def drop_reason(exc: Exception) -> str:
    """The /diagnostics key of a rejected pose."""
    if isinstance(exc, BadInput):
        return exc.reason
    if isinstance(exc, InvalidPoseError):
        return "inside_obstacle"
    if type(exc).__name__ == "ConvergenceError":
        return "not_converged"
    return "model_assumption"


class PosePipeline:
    """Validates foot poses and steps the whisker; the first accepted pose places it."""

    def __init__(self, config: WhiskerConfig):
        self.config = config
        self.tracker: Optional[QuasistaticTracker] = None
        self.last_stamp_ns: Optional[int] = None
        self.noise = SensorNoise(NoiseSpec.from_parameters(config.values))

    def reconfigure(self, config: WhiskerConfig, reset: bool) -> None:
        """A new configuration; ``reset``: the whisker is free again and the next pose places it.
        The sensor-noise generator restarts from its seed."""
        self.config = config
        if reset:
            self.tracker = None
        self.noise = SensorNoise(NoiseSpec.from_parameters(config.values))

    def reset(self, config: WhiskerConfig) -> None:
        self.reconfigure(config, True)

    def reading(self, state: WhiskerState) -> Tuple[SensorReading, Tuple[float, float, float]]:
        """The exact reading of a state (SI, base frame) and the wrench the sensor reports (with the
        noise model, if enabled): call once per accepted pose, in order."""
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
        """Check a pose and take the quasistatic step to it.

        Raises :class:`BadInput` (with a ``reason``) or another :class:`VibrissaError`; the pipeline
        then keeps its state.
        """
        cfg = self.config
        if frame_id != cfg.world_frame:
            raise BadInput("wrong_frame_id", f"frame_id '{frame_id}' is not the world frame '{cfg.world_frame}'")
        if self.last_stamp_ns is not None and stamp_ns < self.last_stamp_ns:
            raise BadInput(
                "stamp_backwards", f"stamp {stamp_ns} ns is older than the last accepted {self.last_stamp_ns} ns"
            )
        x, y, yaw = planar_pose(position, quaternion, cfg.values["input.z_tolerance"], cfg.values["input.angle_tolerance"])
        pose = cfg.units.foot_pose(x, y, yaw)
        if self.tracker is None:
            tracker = QuasistaticTracker(cfg.profile, pose, model=cfg.model)
            state, events = tracker.state, ()
        else:
            tracker = self.tracker
            result = tracker.step(pose)
            state, events = result.state, result.events
        self.tracker = tracker
        self.last_stamp_ns = stamp_ns
        return state, events


__all__ = ["PosePipeline", "drop_reason", "BadInput", "VibrissaError"]
