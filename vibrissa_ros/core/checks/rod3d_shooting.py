"""
The 3D whisker by shooting: the independent check of the 3D (Kirchhoff rod) solvers.

It shares nothing with the 3D collocation solver but the problem statement
(doc/mechanics/rod3d.md) and the shape and pose values (:class:`~vibrissa_ros.core.rod3d.RodShape`,
:class:`~vibrissa_ros.core.rod3d.BasePose`). From the clamped base it integrates the Kirchhoff
equations of the quasistatic, inextensible, unshearable rod (world frame, dimensionless L = 1,
EI_b = 1) with ``solve_ivp`` (DOP853, rtol 1e-13, atol 1e-14):

    r' = d1,   q' = 1/2 q * (0, kappa),   n' = 0,   M' = -d1 x n,

    kappa = (m1 / C(s), m2 / B(s), m3 / B(s) + kappa0(s)),   m = R(q)^T M,

with r the centerline, q the frame's unit quaternion (scalar first; R(q) = (d1 d2 d3), d1 the
tangent), n and M the world force and moment the part beyond s exerts on the part before it,
B(s) = (1 - (1 - taper) s)^4 and C(s) = B(s) / (1 + nu). The quaternion is not renormalised: its
drift ``| |q| - 1 |`` is reported (it stays at the integration's noise, ~1e-14). A contact force
F_c at s_c makes n drop by F_c when the integration passes s_c; M is continuous. Beyond the last
load n = 0 and M = 0 (a free tip).

Two problems are solved for the base's n(0), M(0) (and the contacts' unknowns) by a damped Newton
iteration on a forward-difference Jacobian (each column an integration), with
``scipy.optimize.root`` (``lm``) as a fallback:

* :func:`shoot_tip_load`: a force F and a moment M_tip at the tip, no obstacle. n = F everywhere,
  so the unknowns are M(0) (3) and the equations M(1) = M_tip.
* :func:`shoot_contacts`: frictionless contacts with obstacles, F_c = f_c nu_c with nu_c the
  obstacle's outward unit normal at r(s_c). Unknowns n(0), M(0) and per contact f_c (and s_c for a
  side contact); equations n(1+) = 0, M(1) = 0 and per contact distance(r(s_c)) = 0 (and
  d1(s_c) . nu_c = 0 on the side; s_c = 1 at the tip).

Both report the base load as the spec defines it: force = sum of the loads on the whisker and
moment = sum (r_c - p) x F_c (+ M_tip) about the base point p, world frame. Slow (every residual
is an ODE solve): it exists to check the fast solver, not to be used by product code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional, Sequence, Tuple

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import root

from ..errors import ParameterError

#: relative and absolute tolerance of the DOP853 integration
RTOL = 1e-13
ATOL = 1e-14
#: max-norm residual at which the Newton iteration stops
RESIDUAL_TOL = 1e-15
#: residual below which a Newton step that gains less than half ends the iteration (the
#: integration's noise is ~1e-14 relative to the loads)
NOISE_FLOOR = 1e-12
#: largest residual a solution may keep and still report success
RESIDUAL_ACCEPT = 1e-10
#: Newton iterations of one solve
MAX_NEWTON = 60
#: right-hand side evaluations one integration may use (a regular one uses about a thousand)
MAX_RHS_CALLS = 30_000
#: integrations one solve may use (a regular solve uses tens to a few hundred)
MAX_INTEGRATIONS = 3000
KINDS = ("side", "tip")


class _Unusable(Exception):
    """A trial point of the iteration cannot be integrated (internal)."""


# -- the Kirchhoff rod's right-hand side --------------------------------------------------------
def _rhs(shape, budget):
    """Return f(s, y) for y = (r (3), q (4), n (3), M (3)), counting calls in ``budget``."""
    a = 1.0 - shape.taper
    ratio = 1.0 + shape.poisson  # B / C
    linear = shape.parabola is None
    k0, k1 = shape.k0, shape.k1

    def rhs(s, y):
        budget[0] -= 1
        if budget[0] < 0:
            raise _Unusable("the integration takes too many steps (a load far too large)")
        _, _, _, w, x, v, z, n1, n2, n3, m1, m2, m3 = y
        if not 0.5 < w * w + x * x + v * v + z * z < 2.0:  # only far off a solution
            raise _Unusable("the frame's quaternion left unit length (a load far too large)")
        # the frame's columns (exact for a unit quaternion; scaled by |q|^2 otherwise)
        t1 = w * w + x * x - v * v - z * z
        t2 = 2.0 * (x * v + w * z)
        t3 = 2.0 * (x * z - w * v)
        e1 = 2.0 * (x * v - w * z)
        e2 = w * w - x * x + v * v - z * z
        e3 = 2.0 * (v * z + w * x)
        g1 = 2.0 * (x * z + w * v)
        g2 = 2.0 * (v * z - w * x)
        g3 = w * w - x * x - v * v + z * z
        b = 1.0 - a * s
        b *= b
        b *= b
        kap0 = k0 + k1 * s if linear else float(shape.curvature(s))
        c1 = (t1 * m1 + t2 * m2 + t3 * m3) * ratio / b
        c2 = (e1 * m1 + e2 * m2 + e3 * m3) / b
        c3 = (g1 * m1 + g2 * m2 + g3 * m3) / b + kap0
        return [
            t1, t2, t3,
            0.5 * (-x * c1 - v * c2 - z * c3),
            0.5 * (w * c1 + v * c3 - z * c2),
            0.5 * (w * c2 - x * c3 + z * c1),
            0.5 * (w * c3 + x * c2 - v * c1),
            0.0, 0.0, 0.0,
            -(t2 * n3 - t3 * n2), -(t3 * n1 - t1 * n3), -(t1 * n2 - t2 * n1),
        ]

    return rhs


def _frame(q) -> np.ndarray:
    """Return R(q) (3, 3) of a (nearly) unit quaternion, columns d1, d2, d3."""
    w, x, v, z = q
    return np.array([
        [w * w + x * x - v * v - z * z, 2.0 * (x * v - w * z), 2.0 * (x * z + w * v)],
        [2.0 * (x * v + w * z), w * w - x * x + v * v - z * z, 2.0 * (v * z - w * x)],
        [2.0 * (x * z - w * v), 2.0 * (v * z + w * x), w * w - x * x - v * v + z * z],
    ])


class _Integrator:
    """Piecewise integration of the rod between loads (internal)."""

    def __init__(self, shape, pose):
        self.shape = shape
        self.p = np.array(pose.position, dtype=float)
        self.q = np.array(pose.quaternion, dtype=float)
        self.calls = 0
        self.limit = math.inf  # the integrations allowed (a solve sets its own budget)
        self.drift = 0.0
        # beyond s = 1 the ODE extends smoothly while B > 0: trial arc lengths may go there
        self.s_cap = 1.5 if shape.taper == 1.0 else min(
            1.5, 0.5 * (1.0 + 1.0 / (1.0 - shape.taper)))

    def start(self, n0, m0) -> np.ndarray:
        return np.concatenate((self.p, self.q, n0, m0))

    def segment(self, a, b, y, t_eval=None):
        """Integrate y from a to b; return the end state (and the states at ``t_eval``)."""
        if not (math.isfinite(b) and -0.5 <= b <= self.s_cap):
            raise _Unusable(f"arc length {b!r} out of reach")
        self.calls += 1
        if self.calls > self.limit:
            raise _Unusable(f"more than {MAX_INTEGRATIONS} integrations in one solve")
        if b == a:
            return y.copy(), (None if t_eval is None else np.tile(y[:, None], len(t_eval)))
        budget = [MAX_RHS_CALLS]
        sol = solve_ivp(_rhs(self.shape, budget), (a, b), y, method="DOP853", rtol=RTOL,
                        atol=ATOL, t_eval=t_eval)
        if not sol.success or not np.all(np.isfinite(sol.y)):
            raise _Unusable(f"the integration failed: {sol.message}")
        end = sol.y[:, -1].copy() if t_eval is None else None
        if t_eval is None:
            self.drift = max(self.drift, abs(math.sqrt(end[3:7] @ end[3:7]) - 1.0))
            return end, None
        return None, sol.y


# -- the Newton iteration -----------------------------------------------------------------------
def _newton(fun, x0, scale):
    """
    Solve fun(x) = 0 by damped Newton with a forward-difference Jacobian.

    Returns (x, residual max-norm, message, iterations). A trial point ``fun`` cannot evaluate
    (it raises _Unusable) halves the step.
    """
    x = np.array(x0, dtype=float)
    try:
        r = fun(x)
    except _Unusable as exc:
        return x, math.inf, f"the initial guess cannot be integrated: {exc}", 0
    norm = float(np.max(np.abs(r)))
    for it in range(MAX_NEWTON):
        if norm <= RESIDUAL_TOL:
            return x, norm, "converged", it
        jac = np.empty((r.size, x.size))
        try:
            for j in range(x.size):
                h = 1e-7 * max(scale[j], abs(x[j]))
                xj = x.copy()
                xj[j] += h
                jac[:, j] = (fun(xj) - r) / h
        except _Unusable as exc:
            return x, norm, f"the Jacobian cannot be evaluated: {exc}", it
        try:
            dx = np.linalg.solve(jac, -r)
        except np.linalg.LinAlgError:
            dx = np.linalg.lstsq(jac, -r, rcond=None)[0]
        step, nt, rt, trial = 1.0, math.inf, r, x
        for _ in range(30):
            trial = x + step * dx
            try:
                rt = fun(trial)
                nt = float(np.max(np.abs(rt)))
            except _Unusable:
                nt = math.inf
            if nt < norm or (step == 1.0 and norm <= NOISE_FLOOR):
                break
            step *= 0.5
        if not nt < norm:
            if norm <= NOISE_FLOOR:
                return x, norm, "converged (at the noise floor)", it
            return x, norm, "the Newton step does not reduce the residual", it
        stalled = nt > 0.5 * norm and nt <= NOISE_FLOOR
        x, r, norm = trial, rt, nt
        if stalled:  # at the integration's noise floor
            return x, norm, "converged (at the noise floor)", it + 1
    return x, norm, f"no convergence in {MAX_NEWTON} Newton iterations", MAX_NEWTON


def _solve(fun, x0, scale, ig, limit=MAX_INTEGRATIONS, fallback=True):
    """Newton, then ``scipy.optimize.root`` (lm) when Newton did not reach the tolerance."""
    ig.limit = ig.calls + limit
    try:
        if not fallback:
            return _newton(fun, x0, scale)[:3]
        return _solve_within(fun, x0, scale)
    finally:
        ig.limit = math.inf


def _solve_within(fun, x0, scale):
    x, norm, message, _ = _newton(fun, x0, scale)
    if norm <= RESIDUAL_ACCEPT:
        return x, norm, message

    def safe(v):
        try:
            return fun(v)
        except _Unusable:
            return np.full(len(v), 1e6)

    try:
        res = root(safe, x if math.isfinite(norm) else x0, method="lm",
                   options={"xtol": 1e-15, "ftol": 1e-15})
    except (ValueError, FloatingPointError) as exc:  # pragma: no cover - defensive
        return x, norm, f"{message}; lm: {exc}"
    try:
        norm_lm = float(np.max(np.abs(fun(res.x))))
    except _Unusable:
        norm_lm = math.inf
    if norm_lm < norm:
        x, norm = res.x, norm_lm
        x, norm2, message, _ = _newton(fun, x, scale)  # polish
        norm = min(norm, norm2)
        return x, norm, f"lm then Newton: {message}"
    return x, norm, message


# -- input checks -------------------------------------------------------------------------------
def _vector(what, value, size=3) -> np.ndarray:
    try:
        v = np.array(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ParameterError(f"{what} {value!r} is not a vector of numbers") from None
    if v.size != size or not np.all(np.isfinite(v)):
        raise ParameterError(f"{what} {value!r} must be {size} finite numbers")
    return v


def _points(points) -> int:
    if isinstance(points, bool) or int(points) != points or int(points) < 2:
        raise ParameterError(f"points = {points!r}: need an integer >= 2")
    return int(points)


def _check_shape_pose(shape, pose):
    for key in ("taper", "k0", "k1", "parabola", "poisson", "curvature"):
        if not hasattr(shape, key):
            raise ParameterError(f"shape {shape!r} is not a RodShape (no {key})")
    for key in ("position", "quaternion"):
        if not hasattr(pose, key):
            raise ParameterError(f"pose {pose!r} is not a BasePose (no {key})")


# -- a tip load ---------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class TipLoadResult:
    """
    The rod clamped at its base and loaded at its tip, solved by shooting.

    Returned by :func:`shoot_tip_load`; the parameters are the dataclass's fields, kept as
    attributes of the same names (world frame, dimensionless: L, EI_b / L^2, EI_b / L).

    Parameters
    ----------
    s : numpy.ndarray
        Arc lengths (m,) of the samples, 0 to 1.
    centerline : numpy.ndarray
        The centerline r(s) (m, 3).
    frames : numpy.ndarray
        The frames R(s) (m, 3, 3), columns d1 (tangent), d2, d3.
    tip : numpy.ndarray
        r(1) (3,).
    tip_frame : numpy.ndarray
        R(1) (3, 3).
    force : numpy.ndarray
        The base force (3,): the tip force F (= n(0)).
    moment : numpy.ndarray
        The base moment (3,) about the base point p: (r(1) - p) x F + M_tip (= M(0) solved).
    internal_moment : numpy.ndarray
        M(0) (3,) as the shooting found it (equals ``moment`` to the residual).
    residual : float
        max abs(M(1) - M_tip) of the solution.
    drift : float
        Largest abs(norm(q) - 1) of the frame's quaternion at the ends of the integrations.
    success : bool
        Whether the residual is below :data:`RESIDUAL_ACCEPT`.
    message : str
        How the solve ended.

    """

    s: np.ndarray
    centerline: np.ndarray
    frames: np.ndarray
    tip: np.ndarray
    tip_frame: np.ndarray
    force: np.ndarray
    moment: np.ndarray
    internal_moment: np.ndarray
    residual: float
    drift: float
    success: bool
    message: str


def _free_tip(shape, pose) -> np.ndarray:
    """Return the unloaded whisker's tip (3,) in the world."""
    off = shape.intrinsic_offset(0.0, 1.0)[0]
    return np.array(pose.position) + _frame(pose.quaternion) @ np.array([off[0], off[1], 0.0])


