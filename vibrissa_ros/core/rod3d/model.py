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
from typing import Any, Optional, Sequence, Tuple

import numpy as np
import scipy.linalg as sla

from ..errors import ConvergenceError, ParameterError
from ..general.model import chebyshev_operators
from .pose import BasePose, quat_about, quat_matrix, quat_multiply
from .shape import RodShape

#: Chebyshev points per segment (error ~1e-13 at 24: doc/mechanics/rod3d.md)
DEFAULT_SEGMENT_POINTS = 24
KINDS = ("side", "tip")
_E3 = np.array([0.0, 0.0, 1.0])
_NEWTON_ITERATIONS = 30


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
        """Number of unknowns of the contact (side: s, f; tip: f)."""
        return 2 if self.kind == "side" else 1


def _skew(v: np.ndarray) -> np.ndarray:
    """[v]_x (..., 3, 3) with [v]_x w = v x w."""
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    o = np.zeros_like(x)
    return np.stack((np.stack((o, -z, y), -1), np.stack((z, o, -x), -1),
                     np.stack((-y, x, o), -1)), -2)


def _drot(Q: np.ndarray) -> np.ndarray:
    """dR/dq_k for quaternions Q (N, 4): shape (N, 4, 3, 3)."""
    w, x, y, z = Q[:, 0], Q[:, 1], Q[:, 2], Q[:, 3]

    def m(rows):
        return 2.0 * np.stack([np.stack(r, -1) for r in rows], -2)

    return np.stack((
        m(((w, -z, y), (z, w, -x), (-y, x, w))),
        m(((x, y, z), (y, -x, -w), (z, w, -x))),
        m(((-y, x, w), (x, y, z), (-w, z, -y))),
        m(((-z, -w, x), (w, -z, y), (x, y, z))),
    ), axis=1)


def _left_vector(Q: np.ndarray) -> np.ndarray:
    """Lv(q) (N, 4, 3) with q * (0, v) = Lv(q) v."""
    w, x, y, z = Q[:, 0], Q[:, 1], Q[:, 2], Q[:, 3]
    return np.stack((np.stack((-x, -y, -z), -1), np.stack((w, -z, y), -1),
                     np.stack((z, w, -x), -1), np.stack((-y, x, w), -1)), -2)


def _right_pure(K: np.ndarray) -> np.ndarray:
    """Rm(k) (N, 4, 4) with q * (0, k) = Rm(k) q."""
    a, b, c = K[:, 0], K[:, 1], K[:, 2]
    o = np.zeros_like(a)
    return np.stack((np.stack((o, -a, -b, -c), -1), np.stack((a, o, c, -b), -1),
                     np.stack((b, -c, o, a), -1), np.stack((c, b, -a, o), -1)), -2)


