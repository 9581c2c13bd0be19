"""
The general whisker: tapered, intrinsically curved, solved by Chebyshev spectral collocation.

Model (dimensionless: L = 1, EI_b = bending stiffness at the base): bending stiffness
B(s) = (1 - (1 - taper) s)^4 (a solid cone, taper = tip radius / base radius), intrinsic curvature
kappa0(s) = k0 + k1 s (counter-clockwise positive), constitutive law M = B (theta' - kappa0).
A frictionless point force f (sin alpha, -cos alpha) acts at arc length s1 (the obstacle's outward
normal at the contact, alpha = the obstacle's tangent slope there); beyond s1 the whisker is
unloaded and keeps its intrinsic shape.

Because the force is constant on [0, s1] its moment is known in closed form from the positions:

    M(s) = f [cos(alpha) (x(s) - x(s1)) + sin(alpha) (y(s) - y(s1))]
                                                       (M(s1) = 0, M' = f cos(theta - alpha))

so the whole equilibrium is one integral equation for the slope theta on [0, s1]
(foot frame: foot at the origin, unloaded whisker leaving along +y, theta(0) = pi/2):

    theta(s) = pi/2 + int_0^s [kappa0(u) + M(u) / B(u)] du,
    x = int cos(theta), y = int sin(theta).

It is discretized on n Chebyshev points of [0, s1] with the spectral integration matrix S
(Clenshaw-Curtis weights in its last row): theta = pi/2 + h S kappa0 + f h^2 A cos(theta - alpha)
with h = s1/2 and A = S diag(1/B) (S - 1 w). Newton on this n x n system (n + 1 with s1 in
tangential contact, closed by theta(s1) = alpha) converges quadratically; the sensitivities to the
branch unknowns come from the same factorization. The error decays exponentially in n (convergence
study in doc/mechanics/real-whiskers.md).

The model works in the *unmirrored* foot frame (``mirrored = False``): the intrinsic curvature is
not mirror-symmetric, so both bending directions are solved as they are. Unknowns of a contact
branch: ``z = (alpha, f)`` in both phases (continuous across the tip <-> tangential switch);
f = 0 is an ordinary point of the branch (release, or a side-first touch of a curved whisker).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Dict, Optional, Tuple

import numpy as np
from numpy.polynomial import chebyshev as C

from ..errors import ConvergenceError, ParameterError
from ..state import Phase

HALF_PI = 0.5 * math.pi

#: default number of Chebyshev points (error ~1e-15: doc/mechanics/real-whiskers.md)
DEFAULT_POINTS = 32


@dataclass(frozen=True)
class WhiskerShape:
    """
    Taper and intrinsic curvature of a whisker (dimensionless).

    The parameters are the dataclass's fields, kept as attributes of the same names; the defaults
    are the paper's whisker (uniform, straight).

    Parameters
    ----------
    taper : float, optional
        rho = tip radius / base radius in (0, 1]; B(s) = (1 - (1 - rho) s)^4 [EI_b].
    k0, k1 : float, optional
        Intrinsic curvature kappa0(s) = k0 + k1 s [1/L], counter-clockwise positive;
        ``|k0| + |k1| <= 20`` (more would curl the whisker more than about three turns).

    Raises
    ------
    ParameterError
        When a field is not a finite number, the taper is not in (0, 1] or ``|k0| + |k1| > 20``.

    """

    taper: float = 1.0
    k0: float = 0.0
    k1: float = 0.0

    def __post_init__(self):
        for key in ("taper", "k0", "k1"):
            value = getattr(self, key)
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise ParameterError(f"whisker {key} = {value!r} is not a number") from None
            if not math.isfinite(value):
                raise ParameterError(f"whisker {key} = {value!r} must be finite")
            object.__setattr__(self, key, value)
        if not 0.0 < self.taper <= 1.0:
            raise ParameterError(
                f"whisker taper = {self.taper!r} is not allowed; taper (tip radius / base radius) "
                "must be in (0, 1]"
            )
        if abs(self.k0) + abs(self.k1) > 20.0:
            raise ParameterError(
                f"intrinsic curvature k0 = {self.k0!r}, k1 = {self.k1!r}: |k0| + |k1| must be "
                "<= 20 (the whisker would curl more than about three turns)"
            )

    @property
    def is_paper(self) -> bool:
        """Tell whether this is the paper's whisker (uniform, straight): the closed forms apply."""
        return self.taper == 1.0 and self.k0 == 0.0 and self.k1 == 0.0

    def stiffness(self, s):
        """B(s) [EI_b]."""
        return (1.0 - (1.0 - self.taper) * np.asarray(s, dtype=float)) ** 4

    def intrinsic_slope(self, s):
        """Slope of the unloaded whisker relative to its heading: int_0^s kappa0 [rad]."""
        s = np.asarray(s, dtype=float)
        return self.k0 * s + 0.5 * self.k1 * s * s

    def linear_compliance(self, d: float = 1.0) -> float:
        """
        Return the small-deflection compliance at s = d (units L^3/EI_b).

        That is int_0^d (d - s)^2 / B(s) ds.
        """
        x, w = np.polynomial.legendre.leggauss(64)
        s = 0.5 * d * (x + 1.0)
        return float(0.5 * d * np.sum(w * (d - s) ** 2 / self.stiffness(s)))