def shoot_tip_load(shape, pose, force, moment, points: int = 101) -> TipLoadResult:
    """
    Solve the rod clamped at ``pose`` under a tip force and a tip moment, by shooting.

    The force F and the moment M_tip (about the tip point) act on the tip; n(s) = F all along,
    and the unknown M(0) is solved so that M(1) = M_tip. Large loads are followed from zero by
    continuation in the load's size when the direct solve fails.

    Parameters
    ----------
    shape : RodShape
        The whisker's taper, intrinsic curvature and Poisson ratio.
    pose : BasePose
        The base's position and orientation (clamped).
    force : array_like
        F (3,) on the tip, world frame [EI_b / L^2].
    moment : array_like
        M_tip (3,) on the tip, world frame [EI_b / L].
    points : int, optional
        The number of centerline samples (>= 2), uniform in s from 0 to 1.

    Returns
    -------
    TipLoadResult
        The centerline, tip, base load; ``success`` False (with a message) when the shooting did
        not converge.

    Raises
    ------
    ParameterError
        When the force or moment is not 3 finite numbers, ``points`` < 2, or the shape or pose
        is not of the right kind.

    """
    _check_shape_pose(shape, pose)
    force = _vector("tip force", force)
    moment = _vector("tip moment", moment)
    points = _points(points)
    ig = _Integrator(shape, pose)
    p = ig.p

    def fun_at(load):
        f, m = load * force, load * moment

        def fun(m0):
            end, _ = ig.segment(0.0, 1.0, ig.start(f, m0))
            return end[10:13] - m

        return fun

    def guess(load):
        return load * (np.cross(_free_tip(shape, pose) - p, force) + moment)

    scale = np.full(3, 1.0)
    # directly from the rigid whisker's base moment, on a small budget: a large load's guess
    # is far off and its Newton trials curl the rod up (expensive integrations)
    m0, norm, message = _solve(fun_at(1.0), guess(1.0), scale, ig, limit=60, fallback=False)
    if norm > RESIDUAL_ACCEPT:  # continuation from the unloaded rod, a secant predictor
        for steps in (4, 16, 64):
            path = [(0.0, guess(0.0))]
            for k in range(1, steps + 1):
                lam = k / steps
                if len(path) < 2:
                    start = guess(lam)
                else:
                    (l0, v0), (l1, v1) = path[-2:]
                    start = v1 + (lam - l1) / (l1 - l0) * (v1 - v0)
                m0, norm, message = _solve(fun_at(lam), start, scale, ig)
                if norm > RESIDUAL_ACCEPT:
                    break
                path.append((lam, m0))
            if norm <= RESIDUAL_ACCEPT:
                message = f"{message} (continuation in {steps} steps)"
                break
    y0 = ig.start(force, m0)
    s = np.linspace(0.0, 1.0, points)
    try:
        end, _ = ig.segment(0.0, 1.0, y0)
        _, ys = ig.segment(0.0, 1.0, y0, t_eval=s)
    except _Unusable as exc:
        nan = np.full(3, np.nan)
        return TipLoadResult(s, np.full((points, 3), np.nan), np.full((points, 3, 3), np.nan),
                             nan, np.full((3, 3), np.nan), force, nan, m0, math.inf, ig.drift,
                             False, f"the solution cannot be integrated: {exc}")
    ys[:, -1] = end  # the tip exactly as the shooting integrated it
    tip = end[:3].copy()
    base_moment = np.cross(tip - p, force) + moment
    success = bool(norm <= RESIDUAL_ACCEPT)
    return TipLoadResult(
        s=s, centerline=ys[:3].T.copy(), frames=np.array([_frame(q) for q in ys[3:7].T]),
        tip=tip, tip_frame=_frame(end[3:7]), force=force.copy(), moment=base_moment,
        internal_moment=np.array(m0), residual=float(norm), drift=float(ig.drift),
        success=success, message=message if success else f"no convergence: {message}")


