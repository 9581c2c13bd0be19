"""
Quasistatic tracking of the 3D whisker among obstacles in space.

A :class:`RodTracker` holds the current equilibrium (a configuration of frictionless contacts
solved by :class:`~.model.RodSolver`). :meth:`RodTracker.step` moves the base along the straight
path to a new pose (position linear, orientation along the shorter great arc, in the path
parameter t in [0, 1]) and follows the equilibrium by natural-parameter continuation in t
(tangent predictor, Newton corrector). After every accepted sub-step it evaluates the
configuration's inequalities; where one of them crosses zero the crossing is located in t
(Newton on a bordered system where the value is an unknown, a force or an arc length; else
Brent's method, to 1e-14) and the configuration changes:

===============  ====================================================================
event            change of the configuration
===============  ====================================================================
``touch``        a new contact with zero force (side, or tip when the tip touches first;
                 also a side contact behind a tip contact, on the same obstacle)
``release``      a contact's normal force returns to zero: the contact is dropped
``tip``          a side contact reaches the tip (s = 1): side -> tip
``tangential``   the tip's tangent reaches the surface's tangent plane: tip -> side
``snap``         the equilibrium is lost: the branch folds (no solution beyond t: the
                 fold located by its extended system, or closed in on by sub-steps, and
                 confirmed by a solve just past it that fails) or becomes unstable (the
                 sign of the Jacobian's determinant
                 changes, e.g. a planar equilibrium buckling out of its plane); the
                 whisker jumps to the stable equilibrium found from there
``reset``        the step could not be followed; the unloaded whisker was re-placed
===============  ====================================================================

Stability (doc/mechanics/rod3d.md, "Stability"): the unloaded whisker is stable, and a contact
that appears with zero force cannot destabilise it, so the sign of det J of the collocation
system just after each change of configuration is recorded as the configuration's stable sign;
along the configuration the equilibrium is stable while det J keeps that sign. A sign change is
a fold or a bifurcation: either way the equilibrium followed so far stops being a minimum of
the energy, and the whisker snaps.

Every loop is bounded; all draw on one budget of solver evaluations per step
(``max_evaluations``). A step returns a state or raises a VibrissaError and keeps the state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, List, Optional, Sequence, Tuple

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from ..errors import (
    ConvergenceError,
    InvalidPoseError,
    ModelAssumptionError,
    ParameterError,
    VibrissaError,
)
from . import _jit
from .model import (
    POINTS_TOLERANCE, TAIL_SAMPLES, RodContactMode, RodSolver, _lu_factor, _lu_solve, _settled,
    kernel_geometry, kernel_obstacles,
)
from ..path_check import obstacle_on_path
from .pose import BasePose, _relative, quat_matrix, quat_multiply
from .shape import RodShape

#: largest change of the unknowns in one sub-step
_MAX_CHANGE = 0.05
#: largest motion of any point of the whisker in one sub-step [L]
_MAX_MOVE = 0.05
#: smallest free sub-step motion [L] (the finest sampling of the free whisker's path)
_MIN_FREE_MOVE = 2e-3
_H_MIN = 1e-12
#: a trial step's solution farther than this from the tangent's prediction, and more than twice
#: as far as that prediction is from the start, is taken to lie on another branch
#: (:func:`_off_branch`)
_OFF_BRANCH = 1e-3
#: a solution is moved to other points per segment only where every event value exceeds this
_RESOLVE_MARGIN = 1e-6
#: and only where the new solution, resampled back, lies this close to the old one (or within
#: ten times the solver's points_tolerance, where that is more: two discretizations of a
#: coarse one differ by about it)
_RESOLVE_JUMP = 1e-8
_EVENT_XTOL = 1e-14
_MAX_EVENTS = 64
_MAX_SUBSTEPS = 5000
#: penetration below which a point counts as cutting an obstacle
_CUT = -1e-10
#: the whisker's sample points for the clearance (and the bound on the distance between them)
_SAMPLES = np.linspace(0.0, 1.0, 81)
_HALF_SPACING = 0.5 / 80.0
#: the unloaded whisker's samples (it is drawn, not solved: finer samples are cheap and keep the
#: exact minimum, a bounded search, to where the whisker is within 0.5/320 L of an obstacle)
_FREE_SAMPLES = np.linspace(0.0, 1.0, 321)
_FREE_HALF_SPACING = 0.5 / 320.0
#: clearance below which the distance is refined by a minimisation in s
_NEAR = 0.05
#: the compiled sampled value behind a tip contact (RodSolver.tip_gap) above _NEAR by this is
#: above it as _gap_behind_tip samples it too (the same points and distances, summed in
#: another order: at most 2.8e-13 apart over ~120,000 checks of the soaks)
_TIP_GAP_MARGIN = 1e-9
_NUMERICAL_ERRORS = (ArithmeticError, ValueError, np.linalg.LinAlgError)
#: where the unloaded tail beyond a side contact is checked (fractions of its length)
_TAIL_SAMPLES = TAIL_SAMPLES
#: a tail this far inside the obstacle it slides on is refused [L]
_TAIL_CUT = -1e-9
#: the last step continues this one when their pose increments' angle has this cosine or more
_LINE_COSINE = 0.999
#: a touch this near a prism's edge [L] is a touch of the edge
_EDGE_NEAR = 1e-6
#: Newton for the distance's minimum along the unloaded whisker: tolerance in s and iterations
_MINIMUM_XTOL = 1e-13
_MINIMUM_ITERATIONS = 12
#: the reason of a snap at a fold of the branch
_FOLDS = "the equilibrium branch folds (no solution beyond this pose)"
#: Newton iterations of the fold's extended system (:meth:`RodTracker._locate_fold`)
_FOLD_ITERATIONS = 8
#: the step of its forward differences along the null vector (max norm)
_FOLD_EPS = 1e-6
#: an event value this small and negative at a sub-step's start is a zero's rounding
_BORN_ZERO = 1e-12
#: how far on (in the path parameter) such a value's sign is looked at
_BORN_PROBE = 1e-9
#: the base turns a snap's helper trackers start from: (quaternion component, angle)
_SWINGS = ((2, 0.5 * math.pi), (2, -0.5 * math.pi), (3, 0.5 * math.pi), (3, -0.5 * math.pi),
           (2, 0.25 * math.pi), (2, -0.25 * math.pi), (3, 0.25 * math.pi), (3, -0.25 * math.pi))
_SLIPS = ("the contact reaches the tip and can go on neither along the side nor at the tip: it "
          "slips off the tip")
_CURLS_PREFIX = "the tip contact turns tangent to "
_CURLS = (_CURLS_PREFIX + "{name} where the unloaded whisker curves into it: neither the tip "
          "contact nor a side contact goes on, it slips off the tip")
#: a pose stream is extrapolated by a polynomial of degree k where its poses' (k+1)-th difference
#: is below this part of a step
_STREAM_TOLERANCE = 0.01
#: the orders of the polynomial extrapolation of a pose stream tried, highest first
_STREAM_ORDERS = (7, 5, 3)
_STREAM_HISTORY = max(_STREAM_ORDERS)
#: the (k+1)-th difference of k + 2 values, oldest first: binomial weights (it vanishes on a
#: polynomial of degree k, which gives the extrapolation)
_STREAM_WEIGHTS = {k: np.array([(-1.0) ** (k + 1 - j) * math.comb(k + 1, j)
                                for j in range(k + 2)]) for k in _STREAM_ORDERS}
#: the same as the kernel takes them (_jit.stream_guess): the orders, and their weights padded
_STREAM_KERNEL = (np.array(_STREAM_ORDERS, dtype=np.int64),
                  np.array([np.pad(_STREAM_WEIGHTS[k], (0, _STREAM_HISTORY + 2 - k - 2))
                            for k in _STREAM_ORDERS]))


@dataclass(frozen=True)
class RodContact:
    """
    One contact of a 3D equilibrium (world frame, dimensionless).

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    kind : str
        ``side`` or ``tip``.
    obstacle : int
        Index of the obstacle in the scene.
    name : str
        The obstacle's name.
    s : float
        Arc length of the contact point [L].
    f : float
        Normal force [EI_b / L^2], >= 0.
    point : tuple of float
        The contact point (x, y, z) [L].
    force : tuple of float
        The force on the whisker (fx, fy, fz), along the obstacle's outward normal.

    """

    kind: str
    obstacle: int
    name: str
    s: float
    f: float
    point: Tuple[float, float, float]
    force: Tuple[float, float, float]


@dataclass(frozen=True)
class RodState:
    """
    One quasistatic equilibrium of the 3D whisker.

    The parameters are the dataclass's fields, kept as attributes of the same names (world
    frame, dimensionless).

    Parameters
    ----------
    pose : BasePose
        The base pose.
    contacts : tuple of RodContact
        The contacts, from the base to the tip.
    force : tuple of float
        The total contact force on the whisker (fx, fy, fz).
    moment : tuple of float
        The moment of the contact forces about the base point (mx, my, mz).
    tip : tuple of float
        The tip's position.
    tip_tangent : tuple of float
        The unit tangent at the tip.
    equilibrium : RodEquilibrium, optional
        The solver's solution (internal: it samples the centerline).

    """

    pose: BasePose
    contacts: Tuple[RodContact, ...]
    force: Tuple[float, float, float]
    moment: Tuple[float, float, float]
    tip: Tuple[float, float, float]
    tip_tangent: Tuple[float, float, float]
    equilibrium: Any = field(default=None, compare=False, repr=False)

    @property
    def nearest(self) -> Optional[RodContact]:
        """Return the contact nearest the base, or None."""
        return self.contacts[0] if self.contacts else None

    def centerline(self, n: int = 101) -> np.ndarray:
        """
        Return ``n`` >= 2 points from the base to the tip, world frame, shape (n, 3).

        Parameters
        ----------
        n : int, optional
            Number of points, equally spaced in arc length.

        Returns
        -------
        numpy.ndarray
            The points [L].

        Raises
        ------
        ParameterError
            When ``n`` < 2.

        """
        n = int(n)
        if n < 2:
            raise ParameterError(f"centerline points n = {n}: need at least 2")
        return self.equilibrium.centerline(np.linspace(0.0, 1.0, n))

    def base_wrench(self) -> Tuple[np.ndarray, np.ndarray]:
        """
        Return the base load in the base frame: (force (3,), moment about the base (3,)).

        Returns
        -------
        tuple of numpy.ndarray
            R(q)^T force and R(q)^T moment.

        """
        R = self.pose.rotation
        return R.T @ np.array(self.force), R.T @ np.array(self.moment)


@dataclass(frozen=True)
class RodEvent:
    """
    Something that happened during a step, located by root finding in the path parameter.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    kind : str
        ``touch``, ``release``, ``tip``, ``tangential``, ``snap`` or ``reset``.
    pose : BasePose
        The base pose where it happened.
    obstacle : int or None, optional
        The obstacle concerned.
    s : float or None, optional
        The contact's arc length there.
    contacts_before, contacts_after : int, optional
        The number of contacts before and after.
    reason : str, optional
        Why a snap or a reset happened (not compared).

    """

    kind: str
    pose: BasePose
    obstacle: Optional[int] = None
    s: Optional[float] = None
    contacts_before: int = 0
    contacts_after: int = 0
    reason: str = field(default="", compare=False)


@dataclass(frozen=True)
class RodStepResult:
    """
    The outcome of one step: the new state, the events crossed and the solver work spent.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    state : RodState
        The equilibrium at the new pose.
    events : tuple of RodEvent
        The events, in path order.
    substeps : int
        Accepted continuation sub-steps.
    evaluations : int
        Solver evaluations spent.

    """

    state: RodState
    events: Tuple[RodEvent, ...]
    substeps: int
    evaluations: int


class _OverBudget(ConvergenceError):
    """A step spent its budget of solver evaluations (internal: never swallowed)."""


class _Unlocated(ConvergenceError):
    """No event could be located between two sub-steps (nothing changed yet) (internal)."""


def _off_branch(vec: np.ndarray, line: np.ndarray, start: np.ndarray) -> bool:
    """
    Tell whether a trial step's solution lies on another branch than its start's.

    ``line`` is the tangent's prediction at the step's end (start + h dv/dt, whatever guess
    Newton started from). Along a branch its error is of second order in the step, its change
    of first order. An error more than twice the predicted change (and above _OFF_BRANCH,
    beyond the rounding of a step that barely moves) is taken for Newton converging past a
    fold on the branch beyond, where the whisker would jump with no event. Such a trial step
    fails, and a shorter one follows (down to the fold, where the snap is found). It is a
    safety net, not a proof: the soak at 9.5 Hz had one such jump, RE2 at tick 1781 (its tip
    0.11 L in one step, an error 2.8 times the prediction); a release on the rat's pad,
    followed along its branch, had an error 1.6 times it.
    """
    if line.shape != vec.shape or start.shape != vec.shape:
        return False
    return _beyond_branch(float(np.max(np.abs(vec - line))),
                          float(np.max(np.abs(line - start))))


def _beyond_branch(error: float, change: float) -> bool:
    """Apply :func:`_off_branch`'s rule to the error and the predicted change (max norms)."""
    return error > _OFF_BRANCH and error > 2.0 * change


