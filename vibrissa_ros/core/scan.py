"""Quasistatic scans: the paper's foot line (the x0 grid), whisking (a heading grid), the runs."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Tuple

import numpy as np

from .errors import ParameterError
from .profiles import ConvexProfile
from .state import Event, FootPose, WhiskerState
from .exact.tracker import QuasistaticTracker


@dataclass(frozen=True)
class ScanResult:
    """
    States in scan order (one per grid point) and the events crossed between them.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    states : tuple of WhiskerState
        The states in scan order, one per grid point.
    events : tuple of Event
        The events crossed between them, in order.
    event_steps : tuple of int, optional
        ``event_steps[k]`` is the index of the state whose step crossed ``events[k]``.

    """

    states: Tuple[WhiskerState, ...]
    events: Tuple[Event, ...]
    event_steps: Tuple[int, ...] = ()


def scan_grid(x_from: float, x_to: float, step: float, back: bool = False) -> np.ndarray:
    """
    Foot positions from ``x_from`` to ``x_to`` inclusive, spaced by ``step`` (> 0).

    Points are computed as x_from +- i*step (no accumulated rounding); ``x_to`` ends the grid even
    when the span is not a multiple of the step.

    Parameters
    ----------
    x_from, x_to : float
        The grid's first and last point (either may be the larger).
    step : float
        The spacing, > 0.
    back : bool, optional
        Append the way back to ``x_from``.

    Returns
    -------
    numpy.ndarray
        The grid, shape (n,).

    Raises
    ------
    ParameterError
        When a bound or the step is not finite, the step is not > 0, or the grid would have more
        than 50,000,000 points.

    """
    for name, value in (("from", x_from), ("to", x_to), ("step", step)):
        if not math.isfinite(value):
            raise ParameterError(f"--{name} = {value!r} must be a finite number")
    if not step > 0.0:
        raise ParameterError(f"--step = {step!r} must be > 0")
    span = abs(x_to - x_from)
    n = int(math.floor(span / step * (1.0 + 1e-12)))
    if n > 50_000_000:
        raise ParameterError(
            f"--step = {step!r} gives {n} grid points; at most 50,000,000 are allowed")
    sign = 1.0 if x_to >= x_from else -1.0
    grid = x_from + sign * step * np.arange(n + 1)
    if abs(grid[-1] - x_to) > 1e-12 * max(1.0, span):
        grid = np.append(grid, x_to)
    else:
        grid[-1] = x_to
    if back:
        grid = np.concatenate((grid, grid[-2::-1]))
    return grid


def whisk_poses(
    x: float, y: float, from_deg: float, to_deg: float, step_deg: float, back: bool = False
) -> Tuple[FootPose, ...]:
    """
    Foot poses of a whisk: the foot fixed at (``x``, ``y``) [L], the heading sweeping.

    The headings [deg, counter-clockwise from +x; 90 is the paper's set-up, the whisker along +y]
    are the grid of :func:`scan_grid` from ``from_deg`` to ``to_deg`` inclusive, spaced by
    ``step_deg`` (> 0), and back when ``back`` (a protraction and its retraction); each is turned
    into radians by :func:`math.radians`.

    Parameters
    ----------
    x, y : float
        The foot's fixed position [L].
    from_deg, to_deg : float
        The first and last heading [deg].
    step_deg : float
        The heading spacing [deg], > 0.
    back : bool, optional
        Append the way back (the retraction).

    Returns
    -------
    tuple of FootPose
        The poses in whisking order, headings in radians.

    Raises
    ------
    ParameterError
        When x or y is not finite, or the heading grid is invalid (see :func:`scan_grid`).

    """
    for name, value in (("x", x), ("y", y)):
        if not math.isfinite(value):
            raise ParameterError(f"the whisking foot's {name} = {value!r} must be a finite number")
    headings = scan_grid(from_deg, to_deg, step_deg, back)
    return tuple(FootPose(x, y, math.radians(float(h))) for h in headings)


def _follow(tracker, targets) -> ScanResult:
    """Step ``tracker`` through ``targets`` in order; its state at the start is the first row."""
    states = [tracker.state]
    events, steps = [], []
    for target in targets:
        result = tracker.step(target)
        states.append(result.state)
        events.extend(result.events)
        steps.extend([len(states) - 1] * len(result.events))
    return ScanResult(tuple(states), tuple(events), tuple(steps))


def run_scan(profile: ConvexProfile, grid, model="elastica") -> ScanResult:
    """
    Place the whisker at the first grid point (straight, free) and step through the grid.

    Parameters
    ----------
    profile : ConvexProfile
        The obstacle.
    grid : array_like of float
        The paper's foot positions x0 [L] (foot at (x0, 0), heading pi/2), in scan order.
    model : str or model instance, optional
        ``"elastica"`` (paper §2) or ``"rigid"`` (paper §3), or a model object.

    Returns
    -------
    ScanResult
        One state per grid point and the events crossed.

    """
    grid = np.asarray(grid, dtype=float)
    tracker = QuasistaticTracker(profile, float(grid[0]), model=model)
    return _follow(tracker, (float(x0) for x0 in grid[1:]))


def run_poses(profile: ConvexProfile, poses, model="elastica") -> ScanResult:
    """
    Place the whisker at the first foot pose (unloaded, free) and step through the poses in order.

    Each is a quasistatic step along the straight path in (x, y, heading) from the previous one.

    Parameters
    ----------
    profile : ConvexProfile
        The obstacle.
    poses : iterable of FootPose
        The foot poses, in order.
    model : str or model instance, optional
        ``"elastica"`` (paper §2) or ``"rigid"`` (paper §3), or a model object.

    Returns
    -------
    ScanResult
        One state per pose and the events crossed.

    Raises
    ------
    ParameterError
        When there are no poses.

    """
    poses = list(poses)
    if not poses:
        raise ParameterError("no foot poses")
    return _follow(QuasistaticTracker(profile, poses[0], model=model), poses[1:])


def run_scene(obstacles, poses, shape=None, friction=None) -> ScanResult:
    """
    Scan a scene with the multi-contact tracker: the whisker placed at the first pose (unloaded).

    ``obstacles``: scene obstacles (``core/scenes/scene.py``), ``friction`` their Coulomb
    coefficients, ``shape`` the whisker; ``poses``: foot poses or the paper's x0 values. (A scene
    of one convex profile or peg without friction is the single-contact problem:
    ``scan/scene_scan.py`` hands that to :func:`run_scan`, whose numbers the scene tracker
    reproduces to ~1e-10.)
    """
    from .scenes.tracker import SceneTracker

    poses = [p if isinstance(p, FootPose) else FootPose(float(p)) for p in poses]
    if not poses:
        raise ParameterError("no foot poses")
    return _follow(SceneTracker(obstacles, poses[0], shape=shape, friction=friction), poses[1:])