# -- contacts -----------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class ContactShot:
    """
    One contact of a 3D equilibrium (world frame, dimensionless).

    Parameters
    ----------
    kind : str
        'side' or 'tip'.
    s : float
        The arc length of the contact [L] (1 at the tip).
    f : float
        The normal force's magnitude [EI_b / L^2] (>= 0 for an admissible contact).
    point : numpy.ndarray
        r(s) (3,).
    force : numpy.ndarray
        F = f nu (3,), the obstacle's force on the whisker.
    normal : numpy.ndarray
        nu (3,), the obstacle's outward unit normal at ``point``.
    tangent : numpy.ndarray
        d1(s) (3,), the whisker's tangent there.
    distance : float
        The obstacle's signed distance at ``point`` (0 to the residual).

    """

    kind: str
    s: float
    f: float
    point: np.ndarray
    force: np.ndarray
    normal: np.ndarray
    tangent: np.ndarray
    distance: float


@dataclass(frozen=True, eq=False)
class Samples:
    """
    The rod's state sampled along its arc length (world frame).

    Parameters
    ----------
    s : numpy.ndarray
        Arc lengths (m,).
    r : numpy.ndarray
        Centerline points (m, 3).
    frames : numpy.ndarray
        Frames R(s) (m, 3, 3), columns d1, d2, d3.
    n : numpy.ndarray
        Internal force (m, 3): the sum of the contact forces beyond s (at a contact, the
        right limit).
    M : numpy.ndarray
        Internal moment (m, 3) about r(s).

    """

    s: np.ndarray
    r: np.ndarray
    frames: np.ndarray
    n: np.ndarray
    M: np.ndarray


