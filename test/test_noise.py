"""The seeded sensor-noise model: off is exact, the same seed the same readings, the statistics."""

import numpy as np
import pytest

from vibrissa_ros.node.config import build_config
from vibrissa_ros.node.noise import NoiseSpec, SensorNoise


def test_disabled_noise_returns_the_exact_reading():
    noise = SensorNoise(NoiseSpec(enabled=False, force_stddev=1.0, force_bias_x=5.0))
    assert noise.apply(0.1, -0.2, 3e-3) == (0.1, -0.2, 3e-3)


def test_from_parameters_reads_every_noise_parameter():
    values = dict(build_config({}).values, **{
        "noise.enabled": True, "noise.seed": 7, "noise.force_stddev": 0.1,
        "noise.torque_stddev": 0.2, "noise.force_bias_x": 0.3, "noise.force_bias_y": 0.4,
        "noise.torque_bias": 0.5, "noise.force_step": 0.6, "noise.torque_step": 0.7})
    assert NoiseSpec.from_parameters(values) == NoiseSpec(True, 7, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6,
                                                          0.7)


def test_the_same_seed_gives_the_same_readings_and_another_seed_others():
    spec = NoiseSpec(enabled=True, seed=42, force_stddev=0.01, torque_stddev=1e-4)
    a = [SensorNoise(spec).apply(0.0, 0.0, 0.0) for _ in range(2)]
    assert a[0] == a[1]
    one, two = SensorNoise(spec), SensorNoise(spec)
    assert [one.apply(1.0, 2.0, 3.0) for _ in range(50)] == [two.apply(1.0, 2.0, 3.0)
                                                             for _ in range(50)]
    other = SensorNoise(NoiseSpec(enabled=True, seed=43, force_stddev=0.01))
    assert other.apply(0.0, 0.0, 0.0) != SensorNoise(spec).apply(0.0, 0.0, 0.0)


def test_gaussian_noise_and_bias_have_the_configured_statistics():
    noise = SensorNoise(NoiseSpec(enabled=True, seed=1, force_stddev=0.02, torque_stddev=3e-4,
                                  force_bias_x=0.5, force_bias_y=-0.25, torque_bias=1e-3))
    readings = np.array([noise.apply(1.0, 2.0, 3.0) for _ in range(20000)])
    assert readings.mean(axis=0) == pytest.approx([1.5, 1.75, 3.001],
                                                  abs=5 * 0.02 / np.sqrt(20000))
    assert readings.std(axis=0) == pytest.approx([0.02, 0.02, 3e-4], rel=0.03)
    assert abs(np.corrcoef(readings[:, 0], readings[:, 1])[0, 1]) < 0.03  # independent axes


def test_quantization_rounds_to_the_step():
    noise = SensorNoise(NoiseSpec(enabled=True, force_step=0.25, torque_step=0.1))
    assert noise.apply(0.3, -0.13, 0.26) == pytest.approx((0.25, -0.25, 0.3))
    fx, fy, tz = noise.apply(1.13, 0.9, -0.04)
    assert (fx, fy) == (1.25, 1.0) and tz == pytest.approx(-0.0)
