"""
Several contacts with Coulomb friction by shooting: the independent check of scene solvers.

The whisker (``WhiskerShape``: B(s) = (1 - (1 - taper) s)^4, kappa0 = k0 + k1 s) is clamped at
the foot pose and touched at arc lengths s_1 <= ... <= s_k by forces F_c (of the obstacle on the
whisker, world frame). With N_in(s) = sum of the forces beyond s (the inner force), the bending
moment M(s) = sum_{s_c > s} (r(s_c) - r(s)) x F_c obeys

    x' = cos theta,  y' = sin theta,  theta' = kappa0(s) + M / B(s),
    M' = -(r' x N_in) = sin(theta) N_in,x - cos(theta) N_in,y,

and M vanishes at the last contact (no point moment anywhere). This module integrates that system
from the foot (x, y, theta = heading, M = m0) with ``solve_ivp`` (DOP853, rtol 1e-13 by default),
stopping at every contact, where the inner force drops by F_c, and solves for the unknowns with a
bounded damped Newton iteration on a finite-difference Jacobian. Unknowns and equations of each
contact (world frame; n(u) = (sin phi, -cos phi) the arc's outward normal, t(u) its tangent):

========== ===================== ============================================================
kind       unknowns              equations
========== ===================== ============================================================
side       s, u, N (+ T: stick)  r(s) = point(u), sin(theta(s) - phi(u)) = 0 (+ q = anchor)
corner     s, Fx, Fy             r(s) = V, slip: T + slip_sign mu N = 0 (stick: q = anchor)
tip        u, N (+ T: stick)     r(1) = point(u) (+ q = anchor)
tip_corner Fx, Fy                r(1) = V
========== ===================== ============================================================

plus the base moment m0 with M(s_last) = 0. Side and tip: F = N n(u) + T t(u), a slip contact has
T = -slip_sign mu N. Corner: F = N nu + T tau with tau = (cos theta(s), sin theta(s)) and
nu = e (-sin theta(s), cos theta(s)) (e = ``ContactSpec.side``); its force is solved for directly
so that theta(s) never has to be known before the integration reaches s. The slip coordinate q:
side sigma(u) - e s (e = sign cos(theta - phi)), corner -s, tip sigma(u), with sigma(u) the arc
length along the arc from u = 0.

Nothing here is shared with the collocation solvers except the geometry of ``boundary.py``. It is
slow (every residual is an ODE solve; tens of milliseconds per equilibrium) and exists to check the
fast solvers: equilibria, golden values and events located on a path of foot poses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

from ..scenes.boundary import Arc, CircleArc, GraphArc, SegmentArc, Vertex
from ..errors import ConvergenceError, ParameterError
from ..general.model import WhiskerShape
from ..state import FootPose

KINDS = ("side", "corner", "tip", "tip_corner")
FRICTION_STATES = ("stick", "slip")

#: default relative and absolute tolerance of the DOP853 integration
RTOL = 1e-13
#: residual (max norm) at which Newton stops; the integration's noise floor is ~1e-15
RESIDUAL_TOL = 1e-13
#: largest residual an equilibrium may keep (else ConvergenceError)
RESIDUAL_ACCEPT = 1e-10
#: Newton iterations of one solve
MAX_NEWTON = 60
#: right-hand side evaluations one integration may use (a regular one uses a few hundred)
MAX_RHS_CALLS = 20000
#: largest contact force a trial point may carry [EI_b / L^2] (beyond: a step too far)
MAX_FORCE = 1e5

_TWO_PI = 2.0 * math.pi


class _Unusable(Exception):
    """A trial point of the Newton iteration cannot be integrated (internal)."""


@dataclass(frozen=True)
class ContactSpec:
    """
    One contact: what touches what, its friction state and initial guesses.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    kind : {'side', 'corner', 'tip', 'tip_corner'}
        ``side`` (the whisker's side on a smooth arc), ``corner`` (its side on a vertex),
        ``tip`` (the tip on an arc) or ``tip_corner`` (the tip on a vertex).
    feature : Arc or Vertex
        An arc for side and tip, a vertex for corner and tip_corner.
    friction : {'slip', 'stick'}, optional
        ``stick`` (T unknown, q held at ``anchor``) or ``slip`` (T = -slip_sign mu N). With
        mu = 0 a contact always slips with T = 0.
    mu : float, optional
        Coulomb coefficient >= 0.
    anchor : float, optional
        Stick: the slip coordinate q that is held [L].
    slip_sign : {0, -1, 1}, optional
        Slip: -1, 0 or +1, the sign of dq/dt along the motion.
    side : {1, -1}, optional
        Corner: e = +-1, the side of the whisker's normal the force pushes to.
    s, u, N, T : float, optional
        Initial guesses: arc length, arc parameter, normal and tangential force [EI_b / L^2].
        For tip_corner, N and T are the force's components along the bisector of the vertex's
        normal cone and its tangent (cos, sin of the bisector's tangent angle).

    Raises
    ------
    ParameterError
        When a field is out of its range: an unknown kind or friction state, a feature of the
        wrong type for the kind, a non-finite number, mu < 0, slip_sign or side out of range.

    """

    kind: str
    feature: object
    friction: str = "slip"
    mu: float = 0.0
    anchor: float = 0.0
    slip_sign: int = 0
    side: int = 1
    s: float = 0.5
    u: float = 0.0
    N: float = 0.0
    T: float = 0.0

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ParameterError(f"contact kind {self.kind!r} is not one of {', '.join(KINDS)}")
        wants_vertex = self.kind in ("corner", "tip_corner")
        if wants_vertex and not isinstance(self.feature, Vertex):
            raise ParameterError(f"a {self.kind} contact needs a boundary.Vertex, "
                                 f"got {type(self.feature).__name__}")
        if not wants_vertex and not isinstance(self.feature, Arc):
            raise ParameterError(f"a {self.kind} contact needs a boundary.Arc, "
                                 f"got {type(self.feature).__name__}")
        if self.friction not in FRICTION_STATES:
            raise ParameterError(f"contact friction {self.friction!r} must be 'stick' or 'slip'")
        for key in ("mu", "anchor", "s", "u", "N", "T"):
            value = float(getattr(self, key))
            if not math.isfinite(value):
                raise ParameterError(f"contact {key} = {value!r} must be finite")
            object.__setattr__(self, key, value)
        if self.mu < 0.0:
            raise ParameterError(f"friction coefficient mu = {self.mu!r} must be >= 0")
        if self.slip_sign not in (-1, 0, 1):
            raise ParameterError(f"slip_sign = {self.slip_sign!r} must be -1, 0 or +1")
        if self.side not in (-1, 1):
            raise ParameterError(f"corner side e = {self.side!r} must be -1 or +1")

    @property
    def sticks(self) -> bool:
        """Tell whether T is an unknown held by q = anchor (stick with mu > 0)."""
        return self.friction == "stick" and self.mu > 0.0 and self.kind != "tip_corner"


@dataclass(frozen=True)
class ContactSolution:
    """
    One contact of an equilibrium (world frame, units L and EI_b / L^2).

    ``u`` is None at a vertex, ``q`` (the slip coordinate) None at a tip on a vertex. ``theta``
    is the whisker's slope at the contact, ``N`` and ``T`` the normal and tangential force as
    defined for the kind (module docstring), ``fx, fy`` the force on the whisker.
    """

    kind: str
    friction: str
    mu: float
    s: float
    u: Optional[float]
    x: float
    y: float
    fx: float
    fy: float
    N: float
    T: float
    q: Optional[float]
    theta: float


@dataclass(frozen=True)
class SceneEquilibrium:
    """
    An equilibrium of the whisker under several contacts, found by shooting.

    Returned by :func:`solve_scene_equilibrium`; the parameters are the dataclass's fields, kept
    as attributes of the same names (world frame, units L, EI_b / L^2 and EI_b / L).

    Parameters
    ----------
    shape : WhiskerShape
        The whisker's taper and intrinsic curvature.
    pose : FootPose
        Where the foot is clamped.
    contacts : tuple of ContactSolution
        The contacts solved, in the order of ``specs``.
    specs : tuple of ContactSpec
        The contacts as specified (their guesses are those the solve started from).
    fx, fy : float
        The total force of the obstacles on the whisker.
    m0 : float
        M(0), the base moment (counter-clockwise positive): with ``fx, fy``, what the
        follicle's sensor measures.
    tip : tuple of float
        The tip's position (x, y).
    tip_slope : float
        The whisker's slope at the tip.
    residual : float
        The max norm of the solved equations.
    evaluations : int
        The number of ODE integrations it took.
    rtol : float
        The relative tolerance of the integration.

    Other Parameters
    ----------------
    _pieces : tuple
        The integrated pieces :meth:`state` evaluates (internal).

    """

    shape: WhiskerShape
    pose: FootPose
    contacts: Tuple[ContactSolution, ...]
    specs: Tuple[ContactSpec, ...]
    fx: float
    fy: float
    m0: float
    tip: Tuple[float, float]
    tip_slope: float
    residual: float
    evaluations: int
    rtol: float
    _pieces: Tuple = field(default=(), repr=False, compare=False)

    def state(self, s) -> np.ndarray:
        """Return (x, y, theta, M) at arc lengths ``s`` in [0, 1], shape (4, m)."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        out = np.empty((4, s.size))
        for a, b, sol in self._pieces:
            sel = (s >= a) & (s <= b)
            if np.any(sel):
                out[:, sel] = sol(s[sel])
        return out

    def centerline(self, n: int = 101) -> np.ndarray:
        """Return ``n`` >= 2 centerline points from foot to tip, shape (n, 2), world frame."""
        n = int(n)
        if n < 2:
            raise ValueError(f"n = {n} points: need at least 2")
        return self.state(np.linspace(0.0, 1.0, n))[:2].T.copy()

    def warm(self) -> Tuple[ContactSpec, ...]:
        """Return the contact specs with this equilibrium's values as initial guesses."""
        out = []
        for spec, c in zip(self.specs, self.contacts):
            out.append(replace(spec, s=c.s, u=spec.u if c.u is None else c.u, N=c.N, T=c.T))
        return tuple(out)


# -- geometry helpers ---------------------------------------------------------------------------
def _gauss():
    return np.polynomial.legendre.leggauss(24)


def arc_length_coordinate(arc: Arc, u: float) -> float:
    """
    Arc length sigma(u) from u = 0 along ``arc`` (negative for u < 0).

    Exact for circles and segments; for spline graphs Gauss-Legendre between the knots (the
    spline's speed is smooth only between them); otherwise the arc's own quadrature.
    """
    if isinstance(arc, (CircleArc, SegmentArc)):
        return arc.sigma_between(0.0, u)
    if isinstance(arc, GraphArc):
        sign = 1.0 if arc.side == "above" else -1.0
        x_a, x_b = 0.0, sign * u  # u = x (above) or -x (below)
        lo, hi = min(x_a, x_b), max(x_a, x_b)
        knots = [k for k in arc._spline.x if lo < k < hi]
        cuts = [lo] + knots + [hi]
        xg, wg = _gauss()
        total = 0.0
        for a, b in zip(cuts[:-1], cuts[1:]):
            half = 0.5 * (b - a)
            for xi, wi in zip(xg, wg):
                d1 = arc.height(a + half * (xi + 1.0))[1]
                total += half * wi * math.sqrt(1.0 + d1 * d1)
        return total if u >= 0.0 else -total
    return arc.sigma_between(0.0, u)


def _unloaded_slope(shape: WhiskerShape, pose: FootPose, s: float) -> float:
    return pose.heading + shape.k0 * s + 0.5 * shape.k1 * s * s


def _cone_bisector(v: Vertex) -> float:
    return 0.5 * (v.phi_in + v.phi_out)


# -- the shooting map ---------------------------------------------------------------------------
def _rhs(shape: WhiskerShape, fx_in: float, fy_in: float, budget: List[int]):
    """Right-hand side under the inner force; ``budget[0]`` calls left (then _Unusable)."""
    k0, k1, c = shape.k0, shape.k1, 1.0 - shape.taper

    def rhs(s, y):
        budget[0] -= 1
        if budget[0] < 0:
            raise _Unusable("the integration takes too many steps (a load far too large)")
        th, m = y[2], y[3]
        b = 1.0 - c * s
        b *= b
        ct, st = math.cos(th), math.sin(th)
        return [ct, st, k0 + k1 * s + m / (b * b), st * fx_in - ct * fy_in]

    return rhs


class _Problem:
    """The unknowns, the integration and the residuals of one solve (internal)."""

    def __init__(self, shape, pose, specs, rtol):
        self.shape, self.pose, self.specs = shape, pose, tuple(specs)
        self.rtol, self.atol = rtol, 0.1 * rtol
        self.calls = 0
        s_cap = 1.5 if shape.taper == 1.0 else min(1.5, 0.5 * (1.0 + 1.0 / (1.0 - shape.taper)))
        self.s_cap = s_cap
        layout, x0 = [], []
        for spec in self.specs:
            start = len(x0) + 1
            if spec.kind == "side":
                x0 += [spec.s, spec.u, spec.N] + ([spec.T] if spec.sticks else [])
            elif spec.kind == "tip":
                x0 += [spec.u, spec.N] + ([spec.T] if spec.sticks else [])
            else:
                if spec.kind == "corner":
                    th = _unloaded_slope(shape, pose, spec.s)
                    ct, st = math.cos(th), math.sin(th)
                    fx = spec.N * spec.side * -st + spec.T * ct
                    fy = spec.N * spec.side * ct + spec.T * st
                    x0 += [spec.s, fx, fy]
                else:
                    b = _cone_bisector(spec.feature)
                    fx = spec.N * math.sin(b) + spec.T * math.cos(b)
                    fy = -spec.N * math.cos(b) + spec.T * math.sin(b)
                    x0 += [fx, fy]
            layout.append(start)
        self.layout = layout
        m0 = 0.0
        self.x0 = np.array([m0] + x0, dtype=float)
        self.x0[0] = self._moment_guess(self.x0)

    def _moment_guess(self, x):
        """Return sum_c (r_c - foot) x F_c with the contact points of the guess."""
        m = 0.0
        for spec, (_, fx, fy, p, *_) in zip(self.specs, self._loads(x)):
            px, py = (p.x, p.y) if p is not None else (spec.feature.x, spec.feature.y)
            m += (px - self.pose.x) * fy - (py - self.pose.y) * fx
        return m

    def _loads(self, x):
        """Return per contact (s, fx, fy, arc point, u, N, T) from the unknowns (arc: N, T)."""
        out = []
        for spec, i in zip(self.specs, self.layout):
            if spec.kind in ("side", "tip"):
                if spec.kind == "side":
                    s, u, n = x[i], x[i + 1], x[i + 2]
                    t_i = i + 3
                else:
                    s, u, n = 1.0, x[i], x[i + 1]
                    t_i = i + 2
                t = x[t_i] if spec.sticks else -spec.slip_sign * spec.mu * n
                p = spec.feature.at(float(u))
                sp, cp = math.sin(p.phi), math.cos(p.phi)
                out.append((s, n * sp + t * cp, -n * cp + t * sp, p, float(u), n, t))
            elif spec.kind == "corner":
                out.append((x[i], x[i + 1], x[i + 2], None, None, None, None))
            else:
                out.append((1.0, x[i], x[i + 1], None, None, None, None))
        return out

    def integrate(self, x, dense=False):
        """Integrate foot to last contact; return loads, states at the contacts, pieces."""
        self.calls += 1
        self.budget = [MAX_RHS_CALLS]
        loads = self._loads(x)
        if max((abs(ld[1]) + abs(ld[2]) for ld in loads), default=0.0) > MAX_FORCE:
            raise _Unusable(f"a contact force beyond {MAX_FORCE:g}")
        order = sorted(range(len(loads)), key=lambda c: loads[c][0])
        for c in order:
            s = loads[c][0]
            if not (0.0 < s <= self.s_cap) or not math.isfinite(s):
                raise _Unusable(f"contact arc length {s!r} outside (0, 1]")
        fx_in = sum(ld[1] for ld in loads)
        fy_in = sum(ld[2] for ld in loads)
        y = np.array([self.pose.x, self.pose.y, self.pose.heading, x[0]])
        s_now = 0.0
        states = [None] * len(loads)
        pieces = []
        for c in order:
            s_c = loads[c][0]
            if s_c > s_now:
                y, sol = self._segment(s_now, s_c, y, fx_in, fy_in, dense)
                if dense:
                    pieces.append((s_now, s_c, sol))
                s_now = s_c
            states[c] = y
            fx_in -= loads[c][1]
            fy_in -= loads[c][2]
        if dense and s_now < 1.0:
            _, sol = self._segment(s_now, 1.0, y, 0.0, 0.0, True)
            pieces.append((s_now, 1.0, sol))
        return loads, states, y, pieces

    def _segment(self, a, b, y, fx_in, fy_in, dense):
        sol = solve_ivp(_rhs(self.shape, fx_in, fy_in, self.budget), (a, b), y, method="DOP853",
                        rtol=self.rtol, atol=self.atol, dense_output=dense)
        if not sol.success:
            raise _Unusable(sol.message)
        return sol.y[:, -1].copy(), sol.sol

    def residual(self, x):
        try:
            loads, states, y_last, _ = self.integrate(x)
        except (ArithmeticError, ValueError) as exc:
            raise _Unusable(str(exc)) from exc
        r = [y_last[3]]  # M(s_last) = 0
        for spec, (s, fx, fy, p, u, *_), st in zip(self.specs, loads, states):
            xs, ys, th = st[0], st[1], st[2]
            if spec.kind in ("side", "tip"):
                r += [xs - p.x, ys - p.y]
                if spec.kind == "side":
                    r.append(math.sin(th - p.phi))
                if spec.sticks:
                    q = arc_length_coordinate(spec.feature, u)
                    if spec.kind == "side":
                        q -= math.copysign(1.0, math.cos(th - p.phi)) * s
                    r.append(q - spec.anchor)
            else:
                v = spec.feature
                r += [xs - v.x, ys - v.y]
                if spec.kind == "corner":
                    if spec.sticks:
                        r.append(-s - spec.anchor)
                    else:
                        ct, st_ = math.cos(th), math.sin(th)
                        n = spec.side * (-st_ * fx + ct * fy)
                        t = ct * fx + st_ * fy
                        r.append(t + spec.slip_sign * spec.mu * n)
        out = np.array(r, dtype=float)
        if not np.all(np.isfinite(out)):
            raise _Unusable("non-finite residual")
        return out


def _newton(problem: _Problem, tol: float):
    """
    Damped Newton on a finite-difference Jacobian, refreshed when convergence slows.

    The Jacobian is a forward difference; when no damped step along its direction decreases
    the residual, it is recomputed by central differences (accurate where the problem is stiff
    or ill-conditioned) before the solve is given up.
    """
    x = problem.x0.copy()
    try:
        r = problem.residual(x)
    except _Unusable as exc:
        raise ConvergenceError(f"scene shooting: the initial guess cannot be integrated ({exc})")
    jac, central = None, False
    for _ in range(MAX_NEWTON):
        norm = float(np.max(np.abs(r)))
        if norm <= tol:
            return x, norm
        fresh = jac is None
        if fresh:
            jac = _jacobian(problem, x, r, central)
        try:
            dx = np.linalg.solve(jac, -r)
        except np.linalg.LinAlgError:
            dx = np.linalg.lstsq(jac, -r, rcond=None)[0]
        lam, accepted = 1.0, None
        while lam >= 1.0 / 64.0:
            try:
                trial = problem.residual(x + lam * dx)
            except _Unusable:
                trial = None
            if trial is not None and np.max(np.abs(trial)) < (1.0 - 1e-4 * lam) * norm:
                accepted = trial
                break
            lam *= 0.5
        if accepted is None:
            if not fresh:  # a stale Jacobian: recompute it
                jac = None
                continue
            if not central:  # a fresh forward difference: try central differences
                jac, central = None, True
                continue
            if norm <= RESIDUAL_ACCEPT:  # the integration's noise floor
                return x, norm
            raise ConvergenceError(
                f"scene shooting: no Newton step decreases the residual {norm:.3g}")
        x = x + lam * dx
        if np.max(np.abs(accepted)) > 0.05 * norm or lam < 1.0:
            jac = None
        r = accepted
    norm = float(np.max(np.abs(r)))
    if norm <= RESIDUAL_ACCEPT:
        return x, norm
    raise ConvergenceError(f"scene shooting: {MAX_NEWTON} Newton iterations left the "
                           f"residual at {norm:.3g}")


def _jacobian(problem: _Problem, x, r, central: bool = False):
    jac = np.empty((r.size, x.size))
    for j in range(x.size):
        h = (1e-5 if central else 1e-7) * max(1.0, abs(x[j]))
        xp = x.copy()
        xp[j] += h
        try:
            if central:
                xm = x.copy()
                xm[j] -= h
                jac[:, j] = (problem.residual(xp) - problem.residual(xm)) / (2.0 * h)
            else:
                jac[:, j] = (problem.residual(xp) - r) / h
        except _Unusable:
            xp[j] = x[j] - h
            try:
                jac[:, j] = (r - problem.residual(xp)) / h
            except _Unusable as exc:
                raise ConvergenceError(f"scene shooting: Jacobian not computable ({exc})")
    return jac


def solve_scene_equilibrium(shape: WhiskerShape, pose: FootPose,
                            contacts: Sequence[ContactSpec], rtol: float = RTOL,
                            tol: float = RESIDUAL_TOL) -> SceneEquilibrium:
    """
    Solve the whisker's equilibrium at ``pose`` under ``contacts`` by shooting.

    Parameters
    ----------
    shape : WhiskerShape
        Taper and intrinsic curvature of the whisker.
    pose : FootPose
        Where the foot is clamped (world frame).
    contacts : sequence of ContactSpec
        The contacts and their friction states, with initial guesses (any order; results come
        in the same order).
    rtol : float
        Relative tolerance of the DOP853 integration (absolute: rtol / 10).
    tol : float
        Max-norm residual at which Newton stops.

    Returns
    -------
    SceneEquilibrium
        The equilibrium, its contacts in the order of ``contacts``.

    Raises
    ------
    ConvergenceError
        When the bounded Newton iteration does not reach a residual <= 1e-10.

    """
    if not isinstance(shape, WhiskerShape):
        raise ParameterError(f"shape must be a WhiskerShape, got {type(shape).__name__}")
    if not isinstance(pose, FootPose):
        raise ParameterError(f"pose must be a FootPose, got {type(pose).__name__}")
    specs = tuple(contacts)
    for spec in specs:
        if not isinstance(spec, ContactSpec):
            raise ParameterError(f"contacts must be ContactSpec, got {type(spec).__name__}")
    tips = [c for c in specs if c.kind in ("tip", "tip_corner")]
    if len(tips) > 1:
        raise ParameterError("at most one contact may be at the tip")
    problem = _Problem(shape, pose, specs, rtol)
    if not specs:
        x, norm = problem.x0, 0.0
    else:
        x, norm = _newton(problem, tol)
    try:
        loads, states, _, pieces = problem.integrate(x, dense=True)
    except _Unusable as exc:
        raise ConvergenceError(f"scene shooting: the solution cannot be integrated ({exc})")
    tip_state = pieces[-1][2](1.0)
    out = []
    for spec, (s, fx, fy, p, u, n_arc, t_arc), st in zip(specs, loads, states):
        th = float(st[2])
        ct, st_ = math.cos(th), math.sin(th)
        if spec.kind in ("side", "tip"):
            n, t = n_arc, t_arc
            q = arc_length_coordinate(spec.feature, u)
            if spec.kind == "side":
                q -= math.copysign(1.0, math.cos(th - p.phi)) * s
        elif spec.kind == "corner":
            n, t = spec.side * (-st_ * fx + ct * fy), ct * fx + st_ * fy
            q, u = -float(s), None
        else:
            b = _cone_bisector(spec.feature)
            n, t = fx * math.sin(b) - fy * math.cos(b), fx * math.cos(b) + fy * math.sin(b)
            q, u = None, None
        out.append(ContactSolution(spec.kind, "stick" if spec.sticks else "slip", spec.mu,
                                   float(s), None if u is None else float(u), float(st[0]),
                                   float(st[1]), float(fx), float(fy), float(n), float(t),
                                   None if q is None else float(q), th))
    return SceneEquilibrium(shape, pose, tuple(out), specs,
                            float(sum(c.fx for c in out)), float(sum(c.fy for c in out)),
                            float(x[0]), (float(tip_state[0]), float(tip_state[1])),
                            float(tip_state[2]), float(norm), problem.calls, rtol,
                            tuple(pieces))


# -- paths of foot poses and events -------------------------------------------------------------
@dataclass(frozen=True)
class PosePath:
    """The foot's straight path: x, y and heading linear in t from ``start`` (0) to ``end`` (1)."""

    start: FootPose
    end: FootPose

    def pose(self, t: float) -> FootPose:
        """Return the foot pose at path parameter ``t``."""
        a, b = self.start, self.end
        return FootPose(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y),
                        a.heading + t * (b.heading - a.heading))


@dataclass(frozen=True)
class LocatedEvent:
    """An event located on a path: its parameter ``t``, pose, equilibrium and event value."""

    t: float
    pose: FootPose
    equilibrium: SceneEquilibrium
    value: float


EventFunction = Callable[[SceneEquilibrium], float]


def follow_path(shape: WhiskerShape, path: PosePath, contacts: Sequence[ContactSpec],
                ts: Sequence[float], rtol: float = RTOL) -> List[SceneEquilibrium]:
    """
    Solve the equilibria at the path parameters ``ts`` in order, each warm-started.

    The first solve starts from the guesses in ``contacts``; each next one from the previous
    equilibrium (extrapolated linearly from the two before it). A step whose solve fails is
    halved, at most ``MAX_HALVINGS`` times in a row, before the ConvergenceError is raised.
    """
    out: List[SceneEquilibrium] = []
    done: List[Tuple[float, SceneEquilibrium]] = []
    for k, t in enumerate(ts):
        t = float(t)
        if not done:
            eq = solve_scene_equilibrium(shape, path.pose(t), tuple(contacts), rtol)
            done.append((t, eq))
            out.append(eq)
            continue
        halvings = 0
        while True:
            t_prev = done[-1][0]
            target = t if halvings == 0 else t_prev + (t - t_prev) / 2.0 ** halvings
            try:
                eq = solve_scene_equilibrium(shape, path.pose(target), _extrapolated(done, target),
                                             rtol)
            except ConvergenceError:
                halvings += 1
                if halvings > MAX_HALVINGS:
                    raise
                continue
            done.append((target, eq))
            if target == t:
                break
            halvings = max(halvings - 1, 0)
        out.append(eq)
    return out


#: successive halvings of a continuation step before a failed solve is given up
MAX_HALVINGS = 10


def _extrapolated(done: List[Tuple[float, SceneEquilibrium]], t: float
                  ) -> Tuple[ContactSpec, ...]:
    t1, eq1 = done[-1]
    last = eq1.warm()
    if len(done) < 2:
        return last
    t0, eq0 = done[-2]
    prev = eq0.warm()
    if len(prev) != len(last) or t1 == t0:
        return last
    w = (t - t1) / (t1 - t0)
    out = []
    for a, b in zip(prev, last):
        s = b.s + w * (b.s - a.s) if b.kind in ("side", "corner") else b.s
        out.append(replace(b, s=s, u=b.u + w * (b.u - a.u), N=b.N + w * (b.N - a.N),
                           T=b.T + w * (b.T - a.T)))
    return tuple(out)


def locate_event(shape: WhiskerShape, path: PosePath, contacts: Sequence[ContactSpec],
                 event: EventFunction, t_from: float = 0.0, t_to: float = 1.0, steps: int = 8,
                 xtol: float = 1e-14, rtol: float = RTOL) -> Optional[LocatedEvent]:
    """
    Locate the first t in [t_from, t_to] where ``event(equilibrium)`` changes sign.

    The path is sampled at ``steps`` + 1 equally spaced parameters (solves warm-started along
    it); the first sign change is refined by Brent's method to ``xtol`` in t, every solve
    warm-started from the nearest equilibrium already found.

    Parameters
    ----------
    shape : WhiskerShape
        Taper and intrinsic curvature of the whisker.
    path : PosePath
        The foot's straight path, parametrized by t.
    contacts : sequence of ContactSpec
        The contacts and their friction states, with the initial guesses of the first solve.
    event : callable
        ``event(equilibrium) -> float``: the function of a :class:`SceneEquilibrium` whose sign
        change is the event (:func:`release`, :func:`slip_onset`, ...).
    t_from, t_to : float, optional
        The interval of the path parameter searched.
    steps : int, optional
        The number of sampling intervals.
    xtol : float, optional
        The tolerance in t of Brent's method.
    rtol : float, optional
        Relative tolerance of the DOP853 integration.

    Returns
    -------
    LocatedEvent or None
        The event's parameter t, pose, equilibrium and event value; None when the event does
        not change sign on the sampled path.

    Raises
    ------
    ConvergenceError
        When a solve fails.

    """
    ts = np.linspace(t_from, t_to, int(steps) + 1)
    known: Dict[float, SceneEquilibrium] = {}
    eqs = follow_path(shape, path, contacts, ts, rtol)
    values = []
    for t, eq in zip(ts, eqs):
        known[float(t)] = eq
        values.append(float(event(eq)))
    k = next((i for i in range(len(ts) - 1) if values[i] == 0.0 or values[i] * values[i + 1] < 0),
             None)
    if k is None:
        if values[-1] == 0.0:
            return LocatedEvent(float(ts[-1]), path.pose(float(ts[-1])), eqs[-1], 0.0)
        return None
    if values[k] == 0.0:
        return LocatedEvent(float(ts[k]), path.pose(float(ts[k])), eqs[k], 0.0)

    def g(t):
        near = min(known, key=lambda a: abs(a - t))
        eq = solve_scene_equilibrium(shape, path.pose(t), known[near].warm(), rtol)
        known[float(t)] = eq
        return float(event(eq))

    t_star = brentq(g, float(ts[k]), float(ts[k + 1]), xtol=xtol, rtol=4.0 * np.finfo(float).eps,
                    maxiter=200)
    eq = known.get(float(t_star))
    if eq is None:
        g(t_star)
        eq = known[float(t_star)]
    return LocatedEvent(float(t_star), path.pose(float(t_star)), eq, float(event(eq)))


# -- event functions ----------------------------------------------------------------------------
def release(i: int) -> EventFunction:
    """Contact ``i``'s normal force N (0: it releases)."""
    return lambda eq: eq.contacts[i].N


def slip_onset(i: int) -> EventFunction:
    """Contact ``i``'s |T| - mu N (0: a sticking contact starts to slip)."""
    return lambda eq: abs(eq.contacts[i].T) - eq.contacts[i].mu * eq.contacts[i].N


def reaches_arc_length(i: int, s: float = 1.0) -> EventFunction:
    """Contact ``i``'s s - ``s`` (default: a side or corner contact reaching the tip)."""
    return lambda eq: eq.contacts[i].s - s


def arc_end_margin(i: int) -> EventFunction:
    """
    Distance in u of side or tip contact ``i`` from the nearer finite end of its arc.

    0 when the contact reaches the end of its arc (it moves on to a vertex or off the arc).
    """
    def margin(eq):
        arc = eq.specs[i].feature
        u = eq.contacts[i].u
        ends = [e for e in ((u - arc.u_min) if math.isfinite(arc.u_min) else math.inf,
                            (arc.u_max - u) if math.isfinite(arc.u_max) else math.inf)]
        m = min(ends)
        if not math.isfinite(m) or arc.periodic:
            raise ParameterError("arc end event: the contact's arc has no finite end")
        return m
    return margin


def cone_margin(i: int) -> EventFunction:
    """
    Angle by which a vertex contact's force direction lies inside its admissible cone [rad].

    Corner: the whisker's normal nu against the vertex's normal cone. Tip on a vertex: the
    force against the cone widened by the friction angle atan(mu) on both sides. 0 when it
    leaves the cone (the whisker slides onto an edge).
    """
    def margin(eq):
        spec, c = eq.specs[i], eq.contacts[i]
        v = spec.feature
        if spec.kind == "corner":
            nx, ny = -spec.side * math.sin(c.theta), spec.side * math.cos(c.theta)
            widen = 0.0
        elif spec.kind == "tip_corner":
            nx, ny = c.fx, c.fy
            widen = math.atan(spec.mu)
        else:
            raise ParameterError(f"cone event: contact {i} is a {spec.kind} contact, not at "
                                 "a vertex")
        if v.turn >= _TWO_PI:
            return math.pi
        phi = math.atan2(nx, -ny)
        return 0.5 * v.turn + widen - abs(math.remainder(phi - _cone_bisector(v), _TWO_PI))
    return margin


def touch_gap(feature, side: Optional[int] = None, s_from: float = 0.0, s_to: float = 1.0,
              samples: int = 201) -> EventFunction:
    """
    Signed gap between the whisker's centerline on [s_from, s_to] and ``feature`` (0: touch).

    Without ``side``: for an arc, the min over s of the signed distance of r(s) to the arc
    (positive outside the obstacle); for a vertex, +-min_s |r(s) - V|, positive while V lies on
    the whisker's left. With ``side`` (+1: the feature lies on the whisker's left, -1: on its
    right), for a vertex or a circle (a peg): side h - r, with h the offset of the point or the
    circle's centre along the whisker's left normal at the nearest point, r the radius. That
    one stays monotone when a sampled path would carry a thin peg through the whisker.
    """
    def gap(eq):
        return nearest_approach(eq, feature, side, s_from, s_to, samples)[0]
    return gap


def nearest_approach(eq: SceneEquilibrium, feature, side: Optional[int] = None,
                     s_from: float = 0.0, s_to: float = 1.0, samples: int = 201
                     ) -> Tuple[float, float, Optional[float]]:
    """
    Return (gap, s, u): the gap of :func:`touch_gap` and where it is reached.

    ``s`` is the whisker's arc length there, ``u`` the arc parameter of the nearest arc point
    (None for a vertex). The centerline is sampled at ``samples`` points and the best one
    refined by bounded Brent minimization in s (the gap at an interior minimum is then exact
    to the square of the location error).
    """
    if side not in (None, -1, 1):
        raise ParameterError(f"touch gap: side {side!r} must be None, -1 or +1")
    s = np.linspace(s_from, s_to, int(samples))
    pts = eq.state(s)
    if isinstance(feature, Vertex) or (isinstance(feature, CircleArc) and side is not None):
        if isinstance(feature, Vertex):
            cx, cy = feature.x, feature.y
        else:
            cx, cy = feature.cx, feature.cy
        d = np.hypot(pts[0] - cx, pts[1] - cy)

        def dist(si):
            x, y, th, _ = eq.state(si)[:, 0]
            left = (cx - x) * -math.sin(th) + (cy - y) * math.cos(th)
            return math.hypot(x - cx, y - cy), left
    elif isinstance(feature, Arc):
        seeds = _arc_seeds(feature, pts[0], pts[1])
        near = [_arc_distance(feature, x, y, u0) for x, y, u0 in zip(pts[0], pts[1], seeds)]
        d = np.array([g for g, _ in near])
        start = near[int(np.argmin(d))][1]

        def dist(si):
            x, y = eq.state(si)[:2, 0]
            return _arc_distance(feature, x, y, start)
    else:
        raise ParameterError(f"touch gap: feature must be an Arc or a Vertex, "
                             f"got {type(feature).__name__}")
    k = int(np.argmin(d))
    lo, hi = s[max(k - 1, 0)], s[min(k + 1, len(s) - 1)]
    best_s = float(s[k])
    if hi > lo:
        res = minimize_scalar(lambda a: dist(a)[0], bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-12, "maxiter": 200})
        if res.fun < dist(best_s)[0]:
            best_s = float(res.x)
    value, extra = dist(best_s)
    if isinstance(feature, Vertex):
        if side is not None:
            return side * extra, best_s, None
        return (value if extra >= 0.0 else -value), best_s, None
    if isinstance(feature, CircleArc) and side is not None:
        x, y = eq.state(best_s)[:2, 0]
        return side * extra - feature.r, best_s, math.atan2(x - feature.cx, -(y - feature.cy))
    return value, best_s, extra


