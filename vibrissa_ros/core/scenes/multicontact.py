"""
Equilibrium of a whisker touching several obstacle features at once, with Coulomb friction.

Mechanics (doc/mechanics/contacts.md; dimensionless: L = 1, EI_b = 1, world frame). Contacts
c = 1..k at arc lengths 0 < s_1 < ... < s_k <= 1 carry the forces F_c of the obstacles on the
whisker; the moment of everything beyond s is

    M(s) = sum_{c: s_c > s} (r(s_c) - r(s)) x F_c,   theta' = kappa0 + M / B,  theta(0) = heading,

the generalisation of the one-contact moment of ``general.py`` (paper eq. 2 with the point force
of eq. 4 replaced by a sum). The slope theta is discretized piecewise: on each segment
[s_(c-1), s_c] by Chebyshev collocation (the same nodes and the cone's exponential node map as
``general.py``), so the solution is spectrally accurate although theta'' jumps at each contact.
With the global cumulative integration matrix G (positions r = foot + G (cos, sin) theta) and
the rows E_c integrating up to s_c, the collocation equations are

    theta - heading - G kappa0 - sum_c A_c (F_cy cos(theta) - F_cx sin(theta)) = 0,
    A_c = G diag(1/B) H_c (E_c - G),   H_c = the nodes at or before s_c,

closed by each contact's geometric equations (position on the feature, tangency for a side
contact, the friction state's equation), see :class:`ContactMode`. Newton runs on the whole
bordered system; its Jacobian is analytic except for the columns of the contact arc lengths
(forward differences, which only slow Newton's convergence from quadratic to a factor ~1e-7 per
iteration).

Contact kinds (``ContactMode.kind``) and their unknowns / equations:

==============  ======================  =============================================
kind            unknowns                equations
==============  ======================  =============================================
``side``        s, u, N (+ T stick)     r(s) = b(u), sin(theta(s) - phi(u)) = 0
``corner``      s, N (+ T stick)        r(s) = V
``tip``         u, N (+ T stick)        r(1) = b(u)
``tip_corner``  Fx, Fy                  r(1) = V
==============  ======================  =============================================

Forces: side and tip F = N n(u) + T t(u) (n the outward normal, t the arc's tangent); corner
F = N nu + T tau (nu = e (-sin, cos) theta(s), the whisker's normal away from the corner, tau its
tangent); slip T = -slip_sign mu N; stick adds the equation q = q_anchor on the slip coordinate
q (side: sigma(u) - e s, corner: -s, tip: sigma(u)); mu = 0 is slip with T = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import List, Optional, Sequence, Tuple

import numpy as np
import scipy.linalg as sla

from .boundary import Arc, Vertex
from ..errors import ConvergenceError
from ..general.model import WhiskerShape, chebyshev_operators

#: Chebyshev points per segment (~1e-14 at 24: doc/mechanics/contacts.md)
DEFAULT_SEGMENT_POINTS = 24
KINDS = ("side", "corner", "tip", "tip_corner")
#: relative step of the forward differences in the contact arc lengths
_FD_STEP = 1e-7


class _Ones(dict):
    """Read-only arrays of ones by length (1/B of a cylinder)."""

    def __missing__(self, n):
        a = np.ones(n)
        a.setflags(write=False)
        self[n] = a
        return a


_ONES = _Ones()


@dataclass(frozen=True)
class ContactMode:
    """
    What touches what, and how (one contact of a configuration; immutable).

    Attributes
    ----------
    kind : str
        ``side``, ``corner``, ``tip`` or ``tip_corner``.
    feature : Arc or Vertex
        The obstacle's arc (side, tip) or corner (corner, tip_corner).
    obstacle : int
        Index of the obstacle in its scene (for reporting).
    feature_index : int
        Index of the feature in the obstacle's arcs or vertices.
    mu : float
        Coulomb friction coefficient (0: frictionless).
    stick : bool
        Sticking (T is an unknown, q is held at ``anchor``) or slipping.
    slip_sign : int
        Slipping: sign of dq/dt; T = -slip_sign mu N.
    e : int
        Side contact: cos(theta - phi) = +-1 (whisker and arc parallel or antiparallel); corner:
        the side of the whisker's normal that points away from the corner.
    anchor : (float, float)
        Stick: (u, s) where sticking began (the slip coordinate is held there).

    """

    kind: str
    feature: object
    obstacle: int = 0
    feature_index: int = 0
    mu: float = 0.0
    stick: bool = False
    slip_sign: int = 0
    e: int = 1
    anchor: Tuple[float, float] = (0.0, 0.0)

    @property
    def has_tangential_unknown(self) -> bool:
        return self.stick and self.mu > 0.0 and self.kind != "tip_corner"

    @property
    def on_side(self) -> bool:
        return self.kind in ("side", "corner")

    @property
    def size(self) -> int:
        """Count the scalar unknowns (and equations) of this contact."""
        base = {"side": 3, "corner": 2, "tip": 2, "tip_corner": 2}[self.kind]
        return base + (1 if self.has_tangential_unknown else 0)

    def with_(self, **changes) -> "ContactMode":
        return replace(self, **changes)


@dataclass(frozen=True)
class ContactSolution:
    """One contact of a solved configuration (world frame)."""

    mode: ContactMode
    s: float
    u: Optional[float]
    x: float
    y: float
    fx: float
    fy: float
    N: float
    T: float

    @property
    def kind(self) -> str:
        return self.mode.kind


class _Segment:
    """Collocation operators on one segment [a, b] of the whisker (internal)."""

    __slots__ = ("a", "b", "s", "Sig", "w", "binv", "k")

    def __init__(self, shape: WhiskerShape, t: np.ndarray, S: np.ndarray, a: float, b: float):
        self.a, self.b = a, b
        if shape.taper == 1.0:
            self.s = s = a + (b - a) * t
            self.Sig = (0.5 * (b - a)) * S
            self.w = self.Sig[-1].copy()
            self.binv = _ONES[t.size]
            self.k = shape.k0 + shape.k1 * s if shape.k1 else np.full(t.size, shape.k0)
            return
        else:
            # s_p - s = (s_p - a) r^t: B(s(t)) = ((s_p - a) / s_p)^4 r^(4 t) is entire in t
            s_p = 1.0 / (1.0 - shape.taper)
            log_r = math.log((s_p - b) / (s_p - a))
            e = np.exp(t * log_r)
            s = s_p - (s_p - a) * e
            sp = -(s_p - a) * log_r * e
        self.s = s
        self.Sig = 0.5 * S * sp
        self.w = self.Sig[-1].copy()
        self.binv = (1.0 - (1.0 - shape.taper) * s) ** -4
        self.k = shape.k0 + shape.k1 * s


@dataclass(frozen=True)
class Configuration:
    """A solved configuration: the collocation slope and every contact."""

    modes: Tuple[ContactMode, ...]
    breaks: Tuple[float, ...]  # segment ends s_1 .. s_k
    theta: np.ndarray
    contacts: Tuple[ContactSolution, ...]
    fx: float
    fy: float
    m0: float
    tip: Tuple[float, float]
    tip_slope: float
    vector: np.ndarray  # the Newton unknowns (internal)


class MultiContactSolver:
    """
    Solve the equilibrium of a configuration of contacts for a foot pose.

    Parameters
    ----------
    shape : WhiskerShape, optional
        The whisker's taper and intrinsic curvature; None: the paper's whisker (uniform,
        straight).
    n : int, optional
        Chebyshev points per segment.

    """

    _NEWTON_TOL = 1e-13
    _MAX_ITER = 30
    #: the contact arc lengths' Jacobian columns in closed form (cylinder) or by differences
    analytic_breaks = True

    def __init__(self, shape: Optional[WhiskerShape] = None, n: int = DEFAULT_SEGMENT_POINTS):
        self.shape = shape if shape is not None else WhiskerShape()
        self.n = int(n)
        x, S, Vinv = chebyshev_operators(self.n)
        self._t = 0.5 * (x + 1.0)
        self._x = x
        self._S = S
        self._Vinv = Vinv
        self.evaluations = 0
        self._last_configuration = None
        #: Newton iterations of the last successful solve
        self.iterations = 0
        self._cache = {}

    # -- layout -----------------------------------------------------------------------------
    def layout(self, modes: Sequence[ContactMode]):
        """Offsets of each contact's unknowns in the Newton vector (after the K slopes)."""
        K = self.n * len(modes)
        offsets, off = [], K
        for m in modes:
            offsets.append(off)
            off += m.size
        return K, offsets, off

    def breaks_of(self, modes, vec) -> List[float]:
        K, offsets, _ = self.layout(modes)
        out = []
        for m, o in zip(modes, offsets):
            out.append(vec[o] if m.on_side else 1.0)
        return out

    # -- residual and Jacobian ---------------------------------------------------------------
    def _assemble(self, breaks):
        """Segments and the global matrices G, E (rows), A_c for the given contact arc lengths."""
        key = tuple(float(b) for b in breaks)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        out = self._assemble_new(key)
        if len(self._cache) >= 8:
            self._cache.pop(next(iter(self._cache)))
        self._cache[key] = out
        return out

    def _assemble_new(self, breaks):
        n, k = self.n, len(breaks)
        K = n * k
        segs, a = [], 0.0
        for b in breaks:
            segs.append(_Segment(self.shape, self._t, self._S, a, b))
            a = b
        G = np.zeros((K, K))
        E = np.zeros((k, K))
        for j, seg in enumerate(segs):
            rows = slice(j * n, (j + 1) * n)
            for ell in range(j):
                G[rows, ell * n:(ell + 1) * n] = segs[ell].w
            G[rows, rows] = seg.Sig
            E[j:, rows] = seg.w
        kap = np.concatenate([seg.k for seg in segs])
        Gb = G if self.shape.taper == 1.0 else G * np.concatenate([seg.binv for seg in segs])
        A = []
        for c in range(k):
            r = (c + 1) * n  # H_c: only the rows up to segment c
            A.append(Gb[:, :r] @ (E[c] - G[:r]))
        return segs, G, E, A, kap

    def _forces(self, modes, vec, offsets, theta):
        """Return each force and its derivatives: (F, dF/d(own unknowns), dF/dtheta_c)."""
        out = []
        n = self.n
        for c, (m, o) in enumerate(zip(modes, offsets)):
            kind = m.kind
            if kind == "tip_corner":
                F = np.array([vec[o], vec[o + 1]])
                out.append((F, {o: np.array([1.0, 0.0]), o + 1: np.array([0.0, 1.0])}, None))
                continue
            tan_mu = m.mu if (m.mu > 0.0 and not m.stick) else 0.0
            if kind in ("side", "tip"):
                io = o + 1 if kind == "side" else o
                u, N = vec[io], vec[io + 1]
                p = m.feature.at(u)
                nx, ny = math.sin(p.phi), -math.cos(p.phi)
                tx, ty = -ny, nx
                if m.has_tangential_unknown:
                    T = vec[io + 2]
                else:
                    T = -m.slip_sign * tan_mu * N
                F = np.array([N * nx + T * tx, N * ny + T * ty])
                d = {io: p.dphi * np.array([N * tx - T * nx, N * ty - T * ny])}
                if m.has_tangential_unknown:
                    d[io + 1] = np.array([nx, ny])
                    d[io + 2] = np.array([tx, ty])
                else:
                    Tn = -m.slip_sign * tan_mu
                    d[io + 1] = np.array([nx + Tn * tx, ny + Tn * ty])
                out.append((F, d, None))
            else:  # corner: along the whisker's normal and tangent at s_c
                N = vec[o + 1]
                th = theta[(c + 1) * n - 1]
                ct, st = math.cos(th), math.sin(th)
                nux, nuy = -m.e * st, m.e * ct
                if m.has_tangential_unknown:
                    T = vec[o + 2]
                    Tn = None
                else:
                    Tn = -m.slip_sign * tan_mu
                    T = Tn * N
                F = np.array([N * nux + T * ct, N * nuy + T * st])
                dth = np.array([-N * m.e * ct - T * st, -N * m.e * st + T * ct])
                if Tn is None:
                    d = {o + 1: np.array([nux, nuy]), o + 2: np.array([ct, st])}
                else:
                    d = {o + 1: np.array([nux + Tn * ct, nuy + Tn * st])}
                out.append((F, d, dth))
        return out

    def residual(self, modes, vec, pose, want_jacobian=True):
        """Residual of the collocation and contact equations (and the Jacobian)."""
        self.evaluations += 1
        n = self.n
        K, offsets, size = self.layout(modes)
        breaks = self.breaks_of(modes, vec)
        segs, G, E, A, kap = self._assemble(breaks)
        theta = vec[:K]
        c_, s_ = np.cos(theta), np.sin(theta)
        forces = self._forces(modes, vec, offsets, theta)
        R = np.empty(size)
        Gk = G @ kap
        res = theta - pose.heading - Gk
        Fsum = np.zeros(2)
        for c, (F, _, _) in enumerate(forces):
            res -= A[c] @ (F[1] * c_ - F[0] * s_)
            Fsum += F
        R[:K] = res
        Px = pose.x + E @ c_
        Py = pose.y + E @ s_
        for c, (m, o) in enumerate(zip(modes, offsets)):
            R[o:o + m.size] = self._contact_equations(m, vec, o, Px[c], Py[c],
                                                      theta[(c + 1) * n - 1])
        if not want_jacobian:
            return R, None
        J = np.zeros((size, size))
        diag = np.zeros(K)
        for F, _, _ in forces:
            diag += F[0] * c_ + F[1] * s_
        Jth = np.eye(K)
        for c, (F, d, dth) in enumerate(forces):
            Jth += A[c] * (F[0] * c_ + F[1] * s_)
            col_x, col_y = A[c] @ s_, -(A[c] @ c_)
            for j, dF in d.items():
                J[:K, j] += dF[0] * col_x + dF[1] * col_y
            if dth is not None:  # a corner's force turns with the whisker's slope there
                jc = (c + 1) * n - 1
                Jth[:, jc] += dth[0] * col_x + dth[1] * col_y
        J[:K, :K] = Jth
        for c, (m, o) in enumerate(zip(modes, offsets)):
            # positions: d(Px, Py)/dtheta = E_c (-sin, cos)
            J[o, :K] = -E[c] * s_
            J[o + 1, :K] = E[c] * c_
            self._contact_jacobian(m, vec, o, J, theta[(c + 1) * n - 1], (c + 1) * n - 1)
        # the contact arc lengths: in closed form for a cylinder, else forward differences
        if self.shape.taper == 1.0 and self.analytic_breaks:
            vs = [F[1] * c_ - F[0] * s_ for F, _, _ in forces]
            for c, (m, o) in enumerate(zip(modes, offsets)):
                if m.on_side:
                    self._break_column(c, modes, offsets, breaks, G, E, kap, vs, c_, s_,
                                       J[:, o])
                    if m.has_tangential_unknown:
                        J[o + 3 if m.kind == "side" else o + 2, o] = (
                            -m.e if m.kind == "side" else 1.0)
            return R, J
        for c, (m, o) in enumerate(zip(modes, offsets)):
            if not m.on_side:
                continue
            h = _FD_STEP * max(1.0, abs(vec[o]))
            v2 = vec.copy()
            v2[o] += h
            R2, _ = self.residual(modes, v2, pose, want_jacobian=False)
            J[:, o] = (R2 - R) / h
        return R, J

    def _break_column(self, c, modes, offsets, breaks, G, E, kap, vs, c_, s_, out):
        """
        Write d(residual)/d(s_c) for a cylinder (B = 1) into ``out``.

        The segments' lengths L_j enter G, E and the nodes linearly: G = sum_j L_j G^(j), where
        G^(j) is G's block column j over L_j; s_c lengthens segment c and shortens segment c + 1,
        so dG = G^(c) - G^(c+1), dE likewise, and kappa0 at the nodes moves with k1 (t on
        segment c, 1 - t on segment c + 1).
        """
        n, k = self.n, len(modes)
        K = n * k
        parts = []  # (columns, sign / L_j, j)
        dk = np.zeros(K)
        a = 0.0
        for j in range(k):
            b = breaks[j]
            if j in (c, c + 1):
                sign = 1.0 if j == c else -1.0
                cols = slice(j * n, (j + 1) * n)
                parts.append((cols, sign / (b - a), j))
                if self.shape.k1:
                    dk[cols] = self.shape.k1 * (self._t if sign > 0 else 1.0 - self._t)
            a = b
        res = -(G @ dk) if self.shape.k1 else np.zeros(K)
        for cols, f, _ in parts:
            res -= f * (G[:, cols] @ kap[cols])
        for ell, v in enumerate(vs):
            rows = (ell + 1) * n
            y = E[ell] @ v - G[:rows] @ v  # H_l (E_l - G) v, rows up to segment l
            dy = np.zeros(rows)
            for cols, f, j in parts:
                if j <= ell:  # dE_l v: E_l's block j scales with L_j
                    dy += f * (E[ell, cols] @ v[cols])
                if cols.start < rows:
                    dy -= f * (G[:rows, cols] @ v[cols])
                    res -= f * (G[:, cols] @ y[cols])
            res -= G[:, :rows] @ dy
        out[:K] = res
        for ell, o in enumerate(offsets):
            # the contact's position moves with the lengths: dE_l (cos, sin) theta
            dx = dy_ = 0.0
            for cols, f, j in parts:
                if j <= ell:
                    dx += f * (E[ell, cols] @ c_[cols])
                    dy_ += f * (E[ell, cols] @ s_[cols])
            out[o] = dx
            out[o + 1] = dy_
            if modes[ell].kind == "side":
                out[o + 2] = 0.0
        return out

    def _contact_equations(self, m, vec, o, px, py, th_c):
        kind = m.kind
        if kind == "side":
            u = vec[o + 1]
            p = m.feature.at(u)
            eqs = [px - p.x, py - p.y, math.sin(th_c - p.phi)]
            if m.has_tangential_unknown:
                eqs.append(m.feature.sigma_between(m.anchor[0], u) - m.e * (vec[o] - m.anchor[1]))
            return eqs
        if kind == "tip":
            u = vec[o]
            p = m.feature.at(u)
            eqs = [px - p.x, py - p.y]
            if m.has_tangential_unknown:
                eqs.append(u - m.anchor[0])
            return eqs
        V = m.feature
        eqs = [px - V.x, py - V.y]
        if kind == "corner" and m.has_tangential_unknown:
            eqs.append(vec[o] - m.anchor[1])
        return eqs

    def _contact_jacobian(self, m, vec, o, J, th_c, jc):
        kind = m.kind
        if kind == "side":
            u = vec[o + 1]
            p = m.feature.at(u)
            J[o, o + 1] = -p.speed * math.cos(p.phi)
            J[o + 1, o + 1] = -p.speed * math.sin(p.phi)
            cd = math.cos(th_c - p.phi)
            J[o + 2, jc] = cd
            J[o + 2, o + 1] = -cd * p.dphi
            if m.has_tangential_unknown:
                J[o + 3, o + 1] = p.speed
                # (d/ds from the forward differences)
        elif kind == "tip":
            u = vec[o]
            p = m.feature.at(u)
            J[o, o] = -p.speed * math.cos(p.phi)
            J[o + 1, o] = -p.speed * math.sin(p.phi)
            if m.has_tangential_unknown:
                J[o + 2, o] = 1.0

    # -- Newton ------------------------------------------------------------------------------
    def solve(self, modes: Sequence[ContactMode], pose, guess: np.ndarray,
              max_iter: Optional[int] = None, lu=None) -> Tuple[np.ndarray, object]:
        """
        Newton from ``guess``; return (vector, LU of the last Jacobian) or raise ConvergenceError.

        ``lu``: a factorized Jacobian to start with (chord iterations); it is refreshed when the
        residual does not fall fast enough.
        """
        modes = tuple(modes)
        vec = np.array(guess, dtype=float)
        max_iter = self._MAX_ITER if max_iter is None else max_iter
        prev = math.inf
        for it in range(max_iter):
            fresh = lu is None
            # an iterate may put two contacts at one arc length (a segment of length 0): the
            # residual is then not finite, which is reported below, not warned about
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                if fresh:
                    R, J = self.residual(modes, vec, pose)
                else:
                    R, _ = self.residual(modes, vec, pose, want_jacobian=False)
            if fresh:
                if not np.all(np.isfinite(J)):
                    raise ConvergenceError("multi-contact: the Jacobian is not finite")
                try:
                    lu = sla.lu_factor(J, check_finite=False)
                except (ValueError, np.linalg.LinAlgError):
                    raise ConvergenceError("multi-contact: singular Jacobian") from None
            size = float(np.max(np.abs(R)))
            if not math.isfinite(size):
                raise ConvergenceError("multi-contact: the residual is not finite")
            if size <= self._NEWTON_TOL:
                self.iterations = it
                return vec, lu
            if size > 0.05 * prev and not fresh:
                lu = None  # chord iterations converge slowly: fresh Jacobian
                prev = size
                continue
            rate = size / prev if (not fresh and math.isfinite(prev)) else None
            prev = size
            step = sla.lu_solve(lu, R, check_finite=False)
            big = float(np.max(np.abs(step)))
            if not math.isfinite(big):
                raise ConvergenceError("multi-contact: Newton step is not finite")
            damped = big > 0.3
            if damped:
                step *= 0.3 / big
            vec = vec - step
            if not self._admissible(modes, vec):
                raise ConvergenceError("multi-contact: Newton left the configuration's domain")
            if rate is not None and not damped and rate * size <= 0.01 * self._NEWTON_TOL:
                # the iteration contracts by ``rate`` (measured on the last two residuals): the
                # residual after this step is below a hundredth of the tolerance
                self.iterations = it + 1
                return vec, lu
        raise ConvergenceError(
            f"multi-contact: no convergence in {max_iter} iterations (residual {prev:.3g})")

    def _admissible(self, modes, vec) -> bool:
        K, offsets, _ = self.layout(modes)
        last = 0.0
        for m, o in zip(modes, offsets):
            if m.on_side:
                s = vec[o]
                if not last < s < 1.0 + 0.05:
                    return False
                last = s
        return True

    def tangent(self, modes, vec, pose, dpose, lu=None) -> np.ndarray:
        """
        d(vector)/dt along a path with d(x, y, heading)/dt = ``dpose``: -J^-1 dR/dt.

        The pose enters the collocation equations through theta(0) = heading and the position
        equations through the foot.
        """
        K, offsets, size = self.layout(modes)
        if lu is None:
            _, J = self.residual(modes, vec, pose)
            lu = sla.lu_factor(J, check_finite=False)
        dR = np.zeros(size)
        dR[:K] = -dpose[2]
        for o in offsets:
            dR[o] = dpose[0]
            dR[o + 1] = dpose[1]
        return -sla.lu_solve(lu, dR, check_finite=False)

    # -- results -----------------------------------------------------------------------------
    def configuration(self, modes, vec, pose) -> Configuration:
        """Package a solved vector: contacts, base load, tip (the last one is remembered)."""
        modes = tuple(modes)
        key = (modes, pose, vec.tobytes())
        last = self._last_configuration
        if last is not None and last[0] == key:
            return last[1]
        cfg = self._configuration(modes, vec, pose)
        self._last_configuration = (key, cfg)
        return cfg

    def _configuration(self, modes, vec, pose) -> Configuration:
        if not modes:  # free: the unloaded whisker
            ex, ey = _unloaded_offset(self.shape, 0.0, pose.heading)
            return Configuration((), (), np.zeros(0), (), 0.0, 0.0, 0.0,
                                 (pose.x + ex, pose.y + ey),
                                 pose.heading + float(self.shape.intrinsic_slope(1.0)),
                                 np.zeros(0))
        K, offsets, _ = self.layout(modes)
        breaks = self.breaks_of(modes, vec)
        segs, G, E, A, kap = self._assemble(breaks)
        theta = vec[:K]
        c_, s_ = np.cos(theta), np.sin(theta)
        Px = pose.x + E @ c_
        Py = pose.y + E @ s_
        forces = self._forces(modes, vec, offsets, theta)
        contacts = []
        fx = fy = m0 = 0.0
        for c, (m, o) in enumerate(zip(modes, offsets)):
            F = forces[c][0]
            if m.kind == "tip_corner":
                u, N, T = None, float(math.hypot(F[0], F[1])), 0.0
            elif m.kind == "side":
                u, N = float(vec[o + 1]), float(vec[o + 2])
                T = float(vec[o + 3]) if m.has_tangential_unknown else -m.slip_sign * (
                    m.mu if not m.stick else 0.0) * N
            elif m.kind == "tip":
                u, N = float(vec[o]), float(vec[o + 1])
                T = float(vec[o + 2]) if m.has_tangential_unknown else -m.slip_sign * (
                    m.mu if not m.stick else 0.0) * N
            else:
                u, N = None, float(vec[o + 1])
                T = float(vec[o + 2]) if m.has_tangential_unknown else -m.slip_sign * (
                    m.mu if not m.stick else 0.0) * N
            x, y = float(Px[c]), float(Py[c])
            contacts.append(ContactSolution(m, float(breaks[c]), u, x, y, float(F[0]),
                                            float(F[1]), N, T))
            fx += F[0]
            fy += F[1]
            m0 += (x - pose.x) * F[1] - (y - pose.y) * F[0]
        last = breaks[-1] if breaks else 0.0
        th_last = float(theta[-1]) if K else pose.heading
        ex, ey = _unloaded_offset(self.shape, last, th_last)
        tip_x = (float(Px[-1]) if K else pose.x) + ex
        tip_y = (float(Py[-1]) if K else pose.y) + ey
        tip_slope = th_last + float(self.shape.intrinsic_slope(1.0)
                                    - self.shape.intrinsic_slope(last))
        return Configuration(modes, tuple(float(b) for b in breaks), theta.copy(),
                             tuple(contacts), float(fx), float(fy), float(m0),
                             (tip_x, tip_y), tip_slope, vec.copy())

    def node_points(self, modes, vec, pose, spacing: float):
        """
        Return arc lengths and world points sampling the whisker: the collocation nodes.

        Beyond the last contact the unloaded part is sampled every ``spacing`` or closer.
        """
        modes = tuple(modes)
        if modes:
            breaks = self.breaks_of(modes, vec)
            segs, G, E, A, kap = self._assemble(breaks)
            K = self.n * len(modes)
            theta = vec[:K]
            c_, s_ = np.cos(theta), np.sin(theta)
            s_nodes = np.concatenate([seg.s for seg in segs])
            px, py = pose.x + G @ c_, pose.y + G @ s_
            last, th_last, x_last, y_last = breaks[-1], float(theta[-1]), px[-1], py[-1]
        else:
            s_nodes, px, py = np.zeros(1), np.array([pose.x]), np.array([pose.y])
            last, th_last, x_last, y_last = 0.0, pose.heading, pose.x, pose.y
        if last < 1.0:
            m = max(2, int(math.ceil((1.0 - last) / spacing)) + 1)
            s_free = np.linspace(last, 1.0, m)[1:]
            ox, oy = _unloaded_offsets(self.shape, last, th_last, s_free)
            s_nodes = np.concatenate((s_nodes, s_free))
            px = np.concatenate((px, x_last + ox))
            py = np.concatenate((py, y_last + oy))
        return s_nodes, np.column_stack((px, py))

    def chebyshev_matrix(self, x: np.ndarray) -> np.ndarray:
        """T_k(x) for k < n at points x in [-1, 1], shape (len(x), n)."""
        x = np.clip(np.asarray(x, dtype=float), -1.0, 1.0)
        return np.cos(np.outer(np.arccos(x), np.arange(self.n)))

    def centerline(self, modes, vec, pose, s: np.ndarray) -> np.ndarray:
        """World points of the whisker at arc lengths ``s`` (spectral interpolation), (m, 2)."""
        modes = tuple(modes)
        s = np.asarray(s, dtype=float)
        out = np.empty((s.size, 2))
        n = self.n
        breaks = self.breaks_of(modes, vec) if modes else []
        K = n * len(modes)
        theta = vec[:K]
        x0, y0, a = pose.x, pose.y, 0.0
        th_end = pose.heading
        done = np.zeros(s.size, dtype=bool)
        segs = self._assemble(breaks)[0] if modes else []
        for j, b in enumerate(breaks):
            seg = segs[j]
            th = theta[j * n:(j + 1) * n]
            # positions at the nodes, then Chebyshev interpolation in the node variable
            px = x0 + seg.Sig @ np.cos(th)
            py = y0 + seg.Sig @ np.sin(th)
            inside = (~done) & (s <= b)
            if np.any(inside):
                tt = _node_variable(self.shape, s[inside], a, b)
                T = self.chebyshev_matrix(2.0 * tt - 1.0)
                coef = self._Vinv @ np.column_stack((px, py))
                out[inside] = T @ coef
                done |= inside
            x0, y0, a, th_end = float(px[-1]), float(py[-1]), b, float(th[-1])
        rest = ~done
        if np.any(rest):
            ox, oy = _unloaded_offsets(self.shape, a, th_end, s[rest])
            out[rest, 0] = x0 + ox
            out[rest, 1] = y0 + oy
        return out


