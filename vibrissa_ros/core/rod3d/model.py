"""
Equilibria of the 3D whisker (a Kirchhoff rod) with frictionless point contacts, by collocation.

Mechanics (doc/mechanics/rod3d.md; dimensionless: L = 1, EI_b = 1, world frame). The body frame
(d1, d2, d3) = R(s) is carried by a quaternion q(s) (scalar first, R(q) its rotation matrix):
d1 the tangent, d2 the direction of the intrinsic curvature. Contacts c = 1..k at arc lengths
0 < s_1 < ... < s_k <= 1 carry the forces F_c = f_c n_c of the obstacles on the whisker (n_c the
obstacle's outward normal at the contact). Without distributed loads the moment of everything
beyond s is known from the positions,

    M(s) = sum_{c: s_c > s} (r(s_c) - r(s)) x F_c                   (world components),

(the 3D form of the planar ``M(s) = sum (r_c - r) x F_c``), the constitutive law gives the body
curvature (Darboux) vector

    kappa = (m_1 / C, m_2 / B, m_3 / B + kappa0),   m = R^T M,   C = B / (1 + nu),

and the frame and the centerline follow from

    q(s) = q_base + int_0^s 1/2 q * (0, kappa) du,     r(s) = p + int_0^s d1(q) du.

Beyond the last contact the whisker is unloaded and keeps its intrinsic shape (a plane curve in
the frame at s_k, :meth:`RodShape.intrinsic_offset`). On each segment [s_(c-1), s_c] the
quaternion is discretized on n Chebyshev points with the spectral integration matrix (a global
matrix G integrates across the segments), so that the collocation equations are

    Q - q_base - G (1/2 Q * (0, kappa(Q))) = 0                         (4 N equations)

closed by each contact's geometric equations: a ``side`` contact (unknowns s_c, f_c) puts r(s_c)
on the surface (signed distance 0) with the tangent in the tangent plane (d1 . n = 0); a ``tip``
contact (unknown f_c, s_c = 1) puts the tip on the surface. Newton runs on the whole bordered
system with an analytic Jacobian, including the columns of the contact arc lengths (the
derivatives of the integration weights and of B, kappa0 at the moving nodes) and the
sensitivities to the base pose (the tracker's tangent predictor).

Unknown vector: the quaternions Q (N x 4, row-major) and then, contact by contact from the base
to the tip, (s_c, f_c) for a side contact and f_c for a tip contact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any, NamedTuple, Optional, Sequence, Tuple

import numpy as np
from scipy.linalg.lapack import dgetrf as _getrf, dgetrs as _getrs

from ..errors import ConvergenceError, ParameterError
from ..general.model import chebyshev_operators
from . import _jit
from .obstacles import Cylinder, Plane, Sphere
from .pose import BasePose, quat_matrix, quat_multiply
from .shape import RodShape

#: the fewest Chebyshev points per segment :func:`points_for` chooses
DEFAULT_SEGMENT_POINTS = 16
#: the discretization error :func:`points_for` asks for on its probe load [L]: the default
#: ``points_tolerance`` of a solver (RodSolver), which also sets its thresholds below
POINTS_TOLERANCE = 1e-11
#: the ``points_tolerance`` a solver takes: from finer than the default to a coarse 1e-6
POINTS_TOLERANCE_RANGE = (1e-12, 1e-6)
_POINTS_LADDER = (16, 20, 24, 28, 32, 36, 40, 48)
#: the rungs below the ladder a solver coarser than the default (``points_tolerance`` above
#: POINTS_TOLERANCE) may also take
_COARSE_RUNGS = (8, 10, 12, 14)
_POINTS_REFERENCE = 64
#: a solution is resolved by m points per segment (m on the ladder, below the solver's n) where
#: every Chebyshev coefficient of its quaternions from degree m - 2 up is below this (the error
#: of m points is then ~1e-12 to 1e-11, as POINTS_TOLERANCE asks of the probe load): a tenth
#: of the solver's points_tolerance, this at the default
POINTS_COARSEN = 1e-12
#: and asks for more points again where its last two coefficients exceed this (ten times
#: POINTS_COARSEN: a solution does not go back and forth between two counts): the solver's
#: points_tolerance, this at the default
POINTS_REFINE = 1e-11
KINDS = ("side", "tip")
#: no obstacle, as the kernels take obstacles (codes, parameters)
_NO_OBSTACLES = (np.zeros(0, dtype=np.int64), np.zeros((0, 7)))
_E3 = np.array([0.0, 0.0, 1.0])
_NEWTON_ITERATIONS = 30
_CHORD_ITERATIONS = 8
#: convergence: the estimated error of the unknowns (max norm)
_TOL = 1e-13
#: Newton steps this small that no longer shrink are rounding noise
_NOISE = 1e-12
#: a residual this small (max norm) holds to rounding: where the steps level off above _NOISE
#: there, they are the rounding noise of an ill-conditioned system, and the solution is taken
_ROUNDING = 1e-13
#: Newton gives up after this many iterations without a markedly shorter step
_STALL = 5
#: chord iterations stop here; the closing Newton step squares the error
_CHORD_TOL = 1e-8
#: the longest closing Newton step after a trusted guess (its error is ~C 1e-14)
_TRUSTED_STEP = 1e-7
#: up to here a first step from a trusted guess is followed by chord steps on its Jacobian
_TRUSTED_CHORD = 1e-4
#: the fractions of the unloaded part beyond the last side contact at which the tracker checks
#: that it does not cut that contact's obstacle
TAIL_SAMPLES = np.linspace(0.125, 1.0, 8)
#: how far past the tip the last contact's branch is continued (to locate side -> tip)
_S_EXTEND = 1.25


def _lu_factor(J: np.ndarray, finite: bool = False, overwrite: bool = False):
    """
    Return the LU factorization (lu, piv) of J, as scipy.linalg.lu_factor gives it.

    LAPACK's getrf directly: scipy.linalg's wrappers cost more than the factorization of these
    small matrices. A non-finite J raises ValueError (``finite``: J is known to be finite); an
    exactly singular one numpy.linalg.LinAlgError. ``overwrite``: J is not needed afterwards,
    and a J in Fortran order (the kernels') is factored in place, without a copy.
    """
    if not finite and not np.all(np.isfinite(J)):
        raise ValueError("the Jacobian has non-finite entries")
    lu, piv, info = _getrf(J, overwrite_a=int(overwrite))
    if info > 0:
        raise np.linalg.LinAlgError(f"the Jacobian is singular (pivot {info})")
    return lu, piv


def _lu_solve(lu, b: np.ndarray, trans: int = 0) -> np.ndarray:
    """Return J^-1 b (``trans`` 1: J^-T b) from :func:`_lu_factor`'s factorization (getrs)."""
    x, info = _getrs(lu[0], lu[1], b, trans=trans)
    return x


def _settled(size: float, last: float) -> bool:
    """
    Tell whether Newton has converged from its last two step sizes.

    Either quadratic convergence predicts the next step below the tolerance, or the steps have
    stopped shrinking at the rounding floor (a fine discretization's noise can sit just above
    1e-13). The prediction is trusted only from a last step of at most _TRUSTED_CHORD (1e-4):
    from farther, the steps' ratio need not be Newton's asymptotic one (a trusted solve from a
    guess 5.7e-3 away took steps of 5.7e-3 and 6.2e-7, the next predicted at 7e-15, and stopped
    8.9e-11 from the solution); there the closing chord steps (:meth:`RodSolver._polish`) go on.
    """
    if last == math.inf:
        return False
    return ((last <= _TRUSTED_CHORD and size * size * size / (last * last) <= _TOL)
            or (size <= _NOISE and size > 0.25 * last))


def _probe_tip(shape: RodShape, n: int) -> np.ndarray:
    """
    Return the tip's position and frame under the probe load.

    The probe bends the whisker across and out of its plane (0.4 L of linear deflection each)
    and twists it (0.3 rad of linear twist).
    """
    solver = RodSolver(shape, (), n=n)
    pose = BasePose((0.0, 0.0, 0.0))
    bend, turn = shape.compliance(1.0)
    f = 0.4 / bend
    couple = 0.3 / (turn * (1.0 + shape.poisson))
    vec = solver.solve_loaded(1.0, pose, (0.0, f, f), (couple, 0.0, 0.0), ramp=4)
    full = np.concatenate((vec, [1.0, 0.0]))
    modes = (RodContactMode("side", 0),)
    # numpy: a new process reaches here before its first contact, and need not wait for the
    # kernels to compile (warm_up)
    tip = solver._centerline_numpy(modes, full, pose, np.array([1.0]))[0]
    q = solver.quaternions(modes, full, pose, [1.0])[0]
    return np.concatenate((tip, quat_matrix(q / np.linalg.norm(q)).ravel()))


def warm_up() -> None:
    """
    Compile the solver's kernels now (or load them from numba's cache), once per process.

    The solver does it itself before their first use: about 10 s the first time on a machine
    (numba compiles them and caches them on disk), about 0.2 s afterwards. A program that must
    answer its first poses at once (the ROS node) calls it at start, in a thread. Nothing
    happens when VIBRISSA_NO_JIT=1 selects the numpy code (doc/mechanics/rod3d.md).

    """
    _jit.warm_up()


def _ladder(tolerance: float) -> Tuple[int, ...]:
    """Return the points per segment a solver of this ``points_tolerance`` takes, ascending."""
    return _POINTS_LADDER if tolerance <= POINTS_TOLERANCE else _COARSE_RUNGS + _POINTS_LADDER


def _points_tolerance(value) -> float:
    """Return a solver's ``points_tolerance`` as a float, or raise ParameterError."""
    lo, hi = POINTS_TOLERANCE_RANGE
    try:
        tolerance = float(value)
    except (TypeError, ValueError):
        tolerance = math.nan
    if isinstance(value, bool) or not lo <= tolerance <= hi:
        raise ParameterError(f"points_tolerance = {value!r}: need a number from {lo:g} to {hi:g} "
                             f"(the discretization error asked for, in whisker lengths; default "
                             f"{POINTS_TOLERANCE:g})")
    return tolerance


@lru_cache(maxsize=64)
def points_for(shape: RodShape, tolerance: float = POINTS_TOLERANCE) -> int:
    """
    Return the Chebyshev points per segment that resolve ``shape`` to about ``tolerance``.

    The whisker under a probe tip load (a force across it and out of its plane, 0.4 L of linear
    deflection each, and a couple twisting it by 0.3 rad) is solved on 16, 20, 24, ... points
    (from 8 at a tolerance coarser than the default) and compared with 64 points; the first
    count whose tip position and frame agree to ``tolerance`` is taken. At the default
    (:data:`POINTS_TOLERANCE`, 1e-11) a uniform or gently tapered whisker needs 16; a thin cone
    (taper < 0.1) or a strongly curved parabola (the branch points of its curvature,
    s = +-i/(4A) from the vertex, come close to the base) needs 24 to 48
    (doc/mechanics/rod3d.md). Cached per shape and tolerance.

    Parameters
    ----------
    shape : RodShape
        The whisker.
    tolerance : float, optional
        The discretization error asked for [L] (a solver's ``points_tolerance``).

    Returns
    -------
    int
        Points per segment.

    """
    try:
        reference = _probe_tip(shape, _POINTS_REFERENCE)
    except ConvergenceError:
        return _POINTS_REFERENCE
    for n in _ladder(tolerance):
        try:
            if np.max(np.abs(_probe_tip(shape, n) - reference)) <= tolerance:
                return n
        except ConvergenceError:
            continue
    return _POINTS_REFERENCE


class _Operators(NamedTuple):
    """Chebyshev collocation operators of n points (internal)."""

    x: np.ndarray           # the points on [-1, 1], ascending
    S: np.ndarray           # cumulative integration from -1 (n x n)
    Vinv: np.ndarray        # nodal values -> Chebyshev coefficients
    tau: np.ndarray         # the points mapped to [0, 1]
    int_matrix: np.ndarray  # nodal values -> their integral's Chebyshev coefficients


def _points_from_tail(n: int, most: int, above: np.ndarray, ladder=_POINTS_LADDER,
                      coarsen: float = POINTS_COARSEN, refine: float = POINTS_REFINE) -> int:
    """
    Return the points per segment a solution on n asks for (RodSolver.points_needed's rule).

    ``above[j - lo]`` is the largest Chebyshev coefficient of degree j or more (lo = the
    ``ladder``'s first rung - 2; not read where :func:`_fewest_points`), ``most`` the solver's
    own count; ``coarsen``, ``refine``: the solver's thresholds.
    """
    if _fewest_points(n, most, ladder):
        return max(n, most)
    lo = ladder[0] - 2
    if n < most and float(above[n - 2 - lo]) > refine:
        return min([m for m in ladder if n < m < most] + [most])
    for m in ladder:
        if m >= n:
            break
        if float(above[m - 2 - lo]) <= coarsen:
            return m
    return n


def _fewest_points(n: int, most: int, ladder=_POINTS_LADDER) -> bool:
    """
    Tell whether n points per segment are as few as the ladder has, or fewer (a solver made so).

    None is dropped then, and a vector of fewer than the solver's ``most`` goes to ``most``.
    """
    return n < ladder[0] or (n == ladder[0] and n >= most)


def _kernel_array(a) -> np.ndarray:
    """
    Return ``a`` as the kernels take it: float, C-contiguous and writable (copied if need be).

    A read-only array (an equilibrium's vector, a value) would make numba compile another
    version of the kernel it is passed to, in the middle of a tick.
    """
    a = np.ascontiguousarray(a, dtype=float)
    return a if a.flags.writeable else a.copy()


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """Tell whether two arrays are equal (numpy.array_equal, without its wrapper's checks)."""
    return a.shape == b.shape and bool((a == b).all())


@lru_cache(maxsize=None)
def _operators(n: int) -> _Operators:
    """Return the collocation operators of n points (one set per process, read-only)."""
    x, S, Vinv = chebyshev_operators(n)
    # nodal values -> their interpolant's integral from -1, as Chebyshev series of degree n
    C = np.polynomial.chebyshev
    cint = np.stack([C.chebint(np.eye(n)[j], lbnd=-1.0) for j in range(n)], 1)
    # (tau and the integral's matrix go to the kernels as writable arrays: numba compiles its
    # kernels once more for read-only ones; no one writes into them)
    return _Operators(x, S, Vinv, 0.5 * (x + 1.0), cint @ Vinv)


@lru_cache(maxsize=None)
def _end_row(n: int) -> np.ndarray:
    """Return the interpolation row (1, n) of a segment's end, x = 1 (as _interpolate makes it)."""
    row = np.polynomial.chebyshev.chebvander(np.array([1.0]), n - 1) @ _operators(n).Vinv
    row.setflags(write=False)
    return row


@lru_cache(maxsize=None)
def _resampler(n_old: int, n: int) -> np.ndarray:
    """Return the matrix (n, n_old) of the interpolant of n_old points at n points."""
    M = np.polynomial.chebyshev.chebvander(_operators(n).x, n_old - 1) @ _operators(n_old).Vinv
    M.setflags(write=False)
    return M


class _Config:
    """A configuration's contacts as the solver's kernels take them (internal, cached)."""

    __slots__ = ("kinds", "extra", "geometry", "touched", "tips", "plain", "others")

    def __init__(self, solver: "RodSolver", modes: Tuple["RodContactMode", ...]):
        self.kinds = np.array([m.kind == "side" for m in modes], dtype=np.int64)
        self.tips = any(m.kind == "tip" for m in modes)
        self.extra = sum(m.size for m in modes)
        # (none for contacts on no obstacle: the probe load of points_for)
        self.geometry = (kernel_obstacles([solver.obstacles[m.obstacle] for m in modes])
                         if all(m.obstacle < len(solver.obstacles) for m in modes) else None)
        # the obstacles touched, and the first contact on each
        first = {}
        for c, m in enumerate(modes):
            first.setdefault(m.obstacle, c)
        self.touched = (tuple(sorted(first)),
                        np.array([first[k] for k in sorted(first)], dtype=np.int64))
        #: the kernels' view of the scene's other obstacles (those no contact touches), whose
        #: distance to a solution the kernels bound (_Accepted.clear); None where they do not
        #: know one of them
        self.others = kernel_obstacles([ob for k, ob in enumerate(solver.obstacles)
                                        if k not in first])
        #: per points per segment, the plain step's constant arguments (RodSolver.trusted_step)
        self.plain = {}


class Solved(NamedTuple):
    """
    A converged unknown vector with its Jacobian's LU factorization and pose sensitivities.

    Both are evaluated at most one Newton step (<= 1e-8) from the solution: always fresh, since
    the sign of det J is the stability monitor and a reused Jacobian cannot see an
    out-of-plane mode that a planar iteration never excites.

    Parameters
    ----------
    vec : numpy.ndarray
        The unknown vector.
    lu : tuple of numpy.ndarray
        The Jacobian's LU factorization (scipy.linalg.lu_factor).
    sens : numpy.ndarray
        The residual's derivative with respect to the base pose (p, q) (size x 7).

    """

    vec: np.ndarray
    lu: Tuple[np.ndarray, np.ndarray]
    sens: np.ndarray


class TrustedStep(NamedTuple):
    """
    A plain continuation step taken whole (:meth:`RodSolver.trusted_step`).

    Parameters
    ----------
    solved : Solved
        The solution at the path's end.
    tangent : numpy.ndarray
        The tangent dv/dt at the path's start.
    checked : bool
        Whether the tracker's checks pass on the solution (its unloaded tail and its loaded
        part no deeper than ``tail_cut`` in the obstacles they touch).
    branch_error : float
        max |v - (v0 + tangent)|: how far the solution lies from the tangent's prediction.
    branch_change : float
        max |(v0 + tangent) - v0|: the change the tangent predicts (the same rounding as the
        tracker's branch check).
    least : float
        The least of the contacts' forces and of 1 - s of the last contact where it is a side
        contact: the tracker's event values but a tip contact's tangential one, and the
        stability value (so not all of them where a contact is at the tip).
    det : float
        sign(det J) times the geometric mean of |U_ii|; the stability monitor's event value is
        this times the branch's sign.
    clear : float
        A lower bound of the whole whisker's signed distance to the scene's obstacles that no
        contact touches (inf without any; -inf where it is not known): above 0, the tracker's
        touch test on them has nothing to find.
    needed : int
        The points per segment the solution asks for (:meth:`RodSolver.points_needed` of it;
        0: not given).
    whole : bool
        The bound would have shortened the step: taken whole (``RodSolver.trusted_step``'s
        ``whole``).

    """

    solved: "Solved"
    tangent: np.ndarray
    checked: bool
    branch_error: float
    branch_change: float
    least: float
    det: float
    clear: float = -math.inf
    needed: int = 0
    whole: bool = False


class _Accepted(NamedTuple):
    """A solution's data for the tracker's checks and state, from one kernel call (internal)."""

    points: np.ndarray      # r at the contacts (k, 3)
    normals: np.ndarray     # the obstacles' outward normals there (k, 3)
    tip: np.ndarray         # (3,)
    frame: np.ndarray       # the body frame at the tip (3, 3)
    tail_depth: float       # least distance of the tail samples to the last contact's obstacle
    touched: Tuple[int, ...]  # the obstacles touched, sorted
    depth: np.ndarray       # least distance of the nodes to each (m,)
    where: np.ndarray       # at which node (m,)
    s: Tuple[float, ...]    # the contacts' arc lengths (1 at a tip contact)
    f: Tuple[float, ...]    # their normal forces
    forces: np.ndarray      # the contact forces on the whisker (k, 3)
    force: np.ndarray       # their sum (3,)
    moment: np.ndarray      # their moment about the base point (3,)
    above: Optional[np.ndarray] = None  # points_needed's coefficient tail, where computed
    clear: float = -math.inf  # a bound of the distance to the obstacles not touched (TrustedStep)


def _accepted_of(config, points, normals, tip, frame, tail_depth, depth, where, s_c, f_c,
                 forces, force, moment, above, clear) -> _Accepted:
    """Return :func:`._jit.accepted`'s answer for a configuration as an _Accepted."""
    for arr in (points, tip, frame, forces, force, moment):
        arr.flags.writeable = False  # (shared by every equilibrium made from this entry)
    return _Accepted(points, normals, tip, frame, float(tail_depth), config.touched[0], depth,
                     where, tuple(s_c.tolist()), tuple(f_c.tolist()), forces, force, moment,
                     above, float(clear) if config.others is not None else -math.inf)


@dataclass(frozen=True)
class RodContactMode:
    """
    One contact of a configuration: which obstacle, touched by the side or by the tip.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    kind : str
        ``side`` (an interior point of the whisker, tangent to the surface) or ``tip``.
    obstacle : int
        Index of the obstacle in its scene.

    """

    kind: str
    obstacle: int

    @property
    def size(self) -> int:
        """Return the number of unknowns of the contact (side: s, f; tip: f)."""
        return 2 if self.kind == "side" else 1


def kernel_geometry(ob) -> Optional[Tuple[int, Tuple[float, ...]]]:
    """
    Return an obstacle as the compiled kernels take it, or None for one they do not know.

    Parameters
    ----------
    ob : object
        An obstacle of the scene.

    Returns
    -------
    tuple or None
        (code, 7 parameters) (:func:`._jit.surface`) of a Sphere, Cylinder or Plane, of exactly
        those types (a subclass may answer otherwise); None for any other obstacle.

    """
    kind = type(ob)
    if kind is Sphere:
        return _jit.SPHERE, tuple(ob.center) + (ob.r, 0.0, 0.0, 0.0)
    if kind is Cylinder:
        return _jit.CYLINDER, tuple(ob.point) + tuple(ob.axis) + (ob.r,)
    if kind is Plane:
        return _jit.PLANE, tuple(ob.point) + tuple(ob.normal) + (0.0,)
    return None


def kernel_obstacles(obstacles) -> Optional[Tuple[np.ndarray, np.ndarray]]:
    """
    Return obstacles as the compiled kernels take them, or None if they do not know one of them.

    Parameters
    ----------
    obstacles : sequence
        Obstacles of a scene.

    Returns
    -------
    tuple or None
        (codes (k,), parameters (k, 7)) by :func:`kernel_geometry`; None when it gives None for
        any of them.

    """
    rows = [kernel_geometry(ob) for ob in obstacles]
    if any(row is None for row in rows):
        return None
    return (np.array([row[0] for row in rows], dtype=np.int64),
            np.array([row[1] for row in rows], dtype=float).reshape(len(rows), 7))


def _skew(v: np.ndarray) -> np.ndarray:
    """[v]_x (..., 3, 3) with [v]_x w = v x w."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def _cross(a, b) -> np.ndarray:
    """Return a x b over the last axis (broadcast), without numpy.cross's overhead."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def _table(rows):
    """Index and sign tables from nested tuples of signed component names ('+w', '-x', ...)."""
    names = {"w": 0, "x": 1, "y": 2, "z": 3, "0": 4}
    flat = np.array(rows, dtype=object)
    idx = np.vectorize(lambda e: names[e[1]])(flat).astype(int)
    sgn = np.vectorize(lambda e: -1.0 if e[0] == "-" else 1.0)(flat).astype(float)
    return idx, sgn


# dR/dq_k / 2 for k = w, x, y, z (rows of R, columns of R)
_DROT = _table((
    (("+w", "-z", "+y"), ("+z", "+w", "-x"), ("-y", "+x", "+w")),
    (("+x", "+y", "+z"), ("+y", "-x", "-w"), ("+z", "+w", "-x")),
    (("-y", "+x", "+w"), ("+x", "+y", "+z"), ("-w", "+z", "-y")),
    (("-z", "-w", "+x"), ("+w", "-z", "+y"), ("+x", "+y", "+z")),
))
# Lv(q): q * (0, v) = Lv(q) v
_LEFT = _table((("-x", "-y", "-z"), ("+w", "-z", "+y"), ("+z", "+w", "-x"), ("-y", "+x", "+w")))
# Rm(k): q * (0, k) = Rm(k) q, from (k1, k2, k3) stored as x, y, z (w unused, '0' = zero)
_RIGHT = _table((("+0", "-x", "-y", "-z"), ("+x", "+0", "+z", "-y"),
                 ("+y", "-z", "+0", "+x"), ("+z", "+y", "-x", "+0")))


def _drot(Q: np.ndarray) -> np.ndarray:
    """dR/dq_k for quaternions Q (N, 4): shape (N, 4, 3, 3)."""
    idx, sgn = _DROT
    return 2.0 * Q[:, idx] * sgn


def _left_vector(Q: np.ndarray) -> np.ndarray:
    """Lv(q) (N, 4, 3) with q * (0, v) = Lv(q) v."""
    idx, sgn = _LEFT
    return Q[:, idx] * sgn


def _right_pure(K: np.ndarray) -> np.ndarray:
    """Rm(k) (N, 4, 4) with q * (0, k) = Rm(k) q."""
    idx, sgn = _RIGHT
    padded = np.zeros((K.shape[0], 5))
    padded[:, 1:4] = K
    return padded[:, idx] * sgn


def _turns_about_d3(phi) -> np.ndarray:
    """Return the quaternions (m, 4) of turns by angles phi (m,) about the body's d3 axis."""
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    rot = np.zeros((phi.size, 4))
    rot[:, 0] = np.cos(0.5 * phi)
    rot[:, 3] = np.sin(0.5 * phi)
    return rot


def _tangents(Q: np.ndarray) -> np.ndarray:
    """Return d1 = R(q) e1 (N, 3) of quaternions (N, 4): R's first column only."""
    w, x, y, z = Q[:, 0], Q[:, 1], Q[:, 2], Q[:, 3]
    out = np.empty((Q.shape[0], 3))
    out[:, 0] = w * w + x * x - y * y - z * z
    out[:, 1] = 2.0 * (x * y + w * z)
    out[:, 2] = 2.0 * (x * z - w * y)
    return out


def _rotations(Q: np.ndarray) -> np.ndarray:
    """R(q) (N, 3, 3) of quaternions (N, 4) (the unit-quaternion formula)."""
    w, x, y, z = Q[:, 0], Q[:, 1], Q[:, 2], Q[:, 3]
    R = np.empty((Q.shape[0], 3, 3))
    ww, xx, yy, zz = w * w, x * x, y * y, z * z
    xy, xz, yz, wx, wy, wz = x * y, x * z, y * z, w * x, w * y, w * z
    R[:, 0, 0] = ww + xx - yy - zz
    R[:, 0, 1] = 2.0 * (xy - wz)
    R[:, 0, 2] = 2.0 * (xz + wy)
    R[:, 1, 0] = 2.0 * (xy + wz)
    R[:, 1, 1] = ww - xx + yy - zz
    R[:, 1, 2] = 2.0 * (yz - wx)
    R[:, 2, 0] = 2.0 * (xz - wy)
    R[:, 2, 1] = 2.0 * (yz + wx)
    R[:, 2, 2] = ww - xx - yy + zz
    return R


class _Layout:
    """
    Nodes and integration matrices of one set of segment ends (internal).

    ``breaks`` = (s_1, ..., s_k) the segment ends (the last one is s_k <= 1). Node j of segment
    c = [a, b] sits at s(tau_j), tau the Chebyshev points mapped to [0, 1]: s = a + (b - a) tau
    for a cylinder, and for a cone s_p - s = (s_p - a) exp(tau L), L = log((s_p - b)/(s_p - a)),
    with s_p = 1 / (1 - taper) (where B would vanish): then B(s(tau)) is exp(4 tau L) times a
    constant, an entire function of tau, and the thin tip's boundary layer costs no extra points
    (the planar general solver's map). ``w`` = ds/dtau at the nodes: G = T diag(w).
    """

    __slots__ = ("breaks", "n", "k", "N", "s", "w", "G", "ends", "tau", "a", "b", "L", "sp",
                 "T")

    def __init__(self, solver: "RodSolver", breaks: Sequence[float], n: Optional[int] = None):
        n = solver.n if n is None else n
        self.breaks = tuple(float(v) for v in breaks)
        self.n, self.k = n, len(self.breaks)
        self.N = n * self.k
        self.a = np.array((0.0,) + self.breaks[:-1])
        self.b = np.array(self.breaks)
        self.tau = tau = _operators(n).tau
        self.sp = solver._sp
        a = self.a[:, None]
        if self.sp is None:
            self.L = None
            h = (self.b - self.a)[:, None]
            self.s = (a + h * tau).ravel()
            self.w = np.broadcast_to(h, (self.k, n)).ravel()
        else:
            sp = self.sp
            self.L = np.log((sp - self.b) / (sp - self.a))
            L = self.L[:, None]
            gap = (sp - a) * np.exp(tau * L)
            self.s = (sp - gap).ravel()
            self.w = (-L * gap).ravel()
        self.T = solver._template(self.k, n)
        self.G = self.T * self.w[None, :]
        self.ends = np.arange(1, self.k + 1) * n - 1

    def _parts(self, c: int):
        """Slices and per-node quantities of the segments that end (c) and start (c+1) at s_c."""
        n = self.n
        right = slice(c * n, (c + 1) * n)
        left = slice((c + 1) * n, (c + 2) * n) if c + 1 < self.k else None
        return right, left

    def ds(self, c: int) -> np.ndarray:
        """Return d s_i / d s_c at the nodes."""
        out = np.zeros(self.N)
        right, left = self._parts(c)
        tau = self.tau
        if self.sp is None:
            out[right] = tau
            if left is not None:
                out[left] = 1.0 - tau
            return out
        sp = self.sp
        out[right] = tau * (sp - self.s[right]) / (sp - self.b[c])
        if left is not None:
            out[left] = (1.0 - tau) * (sp - self.s[left]) / (sp - self.a[c + 1])
        return out

    def dw(self, c: int) -> np.ndarray:
        """Return d w_i / d s_c at the nodes."""
        out = np.zeros(self.N)
        right, left = self._parts(c)
        if self.sp is None:
            out[right] = 1.0
            if left is not None:
                out[left] = -1.0
            return out
        sp, tau = self.sp, self.tau
        out[right] = (sp - self.s[right]) * (1.0 + self.L[c] * tau) / (sp - self.b[c])
        if left is not None:
            out[left] = ((sp - self.s[left]) * (-1.0 + self.L[c + 1] * (1.0 - tau))
                         / (sp - self.a[c + 1]))
        return out

    def dG(self, solver: "RodSolver", c: int) -> np.ndarray:
        """Return dG / d s_c (the end of segment c moves; the next segment's start with it)."""
        return self.T * self.dw(c)[None, :]

    def locate(self, s: np.ndarray):
        """Segment index and local coordinate x in [-1, 1] of arc lengths s (<= the last end)."""
        c = np.minimum(np.searchsorted(self.b, s), self.k - 1)
        a, b = self.a[c], self.b[c]
        if self.sp is None:
            tau = (s - a) / (b - a)
        else:
            tau = np.log((self.sp - s) / (self.sp - a)) / self.L[c]
        return c, np.clip(2.0 * tau - 1.0, -1.0, 1.0)


@dataclass(frozen=True)
class RodEquilibrium:
    """
    A converged equilibrium of one configuration (immutable; the tracker's state holds one).

    The parameters are the dataclass's fields, kept as attributes of the same names (world
    frame, dimensionless).

    Parameters
    ----------
    pose : BasePose
        The base pose.
    modes : tuple of RodContactMode
        The contacts from the base to the tip.
    vec : numpy.ndarray
        The unknown vector (quaternions, then the contacts' unknowns).
    s : tuple of float
        The contacts' arc lengths.
    f : tuple of float
        The contacts' normal forces (>= 0 when admissible).
    points : numpy.ndarray
        The contact points (k, 3).
    forces : numpy.ndarray
        The contact forces on the whisker (k, 3).
    force : numpy.ndarray
        The total contact force (3,).
    moment : numpy.ndarray
        The moment of the contact forces about the base point (3,).
    tip : numpy.ndarray
        The tip's position (3,).
    tip_frame : numpy.ndarray
        The body frame at the tip (3, 3), columns (d1, d2, d3).
    solver : object, optional
        The solver (internal: it samples the centerline).

    """

    pose: BasePose
    modes: Tuple[RodContactMode, ...]
    vec: np.ndarray = field(repr=False)
    s: Tuple[float, ...]
    f: Tuple[float, ...]
    points: np.ndarray
    forces: np.ndarray
    force: np.ndarray
    moment: np.ndarray
    tip: np.ndarray
    tip_frame: np.ndarray
    solver: Any = field(default=None, compare=False, repr=False)

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
        return self.solver.centerline(self.modes, self.vec, self.pose, s)

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
        return quat_matrix(self.solver.quaternions(self.modes, self.vec, self.pose, s))


class RodSolver:
    """
    Collocation solver of the 3D whisker's equilibria (see the module's docstring).

    Parameters
    ----------
    shape : RodShape
        The whisker.
    obstacles : sequence
        The scene's 3D obstacles (objects with ``surface(point)`` and ``signed_distance``).
    n : int, optional
        Chebyshev points per segment; default :func:`points_for` the shape (at
        ``points_tolerance``). New configurations start from it; a vector of fewer
        (:meth:`points_needed`, :meth:`resample`) is solved on its own count, read from its
        length.
    points_tolerance : float, optional
        The discretization error asked for [L], in :data:`POINTS_TOLERANCE_RANGE`: the default
        :data:`POINTS_TOLERANCE` (1e-11) resolves the whisker to about the solver's own
        convergence (1e-13 on the unknowns); a coarser one takes fewer points per segment
        (:func:`points_for`, :meth:`points_needed`: coefficients dropped below a tenth of it,
        points added above it, from 8 points up), for speed. On the rat's pad whisking against
        a peg, 1e-9 and 1e-8 moved the base wrenches by ~3e-11 of their largest value, with
        the same events (doc/benchmarks.md).

    Attributes
    ----------
    evaluations : int
        Residual evaluations so far (with or without the Jacobian).
    factorizations : int
        LU factorizations of the Jacobian so far (the costliest part of a step).

    Raises
    ------
    ParameterError
        When ``n`` is below 8, or ``points_tolerance`` is not a number in its range.

    """

    def __init__(self, shape: RodShape, obstacles: Sequence[Any] = (),
                 n: Optional[int] = None, points_tolerance: float = POINTS_TOLERANCE):
        tolerance = _points_tolerance(points_tolerance)
        if n is None:
            n = points_for(shape, tolerance)
        if int(n) < 8:
            raise ParameterError(f"collocation points per segment n = {n}: need at least 8")
        #: the discretization error asked for, and the point counts and thresholds it sets
        self.points_tolerance = tolerance
        self._ladder = _ladder(tolerance)
        self._coarsen = POINTS_COARSEN * (tolerance / POINTS_TOLERANCE)
        self._refine = POINTS_REFINE * (tolerance / POINTS_TOLERANCE)
        self.shape = shape
        self.obstacles = tuple(obstacles)
        self.n = int(n)
        self._templates = {}
        self._configs = {}
        self._config_last = None
        ops = _operators(self.n)
        self._x, self._S, self._Vinv = ops.x, ops.S, ops.Vinv
        self._tau, self._int_matrix = ops.tau, ops.int_matrix
        self._nu1 = 1.0 + shape.poisson
        self._sp = None if shape.taper == 1.0 else 1.0 / (1.0 - shape.taper)
        self.evaluations = 0
        self.factorizations = 0
        self._free_tip_cache = None
        self._nodes_cache = None
        self._accepted_cache = None
        self._chord_rate = 1.0
        self._identity_columns = {}
        # the compiled kernels' view of the shape (vibrissa_ros.core.rod3d._jit)
        self._finite_jacobian = None
        self._jit_sp = -1.0 if self._sp is None else float(self._sp)
        if shape.parabola is not None:
            self._jit_grid, self._jit_table = shape._u_table()
        else:
            self._jit_grid = self._jit_table = np.zeros(2)
        self._jit_shape = np.array((shape.taper, self._nu1, shape.k0, shape.k1,
                                    shape.parabola or 0.0, float(shape.parabola is not None)))

    # -- operators ----------------------------------------------------------------------------
    def _template(self, k: int, n: Optional[int] = None) -> np.ndarray:
        """G for unit segment lengths (N x N), k segments of n points (default: the solver's)."""
        n = self.n if n is None else n
        T = self._templates.get((n, k))
        if T is None:
            T = np.zeros((n * k, n * k))
            half = 0.5 * _operators(n).S
            for c in range(k):
                rows = slice(c * n, (c + 1) * n)
                T[rows, c * n:(c + 1) * n] = half
                for cp in range(c):
                    T[rows, cp * n:(cp + 1) * n] = half[-1]
            T.setflags(write=False)
            self._templates[(n, k)] = T
        return T

    def layout(self, modes: Sequence[RodContactMode], vec: np.ndarray) -> _Layout:
        """Return the segment layout of a configuration at its unknown vector (internal)."""
        return _Layout(self, self.breaks_of(modes, vec), self.points_of(modes, vec))

    def size(self, modes: Sequence[RodContactMode], n: Optional[int] = None) -> int:
        """
        Return the number of unknowns of a configuration.

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts from the base to the tip.
        n : int, optional
            Points per segment; default the solver's.

        Returns
        -------
        int
            4 N + the contacts' unknowns.

        """
        return 4 * (self.n if n is None else n) * len(modes) + self._contact_unknowns(modes)

    def _contact_unknowns(self, modes) -> int:
        """Return the number of the contacts' own unknowns (s_c, f_c or f_c each), cached."""
        return self._config(modes).extra

    def points_of(self, modes: Sequence[RodContactMode], vec: np.ndarray) -> int:
        """
        Return the points per segment of an unknown vector (its length tells them).

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts (at least one).
        vec : numpy.ndarray
            The unknown vector.

        Returns
        -------
        int
            n, with len(vec) = 4 n k + the contacts' unknowns.

        Raises
        ------
        ParameterError
            When no n fits the vector's length.

        """
        k = len(modes)
        n, rest = divmod(len(vec) - self._config(modes).extra, 4 * k) if k else (0, 1)
        if rest or n < 2:
            raise ParameterError(
                f"an unknown vector of {len(vec)} values does not fit {k} contacts "
                "(4 n per contact's segment and the contacts' own unknowns)")
        return n

    def breaks_of(self, modes, vec) -> Tuple[float, ...]:
        """Return the contacts' arc lengths from an unknown vector."""
        out = []
        o = len(vec) - self._config(modes).extra
        for m in modes:
            if m.kind == "side":
                out.append(float(vec[o]))
            else:
                out.append(1.0)
            o += m.size
        return tuple(out)

    def forces_of(self, modes, vec) -> Tuple[float, ...]:
        """Return the contacts' normal forces from an unknown vector."""
        out = []
        o = len(vec) - self._config(modes).extra
        for m in modes:
            out.append(float(vec[o + m.size - 1]))
            o += m.size
        return tuple(out)

    # -- the equations ------------------------------------------------------------------------
    def residual(self, modes: Sequence[RodContactMode], vec: np.ndarray, pose: BasePose,
                 jacobian: bool = True, pose_sensitivity: bool = False):
        """
        Return the collocation and contact residual, and optionally its Jacobian.

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts from the base to the tip (at least one).
        vec : numpy.ndarray
            The unknown vector.
        pose : BasePose
            The base pose.
        jacobian : bool, optional
            Also return d residual / d vec.
        pose_sensitivity : bool, optional
            Also return d residual / d (p, q_base) (size x 7).

        Returns
        -------
        tuple
            (residual, Jacobian or None, pose sensitivity or None).

        """
        if _jit.ENABLED:
            return self._residual_compiled(modes, vec, pose, jacobian, pose_sensitivity)
        return self._residual_numpy(modes, vec, pose, jacobian, pose_sensitivity)

    def _config(self, modes) -> "_Config":
        """
        Return what the solver keeps of a configuration (its kinds, sizes, obstacles), cached.

        The last one asked for is answered first by identity: a tracker passes the same tuple
        of modes for every evaluation of a configuration, and hashing its modes costs more
        than the lookups themselves.
        """
        last = self._config_last  # (modes, config): one read, consistent across threads
        if last is not None and modes is last[0]:
            return last[1]
        key = modes if isinstance(modes, tuple) else tuple(modes)
        config = self._configs.get(key)
        if config is None:
            config = self._configs[key] = _Config(self, key)
        if type(modes) is tuple:
            self._config_last = (modes, config)
        return config

    def _kinds_of(self, modes) -> np.ndarray:
        """Return the contacts' kinds as the kernels take them (1 side, 0 tip), cached."""
        return self._config(modes).kinds

    def _geometry_of(self, modes):
        """
        Return the kernels' view (codes (k,), parameters (k, 7)) of the contacts' obstacles.

        None unless every one is a Sphere, Cylinder or Plane (exactly: a subclass may answer
        otherwise); cached per configuration.
        """
        return self._config(modes).geometry

    def _residual_compiled(self, modes, vec, pose, jacobian, pose_sensitivity):
        """:meth:`residual` by the compiled kernels (:mod:`._jit`)."""
        if not _jit.WARM:
            _jit.warm_up()
        self.evaluations += 1
        k = len(modes)
        n = self.points_of(modes, vec)
        tau = _operators(n).tau
        kinds = self._kinds_of(modes)
        vec = _kernel_array(vec)
        T = self._template(k, n)
        geometry = self._geometry_of(modes)
        if geometry is not None:
            # analytic obstacles: their surface data computed in the same kernel call
            res, J, sens, finite = _jit.evaluate(
                vec, pose.q, n, kinds, tau, self._jit_sp, T, pose.p, self._jit_shape,
                self._jit_grid, self._jit_table, self._nu1, geometry[0], geometry[1], jacobian,
                pose_sensitivity)
        else:
            s, w, ds, dw, kinv, kap0, slope, dkinv, r = _jit.prepare(
                vec, n, kinds, tau, self._jit_sp, T, pose.p, self._jit_shape,
                self._jit_grid, self._jit_table)
            dist = np.empty(k)
            normal = np.empty((k, 3))
            hess = np.empty((k, 3, 3))
            for c, m in enumerate(modes):
                sp = self.obstacles[m.obstacle].surface(r[(c + 1) * n - 1])
                dist[c] = sp.distance
                normal[c] = sp.normal
                hess[c] = sp.hessian
            res, J, sens, finite = _jit.equations(vec, pose.q, n, kinds, T, w, ds, dw, kinv,
                                                  kap0, slope, dkinv, r, self._nu1, dist, normal,
                                                  hess, jacobian, pose_sensitivity)
        if finite:
            # checked by the kernel: _lu_factor need not look again
            self._finite_jacobian = J
        return res, (J if jacobian else None), (sens if pose_sensitivity else None)

    def _residual_numpy(self, modes, vec, pose, jacobian=True, pose_sensitivity=False):
        """:meth:`residual` in numpy: the reference the compiled kernels are tested against."""
        self.evaluations += 1
        k = len(modes)
        lay = self.layout(modes, vec)
        N, G, ends = lay.N, lay.G, lay.ends
        Q = vec[:4 * N].reshape(N, 4)
        R = _rotations(Q)
        D1 = R[:, :, 0]
        r = pose.p + G @ D1
        kinv, kap0, kap0_slope = self._stiffness(lay.s, slopes=jacobian)
        fs, surf, F = [], [], []
        o = 4 * N
        for c, m in enumerate(modes):
            f = float(vec[o + m.size - 1])
            sp = self.obstacles[m.obstacle].surface(r[ends[c]])
            fs.append(f)
            surf.append(sp)
            F.append(f * np.asarray(sp.normal, dtype=float))
            o += m.size
        M = self._moments(r, ends, F)
        kap, Lv, g = self._curvature(Q, R, M, kinv, kap0)
        res = np.empty(self.size(modes, lay.n))
        res[:4 * N] = (Q - pose.q - G @ g).ravel()
        o = 4 * N
        for c, m in enumerate(modes):
            res[o] = surf[c].distance
            if m.kind == "side":
                res[o + 1] = D1[ends[c]] @ np.asarray(surf[c].normal, dtype=float)
            o += m.size
        if not jacobian and not pose_sensitivity:
            return res, None, None
        dR = _drot(Q)                                   # (N, 4, 3, 3)
        D = dR[:, :, :, 0].transpose(0, 2, 1)          # dd1/dq (N, 3, 4)
        Dcat = D.transpose(1, 0, 2).reshape(3, 4 * N)  # columns (j, k)
        P = 0.5 * Lv * kinv[:, None, :]                # (N, 4, 3): dg/dkappa
        PRt = np.matmul(P, R.transpose(0, 2, 1))       # P R^T (N, 4, 3): dg/dM
        n_unk = res.size
        J = np.zeros((n_unk, n_unk)) if jacobian else None
        sens = np.zeros((n_unk, 7)) if pose_sensitivity else None
        Hs = [np.asarray(sp.hessian, dtype=float) for sp in surf]
        ns = [np.asarray(sp.normal, dtype=float) for sp in surf]
        dM_dp = np.zeros((N, 3, 3))                      # dM_i / dp
        for c in range(k):
            e = ends[c] + 1
            dM_dp[:e] += fs[c] * np.matmul(_skew(r[ends[c]] - r[:e]), Hs[c])
        if jacobian:
            dg = self._dg(Q, R, M, kap, P, PRt, dR, Dcat, G, r, ends, F, fs, Hs, dM_dp)
            J[:4 * N, :4 * N] = -(G @ dg.reshape(N, 16 * N)).reshape(4 * N, 4 * N)
            J[np.arange(4 * N), np.arange(4 * N)] += 1.0
        o = 4 * N
        for c, m in enumerate(modes):
            e = ends[c] + 1
            H, nrm = Hs[c], ns[c]
            if jacobian:
                # column f_c
                dM = np.zeros((N, 3))
                dM[:e] = _cross(r[ends[c]] - r[:e], nrm)
                J[:4 * N, o + m.size - 1] = -(G @ np.matmul(PRt, dM[:, :, None])[:, :, 0]
                                              ).ravel()
                # rows: distance and tangency, d/dQ
                ge = G[ends[c]]
                J[o, :4 * N] = ((nrm @ D) * ge[:, None]).ravel()
                if m.kind == "side":
                    row = ((H @ D1[ends[c]]) @ D) * ge[:, None]
                    row[ends[c]] += nrm @ D[ends[c]]
                    J[o + 1, :4 * N] = row.ravel()
            if sens is not None:
                sens[o, :3] = nrm
                if m.kind == "side":
                    sens[o + 1, :3] = H @ D1[ends[c]]
            o += m.size
        if jacobian:
            o = 4 * N
            shared = None
            for c, m in enumerate(modes):
                if m.kind == "side":
                    if shared is None:
                        shared = self._moving_nodes(lay, R, M, kinv, Lv, kap0_slope)
                    J[:, o] = self._break_column(lay, c, modes, D1, r, F, fs, Hs, ns, g, PRt,
                                                 shared)
                o += m.size
        if sens is not None:
            sens[:4 * N, :3] = -(G @ np.matmul(PRt, dM_dp).reshape(N, 12)).reshape(4 * N, 3)
            cols = self._identity_columns.get(N)
            if cols is None:
                cols = self._identity_columns[N] = -np.tile(np.eye(4), (N, 1))
            sens[:4 * N, 3:] = cols
        return res, J, sens

    def _stiffness(self, s, slopes: bool = False):
        """(1/C, 1/B, 1/B) (N, 3) and kappa0 (N,) at arc lengths s (and d kappa0/ds)."""
        B = self.shape.stiffness(s)
        kinv = np.empty((s.size, 3))
        kinv[:, 1] = 1.0 / B
        kinv[:, 2] = kinv[:, 1]
        kinv[:, 0] = self._nu1 * kinv[:, 1]
        if slopes:
            kap0, slope = self.shape.curvature_and_slope(s)
            return kinv, kap0, slope
        return kinv, self.shape.curvature(s), None

    @staticmethod
    def _moments(r, ends, F, tip_moment=None):
        """M(s_i) = sum_c [s_i <= s_c] (r_c - r_i) x F_c (+ a moment applied at the end)."""
        M = np.zeros_like(r)
        for e, Fc in zip(ends, F):
            M[:e + 1] += _cross(r[e] - r[:e + 1], Fc)
        if tip_moment is not None:
            M += tip_moment
        return M

    @staticmethod
    def _curvature(Q, R, M, kinv, kap0):
        """Body curvature kappa (N, 3), Lv(q) and g = 1/2 q * (0, kappa) (N, 4)."""
        mb = np.matmul(M[:, None, :], R)[:, 0, :]        # R^T M
        kap = kinv * mb
        kap[:, 2] += kap0
        Lv = _left_vector(Q)
        g = 0.5 * np.matmul(Lv, kap[:, :, None])[:, :, 0]
        return kap, Lv, g

    @staticmethod
    def _dg(Q, R, M, kap, P, PRt, dR, Dcat, G, r, ends, F, fs, Hs, dM_dp):
        """Return d g_i / d q_j (N, 4, N, 4) (dense: the moments depend on every position)."""
        N = Q.shape[0]
        T = np.einsum("ikab,ia->ibk", dR, M)            # d(R^T M)/dq (N, 3, 4)
        diag = 0.5 * _right_pure(kap) + np.matmul(P, T)
        dg = np.zeros((N, 4, N, 4))
        PR2 = PRt.reshape(4 * N, 3)
        for c, e in enumerate(ends):
            e1 = e + 1
            ge = G[e]
            X = _skew(F[c])
            # -(r_c - r_i) x F = [F]_x (r_c - r_i): d/dq_j = [F]_x (G_cj - G_ij) D_j, negated
            A = (PR2[:4 * e1] @ (X @ Dcat)).reshape(e1, 4, N, 4)
            w1 = ge[None, :] - G[:e1]
            dg[:e1] -= A * w1[:, None, :, None]
            if fs[c] != 0.0:
                # (r_c - r_i) x f H dr_c: the normal turns with the contact point
                PY = np.matmul(PRt[:e1], fs[c] * np.matmul(_skew(r[e] - r[:e1]), Hs[c]))
                B2 = (PY.reshape(4 * e1, 3) @ Dcat).reshape(e1, 4, N, 4)
                dg[:e1] += B2 * ge[None, None, :, None]
        idx = np.arange(N)
        dg[idx, :, idx, :] += diag
        return dg

    def _break_column(self, lay, c, modes, D1, r, F, fs, Hs, ns, g, PRt, shared):
        """Return d residual / d s_c (analytic: moving nodes and integration weights)."""
        N = lay.N
        dG = lay.dG(self, c)
        ds = lay.ds(c)
        dr = dG @ D1                                        # dr_i / ds_c (N, 3)
        dM = np.zeros((N, 3))
        for cp in range(len(modes)):
            e = lay.ends[cp] + 1
            drc = dr[lay.ends[cp]]
            dF = fs[cp] * (Hs[cp] @ drc)
            dM[:e] += _cross(drc - dr[:e], F[cp]) + _cross(r[lay.ends[cp]] - r[:e], dF)
        # the moment's change (through P R^T) and the stiffness' and curvature's at moved nodes
        dg = np.matmul(PRt, dM[:, :, None])[:, :, 0] + shared * ds[:, None]
        col = np.empty(self.size(modes, lay.n))
        col[:4 * N] = -(dG @ g + lay.G @ dg).ravel()
        o = 4 * N
        for cp, m in enumerate(modes):
            drc = dr[lay.ends[cp]]
            col[o] = ns[cp] @ drc
            if m.kind == "side":
                col[o + 1] = D1[lay.ends[cp]] @ (Hs[cp] @ drc)
            o += m.size
        return col

    def _moving_nodes(self, lay, R, M, kinv, Lv, kap0_slope):
        """Return dg/ds at the nodes with M held (B and kappa0 at a moved node), (N, 4)."""
        sh = self.shape
        mb = np.matmul(M[:, None, :], R)[:, 0, :]
        dkinv = -sh.stiffness_slope(lay.s) * kinv[:, 1] ** 2
        dkap = np.empty_like(mb)
        dkap[:, 0] = self._nu1 * dkinv * mb[:, 0]
        dkap[:, 1] = dkinv * mb[:, 1]
        dkap[:, 2] = dkinv * mb[:, 2] + kap0_slope
        return 0.5 * np.matmul(Lv, dkap[:, :, None])[:, :, 0]

    # -- solving ------------------------------------------------------------------------------
    def solve(self, modes: Sequence[RodContactMode], pose: BasePose, guess: np.ndarray,
              start: Optional["Solved"] = None, exact_jacobian: bool = False,
              trusted: bool = False,
              max_iterations: int = _NEWTON_ITERATIONS,
              max_step: Optional[float] = None, fail_fast: bool = False) -> "Solved":
        """
        Solve a configuration's equilibrium from ``guess``: chord iterations, then Newton.

        With ``start`` (a nearby solution) the first iterations reuse its factorized Jacobian
        (a residual evaluation each); when they stop contracting fast, Newton takes over. The
        result carries the Jacobian's factorization and the pose sensitivities at the solution
        (evaluated at most one Newton step away from it).

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts from the base to the tip.
        pose : BasePose
            The base pose.
        guess : numpy.ndarray
            The starting unknown vector.
        start : Solved, optional
            A nearby solution whose Jacobian the chord iterations use.
        exact_jacobian : bool, optional
            Evaluate the Jacobian and sensitivities at the converged solution itself (one more
            evaluation): for locating where det J vanishes to rounding.
        trusted : bool, optional
            The guess is within ~1e-7 (an extrapolated pose stream): Newton at once, no chord
            iterations, and one step of at most 1e-7 converges it (its error is then ~1e-14).
        max_iterations : int, optional
            Bound on the iterations.
        max_step : float or None, optional
            Refuse (ConvergenceError) an iteration step longer than this (max norm).
        fail_fast : bool, optional
            Give up (ConvergenceError) as soon as a Newton step, from the third on, is longer
            than 0.9 times the one before: for trial steps of a continuation, where a shorter
            step is the remedy (past a fold Newton wanders and would spend every iteration; at a
            singular solution, a bifurcation, it still contracts by about 1/2 per step).

        Returns
        -------
        Solved
            The solution, its Jacobian's factorization and its pose sensitivities.

        Raises
        ------
        ConvergenceError
            When the iterations do not converge within ``max_iterations``, a contact leaves
            (0, 1], or a value is not finite.

        """
        vec = np.array(guess, dtype=float)
        last = math.inf
        it = 0
        try:
            converged = False
            if start is not None and not trusted:
                lu = start.lu
                for it in range(1, _CHORD_ITERATIONS + 1):
                    res, _, _ = self.residual(modes, vec, pose, jacobian=False)
                    step = _lu_solve(lu, res)
                    size = self._take(step, max_step)
                    vec = vec - step
                    self._check_breaks(modes, vec)
                    # the contraction rate: measured, or at the first step the last solve's
                    rate = size / last if last < math.inf else self._chord_rate
                    # near enough for the closing Newton step to square the error away (that
                    # step's size is checked below: a wrong guess only costs an iteration)
                    if size <= _TOL or (rate < 0.5 and size * rate / (1.0 - rate) <= _CHORD_TOL):
                        converged = True
                        if last < math.inf:
                            self._chord_rate = rate
                        break
                    if last < math.inf:
                        self._chord_rate = rate
                    if last < math.inf and (rate > 0.5
                                            or size * rate ** 3 / (1.0 - rate) > _CHORD_TOL):
                        # contracting too slowly (more than two further iterations): a Newton
                        # step and chord steps on its fresh Jacobian cost less
                        break
                    last = size
                last = math.inf
            newton = 0
            shortest, since = math.inf, 0
            for it in range(it, max_iterations):
                # at a converged chord solution this evaluation gives the Jacobian and the
                # sensitivities there; its Newton step is one more (tiny) correction
                res, J, sens = self.residual(modes, vec, pose, pose_sensitivity=True)
                self.factorizations += 1
                lu = _lu_factor(J, finite=J is self._finite_jacobian, overwrite=True)
                step = _lu_solve(lu, res)
                size = self._take(step, max_step)
                at = vec
                vec = vec - step
                self._check_breaks(modes, vec)
                settled = (size <= _TOL or (converged and size <= _CHORD_TOL)
                           or _settled(size, last)
                           or (trusted and it == 0 and size <= _TRUSTED_STEP))
                if not settled and size <= _TRUSTED_CHORD and not size > 0.1 * last:
                    # close enough: chord steps on this fresh Jacobian contract by ~size each,
                    # a residual each instead of another Jacobian and factorization
                    settled, vec = self._polish(modes, vec, pose, lu, max_step)
                if settled:
                    if exact_jacobian:
                        _, J, sens = self.residual(modes, vec, pose, pose_sensitivity=True)
                        self.factorizations += 1
                        lu = _lu_factor(J, finite=J is self._finite_jacobian,
                                        overwrite=True)
                    return Solved(vec, lu, sens)
                newton += 1
                if fail_fast and newton >= 3 and size > 0.9 * last:
                    raise ConvergenceError("3D whisker: Newton is not contracting")
                # stalled: no step shorter than 0.9 times the shortest yet for _STALL iterations,
                # from the (2 _STALL)-th on (past a fold Newton halves its steps for a while, then
                # wanders at ~1e-7; at a singular solution it goes on halving them to convergence;
                # from a far guess its first steps may grow before they shrink)
                if size < 0.9 * shortest:
                    shortest, since = size, 0
                else:
                    since += 1
                    if since >= _STALL and newton >= 2 * _STALL and size > _NOISE:
                        if float(np.max(np.abs(res))) <= _ROUNDING:
                            # the equations hold to rounding where the steps level off: an
                            # ill-conditioned solution (a contact 1e-4 from another), whose
                            # steps are its rounding noise
                            return Solved(at, lu, sens)
                        raise ConvergenceError("3D whisker: Newton has stalled")
                converged = False
                last = size
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            raise ConvergenceError(f"3D whisker: Newton failed ({exc})") from None
        raise ConvergenceError(
            f"3D whisker: Newton did not converge in {max_iterations} iterations"
        )

    def trusted_step(self, modes: Sequence[RodContactMode], start: "Solved", rate: np.ndarray,
                     guess: np.ndarray, pose: BasePose, max_change: float,
                     max_step: float = 0.5, tail_cut: float = -1e-9, whole: bool = False,
                     adapt: bool = True, fold_before: Optional[Tuple[float, float]] = None
                     ) -> Optional[TrustedStep]:
        """
        Take a plain continuation step whole in one compiled call, or return None.

        The tracker's commonest step: from the solution ``start`` along a path of pose rate
        ``rate`` (d(p, q)/dt, the path parameter t from 0 to 1) to ``pose``, from ``guess``, a
        pose stream's extrapolation (within ~1e-7). The tangent's bound (the largest change
        of an unknown, forces relative to 1 + |f|, over the whole step) must stay within
        ``max_change``; then the solve is :meth:`solve`'s with ``trusted`` and ``fail_fast``
        (Newton; chord steps on a Jacobian within 1e-4 of the solution), and the solution's
        data for the tracker's checks and state are computed in the same call (and kept, as
        :meth:`_accepted` keeps them). The same operations as those methods, in one kernel
        (:func:`._jit.trusted_step`, LAPACK's getrf and getrs as scipy.linalg's): the same
        solution to the last bit, without a Python call per iteration.

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts (a tuple; side contacts on spheres, cylinders or planes).
        start : Solved
            The solution at the path's start.
        rate : numpy.ndarray
            (7,) the pose's rate along the path.
        guess : numpy.ndarray
            The predicted solution at ``pose``.
        pose : BasePose
            The path's end.
        max_change : float
            The sub-step bound on the largest change.
        max_step : float, optional
            Refuse a longer Newton step (as :meth:`solve`).
        tail_cut : float, optional
            The depth [L] beyond which the tracker's checks refuse the unloaded tail or the
            loaded part cutting an obstacle it touches.
        whole : bool, optional
            Where the bound would shorten the step, take it whole all the same as the tracker
            does (one solve of at most one Newton step, :meth:`solve` with ``max_iterations``
            1; ``TrustedStep.whole``), unless ``adapt`` and the tangent's end asks for more
            points than the start's (the tracker then goes to the full count first).
        adapt : bool, optional
            The tracker adapts the point count (``RodTracker.adapt_points``).
        fold_before : (float, float), optional
            A tangent recorded before the step, (t, g) on this step's parameter (t < 0, g =
            1 / norm(tangent)^2): where the tangent's g has fallen below half of it and the
            line through the two reaches 0 within the step (or the bound's sub-step), a fold
            is announced there (``RodTracker._fold_limit``), and nothing is solved (None).

        Returns
        -------
        TrustedStep or None
            The solution, the tangent at the start (as :meth:`tangent` computes it), whether
            the tracker's checks pass on it (its unloaded tail and its loaded part no deeper
            than ``tail_cut`` in the obstacles they touch, from the data the call computed),
            and what the tracker decides the step by (its distance from the tangent's
            prediction and the predicted change, its least force or 1 - s, its stability
            value). None where the bound would shorten the step (and it is not taken
            ``whole``), a fold is announced within it (``fold_before``) or the tangent is not
            finite (nothing solved), where the kernels meet an arithmetic error, or where the
            kernel does not apply (other obstacles or shapes, other arrays): the caller takes
            its general path.

        Raises
        ------
        ConvergenceError
            Where :meth:`solve` raises it from the same guess (its evaluations are counted).

        """
        if not (_jit.ENABLED and _jit.LAPACK) or not modes:
            return None
        config = self._config(modes)
        geometry = config.geometry
        shape = self.shape
        if geometry is None or (shape.parabola is None and not shape.is_straight):
            return None
        if not _jit.WARM:
            _jit.warm_up()
        lu0, piv0 = start.lu
        if len(guess) != len(start.vec):
            self.points_of(modes, guess)  # (a length that fits no n is refused here)
            return None
        if (not lu0.flags.f_contiguous
                or piv0.dtype != np.int32 or not start.sens.flags.c_contiguous):
            return None  # (the kernels' own arrays only: one compiled version, no copies)
        n = self.points_of(modes, start.vec)
        plain = config.plain.get(n)
        if plain is None:
            forces = self._force_indices(modes, start.vec)
            plain = config.plain[n] = (
                forces, forces[-1] - 1 if modes[-1].kind == "side" else -1, _operators(n).tau,
                self._template(len(modes), n),
                _S_EXTEND if self._sp is None else min(_S_EXTEND, 0.5 * (1.0 + self._sp)),
                _operators(n).Vinv)
        forces, last_break, tau, T, limit, Vinv = plain
        try:
            fold_t, fold_g = (0.0, math.inf) if fold_before is None else fold_before
            (status, tan, vec, lu, piv, sens, spent, factored, points, normals, tip, frame,
             tail_depth, depth, where, checked, error, change, least, det, s_c, f_c, loads,
             total, moment, above, clear) = _jit.trusted_step(
                lu0, piv0, start.sens @ rate, forces, start.vec, max_change,
                _kernel_array(guess), pose.q, pose.p, n, config.kinds,
                tau, self._jit_sp, T, self._jit_shape, self._jit_grid, self._jit_table,
                self._nu1, geometry[0], geometry[1], limit, config.touched[1], TAIL_SAMPLES,
                shape.parabola or 0.0, _TOL, _TRUSTED_STEP, _TRUSTED_CHORD, _CHORD_TOL,
                float(max_step), _NEWTON_ITERATIONS, _STALL, _NOISE, _ROUNDING, float(tail_cut),
                last_break, Vinv, self._ladder[0] - 2, *(config.others or _NO_OBSTACLES),
                1 if whole else 0, self.n, bool(adapt), self._refine, float(fold_t),
                float(fold_g))
        except (ValueError, ArithmeticError):
            # (an arithmetic error in the kernels, e.g. a division by zero: the general path
            # meets it in solve, counts its evaluations and takes a shorter sub-step)
            return None
        self.evaluations += spent
        self.factorizations += factored
        if status == 1:
            return None
        if status == 2:
            raise ConvergenceError("3D whisker: the trusted Newton solve failed")
        post = _accepted_of(config, points, normals, tip, frame, tail_depth, depth, where, s_c,
                            f_c, loads, total, moment, above if above.size else None, clear)
        self._accepted_cache = (vec.copy(), pose, tuple(modes), post)
        # (points_needed of the solution, from the coefficient tail computed with it; the
        # kernel computes it wherever n is above the ladder's fewest)
        return TrustedStep(Solved(vec, (lu, piv), sens), tan, bool(checked), error, change,
                           least, det, post.clear,
                           _points_from_tail(n, self.n, above, self._ladder, self._coarsen,
                                             self._refine),
                           status == 3)

    def _force_indices(self, modes, vec) -> np.ndarray:
        """Return the indices of the contacts' forces in an unknown vector of this length."""
        o = len(vec) - self._config(modes).extra
        out = []
        for m in modes:
            o += m.size
            out.append(o - 1)
        return np.array(out, dtype=np.int64)

    def _polish(self, modes, vec, pose, lu, max_step):
        """
        Return (converged, vec) after at most three chord steps with a fresh factorization.

        Each step must be at most a tenth of the one before (the Jacobian, within 1e-4 of the
        solution, makes them contract by ~1e-4 or better); the first at most 1e-10 ends them
        (the error is then ~1e-14). Otherwise Newton goes on from the last iterate.
        """
        last = math.inf
        for _ in range(3):
            res, _, _ = self.residual(modes, vec, pose, jacobian=False)
            step = _lu_solve(lu, res)
            size = self._take(step, max_step)
            if size > 0.1 * last:
                return False, vec
            vec = vec - step
            self._check_breaks(modes, vec)
            if size <= _CHORD_TOL * 1e-2:
                return True, vec
            last = size
        return False, vec

    @staticmethod
    def _take(step, max_step) -> float:
        size = float(np.abs(step).max())
        if not math.isfinite(size):
            raise ConvergenceError("3D whisker: Newton step is not finite")
        if max_step is not None and size > max_step:
            raise ConvergenceError("3D whisker: Newton step too long")
        return size

    def loaded_residual(self, s_load: float, vec: np.ndarray, pose: BasePose, force, moment,
                        jacobian: bool = True):
        """
        Return the residual (and Jacobian) of the whisker under a given point load.

        A force ``force`` and a couple ``moment`` (world frame) act at arc length ``s_load``;
        beyond it the whisker is unloaded. The unknowns are the quaternions of one segment
        [0, s_load] (``vec`` (4 n,)).

        Parameters
        ----------
        s_load : float
            Where the load acts, in (0, 1].
        vec : numpy.ndarray
            The quaternions (4 n,).
        pose : BasePose
            The base pose.
        force, moment : array_like
            The load (3,) each.
        jacobian : bool, optional
            Also return d residual / d vec.

        Returns
        -------
        tuple
            (residual, Jacobian or None).

        """
        self.evaluations += 1
        lay = _Layout(self, (s_load,))
        N, G, ends = lay.N, lay.G, lay.ends
        Q = vec.reshape(N, 4)
        R = _rotations(Q)
        D1 = R[:, :, 0]
        r = pose.p + G @ D1
        kinv, kap0, _ = self._stiffness(lay.s)
        F = [np.asarray(force, dtype=float)]
        M = self._moments(r, ends, F, np.asarray(moment, dtype=float))
        kap, Lv, g = self._curvature(Q, R, M, kinv, kap0)
        res = (Q - pose.q - G @ g).ravel()
        if not jacobian:
            return res, None
        dR = _drot(Q)
        D = dR[:, :, :, 0].transpose(0, 2, 1)
        Dcat = D.transpose(1, 0, 2).reshape(3, 4 * N)
        P = 0.5 * Lv * kinv[:, None, :]
        PRt = np.matmul(P, R.transpose(0, 2, 1))
        dg = self._dg(Q, R, M, kap, P, PRt, dR, Dcat, G, r, ends, F, [0.0], [None], None)
        J = -(G @ dg.reshape(N, 16 * N)).reshape(4 * N, 4 * N)
        J[np.arange(4 * N), np.arange(4 * N)] += 1.0
        return res, J

    def solve_loaded(self, s_load: float, pose: BasePose, force, moment, guess=None,
                     ramp: int = 1) -> np.ndarray:
        """
        Solve the whisker under a given point load (Newton, the load ramped in ``ramp`` steps).

        Parameters
        ----------
        s_load : float
            Where the load acts, in (0, 1].
        pose : BasePose
            The base pose.
        force, moment : array_like
            The load (3,) each, world frame.
        guess : numpy.ndarray, optional
            Starting quaternions (4 n,); default the unloaded whisker.
        ramp : int, optional
            Load steps (the load grows linearly to its value; each step starts from the last).

        Returns
        -------
        numpy.ndarray
            The quaternions (4 n,).

        Raises
        ------
        ConvergenceError
            When Newton does not converge at some load step.

        """
        lay = _Layout(self, (s_load,))
        vec = (self.free_quaternions(pose, lay.s).ravel() if guess is None
               else np.array(guess, dtype=float))
        force = np.asarray(force, dtype=float)
        moment = np.asarray(moment, dtype=float)
        for k in range(1, ramp + 1):
            lam = k / ramp
            last = math.inf
            for _ in range(_NEWTON_ITERATIONS):
                try:
                    res, J = self.loaded_residual(s_load, vec, pose, lam * force, lam * moment)
                    step = np.linalg.solve(J, res)
                except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
                    raise ConvergenceError(f"3D whisker under a load: Newton failed ({exc})"
                                           ) from None
                size = self._take(step, None)
                vec = vec - step
                if size <= _TOL or _settled(size, last):
                    break
                last = size
            else:
                raise ConvergenceError(
                    f"3D whisker under a load: Newton did not converge at load step {k}/{ramp}"
                )
        return vec

    # -- points per segment -------------------------------------------------------------------
    def coefficient_magnitudes(self, modes: Sequence[RodContactMode], vec: np.ndarray,
                               lowest: int = 0) -> np.ndarray:
        """
        Return the largest Chebyshev coefficient of each degree of a solution's quaternions.

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts (at least one).
        vec : numpy.ndarray
            The unknown vector.
        lowest : int, optional
            The lowest degree wanted.

        Returns
        -------
        numpy.ndarray
            (n - lowest,): max over the segments and the four components of |c_j|,
            j = lowest .. n - 1, of the interpolant in each segment's own coordinate (the
            layout's tau).

        """
        n = self.points_of(modes, vec)
        k = len(modes)
        Q = np.asarray(vec[:4 * n * k], dtype=float).reshape(k, n, 4)
        coef = np.matmul(_operators(n).Vinv[lowest:], Q)       # (k, n - lowest, 4)
        return np.abs(coef).max(axis=(0, 2))

    def points_needed(self, modes: Sequence[RodContactMode], vec: np.ndarray) -> int:
        """
        Return the points per segment a configuration's solution asks for.

        :func:`points_for` sizes the whisker for its hardest case, a load at the tip; a
        lighter load, or a contact nearer the base, leaves a smoother loaded part that fewer
        points resolve. The count drops to the least m on the ladder (16, 20, 24, ...; from 8 at
        a ``points_tolerance`` coarser than the default) whose omitted Chebyshev coefficients
        (degree m - 2 up) are all below a tenth of the solver's ``points_tolerance``
        (:data:`POINTS_COARSEN` at the default), and climbs one rung where the last two
        coefficients of the current count exceed it (:data:`POINTS_REFINE`); never above the
        solver's n, which every new configuration starts from.

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts (at least one).
        vec : numpy.ndarray
            A converged unknown vector.

        Returns
        -------
        int
            The points per segment to solve it with (the current count where it may stay).

        """
        vec = _kernel_array(vec)
        n = self.points_of(modes, vec)
        lo = self._ladder[0] - 2
        if _fewest_points(n, self.n, self._ladder):
            return _points_from_tail(n, self.n, None, self._ladder)
        last = self._accepted_cache
        if (last is not None and last[3].above is not None
                and (last[2] is modes or last[2] == tuple(modes)) and _same(last[0], vec)):
            above = last[3].above  # (computed with the solution, in the plain step's kernel)
        elif _jit.ENABLED:
            if not _jit.WARM:
                _jit.warm_up()
            above = _jit.coefficient_tail(_operators(n).Vinv, vec, n, len(modes), lo)
        else:
            above = np.maximum.accumulate(
                self.coefficient_magnitudes(modes, vec, lo)[::-1])[::-1]
        return _points_from_tail(n, self.n, above, self._ladder, self._coarsen, self._refine)

    def resample(self, modes: Sequence[RodContactMode], vec: np.ndarray, n: int) -> np.ndarray:
        """
        Return an unknown vector on n points per segment (spectral interpolation), same contacts.

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts (at least one).
        vec : numpy.ndarray
            The unknown vector.
        n : int
            The new points per segment.

        Returns
        -------
        numpy.ndarray
            The quaternions' interpolant at the new nodes of each segment, then the contacts'
            unknowns unchanged (a guess for :meth:`solve` with n points).

        """
        n_old = self.points_of(modes, vec)
        k = len(modes)
        vec = np.asarray(vec, dtype=float)
        if n == n_old:
            return vec.copy()
        Q = np.matmul(_resampler(n_old, n), vec[:4 * n_old * k].reshape(k, n_old, 4))
        return np.concatenate((Q.ravel(), vec[4 * n_old * k:]))

    def _check_breaks(self, modes, vec):
        b = self.breaks_of(modes, vec)
        prev = 0.0
        # the last side contact may run past the tip while the tracker locates its side -> tip
        # switch: the equations continue smoothly there (B > 0 up to the cone's apex)
        limit = _S_EXTEND if self._sp is None else min(_S_EXTEND, 0.5 * (1.0 + self._sp))
        for i, v in enumerate(b):
            top = limit if i == len(b) - 1 else 1.0
            if not (prev < v <= top) or not math.isfinite(v):
                raise ConvergenceError(
                    f"3D whisker: contact arc lengths {b} left 0 < s_1 < ... <= 1"
                )
            prev = v

    def tangent(self, solved: "Solved", dpose: np.ndarray) -> np.ndarray:
        """
        Return d vec / dt along a pose path with d(p, q_base)/dt = ``dpose`` (7,).

        Parameters
        ----------
        solved : Solved
            A solution with its Jacobian and pose sensitivities.
        dpose : numpy.ndarray
            (dp/dt, dq/dt) (7,).

        Returns
        -------
        numpy.ndarray
            The tangent (size,).

        """
        return -_lu_solve(solved.lu, solved.sens @ dpose)

    def _free_tip(self):
        """Return the unloaded whisker's tip and tip frame in its base frame (cached)."""
        if self._free_tip_cache is None:
            (dx, dy), phi = self.shape.tail(0.0)
            off = np.array([dx, dy, 0.0])
            c, sn = math.cos(phi), math.sin(phi)
            frame = np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])
            off.setflags(write=False)
            frame.setflags(write=False)
            self._free_tip_cache = (off, frame)
        return self._free_tip_cache

    # -- guesses and sampling -----------------------------------------------------------------
    def free_quaternions(self, pose: BasePose, s) -> np.ndarray:
        """
        Return the unloaded whisker's quaternions at arc lengths ``s``, shape (m, 4).

        Parameters
        ----------
        pose : BasePose
            The base pose.
        s : array_like
            Arc lengths [L].

        Returns
        -------
        numpy.ndarray
            q(s) = q_base * (rotation about d3 by the intrinsic slope).

        """
        phi = self.shape.intrinsic_slope(np.asarray(s, dtype=float))
        return quat_multiply(pose.q, _turns_about_d3(phi))

    def guess(self, modes: Sequence[RodContactMode], breaks: Sequence[float],
              forces: Sequence[float], quaternions, n: Optional[int] = None) -> np.ndarray:
        """
        Build an unknown vector from contact arc lengths, forces and a quaternion field.

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts.
        breaks : sequence of float
            Their arc lengths.
        forces : sequence of float
            Their normal forces.
        quaternions : callable
            s (m,) -> q (m, 4), e.g. an old solution's :meth:`quaternions`.
        n : int, optional
            Points per segment; default the solver's.

        Returns
        -------
        numpy.ndarray
            The unknown vector.

        """
        lay = _Layout(self, breaks, n)
        out = [np.asarray(quaternions(lay.s), dtype=float).ravel()]
        for m, b, f in zip(modes, breaks, forces):
            out.append([b, f] if m.kind == "side" else [f])
        return np.concatenate([np.asarray(v, dtype=float) for v in out])

    def _interpolate(self, lay: _Layout, values: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Nodal values (N, d) interpolated at arc lengths s (m,) inside the segments."""
        c, x = lay.locate(s)
        V = np.polynomial.chebyshev.chebvander(x, lay.n - 1) @ _operators(lay.n).Vinv
        vals = values.reshape(lay.k, lay.n, -1)[c]                            # (m, n, d)
        return np.einsum("mj,mjd->md", V, vals)

    def quaternions(self, modes, vec, pose: BasePose, s) -> np.ndarray:
        """
        Return the quaternions q(s) (m, 4) of a configuration's solution (spectral interpolation).

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts.
        vec : numpy.ndarray
            The unknown vector.
        pose : BasePose
            The base pose.
        s : array_like
            Arc lengths in [0, 1].

        Returns
        -------
        numpy.ndarray
            Quaternions (m, 4) (unit to the discretization's accuracy).

        """
        s = np.atleast_1d(np.asarray(s, dtype=float))
        if not modes:
            return self.free_quaternions(pose, s)
        if s.size == 1 and float(s[0]) == self.breaks_of(modes, vec)[-1]:
            # the last contact's end, x = 1 of its segment (a tip contact's q(1), asked at every
            # sub-step): the same operations as below, without the layout and the Vandermonde
            n, k = self.points_of(modes, vec), len(modes)
            last = vec[4 * n * (k - 1):4 * n * k].reshape(1, n, 4)
            return np.einsum("mj,mjd->md", _end_row(n), last)
        lay = self.layout(modes, vec)
        Q = vec[:4 * lay.N].reshape(lay.N, 4)
        end = lay.breaks[-1]
        out = np.empty((s.size, 4))
        inside = s <= end
        if np.any(inside):
            out[inside] = self._interpolate(lay, Q, s[inside])
        if not np.all(inside):
            phi = self.shape.intrinsic_slope(s[~inside]) - self.shape.intrinsic_slope(end)
            out[~inside] = quat_multiply(Q[-1], _turns_about_d3(phi))
        return out

    def centerline(self, modes, vec, pose: BasePose, s) -> np.ndarray:
        """
        Return the centerline r(s) (m, 3) of a configuration's solution.

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts.
        vec : numpy.ndarray
            The unknown vector.
        pose : BasePose
            The base pose.
        s : array_like
            Arc lengths in [0, 1].

        Returns
        -------
        numpy.ndarray
            Points (m, 3), world frame [L].

        """
        s = np.atleast_1d(np.asarray(s, dtype=float))
        p = pose.p
        if not modes:
            return p + self.shape.free_centerline(s) @ pose.rotation.T
        if _jit.ENABLED:
            return self._centerline_compiled(modes, vec, pose, s)
        return self._centerline_numpy(modes, vec, pose, s)

    def _centerline_numpy(self, modes, vec, pose, s):
        """:meth:`centerline` (with contacts) in numpy: the reference of the kernels."""
        p = pose.p
        lay = self.layout(modes, vec)
        Q = vec[:4 * lay.N].reshape(lay.N, 4)
        R = _rotations(Q)
        D1 = R[:, :, 0]
        # segment starts: the nodes' positions r = p + G D1 at each segment's first node
        r_nodes = p + lay.G @ D1
        end = lay.breaks[-1]
        out = np.empty((s.size, 3))
        inside = s <= end
        if np.any(inside):
            c, x = lay.locate(s[inside])
            W = (np.polynomial.chebyshev.chebvander(x, lay.n)
                 @ _operators(lay.n).int_matrix)                         # (m, n)
            vals = (D1 * lay.w[:, None]).reshape(lay.k, lay.n, 3)[c]
            starts = r_nodes.reshape(lay.k, lay.n, 3)[c, 0]
            out[inside] = starts + 0.5 * np.einsum("mj,mjd->md", W, vals)
        if not np.all(inside):
            off = self.shape.intrinsic_offset(end, s[~inside])
            out[~inside] = r_nodes[-1] + off[:, :1] * R[-1, :, 0] + off[:, 1:] * R[-1, :, 1]
        return out

    def _centerline_compiled(self, modes, vec, pose, s):
        """:meth:`centerline` (with contacts) by the compiled kernels."""
        vec = _kernel_array(vec)
        s = _kernel_array(s)
        breaks, w, r_nodes, frames = self._nodes(modes, vec, pose)
        n = self.points_of(modes, vec)
        int_matrix = _operators(n).int_matrix
        end = breaks[-1]
        last = frames[-1]
        beyond = s > end
        n_beyond = int(np.count_nonzero(beyond))
        if n_beyond == 0:
            return _jit.sample(s, vec, n, breaks, w, r_nodes, self._jit_sp, int_matrix)
        tail = s if n_beyond == s.size else s[beyond]
        if self.shape.parabola is not None:
            off = _jit.parabola_tail(end, tail, self.shape.parabola, self._jit_grid,
                                     self._jit_table)
        else:
            off = self.shape.intrinsic_offset(end, tail)
        pts = r_nodes[-1] + off[:, :1] * last[:, 0] + off[:, 1:] * last[:, 1]
        if n_beyond == s.size:
            return pts
        out = np.empty((s.size, 3))
        out[beyond] = pts
        out[~beyond] = _jit.sample(s[~beyond], vec, n, breaks, w, r_nodes, self._jit_sp,
                                   int_matrix)
        return out

    def tip_gap(self, modes, vec, pose: BasePose, s) -> Optional[float]:
        """
        Return the least d(s) / (1 - s) over ``s``, d the distance to the last contact's obstacle.

        The sampled value behind a tip contact (RodTracker._gap_behind_tip's before it refines
        it), by one compiled call: the centerline at ``s`` (< 1, inside the segments, as
        :meth:`centerline` samples it) and the obstacle's signed distance there. None where the
        kernels do not know the obstacle, or a value is not a number.

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts (at least one).
        vec : numpy.ndarray
            The unknown vector.
        pose : BasePose
            The base pose.
        s : numpy.ndarray
            Arc lengths in [0, 1), inside the segments.

        Returns
        -------
        float or None
            The least value (inf without arc lengths).

        """
        if not _jit.ENABLED:
            return None
        geometry = self._geometry_of(modes)
        if geometry is None:
            return None
        vec = _kernel_array(vec)
        breaks, w, r_nodes, _ = self._nodes(modes, vec, pose)
        n = self.points_of(modes, vec)
        value = _jit.tip_gap(_kernel_array(s), vec, n, breaks, w, r_nodes,
                             self._jit_sp, _operators(n).int_matrix, geometry[0][-1],
                             geometry[1][-1])
        return None if value == -math.inf else float(value)

    def _nodes(self, modes, vec, pose):
        """
        Return (breaks, w, r at the nodes, frames at the contacts) by the compiled kernel.

        The last answer is kept: an accepted solution is sampled several times (its tail
        checked, its state made) with the same vector and pose. The cache holds a copy of the
        vector and is used only for an equal one; the arrays are shared, and no caller writes
        into them (marking them read-only would make numba compile its kernels again for
        read-only arguments).
        """
        if not _jit.WARM:
            _jit.warm_up()
        modes = tuple(modes)
        vec = _kernel_array(vec)
        last = self._nodes_cache
        if (last is not None and last[1] == pose and last[2] == modes
                and _same(last[0], vec)):
            return last[3]
        n = self.points_of(modes, vec)
        out = _jit.nodes(vec, n, self._kinds_of(modes), _operators(n).tau, self._jit_sp,
                         self._template(len(modes), n), pose.p)
        self._nodes_cache = (vec.copy(), pose, modes, out)
        return out

    def _accepted(self, modes, vec, pose) -> Optional["_Accepted"]:
        """
        Return the checks' and the state's data of a solution from one kernel call, or None.

        For contacts on spheres, cylinders and planes only, and a straight or parabolic
        unloaded whisker (:func:`._jit.accepted`); None otherwise, and the callers sample and
        measure in Python. The tail is sampled at :data:`TAIL_SAMPLES`. The last answer is kept,
        as :meth:`_nodes`'s: the tracker's checks and its state ask for the same solution.
        """
        if not _jit.ENABLED or not modes:
            return None
        vec = _kernel_array(vec)
        last = self._accepted_cache
        # (asked for several times per step, with the same tuple of modes and the same pose:
        # identity first, then equality)
        if (last is not None and (last[2] is modes or last[2] == tuple(modes))
                and (last[1] is pose or last[1] == pose) and _same(last[0], vec)):
            return last[3]
        shape = self.shape
        if shape.parabola is None and not shape.is_straight:
            return None
        modes = tuple(modes)
        geometry = self._geometry_of(modes)
        if geometry is None:
            return None
        if not _jit.WARM:
            _jit.warm_up()
        n = self.points_of(modes, vec)
        config = self._config(modes)
        touched = config.touched
        (points, normals, tip, frame, tail_depth, depth, where, s_c, f_c, forces, force,
         moment, clear) = _jit.accepted(
            vec, n, config.kinds, _operators(n).tau, self._jit_sp,
            self._template(len(modes), n), pose.p, geometry[0], geometry[1], touched[1],
            TAIL_SAMPLES, shape.parabola or 0.0, self._jit_grid, self._jit_table,
            *(config.others or _NO_OBSTACLES))
        out = _accepted_of(config, points, normals, tip, frame, tail_depth, depth, where, s_c, f_c,
                           forces, force, moment, None, clear)
        self._accepted_cache = (vec.copy(), pose, modes, out)
        return out

    def equilibrium(self, modes: Sequence[RodContactMode], vec: np.ndarray, pose: BasePose
                    ) -> RodEquilibrium:
        """
        Return the equilibrium value of a converged solution.

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts.
        vec : numpy.ndarray
            The converged unknown vector.
        pose : BasePose
            The base pose.

        Returns
        -------
        RodEquilibrium
            Contacts, base load, tip.

        """
        modes = tuple(modes)
        post = self._accepted(modes, vec, pose) if modes else None
        if post is not None:
            # (the kernel's: the same operations as below)
            breaks, fs, pts, tip, frame = post.s, post.f, post.points, post.tip, post.frame
            forces, force, moment = post.forces, post.force, post.moment
        elif modes:
            breaks = self.breaks_of(modes, vec)
            fs = self.forces_of(modes, vec)
            if _jit.ENABLED:
                _, _, r_nodes, R = self._nodes(modes, vec, pose)
                n = self.points_of(modes, vec)
                r_ends = r_nodes[n - 1::n]
                Q_last = vec[4 * n * len(modes) - 4:4 * n * len(modes)]
            else:
                lay = self.layout(modes, vec)
                Q = vec[:4 * lay.N].reshape(lay.N, 4)
                R = _rotations(Q[lay.ends])
                r_ends = pose.p + lay.G[lay.ends] @ _tangents(Q)
                Q_last = Q[-1]
            pts = r_ends
            forces = np.array([f * np.asarray(self.obstacles[m.obstacle].surface(x).normal)
                               for m, f, x in zip(modes, fs, pts)])
            end = breaks[-1]
            frame = R[-1] / float(Q_last @ Q_last)
            tip = r_ends[-1]
            if end < 1.0:
                if _jit.ENABLED and self.shape.parabola is not None:
                    # (the kernel of the centerline's tail: the same tip as centerline(1))
                    *off, phi = _jit.parabola_tip(end, self.shape.parabola, self._jit_grid,
                                                  self._jit_table)
                else:
                    off, phi = self.shape.tail(end)
                tip = tip + off[0] * frame[:, 0] + off[1] * frame[:, 1]
                c, sn = math.cos(phi), math.sin(phi)
                turned = np.empty((3, 3))
                turned[:, 0] = c * frame[:, 0] + sn * frame[:, 1]
                turned[:, 1] = -sn * frame[:, 0] + c * frame[:, 1]
                turned[:, 2] = frame[:, 2]
                frame = turned
            force = forces.sum(axis=0)
            # sum_c (x_c - p) x F_c, in floats (as _cross(pts - p, forces).sum(axis=0))
            px, py, pz = pose.position
            moment = None
            for (x, y, z), (fx, fy, fz) in zip(pts.tolist(), forces.tolist()):
                ax, ay, az = x - px, y - py, z - pz
                mc = (ay * fz - az * fy, az * fx - ax * fz, ax * fy - ay * fx)
                moment = mc if moment is None else tuple(u + v for u, v in zip(moment, mc))
            moment = np.array(moment)
        else:
            breaks, fs = (), ()
            pts = np.zeros((0, 3))
            forces = np.zeros((0, 3))
            R0 = pose.rotation
            tip_off, tip_frame = self._free_tip()
            frame = R0 @ tip_frame
            tip = pose.p + R0 @ tip_off
            force = np.zeros(3)
            moment = np.zeros(3)
        vec = np.array(vec, dtype=float)
        vec.setflags(write=False)
        for arr in (pts, forces, force, moment, tip, frame):
            # (an equilibrium is a value: the kernels' arrays are shared with the solver's
            # cache of the last answer, which the tracker's checks read)
            arr.flags.writeable = False
        return RodEquilibrium(pose, modes, vec, tuple(breaks), tuple(fs), pts, forces, force,
                              moment, tip, frame, self)