class _Path:
    """The straight path between two base poses (p linear, q by slerp) (internal)."""

    def __init__(self, a: BasePose, b: BasePose):
        self.a, self.b = a, b
        (ax_, ay_, az_), (bx_, by_, bz_) = a.position, b.position
        dx, dy, dz = bx_ - ax_, by_ - ay_, bz_ - az_
        self.dp = np.array((dx, dy, dz))
        # the relative rotation conj(q_a) * q_b, on the shorter arc (in floats: a path is made
        # per step and per event, and numpy's calls cost more than the arithmetic here)
        rw, rx, ry, rz = _relative(a.quaternion, b.quaternion)
        sin_half = math.sqrt(rx * rx + ry * ry + rz * rz)
        self.angle = 2.0 * math.atan2(sin_half, rw)
        c = self.angle / sin_half if sin_half > 0.0 else 0.0
        self._turn = (0.5 * c * rx, 0.5 * c * ry, 0.5 * c * rz)
        #: bound on the speed of any point of the whisker per unit t
        self.speed = math.sqrt(dx * dx + dy * dy + dz * dz) + self.angle
        #: (dp, angle axis in the body frame at a): the direction of the motion
        self._motion = (dx, dy, dz, c * rx, c * ry, c * rz)
        self._cache = {}

    def pose(self, t: float) -> BasePose:
        if t == 0.0:
            return self.a
        if t == 1.0:
            return self.b
        cached = self._cache.get(t)
        if cached is None:
            if len(self._cache) > 8:
                self._cache.clear()
            cached = self._cache[t] = self.a.at(self.b, t)
        return cached

    def continuing(self, record):
        """
        Return a tangent's record on the path before, on this path, or None.

        A record is (path, contacts, t, g = 1 / norm(dv/dt)^2, dv/dt). Where this path goes on
        from that one's end (``a`` is its ``b``) at about its speed and in about its direction
        (a pose stream's next step: the ratio r of the speeds within [0.8, 1.25], the
        directions of (dp, angle axis) within ~25 degrees), its t and g are converted to this
        path's parameter: t - 1 scaled by r, g by r^2 (the same pose-space distance in a step
        r times as long); the tangent is kept as it is.
        """
        before = record[0]
        if before.b is not self.a or not (self.speed > 0.0 and before.speed > 0.0):
            return None
        r = before.speed / self.speed
        if not 0.8 <= r <= 1.25:
            return None
        u, w = self._motion, before._motion
        uw = uu = ww = 0.0
        for x, y in zip(u, w):
            uw, uu, ww = uw + x * y, uu + x * x, ww + y * y
        if not uw > 0.9 * math.sqrt(uu * ww):
            return None
        return self, record[1], (record[2] - 1.0) * r, record[3] * r * r, record[4]

    def rate(self, pose: BasePose) -> np.ndarray:
        """(dp/dt, dq/dt) (7,) at ``pose`` on the path: dq/dt = q * (0, angle axis / 2)."""
        qw, qx, qy, qz = pose.quaternion
        wx, wy, wz = self._turn
        out = np.empty(7)
        out[:3] = self.dp
        out[3:] = (-qx * wx - qy * wy - qz * wz,
                   qw * wx + qy * wz - qz * wy,
                   qw * wy - qx * wz + qz * wx,
                   qw * wz + qx * wy - qy * wx)
        return out


def _stream_arrays(history):
    """Return (history, its poses' rows (p, q) (m, 7), its solutions (m, size)) for the kernel."""
    return (history, np.array([pose.position + pose.quaternion for pose, _ in history]),
            np.array([v for _, v in history]))


def _fold_g(tan: np.ndarray) -> float:
    """Return g = 1 / norm(tan)^2, as the plain step's kernel computes it (_jit.fold_measure)."""
    return float(_jit.fold_measure(np.ascontiguousarray(tan, dtype=float)))


def _as_pose(pose) -> BasePose:
    if isinstance(pose, BasePose):
        return pose
    raise InvalidPoseError(f"base pose {pose!r} is not a BasePose")