@lru_cache(maxsize=16)
def chebyshev_operators(n: int):
    """
    Build the Chebyshev collocation operators for ``n`` points.

    They are the Chebyshev points on [-1, 1] (ascending), the cumulative integration matrix S
    (from -1), and the matrix taking nodal values to Chebyshev coefficients.
    """
    if n < 4:
        raise ParameterError(f"collocation points n = {n}: need at least 4")
    k = np.arange(n)
    x = -np.cos(math.pi * k / (n - 1))
    V = C.chebvander(x, n - 1)  # V[j, k] = T_k(x_j)
    Vinv = np.linalg.inv(V)
    integ = np.empty((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = 1.0
        integ[:, j] = C.chebval(x, C.chebint(e, lbnd=-1.0))
    S = integ @ Vinv
    S[0, :] = 0.0
    for a in (x, S, Vinv):
        a.setflags(write=False)
    return x, S, Vinv


def _intrinsic_offset(shape: WhiskerShape, s_a: float, theta_a: float, s_b: float = 1.0):
    """
    Return the displacement from s_a to s_b along the unloaded part, from slope theta_a.

    By Gauss-Legendre quadrature.
    """
    if s_b <= s_a:
        return 0.0, 0.0
    x, w = _gauss()
    u = s_a + 0.5 * (s_b - s_a) * (x + 1.0)
    th = theta_a + shape.k0 * (u - s_a) + 0.5 * shape.k1 * (u * u - s_a * s_a)
    half = 0.5 * (s_b - s_a)
    return float(half * (w @ np.cos(th))), float(half * (w @ np.sin(th)))


@lru_cache(maxsize=1)
def _gauss():
    return np.polynomial.legendre.leggauss(48)


def free_centerline(shape: WhiskerShape, s) -> np.ndarray:
    """
    Return points of the unloaded whisker in the foot frame, shape (m, 2).

    The foot frame has the foot at the origin and the heading along +y.
    """
    s = np.atleast_1d(np.asarray(s, dtype=float))
    out = np.empty((s.size, 2))
    if shape.k0 == 0.0 and shape.k1 == 0.0:
        out[:, 0] = 0.0
        out[:, 1] = s
        return out
    for i, si in enumerate(s):
        out[i] = _intrinsic_offset(shape, 0.0, HALF_PI, si)
    return out


class _Ops:
    """
    Collocation operators on [0, s1] for one s1 (internal).

    Nodes t in [0, 1] (Chebyshev) are mapped to arc length by s(t): linearly (s = s1 t) for a
    cylinder, and for a cone by s_p - s = s_p r^t with s_p = 1/(1 - taper) (where B would vanish)
    and r = 1 - s1/s_p, which makes B(s(t)) = r^(4t) an entire function of t: the tip's boundary
    layer of a thin cone costs no extra points.
    """

    __slots__ = ("s1", "s", "sp", "ds", "dsp", "Sig", "w", "A", "b", "db", "k", "Sigk")

    def __init__(self, model: "GeneralWhiskerModel", s1: float):
        sh = model.shape
        t = model._t
        S = model._S
        self.s1 = s1
        if sh.taper == 1.0:
            s = s1 * t
            sp = np.full_like(t, s1)
            ds = t
            dsp = np.ones_like(t)
        else:
            s_p = 1.0 / (1.0 - sh.taper)
            r = 1.0 - s1 / s_p
            L = math.log1p(-s1 / s_p)
            e = np.exp(t * L)
            s = -s_p * np.expm1(t * L)
            sp = -s_p * L * e
            ds = t * e / r
            dsp = (1.0 + t * L) * e / r
        self.s, self.sp, self.ds, self.dsp = s, sp, ds, dsp
        Sig = 0.5 * S * sp  # integration in s from 0
        self.Sig = Sig
        self.w = Sig[-1].copy()
        base = 1.0 - (1.0 - sh.taper) * s
        self.b = base ** -4
        self.db = 4.0 * (1.0 - sh.taper) * base ** -5  # d(1/B)/ds
        self.A = (Sig * self.b) @ (Sig - self.w)
        self.k = sh.k0 + sh.k1 * s
        self.Sigk = Sig @ self.k


class _Solution:
    """
    A converged collocation solution and its sensitivities (internal).

    ``mu`` is the second branch unknown (s1 in phase 1, the tip rotation gamma in phase 2) and
    ``extra`` the scalar unknown of the inner system, f; ``*_a`` and ``*_m`` are derivatives with
    respect to alpha and mu.
    """

    __slots__ = ("phase", "alpha", "mu", "theta", "extra", "th_a", "th_m", "ex_a", "ex_m", "P",
                 "dP", "ops")

    def __init__(self, phase, alpha, mu, theta, extra, th_a, th_m, ex_a, ex_m, P, dP, ops):
        self.phase, self.alpha, self.mu = phase, alpha, mu
        self.theta, self.extra = theta, extra
        self.th_a, self.th_m, self.ex_a, self.ex_m = th_a, th_m, ex_a, ex_m
        self.P, self.dP, self.ops = P, dP, ops

    @property
    def tangential(self) -> bool:
        return self.phase == Phase.TANGENTIAL

    @property
    def f(self) -> float:
        return self.extra

    @property
    def s1(self) -> float:
        return self.mu if self.tangential else 1.0

    def base_moment(self) -> float:
        """
        Return the contact force's moment at the foot.

        M(0) = f [cos(alpha) (0 - x(s1)) + sin(alpha) (0 - y(s1))].
        """
        return -self.f * (self.P[0] * math.cos(self.alpha) + self.P[1] * math.sin(self.alpha))

    def operators(self, model: "GeneralWhiskerModel") -> "_Ops":
        if self.ops is None:
            self.ops = _Ops(model, self.s1)
        return self.ops

    def moments(self, model: "GeneralWhiskerModel") -> np.ndarray:
        """M at the nodes: f (Sig - 1 w) cos(theta - alpha)."""
        ops = self.operators(model)
        return self.f * ((ops.Sig - ops.w) @ np.cos(self.theta - self.alpha))


class GeneralWhiskerModel:
    """
    The tapered, intrinsically curved elastica behind the tracker's model interface.

    Unknowns (contact frame): phase 1 (tangential, theta(s1) = alpha, s1 < 1) ``z = (alpha, s1)``;
    phase 2 (tip, s1 = 1, theta(1) >= alpha) ``z = (alpha, gamma)``, gamma = theta0(1) - theta(1).

    Parameters
    ----------
    shape : WhiskerShape, optional
        Taper and intrinsic curvature (default: the paper's uniform, straight whisker).
    n : int, optional
        Chebyshev points on the loaded part [0, s1].

    """

    name = "general"
    release_by_gap = False
    #: a Newton correction this small leaves an error of about its square (quadratic convergence;
    #: the numeric-vs-exact scans agree to ~1e-14 with it)
    _NEWTON_TOL = 1e-7
    _MAX_ITER = 40

    def __init__(self, shape: Optional[WhiskerShape] = None, n: int = DEFAULT_POINTS):
        self.shape = shape if shape is not None else WhiskerShape()
        self.n = int(n)
        x, S, Vinv = chebyshev_operators(self.n)
        self._x, self._S, self._Vinv = x, S, Vinv
        self._t = 0.5 * (x + 1.0)
        self._eye = np.eye(self.n)
        self._tip_ops = _Ops(self, 1.0)  # phase 2 (s1 = 1): constant
        self._last: Optional[_Solution] = None
        self._base: Optional[_Solution] = None  # the last solution from Newton (not an update)
        self._memo: Dict[tuple, _Solution] = {}
        self._mirror: Optional["GeneralWhiskerModel"] = None
        self._free_series = None
        self._free_tip: Optional[Tuple[float, float, float]] = None
        taper = self.shape.taper
        self._s1_max = 1.05 if taper == 1.0 else min(1.05, 1.0 + 0.5 * taper / (1.0 - taper))
        #: solutions of reported states (contact_quantities), to redraw their centerlines later
        self._reported: Dict[tuple, _Solution] = {}

    def for_side(self, side: int) -> "GeneralWhiskerModel":
        """Return the model in the contact frame of ``side``: mirrored (-kappa0) for side -1."""
        if side >= 0 or self.is_straight:
            return self
        if self._mirror is None:
            sh = self.shape
            self._mirror = GeneralWhiskerModel(WhiskerShape(sh.taper, -sh.k0, -sh.k1), self.n)
            self._mirror._mirror = self
        return self._mirror

    def forget(self) -> None:
        """
        Drop the warm starts (the last solutions and the memo), of the mirrored model too.

        The tracker calls this whenever the whisker is free, so that what follows depends on the
        pose alone, not on the history (the solutions of reported states are kept: they redraw
        centerlines).
        """
        for model in (self, self._mirror):
            if model is not None:
                model._last = model._base = None
                model._memo.clear()

    def _t_of_s(self, s, s1: float):
        """Node variable t in [0, 1] of arc length s on [0, s1] (inverse of the map)."""
        s = np.asarray(s, dtype=float)
        if self.shape.taper == 1.0:
            return s / s1
        s_p = 1.0 / (1.0 - self.shape.taper)
        return np.log1p(-s / s_p) / math.log1p(-s1 / s_p)

    def _guess(self, phase: Phase, alpha: float, mu: float):
        last = self._last
        if last is None or last.phase != phase:
            return self._intrinsic_guess(phase, alpha)
        da, dm = alpha - last.alpha, mu - last.mu
        theta = last.theta + last.th_a * da + last.th_m * dm
        extra = last.extra + last.ex_a * da + last.ex_m * dm
        return theta, extra

    def _intrinsic_guess(self, phase: Phase, alpha: float, mu: float = 1.0):
        s1 = mu if phase == Phase.TANGENTIAL and 0.0 < mu <= 1.0 else 1.0
        return HALF_PI + self.shape.intrinsic_slope(_Ops(self, s1).s), 0.0

    def solve(self, phase: Phase, alpha: float, mu: float, guess=None) -> _Solution:
        """Solve the collocation for the branch unknowns (alpha, mu); raise ConvergenceError."""
        key = (int(phase), alpha, mu)
        sol = self._memo.get(key)
        if sol is not None:
            # it seeds the next guess like a fresh solution: after a switch back to a phase at a
            # point solved before, _last would otherwise still hold the other phase, and the
            # next Newton would start from the unloaded shape (which fails for large loads)
            self._last = sol
            return sol
        last = self._base
        if guess is None and last is not None and last.phase == phase:
            da, dm = alpha - last.alpha, mu - last.mu
            if abs(da) + abs(dm) <= 1e-7:
                # within 1e-7 of the last Newton solution (the tracker's last correction, its
                # convergence check): the first-order update from it is exact to O(|dz|^2) ~ 1e-14
                sol = _Solution(
                    phase, alpha, mu,
                    last.theta + last.th_a * da + last.th_m * dm,
                    last.extra + last.ex_a * da + last.ex_m * dm,
                    last.th_a, last.th_m, last.ex_a, last.ex_m,
                    (last.P[0] + last.dP[0] * da + last.dP[1] * dm,
                     last.P[1] + last.dP[2] * da + last.dP[3] * dm),
                    last.dP, last.ops if (phase == Phase.TIP or dm == 0.0) else None,
                )
                self._remember(key, sol)
                return sol
        tries = [lambda: guess] if guess is not None else []
        tries.append(lambda: self._guess(phase, alpha, mu))
        if self._last is not None:
            tries.append(lambda: self._intrinsic_guess(phase, alpha, mu))
        for make_guess in tries:
            theta0, extra0 = make_guess()
            sol = self._newton(phase, alpha, mu, np.array(theta0, dtype=float), float(extra0))
            if sol is not None:
                break
        else:
            sol = self._homotopy(phase, alpha, mu)
        if sol is None:
            raise ConvergenceError(
                f"general whisker: no equilibrium found for alpha = {alpha!r}, "
                f"{'s1' if phase == Phase.TANGENTIAL else 'tip rotation'} = {mu!r} "
                f"(phase {int(phase)})"
            )
        self._remember(key, sol)
        self._base = sol
        return sol

    def _remember(self, key, sol: _Solution) -> None:
        self._last = sol
        if len(self._memo) > 64:
            self._memo.clear()
        self._memo[key] = sol

    def _homotopy(self, phase: Phase, alpha: float, gamma: float) -> Optional[_Solution]:
        """Cold start of a tip contact: rotate the tip from the unloaded shape in small steps."""
        if phase != Phase.TIP:
            return None
        theta, extra = self._intrinsic_guess(phase, alpha)
        sol = None
        steps = 16
        for k in range(1, steps + 1):
            gk = gamma * k / steps
            if sol is not None:
                theta = sol.theta + sol.th_m * (gk - sol.mu)
                extra = sol.extra + sol.ex_m * (gk - sol.mu)
            sol = self._newton(phase, alpha, gk, theta, extra)
            if sol is None:
                return None
        return sol

    def _newton(self, phase, alpha, mu, theta, f) -> Optional[_Solution]:
        """
        Newton on the bordered collocation system in the unknowns (theta at the nodes, f).

        phase 1: s1 = mu, closed by theta(s1) = alpha (tangency);
        phase 2: s1 = 1, closed by theta(1) = theta0(1) - gamma (gamma = mu, the tip rotation).
        """
        n = self.n
        tangential = phase == Phase.TANGENTIAL
        if tangential:
            if not 0.0 < mu <= self._s1_max:
                return None
            ops = self._tip_ops if mu == 1.0 else _Ops(self, mu)
            target = alpha
        else:
            ops = self._tip_ops
            target = HALF_PI + float(self.shape.intrinsic_slope(1.0)) - mu
        A = ops.A
        M = np.zeros((n + 1, n + 1))
        M[n, n - 1] = 1.0
        rhs = np.zeros((n + 1, 3))
        if tangential:
            rhs[n, 1] = 1.0  # -d(theta(s1) - alpha)/dalpha
        else:
            rhs[n, 2] = -1.0  # -d(theta(1) - theta0(1) + gamma)/dgamma
        for it in range(self._MAX_ITER):
            d = theta - alpha
            cd, sd = np.cos(d), np.sin(d)
            Ac = A @ cd
            F = theta - HALF_PI - ops.Sigk - f * Ac
            M[:n, :n] = self._eye + f * (A * sd)
            M[:n, n] = -Ac  # dF/df
            rhs[:n, 0] = -F
            rhs[n, 0] = target - theta[-1]
            # the sensitivities d(theta, f)/d(alpha, mu) ride along (exact to O(last step) = 1e-9
            # relative, ample for the tracker's Newton and tangents)
            rhs[:n, 1] = f * (A @ sd)  # -dF/dalpha
            if tangential:
                rhs[:n, 2] = self._minus_dF_ds1(ops, cd, f)
            try:
                sol = np.linalg.solve(M, rhs)
            except np.linalg.LinAlgError:
                return None
            step = sol[:, 0]
            size = float(np.max(np.abs(step)))
            if not math.isfinite(size):
                return None
            if size > 0.5:  # damped far from the solution (cold starts)
                step = step * (0.5 / size)
            theta = theta + step[:n]
            f = f + step[n]
            if size <= self._NEWTON_TOL:
                break
        else:
            return None
        sens = sol[:, 1:]
        th_a, th_m = sens[:n, 0], sens[:n, 1]
        ex_a, ex_m = float(sens[n, 0]), float(sens[n, 1])
        w = ops.w
        c, sn = np.cos(theta), np.sin(theta)
        P = (float(w @ c), float(w @ sn))
        # dP/d(alpha, mu) = w (-sin, cos) d theta / d(alpha, mu), both at once
        dpx, dpy = (-(w * sn)) @ sens[:n], (w * c) @ sens[:n]
        dP = [float(dpx[0]), float(dpx[1]), float(dpy[0]), float(dpy[1])]
        if tangential:  # the nodes move with s1: + (1/2) S[-1] (ds'/ds1 (cos, sin))
            dP[1] += 0.5 * float(self._S[-1] @ (ops.dsp * c))
            dP[3] += 0.5 * float(self._S[-1] @ (ops.dsp * sn))
        return _Solution(phase, alpha, mu, theta, f, th_a, th_m, ex_a, ex_m, P, tuple(dP), ops)

    def _minus_dF_ds1(self, ops: _Ops, cd: np.ndarray, f: float) -> np.ndarray:
        """-dF/ds1 at fixed nodal values (the nodes, B and kappa0 move with s1)."""
        S, Sig, w, b, dsp = self._S, ops.Sig, ops.w, ops.b, ops.dsp
        u = Sig @ cd - (w @ cd)  # G c
        dspc = dsp * cd
        dGc = 0.5 * (S @ dspc - S[-1] @ dspc)
        # d/ds1 of Sig (k + f b G c): through the node spacing, and through k, b and G c
        return 0.5 * (S @ (dsp * (ops.k + f * b * u))) + Sig @ (
            ops.ds * (self.shape.k1 + f * ops.db * u) + f * b * dGc
        )

    # -- the tracker's model interface -------------------------------------------------------
    def load_point(self, phase: Phase, z):
        """
        Return the contact point on the whisker (foot frame) and its Jacobian.

        As (Px, Py, dPx/dz0, dPx/dz1, dPy/dz0, dPy/dz1).
        """
        try:
            sol = self.solve(phase, float(z[0]), float(z[1]))
        except ConvergenceError as exc:
            raise ValueError(str(exc)) from None
        return (sol.P[0], sol.P[1]) + sol.dP

    def valid(self, phase: Phase, z) -> bool:
        alpha, f = z
        if not (math.isfinite(alpha) and math.isfinite(f)):
            return False
        # a curved whisker may touch with a force that points away from the foot (alpha is not
        # wrapped along a branch)
        if not -1.5 * math.pi < alpha < 1.5 * math.pi:
            return False
        # (f is s1 in phase 1; a little beyond the tip is allowed so that the continuation can step
        # over the tip event and locate it)
        return phase == Phase.TIP or 0.0 < f <= self._s1_max

    def events(self, phase: Phase, z) -> Dict[str, float]:
        """
        Return the event functions of ``phase`` at ``z``.

        Phase 1: ``tip`` = 1 - s1, ``release`` = f; phase 2: ``tangential`` = theta(1) - alpha
        (the tip becomes tangent to the obstacle), ``release`` = f.
        """
        alpha, mu = float(z[0]), float(z[1])
        sol = self.solve(phase, alpha, mu)
        if phase == Phase.TANGENTIAL:
            return {"tip": 1.0 - mu, "release": sol.f}
        return {"tangential": float(sol.theta[-1]) - alpha, "release": sol.f}

    def transition(self, phase: Phase, event: str, z):
        alpha, mu = float(z[0]), float(z[1])
        if event == "release":
            return Phase.FREE, None
        # at the switch (s1 = 1, theta(1) = alpha) both phases have the same solution: seed with it
        sol = self.solve(phase, alpha, mu)
        if phase == Phase.TANGENTIAL and event == "tip":
            gamma = HALF_PI + float(self.shape.intrinsic_slope(1.0)) - alpha
            self.solve(Phase.TIP, alpha, gamma, guess=(sol.theta, sol.f))
            return Phase.TIP, (alpha, gamma)
        if phase == Phase.TIP and event == "tangential":
            self.solve(Phase.TANGENTIAL, alpha, 1.0, guess=(sol.theta, sol.f))
            return Phase.TANGENTIAL, (alpha, 1.0)
        raise AssertionError(f"no transition for event {event!r} in phase {phase!r}")

    def touch_start(self, alpha0: float, penetration: float):
        """
        Guess the tip contact after a tip-first touch.

        By the linear theory of the straightened whisker: a normal tip force F deflects the tip by
        F c2 and turns it by F c1.
        """
        sa = math.sin(alpha0)
        c2 = self.shape.linear_compliance()
        x, w = np.polynomial.legendre.leggauss(32)
        u = 0.5 * (x + 1.0)
        c1 = float(0.5 * np.sum(w * (1.0 - u) / self.shape.stiffness(u)))
        gamma = penetration * c1 / (c2 * sa)
        self._last = self._base = None
        return Phase.TIP, (alpha0, gamma)

    def seed(self, phase: Phase, z, f: float) -> None:
        """Solve a branch point from scratch, knowing its force (e.g. to redraw a stored state)."""
        alpha, mu = float(z[0]), float(z[1])
        theta = self._intrinsic_guess(phase, alpha, mu)[0]
        self.solve(phase, alpha, mu, guess=(theta, float(f)))

    def side_touch_start(self, s_touch: float, alpha: float):
        """Return the branch point of a side-first touch at arc length ``s_touch``: zero force."""
        theta = HALF_PI + self.shape.intrinsic_slope(_Ops(self, s_touch).s)
        self._last = self._base = None
        self._memo.clear()
        self.solve(Phase.TANGENTIAL, alpha, s_touch, guess=(theta, 0.0))
        return Phase.TANGENTIAL, (alpha, s_touch)

    def step_scale(self, phase: Phase, z) -> float:
        """Scale of the continuation's steps (the unknowns stay O(1) on every branch)."""
        return 1.0

    def released(self, phase: Phase, z) -> bool:
        """Releases are the ``release`` event (f = 0), located like any other."""
        return False

    def tip_rotation(self, phase: Phase, z) -> float:
        if phase == Phase.TIP:
            return float(z[1])
        return HALF_PI + float(self.shape.intrinsic_slope(1.0)) - float(
            self.contact_quantities(phase, z)[3])

    def free_tip(self) -> Tuple[float, float, float]:
        """Tip of the unloaded whisker in the foot frame and its slope relative to the heading."""
        if self._free_tip is None:
            x, y = _intrinsic_offset(self.shape, 0.0, HALF_PI, 1.0)
            self._free_tip = (x, y, float(self.shape.intrinsic_slope(1.0)))
        return self._free_tip

    @property
    def is_straight(self) -> bool:
        return self.shape.k0 == 0.0 and self.shape.k1 == 0.0

    def contact_quantities(self, phase: Phase, z):
        """(f, m0, s1, tip_slope, tip_offset), contact frame; tip_offset = tip - contact."""
        alpha, mu = float(z[0]), float(z[1])
        sol = self.solve(phase, alpha, mu)
        if len(self._reported) > 4096:
            self._reported.clear()
        self._reported[(int(phase), alpha, mu)] = sol
        m0 = sol.base_moment()
        if phase == Phase.TANGENTIAL:
            s1 = sol.s1
            tip_slope = alpha + float(self.shape.intrinsic_slope(1.0)
                                      - self.shape.intrinsic_slope(s1))
            return sol.f, m0, s1, tip_slope, _intrinsic_offset(self.shape, s1, alpha, 1.0)
        return sol.f, m0, 1.0, float(sol.theta[-1]), (0.0, 0.0)

    def moment_profile(self, phase: Phase, z, s) -> np.ndarray:
        """Bending moment M(s) [EI_b] at arc lengths ``s`` (0 beyond the contact)."""
        sol = self.solve(phase, float(z[0]), float(z[1]))
        s = np.asarray(s, dtype=float)
        out = np.zeros_like(s)
        inside = s <= sol.s1
        x = 2.0 * self._t_of_s(s[inside], sol.s1) - 1.0
        out[inside] = C.chebval(x, self._Vinv @ sol.moments(self))
        return out

    def centerline_contact_frame(self, phase: Phase, z, n: int) -> np.ndarray:
        """``n`` points from foot to tip in the foot frame (not mirrored), shape (n, 2)."""
        alpha, mu = float(z[0]), float(z[1])
        sol = self._reported.get((int(phase), alpha, mu)) or self.solve(phase, alpha, mu)
        s = np.linspace(0.0, 1.0, n)
        pts = np.empty((n, 2))
        half_sp = 0.5 * sol.operators(self).sp
        cx = C.chebint(self._Vinv @ (np.cos(sol.theta) * half_sp), lbnd=-1.0)
        cy = C.chebint(self._Vinv @ (np.sin(sol.theta) * half_sp), lbnd=-1.0)
        loaded = s <= sol.s1
        x = 2.0 * self._t_of_s(s[loaded], sol.s1) - 1.0
        pts[loaded, 0] = C.chebval(x, cx)
        pts[loaded, 1] = C.chebval(x, cy)
        for i in np.nonzero(~loaded)[0]:
            ox, oy = _intrinsic_offset(self.shape, sol.s1, alpha, s[i])
            pts[i] = (sol.P[0] + ox, sol.P[1] + oy)
        return pts

    def free_point(self, s: float) -> Tuple[float, float]:
        """
        Return the unloaded whisker's point at arc length s, foot frame (Chebyshev, ~1e-15).

        Both series by one Clenshaw recurrence on Python floats, their coefficients below
        rounding dropped: a touch search asks for single points many times, and numpy's
        chebval costs ~15 us a call on a scalar, this ~2 us for both.
        """
        if self._free_series is None:
            x, S, Vinv = chebyshev_operators(48)
            th = HALF_PI + self.shape.intrinsic_slope(0.5 * (x + 1.0))
            cx = C.chebint(Vinv @ (0.5 * np.cos(th)), lbnd=-1.0)
            cy = C.chebint(Vinv @ (0.5 * np.sin(th)), lbnd=-1.0)
            # |x|, |y| <= 1 on the whisker: coefficients below 1e-18 are below its rounding
            big = np.nonzero(np.maximum(np.abs(cx), np.abs(cy)) > 1e-18)[0]
            m = int(big[-1]) + 1 if big.size else 1
            self._free_series = tuple(zip(cx[m - 1::-1].tolist(), cy[m - 1::-1].tolist()))
        u2 = 4.0 * s - 2.0  # 2 u, u = 2 s - 1 on the series' [-1, 1]
        bx1 = bx2 = by1 = by2 = 0.0
        for ax, ay in self._free_series[:-1]:  # Clenshaw, from the highest degree down to 1
            bx1, bx2 = ax + u2 * bx1 - bx2, bx1
            by1, by2 = ay + u2 * by1 - by2, by1
        ax, ay = self._free_series[-1]
        return ax + 0.5 * u2 * bx1 - bx2, ay + 0.5 * u2 * by1 - by2

    def free_centerline(self, n: int) -> np.ndarray:
        return free_centerline(self.shape, np.linspace(0.0, 1.0, n))