class _Layout:
    """
    Nodes and integration matrices of one set of segment ends (internal).

    ``breaks`` = (s_1, ..., s_k) the segment ends (the last one is s_k <= 1); node i of segment
    c sits at s = s_(c-1) + h_c tau_j with tau the Chebyshev points mapped to [0, 1].
    """

    __slots__ = ("breaks", "n", "k", "N", "s", "G", "seg", "ends", "tau", "h")

    def __init__(self, solver: "RodSolver", breaks: Sequence[float]):
        n = solver.n
        self.breaks = tuple(float(b) for b in breaks)
        self.n, self.k = n, len(self.breaks)
        self.N = n * self.k
        starts = (0.0,) + self.breaks[:-1]
        self.h = np.array(self.breaks) - np.array(starts)
        self.tau = solver._tau
        self.seg = np.repeat(np.arange(self.k), n)
        self.s = np.repeat(np.array(starts), n) + np.repeat(self.h, n) * np.tile(self.tau, self.k)
        self.G = solver._template(self.k) * np.repeat(self.h, n)[None, :]
        self.ends = np.arange(1, self.k + 1) * n - 1

    def dG(self, solver: "RodSolver", c: int) -> np.ndarray:
        """dG / d s_c (the end of segment c moves; the next segment's start with it)."""
        dh = np.zeros(self.k)
        dh[c] = 1.0
        if c + 1 < self.k:
            dh[c + 1] = -1.0
        return solver._template(self.k) * np.repeat(dh, self.n)[None, :]

    def ds(self, c: int) -> np.ndarray:
        """d s_i / d s_c at the nodes."""
        out = np.zeros(self.N)
        n = self.n
        out[c * n:(c + 1) * n] = self.tau
        if c + 1 < self.k:
            out[(c + 1) * n:(c + 2) * n] = 1.0 - self.tau
        return out


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
        Chebyshev points per segment.

    Raises
    ------
    ParameterError
        When ``n`` is below 8.

    """

    def __init__(self, shape: RodShape, obstacles: Sequence[Any] = (),
                 n: int = DEFAULT_SEGMENT_POINTS):
        if int(n) < 8:
            raise ParameterError(f"collocation points per segment n = {n}: need at least 8")
        self.shape = shape
        self.obstacles = tuple(obstacles)
        self.n = int(n)
        x, S, Vinv = chebyshev_operators(self.n)
        self._x, self._S, self._Vinv = x, S, Vinv
        self._tau = 0.5 * (x + 1.0)
        self._templates = {}
        self._nu1 = 1.0 + shape.poisson
        self.evaluations = 0

    # -- operators ----------------------------------------------------------------------------
    def _template(self, k: int) -> np.ndarray:
        """G for unit segment lengths (N x N), k segments."""
        T = self._templates.get(k)
        if T is None:
            n = self.n
            T = np.zeros((n * k, n * k))
            half = 0.5 * self._S
            for c in range(k):
                rows = slice(c * n, (c + 1) * n)
                T[rows, c * n:(c + 1) * n] = half
                for cp in range(c):
                    T[rows, cp * n:(cp + 1) * n] = half[-1]
            T.setflags(write=False)
            self._templates[k] = T
        return T

    def layout(self, modes: Sequence[RodContactMode], vec: np.ndarray) -> _Layout:
        """Return the segment layout of a configuration at its unknown vector (internal)."""
        return _Layout(self, self.breaks_of(modes, vec))

    def size(self, modes: Sequence[RodContactMode]) -> int:
        """
        Return the number of unknowns of a configuration.

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts from the base to the tip.

        Returns
        -------
        int
            4 N + the contacts' unknowns.

        """
        return 4 * self.n * len(modes) + sum(m.size for m in modes)

    def breaks_of(self, modes, vec) -> Tuple[float, ...]:
        """The contacts' arc lengths from an unknown vector."""
        out = []
        o = 4 * self.n * len(modes)
        for m in modes:
            if m.kind == "side":
                out.append(float(vec[o]))
            else:
                out.append(1.0)
            o += m.size
        return tuple(out)

    def forces_of(self, modes, vec) -> Tuple[float, ...]:
        """The contacts' normal forces from an unknown vector."""
        out = []
        o = 4 * self.n * len(modes)
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
        self.evaluations += 1
        sh = self.shape
        k = len(modes)
        lay = _Layout(self, self.breaks_of(modes, vec))
        N, G = lay.N, lay.G
        Q = vec[:4 * N].reshape(N, 4)
        R = quat_matrix(Q)
        D1 = R[:, :, 0]
        p = np.array(pose.position)
        r = p + G @ D1
        s = lay.s
        B = sh.stiffness(s)
        kinv = np.empty((N, 3))
        kinv[:, 0] = self._nu1 / B
        kinv[:, 1] = 1.0 / B
        kinv[:, 2] = kinv[:, 1]
        kap0 = sh.curvature(s)
        # contacts
        o = 4 * N
        fs, surf, F, rc, ends = [], [], [], [], lay.ends
        for c, m in enumerate(modes):
            f = float(vec[o + m.size - 1])
            sp = self.obstacles[m.obstacle].surface(r[ends[c]])
            fs.append(f)
            surf.append(sp)
            F.append(f * np.asarray(sp.normal))
            rc.append(r[ends[c]])
            o += m.size
        M = np.zeros((N, 3))
        for c in range(k):
            e = ends[c] + 1
            M[:e] += np.cross(rc[c] - r[:e], F[c])
        mb = np.einsum("iab,ia->ib", R, M)
        kap = kinv * mb
        kap[:, 2] += kap0
        Lv = _left_vector(Q)
        g = 0.5 * np.einsum("iab,ib->ia", Lv, kap)
        qb = np.array(pose.quaternion)
        res = np.empty(self.size(modes))
        res[:4 * N] = (Q - qb - G @ g).ravel()
        o = 4 * N
        for c, m in enumerate(modes):
            sp = surf[c]
            res[o] = sp.distance
            if m.kind == "side":
                res[o + 1] = D1[ends[c]] @ np.asarray(sp.normal)
            o += m.size
        if not jacobian and not pose_sensitivity:
            return res, None, None
        dR = _drot(Q)                                   # (N, 4, 3, 3)
        D = dR[:, :, :, 0].transpose(0, 2, 1)          # dd1/dq (N, 3, 4)
        P = 0.5 * Lv * kinv[:, None, :]                # (N, 4, 3): dg/dkappa
        PRt = np.einsum("iab,icb->iac", P, R)          # P R^T (N, 4, 3): dg/dM
        n_unk = res.size
        J = np.zeros((n_unk, n_unk)) if jacobian else None
        sens = np.zeros((n_unk, 7)) if pose_sensitivity else None
        # dg/dQ: diagonal part
        T = np.einsum("ikab,ia->ibk", dR, M)            # d(R^T M)/dq (N, 3, 4)
        diag = 0.5 * _right_pure(kap) + np.einsum("iab,ibk->iak", P, T)
        dg = np.zeros((N, 4, N, 4))
        idx = np.arange(N)
        dg[idx, :, idx, :] = diag
        # dg/dQ through M: the contacts' forces and positions
        dM_dp = np.zeros((N, 3, 3))                      # dM_i / dp
        Hs, ns = [], []
        for c in range(k):
            e = ends[c] + 1
            X = _skew(F[c])
            H = np.asarray(surf[c].hessian)
            nrm = np.asarray(surf[c].normal)
            Hs.append(H)
            ns.append(nrm)
            ge = G[ends[c]]                                # (N,)
            XD = np.einsum("ab,jbk->jak", X, D)             # (N, 3, 4)
            PX = np.einsum("iab,jbk->ijak", PRt[:e], XD)  # (e, N, 4, 4)
            w1 = ge[None, :] - G[:e]                        # (e, N)
            dg[:e] -= w1[:, None, :, None] * PX.transpose(0, 2, 1, 3)
            Y = fs[c] * np.einsum("iab,bc->iac", _skew(rc[c] - r[:e]), H)   # (e, 3, 3)
            PY = np.einsum("iab,ibc->iac", PRt[:e], Y)     # (e, 4, 3)
            PYD = np.einsum("iab,jbk->iajk", PY, D)        # (e, 4, N, 4)
            dg[:e] += PYD * ge[None, None, :, None]
            dM_dp[:e] += Y
        if jacobian:
            J[:4 * N, :4 * N] = np.eye(4 * N) - np.tensordot(G, dg, axes=(1, 0)).reshape(
                4 * N, 4 * N)
        # the contacts' unknown columns and equations
        o = 4 * N
        for c, m in enumerate(modes):
            e = ends[c] + 1
            H, nrm = Hs[c], ns[c]
            if jacobian:
                # column f_c
                dM = np.zeros((N, 3))
                dM[:e] = np.cross(rc[c] - r[:e], nrm)
                J[:4 * N, o + m.size - 1] = -(G @ np.einsum("iab,ib->ia", PRt, dM)).ravel()
                # rows: distance and tangency, d/dQ
                ge = G[ends[c]]
                dr_dQ = ge[:, None, None] * D                  # (N, 3, 4): dr_c / dQ_j
                J[o, :4 * N] = np.einsum("a,jak->jk", nrm, dr_dQ).ravel()
                if m.kind == "side":
                    t = D1[ends[c]]
                    row = np.einsum("a,jak->jk", H @ t, dr_dQ)
                    row[ends[c]] += nrm @ D[ends[c]]
                    J[o + 1, :4 * N] = row.ravel()
            if sens is not None:
                sens[o, :3] = nrm
                if m.kind == "side":
                    sens[o + 1, :3] = H @ D1[ends[c]]
            o += m.size
        if jacobian:
            # columns of the contact arc lengths
            o = 4 * N
            for c, m in enumerate(modes):
                if m.kind == "side":
                    J[:, o] = self._break_column(lay, c, modes, Q, R, D1, r, M, F, fs, Hs, ns,
                                                 rc, kinv, B, g, PRt, Lv)
                o += m.size
        if sens is not None:
            sens[:4 * N, :3] = -(G @ np.einsum("iab,ibc->iac", PRt, dM_dp).reshape(N, 12)
                                 ).reshape(N, 4, 3).reshape(4 * N, 3)
            sens[:4 * N, 3:] = -np.tile(np.eye(4), (N, 1))
        return res, J, sens

    def _break_column(self, lay, c, modes, Q, R, D1, r, M, F, fs, Hs, ns, rc, kinv, B, g,
                      PRt, Lv):
        """d residual / d s_c (analytic: moving nodes and integration weights)."""
        sh = self.shape
        N = lay.N
        dG = lay.dG(self, c)
        ds = lay.ds(c)
        dr = dG @ D1                                        # dr_i / ds_c (N, 3)
        dM = np.zeros((N, 3))
        for cp in range(len(modes)):
            e = lay.ends[cp] + 1
            drc = dr[lay.ends[cp]]
            dF = fs[cp] * (Hs[cp] @ drc)
            dM[:e] += np.cross(drc - dr[:e], F[cp]) + np.cross(rc[cp] - r[:e], dF)
        mb = np.einsum("iab,ia->ib", R, M)
        dB = sh.stiffness_slope(lay.s) * ds
        dkinv = -dB / (B * B)
        dkap = np.einsum("iab,ia->ib", R, dM) * kinv
        dkap[:, 0] += self._nu1 * dkinv * mb[:, 0]
        dkap[:, 1] += dkinv * mb[:, 1]
        dkap[:, 2] += dkinv * mb[:, 2] + sh.curvature_slope(lay.s) * ds
        dg = 0.5 * np.einsum("iab,ib->ia", Lv, dkap)
        col = np.empty(self.size(modes))
        col[:4 * N] = -(dG @ g + lay.G @ dg).ravel()
        o = 4 * N
        for cp, m in enumerate(modes):
            drc = dr[lay.ends[cp]]
            col[o] = ns[cp] @ drc
            if m.kind == "side":
                col[o + 1] = D1[lay.ends[cp]] @ (Hs[cp] @ drc)
            o += m.size
        return col

    # -- solving ------------------------------------------------------------------------------
    def solve(self, modes: Sequence[RodContactMode], pose: BasePose, guess: np.ndarray,
              tol: float = 1e-13, max_iterations: int = _NEWTON_ITERATIONS,
              max_step: Optional[float] = None):
        """
        Solve a configuration's equilibrium by Newton's method from ``guess``.

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts from the base to the tip.
        pose : BasePose
            The base pose.
        guess : numpy.ndarray
            The starting unknown vector.
        tol : float, optional
            Convergence: the Newton step's max norm.
        max_iterations : int, optional
            Bound on the iterations.
        max_step : float or None, optional
            Refuse (ConvergenceError) a Newton step longer than this (max norm).

        Returns
        -------
        tuple
            (vec, lu factorization of the Jacobian at the solution).

        Raises
        ------
        ConvergenceError
            When Newton does not converge within ``max_iterations``, a contact leaves (0, 1], or
            a value is not finite.

        """
        vec = np.array(guess, dtype=float)
        last = math.inf
        for it in range(max_iterations):
            try:
                res, J, _ = self.residual(modes, vec, pose)
                lu = sla.lu_factor(J, check_finite=True)
                step = sla.lu_solve(lu, res, check_finite=False)
            except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
                raise ConvergenceError(f"3D whisker: Newton failed ({exc})") from None
            size = float(np.max(np.abs(step)))
            if not math.isfinite(size):
                raise ConvergenceError("3D whisker: Newton step is not finite")
            if max_step is not None and size > max_step:
                raise ConvergenceError("3D whisker: Newton step too long")
            vec = vec - step
            self._check_breaks(modes, vec)
            if size <= tol or (size < 1e-9 and size >= 0.5 * last):
                res, J, _ = self.residual(modes, vec, pose)
                return vec, sla.lu_factor(J, check_finite=False)
            last = size
        raise ConvergenceError(
            f"3D whisker: Newton did not converge in {max_iterations} iterations"
        )

    def _check_breaks(self, modes, vec):
        b = self.breaks_of(modes, vec)
        prev = 0.0
        for v in b:
            if not (prev < v <= 1.0) or not math.isfinite(v):
                raise ConvergenceError(
                    f"3D whisker: contact arc lengths {b} left 0 < s_1 < ... <= 1"
                )
            prev = v

    def tangent(self, modes, vec, pose: BasePose, dpose: np.ndarray, lu=None) -> np.ndarray:
        """
        Return d vec / dt along a pose path with d(p, q_base)/dt = ``dpose`` (7,).

        Parameters
        ----------
        modes : sequence of RodContactMode
            The contacts.
        vec : numpy.ndarray
            A solution.
        pose : BasePose
            Its pose.
        dpose : numpy.ndarray
            (dp/dt, dq/dt) (7,).
        lu : tuple, optional
            The Jacobian's LU factorization at ``vec``.

        Returns
        -------
        numpy.ndarray
            The tangent (size,).

        """
        _, J, sens = self.residual(modes, vec, pose, jacobian=lu is None, pose_sensitivity=True)
        if lu is None:
            lu = sla.lu_factor(J, check_finite=False)
        return -sla.lu_solve(lu, sens @ dpose, check_finite=False)

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
        phi = np.atleast_1d(self.shape.intrinsic_slope(np.asarray(s, dtype=float)))
        rot = np.zeros((phi.size, 4))
        rot[:, 0] = np.cos(0.5 * phi)
        rot[:, 3] = np.sin(0.5 * phi)
        return quat_multiply(np.array(pose.quaternion), rot)

    def guess(self, modes: Sequence[RodContactMode], breaks: Sequence[float],
              forces: Sequence[float], quaternions) -> np.ndarray:
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

        Returns
        -------
        numpy.ndarray
            The unknown vector.

        """
        lay = _Layout(self, breaks)
        out = [np.asarray(quaternions(lay.s), dtype=float).ravel()]
        for m, b, f in zip(modes, breaks, forces):
            out.append([b, f] if m.kind == "side" else [f])
        return np.concatenate([np.asarray(v, dtype=float) for v in out])

    def _segment_coefficients(self, lay: _Layout, values: np.ndarray) -> np.ndarray:
        """Chebyshev coefficients (k, n, d) of nodal values (N, d) per segment."""
        v = values.reshape(lay.k, lay.n, -1)
        return np.einsum("ab,kbd->kad", self._Vinv, v)

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
        lay = _Layout(self, self.breaks_of(modes, vec))
        Q = vec[:4 * lay.N].reshape(lay.N, 4)
        coef = self._segment_coefficients(lay, Q)
        out = np.empty((s.size, 4))
        starts = np.concatenate(([0.0], lay.breaks[:-1]))
        end = lay.breaks[-1]
        for i, si in enumerate(s):
            if si > end:
                phi = (self.shape.intrinsic_slope(si) - self.shape.intrinsic_slope(end))
                out[i] = quat_multiply(Q[-1], quat_about(_E3, float(phi)))
                continue
            c = min(int(np.searchsorted(lay.breaks, si)), lay.k - 1)
            x = 2.0 * (si - starts[c]) / lay.h[c] - 1.0
            out[i] = np.polynomial.chebyshev.chebval(x, coef[c])
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
        p = np.array(pose.position)
        if not modes:
            return p + self.shape.free_centerline(s) @ quat_matrix(np.array(pose.quaternion)).T
        lay = _Layout(self, self.breaks_of(modes, vec))
        Q = vec[:4 * lay.N].reshape(lay.N, 4)
        R = quat_matrix(Q)
        D1 = R[:, :, 0]
        coef = self._segment_coefficients(lay, D1)
        starts = np.concatenate(([0.0], lay.breaks[:-1]))
        base = np.empty((lay.k, 3))
        ints = []
        acc = p.copy()
        C = np.polynomial.chebyshev
        for c in range(lay.k):
            base[c] = acc
            ic = C.chebint(coef[c], lbnd=-1.0) * (0.5 * lay.h[c])
            ints.append(ic)
            acc = acc + C.chebval(1.0, ic)
        end = lay.breaks[-1]
        out = np.empty((s.size, 3))
        tail = s > end
        for i, si in enumerate(s):
            if tail[i]:
                continue
            c = min(int(np.searchsorted(lay.breaks, si)), lay.k - 1)
            x = 2.0 * (si - starts[c]) / lay.h[c] - 1.0
            out[i] = base[c] + C.chebval(x, ints[c])
        if np.any(tail):
            off = self.shape.intrinsic_offset(end, s[tail])
            out[tail] = acc + off[:, :1] * R[-1, :, 0] + off[:, 1:] * R[-1, :, 1]
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
        p = np.array(pose.position)
        breaks = self.breaks_of(modes, vec) if modes else ()
        fs = self.forces_of(modes, vec) if modes else ()
        if modes:
            pts = self.centerline(modes, vec, pose, np.array(breaks))
            forces = np.array([f * np.asarray(self.obstacles[m.obstacle].surface(x).normal)
                               for m, f, x in zip(modes, fs, pts)])
        else:
            pts = np.zeros((0, 3))
            forces = np.zeros((0, 3))
        tip = self.centerline(modes, vec, pose, [1.0])[0]
        qt = self.quaternions(modes, vec, pose, [1.0])[0]
        frame = quat_matrix(qt / np.linalg.norm(qt))
        force = forces.sum(axis=0) if len(forces) else np.zeros(3)
        moment = (np.cross(pts - p, forces).sum(axis=0) if len(forces) else np.zeros(3))
        vec = np.array(vec, dtype=float)
        vec.setflags(write=False)
        return RodEquilibrium(pose, modes, vec, tuple(breaks), tuple(fs), pts, forces, force,
                              moment, tip, frame, self)
