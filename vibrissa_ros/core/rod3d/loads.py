"""
The 3D whisker under a given load: a force and a couple at one point, no obstacle.

The 3D counterpart of the planar :func:`~vibrissa_ros.core.exact.elastica.tip_loaded_elastica`:
the building block of calibration and of the 3D inverse problem, and the way to check a rod
solver against the classic benchmarks (a pure tip couple bends a uniform straight rod into a
circle of curvature M/B, twists it by M/C; a small force deflects it by F/3 in either plane).
Solved by the same Chebyshev collocation as the contacts
(:mod:`vibrissa_ros.core.rod3d.model`) on [0, s], the load ramped from zero in steps so that
large loads converge from the unloaded shape.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Optional, Tuple

import numpy as np

from ..errors import ParameterError
from .model import RodContactMode, RodSolver
from .pose import BasePose, quat_matrix
from .shape import RodShape

#: most load steps of the ramp (a load needing more is refused)
_MAX_RAMP = 400


@dataclass(frozen=True)
class LoadedRod:
    """
    The 3D whisker in equilibrium under a point load (world frame, dimensionless).

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    pose : BasePose
        The base pose.
    s : float
        Where the load acts [L].
    force : tuple of float
        The applied force (3,) [EI_b / L^2].
    moment : tuple of float
        The applied couple (3,) [EI_b / L].
    load_point : tuple of float
        Where the load point is in equilibrium (3,) [L].
    tip : tuple of float
        The tip's position (3,) [L].
    tip_frame : numpy.ndarray
        The body frame at the tip (3, 3), columns (d1, d2, d3).
    base_force : tuple of float
        The load's resultant, what a sensor at the base measures (= force).
    base_moment : tuple of float
        The load's moment about the base point: (load_point - p) x force + moment.
    solver : object, optional
        The collocation solver (internal: it samples the centerline).
    vec : numpy.ndarray, optional
        The collocation unknowns (internal).

    """

    pose: BasePose
    s: float
    force: Tuple[float, float, float]
    moment: Tuple[float, float, float]
    load_point: Tuple[float, float, float]
    tip: Tuple[float, float, float]
    tip_frame: np.ndarray
    base_force: Tuple[float, float, float]
    base_moment: Tuple[float, float, float]
    solver: Any = field(default=None, compare=False, repr=False)
    vec: Any = field(default=None, compare=False, repr=False)

    def centerline(self, s) -> np.ndarray:
        """
        Return points of the centerline at arc lengths ``s``, world frame.

        Parameters
        ----------
        s : array_like
            Arc lengths in [0, 1] [L].

        Returns
        -------
        numpy.ndarray
            Points (m, 3) [L].

        """
        return self.solver.centerline(self._modes(), self._full(), self.pose, s)

    def frames(self, s) -> np.ndarray:
        """
        Return the body frames at arc lengths ``s``.

        Parameters
        ----------
        s : array_like
            Arc lengths in [0, 1] [L].

        Returns
        -------
        numpy.ndarray
            Rotation matrices (m, 3, 3), columns (d1, d2, d3).

        """
        q = self.solver.quaternions(self._modes(), self._full(), self.pose, s)
        return quat_matrix(q / np.linalg.norm(q, axis=-1, keepdims=True))

    def _modes(self):
        return (RodContactMode("side", 0),)

    def _full(self):
        return np.concatenate((self.vec, [self.s, 0.0]))


def _vector(name: str, value) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ParameterError(f"load {name} {value!r} is not three numbers") from None
    if v.size != 3 or not np.all(np.isfinite(v)):
        raise ParameterError(f"load {name} {value!r} must be three finite numbers")
    return v


def tip_loaded_rod(shape: RodShape, pose: BasePose, force, moment=(0.0, 0.0, 0.0),
                   s: float = 1.0, n: Optional[int] = None) -> LoadedRod:
    """
    Solve the 3D whisker clamped at ``pose`` under a force and a couple at arc length ``s``.

    Parameters
    ----------
    shape : RodShape
        The whisker.
    pose : BasePose
        The base pose.
    force : array_like
        The force (3,) on the whisker at ``s``, world frame [EI_b / L^2].
    moment : array_like, optional
        The couple (3,) on the whisker at ``s``, world frame [EI_b / L].
    s : float, optional
        Where the load acts, in (0, 1]; 1 is the tip.
    n : int, optional
        Chebyshev points; default :func:`~vibrissa_ros.core.rod3d.model.points_for` the shape.

    Returns
    -------
    LoadedRod
        The equilibrium, its load point, tip and base load.

    Raises
    ------
    ParameterError
        When the load is not three finite numbers each, ``s`` is not in (0, 1], or the load is
        too large to be ramped up (a linear deflection plus rotation above 133).
    ConvergenceError
        When the equilibrium cannot be followed from the unloaded whisker.

    """
    F = _vector("force", force)
    Mt = _vector("moment", moment)
    s = float(s)
    if not (math.isfinite(s) and 0.0 < s <= 1.0):
        raise ParameterError(f"load arc length s = {s!r} must be in (0, 1]")
    # the load's size in linear theory: deflection [L] + rotation [rad] it would cause
    bend, turn = shape.compliance(s)
    size = (float(np.linalg.norm(F)) * bend
            + float(np.linalg.norm(Mt)) * turn * (1.0 + shape.poisson))
    ramp = 1 + int(math.ceil(3.0 * size))
    if ramp > _MAX_RAMP:
        raise ParameterError(
            f"load too large: in linear theory it would deflect the whisker by {size:.4g} "
            f"(L + rad), at most {(_MAX_RAMP - 1) / 3:.0f} is followed (many turns of the "
            "whisker)"
        )
    solver = RodSolver(shape, (), n=n)
    vec = solver.solve_loaded(s, pose, F, Mt, ramp=ramp)
    full = np.concatenate((vec, [s, 0.0]))
    modes = (RodContactMode("side", 0),)
    pts = solver.centerline(modes, full, pose, [s, 1.0])
    q_tip = solver.quaternions(modes, full, pose, [1.0])[0]
    frame = quat_matrix(q_tip / np.linalg.norm(q_tip))
    p = pose.p
    base_moment = np.cross(pts[0] - p, F) + Mt
    vec.setflags(write=False)
    return LoadedRod(pose, s, tuple(F), tuple(Mt), tuple(pts[0]), tuple(pts[1]), frame,
                     tuple(F), tuple(float(v) for v in base_moment), solver, vec)
