"""
The inverse problem in 3D: the contact point from the base wrench of a known whisker.

Huet et al. 2017: with one point contact and no contact couple, the six base signals of a whisker
of known shape and base pose fix the contact. The measured force F (world frame) is the contact
force, constant from the base to the contact; the measured moment about the base point is

    M0 = (r(s_c) - p) x F,                                          (one point load, no couple)

with r(s) the load point of the whisker clamped at the pose and loaded by F at arc length s
(:func:`~.loads.tip_loaded_rod`). Three equations in one unknown s_c: M0 . F = 0 for any contact
(the consistency condition, measured by ‖M0 . F‖ / (‖M0‖ ‖F‖)), the other two fix s_c. The contact
arc length is the least-squares fit

    s_c = argmin_{s in [s_min, 1]} ‖g(s)‖^2,    g(s) = (r(s) - p) x F - M0,

found in two stages. (1) The shot: between the base and the contact the internal moment is
M(s) = M0 - (r(s) - p) x F, so the whisker there solves an initial value problem from the base
alone (the 3D form of the planar general inverse, :mod:`vibrissa_ros.core.general.inverse`),
integrated with DOP853; ‖M(s)‖ = ‖F‖ times the distance from r(s) to the force's line of action,
and its local minima on a grid of s are the candidate contacts. The shot is unique, so it follows
the reading's own equilibrium branch where a given load at a given point has several (a strongly
bent whisker). (2) The fit: from each candidate (every loaded solve started from the shot, the
reading's branch: a start from a nearby solved s could carry a jump to another branch along),
Gauss-Newton on ‖g(s)‖^2 with dg/ds by a difference of loaded solves, kept inside the
candidate's basin, each step halved until ‖g‖ decreases. Exact data have g(s_c) = 0 and
Gauss-Newton converges quadratically (to the forward model's 1e-12). Noisy data leave a
residual ‖g(s_c)‖; divided by ‖F‖ it is the distance [L] by which the force's line of action
misses the fitted contact point.

Only "no contact couple" is assumed, not the frictionless condition: a side contact with friction
inverts the same way. The whisker's tangent at the fitted contact is reported, so that a user can
check frictionless tangency (tangent . F = 0 below the tip). When several arc lengths explain the
reading (the whisker crosses the force's line of action more than once: the planar general
inverse's assumption), the best fit is returned, on a tie the one nearest the base, and the
others are listed in ``alternatives``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Dict, List, Optional, Tuple

import numpy as np
from scipy.integrate import solve_ivp

from ..errors import ConvergenceError, ParameterError
from .model import RodContactMode, RodSolver
from .pose import BasePose, quat_matrix
from .shape import RodShape

#: the smallest contact arc length searched [L] (a contact nearer the base is not resolved)
MIN_ARC_LENGTH = 0.02
#: a fitted s within this of 1 is the tip
TIP_TOLERANCE = 1e-9
FRAMES = ("world", "base")
#: points at which the shot whisker's moment is sampled on [0, 1]
_SCAN_POINTS = 201
#: tolerances of the shot from the base (it only finds the candidates and the branch)
_SHOOT_RTOL = 1e-8
#: the shot's local minima (lowest |M| first) refined by Gauss-Newton at most
_CANDIDATES = 4
#: Gauss-Newton iterations per local minimum, step halvings per iteration, step size that stops
_GN_ITERATIONS = 40
_HALVINGS = 12
_S_TOL = 1e-14
#: difference step of dg/ds [L]
_FD_STEP = 1e-5
#: most load steps of a solve from the unloaded whisker (when the warm start fails)
_MAX_RAMP = 400
#: refined minima closer than this are one [L]
_SAME_S = 1e-8
_MODES = (RodContactMode("side", 0),)


@dataclass(frozen=True)
class ContactEstimate3D:
    """
    A contact estimated from one base wrench of the 3D whisker (dimensionless, world frame).

    Returned by :func:`contact_from_wrench`; the parameters are the dataclass's fields, kept as
    attributes of the same names.

    Parameters
    ----------
    pose : BasePose
        The base pose of the reading.
    s : float
        The contact's arc length on the whisker, in [MIN_ARC_LENGTH, 1] [L].
    point : tuple of float
        The contact point r(s) (3,) [L].
    force : tuple of float
        The contact force on the whisker (3,) [EI_b / L^2]: the measured force.
    moment : tuple of float
        The measured moment about the base point (3,) [EI_b / L].
    fitted_moment : tuple of float
        The moment the fitted contact produces, (point - p) x force (3,) [EI_b / L].
    residual : float
        ‖fitted_moment - moment‖ [EI_b / L]: 0 for exact data; residual / ‖force‖ is the
        distance [L] by which the force's line of action misses the contact point.
    consistency : float
        ‖moment . force‖ / (‖moment‖ ‖force‖) in [0, 1]: 0 for every single point contact
        without a contact couple (0 when the moment is 0).
    tangent : tuple of float
        The whisker's unit tangent d1 at the contact (3,): tangent . force = 0 for a
        frictionless side contact.
    moment_slope : float
        ‖d fitted_moment / ds‖ at ``s`` [EI_b / L^2]: a moment error e moves s by about
        e / moment_slope (0: s is not determined by the reading).
    alternatives : tuple of tuple of float
        (s, residual) of the other local minima of the fit, best first (empty: unique).

    """

    pose: BasePose
    s: float
    point: Tuple[float, float, float]
    force: Tuple[float, float, float]
    moment: Tuple[float, float, float]
    fitted_moment: Tuple[float, float, float]
    residual: float
    consistency: float
    tangent: Tuple[float, float, float]
    moment_slope: float
    alternatives: Tuple[Tuple[float, float], ...] = ()

    @property
    def tip(self) -> bool:
        """Tell whether the contact is the tip: s = 1 within TIP_TOLERANCE."""
        return self.s >= 1.0 - TIP_TOLERANCE


def _wrench_vector(name: str, value) -> np.ndarray:
    """Return a wrench part as an array (3,); refuse it, named, unless three finite numbers."""
    try:
        v = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ParameterError(f"wrench {name} {value!r} is not three numbers") from None
    if v.size != 3:
        raise ParameterError(f"wrench {name} {value!r} must have three components")
    for i, x in enumerate(v):
        if not math.isfinite(x):
            raise ParameterError(f"wrench {name}[{i}] = {float(x)!r} must be finite")
    return v


class _MomentFit:
    """
    g(s) = (r(s) - p) x F - M0 for the whisker loaded by F at s, on one branch (internal).

    Every solve starts from ``start`` (s (m,) -> quaternions (m, 4): the shot from the base, the
    reading's own branch), so that the fit stays on it; from the nearest solved load's solution
    instead, one solve that jumped to another branch would hold the fit there. Solves are cached
    by s.
    """

    def __init__(self, solver: RodSolver, pose: BasePose, F: np.ndarray, M0: np.ndarray,
                 start: Callable[[np.ndarray], np.ndarray]):
        self.solver = solver
        self.pose, self.F, self.M0 = pose, F, M0
        self.p = pose.p
        self.f = float(np.linalg.norm(F))
        self._start = start
        self._zero = np.zeros(3)
        self._solved: Dict[float, np.ndarray] = {}

    def _full(self, s: float) -> np.ndarray:
        return np.concatenate((self._solved[s], [s, 0.0]))

    def _guess(self, s: float) -> np.ndarray:
        """Return a guess at the nodes of [0, s]: the shot from the base, the reading's branch."""
        return self.solver.guess(_MODES, [s], [0.0], self._start)[:-2]

    def solve(self, s: float) -> np.ndarray:
        """Return the quaternions of the whisker loaded by F at s (ConvergenceError if none)."""
        vec = self._solved.get(s)
        if vec is not None:
            return vec
        try:
            with np.errstate(over="ignore", invalid="ignore"):  # a diverging Newton: refused
                vec = self.solver.solve_loaded(s, self.pose, self.F, self._zero,
                                               guess=self._guess(s))
        except ConvergenceError:
            # from the unloaded whisker, the load ramped (like tip_loaded_rod)
            ramp = min(_MAX_RAMP, 1 + int(math.ceil(2.0 * self.f * s * s)))
            vec = self.solver.solve_loaded(s, self.pose, self.F, self._zero, ramp=ramp)
        self._solved[s] = vec
        return vec

    def point(self, s: float) -> np.ndarray:
        self.solve(s)
        return self.solver.centerline(_MODES, self._full(s), self.pose, [s])[0]

    def tangent(self, s: float) -> np.ndarray:
        self.solve(s)
        q = self.solver.quaternions(_MODES, self._full(s), self.pose, [s])[0]
        return quat_matrix(q / np.linalg.norm(q))[:, 0]

    def misfit(self, s: float) -> np.ndarray:
        return np.cross(self.point(s) - self.p, self.F) - self.M0

    def slope(self, s: float) -> np.ndarray:
        """Return dg/ds by a one-sided difference (outward, inward at s = 1): one more solve."""
        h = _FD_STEP if s + _FD_STEP <= 1.0 else -_FD_STEP
        return (self.misfit(s + h) - self.misfit(s)) / h


def _intrinsic_curvature(shape: RodShape) -> Callable[[float], float]:
    """Return kappa0(s) for scalars, in floats (the parabola's u(s) warm-started by Newton)."""
    if shape.parabola is None:
        k0, k1 = shape.k0, shape.k1
        return lambda s: k0 + k1 * s
    a = abs(shape.parabola)
    state = [0.0]

    def kappa0(s):
        # u sqrt(1 + u^2) + asinh(u) = 4 |A| s: convex and increasing in u >= 0, so Newton
        # converges from any start (:meth:`RodShape._u`)
        target, u = 4.0 * a * s, state[0]
        for _ in range(60):
            root = math.sqrt(1.0 + u * u)
            du = (u * root + math.asinh(u) - target) / (2.0 * root)
            u = max(u - du, 0.0)
            if abs(du) <= 4e-16 * (1.0 + u):
                break
        state[0] = u
        return 2.0 * shape.parabola / (1.0 + u * u) ** 1.5

    return kappa0


def _shoot(shape: RodShape, pose: BasePose, F: np.ndarray, M0: np.ndarray):
    """
    Integrate the whisker from the base under the reading: the initial value problem.

    Between the base and the contact the internal moment is M(s) = M0 - (r(s) - p) x F, so
    the frame and the centerline follow from the base alone (the 3D form of the planar general
    inverse's shot): r' = d1, q' = 1/2 q * (0, kappa), kappa = (m1 / C, m2 / B, m3 / B + kappa0),
    m = R^T M. Unique, so it follows the reading's own equilibrium branch even where a load at a
    given point has several. Returns the dense solution s -> (r, q) (7,).
    """
    px, py, pz = pose.position
    fx, fy, fz = (float(v) for v in F)
    mx, my, mz = (float(v) for v in M0)
    nu1 = 1.0 + shape.poisson
    cone = 1.0 - shape.taper
    kappa0 = _intrinsic_curvature(shape)

    def rhs(s, y):  # in floats: it runs a few hundred times per reading
        x, yy, z, w, a, b, c = y.tolist()
        norm = math.sqrt(w * w + a * a + b * b + c * c)
        w, a, b, c = w / norm, a / norm, b / norm, c / norm
        # R(q)'s columns d1, d2, d3
        d1 = (w * w + a * a - b * b - c * c, 2 * (a * b + w * c), 2 * (a * c - w * b))
        d2 = (2 * (a * b - w * c), w * w - a * a + b * b - c * c, 2 * (b * c + w * a))
        d3 = (2 * (a * c + w * b), 2 * (b * c - w * a), w * w - a * a - b * b + c * c)
        # M = M0 - (r - p) x F
        rx, ry, rz = x - px, yy - py, z - pz
        Mx = mx - (ry * fz - rz * fy)
        My = my - (rz * fx - rx * fz)
        Mz = mz - (rx * fy - ry * fx)
        inv_b = 1.0 / (1.0 - cone * s) ** 4
        k1 = nu1 * inv_b * (d1[0] * Mx + d1[1] * My + d1[2] * Mz)
        k2 = inv_b * (d2[0] * Mx + d2[1] * My + d2[2] * Mz)
        k3 = inv_b * (d3[0] * Mx + d3[1] * My + d3[2] * Mz) + kappa0(s)
        # q' = 1/2 q * (0, kappa), on the integrated (unnormalised) q
        w, a, b, c = y[3], y[4], y[5], y[6]
        return np.array((d1[0], d1[1], d1[2],
                         0.5 * (-a * k1 - b * k2 - c * k3),
                         0.5 * (w * k1 + b * k3 - c * k2),
                         0.5 * (w * k2 - a * k3 + c * k1),
                         0.5 * (w * k3 + a * k2 - b * k1)))

    y0 = np.concatenate((pose.p, pose.q))
    sol = solve_ivp(rhs, (0.0, 1.0), y0, method="DOP853", rtol=_SHOOT_RTOL,
                    atol=_SHOOT_RTOL, dense_output=True)
    return sol.sol if sol.success else None


def _basins(s: np.ndarray, size: np.ndarray, most: int) -> List[Tuple[float, float, float]]:
    """
    Return (s, lo, hi) for the local minima of the sampled ‖M‖ and their basins, at most ``most``.

    The basin of a minimum reaches the neighbouring maxima; the minima kept are the lowest, in
    order of s.
    """
    k = len(s)
    minima, maxima = [], [0]
    for i in range(k):
        left = size[i - 1] if i > 0 else math.inf
        right = size[i + 1] if i + 1 < k else math.inf
        if size[i] <= left and size[i] <= right and not (i > 0 and size[i] == left):
            minima.append(i)
        elif 0 < i < k - 1 and size[i] >= left and size[i] >= right:
            maxima.append(i)
    maxima.append(k - 1)
    minima = sorted(sorted(minima, key=lambda i: size[i])[:most])
    out = []
    for i in minima:
        lo = max(j for j in maxima if j <= i)
        hi = min(j for j in maxima if j >= i)
        out.append((float(s[i]), float(s[lo]), float(s[hi])))
    return out


def _refine(fit: _MomentFit, s: float, lo: float, hi: float) -> Tuple[float, np.ndarray]:
    """Gauss-Newton on ‖g‖^2 from s, kept in [lo, hi], each step halved until ‖g‖ decreases."""
    g = fit.misfit(s)
    size = float(g @ g)
    for _ in range(_GN_ITERATIONS):
        if size == 0.0:
            break
        try:
            d = fit.slope(s)
        except ConvergenceError:
            break
        dd = float(d @ d)
        gd = float(g @ d)
        # the step's predicted decrease of |g|^2 below rounding: converged
        if dd == 0.0 or gd * gd / dd <= 1e-28 + 1e-12 * size:
            break
        target = min(max(s - gd / dd, lo), hi)
        if abs(target - s) <= _S_TOL:  # converged (or pinned at a bound)
            break
        for _ in range(_HALVINGS):
            try:
                g_new = fit.misfit(target)
            except ConvergenceError:
                g_new = None
            if g_new is not None and float(g_new @ g_new) <= size:
                break
            target = s + 0.5 * (target - s)
        else:
            break
        s, g, size = target, g_new, float(g_new @ g_new)
    return s, g


def contact_from_wrench(shape: RodShape, pose: BasePose, force, moment, frame: str = "world",
                        min_force: float = 0.0, n: Optional[int] = None
                        ) -> Optional[ContactEstimate3D]:
    """
    Estimate the contact from one base wrench of a known 3D whisker (Huet et al. 2017).

    Units EI_b, L. The whisker (``shape``) is clamped at ``pose`` and touched at one point
    without a contact couple; the reading is the contact force and its moment about the base
    point. The contact arc length is the least-squares fit of the moment (see the module's
    docstring); the contact force is the measured force.

    Parameters
    ----------
    shape : RodShape
        The whisker's taper, intrinsic curvature and Poisson ratio.
    pose : BasePose
        The base pose of the reading.
    force : array_like
        The force of the contact on the whisker (3,) [EI_b / L^2].
    moment : array_like
        Its moment about the base point (3,) [EI_b / L].
    frame : {'world', 'base'}, optional
        The frame of ``force`` and ``moment``: the world, or the whisker's base frame as a
        sensor at the base reports them (turned into the world by R(q)). The estimate is in
        the world frame either way.
    min_force : float, optional
        A reading with ‖force‖ <= ``min_force`` has no usable contact (e.g. 3 sigma of the
        force's noise).
    n : int, optional
        Chebyshev points of the loaded solves; default
        :func:`~vibrissa_ros.core.rod3d.model.points_for` the shape.

    Returns
    -------
    ContactEstimate3D or None
        The estimate, with its residual and consistency for the user to judge the reading (data
        that no contact explains give the best fit and a large residual, never NaN); None when
        the force is 0 or at most ``min_force``: no contact (like the planar
        :func:`~vibrissa_ros.core.general.inverse.estimate_contact_general`).

    Raises
    ------
    ParameterError
        When ``force`` or ``moment`` is not three finite numbers (the message names the
        component), ``frame`` is not one of FRAMES, ``min_force`` is negative or not finite,
        or ``shape`` / ``pose`` are not a RodShape / BasePose.
    ConvergenceError
        When the whisker cannot be solved under the force at any arc length (a force of
        hundreds of EI_b / L^2).

    """
    if not isinstance(shape, RodShape):
        raise ParameterError(f"whisker shape {shape!r} must be a RodShape")
    if not isinstance(pose, BasePose):
        raise ParameterError(f"base pose {pose!r} must be a BasePose")
    if frame not in FRAMES:
        raise ParameterError(f"wrench frame {frame!r} must be one of {', '.join(FRAMES)}")
    try:
        min_force = float(min_force)
    except (TypeError, ValueError):
        raise ParameterError(f"min_force = {min_force!r} is not a number") from None
    if not (math.isfinite(min_force) and min_force >= 0.0):
        raise ParameterError(f"min_force = {min_force!r} must be finite and >= 0")
    F = _wrench_vector("force", force)
    M0 = _wrench_vector("moment", moment)
    if frame == "base":
        R = pose.rotation
        F, M0 = R @ F, R @ M0
    f = float(np.linalg.norm(F))
    if f == 0.0 or f <= min_force:
        return None
    m = float(np.linalg.norm(M0))
    consistency = min(1.0, abs(float(M0 @ F)) / (m * f)) if m > 0.0 else 0.0

    # the shot from the base under the part of M0 a contact can produce (M0 . F = 0)
    M0p = M0 - (float(M0 @ F) / (f * f)) * F
    shot = _shoot(shape, pose, F, M0p)
    if shot is None:
        raise ConvergenceError(
            f"3D inverse: the whisker cannot be integrated from the base under |F| = {f:.4g} "
            f"EI_b/L^2, |M0| = {m:.4g} EI_b/L"
        )
    grid = np.linspace(0.0, 1.0, _SCAN_POINTS)
    grid = grid[grid >= MIN_ARC_LENGTH]
    shape_at = shot(grid)
    size = np.linalg.norm(M0p - np.cross(shape_at[:3].T - pose.p, F), axis=1)

    def start(x):
        q = shot(np.asarray(x, dtype=float))[3:].T
        return q / np.linalg.norm(q, axis=1, keepdims=True)

    solver = RodSolver(shape, (), n=n)
    found = []
    # the shot's lowest minima only (data no contact explains leave many shallow ones)
    for s0, lo, hi in _basins(grid, size, _CANDIDATES):
        fit = _MomentFit(solver, pose, F, M0, start)
        try:
            s, g = _refine(fit, s0, lo, hi)
        except ConvergenceError:
            continue
        if all(abs(s - t) > _SAME_S for _, t, _ in found):  # two basins ending at one minimum
            found.append((float(np.linalg.norm(g)), s, fit))
    if not found:
        raise ConvergenceError(
            f"3D inverse: the whisker cannot be solved under |F| = {f:.4g} EI_b/L^2 near any "
            "candidate contact"
        )
    best = min(r for r, _, _ in found)
    # ties (within the forward model's accuracy): the contact nearest the base
    tie = best + 1e-10 * max(m, f)
    residual, s, fit = min((c for c in found if c[0] <= tie), key=lambda c: c[1])
    others = sorted((r, t) for r, t, _ in found if t != s)
    point = fit.point(s)
    try:
        slope = float(np.linalg.norm(fit.slope(s)))
    except ConvergenceError:
        slope = 0.0
    fitted = np.cross(point - fit.p, F)
    return ContactEstimate3D(
        pose, s, tuple(float(v) for v in point), tuple(float(v) for v in F),
        tuple(float(v) for v in M0), tuple(float(v) for v in fitted), residual, consistency,
        tuple(float(v) for v in fit.tangent(s)), slope,
        tuple((t, r) for r, t in others),
    )


__all__ = ["ContactEstimate3D", "FRAMES", "MIN_ARC_LENGTH", "TIP_TOLERANCE",
           "contact_from_wrench"]