@dataclass(frozen=True, eq=False)
class ContactsResult:
    """
    An equilibrium of the rod with frictionless contacts, found by shooting.

    Returned by :func:`shoot_contacts`; the parameters are the dataclass's fields, kept as
    attributes of the same names (world frame, dimensionless).

    Parameters
    ----------
    contacts : tuple of ContactShot
        The contacts, in the order given.
    force : numpy.ndarray
        The base force (3,): sum of the contact forces.
    moment : numpy.ndarray
        The base moment (3,): sum (r_c - p) x F_c about the base point p.
    n0, m0 : numpy.ndarray
        n(0) and M(0) (3,) as the shooting found them (equal ``force`` and ``moment`` to the
        residual).
    tip : numpy.ndarray
        r(1) (3,).
    tip_frame : numpy.ndarray
        R(1) (3, 3).
    residual : float
        The max norm of the solved equations.
    drift : float
        Largest abs(norm(q) - 1) at the ends of the integrations.
    success : bool
        Whether the residual is below :data:`RESIDUAL_ACCEPT`.
    message : str
        How the solve ended.
    integrations : int
        The ODE integrations the solve used.
    _problem : object, optional
        The shooting problem (internal: :meth:`sample` re-integrates it).
    _x : numpy.ndarray, optional
        The solved unknowns (internal).

    """

    contacts: Tuple[ContactShot, ...]
    force: np.ndarray
    moment: np.ndarray
    n0: np.ndarray
    m0: np.ndarray
    tip: np.ndarray
    tip_frame: np.ndarray
    residual: float
    drift: float
    success: bool
    message: str
    integrations: int
    _problem: object = field(default=None, repr=False)
    _x: Optional[np.ndarray] = field(default=None, repr=False)

    @property
    def admissible(self) -> bool:
        """Whether every contact pushes (f >= 0) and a tip points into its surface."""
        return all(c.f >= 0.0 and (c.kind == "side" or c.tangent @ c.normal <= 1e-12)
                   for c in self.contacts)

    def sample(self, points: int = 101) -> Samples:
        """
        Return the state sampled at ``points`` arc lengths uniform in [0, 1].

        Parameters
        ----------
        points : int, optional
            The number of samples (>= 2).

        Returns
        -------
        Samples
            r, R, n, M at the samples.

        Raises
        ------
        ParameterError
            When ``points`` < 2.

        """
        s = np.linspace(0.0, 1.0, _points(points))
        return self._problem.sample(self._x, s)

    def centerline(self, points: int = 101) -> np.ndarray:
        """
        Return the centerline sampled at ``points`` arc lengths uniform in [0, 1].

        Parameters
        ----------
        points : int, optional
            The number of samples (>= 2).

        Returns
        -------
        numpy.ndarray
            r(s) (points, 3), from the base to the tip.

        Raises
        ------
        ParameterError
            When ``points`` < 2.

        """
        return self.sample(points).r


