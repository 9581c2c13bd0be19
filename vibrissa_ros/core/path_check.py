"""
Where a straight path of a whisker's foot (or base) meets an obstacle: a failed step's cause.

Shared by the scene tracker (planar foot) and the 3D whisker (its base): a step whose foot is
driven into an obstacle, or through one, fails on its budget with a message that does not say
why; once it has failed, its path is looked at here and the error names it.
"""

from __future__ import annotations

from typing import Optional, Sequence, Tuple

import numpy as np

_NUMERICAL_ERRORS = (ArithmeticError, ValueError, np.linalg.LinAlgError)


def obstacle_on_path(start, end, obstacles: Sequence, cut: float,
                     samples: int = 33) -> Optional[Tuple[int, bool, float]]:
    """
    Return the obstacle a straight path ends inside, or else passes through, or None.

    Parameters
    ----------
    start, end : array_like
        The path's ends (points of the dimension the obstacles take).
    obstacles : sequence
        Objects with ``signed_distance(points)`` (negative inside).
    cut : float
        How far below 0 a distance counts as inside (placement's tolerance, < 0).
    samples : int, optional
        Points along the path, both ends included.

    Returns
    -------
    (int, bool, float) or None
        The obstacle's index, whether it holds the end (looked for first, whatever the path
        crossed before it), and the deepest sampled depth (> 0); None where the samples stay
        outside every obstacle.

    """
    a, b = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    points = a + np.linspace(0.0, 1.0, samples)[:, None] * (b - a)
    distances = []
    for k, ob in enumerate(obstacles):
        try:
            distances.append((k, np.asarray(ob.signed_distance(points), dtype=float)))
        except _NUMERICAL_ERRORS:
            continue
    for k, d in distances:
        if d[-1] < cut:
            return k, True, -float(d[-1])
    for k, d in distances:
        if np.any(d < cut):
            return k, False, -float(np.min(d))
    return None