def _aligned(q: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Return q or -q, whichever is nearer ref (the same rotation)."""
    return q if float(q @ ref) >= 0.0 else -q


def _det_measure(lu) -> float:
    """Sign of det J times the geometric mean of |U_ii|: continuous, zero where J is singular."""
    lu_, piv = lu
    if _jit.ENABLED:
        return _jit.det_measure(lu_, piv)
    d = np.diag(lu_)
    swaps = int(np.count_nonzero(piv != np.arange(piv.size)))
    sign = -1.0 if (swaps + int(np.count_nonzero(d < 0.0))) % 2 else 1.0
    with np.errstate(divide="ignore"):
        mean = float(np.mean(np.log(np.abs(d))))
    return sign * math.exp(mean)


class RodTracker:
    """
    Quasistatic tracker of the 3D whisker in a scene of 3D obstacles.

    Parameters
    ----------
    obstacles : Scene3D or sequence
        The scene, or its 3D obstacles (:mod:`.obstacles`).
    pose : BasePose
        The initial base pose; the unloaded whisker must be clear of every obstacle there.
    shape : RodShape, optional
        The whisker (default: uniform, straight, nu = 0.38).
    n : int, optional
        Chebyshev points per segment, the most it solves on; default
        :func:`~vibrissa_ros.core.rod3d.model.points_for` the shape.
    max_evaluations : int, optional
        Budget of solver evaluations per step.
    recover : bool, optional
        Re-place the unloaded whisker when a step cannot be followed and the unloaded whisker
        is clear of every obstacle at the new pose (a ``reset`` event).
    adapt_points : bool, optional
        Solve each contact configuration on as few points per segment as its solution needs
        (:meth:`~vibrissa_ros.core.rod3d.model.RodSolver.points_needed`, at most ``n``; a long
        step whose end asks for more goes on ``n``): on the rat's pad, the same events and base
        wrenches within 2e-14 relative, with a third less factorization work
        (``bench/bench_array.py``). False: always ``n``.
    points_tolerance : float, optional
        The discretization error asked for [L]
        (:class:`~vibrissa_ros.core.rod3d.model.RodSolver`): the default 1e-11 resolves the
        whisker to about the solver's own convergence; a coarser one (up to 1e-6) solves on
        fewer points, for speed.

    Raises
    ------
    InvalidPoseError
        When the unloaded whisker cuts an obstacle at ``pose``.
    ParameterError
        When ``n`` or ``points_tolerance`` is out of range.

    """

    def __init__(self, obstacles: Sequence[Any], pose: BasePose,
                 shape: Optional[RodShape] = None, n: Optional[int] = None,
                 max_evaluations: int = 20000, recover: bool = True,
                 adapt_points: bool = True, points_tolerance: float = POINTS_TOLERANCE):
        self.shape = RodShape() if shape is None else shape
        self.obstacles = tuple(getattr(obstacles, "obstacles", obstacles))
        self.solver = RodSolver(self.shape, self.obstacles, n=n,
                                points_tolerance=points_tolerance)
        self.max_evaluations = int(max_evaluations)
        self.recover = bool(recover)
        self.adapt_points = bool(adapt_points)
        self._nested = False
        self._free_points = self.shape.free_centerline(_FREE_SAMPLES)
        # the free whisker's least distance near a sample, compiled (_jit.free_minimum) for a
        # straight or parabolic whisker and each sphere, cylinder and plane; None: in Python
        self._free_kernels = None
        if _jit.ENABLED and (self.shape.parabola is not None or self.shape.is_straight):
            table = (self.shape._u_table() if self.shape.parabola is not None
                     else (np.zeros(2), np.zeros(2)))
            self._free_kernels = (self.shape.parabola or 0.0, table[0], table[1], [
                None if g is None else (g[0], np.array(g[1], dtype=float))
                for g in (kernel_geometry(ob) for ob in self.obstacles)])
        # and its sampled distances to every obstacle, where the kernels know them all
        self._free_samples = kernel_obstacles(self.obstacles) if _jit.ENABLED else None
        # only prisms have edges (a polygon's corners, a point peg)
        self._edges = any(getattr(ob, "planar", None) is not None for ob in self.obstacles)
        pose = _as_pose(pose)
        self._check_placeable(pose, "the initial pose")
        self._place(pose)

    # -- placing ------------------------------------------------------------------------------
    def _check_placeable(self, pose: BasePose, what: str) -> None:
        gap, k, s = self._free_gap(pose, exact=True)
        if gap < _CUT:
            ob = self.obstacles[k]
            name = getattr(ob, "name", f"obstacle {k}")
            where = "its base" if s == 0.0 else f"arc length s = {s:.4g} L"
            raise InvalidPoseError(
                f"{what} {pose.position} (quaternion {pose.quaternion}) puts the unloaded "
                f"whisker inside {name} (at {where}, {-gap:.3g} L deep): a whisker can only be "
                "placed clear of every obstacle"
            )

    def _place(self, pose: BasePose) -> None:
        self._pose = pose
        self._modes: Tuple[RodContactMode, ...] = ()
        self._vec = np.zeros(0)
        self._solved = None
        self._sign = 1.0
        self._gap_cache = None
        #: the last tangent's (path, contacts, t, g = 1 / norm(dv/dt)^2, dv/dt) (_fold_limit),
        #: and the last one on the path before
        self._fold_prev = self._fold_before = None
        #: (path, contacts) where _locate_fold found no fold (not looked for again there)
        self._fold_sought = None
        self._last_change = None
        self._last_step = None
        self._history = []
        #: (the history list, its poses (m, 7), its solutions (m, size)) as arrays, for the
        #: compiled extrapolation; valid while that list is self._history
        self._stream = None
        #: (solution, points_needed of it) of the last plain step (RodSolver.trusted_step)
        self._needed = None
        self._state = self._make_state()

    @property
    def state(self) -> RodState:
        """Return the current equilibrium."""
        return self._state

    @property
    def pose(self) -> BasePose:
        """Return the current base pose, as it was given."""
        return self._state.pose

    # -- the public step ----------------------------------------------------------------------
    def step(self, pose: BasePose) -> RodStepResult:
        """
        Move the base along the straight path to ``pose`` and follow the equilibrium.

        Parameters
        ----------
        pose : BasePose
            The new base pose.

        Returns
        -------
        RodStepResult
            The new state and the events crossed.

        Raises
        ------
        InvalidPoseError
            The pose is not valid input, or a step that fails puts the base inside an obstacle
            (the state is kept).
        ModelAssumptionError, ConvergenceError
            The step cannot be followed (the reason names the base's path where it passes
            through an obstacle) and the unloaded whisker would cut an obstacle at
            ``pose``, or ``recover`` is off; the state is kept. When the whisker is free there it
            is re-placed instead, and the result has one event ``reset``.

        """
        given = _as_pose(pose)
        # q and -q are the same rotation; the unknowns follow the sign of the base quaternion,
        # so the path is followed with the sign nearest the last pose's (a pose stream may flip
        # it, e.g. a rotation matrix's quaternion with w >= 0 as w crosses 0) and the state
        # reports the pose as it was given
        target = given
        (gw, gx, gy, gz), (w, x, y, z) = given.quaternion, self._pose.quaternion
        if gw * w + gx * x + gy * y + gz * z < 0.0:
            target = BasePose(given.position, tuple(-v for v in given.quaternion))
        self._start = self.solver.evaluations
        saved = (self._pose, self._modes, self._vec, self._solved, self._sign, self._state,
                 self._history, self._last_step, self._fold_prev, self._fold_before)
        try:
            result = self._step_checked(target)
            if target is not given:
                self._state = replace(self._state, pose=given)
                result = replace(result, state=self._state)
            return result
        except (ModelAssumptionError, ConvergenceError) as exc:
            (self._pose, self._modes, self._vec, self._solved, self._sign, self._state,
             self._history, self._last_step, self._fold_prev, self._fold_before) = saved
            cause = self._base_path_cause(target, exc)
            if cause is not exc:
                if isinstance(cause, InvalidPoseError) or not self.recover:
                    raise cause from None
                exc = cause
            if not self.recover:
                raise
            spent = self.solver.evaluations - self._start
            try:
                result = self.reset(given, reason=str(exc))
            except InvalidPoseError:
                raise exc from None
            return RodStepResult(result.state, result.events, 0, spent + result.evaluations)
        except BaseException:
            (self._pose, self._modes, self._vec, self._solved, self._sign, self._state,
             self._history, self._last_step, self._fold_prev, self._fold_before) = saved
            raise

    def _base_path_cause(self, target: BasePose, exc: VibrissaError) -> VibrissaError:
        """
        Return the error a failed step is reported with: the base's own path, where it is to blame.

        A base driven into an obstacle, or through one, presses the whisker on it without
        bound, and the step fails only on its budget or its sub-steps (~1 s) with a message that
        does not say why. Looked at only once a step has failed, at 33 points of the base's
        straight path: a base inside an obstacle at the target is an InvalidPoseError (as for a
        placement), one that passes through an obstacle on the way a ModelAssumptionError that
        says so; otherwise ``exc`` itself.
        """
        found = obstacle_on_path(self._pose.position, target.position, self.obstacles, _CUT)
        if found is None:
            return exc
        k, at_end, depth = found
        if at_end:
            return InvalidPoseError(
                f"the pose {target.position} (quaternion {target.quaternion}) puts the "
                f"whisker's base inside {self._name(k)} ({depth:.3g} L deep)")
        return ModelAssumptionError(
            f"the base's path from {self._pose.position} to {target.position} passes "
            f"through {self._name(k)}: a base cannot move through an obstacle ({exc})")

    def reset(self, pose: Optional[BasePose] = None, reason: str = "reset on request"
              ) -> RodStepResult:
        """
        Place the whisker unloaded at ``pose``, forgetting its history.

        Parameters
        ----------
        pose : BasePose, optional
            Where to place it; default: the current base pose.
        reason : str
            Why, carried by the event.

        Returns
        -------
        RodStepResult
            The unloaded state and one event ``reset``.

        Raises
        ------
        InvalidPoseError
            The unloaded whisker would cut an obstacle at ``pose`` (the state is kept).

        """
        target = self._state.pose if pose is None else _as_pose(pose)
        before = len(self._modes)
        self._check_placeable(target, "the reset pose")
        self._place(target)
        event = RodEvent("reset", target, contacts_before=before, reason=reason)
        return RodStepResult(self._state, (event,), 0, 0)

    def _step_checked(self, target: BasePose) -> RodStepResult:
        try:
            return self._step(target)
        except VibrissaError:
            raise
        except _NUMERICAL_ERRORS as exc:
            raise ConvergenceError(
                f"the step from {self._pose.position} to {target.position} failed numerically "
                f"({type(exc).__name__}: {exc})") from exc

    def _check_budget(self) -> None:
        if self.solver.evaluations - self._start > self.max_evaluations:
            raise _OverBudget(
                f"the step used more than {self.max_evaluations} solver evaluations without "
                "settling")

    # -- the step -----------------------------------------------------------------------------
    def _step(self, target: BasePose) -> RodStepResult:
        path = _Path(self._pose, target)
        self._last_snap = None
        self._last_change = None
        start_pose, start_vec, start_modes = self._pose, self._vec, self._modes
        events: List[RodEvent] = []
        if path.speed == 0.0 or target == self._pose:
            # (the same pose: its path's angle may come out ~1e-16, not 0, from rounding)
            if self._modes:
                # the same pose again: a sample of a pose stream all the same (as at a whisk's
                # turning point sampled symmetrically about it), so that the stream's history
                # stays uniform in time and its extrapolation goes on (_extrapolate; a pose
                # held, or sent twice, is left out there where the stream is not uniform with it)
                self._last_step = (self._pose, self._vec, self._modes)
                self._grow_history(self._pose, self._vec)
            return RodStepResult(self._state, (), 0, 0)
        t = 0.0
        substeps = 0
        h = 1.0
        for _ in range(_MAX_SUBSTEPS):
            if t >= 1.0:
                break
            self._check_budget()
            if len(events) > _MAX_EVENTS:
                raise ConvergenceError(f"more than {_MAX_EVENTS} events in one step")
            if not self._modes:
                t = self._free_advance(path, t, events)
                h = 1.0
            else:
                t, h = self._contact_advance(path, t, h, events)
            substeps += 1
        else:
            raise ConvergenceError(f"the step needed more than {_MAX_SUBSTEPS} sub-steps")
        if (self._modes and start_modes == self._modes
                and len(start_vec) != len(self._vec)):
            # (the step went to the full count first: its start on the same points)
            start_vec = self.solver.resample(start_modes, start_vec,
                                             self.solver.points_of(self._modes, self._vec))
        # (pose, solution, configuration) at this step's start, for the next step's predictor
        self._last_step = ((start_pose, start_vec, start_modes)
                           if not events and start_modes == self._modes and self._modes
                           else None)
        if self._last_step is None:
            self._history = []
        else:
            self._grow_history(start_pose, start_vec)
        self._pose = target
        if not self._modes:
            self._vec, self._solved = np.zeros(0), None
        elif not events and self.adapt_points:
            self._resolve_points()
        self._state = self._make_state()
        return RodStepResult(self._state, tuple(events), substeps,
                             self.solver.evaluations - self._start)

    # -- the free whisker ---------------------------------------------------------------------
    def _free_gap(self, pose: BasePose, exact: bool = False, skip=(), certify: bool = False):
        """
        (clearance, obstacle, s): a lower bound of the free whisker's distance, exact near.

        With ``certify`` a positive lower bound (the samples' distance less half their spacing)
        is returned as it is, without the exact minimum: enough to size a free sub-step and to
        know there is no touch; the exact minimum is taken only where the bound is not positive.
        """
        if self._free_samples is not None and self.obstacles:
            # the samples' nearest to each obstacle in one kernel call (as below)
            if not _jit.WARM:
                _jit.warm_up()
            pts, nearest = None, _jit.free_samples(self._free_samples[0], self._free_samples[1],
                                                   np.array(pose.rotation), pose.p,
                                                   self._free_points)
        else:
            pts = np.array(pose.position) + self._free_points @ pose.rotation.T
            nearest = None
        return self._gap_of_points(pts, lambda s: self._free_point(pose, s), exact, skip,
                                   certify, _FREE_SAMPLES, _FREE_HALF_SPACING,
                                   lambda s: self._free_geometry(pose, s), pose, nearest)

    def _free_point(self, pose: BasePose, s: float) -> np.ndarray:
        x, y = self.shape.free_frame(s)[:2]
        R = pose.rotation
        return pose.p + x * R[:, 0] + y * R[:, 1]

    def _free_geometry(self, pose: BasePose, s: float):
        """Return the unloaded whisker's point, unit tangent and its s-derivative at s (world)."""
        x, y, phi, kappa = self.shape.free_frame(s)
        R = pose.rotation
        c, sn = math.cos(phi), math.sin(phi)
        e1, e2 = R[:, 0], R[:, 1]
        return (pose.p + x * e1 + y * e2, c * e1 + sn * e2, kappa * (c * e2 - sn * e1))

    def _gap_of_points(self, pts, point_at, exact, skip, certify=False, samples=_SAMPLES,
                       half=_HALF_SPACING, geometry_at=None, free_pose=None, nearest=None):
        """
        Return (value, obstacle, s): the least distance of the sampled curve to an obstacle.

        ``pts`` are the samples (at ``samples``), or ``nearest`` gives each obstacle's least
        sampled distance and its sample; near an obstacle (or ``exact``) the distance is
        minimized over s about that sample (:meth:`_refine_free` for the free whisker at
        ``free_pose``, else :meth:`_refine`).
        """
        best = (math.inf, -1, 0.0)
        for k, ob in enumerate(self.obstacles):
            if k in skip:
                continue
            if nearest is not None:
                dmin, j = float(nearest[0][k]), int(nearest[1][k])
            else:
                d = ob.signed_distance(pts)
                j = int(np.argmin(d))
                dmin = float(d[j])
            if (dmin > _NEAR and not exact) or (certify and dmin - half > 0.0):
                value, s = dmin - half, float(samples[j])
            else:
                found = (None if free_pose is None
                         else self._refine_free(k, free_pose, j, dmin, samples))
                value, s = (found if found is not None
                            else self._refine(ob, point_at, j, dmin, samples, geometry_at))
            if value < best[0]:
                best = (value, k, s)
        return best

    def _refine_free(self, k, pose, j, dmin, samples):
        """
        Return the free whisker's least distance to obstacle k near sample j, compiled, or None.

        :meth:`_refine`'s Newton on d'(s) in one kernel call (:func:`._jit.free_minimum`), for
        a straight or parabolic whisker and a sphere, cylinder or plane; None where it is not
        compiled or Newton does not settle (then :meth:`_refine`, with its Brent search). A
        touch search evaluates the free whisker's distance ~15 times per touch: ~300 us each
        in Python, ~25 us so.
        """
        if self._free_kernels is None or self._free_kernels[3][k] is None:
            return None
        if not _jit.WARM:
            _jit.warm_up()
        A, grid, table, kernels = self._free_kernels
        code, prm = kernels[k]
        lo = float(samples[max(j - 1, 0)])
        hi = float(samples[min(j + 1, samples.size - 1)])
        s_j = float(samples[j])
        found, s, d_s, d_lo, d_hi = _jit.free_minimum(
            code, prm, np.array(pose.rotation), pose.p, A, grid, table, s_j, lo, hi,
            _MINIMUM_ITERATIONS, _MINIMUM_XTOL)
        if not found:
            return None
        return min([(dmin, s_j), (d_s, s), (d_lo, lo), (d_hi, hi)])

    def _refine(self, ob, point_at, j, dmin, samples=_SAMPLES, geometry_at=None):
        """
        Return the distance's minimum over s near sample j.

        With ``geometry_at`` (s -> point, unit tangent and its s-derivative) Newton on
        d'(s) = n . t, d''(s) = t . H t + n . t' from the sample (the obstacle's normal n and
        distance Hessian H at the point), kept in the samples' bracket; a bounded Brent search
        in s where it is not given or Newton does not settle there.
        """
        lo = float(samples[max(j - 1, 0)])
        hi = float(samples[min(j + 1, samples.size - 1)])

        def d(s):
            return float(ob.signed_distance(point_at(s)[None, :])[0])

        found = None
        if geometry_at is not None:
            found = _newton_minimum(ob, geometry_at, float(samples[j]), lo, hi)
        if found is None:
            res = minimize_scalar(d, bounds=(lo, hi), method="bounded",
                                  options={"xatol": 1e-12, "maxiter": 200})
            found = float(res.x)
        cands = [(dmin, float(samples[j])), (d(found), found)]
        for s_end in (lo, hi):
            cands.append((d(s_end), s_end))
        return min(cands)

    def _free_advance(self, path: _Path, t: float, events: List[RodEvent]) -> float:
        """Move the free whisker as far as it stays clear; on a touch, add the contact."""
        pose = path.pose(t)
        cached = self._gap_cache
        # (computed as the cache's was: the same first sub-step whether the whisker was stepped
        # here or placed here, as the array places the whiskers it skipped)
        gap = (cached[1] if cached is not None and cached[0] is pose
               else self._free_gap(pose, certify=True)[0])
        for _ in range(_MAX_SUBSTEPS):
            self._check_budget()
            self.solver.evaluations += 1
            move = max(gap, _MIN_FREE_MOVE)
            t_new = min(1.0, t + move / path.speed)
            pose_new = path.pose(t_new)
            gap_new, k, s = self._free_gap(pose_new, exact=gap - 2 * path.speed * (t_new - t)
                                           < _NEAR, certify=True)
            if gap_new < _CUT:
                return self._free_touch(path, t, t_new, events)
            t, gap = t_new, gap_new
            if t >= 1.0:
                self._gap_cache = (pose_new, gap_new)
                return 1.0
        raise ConvergenceError("the free whisker's path needed too many sub-steps")

    def _free_touch(self, path: _Path, t_a: float, t_b: float, events) -> float:
        def g(tau):
            self.solver.evaluations += 1
            return self._free_gap(path.pose(tau), exact=True)[0]

        t_star = t_a if g(t_a) <= 0.0 else self._root(g, t_a, t_b)
        pose = path.pose(t_star)
        gap, k, s = self._free_gap(pose, exact=True)
        kind = "tip" if s >= 1.0 - 1e-9 else "side"
        mode = RodContactMode(kind, k)
        self._check_touch_feature(k, self._free_point(pose, s))
        breaks = [1.0 if kind == "tip" else s]
        vec = self.solver.guess((mode,), breaks, [0.0],
                                lambda ss: self.solver.free_quaternions(pose, ss))
        solved = self.solver.solve((mode,), pose, vec)
        if solved.vec[-1] < -_BORN_ZERO and t_star < t_b:
            # the contact pulls where the unloaded whisker touches: the discretization's
            # whisker (its points_tolerance) touches a little later, where its force reaches 0;
            # or not within this free sub-step, and it goes on unloaded (within that tolerance
            # of the obstacle), instead of a contact released at once and touched again
            later = self._discrete_touch(path, t_star, t_b, mode, solved)
            if later is None:
                return t_b
            t_star, solved = later
            pose = path.pose(t_star)
            breaks = [1.0 if kind == "tip" else float(solved.vec[-2])]
        self._check_features((mode,), solved.vec, pose)
        self._modes = (mode,)
        self._fold_prev = self._fold_before = None  # (as for any change of the contacts)
        self._accept(solved, pose)
        self._sign = math.copysign(1.0, _det_measure(solved.lu))
        self._pose = pose
        events.append(RodEvent("touch", pose, k, breaks[0], 0, 1))
        return t_star

    def _discrete_touch(self, path: _Path, t_a: float, t_b: float, mode, solved):
        """
        Return (t, solution) where a contact just made bears load on the discrete whisker.

        The touch is located on the unloaded whisker as it is (:meth:`_free_gap`), the contact
        solved on the collocation's points: the two differ by about the solver's
        ``points_tolerance``, so at a coarse one the contact's force at the touch can come out
        a little below 0 (-2e-10 at 1e-8). Followed from there, a grazing contact would be
        released at once and touched again at the same pose, without end. Its force's zero on
        the contact's branch in [t_a, t_b] (:meth:`_locate_linear`) is where the discrete
        whisker touches (where the bordered Newton does not settle, Brent's search on the
        force); None where the force at t_b is still not above 0 (the whisker goes on unloaded
        through this free sub-step, as near the obstacle as the discretization can tell).
        Where neither finds it (a solve fails), the contact at t_a as before.
        """
        modes, vec0, pose0 = self._modes, self._vec, self._pose
        self._modes = (mode,)
        try:
            end = self._solve_at(path, t_a, t_b, solved)
            if end.vec[-1] <= 0.0:
                return None
            found = self._locate_linear(path, t_a, t_b, solved, solved.vec.size - 1, 0.0)
            if found is None:
                # Brent's search on the force instead, each value a solve from the touch (its
                # zero may be the bracket's end itself: a force of exactly 0 at the touch)
                cache = {t_a: solved, t_b: end}

                def force(tau):
                    if tau not in cache:
                        cache[tau] = self._solve_at(path, t_a, tau, solved)
                    return float(cache[tau].vec[-1])

                t_f = self._root(force, t_a, t_b)
                force(t_f)
                found = (t_f, cache[t_f])
        except ConvergenceError:
            found = None
        finally:
            self._modes, self._vec, self._pose = modes, vec0, pose0
        return found if found is not None else (t_a, solved)

    # -- contact continuation -----------------------------------------------------------------
    def _accept(self, solved, pose):
        self._solved, self._vec, self._pose = solved, solved.vec, pose

    def _solve_at(self, path, t, t_new, solved, exact=True):
        """
        Solve at t_new from the solution at t (``exact``: the Jacobian at the solution).

        Within a sub-step already taken, to locate an event in it. A solution off the branch
        of the one at t (:func:`_off_branch`, as a trial step is judged) is a ConvergenceError,
        as where Newton fails: the event is then not located from it.
        """
        pose = path.pose(t)
        tan = self.solver.tangent(solved, path.rate(pose))
        guess = solved.vec + (t_new - t) * tan
        pose_new = path.pose(t_new)
        found = self.solver.solve(self._modes, pose_new, guess, start=solved, max_step=0.5,
                                  exact_jacobian=exact)
        if _off_branch(found.vec, guess, solved.vec):
            raise ConvergenceError("3D whisker: a solve within the sub-step landed on another "
                                   "branch")
        return found

    def _event_values(self, path, t, vec, lu):
        """Named inequality values (>= 0 admissible) of the configuration at (t, vec)."""
        sol = self.solver
        modes = self._modes
        pose = path.pose(t)
        out = {}
        fs = sol.forces_of(modes, vec)
        br = sol.breaks_of(modes, vec)
        for c, m in enumerate(modes):
            out[("release", c)] = fs[c]
            if m.kind == "side" and c == len(modes) - 1:
                out[("tip", c)] = 1.0 - br[c]
            if m.kind == "tip":
                out[("tangential", c)] = self._tangential(modes, vec, pose)
        out[("stable", -1)] = self._sign * _det_measure(lu)
        return out

    def _contact_gap(self, path, t, vec, exact=False):
        skip = {m.obstacle for m in self._modes}
        behind = self._behind_tip()
        if len(skip) == len(self.obstacles) and not behind:
            return (math.inf, -1, 0.0)
        pose = path.pose(t)
        sol = self.solver
        pts = sol.centerline(self._modes, vec, pose, _SAMPLES)

        def point_at(s):
            return sol.centerline(self._modes, vec, pose, [s])[0]

        best = self._gap_of_points(pts, point_at, exact, skip)
        if behind:
            same = self._gap_behind_tip(pose, vec, pts, point_at, exact)
            if same[0] < best[0]:
                best = same
        return best

    def _behind_tip(self) -> bool:
        """Tell whether the last contact is at the tip, alone on its obstacle (_gap_behind_tip)."""
        return self._modes[-1].kind == "tip" and self._alone_on_its_obstacle(-1)

    def _touches(self, path, t, vec, clear=None) -> bool:
        """
        Tell whether the solution ``vec`` at path parameter t touches an obstacle (a new contact).

        That is :meth:`_contact_gap` below _CUT, whose samples of the centerline and minima
        cost ~0.1 ms per obstacle it does not touch. Where the kernels bound the whole
        whisker's distance to those obstacles above 0 (``clear``, the plain step's, or
        :meth:`RodSolver._accepted`'s: :func:`._jit.clear_of`), there is nothing to find on
        them and _contact_gap is not called: its value would be above 0 too (a sampled
        distance less half the spacing where it is over _NEAR, else a distance the centerline
        attains). Behind a tip contact alone on its obstacle, the second touch on that obstacle
        is its own test: its sampled value (:meth:`_gap_behind_tip`'s, by one compiled call,
        :meth:`RodSolver.tip_gap`) clearly above _NEAR is what _contact_gap would return (no
        touch); else _contact_gap is called.
        """
        modes = self._modes
        if clear is None and len(self.obstacles) > 1:
            post = self.solver._accepted(modes, vec, path.pose(t))
            clear = -math.inf if post is None else post.clear
        behind = self._behind_tip()
        cleared = clear is not None and clear > 0.0
        if cleared and not behind:
            return False
        if behind and (cleared or len(self.obstacles) == 1):
            # behind a tip contact (the other obstacles cleared): _gap_behind_tip's sampled
            # value, compiled; clearly above _NEAR, it is what _contact_gap returns (no touch)
            first = self._first_behind_tip(vec)
            least = self.solver.tip_gap(modes, vec, path.pose(t), _SAMPLES[first:-1])
            if least is not None and least > _NEAR + _TIP_GAP_MARGIN:
                return False
        return self._contact_gap(path, t, vec)[0] < _CUT

    def _first_behind_tip(self, vec) -> int:
        """Return the first of the _SAMPLES behind a tip contact: past the contact before it."""
        modes = self._modes
        lo = self.solver.breaks_of(modes, vec)[-2] if len(modes) > 1 else 0.0
        return int(np.searchsorted(_SAMPLES, lo, side="right"))

    def _gap_behind_tip(self, pose, vec, pts, point_at, exact):
        """
        Return (value, obstacle, s): how near the whisker behind a tip contact is to its obstacle.

        The distance d(s) to the tip contact's obstacle vanishes at the tip itself, so the
        value is the least of d(s) / (1 - s) over the samples between the contact before (or
        the base) and the tip (at the tip, its limit -d1 . n, the tangential event's value),
        refined near the least sample (bounded Brent in s, to 1 - 1e-6). It is 0 where the
        whisker touches the obstacle a second time behind the tip: a touch, born apart from the
        tip (a whisker curved into the surface, its tip pressed on it, lays its side on it
        before the tip contact turns tangent). A least value at the tip itself is no touch
        (inf): that is the tangential event.
        """
        modes = self._modes
        k = modes[-1].obstacle
        ob = self.obstacles[k]
        first = self._first_behind_tip(vec)
        if first >= _SAMPLES.size - 1:
            return (math.inf, -1, 0.0)
        d = ob.signed_distance(pts[first:-1])
        g = d / (1.0 - _SAMPLES[first:-1])
        j = int(np.argmin(g))
        last = j == g.size - 1
        least = (float(g[j]), float(_SAMPLES[first + j]))

        def reduced(s):
            return float(ob.signed_distance(point_at(s)[None, :])[0]) / (1.0 - s)

        if not exact:
            if least[0] > _NEAR:
                return (least[0], k, least[1])
            if last:
                # the least sample next to the tip: where g still falls at two points in the
                # last interval (towards its limit at the tip, -d1 . n), the least value is the
                # tip's, the tangential event's, not a touch (one Brent search saved a sub-step
                # for every shallow tip contact)
                h = 1.0 - least[1]
                mid, near = reduced(1.0 - 0.5 * h), reduced(1.0 - 0.25 * h)
                if least[0] >= mid >= near > 0.0:
                    return (math.inf, -1, 0.0)
        a = float(_SAMPLES[max(first + j - 1, first)])
        b = min(float(_SAMPLES[first + j + 1]), 1.0 - 1e-6)
        res = minimize_scalar(reduced, bounds=(a, b), method="bounded",
                              options={"xatol": 1e-12, "maxiter": 200})
        value = min((float(res.fun), float(res.x)), least)
        if value[1] >= 1.0 - 2e-6:
            # the least value at the tip: no touch near it; the least sample apart from it
            if g.size < 2:
                return (math.inf, -1, 0.0)
            i = int(np.argmin(g[:-1]))
            return (float(g[i]), k, float(_SAMPLES[first + i]))
        return (value[0], k, value[1])

    def _contact_advance(self, path: _Path, t: float, h: float, events) -> Tuple[float, float]:
        tried = False  # the trusted solve from the stream's prediction failed already
        if t == 0.0 and h == 1.0:
            taken = self._plain_step(path, events)
            if taken:
                return taken
            tried = taken is False
        sol = self.solver
        pose = path.pose(t)
        tan = sol.tangent(self._solved, path.rate(pose))
        big = self._largest_change(tan)
        dt = min(1.0 - t, h, _MAX_MOVE / path.speed)
        bounded = big > 0.0 and _MAX_CHANGE / big < dt
        if bounded:
            dt = _MAX_CHANGE / big
        if (bounded and t == 0.0 and self.adapt_points and len(self._vec) < sol.size(self._modes)
                and sol.points_needed(self._modes, self._vec + tan)
                > sol.points_of(self._modes, self._vec) and self._resolve_points(full=True)):
            # a long step (sub-steps, events, folds) whose end, as the tangent predicts it,
            # would ask for more points is followed on the full count
            return self._contact_advance(path, t, h, events)
        reach = dt
        limited, left, across = self._fold_limit(path, t, tan, dt)
        near_fold, dt = limited < dt, limited
        # a fold announced within the sub-step: located at once, and the sub-step goes to
        # _H_MIN short of it (as a failed step would have located it), or None; looked for
        # once per path and contacts (where it is not found or not confirmed, the sub-steps
        # close in on it as before), and once more where the step's first announcement came
        # from the tangents of the step before (a coarser estimate)
        fold = None
        if near_fold and self._fold_sought != (path, self._modes):
            if not across:
                self._fold_sought = (path, self._modes)
            fold = self._locate_fold(path, t, tan, left, min(reach, 2.0 * left))
            if fold is None and across:
                # the step before's coarser estimate, not confirmed: dropped, and the sub-steps'
                # own tangents announce the fold where there is one (held to it, a false
                # announcement had a step crawl at 0.9 of it and double back: ~100 evaluations
                # where ~20 did)
                near_fold, dt, left = False, reach, None
        if fold is not None:
            dt = (fold[0] - _H_MIN) - t
        stream = self._extrapolate(path) if t == 0.0 and dt == 1.0 else None
        solved = None
        if (bounded and t == 0.0 and dt < 1.0 and h == 1.0 and not near_fold
                and _MAX_MOVE >= path.speed and not tried):
            # (where _plain_step's kernel failed this very solve, it is not tried again)
            solved = self._whole_step(path)
            if solved is not None:
                dt, t_new = 1.0, 1.0
        curve = (self._second_order(path, t, tan) if stream is None and left is None
                 else None)
        whole = solved is not None
        # the whole step from a prediction (the stream's, or the tangent's with the last
        # step's second-order term) is solved as trusted: Newton at once, as _plain_step's
        # kernel solves it
        predicted = t == 0.0 and (stream is not None or curve is not None)
        # a sub-step's solve gives up as soon as Newton stops contracting (fail_fast: from its
        # third step on, no step shorter than 0.9 times the one before): a shorter sub-step is
        # the remedy, and past a fold Newton would wander for ten iterations or more; only the
        # solve before a fold is called, at the shortest sub-step, is taken in full (fail_fast
        # also refuses an ill-conditioned solution whose steps level off at rounding, which
        # the stall rule takes only after five of them: sub-steps are shortened for nothing
        # there, down to that solve in full)
        in_full = False
        for _ in range(0 if whole else 64):
            self._check_budget()
            t_new = min(1.0, t + dt)
            if left is not None and t_new - t < left:
                # v = v_f + a sqrt(t_f - t) short of a fold: follow the square root, not the
                # tangent (a better guess only: ~2 Newton iterations fewer a sub-step there)
                guess = self._vec + (2.0 * left * (1.0 - math.sqrt(1.0 - (t_new - t) / left))
                                     ) * tan
            else:
                guess = self._vec + (t_new - t) * tan
            if curve is not None:
                guess = guess + (t_new - t) ** 2 * curve
            if stream is not None and t_new == 1.0:
                guess = stream
            if fold is not None:
                # v = v_f + a sqrt(t_f - t) through this solution
                t_f, v_f = fold
                guess = v_f + math.sqrt((t_f - t_new) / (t_f - t)) * (self._vec - v_f)
            try:
                if tried and predicted and t_new == 1.0:
                    # (the same solve, from the same guess, failed in _plain_step: not again)
                    tried = False
                    raise ConvergenceError("3D whisker: the trusted Newton solve failed")
                solved = sol.solve(self._modes, path.pose(t_new), guess, start=self._solved,
                                   max_step=0.5, trusted=predicted and t_new == 1.0,
                                   fail_fast=not in_full)
                # (measured against the tangent's prediction, whatever the guess was)
                if _off_branch(solved.vec, self._vec + (t_new - t) * tan, self._vec):
                    raise ConvergenceError("3D whisker: the trial step landed on another branch")
                break
            except ConvergenceError:
                fold = None  # the sub-steps go on toward it as before
                if not in_full and dt * 0.25 < _H_MIN:
                    in_full = True  # before it is called a fold: one solve in full
                    continue
                dt *= 0.25
                if dt < _H_MIN:
                    return self._snap(path, t, events, _FOLDS), 1.0
        else:
            if solved is None:
                raise ConvergenceError("the continuation step could not be shortened enough")
            try:
                # a step taken whole that a check refuses: from bounded sub-steps instead
                # (an event before its end may change the contacts first)
                self._check_features(self._modes, solved.vec, path.b)
                self._check_tail(self._modes, solved.vec, path.b)
                self._check_between(self._modes, solved.vec, path.b)
            except ModelAssumptionError:
                return t, reach
        return self._conclude(path, t, t_new, dt, tan, solved, events, fold, whole, reach)

    def _conclude(self, path, t, t_new, dt, tan, solved, events, fold=None, whole=False,
                  reach=None) -> Tuple[float, float]:
        """
        Accept a sub-step's solution at t_new, or locate the event it crossed; return (t, h).

        ``tan`` is the tangent at t, ``dt`` the sub-step, ``fold`` the located fold it stops
        short of (or None), ``whole`` a step taken whole (``reach`` the sub-step it replaced).
        """
        sol = self.solver
        self._check_features(self._modes, solved.vec, path.pose(t_new))
        values = self._event_values(path, t_new, solved.vec, solved.lu)
        crossed = [key for key, v in values.items() if v < 0.0]
        if self._touches(path, t_new, solved.vec):
            crossed.append(("touch", -1))
        if crossed and whole:
            # an event within a step taken whole: located from bounded sub-steps instead
            return t, reach
        if not crossed:
            # (after the events: one crossed in the sub-step changes the contacts before its
            # end, e.g. a tip contact turned into the surface becomes a side contact)
            self._check_tail(self._modes, solved.vec, path.pose(t_new))
            self._check_between(self._modes, solved.vec, path.pose(t_new))
            self._accept(solved, path.pose(t_new))
            if fold is not None and self._lost_beyond(path, t_new):
                # _H_MIN short of the fold, and no solution just past it: lost there
                return self._snap(path, t_new, events, _FOLDS), 1.0
            return t_new, min(1.0, 2.0 * dt)
        if ("stable", -1) in crossed:
            # short of a fold the stable branch and its unstable sibling, v_f +- a sqrt(t_f - t),
            # lie close together and Newton may land on the sibling: the determinant's sign
            # changes, but the tangent there points back (a loss of stability on one branch keeps
            # its direction). Not an event: a shorter sub-step, as for a failed trial step
            back = -sol.tangent(solved, path.rate(path.pose(t_new)))
            if float(back @ tan) > 0.0:
                if dt * 0.25 < _H_MIN:
                    return self._snap(path, t, events, _FOLDS), 1.0
                return t, 0.25 * dt
        try:
            return self._first_event(path, t, t_new, crossed, events), 1.0
        except _Unlocated:
            # the solutions between the two could not be followed from this one (a long trial
            # step may have converged to a distant branch): a shorter sub-step, as for a
            # failed trial step
            if dt * 0.25 < _H_MIN:
                raise
            return t, 0.25 * dt

    def _plain_step(self, path: _Path, events):
        """
        Take the commonest step's solve in one compiled call, or return None for the general path.

        A pose stream's next pose, within the sub-step bound, the solution predicted by
        :meth:`_extrapolate` (or, where there is no stream yet, the first steps after an
        event, by the tangent and the last step's second-order term, :meth:`_second_order`),
        contacts on spheres, cylinders and planes (no edges): the general path below would
        compute the tangent and its bound, then solve from the prediction (Newton, chord
        steps near the solution). :meth:`RodSolver.trusted_step` does both in
        one kernel call with the same operations (the same solution to the last bit), and the
        sub-step is concluded as below (:meth:`_conclude`: event values, gap, checks). Returns
        its (t, h); None where the bound would shorten the step, where the tangent announces
        a fold within it from the step before (:meth:`_fold_limit`: the general path locates
        it), or where the kernel does not apply, and False where the solve failed: nothing
        has changed, and the general path takes the step from the start (after a failed
        solve, as after its own: a shorter sub-step).
        """
        modes = self._modes
        if self._edges or not _MAX_MOVE >= path.speed:
            return None
        stream = self._extrapolate(path)
        if stream is None:
            # no stream yet (the first steps after an event): the general path's guess for
            # the whole step, the tangent and the last step's second-order term (~1e-4 away
            # on the rat's pad), solved as trusted there too; not taken whole where the bound would
            # shorten the step (the general path takes that whole from a stream only)
            if self._last_step is None or self._last_step[2] != modes:
                return None
            tan = self.solver.tangent(self._solved, path.rate(path.a))
            curve = self._second_order(path, 0.0, tan)
            if curve is None:
                return None
            guess, whole = (self._vec + 1.0 * tan) + 1.0 * curve, False
        else:
            guess, whole = stream, True
        before = self._tangent_before(path)
        try:
            taken = self.solver.trusted_step(modes, self._solved, path.rate(path.a), guess,
                                             path.b, _MAX_CHANGE, tail_cut=_TAIL_CUT,
                                             whole=whole, adapt=self.adapt_points,
                                             fold_before=None if before is None
                                             else before[2:4])
        except ConvergenceError:
            return False
        if taken is None:
            return None
        solved, tan = taken.solved, taken.tangent
        # (as _fold_limit records it at the step's start)
        self._record_tangent(path, 0.0, tan)
        # _off_branch(solved.vec, self._vec + tan, self._vec), from the kernel's measures (a
        # step taken whole is not measured so, as _contact_advance takes it)
        if not taken.whole and _beyond_branch(taken.branch_error, taken.branch_change):
            return False  # (as a failed solve: the general path takes shorter sub-steps)
        if (taken.checked and not self._crossed(path, taken)
                and not self._touches(path, 1.0, solved.vec, taken.clear)):
            # no event crossed, no touch, and the checks pass (as _conclude finds them, from
            # the same values): accepted
            self._accept(solved, path.b)
            if taken.needed:
                self._needed = (solved.vec, taken.needed)
            return 1.0, 1.0
        if taken.whole:
            # a step the bound would shorten, taken whole (_whole_step) where it crossed an
            # event or a check refuses it: the bounded sub-steps from the start, as
            # _contact_advance and _conclude with ``whole`` go on
            return 0.0, _MAX_CHANGE / self._largest_change(tan)
        return self._conclude(path, 0.0, 1.0, 1.0, tan, solved, events)

    def _crossed(self, path: _Path, taken) -> bool:
        """
        Tell whether a plain step's solution crossed an event value (as :meth:`_event_values`).

        Without a tip contact, from the kernel's values (``TrustedStep``: the least force
        and 1 - s, the stability value times the branch's sign); with one, its tangential value
        too, from :meth:`_event_values`. An event value added there must be added here too
        (test_rod3d_trusted_step.py alters the kernel's values and checks the decision).
        """
        if self.solver._config(self._modes).tips:
            solved = taken.solved
            return any(v < 0.0 for v in self._event_values(
                path, 1.0, solved.vec, solved.lu).values())
        return taken.least < 0.0 or self._sign * taken.det < 0.0

    def _resolve_points(self, full: bool = False) -> bool:
        """
        Solve the accepted solution again on the points per segment it asks for, if others.

        :meth:`RodSolver.points_needed` reads them from its Chebyshev coefficients: a light
        load, or a contact near the base, needs fewer than the tip probe's count, and a solve
        costs about the cube of the unknowns. Fewer points are taken from ~1e-11 away (one
        Newton step), and only well inside the admissible region: every event value above
        _RESOLVE_MARGIN, the new solution within _RESOLVE_JUMP of the old one (the same
        equilibrium), its checks and its gap to the other obstacles still holding. Where the
        solution asks for more, it takes them (one rung up the ladder; ``full``: the solver's
        own count, before a long step, so that its sub-steps and events are located on it),
        unless an event value of the finer solution is on the other side of its bound. The
        stream's past solutions are resampled with it, so that its predictor goes on. Returns
        whether the count changed.
        """
        sol = self.solver
        modes, vec = self._modes, self._vec
        n_now = sol.points_of(modes, vec)
        known = self._needed  # (the plain step's solution and the count it asks for)
        if full:
            n_new = sol.n
        elif known is not None and known[0] is vec:
            n_new = known[1]
        else:
            n_new = sol.points_needed(modes, vec)
        if n_new == n_now:
            return False
        finer = n_new > n_now
        path = _Path(self._pose, self._pose)
        values = self._event_values(path, 1.0, vec, self._solved.lu)
        if not finer and min(values.values()) < _RESOLVE_MARGIN:
            return False
        try:
            solved = sol.solve(modes, self._pose, sol.resample(modes, vec, n_new), trusted=True,
                               max_step=0.5, max_iterations=4)
            # the stable value keeps its sign (det J of another size may have the other)
            old, new = _det_measure(self._solved.lu), _det_measure(solved.lu)
            if old == 0.0 or new == 0.0:
                return False
            sign = self._sign * math.copysign(1.0, old) * math.copysign(1.0, new)
            after = self._event_values(path, 1.0, solved.vec, solved.lu)
            after[("stable", -1)] = sign * new
            if any((after[key] < 0.0) != (v < 0.0) for key, v in values.items()):
                return False
            if not finer:
                jump = float(np.max(np.abs(sol.resample(modes, solved.vec, n_now) - vec)))
                if (jump > max(_RESOLVE_JUMP, 10.0 * sol.points_tolerance)
                        or self._contact_gap(path, 1.0, solved.vec)[0] < min(
                            _RESOLVE_MARGIN, self._contact_gap(path, 1.0, vec)[0])):
                    return False
                self._check_tail(modes, solved.vec, self._pose)
                self._check_between(modes, solved.vec, self._pose)
        except _OverBudget:
            raise
        except (ConvergenceError, ModelAssumptionError):
            return False
        self._history = [(p, sol.resample(modes, v, n_new)) for p, v in self._history]
        if self._last_step is not None:
            p, v, m = self._last_step
            self._last_step = (p, sol.resample(modes, v, n_new), m)
        # (the tangents recorded for _fold_limit on the new points, before the vector changes)
        self._fold_prev, self._fold_before = (self._resampled_record(r, n_new)
                                              for r in (self._fold_prev, self._fold_before))
        self._sign = sign
        self._solved, self._vec = solved, solved.vec
        return True

    def _lost_beyond(self, path: _Path, t: float) -> bool:
        """
        Tell whether no solution of this branch follows 2 _H_MIN past t (just short of a fold).

        Newton from this solution, at most four iterations: where the branch goes on (it only
        passed close to a fold: the extended system may have found the fold of a neighbouring
        branch) it converges in one or two from 2e-12 away; past a fold there is no solution
        near, and it does not settle (it halves its steps for about ten iterations there).
        """
        t_past = min(1.0, t + 2.0 * _H_MIN)
        if t_past <= t:
            return True
        try:
            self.solver.solve(self._modes, path.pose(t_past), self._vec, max_step=0.5,
                              max_iterations=4)
        except _OverBudget:
            raise
        except ConvergenceError:
            return True
        return False

    def _whole_step(self, path: _Path):
        """
        Return the solution at a pose stream's next pose in one solve, or None.

        For a step whose tangent changes the unknowns by more than the sub-step bound
        (_MAX_CHANGE): solved whole from the stream's prediction (:meth:`_extrapolate`), and
        taken only where the first Newton step from it, on a fresh Jacobian, converges it: a
        step of at most 1e-7, or of at most 1e-4 followed by at most three chord steps each a
        tenth of the one before (:meth:`RodSolver.solve`, ``trusted``, one iteration: the
        prediction is then within ~1e-4 of this branch's solution); None otherwise (no
        prediction, or Newton needs more), and the bounded sub-steps follow. Where an event
        is crossed within it, the caller drops it and locates the event from bounded
        sub-steps. On the rat's pad (``bench/bench_array.py``) 30 of 46 such steps are taken
        whole: 1-2 evaluations each instead of ~7 in two sub-steps.
        """
        whole = self._extrapolate(path)
        if whole is None:
            return None
        try:
            return self.solver.solve(self._modes, path.b, whole, start=self._solved,
                                     max_step=0.5, trusted=True, fail_fast=True,
                                     max_iterations=1)
        except ConvergenceError:
            return None

    def _fold_limit(self, path: _Path, t: float, tan: np.ndarray, dt: float):
        """
        Return the sub-step shortened short of a fold the tangent announces, t_f - t, and how.

        The third value tells whether the announcement came from the tangent of the step
        before.

        Near a fold the solution goes like v_f + a sqrt(t_f - t), so 1 / norm(dv/dt)^2 falls
        linearly to 0 at t_f: two sub-steps of the same configuration along the same path give
        t_f. Aiming at 90% of the way there, the fold is approached by a factor 10 per sub-step
        instead of being found by quartering failed steps, and the trial steps there give up as
        soon as Newton stops contracting (past a fold it wanders and would spend every
        iteration). Only the sub-step length and the starting guess change, and every accepted
        sub-step is an ordinary converged solve. The announced fold is first looked for by
        its extended system (:meth:`_locate_fold`: the sub-step then goes to _H_MIN short of
        it, and a solve just past it must fail); where that does not find it, it is located
        to _H_MIN by a failed step. The distance t_f - t is None where no fold is announced
        within the sub-step.

        At a step's start the tangent before it is the last one recorded on the step before,
        where this step goes on from it (a pose stream, :meth:`_Path.continuing`; and across
        a change of the point count, its tangent resampled): a fold within the step is then
        announced before any solve past it fails, and the pose stream's trusted solve is not
        tried (:meth:`RodSolver.trusted_step` makes the same test). That estimate spans a
        whole step and is coarser: where it is not confirmed, it is dropped (the sub-step is
        not held short of it) and the fold is looked for once more from the sub-steps' own
        tangents. Only at t = 0: a sub-step tried again from the same t, or the first one
        after a touch within the step, has no tangent before it; and a change of the contacts
        forgets the recorded ones. On the rat's pad (``bench/bench_array.py``, the right
        side's 17 snaps) the snaps took 437 evaluations instead of 693.
        """
        prev = self._record_tangent(path, t, tan)
        g = self._fold_prev[3]
        across = prev is None or prev[0] is not path or not prev[2] < t
        if across:
            # none earlier on this path (_plain_step may have recorded its start): at the
            # step's start, the last on the path before; elsewhere (a sub-step tried again from
            # the same t, the first after a touch within the step) none
            prev = self._tangent_before(path) if t == 0.0 else None
        if prev is None or prev[1] != self._modes or not prev[2] < t:
            return dt, None, False
        t_prev, g_prev = prev[2], prev[3]
        if not g < 0.5 * g_prev:  # the tangent must grow markedly
            return dt, None, False
        left = g * (t - t_prev) / (g_prev - g)
        if left >= dt:
            return dt, None, False
        return (0.9 * left if 0.9 * left >= _H_MIN else 4.0 * _H_MIN), left, across

    def _record_tangent(self, path: _Path, t: float, tan: np.ndarray):
        """Record the tangent at t of ``path`` for :meth:`_fold_limit`; return the last record."""
        prev = self._fold_prev
        if prev is not None and prev[0] is not path:
            self._fold_before = prev
        self._fold_prev = (path, self._modes, t, _fold_g(tan), tan)
        return prev

    def _tangent_before(self, path: _Path):
        """Return the last tangent's record on the path before, on this path's t, or None."""
        prev = self._fold_prev
        if prev is not None and prev[0] is path:
            prev = self._fold_before
        if prev is None or prev[0] is path or prev[1] != self._modes:
            return None
        return path.continuing(prev)

    def _resampled_record(self, record, n: int):
        """Return a tangent's record with its tangent on n points per segment, or None."""
        if record is None or record[1] != self._modes or record[4].size != self._vec.size:
            return None
        tan = self.solver.resample(self._modes, record[4], n)
        return record[:3] + (_fold_g(tan), tan)

    def _locate_fold(self, path: _Path, t: float, tan: np.ndarray, left: float, reach: float):
        """
        Return the fold the tangent announces at about t + ``left``, (t_f, v_f), or None.

        Newton on the minimally extended system (Govaerts, *Numerical methods for bifurcations
        of dynamical equilibria*, SIAM 2000; MATCONT's system for limit points): R(v, t) = 0
        and g(v, t) = 0, where g is the last component of the solution of the bordered system
        [[J, psi], [phi^T, 0]] [w; g] = [0; 1] (phi, psi: the right and left null vectors of
        the Jacobian here, by inverse iteration), zero exactly where J is singular. Its
        derivatives are g_z = -u^T J_z w (u from the transposed bordered system); u^T J_v w
        and u^T J_t w are forward differences of u^T J and u^T dR/dt along w from z, whose J
        and dR/dt Newton has (J's symmetric second derivative; central ones took one more
        evaluation per iteration for the same iterations on the rat's pads, and the located
        fold only guides the sub-step). From the square root's guess (t + left,
        v + 2 left dv/dt) it converges quadratically to the fold, regular for this system, in
        3-5 iterations of two evaluations and two factorizations each, where the sub-steps
        closing in on it by a factor 10 each and the failed steps locating it to _H_MIN took
        ~120 evaluations (``bench/bench_array.py``'s snaps).

        Taken only where Newton settles, within this step and the sub-step's bounds (t < t_f
        <= 1, not closer than 2 _H_MIN, t_f - t at most ``reach``: the sub-step the bounds on
        the change and on the motion allow, and twice ``left``; the events are checked only
        at the end of the sub-step it gives), at a fold, not a bifurcation (u^T dR/dt not 0
        relative to its norms), and
        on this branch (v_f within 4 times the square root's prediction v - v_f = -2 (t_f - t)
        dv/dt of v). Newton gives up as soon as a step is not shorter than 0.3 times the one
        before (near a regular solution it contracts by far more): the tangent also grows
        where the branch passes close to a fold and goes on (on the rat's pad, ~1 in 2 of the
        announcements). Otherwise None: the sub-steps close in on it as before. Only where the
        fold is looked for changes: the caller still solves, checks and accepts an ordinary
        solution _H_MIN short of it, and snaps there only where a solve just past it fails
        (:meth:`_lost_beyond`), as the sub-steps closing in on it call a fold.
        """
        sol = self.solver
        modes = self._modes
        v = self._vec
        n = v.size
        last_border = {}

        def border(z, pose, J, dR_dt, rate):
            # g of the bordered system at (z, t) and its derivatives by forward differences
            M[:n, :n] = J
            bordered = _lu_factor(M)
            wg = _lu_solve(bordered, unit)
            w, g = wg[:n], float(wg[n])
            u = _lu_solve(bordered, unit, trans=1)[:n]
            eps = _FOLD_EPS / max(float(np.max(np.abs(w))), 1e-300)
            _, J_plus, sens_plus = sol.residual(modes, z + eps * w, pose, pose_sensitivity=True)
            last_border.update(u=u, dR_dt=dR_dt)
            return (g, (u @ J - u @ J_plus) / eps,
                    float(u @ dR_dt - u @ (sens_plus @ rate)) / eps)

        try:
            phi = _null_vector(self._solved.lu)
            psi = _null_vector(self._solved.lu, trans=1)
            M = np.zeros((n + 1, n + 1))
            M[:n, n] = psi
            M[n, :n] = phi
            unit = np.zeros(n + 1)
            unit[n] = 1.0
            found = self._bordered_newton(path, v + 2.0 * left * tan, t + left, t, 1.0, border)
        except _OverBudget:
            raise
        except (ConvergenceError, ArithmeticError, ValueError, np.linalg.LinAlgError):
            return None
        if found is None:
            return None
        z, t_f = found
        u, dR_dt = last_border["u"], last_border["dR_dt"]
        if not t + 2.0 * _H_MIN <= t_f <= 1.0 or t_f - t > reach:
            return None
        transversal = abs(float(u @ dR_dt))
        if not transversal > 1e-8 * float(np.linalg.norm(u)) * float(np.linalg.norm(dR_dt)):
            return None
        if float(np.max(np.abs(z - v))) > 4.0 * float(np.max(np.abs(2.0 * (t_f - t) * tan))):
            return None
        return t_f, z

    def _extrapolate(self, path: _Path) -> Optional[np.ndarray]:
        """
        Return the solution at the step's end extrapolated from the last ones, or None.

        A pose stream (a robot's, a log's, 1 kHz) is smooth in time: where the last k steps and
        this one are uniform enough that the poses themselves follow a polynomial of degree k
        (their (k+1)-th difference below 1 % of the step), the solutions do too, and the
        polynomial through the last k + 1 solutions predicts the next. The highest degree of
        :data:`_STREAM_ORDERS` the history and the gate allow is taken: the error goes like
        (step)^(k+1), and a rat whisking at 8 Hz sampled at 1 kHz has its next solution
        predicted to ~1e-5 by a cubic, ~2e-7 by a quintic and ~1e-8 by degree 7
        (``bench/bench_array.py``'s whiskers in contact, median), within the 1e-7 where one
        Newton step converges it (:meth:`RodSolver.solve`, ``trusted``) instead of a Newton
        step and two chord steps. Only the starting guess depends on it. Compiled
        (:func:`._jit.stream_guess`, on the history kept as arrays: a solution sums in another
        order than numpy's, ~1e-16 apart); :meth:`_extrapolate_numpy` without the kernels.

        A pose given again is kept in the history (a stream's sample: a whisk sampled
        symmetrically about its turning point gives the same pose twice, :meth:`_step`); where
        the stream is not uniform with it, it is tried once more without the repeated poses (a
        pose held or sent twice, e.g. a head pose that ticks the array between two whisks).
        """
        return self._extrapolate_by(path, self._stream_compiled if _jit.ENABLED
                                    else self._stream_numpy)

    def _extrapolate_numpy(self, path: _Path) -> Optional[np.ndarray]:
        """:meth:`_extrapolate` in numpy (without the compiled kernels; the tests' reference)."""
        return self._extrapolate_by(path, self._stream_numpy)

    def _extrapolate_by(self, path: _Path, stream_guess) -> Optional[np.ndarray]:
        """:meth:`_extrapolate` with ``stream_guess(path, history)`` for the rule itself."""
        if len(self._history) < 3 or self._last_step is None:
            return None
        guess = stream_guess(path, self._history)
        if guess is None:
            distinct = self._distinct_history()
            if distinct is not None:
                guess = stream_guess(path, distinct)
        return guess

    def _distinct_history(self):
        """Return the history without its repeated poses, if it has any and 3 others, or None."""
        history = self._history
        after = [pose for pose, _ in history[1:]] + [self._pose]
        distinct = [(pose, vec) for (pose, vec), nxt in zip(history, after) if pose != nxt]
        return distinct if len(distinct) < len(history) and len(distinct) >= 3 else None

    def _stream_compiled(self, path: _Path, history) -> Optional[np.ndarray]:
        """:meth:`_stream_numpy`'s rule in one kernel call, on the history kept as arrays."""
        v0 = self._vec
        stream = self._stream
        if history is not self._history:
            stream = _stream_arrays(history)
        elif stream is None or stream[0] is not history:
            stream = self._stream = _stream_arrays(history)
        if stream[2].shape[1] != v0.size:  # (never: the history is kept on the vector's count)
            raise ConvergenceError(f"the pose stream's history holds vectors of "
                                   f"{stream[2].shape[1]} unknowns, the solution {v0.size}")
        if not _jit.WARM:
            _jit.warm_up()
        p0, target = self._pose, path.b
        k, guess = _jit.stream_guess(stream[1], stream[2], np.array(p0.position + p0.quaternion),
                                     v0, np.array(target.position + target.quaternion),
                                     _STREAM_KERNEL[0], _STREAM_KERNEL[1], _STREAM_TOLERANCE)
        return guess if k >= 0 else None

    def _stream_numpy(self, path: _Path, history) -> Optional[np.ndarray]:
        """Return the extrapolation of ``history`` and the current solution to path.b, or None."""
        p0, v0 = self._pose, self._vec
        target = path.b
        # (p, q) of each pose, q on the side of p0's (one array: fewer numpy calls per pose)
        rw, rx, ry, rz = p0.quaternion
        rows = []
        for pose, _ in history + [(p0, v0), (target, None)]:
            w, x, y, z = q = pose.quaternion
            if w * rw + x * rx + y * ry + z * rz < 0.0:
                q = (-w, -x, -y, -z)
            rows.append(pose.position + q)
        rows = np.array(rows)
        last = rows[-1] - rows[-2]
        step = math.sqrt(float(last.dot(last)))  # (np.linalg.norm, without its wrapper)
        if step == 0.0:
            return None
        for k in _STREAM_ORDERS:
            if k + 2 > len(rows):
                continue  # too short a history yet
            c = _STREAM_WEIGHTS[k]
            diff = c @ rows[-(k + 2):]
            if math.sqrt(float(diff.dot(diff))) <= _STREAM_TOLERANCE * step:
                # the (k+1)-th difference of the solutions, target's included, vanishes
                known = np.array([v for _, v in history[-k:]] + [v0])
                return -(c[:-1] @ known)
        return None

    def _grow_history(self, pose: BasePose, vec: np.ndarray) -> None:
        """Append (pose, vec) to the stream's history, and to its arrays (:meth:`_extrapolate`)."""
        old = self._history
        self._history = (old + [(pose, vec)])[-_STREAM_HISTORY:]
        stream = self._stream
        if (_jit.ENABLED and stream is not None and stream[0] is old
                and stream[2].shape[1] == vec.size):
            row = np.array(pose.position + pose.quaternion)
            self._stream = (self._history,
                            np.concatenate((stream[1], row[None]))[-_STREAM_HISTORY:],
                            np.concatenate((stream[2], vec[None]))[-_STREAM_HISTORY:])
        else:
            self._stream = None  # (made again from the list where it is asked for)

    def _second_order(self, path: _Path, t: float, tan: np.ndarray) -> Optional[np.ndarray]:
        """
        Return the predictor's second-order term from the last step, where it continues this one.

        When the last step ended here in the same configuration and came along (nearly) the
        same line in pose space, the solution at its start, here and the tangent here fix a
        parabola in the path parameter: v(t) = v + tan t + c t^2 through v(-r) = v_last. It
        only improves the starting guess (the rat whisking at 8 Hz sampled at 1 kHz: its next
        solution within ~5e-5 instead of ~2e-4, median); nothing else depends on it.
        """
        last = self._last_step
        if t != 0.0 or last is None or last[2] != self._modes:
            return None
        pose_last, vec_last = last[0], last[1]
        rate = path.rate(path.a)
        back = np.concatenate((path.a.p - pose_last.p, path.a.q - _aligned(pose_last.q,
                                                                           path.a.q)))
        norm_rate, norm_back = float(np.linalg.norm(rate)), float(np.linalg.norm(back))
        if norm_rate == 0.0 or norm_back == 0.0:
            return None
        if float(rate @ back) < _LINE_COSINE * norm_rate * norm_back:
            return None
        r = norm_back / norm_rate
        if not 0.2 <= r <= 5.0:
            return None
        return (vec_last - self._vec + r * tan) / (r * r)

    def _largest_change(self, tan: np.ndarray) -> float:
        """
        Return the sub-step bound's measure of a change of the unknowns (its largest entry).

        Forces count relative to their size, |df| / (1 + |f|); every other unknown as it is.
        """
        a = np.abs(tan)
        vec = self._vec
        o = len(vec) - self.solver._contact_unknowns(self._modes)
        for m in self._modes:
            o += m.size
            # (as abs(tan * w) with the weight w of the force: a weight 1 changes no other)
            a[o - 1] = abs(float(tan[o - 1]) * (1.0 / (1.0 + abs(float(vec[o - 1])))))
        return float(a.max())

    def _first_event(self, path, t_a, t_b, crossed, events) -> float:
        solved_a = self._solved
        cache = {}
        # the determinant's zero is located to rounding only with the Jacobian at the solution
        # itself; the other events are values of the solution (and the Jacobian of its last
        # Newton step is as fresh as every accepted solution's)
        exact = any(key[0] == "stable" for key in crossed)

        def solution(tau):
            if tau not in cache:
                if tau == t_a:
                    cache[tau] = solved_a
                else:
                    cache[tau] = self._solve_at(path, t_a, tau, solved_a, exact)
            return cache[tau]

        best = None
        for key in crossed:
            if key[0] == "touch":
                def g(tau):
                    return self._contact_gap(path, tau, solution(tau).vec, exact=True)[0]
            else:
                def g(tau, key=key):
                    sv = solution(tau)
                    return self._event_values(path, tau, sv.vec, sv.lu)[key]
            try:
                g_a = g(t_a)
                if g_a >= 0.0:
                    t_star = None
                    linear = self._linear_event(key)
                    if linear is not None:
                        # a force or an arc length reaching its bound: located at once
                        found = self._locate_linear(path, t_a, t_b, solved_a, *linear)
                        if found is not None:
                            t_star, cache[found[0]] = found
                    if t_star is None:
                        t_star = self._root(g, t_a, t_b)
                elif g_a < -_BORN_ZERO:
                    t_star = t_a
                else:
                    # a value zero by construction at the sub-step's start (the force of a
                    # contact just touched, the tip value of a side contact just made from a
                    # tip one, ...) is negative by rounding: it is crossed there only if it
                    # is still negative just after; else its crossing is further on
                    t_probe = t_a + min(_BORN_PROBE, 0.5 * (t_b - t_a))
                    try:
                        after = g(t_probe)
                    except ConvergenceError:
                        after = -1.0  # not followed there: at the start, as before
                    t_star = t_a if after < 0.0 else self._root(g, t_probe, t_b)
            except ConvergenceError:
                continue
            if best is None or t_star < best[0]:
                best = (t_star, key)
        if best is None:
            raise _Unlocated("an event between two sub-steps could not be located")
        t_star, key = best
        if key[0] == "stable":
            # follow the branch up to the singular point, then snap
            if t_star > t_a:
                self._accept(solution(t_star), path.pose(t_star))
            return self._snap(path, t_star, events, "the equilibrium becomes unstable (the "
                              "sign of the Jacobian's determinant changes)")
        self._accept(solution(t_star), path.pose(t_star))
        return self._change(path, t_star, key, events)

    def _bordered_newton(self, path, z, t, lo, hi, border):
        """
        Return (v, t) where R(v, t) = 0 and one more equation b(v, t) = 0 hold, or None.

        Newton on the bordered Jacobian [[J, dR/dt], [db/dv, db/dt]] from (z, t) along the
        path; ``border(z, pose, J, dR/dt, rate)`` gives (b, db/dv, db/dt) there. None where t
        leaves [lo, hi], where a step is not shorter than 0.3 times the one before (not
        contracting as Newton does near a regular solution), or after _FOLD_ITERATIONS; the
        evaluations' errors pass through. For :meth:`_locate_fold` (b = g, J's singularity) and
        :meth:`_locate_linear` (b = v_i - bound).
        """
        sol = self.solver
        modes = self._modes
        n = z.size
        A = np.empty((n + 1, n + 1))
        last = math.inf
        for _ in range(_FOLD_ITERATIONS):
            self._check_budget()
            pose = path.pose(t)
            rate = path.rate(pose)
            res, J, sens = sol.residual(modes, z, pose, pose_sensitivity=True)
            dR_dt = sens @ rate
            value, A[n, :n], A[n, n] = border(z, pose, J, dR_dt, rate)
            A[:n, :n] = J
            A[:n, n] = dR_dt
            step = _lu_solve(_lu_factor(A), np.append(res, value))
            z = z - step[:n]
            t -= float(step[n])
            sol._check_breaks(modes, z)
            if not lo <= t <= hi:
                return None
            size = float(np.max(np.abs(step)))
            if size <= 1e-13 or _settled(size, last):
                return z, t
            if size > 0.3 * last:
                # not contracting as Newton does near a regular solution (for a fold: none
                # near; the tangent also grows where the branch passes close to one)
                return None
            last = size
        return None

    def _linear_event(self, key):
        """
        Return (index, bound) where an event's value is an unknown less its bound, or None.

        A release is the contact's force reaching 0, a side contact's slide to the tip its
        arc length reaching 1: both linear in the unknowns.
        """
        kind, c = key
        if kind not in ("release", "tip") or c < 0:
            return None
        o = len(self._vec) - self.solver._contact_unknowns(self._modes)
        for m in self._modes[:c]:
            o += m.size
        mode = self._modes[c]
        if kind == "release":
            return o + mode.size - 1, 0.0
        return (o, 1.0) if mode.kind == "side" else None

    def _locate_linear(self, path, t_a, t_b, solved_a, index, bound):
        """
        Return (t, solution) where the unknown ``index`` reaches ``bound`` in [t_a, t_b], or None.

        Newton on the bordered system R(v, t) = 0, v[index] = bound (its Jacobian [[J, dR/dt],
        [e_index^T, 0]]), from where the tangent at t_a reaches the bound: quadratic, 2-4
        iterations, where Brent's search on the value took 6-10 solves of ~3 evaluations each
        (a release on the rat's pad: ~25 evaluations). Given up (None: Brent's search) where it
        leaves the sub-step or does not contract as Newton does. The solution at t is then
        solved as every located event's is (its Jacobian at the solution itself).
        """
        sol = self.solver
        modes = self._modes
        tan = sol.tangent(solved_a, path.rate(path.pose(t_a)))
        value = float(solved_a.vec[index]) - bound
        slope = float(tan[index])
        tau = t_a - value / slope if slope != 0.0 else 0.5 * (t_a + t_b)
        tau = min(max(tau, t_a), t_b)
        row = np.zeros(solved_a.vec.size)
        row[index] = 1.0

        def border(z, pose, J, dR_dt, rate):
            return z[index] - bound, row, 0.0

        try:
            found = self._bordered_newton(path, solved_a.vec + (tau - t_a) * tan, tau, t_a, t_b,
                                          border)
            if found is None:
                return None
            z, tau = found
            return tau, sol.solve(modes, path.pose(tau), z, max_step=0.5, exact_jacobian=True)
        except _OverBudget:
            raise
        except (ConvergenceError, ArithmeticError, ValueError, np.linalg.LinAlgError):
            return None

    def _root(self, g, a, b):
        try:
            return float(brentq(g, a, b, xtol=_EVENT_XTOL, rtol=4 * np.finfo(float).eps,
                                maxiter=200))
        except ValueError as exc:
            raise ConvergenceError(f"an event could not be bracketed ({exc})") from None

    # -- configuration changes ----------------------------------------------------------------
    def _rebuild(self, pose, modes, breaks, forces, old_modes, old_vec):
        sol = self.solver

        def quats(s):
            return sol.quaternions(old_modes, old_vec, pose, s)

        vec = sol.guess(modes, breaks, forces, quats)
        return sol.solve(modes, pose, vec)

    def _change(self, path, t, key, events) -> float:
        """Make the configuration change ``key`` at t; return the path parameter to go on from."""
        sol = self.solver
        kind, c = key
        changed = (self._modes[c].obstacle, len(self._modes)) if c >= 0 else None
        last, self._last_change = self._last_change, (path, t, kind, changed)
        if (kind in ("tip", "tangential") and last is not None and last[0] is path
                and abs(last[1] - t) <= 1e-9 and last[3] == changed
                and {last[2], kind} == {"tip", "tangential"}):
            # side -> tip, then at once tip -> side (or the reverse) at the same pose (within
            # 1e-9 of the path, as for a snap that lands where it left; each change made only
            # where its value is still negative 1e-9 on): the side contact would pass beyond
            # the tip (s > 1) and the tip contact would cut the obstacle (d1 . n > 0), so
            # neither goes on. The equilibrium is lost there: a snap
            return self._snap(path, t, events, _SLIPS)
        pose = path.pose(t)
        if (kind == "tangential" and self._alone_on_its_obstacle(c)
                and self._tail_bend(pose) < 0.0):
            # the side contact that would follow at s = 1 has its unloaded tail curving into
            # the surface (its distance falls like d'' (s - 1)^2 / 2 < 0 as the contact moves
            # in), and the tip contact's d1 . n turns positive: the equilibrium is lost, as for
            # a slip off the tip (doc/mechanics/rod3d.md)
            return self._snap(path, t, events,
                              _CURLS.format(name=self._name(self._modes[c].obstacle)))
        modes = list(self._modes)
        breaks = list(sol.breaks_of(self._modes, self._vec))
        forces = list(sol.forces_of(self._modes, self._vec))
        before = len(modes)
        obstacle = modes[c].obstacle if c >= 0 else None
        s_event = breaks[c] if c >= 0 else None
        if kind == "release":
            del modes[c], breaks[c], forces[c]
        elif kind == "tip":
            modes[c] = RodContactMode("tip", modes[c].obstacle)
            breaks[c] = 1.0
        elif kind == "tangential":
            modes[c] = RodContactMode("side", modes[c].obstacle)
            breaks[c] = 1.0
        elif kind == "touch":
            gap, k, s = self._contact_gap(path, t, self._vec, exact=True)
            obstacle, s_event = k, s
            self._check_touch_feature(k, self.solver.centerline(self._modes, self._vec, pose,
                                                                [s])[0])
            new = RodContactMode("tip" if s >= 1.0 - 1e-9 else "side", k)
            at = int(np.searchsorted(breaks, s))
            if new.kind == "side" and at == len(breaks) and modes and modes[-1].kind == "tip":
                raise ModelAssumptionError("a side touch beyond a tip contact")
            modes.insert(at, new)
            breaks.insert(at, 1.0 if new.kind == "tip" else s)
            forces.insert(at, 0.0)
        events.append(RodEvent(kind, pose, obstacle, s_event, before, len(modes)))
        self._set_configuration(pose, tuple(modes), breaks, forces)
        return t

    def _at_tip(self, modes, vec, pose):
        """Return q(1) (as solved) and the last contact's obstacle's surface data at the tip."""
        sol = self.solver
        q = sol.quaternions(modes, vec, pose, [1.0])[0]
        tip = sol.centerline(modes, vec, pose, [1.0])[0]
        return q, self.obstacles[modes[-1].obstacle].surface(tip)

    def _tangential(self, modes, vec, pose) -> float:
        """Return -d1 . n at the tip of a last tip contact (>= 0: not turned into the surface)."""
        q, near = self._at_tip(modes, vec, pose)
        return -float(quat_matrix(q)[:, 0] @ np.asarray(near.normal))

    def _tail_bend(self, pose) -> float:
        """
        Return d''(s) at the tip of a tip contact turned tangent, for the unloaded tail beyond.

        A side contact at s_c leaves an unloaded tail whose distance to the obstacle starts as
        d''/2 (s - s_c)^2 with d'' = d1 . H d1 + kappa0 (n . d2) (the contact's tangent d1 and
        the intrinsic curvature kappa0 along d2; the obstacle's normal n and distance Hessian
        H): negative, the tail cuts the surface as soon as the contact moves in from the tip.
        """
        q, near = self._at_tip(self._modes, self._vec, pose)
        R = quat_matrix(q / np.linalg.norm(q))
        H = np.asarray(near.hessian, dtype=float)
        kappa0 = self.shape.free_frame(1.0)[3]
        d1, d2 = R[:, 0], R[:, 1]
        return float(d1 @ H @ d1 + kappa0 * (np.asarray(near.normal, dtype=float) @ d2))

    def _set_configuration(self, pose, modes, breaks, forces):
        # the tangents recorded before a change of the contacts say nothing about the branch
        # after it (even where the same contacts come back within the step)
        self._fold_prev = self._fold_before = None
        if not modes:
            self._modes, self._vec, self._solved, self._pose = (), np.zeros(0), None, pose
            return
        solved = self._rebuild(pose, modes, breaks, forces, self._modes, self._vec)
        self._check_features(modes, solved.vec, pose)
        self._modes = modes
        self._accept(solved, pose)
        self._sign = math.copysign(1.0, _det_measure(solved.lu))

    def _snap(self, path, t, events, reason) -> float:
        """
        Find where the whisker goes when its equilibrium is lost at t, and go there.

        Return the path parameter of the state it lands in: t, or t + 1e-6 (cases 1 and 3).
        """
        # the tangent before the jump says nothing about the branch after
        self._fold_prev = self._fold_before = None
        self._last_change = None  # a change after the snap is not the reverse of one before it
        if self._last_snap is not None and self._last_snap[0] is path \
                and self._last_snap[1] - 1e-9 <= t <= self._last_snap[2] + 1e-9:
            # the last snap landed back where the branch is lost (between the loss and the
            # pose it landed at): a loop, not a destination
            raise ConvergenceError(
                f"the whisker snaps at base {tuple(round(v, 6) for v in path.pose(t).position)} "
                f"({reason}) and the only equilibrium found to jump to leads straight back to "
                "the lost one: no other stable equilibrium was found")
        t_after = min(1.0, t + 1e-6)
        self._last_snap = (path, t, t_after)
        sol = self.solver
        pose = path.pose(t)
        before = len(self._modes)
        old_modes, old_vec = self._modes, self._vec
        breaks = sol.breaks_of(old_modes, old_vec)
        forces = sol.forces_of(old_modes, old_vec)
        pose_after = path.pose(t_after)
        # 1. a stable equilibrium of the same contacts, off the lost one (a bifurcated branch);
        # not at a fold, where the branch of these contacts turns back (unstable) and ends, nor
        # where a contact slips off the tip (its own branches end there)
        null = _null_vector(self._solved.lu)
        curls = reason.startswith(_CURLS_PREFIX)
        for amp in (() if reason in (_FOLDS, _SLIPS) or curls
                    else (1e-3, -1e-3, 1e-2, -1e-2, 1e-1, -1e-1)):
            try:
                solved = sol.solve(old_modes, pose_after, old_vec + amp * null, max_step=0.5)
            except ConvergenceError:
                continue
            vec = solved.vec
            if (np.max(np.abs(vec - old_vec)) > 1e-6
                    and _det_measure(solved.lu) * self._sign > 0.0
                    and min(sol.forces_of(old_modes, vec)) >= 0.0
                    and self._contact_gap_at(pose_after, old_modes, vec) >= _CUT):
                events.append(RodEvent("snap", pose, None, None, before, before, reason))
                self._accept(solved, pose_after)
                return t_after
        # 2a. a tip contact turned tangent with its tail curving into the surface: the whisker
        # lays its tail on it, a side contact behind the tip contact on the same obstacle
        if curls:
            found = self._lay_tail(pose_after, old_modes, old_vec, breaks, forces)
            if found is not None:
                modes, solved = found
                name = self._name(modes[-1].obstacle)
                events.append(RodEvent("snap", pose, None, None, before, len(modes),
                                       f"{reason}; it lands with its side and its tip on {name}"))
                self._modes = modes
                self._accept(solved, pose_after)
                self._sign = math.copysign(1.0, _det_measure(solved.lu))
                return t_after
        # 2b. drop contacts: the last ones first, then all
        k = len(old_modes)
        subsets = [tuple(i for i in range(k) if i != j) for j in reversed(range(k))] + [()]
        for keep in subsets:
            modes = tuple(old_modes[i] for i in keep)
            try:
                if not modes:
                    if self._free_gap(pose, exact=True)[0] < _CUT:
                        continue
                    events.append(RodEvent("snap", pose, None, None, before, 0, reason))
                    self._modes, self._vec, self._solved, self._pose = (), np.zeros(0), None, pose
                    return t
                solved = self._rebuild(pose, modes, [breaks[i] for i in keep],
                                       [forces[i] for i in keep], old_modes, old_vec)
            except ConvergenceError:
                continue
            if (min(sol.forces_of(modes, solved.vec)) >= 0.0
                    and self._contact_gap_at(pose, modes, solved.vec) >= _CUT):
                events.append(RodEvent("snap", pose, None, None, before, len(modes), reason))
                self._modes = modes
                self._accept(solved, pose)
                self._sign = math.copysign(1.0, _det_measure(solved.lu))
                return t
        # 3. the equilibrium reached by swinging the whisker in from out of its plane, just past
        # the loss: at the loss itself a helper coming in may arrive on the lost branch (it
        # still exists there, at its fold) and the step would snap again where it left
        if not self._nested:
            found = self._swing_in(pose_after)
            if found is not None:
                modes, solved = found
                how = "; it swings out of its plane"
                crossed = self._sides_crossed(pose, old_modes, old_vec, pose_after, modes,
                                              solved.vec)
                if crossed:
                    # the tip passed the obstacle in the jump (as a whisker flicks past a peg):
                    # the quasistatic model does not follow the jump, so which side is the
                    # first helper's that arrives, and the reason says so
                    how += f" and lands on the other side of {', '.join(crossed)}"
                events.append(RodEvent("snap", pose, None, None, before, len(modes),
                                       reason + how))
                self._modes = modes
                self._accept(solved, pose_after)
                self._sign = math.copysign(1.0, _det_measure(solved.lu))
                return t_after
        raise ConvergenceError(
            f"the whisker snaps at base {tuple(round(v, 6) for v in pose.position)} ({reason}) "
            "and no stable equilibrium was found to jump to"
        )

    def _name(self, k: int) -> str:
        return getattr(self.obstacles[k], "name", f"obstacle {k}")

    def _lay_tail(self, pose, modes, vec, breaks, forces):
        """
        Return (modes, solved) with a side contact behind the last (tip) contact, or None.

        The side contact goes on the tip contact's obstacle at 1 - eps, eps from 1e-3 to 0.3
        (the first admissible solution: both forces >= 0, no obstacle cut, the segment between
        the two contacts clear of their obstacle).
        """
        k = modes[-1].obstacle
        new = tuple(modes[:-1]) + (RodContactMode("side", k), RodContactMode("tip", k))
        lo = breaks[-2] if len(breaks) > 1 else 0.0
        f = forces[-1]
        for eps in (1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3):
            if 1.0 - eps <= lo:
                break
            try:
                solved = self._rebuild(pose, new, list(breaks[:-1]) + [1.0 - eps, 1.0],
                                       list(forces[:-1]) + [0.5 * f, 0.5 * f], modes, vec)
            except ConvergenceError:
                continue
            s_side = self.solver.breaks_of(new, solved.vec)[-2]
            if (lo < s_side < 1.0
                    and min(self.solver.forces_of(new, solved.vec)) >= 0.0
                    and self._tangential(new, solved.vec, pose) >= 0.0
                    and self._contact_gap_at(pose, new, solved.vec) >= _CUT
                    and self._touched_depth(new, solved.vec, pose)[0] >= _TAIL_CUT):
                return new, solved
        return None

    def _alone_on_its_obstacle(self, c) -> bool:
        k = self._modes[c].obstacle
        return sum(m.obstacle == k for m in self._modes) == 1

    def _sides_crossed(self, pose, modes, vec, pose_new, modes_new, vec_new):
        """Return the names of the obstacles touched before and after whose normals turned over."""
        sol = self.solver

        def normals(p, ms, v):
            pts = sol.centerline(ms, v, p, np.array(sol.breaks_of(ms, v)))
            out = {}
            for m, x in zip(ms, pts):
                out.setdefault(m.obstacle, []).append(
                    np.asarray(self.obstacles[m.obstacle].surface(x).normal, dtype=float))
            return out

        before, after = normals(pose, modes, vec), normals(pose_new, modes_new, vec_new)
        names = []
        for k in sorted(set(before) & set(after)):
            if all(float(a @ b) < 0.0 for a in before[k] for b in after[k]):
                names.append(self._name(k))
        return names

    def _swing_in(self, pose: BasePose):
        """
        Return (modes, solved) reached by turning the whisker in from a clear pose, or None.

        The base is turned about its own y axis by +-90 deg (the whisker out of its plane of
        curvature), where the unloaded whisker is clear, and turned back to ``pose`` by a helper
        tracker with the same scene: the equilibrium it arrives at is stable by construction
        (monitored on the way) and is where an out-of-plane snap lands (the +90 deg side first:
        doc/mechanics/rod3d.md, "Snaps"). Where neither arrives (each helper meets a fold of its
        own with nowhere to go), the base is turned about its z axis by +-90 deg (the whisker
        swept in within its plane, from either side of the obstacle), then about y and z by
        +-45 deg: the first helper that arrives gives the landing.
        """
        for axis, angle in _SWINGS:
            self._check_budget()  # the helpers' work counts against this step's bound
            half = 0.5 * angle
            turn = np.array([math.cos(half), 0.0, 0.0, 0.0])
            turn[axis] = math.sin(half)
            q = quat_multiply(pose.q, turn)
            start = BasePose(pose.position, tuple(q))
            helper = None
            try:
                left = self.max_evaluations - (self.solver.evaluations - self._start)
                helper = RodTracker(self.obstacles, start, shape=self.shape, n=self.solver.n,
                                    max_evaluations=max(left, 1), recover=False,
                                    adapt_points=self.adapt_points,
                                    points_tolerance=self.solver.points_tolerance)
                helper._nested = True
                helper.step(pose)
            except VibrissaError:
                continue
            finally:
                if helper is not None:
                    self.solver.evaluations += helper.solver.evaluations
            if helper._modes:
                self._check_budget()
                return helper._modes, helper._solved
        return None

    def _contact_gap_at(self, pose, modes, vec):
        pts = self.solver.centerline(modes, vec, pose, _SAMPLES)
        skip = {m.obstacle for m in modes}
        best = math.inf
        for k, ob in enumerate(self.obstacles):
            if k not in skip:
                best = min(best, float(np.min(ob.signed_distance(pts))))
        return best

    def _check_tail(self, modes, vec, pose):
        """
        Refuse an unloaded tail that cuts the obstacle its last contact touches.

        New touches are looked for on the other obstacles only; a whisker whose intrinsic
        curvature hooks its tail into the obstacle it slides on would need a second contact on
        that obstacle (not modelled): refused rather than returned inadmissible.
        """
        last = modes[-1]
        end = self.solver.breaks_of(modes, vec)[-1]
        if last.kind != "side" or end >= 1.0:
            return
        ob = self.obstacles[last.obstacle]
        post = self.solver._accepted(modes, vec, pose)
        if post is not None:
            depth = post.tail_depth
        else:
            s = end + (1.0 - end) * _TAIL_SAMPLES
            depth = float(np.min(ob.signed_distance(self.solver.centerline(modes, vec, pose, s))))
        if depth < _TAIL_CUT:
            name = getattr(ob, "name", f"obstacle {last.obstacle}")
            raise ModelAssumptionError(
                f"at base {tuple(round(float(v), 6) for v in pose.position)} the whisker's "
                f"unloaded tail beyond its contact at s = {end:.4g} would cut {name} "
                f"({-depth:.3g} L deep): a second contact on the obstacle already touched is "
                "not modelled by the 3D whisker"
            )

    def _check_between(self, modes, vec, pose):
        """
        Refuse a whisker that cuts an obstacle it touches, away from its contacts on it.

        New touches are looked for on the other obstacles (and behind a tip contact); a further
        contact on an obstacle already touched is not modelled, so the loaded part of the
        whisker is checked against each obstacle it touches at its collocation nodes (16 or more
        per segment at the default points_tolerance, 8 or more at a coarse one, so densely
        between two close contacts): refused rather than returned cutting the obstacle.
        """
        depth, where, k_cut = self._touched_depth(modes, vec, pose)
        if depth >= _TAIL_CUT:
            return
        breaks = self.solver.breaks_of(modes, vec)
        pairs = [(breaks[c], breaks[c + 1]) for c in range(len(modes) - 1)
                 if modes[c].obstacle == modes[c + 1].obstacle == k_cut]
        if any(a < where < b for a, b in pairs):
            what = "between its two contacts on one obstacle would cut it"
        else:
            what = f"would cut {self._name(k_cut)} away from its contact on it"
        raise ModelAssumptionError(
            f"at base {tuple(round(float(v), 6) for v in pose.position)} the whisker {what} "
            f"(at s = {where:.4g}, {-depth:.3g} L deep): a further contact on an obstacle already "
            "touched is not modelled by the 3D whisker"
        )

    def _touched_depth(self, modes, vec, pose):
        """
        Return (depth, s, obstacle): the least distance to an obstacle touched, at the nodes.

        The nodes are the collocation points of the loaded part (the solution's points per
        segment, 16 or more, 8 or more at a coarse points_tolerance, a segment between each two
        contacts: their positions are kept from the solve, so this costs one distance
        evaluation per obstacle touched); beyond the last contact the tail's own check samples
        it.
        """
        depth, j_cut, k_cut = math.inf, -1, -1
        post = self.solver._accepted(modes, vec, pose)
        if post is not None:
            for k, d, j in zip(post.touched, post.depth.tolist(), post.where.tolist()):
                if d < depth:
                    depth, j_cut, k_cut = d, j, k
        else:
            _, _, r_nodes, _ = self.solver._nodes(modes, vec, pose)
            for k in sorted({m.obstacle for m in modes}):
                d = self.obstacles[k].signed_distance(r_nodes)
                j = int(np.argmin(d))
                if d[j] < depth:
                    depth, j_cut, k_cut = float(d[j]), j, k
        if depth >= _TAIL_CUT:
            return depth, 0.0, k_cut
        return depth, float(self.solver.layout(modes, vec).s[j_cut]), k_cut

    def _check_touch_feature(self, k, point):
        """Refuse a touch on an edge, or within _EDGE_NEAR of one (where it is located)."""
        ob = self.obstacles[k]
        near = ob.surface(point)
        if near.feature == "edge":
            self._refuse_edge(k, point)
        # the touch's arc length is a minimum's location, known to ~1e-7: a touch that close
        # to a corner is the corner's
        for v in getattr(getattr(ob, "planar", None), "vertices", ()):
            if v.convex and math.hypot(near.point[0] - v.x, near.point[1] - v.y) <= _EDGE_NEAR:
                self._refuse_edge(k, point)

    def _refuse_edge(self, k, x):
        name = self._name(k)
        raise ModelAssumptionError(
            f"the whisker would touch an edge of {name} (a polygon's corner or a point "
            f"peg, at {tuple(round(float(v), 6) for v in x)}): contacts with edges are "
            "not modelled by the 3D whisker; round the corner (a peg with r > 0) instead"
        )

    def _check_features(self, modes, vec, pose):
        """Refuse a contact on a prism's edge (a polygon's corner, a point peg): not modelled."""
        if not self._edges:
            return
        sol = self.solver
        pts = sol.centerline(modes, vec, pose, np.array(sol.breaks_of(modes, vec)))
        for m, x in zip(modes, pts):
            if self.obstacles[m.obstacle].surface(x).feature == "edge":
                self._refuse_edge(m.obstacle, x)

    # -- states -------------------------------------------------------------------------------
    def _make_state(self) -> RodState:
        eq = self.solver.equilibrium(self._modes, self._vec, self._pose)
        contacts = []
        for m, s, f, x, F in zip(eq.modes, eq.s, eq.f, eq.points.tolist(), eq.forces.tolist()):
            name = getattr(self.obstacles[m.obstacle], "name", f"obstacle{m.obstacle}")
            contacts.append(RodContact(m.kind, m.obstacle, name, float(s), float(f), tuple(x),
                                       tuple(F)))
        return RodState(self._pose, tuple(contacts), tuple(eq.force.tolist()),
                        tuple(eq.moment.tolist()), tuple(eq.tip.tolist()),
                        tuple(eq.tip_frame[:, 0].tolist()), eq)


def _newton_minimum(ob, geometry_at, s: float, lo: float, hi: float) -> Optional[float]:
    """
    Return where the distance to ``ob`` along a curve is stationary in [lo, hi], or None.

    Newton on d'(s) = 0 from s, each iterate a local minimum's (d'' > 0); a step out of the
    bracket stops at its end, which is returned where d still falls toward it there (the
    whisker's tip touching first, say). None where d'' <= 0, or Newton has not settled to
    _MINIMUM_XTOL in _MINIMUM_ITERATIONS.
    """
    bound = None
    for _ in range(_MINIMUM_ITERATIONS):
        point, t, dt = geometry_at(s)
        sp = ob.surface(point)
        normal = np.asarray(sp.normal, dtype=float)
        d1 = float(normal @ t)
        if bound is not None and (d1 <= 0.0 if bound == hi else d1 >= 0.0):
            return bound
        d2 = float(t @ (np.asarray(sp.hessian, dtype=float) @ t)) + float(normal @ dt)
        if not (d2 > 0.0 and math.isfinite(d1)):
            return None
        step = d1 / d2
        s, bound = s - step, None
        if s > hi or s < lo:
            s = bound = hi if s > hi else lo
        elif abs(step) <= _MINIMUM_XTOL:
            return s
    return None


def _null_vector(lu, trans: int = 0) -> np.ndarray:
    """
    Return an approximate null vector of the factorized Jacobian (inverse iteration).

    With ``trans`` 1, of its transpose (a left null vector).
    """
    n = lu[0].shape[0]
    v = np.ones(n) / math.sqrt(n)
    for _ in range(3):
        w = _lu_solve(lu, v, trans=trans)
        norm = float(np.linalg.norm(w))
        if not math.isfinite(norm) or norm == 0.0:
            break
        v = w / norm
    return v / max(float(np.max(np.abs(v))), 1e-300)