class _ContactProblem:
    """Unknowns x = (n0 (3), M0 (3), per contact [s,] f) and their residuals (internal)."""

    def __init__(self, shape, pose, obstacles, kinds):
        self.ig = _Integrator(shape, pose)
        self.obstacles, self.kinds = tuple(obstacles), tuple(kinds)
        self.index = []
        i = 6
        for kind in self.kinds:
            self.index.append(i)
            i += 2 if kind == "side" else 1
        self.size = i

    def arcs(self, x):
        return [x[i] if k == "side" else 1.0 for k, i in zip(self.kinds, self.index)]

    def forces(self, x):
        return [x[i + 1] if k == "side" else x[i] for k, i in zip(self.kinds, self.index)]

    def run(self, x, s_eval=None):
        """
        Integrate from the base through the contacts.

        Returns the states at the contacts (left limits), the normals there and the end state
        (n already past the last load); with ``s_eval``, the states there too.
        """
        arcs, mags = self.arcs(x), self.forces(x)
        order = sorted(range(len(arcs)), key=lambda c: arcs[c])
        y = self.ig.start(x[0:3], x[3:6])
        s_now = 0.0
        states, normals = [None] * len(arcs), [None] * len(arcs)
        out = None if s_eval is None else np.empty((13, len(s_eval)))

        def fill(a, b, y, last=False):
            if s_eval is None:
                return
            sel = (s_eval >= a) & ((s_eval <= b) if last else (s_eval < b))
            if np.any(sel):
                _, ys = self.ig.segment(a, b, y, t_eval=s_eval[sel])
                out[:, sel] = ys

        for c in order:
            s_c = arcs[c]
            if s_eval is not None and s_c > s_now:
                fill(s_now, s_c, y)
            y, _ = self.ig.segment(s_now, s_c, y)
            s_now = s_c
            states[c] = y.copy()
            sp = self.obstacles[c].surface(y[:3].copy())
            nu = np.asarray(sp.normal, dtype=float)
            normals[c] = (float(sp.distance), nu)
            y = y.copy()
            y[7:10] -= mags[c] * nu
        end = y
        if s_now < 1.0:
            if s_eval is not None:
                fill(s_now, 1.0, y, last=True)
            end, _ = self.ig.segment(s_now, 1.0, y)
        elif s_eval is not None:
            fill(s_now, 1.0, y, last=True)
        return states, normals, end, out

    def residual(self, x):
        states, normals, end, _ = self.run(x)
        res = list(end[7:10]) + list(end[10:13])
        for c, kind in enumerate(self.kinds):
            dist, nu = normals[c]
            res.append(dist)
            if kind == "side":
                res.append(float(_frame(states[c][3:7])[:, 0] @ nu))
        return np.array(res)

    def sample(self, x, s):
        _, _, _, out = self.run(x, s_eval=s)
        return Samples(s=s, r=out[:3].T.copy(), frames=np.array([_frame(q) for q in out[3:7].T]),
                       n=out[7:10].T.copy(), M=out[10:13].T.copy())