def _arc_seeds(arc: Arc, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Nearest sampled arc parameter for each point (a start for Newton)."""
    if isinstance(arc, CircleArc):
        return np.arctan2(xs - arc.cx, -(ys - arc.cy))
    if isinstance(arc, SegmentArc):
        return np.clip((xs - arc.x0) * math.cos(arc._phi) + (ys - arc.y0) * math.sin(arc._phi),
                       arc.u_min, arc.u_max)
    if isinstance(arc, GraphArc):
        lo, hi = float(np.min(xs)) - 1.0, float(np.max(xs)) + 1.0
        ug = np.linspace(lo, hi, 801) * (1.0 if arc.side == "above" else -1.0)
    else:
        eps = 1e-9 * (arc.u_max - arc.u_min)
        ug = np.linspace(arc.u_min + eps, arc.u_max - eps, 801)
    pg = np.array([(p.x, p.y) for p in (arc.at(float(u)) for u in ug)])
    d2 = (xs[:, None] - pg[None, :, 0]) ** 2 + (ys[:, None] - pg[None, :, 1]) ** 2
    return ug[np.argmin(d2, axis=1)]


def _arc_distance(arc: Arc, x: float, y: float, u: float) -> Tuple[float, float]:
    """Return (signed distance, u) of (x, y) to the arc's nearest point, Newton from ``u``."""
    if isinstance(arc, CircleArc):
        u = math.atan2(x - arc.cx, -(y - arc.cy))
        return math.hypot(x - arc.cx, y - arc.cy) - arc.r, u
    lo = arc.u_min if not arc.periodic else -math.inf
    hi = arc.u_max if not arc.periodic else math.inf
    for _ in range(30):
        p = arc.at(u)
        ct, st = math.cos(p.phi), math.sin(p.phi)
        g = (x - p.x) * ct + (y - p.y) * st
        dg = -p.speed - p.dphi * ((x - p.x) * st - (y - p.y) * ct)
        if dg >= 0.0:  # not a local minimum of the distance: move along the tangent
            dg = -p.speed
        step = -g / dg
        u_new = min(max(u + step, lo), hi)
        if abs(u_new - u) <= 1e-15 * max(1.0, abs(u)):
            u = u_new
            break
        u = u_new
    p = arc.at(u)
    dx, dy = x - p.x, y - p.y
    dist = math.hypot(dx, dy)
    sign = 1.0 if dx * math.sin(p.phi) - dy * math.cos(p.phi) >= 0.0 else -1.0
    return sign * dist, u


def touching_contact(eq: SceneEquilibrium, feature, side: Optional[int] = None,
                     s_from: float = 0.0, s_to: float = 1.0, **friction) -> ContactSpec:
    """
    Return the contact a touch of ``feature`` starts (N = 0), to add to the contact set.

    The kind follows from where the whisker is nearest: its tip (within 1e-9) or its side; on a
    vertex the corner's e is the side away from the vertex. ``friction``: further ContactSpec
    fields (friction, mu, anchor, slip_sign).
    """
    _, s, u = nearest_approach(eq, feature, side, s_from, s_to)
    at_tip = s >= 1.0 - 1e-9
    if isinstance(feature, Vertex):
        x, y, th, _ = eq.state(min(s, 1.0))[:, 0]
        left = (feature.x - x) * -math.sin(th) + (feature.y - y) * math.cos(th)
        return ContactSpec("tip_corner" if at_tip else "corner", feature,
                           side=-1 if left > 0.0 else 1, s=1.0 if at_tip else s, N=0.0,
                           **friction)
    return ContactSpec("tip" if at_tip else "side", feature, s=1.0 if at_tip else s, u=u,
                       N=0.0, **friction)