def _node_variable(shape: WhiskerShape, s, a: float, b: float):
    if shape.taper == 1.0:
        return (s - a) / (b - a)
    s_p = 1.0 / (1.0 - shape.taper)
    return np.log((s_p - s) / (s_p - a)) / math.log((s_p - b) / (s_p - a))


def _unloaded_offset(shape: WhiskerShape, s_a: float, theta_a: float, s_b: float = 1.0):
    """Return the displacement along the unloaded part from s_a (slope theta_a) to s_b."""
    ox, oy = _unloaded_offsets(shape, s_a, theta_a, np.array([s_b]))
    return float(ox[0]), float(oy[0])


def _unloaded_offsets(shape: WhiskerShape, s_a: float, theta_a: float, s_b: np.ndarray):
    """
    Return the displacements along the unloaded part from s_a (slope theta_a) to arc lengths s_b.

    Gauss-Legendre (48 points) on the intrinsic slope; exact for a straight whisker.
    """
    d = np.maximum(np.asarray(s_b, dtype=float) - s_a, 0.0)
    if shape.k0 == 0.0 and shape.k1 == 0.0:
        return d * math.cos(theta_a), d * math.sin(theta_a)
    x, w = np.polynomial.legendre.leggauss(48)
    u = s_a + 0.5 * np.outer(d, x + 1.0)
    th = theta_a + shape.k0 * (u - s_a) + 0.5 * shape.k1 * (u * u - s_a * s_a)
    half = 0.5 * d
    return half * (np.cos(th) @ w), half * (np.sin(th) @ w)


__all__ = ["ContactMode", "ContactSolution", "Configuration", "MultiContactSolver", "KINDS",
           "Arc", "Vertex"]