def _base_guess(shape, pose, obstacles, kinds, arcs, mags):
    """
    Return (n0, M0) of the guessed contact forces applied at the unloaded whisker's points.

    It is exact as the loads vanish (the rigid whisker's base load) and first-order off for
    small deflections; :func:`shoot_contacts` then solves the base load with the contacts' guesses
    held (a well-posed 6-unknown shot) before the full solve.
    """
    p = np.array(pose.position)
    rot = _frame(pose.quaternion)
    n0, m0 = np.zeros(3), np.zeros(3)
    for ob, s, f in zip(obstacles, arcs, mags):
        off = shape.intrinsic_offset(0.0, s)[0]
        r = p + rot @ np.array([off[0], off[1], 0.0])
        nu = np.asarray(ob.surface(r).normal, dtype=float)
        n0 += f * nu
        m0 += np.cross(r - p, f * nu)
    return n0, m0


def shoot_contacts(shape, pose, contacts: Sequence, guess: Sequence,
                   base_guess=None) -> ContactsResult:
    """
    Solve the rod clamped at ``pose`` and touching obstacles, by shooting.

    Contacts are frictionless: the force on the whisker is F_c = f_c nu_c, nu_c the obstacle's
    outward unit normal at the contact point r(s_c). A side contact has unknowns (s_c, f_c) and
    equations distance(r(s_c)) = 0, d1(s_c) . nu_c = 0; a tip contact has f_c with s_c = 1 and
    distance(r(1)) = 0. With the base's n(0), M(0) and the free tip's n(1+) = 0, M(1) = 0 the
    system is square. Its sign conditions (f_c >= 0, a tip pointing into the surface) are not
    imposed: see :attr:`ContactsResult.admissible`.

    Without ``base_guess``, the base load starts as the guessed contact forces applied at the
    unloaded whisker's points, and is first solved with the contacts' guesses held fixed.

    Parameters
    ----------
    shape : RodShape
        The whisker's taper, intrinsic curvature and Poisson ratio.
    pose : BasePose
        The base's position and orientation (clamped).
    contacts : sequence of (obstacle, str)
        Per contact the obstacle (with ``surface(point (3,))`` returning an object with
        ``distance`` and ``normal`` (3,), the outward unit normal) and its kind, 'side' or 'tip'.
        At most one tip contact.
    guess : sequence of (float, float)
        Per contact the starting (s_c, f_c); s_c is ignored for a tip contact.
    base_guess : tuple of array_like, optional
        Starting (n(0), M(0)), each (3,).

    Returns
    -------
    ContactsResult
        The contacts, base load and tip; ``success`` False (with a message) when the shooting
        did not converge.

    Raises
    ------
    ParameterError
        When a kind is unknown, an obstacle has no ``surface``, the guesses do not match the
        contacts or are not finite, a side guess is not in (0, 1), there are several tip
        contacts or none at all, or the shape or pose is not of the right kind.

    """
    _check_shape_pose(shape, pose)
    contacts = list(contacts)
    guess = list(guess)
    if not contacts:
        raise ParameterError("shoot_contacts needs at least one contact")
    if len(guess) != len(contacts):
        raise ParameterError(f"{len(guess)} guesses for {len(contacts)} contacts")
    obstacles, kinds = [], []
    for item in contacts:
        try:
            ob, kind = item
        except (TypeError, ValueError):
            raise ParameterError(f"contact {item!r} is not a pair (obstacle, kind)") from None
        if kind not in KINDS:
            raise ParameterError(f"contact kind {kind!r} is not one of {', '.join(KINDS)}")
        if not callable(getattr(ob, "surface", None)):
            raise ParameterError(f"obstacle {ob!r} has no surface(point) method")
        obstacles.append(ob)
        kinds.append(kind)
    if kinds.count("tip") > 1:
        raise ParameterError("at most one tip contact")
    arcs, mags = [], []
    for kind, g in zip(kinds, guess):
        s, f = _vector("contact guess (s, f)", g, 2)
        if kind == "side" and not 0.0 < s < 1.0:
            raise ParameterError(f"side contact guess s = {s!r} must be in (0, 1)")
        arcs.append(s if kind == "side" else 1.0)
        mags.append(f)
    problem = _ContactProblem(shape, pose, obstacles, kinds)
    x0 = np.zeros(problem.size)
    for kind, i, s, f in zip(kinds, problem.index, arcs, mags):
        if kind == "side":
            x0[i], x0[i + 1] = s, f
        else:
            x0[i] = f
    message = ""
    if base_guess is not None:
        try:
            n0, m0 = base_guess
        except (TypeError, ValueError):
            raise ParameterError("base_guess must be a pair (n0, M0)") from None
        x0[0:3], x0[3:6] = _vector("base guess n0", n0), _vector("base guess M0", m0)
    else:
        x0[0:3], x0[3:6] = _base_guess(shape, pose, obstacles, kinds, arcs, mags)
        held = x0.copy()

        def base_only(v):
            held[:6] = v
            return problem.residual(held)[:6]

        v, _, _ = _solve(base_only, x0[:6], np.ones(6), problem.ig)
        x0[:6] = v
    scale = np.ones(problem.size)
    x, norm, message = _solve(problem.residual, x0, scale, problem.ig)
    return _contacts_result(problem, pose, x, norm, message)


