"""The scan grid (core/scan.py): endpoints, spacing without accumulated rounding, the way back."""

import math

import numpy as np
import pytest

from vibrissa_ros.core import ParameterError, scan_grid


@pytest.mark.parametrize(
    "x_from, x_to, step, back, expected",
    [
        (0.0, 1.0, 0.25, False, [0.0, 0.25, 0.5, 0.75, 1.0]),
        (1.0, 0.0, 0.25, False, [1.0, 0.75, 0.5, 0.25, 0.0]),
        (2.0, 1.75, 0.1, False, [2.0, 1.9, 1.8, 1.75]),  # --to ends the grid off the step
        (0.0, 0.5, 0.25, True, [0.0, 0.25, 0.5, 0.25, 0.0]),
        (0.3, 0.3, 0.1, False, [0.3]),
        (0.3, 0.3, 0.1, True, [0.3]),
    ],
)
def test_grid_points(x_from, x_to, step, back, expected):
    assert scan_grid(x_from, x_to, step, back) == pytest.approx(expected, abs=1e-15)


def test_points_are_computed_not_accumulated():
    grid = scan_grid(2.0, -2.0, 0.001)
    assert len(grid) == 4001 and grid[0] == 2.0 and grid[-1] == -2.0
    assert np.array_equal(grid[:-1], 2.0 - 0.001 * np.arange(4000))


def test_a_span_a_hair_short_of_a_multiple_still_ends_on_to():
    grid = scan_grid(0.0, 0.3, 0.1)  # 0.3 / 0.1 = 2.9999999999999996
    assert grid == pytest.approx([0.0, 0.1, 0.2, 0.3], abs=1e-15) and grid[-1] == 0.3


@pytest.mark.parametrize(
    "args, words",
    [
        ((0.0, 1.0, 0.0), ["--step", "> 0"]),
        ((0.0, 1.0, -0.1), ["--step", "> 0"]),
        ((math.nan, 1.0, 0.1), ["--from", "finite"]),
        ((0.0, math.inf, 0.1), ["--to", "finite"]),
        ((0.0, 1.0, 1e-9), ["50,000,000"]),
    ],
)
def test_bad_grids_say_what_is_allowed(args, words):
    with pytest.raises(ParameterError) as info:
        scan_grid(*args)
    for word in words:
        assert word in str(info.value)
