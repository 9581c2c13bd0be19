"""
An optional, seeded model of the follicle sensor's imperfections, added to the published wrench.

Per reading: Gaussian noise (independent on force x, force y and torque z), then a constant bias,
then quantization to the sensor's resolution. Seeded (numpy PCG64), so a log re-simulated with the
recorded configuration reproduces the very same noisy readings.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Tuple

import numpy as np


@dataclass(frozen=True)
class NoiseSpec:
    """
    Sensor-noise parameters in SI (N, N m); all zero and ``enabled`` False: an ideal sensor.

    The parameters are the dataclass's fields, kept as attributes of the same names (the node's
    ``noise.*`` parameters, :meth:`from_parameters`).

    Parameters
    ----------
    enabled : bool, optional
        Apply the noise; False: the readings pass unchanged.
    seed : int, optional
        The seed of the PCG64 generator.
    force_stddev, torque_stddev : float, optional
        Standard deviation of the Gaussian noise on each force component [N] and on the torque
        [N m].
    force_bias_x, force_bias_y, torque_bias : float, optional
        Constant bias added to force x, force y [N] and the torque [N m].
    force_step, torque_step : float, optional
        Quantization step (the sensor's resolution) of the force [N] and the torque [N m]; 0: none.

    """

    enabled: bool = False
    seed: int = 0
    force_stddev: float = 0.0
    torque_stddev: float = 0.0
    force_bias_x: float = 0.0
    force_bias_y: float = 0.0
    torque_bias: float = 0.0
    force_step: float = 0.0
    torque_step: float = 0.0

    @classmethod
    def from_parameters(cls, values: Mapping[str, object]) -> "NoiseSpec":
        return cls(
            enabled=bool(values["noise.enabled"]),
            seed=int(values["noise.seed"]),
            force_stddev=float(values["noise.force_stddev"]),
            torque_stddev=float(values["noise.torque_stddev"]),
            force_bias_x=float(values["noise.force_bias_x"]),
            force_bias_y=float(values["noise.force_bias_y"]),
            torque_bias=float(values["noise.torque_bias"]),
            force_step=float(values["noise.force_step"]),
            torque_step=float(values["noise.torque_step"]),
        )


class SensorNoise:
    """
    Applies a :class:`NoiseSpec` to successive readings, in order.

    Parameters
    ----------
    spec : NoiseSpec
        The noise applied; its seed starts the generator, so the same readings in the same order
        get the same noise.

    """

    def __init__(self, spec: NoiseSpec):
        self.spec = spec
        self._rng = np.random.Generator(np.random.PCG64(spec.seed))

    def apply(self, fx: float, fy: float, tz: float) -> Tuple[float, float, float]:
        spec = self.spec
        if not spec.enabled:
            return fx, fy, tz
        nx, ny, nz = self._rng.standard_normal(3)
        fx = fx + spec.force_stddev * nx + spec.force_bias_x
        fy = fy + spec.force_stddev * ny + spec.force_bias_y
        tz = tz + spec.torque_stddev * nz + spec.torque_bias
        if spec.force_step > 0.0:
            fx = spec.force_step * round(fx / spec.force_step)
            fy = spec.force_step * round(fy / spec.force_step)
        if spec.torque_step > 0.0:
            tz = spec.torque_step * round(tz / spec.torque_step)
        return float(fx), float(fy), float(tz)