def _contacts_result(problem, pose, x, norm, message) -> ContactsResult:
    p = np.array(pose.position)
    nan3 = np.full(3, np.nan)
    try:
        states, normals, end, _ = problem.run(x)
        y_end = end
    except _Unusable as exc:
        return ContactsResult((), nan3, nan3, x[0:3], x[3:6], nan3, np.full((3, 3), np.nan),
                              math.inf, problem.ig.drift, False,
                              f"the solution cannot be integrated: {exc}", problem.ig.calls,
                              problem, x)
    shots = []
    force, moment = np.zeros(3), np.zeros(3)
    for kind, s, f, st, (dist, nu) in zip(problem.kinds, problem.arcs(x), problem.forces(x),
                                          states, normals):
        fc = f * nu
        shots.append(ContactShot(kind, float(s), float(f), st[:3].copy(), fc, nu.copy(),
                                 _frame(st[3:7])[:, 0].copy(), dist))
        force += fc
        moment += np.cross(st[:3] - p, fc)
    success = bool(norm <= RESIDUAL_ACCEPT)
    if success and not all(0.0 < c.s <= 1.0 for c in shots):
        success = False
        message = "a contact's arc length left (0, 1]"
    elif not success:
        message = f"no convergence: {message}"
    return ContactsResult(tuple(shots), force, moment, x[0:3].copy(), x[3:6].copy(),
                          y_end[:3].copy(), _frame(y_end[3:7]), float(norm),
                          float(problem.ig.drift), success, message, problem.ig.calls,
                          problem, x.copy())
