"""
Compiled kernels of the 3D whisker's collocation equations (numba, cached on disk).

The same equations as :meth:`.model.RodSolver.residual_reference` (the numpy reference, which the
tests compare these kernels with), written as loops over the nodes: one kernel places the nodes
and evaluates the shape there (:func:`prepare`), one evaluates the residual, its Jacobian and its
pose sensitivities (:func:`equations`) from those and the obstacles' surface data at the
contacts. Spheres, cylinders and planes have their surface data computed here too
(:func:`surface`; :func:`evaluate` does all three in one call); other obstacles give theirs from
Python. ``VIBRISSA_NO_JIT=1`` in the environment, or numba missing, selects the numpy reference
everywhere (``ENABLED`` is then False).

Shapes: n points per segment, k segments (contacts), N = n k nodes; contact kinds as integers
(1 side, 0 tip).
"""

from __future__ import annotations

import hashlib
import math
import os
import threading

import numpy as np

ENABLED = os.environ.get("VIBRISSA_NO_JIT", "").strip() not in ("1", "true", "yes", "on")
try:  # pragma: no cover - numba is a dependency; without it the numpy reference runs
    import numba
except ImportError:  # pragma: no cover
    numba = None
    ENABLED = False

#: set once every kernel is compiled (or loaded from numba's cache) in this process
WARM = False
_WARMING = threading.RLock()


def warm_up() -> None:
    """
    Compile every kernel (or load it from the on-disk cache) now, once per process.

    The first use of a kernel compiles it (~10 s the first time on a machine, ~0.2 s from the
    cache afterwards); this does it at once, in one thread: the solver calls it before a
    kernel's first use, and the ROS node starts it in the background when it starts. Other
    threads wait for it to finish (numba must not compile one kernel in two threads at once).
    """
    global WARM
    if WARM or not ENABLED:
        return
    with _WARMING:
        if WARM:
            return
        # imported here: model imports this module
        from ..errors import ConvergenceError
        from .model import RodContactMode, RodSolver, Solved, _lu_factor, _operators
        from .obstacles import Sphere
        from .pose import BasePose
        from .shape import RodShape

        solver = RodSolver(RodShape(), (Sphere((0.5, 0.1, 0.0), 0.1),), n=8)
        modes = (RodContactMode("side", 0),)
        pose = BasePose((0.0, 0.0, 0.0))
        vec = solver.guess(modes, (0.5,), (0.1,), lambda s: solver.free_quaternions(pose, s))
        WARM = True  # the calls below would otherwise come back here
        try:
            _, J, sens = solver._residual_compiled(modes, vec, pose, True, True)
            solver._residual_compiled(modes, vec, pose, False, False)
            solver._accepted(modes, vec, pose)
            solver.tip_gap(modes, vec, pose, np.array([0.25, 0.5]))
            if LAPACK:
                try:
                    solver.trusted_step(modes, Solved(vec, _lu_factor(J), sens), np.zeros(7),
                                        vec, pose, 0.05)
                except ConvergenceError:
                    pass  # (compiled all the same)
            # and as for an obstacle the kernels do not know (its surface data from Python)
            solver._config(modes).geometry = None
            solver._residual_compiled(modes, vec, pose, True, True)
            solver._residual_compiled(modes, vec, pose, False, False)
            solver._nodes(modes, vec, pose)
            least_distance(np.array([SPHERE]), np.zeros((1, 7)), np.zeros((2, 3)))
            fold_measure(np.ones(2))
            solver._centerline_compiled(modes, vec, pose, np.array([0.25, 1.0]))
            parabola_tail(0.5, np.array([1.0]), 1.0, *RodShape(parabola=1.0)._u_table())
            parabola_tip(0.5, 1.0, *RodShape(parabola=1.0)._u_table())
            det_measure(*_lu_factor(J))
            # (points_needed does not ask for it at n = 8; the operators are read-only)
            coefficient_tail(_operators(16).Vinv, np.zeros(64), 16, 1, 14)
            table = RodShape(parabola=1.0)._u_table()
            free_minimum(SPHERE, np.array([0.5, 0.2, 0.0, 0.1, 0.0, 0.0, 0.0]), np.eye(3),
                         np.zeros(3), 1.0, table[0], table[1], 0.5, 0.4, 0.6, 12, 1e-13)
            free_samples(np.array([SPHERE]), np.zeros((1, 7)), np.eye(3), np.zeros(3),
                         np.zeros((3, 3)))
            stream_guess(np.zeros((3, 7)), np.zeros((3, 4)), np.zeros(7), np.zeros(4),
                         np.ones(7), np.array([3], np.int64), np.ones((1, 5)), 0.01)
            # the array's tick kernels (arrays/_jit.py), with the argument types it passes
            from ..arrays import _jit as arrays_jit
            arrays_jit.frames(np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2),
                              np.zeros(2), np.zeros(2, np.bool_), np.eye(3))
            arrays_jit.clearance(np.tile(np.eye(3), (2, 1, 1)), np.zeros((2, 3)),
                                 np.tile(np.eye(3), (2, 1, 1)), np.zeros((2, 3)), np.ones(2),
                                 np.zeros((2, 5, 3)), 4, np.ones(2), np.array([SPHERE]),
                                 np.zeros((1, 7)))
            arrays_jit.poses(np.tile(np.eye(3), (2, 1, 1)), np.zeros((2, 3)), np.ones(2),
                             np.zeros(1, np.int64))
            arrays_jit.quaternions(np.tile(np.eye(3), (2, 1, 1)))
            arrays_jit.collect(np.tile(np.eye(3), (2, 1, 1)), np.zeros((2, 3)), np.zeros((2, 3)),
                               np.ones(2), np.ones(2), np.ones(2), np.zeros(1, np.int64),
                               np.zeros((1, 10)), np.zeros(1, np.int64), np.zeros((1, 11)))
        except BaseException:
            WARM = False
            raise


def shared_cache(source: str, prefix: str, also=()) -> None:
    """
    Cache the kernels of ``source`` by its content, in the user's numba cache, for every copy.

    numba caches by the source file's path by default: a colcon install (a copy) would compile
    everything again (~10 s). The locator below keys the cache directory on the content of
    ``source`` and of the files ``also`` (those whose kernels it calls, compiled into its own)
    instead, so a source tree and its installs share one cache, and a changed file gets a new
    one. It uses numba's cache locator classes; where they differ (another numba release) the
    default per-path cache is kept.
    """
    try:
        from numba.core import caching
        base = getattr(caching, "UserWideCacheLocator", None) or caching._UserWideCacheLocator
        impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
    except (ImportError, AttributeError):  # pragma: no cover - another numba layout
        return
    source = os.path.abspath(source)
    digest = hashlib.sha256()
    for path in (source,) + tuple(also):
        with open(path, "rb") as fh:
            digest.update(fh.read())
    digest = digest.hexdigest()

    class _SharedLocator(base):
        shared_source = source

        def __init__(self, py_func, py_file):
            super().__init__(py_func, py_file)
            root = numba.config.CACHE_DIR or os.path.dirname(self._cache_path)
            self._cache_path = os.path.join(root, prefix + digest[:16])

        def get_source_stamp(self):
            return digest

        @classmethod
        def from_function(cls, py_func, py_file):
            if os.path.abspath(py_file) != source:
                return None
            return super().from_function(py_func, py_file)

    if not any(getattr(c, "shared_source", None) == source for c in impl._locator_classes):
        impl._locator_classes.insert(0, _SharedLocator)


if numba is not None:
    shared_cache(__file__, "vibrissa_ros_rod3d_")

    def _kernel(func):
        return numba.njit(cache=True, nogil=True)(func)
else:  # pragma: no cover
    def _kernel(func):
        return func


def _bind_lapack():
    """
    Return LAPACK's getrf and getrs as functions the kernels call, or (None, None).

    scipy's ``cython_lapack`` (the LAPACK scipy.linalg itself uses: the same results) exports
    them as C functions; their addresses are bound to symbol names that the compiled code calls
    by name, so that numba's on-disk cache stays valid in every process (an address baked into
    the code would not).
    """
    if numba is None:  # pragma: no cover
        return None, None
    try:
        import llvmlite.binding as llvm
        from numba.extending import get_cython_function_address

        out = []
        vp = numba.types.voidptr
        for name, nargs in (("dgetrf", 6), ("dgetrs", 9)):
            symbol = "vibrissa_rod3d_" + name
            address = get_cython_function_address("scipy.linalg.cython_lapack", name)
            llvm.add_symbol(symbol, address)
            out.append(numba.types.ExternalFunction(symbol, numba.types.void(*([vp] * nargs))))
    except (ImportError, ValueError, AttributeError):  # pragma: no cover - another layout
        return None, None
    return tuple(out)


_getrf, _getrs = _bind_lapack()
#: LAPACK is callable from the kernels (:func:`trusted_step`); else the tracker's general path
LAPACK = ENABLED and _getrf is not None


@_kernel
def _breaks(vec, n, kinds):
    """Contact arc lengths (k,) from the unknown vector (tip contacts at s = 1)."""
    k = kinds.size
    out = np.empty(k)
    o = 4 * n * k
    for c in range(k):
        if kinds[c] == 1:
            out[c] = vec[o]
            o += 2
        else:
            out[c] = 1.0
            o += 1
    return out


@_kernel
def _parabola_u(s, A, grid, table):
    """Return u = 2 A x(s) on the parabola y = A x^2 (as RodShape._u: table, then Newton)."""
    m = s.size
    u = np.empty(m)
    a = abs(A)
    top = grid[-1]
    inside = True
    for i in range(m):
        if not s[i] <= top:
            inside = False
    h = grid[1] - grid[0]
    for i in range(m):
        x = s[i]
        if x > top or not x == x:
            u[i] = 0.5 * 4.0 * a * x
        else:
            j = min(int(x / h), grid.size - 1)
            while j > 0 and grid[j] > x:
                j -= 1
            while j < grid.size - 1 and grid[j + 1] <= x:
                j += 1
            if j == grid.size - 1 or grid[j] == x:
                u[i] = table[j]
            else:
                slope = (table[j + 1] - table[j]) / (grid[j + 1] - grid[j])
                u[i] = slope * (x - grid[j]) + table[j]
    steps = 2 if inside else 60
    for i in range(m):
        target = 4.0 * a * s[i]
        v = u[i]
        for _ in range(steps):
            root = math.sqrt(1.0 + v * v)
            v = v - (v * root + math.asinh(v) - target) / (2.0 * root)
        u[i] = math.copysign(1.0, A) * v
    return u


@_kernel
def _weights(vec, n, kinds, tau, sp):
    """Return the breaks (k,), the nodes' arc lengths and weights (N,) and the cone's logs (k,)."""
    k = kinds.size
    N = n * k
    b = _breaks(vec, n, kinds)
    s = np.empty(N)
    w = np.empty(N)
    Ls = np.zeros(k)
    for c in range(k):
        a = 0.0 if c == 0 else b[c - 1]
        if sp <= 0.0:
            h = b[c] - a
            for j in range(n):
                s[c * n + j] = a + h * tau[j]
                w[c * n + j] = h
        else:
            L = math.log((sp - b[c]) / (sp - a))
            Ls[c] = L
            for j in range(n):
                gap = (sp - a) * math.exp(tau[j] * L)
                s[c * n + j] = sp - gap
                w[c * n + j] = -L * gap
    return b, s, w, Ls


@_kernel
def nodes(vec, n, kinds, tau, sp, T, p):
    """
    Return (breaks (k,), w (N,), r (N, 3), frames at the contacts (k, 3, 3)) of a solution.

    The centerline at the nodes, r = p + G d1, and R(q) at the segments' ends, for sampling a
    solution (:meth:`.model.RodSolver.centerline`, :meth:`.model.RodSolver.equilibrium`).
    """
    k = kinds.size
    N = n * k
    b, s, w, Ls = _weights(vec, n, kinds, tau, sp)
    r = _positions(vec, T, w, p, N)
    frames = np.empty((k, 3, 3))
    for c in range(k):
        e = (c + 1) * n - 1
        _rotation(vec[4 * e:4 * e + 4], frames[c])
    return b, w, r, frames


@_kernel
def prepare(vec, n, kinds, tau, sp, T, p, shape, grid, table):
    """
    Return the nodes, the shape at them and the centerline there, for one unknown vector.

    ``shape`` = (taper, 1 + nu, k0, k1, A, parabola flag); ``sp`` the cone's apex (or <= 0
    for a cylinder). Returns (s, w, ds, dw, kinv, kap0, kap0_slope, dkinv, r): the nodes' arc
    lengths and integration weights (N,), their derivatives by each contact's arc length (k, N),
    (nu1/B, 1/B, 1/B) (N, 3), kappa0 and its slope (N,), d(1/B)/ds (N,), and r (N, 3).
    """
    k = kinds.size
    N = n * k
    b, s, w, Ls = _weights(vec, n, kinds, tau, sp)
    ds = np.zeros((k, N))
    dw = np.zeros((k, N))
    cone = sp > 0.0
    for c in range(k):
        for j in range(n):
            i = c * n + j
            if not cone:
                ds[c, i] = tau[j]
                dw[c, i] = 1.0
            else:
                ds[c, i] = tau[j] * (sp - s[i]) / (sp - b[c])
                dw[c, i] = (sp - s[i]) * (1.0 + Ls[c] * tau[j]) / (sp - b[c])
            if c + 1 < k:
                i2 = (c + 1) * n + j
                if not cone:
                    ds[c, i2] = 1.0 - tau[j]
                    dw[c, i2] = -1.0
                else:
                    ds[c, i2] = (1.0 - tau[j]) * (sp - s[i2]) / (sp - b[c])
                    dw[c, i2] = ((sp - s[i2]) * (-1.0 + Ls[c + 1] * (1.0 - tau[j]))
                                 / (sp - b[c]))
    taper, nu1, k0, k1, A, parabola = (shape[0], shape[1], shape[2], shape[3], shape[4],
                                       shape[5])
    kinv = np.empty((N, 3))
    kap0 = np.empty(N)
    slope = np.empty(N)
    dkinv = np.empty(N)
    t1 = 1.0 - taper
    for i in range(N):
        x = 1.0 - t1 * s[i]
        B = x ** 4.0
        inv = 1.0 / B
        kinv[i, 0] = nu1 * inv
        kinv[i, 1] = inv
        kinv[i, 2] = inv
        dkinv[i] = -(-4.0 * t1 * x ** 3.0) * inv ** 2.0
    if parabola != 0.0:
        u = _parabola_u(s, A, grid, table)
        for i in range(N):
            ww = 1.0 + u[i] * u[i]
            kap0[i] = 2.0 * A / ww ** 1.5
            slope[i] = -12.0 * A ** 2.0 * u[i] / ww ** 3.0
    else:
        for i in range(N):
            kap0[i] = k0 + k1 * s[i]
            slope[i] = k1 + 0.0 * s[i]
    r = _positions(vec, T, w, p, N)
    return s, w, ds, dw, kinv, kap0, slope, dkinv, r


@_kernel
def _positions(vec, T, w, p, N):
    """Return r = p + G d1 (N, 3) at the nodes, G = T diag(w)."""
    d1 = np.empty((N, 3))
    for j in range(N):
        qw, qx, qy, qz = vec[4 * j], vec[4 * j + 1], vec[4 * j + 2], vec[4 * j + 3]
        d1[j, 0] = (qw * qw + qx * qx - qy * qy - qz * qz) * w[j]
        d1[j, 1] = 2.0 * (qx * qy + qw * qz) * w[j]
        d1[j, 2] = 2.0 * (qx * qz - qw * qy) * w[j]
    r = np.empty((N, 3))
    for i in range(N):
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        for j in range(N):
            t = T[i, j]
            a0 += t * d1[j, 0]
            a1 += t * d1[j, 1]
            a2 += t * d1[j, 2]
        r[i, 0] = p[0] + a0
        r[i, 1] = p[1] + a1
        r[i, 2] = p[2] + a2
    return r


@_kernel
def _rotation(q, R):
    """Fill R (3, 3) with R(q) (the unit-quaternion formula, as model._rotations)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    ww, xx, yy, zz = w * w, x * x, y * y, z * z
    xy, xz, yz, wx, wy, wz = x * y, x * z, y * z, w * x, w * y, w * z
    R[0, 0] = ww + xx - yy - zz
    R[0, 1] = 2.0 * (xy - wz)
    R[0, 2] = 2.0 * (xz + wy)
    R[1, 0] = 2.0 * (xy + wz)
    R[1, 1] = ww - xx + yy - zz
    R[1, 2] = 2.0 * (yz - wx)
    R[2, 0] = 2.0 * (xz - wy)
    R[2, 1] = 2.0 * (yz + wx)
    R[2, 2] = ww - xx - yy + zz


@_kernel
def _left(q, Lv):
    """Fill Lv (4, 3) with q * (0, v) = Lv v."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    Lv[0, 0], Lv[0, 1], Lv[0, 2] = -x, -y, -z
    Lv[1, 0], Lv[1, 1], Lv[1, 2] = w, -z, y
    Lv[2, 0], Lv[2, 1], Lv[2, 2] = z, w, -x
    Lv[3, 0], Lv[3, 1], Lv[3, 2] = -y, x, w


@_kernel
def _drot(q, dR):
    """Fill dR (4, 3, 3) with dR/dq_k (k = w, x, y, z)."""
    w, x, y, z = 2.0 * q[0], 2.0 * q[1], 2.0 * q[2], 2.0 * q[3]
    dR[0, 0, 0], dR[0, 0, 1], dR[0, 0, 2] = w, -z, y
    dR[0, 1, 0], dR[0, 1, 1], dR[0, 1, 2] = z, w, -x
    dR[0, 2, 0], dR[0, 2, 1], dR[0, 2, 2] = -y, x, w
    dR[1, 0, 0], dR[1, 0, 1], dR[1, 0, 2] = x, y, z
    dR[1, 1, 0], dR[1, 1, 1], dR[1, 1, 2] = y, -x, -w
    dR[1, 2, 0], dR[1, 2, 1], dR[1, 2, 2] = z, w, -x
    dR[2, 0, 0], dR[2, 0, 1], dR[2, 0, 2] = -y, x, w
    dR[2, 1, 0], dR[2, 1, 1], dR[2, 1, 2] = x, y, z
    dR[2, 2, 0], dR[2, 2, 1], dR[2, 2, 2] = -w, z, -y
    dR[3, 0, 0], dR[3, 0, 1], dR[3, 0, 2] = -z, -w, x
    dR[3, 1, 0], dR[3, 1, 1], dR[3, 1, 2] = w, -z, y
    dR[3, 2, 0], dR[3, 2, 1], dR[3, 2, 2] = x, y, z


@_kernel
def _cross3(a0, a1, a2, b0, b1, b2, out, i):
    """Add (a x b) to out[i]."""
    out[i, 0] += a1 * b2 - a2 * b1
    out[i, 1] += a2 * b0 - a0 * b2
    out[i, 2] += a0 * b1 - a1 * b0


@_kernel
def equations(vec, qb, n, kinds, T, w, ds, dw, kinv, kap0, slope, dkinv, r, nu1,
              dist, normal, hess, jacobian, sensitivity):
    """
    Return (residual, Jacobian, pose sensitivity, Jacobian finite) of the collocation system.

    ``dist`` (k,), ``normal`` (k, 3), ``hess`` (k, 3, 3): the obstacles' surface data at the
    contact points r(s_c). The Jacobian and the sensitivity are (0, 0) arrays unless asked for.
    """
    k = kinds.size
    N = n * k
    M4 = 4 * N
    size = M4
    for c in range(k):
        size += 2 if kinds[c] == 1 else 1
    ends = np.empty(k, dtype=np.int64)
    fs = np.empty(k)
    o = M4
    offs = np.empty(k, dtype=np.int64)
    for c in range(k):
        ends[c] = (c + 1) * n - 1
        sz = 2 if kinds[c] == 1 else 1
        offs[c] = o
        fs[c] = vec[o + sz - 1]
        o += sz
    G = np.empty((N, N))
    for i in range(N):
        for j in range(N):
            G[i, j] = T[i, j] * w[j]
    F = np.empty((k, 3))
    for c in range(k):
        for m in range(3):
            F[c, m] = fs[c] * normal[c, m]
    # moments M_i = sum_c [i <= e_c] (r_c - r_i) x F_c
    M = np.zeros((N, 3))
    for c in range(k):
        e = ends[c]
        for i in range(e + 1):
            _cross3(r[e, 0] - r[i, 0], r[e, 1] - r[i, 1], r[e, 2] - r[i, 2],
                    F[c, 0], F[c, 1], F[c, 2], M, i)
    R = np.empty((N, 3, 3))
    Lv = np.empty((N, 4, 3))
    mb = np.empty((N, 3))
    kap = np.empty((N, 3))
    g = np.empty((N, 4))
    for i in range(N):
        q = vec[4 * i:4 * i + 4]
        _rotation(q, R[i])
        _left(q, Lv[i])
        for m in range(3):
            mb[i, m] = M[i, 0] * R[i, 0, m] + M[i, 1] * R[i, 1, m] + M[i, 2] * R[i, 2, m]
            kap[i, m] = kinv[i, m] * mb[i, m]
        kap[i, 2] += kap0[i]
        for a in range(4):
            g[i, a] = 0.5 * (Lv[i, a, 0] * kap[i, 0] + Lv[i, a, 1] * kap[i, 1]
                             + Lv[i, a, 2] * kap[i, 2])
    res = np.empty(size)
    for i in range(N):
        for a in range(4):
            acc = 0.0
            for j in range(N):
                acc += G[i, j] * g[j, a]
            res[4 * i + a] = vec[4 * i + a] - qb[a] - acc
    for c in range(k):
        o = offs[c]
        res[o] = dist[c]
        if kinds[c] == 1:
            e = ends[c]
            res[o + 1] = (R[e, 0, 0] * normal[c, 0] + R[e, 1, 0] * normal[c, 1]
                          + R[e, 2, 0] * normal[c, 2])
    if not jacobian and not sensitivity:
        return res, np.zeros((0, 0)).T, np.zeros((0, 0)), False
    # D[j, ax, b] = d d1_l / d q_jb;  P = dg/dkappa;  PRt = P R^T = dg/dM
    dR = np.empty((N, 4, 3, 3))
    D = np.empty((N, 3, 4))
    P = np.empty((N, 4, 3))
    PRt = np.empty((N, 4, 3))
    for i in range(N):
        _drot(vec[4 * i:4 * i + 4], dR[i])
        for b in range(4):
            for ax in range(3):
                D[i, ax, b] = dR[i, b, ax, 0]
        for a in range(4):
            for m in range(3):
                P[i, a, m] = 0.5 * Lv[i, a, m] * kinv[i, m]
            for ax in range(3):
                PRt[i, a, ax] = (P[i, a, 0] * R[i, ax, 0] + P[i, a, 1] * R[i, ax, 1]
                                 + P[i, a, 2] * R[i, ax, 2])
    # dM_i/dp (the normals turn with the contact points)
    dMdp = np.zeros((N, 3, 3))
    for c in range(k):
        e = ends[c]
        f = fs[c]
        for i in range(e + 1):
            v0, v1, v2 = r[e, 0] - r[i, 0], r[e, 1] - r[i, 1], r[e, 2] - r[i, 2]
            for col in range(3):
                h0, h1, h2 = hess[c, 0, col], hess[c, 1, col], hess[c, 2, col]
                dMdp[i, 0, col] += f * (v1 * h2 - v2 * h1)
                dMdp[i, 1, col] += f * (v2 * h0 - v0 * h2)
                dMdp[i, 2, col] += f * (v0 * h1 - v1 * h0)
    # the Jacobian is written as its transpose Jt (C order), and J = Jt.T returned: Fortran
    # order, which LAPACK's getrf factors in place, without a transposed copy
    Jt = np.zeros((size, size)) if jacobian else np.zeros((0, 0))
    sens = np.zeros((size, 7)) if sensitivity else np.zeros((0, 0))
    if jacobian:
        # d g_i / d q_j = [i == j] diag_i + V_ij D_j: the moments' part of every pair (i, j)
        # shares D_j (3 x 4), so G is applied to V (N x N x 4 x 3) and D_j afterwards
        diag = np.empty((N, 4, 4))
        Tm = np.empty((3, 4))
        for i in range(N):
            # 1/2 Rm(kappa) + P d(R^T M)/dq, Rm(k) q = q * (0, k)
            for b in range(3):
                for kk in range(4):
                    Tm[b, kk] = (dR[i, kk, 0, b] * M[i, 0] + dR[i, kk, 1, b] * M[i, 1]
                                 + dR[i, kk, 2, b] * M[i, 2])
            k1_, k2_, k3_ = 0.5 * kap[i, 0], 0.5 * kap[i, 1], 0.5 * kap[i, 2]
            diag[i, 0, 0], diag[i, 0, 1], diag[i, 0, 2], diag[i, 0, 3] = 0.0, -k1_, -k2_, -k3_
            diag[i, 1, 0], diag[i, 1, 1], diag[i, 1, 2], diag[i, 1, 3] = k1_, 0.0, k3_, -k2_
            diag[i, 2, 0], diag[i, 2, 1], diag[i, 2, 2], diag[i, 2, 3] = k2_, -k3_, 0.0, k1_
            diag[i, 3, 0], diag[i, 3, 1], diag[i, 3, 2], diag[i, 3, 3] = k3_, k2_, -k1_, 0.0
            for a in range(4):
                for kk in range(4):
                    diag[i, a, kk] += (P[i, a, 0] * Tm[0, kk] + P[i, a, 1] * Tm[1, kk]
                                       + P[i, a, 2] * Tm[2, kk])
        # C_ci = PRt_i (f_c [r_c - r_i]_x H_c - [F_c]_x) (the normal turns with the contact
        # point) and A_i = PRt_i sum_c [i <= e_c] [F_c]_x, so that
        # V_ij = G_ij A_i + sum_c [i <= e_c] G_cj C_ci
        C = np.zeros((k, N, 4, 3))
        A = np.zeros((N, 4, 3))
        for c in range(k):
            e = ends[c]
            f = fs[c]
            F0, F1, F2 = F[c, 0], F[c, 1], F[c, 2]
            for i in range(e + 1):
                v0, v1, v2 = r[e, 0] - r[i, 0], r[e, 1] - r[i, 1], r[e, 2] - r[i, 2]
                for col in range(3):
                    h0, h1, h2 = hess[c, 0, col], hess[c, 1, col], hess[c, 2, col]
                    # column col of [F]_x
                    x0 = 0.0 if col == 0 else (-F2 if col == 1 else F1)
                    x1 = F2 if col == 0 else (0.0 if col == 1 else -F0)
                    x2 = -F1 if col == 0 else (F0 if col == 1 else 0.0)
                    y0 = f * (v1 * h2 - v2 * h1) - x0
                    y1 = f * (v2 * h0 - v0 * h2) - x1
                    y2 = f * (v0 * h1 - v1 * h0) - x2
                    for a in range(4):
                        p0, p1, p2 = PRt[i, a, 0], PRt[i, a, 1], PRt[i, a, 2]
                        C[c, i, a, col] = p0 * y0 + p1 * y1 + p2 * y2
                        A[i, a, col] += p0 * x0 + p1 * x1 + p2 * x2
        V = np.empty((N, N * 12))
        for i in range(N):
            for j in range(N):
                gij = G[i, j]
                base = j * 12
                for a in range(4):
                    for col in range(3):
                        V[i, base + 3 * a + col] = gij * A[i, a, col]
                for c in range(k):
                    if i > ends[c]:
                        continue
                    gc = G[ends[c], j]
                    for a in range(4):
                        for col in range(3):
                            V[i, base + 3 * a + col] += gc * C[c, i, a, col]
        GV = np.dot(G, V)
        for j in range(N):
            base = j * 12
            for i in range(N):
                gij = G[i, j]
                for a in range(4):
                    o3 = base + 3 * a
                    g0, g1, g2 = GV[i, o3], GV[i, o3 + 1], GV[i, o3 + 2]
                    for b in range(4):
                        Jt[4 * j + b, 4 * i + a] = -(g0 * D[j, 0, b] + g1 * D[j, 1, b]
                                                     + g2 * D[j, 2, b] + gij * diag[j, a, b])
        for i in range(4 * N):
            Jt[i, i] += 1.0
        # the columns of the forces and the rows of the contact equations
        Z = np.empty((N, 4))
        for c in range(k):
            e = ends[c]
            o = offs[c]
            sz = 2 if kinds[c] == 1 else 1
            n0, n1, n2 = normal[c, 0], normal[c, 1], normal[c, 2]
            for i in range(N):
                for a in range(4):
                    Z[i, a] = 0.0
            for i in range(e + 1):
                v0, v1, v2 = r[e, 0] - r[i, 0], r[e, 1] - r[i, 1], r[e, 2] - r[i, 2]
                m0 = v1 * n2 - v2 * n1
                m1 = v2 * n0 - v0 * n2
                m2 = v0 * n1 - v1 * n0
                for a in range(4):
                    Z[i, a] = PRt[i, a, 0] * m0 + PRt[i, a, 1] * m1 + PRt[i, a, 2] * m2
            for i in range(N):
                for a in range(4):
                    acc = 0.0
                    for j in range(N):
                        acc += G[i, j] * Z[j, a]
                    Jt[o + sz - 1, 4 * i + a] = -acc
            if kinds[c] == 1:
                t0, t1_, t2 = R[e, 0, 0], R[e, 1, 0], R[e, 2, 0]
                hd0 = hess[c, 0, 0] * t0 + hess[c, 0, 1] * t1_ + hess[c, 0, 2] * t2
                hd1 = hess[c, 1, 0] * t0 + hess[c, 1, 1] * t1_ + hess[c, 1, 2] * t2
                hd2 = hess[c, 2, 0] * t0 + hess[c, 2, 1] * t1_ + hess[c, 2, 2] * t2
            for j in range(N):
                ge = G[e, j]
                for b in range(4):
                    Jt[4 * j + b, o] = (n0 * D[j, 0, b] + n1 * D[j, 1, b] + n2 * D[j, 2, b]) * ge
                    if kinds[c] == 1:
                        val = (hd0 * D[j, 0, b] + hd1 * D[j, 1, b] + hd2 * D[j, 2, b]) * ge
                        if j == e:
                            val += n0 * D[j, 0, b] + n1 * D[j, 1, b] + n2 * D[j, 2, b]
                        Jt[4 * j + b, o + 1] = val
        # the columns of the contact arc lengths: moving nodes and integration weights
        shared = np.empty((N, 4))
        for i in range(N):
            dk0 = nu1 * dkinv[i] * mb[i, 0]
            dk1 = dkinv[i] * mb[i, 1]
            dk2 = dkinv[i] * mb[i, 2] + slope[i]
            for a in range(4):
                shared[i, a] = 0.5 * (Lv[i, a, 0] * dk0 + Lv[i, a, 1] * dk1 + Lv[i, a, 2] * dk2)
        dr = np.empty((N, 3))
        dM = np.empty((N, 3))
        dg2 = np.empty((N, 4))
        for c in range(k):
            if kinds[c] != 1:
                continue
            o = offs[c]
            # dr = dG D1, dG = T diag(dw_c)
            for i in range(N):
                a0 = 0.0
                a1 = 0.0
                a2 = 0.0
                for j in range(N):
                    t = T[i, j] * dw[c, j]
                    a0 += t * R[j, 0, 0]
                    a1 += t * R[j, 1, 0]
                    a2 += t * R[j, 2, 0]
                dr[i, 0], dr[i, 1], dr[i, 2] = a0, a1, a2
            for i in range(N):
                dM[i, 0], dM[i, 1], dM[i, 2] = 0.0, 0.0, 0.0
            for cp in range(k):
                e = ends[cp]
                x0, x1, x2 = dr[e, 0], dr[e, 1], dr[e, 2]
                f = fs[cp]
                dF0 = f * (hess[cp, 0, 0] * x0 + hess[cp, 0, 1] * x1 + hess[cp, 0, 2] * x2)
                dF1 = f * (hess[cp, 1, 0] * x0 + hess[cp, 1, 1] * x1 + hess[cp, 1, 2] * x2)
                dF2 = f * (hess[cp, 2, 0] * x0 + hess[cp, 2, 1] * x1 + hess[cp, 2, 2] * x2)
                for i in range(e + 1):
                    _cross3(x0 - dr[i, 0], x1 - dr[i, 1], x2 - dr[i, 2],
                            F[cp, 0], F[cp, 1], F[cp, 2], dM, i)
                    _cross3(r[e, 0] - r[i, 0], r[e, 1] - r[i, 1], r[e, 2] - r[i, 2],
                            dF0, dF1, dF2, dM, i)
            for i in range(N):
                for a in range(4):
                    dg2[i, a] = (PRt[i, a, 0] * dM[i, 0] + PRt[i, a, 1] * dM[i, 1]
                                 + PRt[i, a, 2] * dM[i, 2]) + shared[i, a] * ds[c, i]
            for i in range(N):
                for a in range(4):
                    acc = 0.0
                    for j in range(N):
                        acc += T[i, j] * dw[c, j] * g[j, a] + G[i, j] * dg2[j, a]
                    Jt[o, 4 * i + a] = -acc
            for cp in range(k):
                e = ends[cp]
                op = offs[cp]
                x0, x1, x2 = dr[e, 0], dr[e, 1], dr[e, 2]
                Jt[o, op] = normal[cp, 0] * x0 + normal[cp, 1] * x1 + normal[cp, 2] * x2
                if kinds[cp] == 1:
                    acc = 0.0
                    for ax in range(3):
                        acc += R[e, ax, 0] * (hess[cp, ax, 0] * x0 + hess[cp, ax, 1] * x1
                                              + hess[cp, ax, 2] * x2)
                    Jt[o, op + 1] = acc
    if sensitivity:
        for c in range(k):
            e = ends[c]
            o = offs[c]
            for ax in range(3):
                sens[o, ax] = normal[c, ax]
            if kinds[c] == 1:
                for ax in range(3):
                    sens[o + 1, ax] = (hess[c, ax, 0] * R[e, 0, 0] + hess[c, ax, 1] * R[e, 1, 0]
                                       + hess[c, ax, 2] * R[e, 2, 0])
        PM = np.empty((N, 4, 3))
        for i in range(N):
            for a in range(4):
                for col in range(3):
                    PM[i, a, col] = (PRt[i, a, 0] * dMdp[i, 0, col]
                                     + PRt[i, a, 1] * dMdp[i, 1, col]
                                     + PRt[i, a, 2] * dMdp[i, 2, col])
        for i in range(N):
            for a in range(4):
                for col in range(3):
                    acc = 0.0
                    for j in range(N):
                        acc += G[i, j] * PM[j, a, col]
                    sens[4 * i + a, col] = -acc
                sens[4 * i + a, 3 + a] = -1.0
    finite = jacobian
    if jacobian:
        for i in range(size):
            for j in range(size):
                if not math.isfinite(Jt[i, j]):
                    finite = False
    return res, Jt.T, sens, finite


#: the obstacles whose surface data the kernels compute themselves (obstacles.py's formulas, in
#: the same order), and their parameters (7 floats): a sphere (center, r), a cylinder (point,
#: unit axis, r), a plane (point, unit normal)
SPHERE, CYLINDER, PLANE = 0, 1, 2


@_kernel
def _unit_normal_to(ax, ay, az):
    """obstacles._unit_normal_to: a unit vector normal to the unit (ax, ay, az)."""
    if abs(az) < 0.9:
        nx, ny, nz = ay, -ax, 0.0
    else:
        nx, ny, nz = 0.0, az, -ay
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    return nx / norm, ny / norm, nz / norm


@_kernel
def surface(code, prm, x, y, z, normal, hess, c):
    """
    Return the signed distance at (x, y, z); write the outward normal and d's Hessian to row c.

    Sphere.surface, Cylinder.surface and Plane.surface of obstacles.py, operation for operation.
    """
    for a in range(3):
        for b in range(3):
            hess[c, a, b] = 0.0
    if code == PLANE:
        px, py, pz, nx, ny, nz = prm[0], prm[1], prm[2], prm[3], prm[4], prm[5]
        normal[c, 0], normal[c, 1], normal[c, 2] = nx, ny, nz
        return (x - px) * nx + (y - py) * ny + (z - pz) * nz
    if code == SPHERE:
        cx, cy, cz, r = prm[0], prm[1], prm[2], prm[3]
        dx, dy, dz = x - cx, y - cy, z - cz
        rho = math.sqrt(dx * dx + dy * dy + dz * dz)
        if rho > 0.0:
            nx, ny, nz = dx / rho, dy / rho, dz / rho
            f = 1.0 / rho
            hess[c, 0, 0], hess[c, 0, 1], hess[c, 0, 2] = (f * (1.0 - nx * nx), -f * nx * ny,
                                                           -f * nx * nz)
            hess[c, 1, 0], hess[c, 1, 1], hess[c, 1, 2] = (-f * nx * ny, f * (1.0 - ny * ny),
                                                           -f * ny * nz)
            hess[c, 2, 0], hess[c, 2, 1], hess[c, 2, 2] = (-f * nx * nz, -f * ny * nz,
                                                           f * (1.0 - nz * nz))
        else:
            nx, ny, nz = 0.0, 0.0, 1.0
        normal[c, 0], normal[c, 1], normal[c, 2] = nx, ny, nz
        return rho - r
    # CYLINDER
    px, py, pz, ax, ay, az, r = prm[0], prm[1], prm[2], prm[3], prm[4], prm[5], prm[6]
    wx, wy, wz = x - px, y - py, z - pz
    t = wx * ax + wy * ay + wz * az
    rx, ry, rz = wx - t * ax, wy - t * ay, wz - t * az
    rho = math.sqrt(rx * rx + ry * ry + rz * rz)
    if rho > 0.0:
        nx, ny, nz = rx / rho, ry / rho, rz / rho
        f = 1.0 / rho
        xy, xz, yz = ax * ay + nx * ny, ax * az + nx * nz, ay * az + ny * nz
        # (P - n n^T) / rho, P = I - a a^T
        hess[c, 0, 0] = f * (1.0 - ax * ax - nx * nx)
        hess[c, 1, 1] = f * (1.0 - ay * ay - ny * ny)
        hess[c, 2, 2] = f * (1.0 - az * az - nz * nz)
        hess[c, 0, 1] = hess[c, 1, 0] = -f * xy
        hess[c, 0, 2] = hess[c, 2, 0] = -f * xz
        hess[c, 1, 2] = hess[c, 2, 1] = -f * yz
    else:
        nx, ny, nz = _unit_normal_to(ax, ay, az)
    normal[c, 0], normal[c, 1], normal[c, 2] = nx, ny, nz
    return rho - r


@_kernel
def distance(code, prm, x, y, z):
    """Return the signed distance of the obstacle ``code`` at (x, y, z) (:func:`surface`'s)."""
    if code == PLANE:
        return (x - prm[0]) * prm[3] + (y - prm[1]) * prm[4] + (z - prm[2]) * prm[5]
    if code == SPHERE:
        dx, dy, dz = x - prm[0], y - prm[1], z - prm[2]
        return math.sqrt(dx * dx + dy * dy + dz * dz) - prm[3]
    ax, ay, az = prm[3], prm[4], prm[5]
    wx, wy, wz = x - prm[0], y - prm[1], z - prm[2]
    t = wx * ax + wy * ay + wz * az
    rx, ry, rz = wx - t * ax, wy - t * ay, wz - t * az
    return math.sqrt(rx * rx + ry * ry + rz * rz) - prm[6]


@_kernel
def least_distance(codes, prm, points):
    """Return the least signed distance of each point (m, 3) to the obstacles (by distance)."""
    m = points.shape[0]
    out = np.empty(m)
    for i in range(m):
        d = math.inf
        for c in range(codes.size):
            dc = distance(codes[c], prm[c], points[i, 0], points[i, 1], points[i, 2])
            if dc < d:
                d = dc
        out[i] = d
    return out


@_kernel
def accepted(vec, n, kinds, tau, sp, T, p, codes, prm, touched, samples, A, grid, table,
             other_codes, other_prm):
    """
    Return what the tracker checks and reports of a solution, from one placement of its nodes.

    For analytic obstacles (``codes``, ``prm`` of the contacts, as :func:`evaluate`) and a
    straight (A = 0) or parabolic unloaded whisker. ``touched`` (m,): for each obstacle touched,
    in the order the tracker checks them, the index of a contact on it; ``samples``: the tail
    check's fractions of the unloaded part. Returns (r at the contacts (k, 3), the obstacles'
    outward normals there (k, 3), the tip (3,), the body frame at the tip (3, 3), the least
    distance of the tail samples to the last contact's obstacle (inf without a side contact
    short of the tip), the least distance of the nodes to each obstacle touched (m,) and the
    node where (m,)), :func:`contact_loads` and :func:`clear_of`'s bound of the whole whisker's
    distance to the obstacles ``other_codes``, ``other_prm`` (those it does not touch; inf
    without any): RodSolver.equilibrium's points, normals, tip, frame and loads,
    RodTracker._check_tail's and _touched_depth's distances, and what spares _contact_gap.
    """
    k = kinds.size
    N = n * k
    # (nodes' placement, with the nodes' arc lengths kept for clear_of)
    b, s_nodes, w, Ls = _weights(vec, n, kinds, tau, sp)
    r = _positions(vec, T, w, p, N)
    points = np.empty((k, 3))
    normals = np.empty((k, 3))
    hess = np.empty((k, 3, 3))
    for c in range(k):
        e = (c + 1) * n - 1
        points[c, 0], points[c, 1], points[c, 2] = r[e, 0], r[e, 1], r[e, 2]
        surface(codes[c], prm[c], r[e, 0], r[e, 1], r[e, 2], normals, hess, c)
    e = N - 1
    last = np.empty((3, 3))
    _rotation(vec[4 * e:4 * e + 4], last)
    q2 = 0.0
    for i in range(4):
        q2 += vec[4 * e + i] * vec[4 * e + i]
    frame = last / q2
    end = b[k - 1]
    tip = np.empty(3)
    tip[:] = r[e]
    tail_depth = math.inf
    # the unloaded tail's samples beyond a last side contact short of the tip (arc lengths,
    # points): the tail check's, and clear_of's
    tail_s = np.zeros(0)
    tail = np.zeros((0, 3))
    if end < 1.0:
        if A != 0.0:
            dx, dy, phi = parabola_tip(end, A, grid, table)
        else:
            dx, dy, phi = 1.0 - end, 0.0, 0.0
        for i in range(3):
            tip[i] = tip[i] + dx * frame[i, 0] + dy * frame[i, 1]
        c_, s_ = math.cos(phi), math.sin(phi)
        turned = np.empty((3, 3))
        for i in range(3):
            turned[i, 0] = c_ * frame[i, 0] + s_ * frame[i, 1]
            turned[i, 1] = -s_ * frame[i, 0] + c_ * frame[i, 1]
            turned[i, 2] = frame[i, 2]
        frame = turned
        if kinds[k - 1] == 1:
            tail_s = end + (1.0 - end) * samples
            if A != 0.0:
                off = parabola_tail(end, tail_s, A, grid, table)
            else:
                off = np.zeros((tail_s.size, 2))
                for j in range(tail_s.size):
                    off[j, 0] = tail_s[j] - end
            tail = np.empty((tail_s.size, 3))
            for j in range(tail_s.size):
                for i in range(3):
                    tail[j, i] = r[e, i] + off[j, 0] * last[i, 0] + off[j, 1] * last[i, 1]
                d = distance(codes[k - 1], prm[k - 1], tail[j, 0], tail[j, 1], tail[j, 2])
                if d < tail_depth:
                    tail_depth = d
    m = touched.size
    depth = np.empty(m)
    where = np.empty(m, dtype=np.int64)
    for j in range(m):
        c = touched[j]
        depth[j] = math.inf
        where[j] = 0
        for i in range(N):
            d = distance(codes[c], prm[c], r[i, 0], r[i, 1], r[i, 2])
            if d < depth[j]:
                depth[j] = d
                where[j] = i
    s_c, f_c, forces, force, moment = contact_loads(vec, n, kinds, points, normals, p)
    clear = math.inf
    if other_codes.size:
        clear = clear_of(s_nodes, r, tail_s, tail, other_codes, other_prm)
    return (points, normals, tip, frame, tail_depth, depth, where, s_c, f_c, forces, force,
            moment, clear)


#: the bound of :func:`clear_of` takes the centerline's speed |dr/ds| as at most this. It is
#: |q|^2 = 1 + O(1e-12) at the nodes, and between them the interpolant of a resolved solution
#: is as close to it (the point count is chosen so: its Chebyshev tail below 1e-11; the soaks'
#: solutions measured at most 1 - 2e-13); for arbitrary node values only the interpolation's
#: Lebesgue constant (~2.3-3 for 16-48 points) would bound it, so this is an assumption on
#: resolved solutions, with a margin of 1.5
_SPEED = 1.5


@_kernel
def fold_measure(tan):
    """
    Return g = 1 / norm(tan)^2 (at least 1 / 1e-300), summed in index order.

    RodTracker._fold_limit's measure of a tangent, here for both it and :func:`trusted_step`
    (one loop, the same bits in either: numpy's ``@`` and numba's ``np.dot`` call BLAS builds
    that may sum in other orders).
    """
    total = 0.0
    for i in range(tan.size):
        total += tan[i] * tan[i]
    return 1.0 / max(total, 1e-300)


@_kernel
def clear_of(s, r, tail_s, tail, codes, prm):
    """
    Return a lower bound of the whole centerline's signed distance to the obstacles given.

    The signed distance to a sphere, cylinder or plane changes by at most the distance moved
    (it is 1-Lipschitz), and the centerline moves by at most _SPEED ds, so between two of its
    points at arc lengths s_a <= s_b the distance is at least (d_a + d_b - _SPEED (s_b - s_a)) / 2
    (the larger of d_a - _SPEED u and d_b - _SPEED (s_b - s_a - u) at any u). The points: the
    nodes (``r`` (N, 3) at their arc lengths ``s``, the segments' ends among them) and, beyond a
    last side contact short of the tip, the unloaded tail's samples (``tail`` (m, 3) at
    ``tail_s``, the centerline's own, RodSolver.centerline, as :func:`accepted` places them;
    m = 0 without). A bound above 0 means no point of the whisker is on or inside one of them:
    what RodTracker._contact_gap would find only by sampling the centerline and minimizing.
    """
    N = s.size
    m = tail_s.size
    arc = np.empty(N + m)
    pts = np.empty((N + m, 3))
    for i in range(N):
        arc[i] = s[i]
        pts[i, 0], pts[i, 1], pts[i, 2] = r[i, 0], r[i, 1], r[i, 2]
    for j in range(m):
        arc[N + j] = tail_s[j]
        pts[N + j, 0], pts[N + j, 1], pts[N + j, 2] = tail[j, 0], tail[j, 1], tail[j, 2]
    least = math.inf
    for o in range(codes.size):
        before = distance(codes[o], prm[o], pts[0, 0], pts[0, 1], pts[0, 2])
        if before < least:
            least = before
        for i in range(1, N + m):
            d = distance(codes[o], prm[o], pts[i, 0], pts[i, 1], pts[i, 2])
            # (arc lengths ascend; a segment's end and the next one's start coincide)
            bound = 0.5 * (before + d - _SPEED * abs(arc[i] - arc[i - 1]))
            if bound < least:
                least = bound
            before = d
    return least


@_kernel
def tip_gap(s, vec, n, breaks, w, r, sp, cheb, code, prm):
    """
    Return the least d(s) / (1 - s) of a solution's centerline over arc lengths ``s`` (< 1).

    d is the signed distance to one obstacle (``code``, ``prm``) of the centerline at ``s``
    (inside the segments), as :func:`sample` gives it, but from each segment's Chebyshev
    coefficients of the integrated tangent, computed once (~(n + 1) operations a point instead
    of ~n^2; the same points to rounding): RodTracker._gap_behind_tip's sampled value behind a
    tip contact, before it refines anything. inf without samples; -inf where a value is not a
    number (the caller then takes its own path).
    """
    k = breaks.size
    # coef[c, d] = sum_j cheb[d, j] w_i d1_i (i = c n + j): the integral's coefficients
    coef = np.zeros((k, n + 1, 3))
    for c in range(k):
        for j in range(n):
            i = c * n + j
            qw, qx, qy, qz = vec[4 * i], vec[4 * i + 1], vec[4 * i + 2], vec[4 * i + 3]
            t0 = w[i] * (qw * qw + qx * qx - qy * qy - qz * qz)
            t1 = w[i] * 2.0 * (qx * qy + qw * qz)
            t2 = w[i] * 2.0 * (qx * qz - qw * qy)
            for d in range(n + 1):
                cd = cheb[d, j]
                coef[c, d, 0] += cd * t0
                coef[c, d, 1] += cd * t1
                coef[c, d, 2] += cd * t2
    least = math.inf
    for p in range(s.size):
        x = s[p]
        c, z = _segment_of(x, breaks, sp)
        before, now = 1.0, z
        a0 = coef[c, 0, 0] + z * coef[c, 1, 0]
        a1 = coef[c, 0, 1] + z * coef[c, 1, 1]
        a2 = coef[c, 0, 2] + z * coef[c, 1, 2]
        for d in range(2, n + 1):
            before, now = now, now * (2.0 * z) - before
            a0 += now * coef[c, d, 0]
            a1 += now * coef[c, d, 1]
            a2 += now * coef[c, d, 2]
        first = c * n
        g = distance(code, prm, r[first, 0] + 0.5 * a0, r[first, 1] + 0.5 * a1,
                     r[first, 2] + 0.5 * a2) / (1.0 - x)
        if not g == g:
            return -math.inf
        if g < least:
            least = g
    return least


@_kernel
def contact_loads(vec, n, kinds, points, normals, p):
    """
    Return the contacts' (s (k,), f (k,), forces (k, 3)) and their total force and moment.

    RodSolver.breaks_of and forces_of (s = 1 at a tip contact), the forces f n on the whisker
    at the contact ``points`` with the outward ``normals``, their sum (from +0.0, row by row, as
    numpy's sum over the first axis: -0.0 components sum to +0.0) and their moment about the
    base point ``p`` (from the first contact's, as RodSolver.equilibrium's loop in floats): the
    same operations in the same order.
    """
    k = kinds.size
    s_c = np.empty(k)
    f_c = np.empty(k)
    forces = np.empty((k, 3))
    force = np.zeros(3)
    moment = np.zeros(3)
    o = 4 * n * k
    for c in range(k):
        size = 2 if kinds[c] == 1 else 1
        s_c[c] = vec[o] if kinds[c] == 1 else 1.0
        f = vec[o + size - 1]
        f_c[c] = f
        o += size
        for i in range(3):
            forces[c, i] = normals[c, i] * f
        ax, ay, az = points[c, 0] - p[0], points[c, 1] - p[1], points[c, 2] - p[2]
        fx, fy, fz = forces[c, 0], forces[c, 1], forces[c, 2]
        mx, my, mz = ay * fz - az * fy, az * fx - ax * fz, ax * fy - ay * fx
        force[0], force[1], force[2] = force[0] + fx, force[1] + fy, force[2] + fz
        if c == 0:
            moment[0], moment[1], moment[2] = mx, my, mz
        else:
            moment[0], moment[1], moment[2] = moment[0] + mx, moment[1] + my, moment[2] + mz
    return s_c, f_c, forces, force, moment


@_kernel
def evaluate(vec, qb, n, kinds, tau, sp, T, p, shape, grid, table, nu1, codes, prm, jacobian,
             sensitivity):
    """
    Return :func:`equations` at ``vec``, with the nodes placed and the surface data computed here.

    :func:`prepare`, the obstacles' :func:`surface` at the contact points (obstacle ``codes``
    (k,) and parameters ``prm`` (k, 7) of the contacts, analytic obstacles only), then
    :func:`equations`: one call per evaluation.
    """
    s, w, ds, dw, kinv, kap0, slope, dkinv, r = prepare(vec, n, kinds, tau, sp, T, p, shape,
                                                        grid, table)
    k = kinds.size
    dist = np.empty(k)
    normal = np.empty((k, 3))
    hess = np.empty((k, 3, 3))
    for c in range(k):
        e = (c + 1) * n - 1
        dist[c] = surface(codes[c], prm[c], r[e, 0], r[e, 1], r[e, 2], normal, hess, c)
    return equations(vec, qb, n, kinds, T, w, ds, dw, kinv, kap0, slope, dkinv, r, nu1, dist,
                     normal, hess, jacobian, sensitivity)


@_kernel
def coefficient_tail(Vinv, vec, n, k, lowest):
    """
    Return, for each degree j >= ``lowest``, the largest Chebyshev coefficient of degree j or more.

    Over the k segments and the four components of the quaternions (the first 4 n k values of
    ``vec``, segment by segment, node by node); ``Vinv`` (n, n) maps nodal values to
    coefficients (model.RodSolver.points_needed's ``above``: coefficient_magnitudes' to
    rounding, summed here in order where numpy's matmul sums by blocks).
    """
    m = n - lowest
    out = np.zeros(m)
    for c in range(k):
        base = 4 * n * c
        for j in range(m):
            row = lowest + j
            for a in range(4):
                acc = 0.0
                for i in range(n):
                    acc += Vinv[row, i] * vec[base + 4 * i + a]
                acc = abs(acc)
                if acc > out[j]:
                    out[j] = acc
    for j in range(m - 2, -1, -1):
        if out[j + 1] > out[j]:
            out[j] = out[j + 1]
    return out


@_kernel
def det_measure(lu, piv):
    """
    Return sign(det J) times the geometric mean of abs(U_ii), from getrf's (lu, piv).

    Continuous in J and zero where J is singular (tracker._det_measure, the stability monitor).
    """
    n = piv.size
    odd = 0
    total = 0.0
    for i in range(n):
        if piv[i] != i:
            odd += 1
        d = lu[i, i]
        if d < 0.0:
            odd += 1
        total += math.log(abs(d)) if d != 0.0 else -math.inf
    sign = -1.0 if odd % 2 else 1.0
    return sign * math.exp(total / n)


@_kernel
def _lu_solve(lu, piv1, b, trans):
    """Solve with getrf's factorization, in place of ``b`` (piv1: LAPACK's, 1-based; 78 'N')."""
    n = np.empty(1, np.int32)
    n[0] = lu.shape[0]
    one = np.ones(1, np.int32)
    info = np.zeros(1, np.int32)
    code = np.empty(1, np.uint8)
    code[0] = trans
    _getrs(code.ctypes, n.ctypes, one.ctypes, lu.ctypes, n.ctypes, piv1.ctypes, b.ctypes,
           n.ctypes, info.ctypes)


@_kernel
def _largest(step):
    """Return max |step|, or inf if an entry is not finite (RodSolver._take's size)."""
    size = 0.0
    for i in range(step.size):
        a = abs(step[i])
        if not math.isfinite(a):
            return math.inf
        if a > size:
            size = a
    return size


@_kernel
def _breaks_hold(vec, n, kinds, limit):
    """Tell whether 0 < s_1 < ... <= 1 (the last up to ``limit``) (RodSolver._check_breaks)."""
    b = _breaks(vec, n, kinds)
    prev = 0.0
    k = b.size
    for i in range(k):
        top = limit if i == k - 1 else 1.0
        v = b[i]
        if not (prev < v <= top) or not math.isfinite(v):
            return False
        prev = v
    return True


@_kernel
def _checks_hold(tail_depth, depth, tail_cut):
    """
    Tell whether the tracker's checks on a solution pass, from :func:`accepted`'s distances.

    RodTracker._check_tail and _check_between: the unloaded tail's and the loaded part's least
    distances to the obstacles they touch, ``tail_depth`` and ``depth``, not below ``tail_cut``.
    """
    if tail_depth < tail_cut:
        return False
    for j in range(depth.size):
        if depth[j] < tail_cut:
            return False
    return True


@_kernel
def _solution_measures(vec, vec0, tan, forces, last_break, lu, piv):
    """
    Return what the tracker decides a plain step's solution by, from :func:`trusted_step`.

    (error, change, least, det): max |vec - (vec0 + tan)| and max |(vec0 + tan) - vec0| (as
    tracker._off_branch computes them: the same rounding), the least of the forces
    vec[forces] and of 1 - vec[last_break] (where last_break >= 0: the arc length of the last
    contact, where it is a side contact), and :func:`det_measure` (lu, piv).
    """
    error = 0.0
    change = 0.0
    for i in range(vec.size):
        line = vec0[i] + tan[i]
        a = abs(vec[i] - line)
        if a > error:
            error = a
        b = abs(line - vec0[i])
        if b > change:
            change = b
    least = math.inf
    for j in range(forces.size):
        if vec[forces[j]] < least:
            least = vec[forces[j]]
    if last_break >= 0 and 1.0 - vec[last_break] < least:
        least = 1.0 - vec[last_break]
    return error, change, least, det_measure(lu, piv)


@_kernel
def _trusted_solution(status, vec, tan, J, piv, sens, evaluations, factorizations, vec0, forces,
                      last_break, n, kinds, tau, sp, T, p, codes, prm, touched, samples, A,
                      grid, table, tail_cut, Vinv, lowest, other_codes, other_prm):
    """
    Return :func:`trusted_step`'s answer for the solution ``vec`` (``status`` 0 or 3).

    Its pivots 0-based (``piv``: LAPACK's), :func:`accepted`'s data (the bound of its distance
    to the obstacles ``other_codes``, ``other_prm`` among them), :func:`_checks_hold`,
    :func:`_solution_measures` and the :func:`coefficient_tail` from degree ``lowest``.
    """
    size = vec.size
    piv0 = np.empty(size, np.int32)
    for i in range(size):
        piv0[i] = piv[i] - 1
    (points, normals, tip, frame, tail_depth, depth, where, s_c, f_c, loads, total,
     moment, clear) = accepted(vec, n, kinds, tau, sp, T, p, codes, prm, touched, samples, A,
                               grid, table, other_codes, other_prm)
    clean = _checks_hold(tail_depth, depth, tail_cut)
    error, change, least, det = _solution_measures(vec, vec0, tan, forces, last_break, J, piv0)
    above = coefficient_tail(Vinv, vec, n, kinds.size, lowest) if n > lowest else np.zeros(0)
    return (status, tan, vec, J, piv0, sens, evaluations, factorizations, points, normals, tip,
            frame, tail_depth, depth, where, clean, error, change, least, det, s_c, f_c, loads,
            total, moment, above, clear)


@_kernel
def _unsolved(status, tan, evaluations, factorizations):
    """Return :func:`trusted_step`'s answer where nothing was solved (status 1 or 2)."""
    e1 = np.zeros(0)
    m0 = np.zeros((0, 3))
    return (status, tan, e1, np.zeros((0, 0)).T, np.zeros(0, np.int32), m0, evaluations,
            factorizations, m0, m0, e1, np.zeros((3, 3)), math.inf, e1, np.zeros(0, np.int64),
            False, 0.0, 0.0, 0.0, 0.0, e1, e1, m0, e1, e1, e1, -math.inf)


@_kernel
def trusted_step(lu0, piv0, rhs, forces, vec0, max_change, guess, qb, p, n, kinds, tau,
                 sp, T, shape, grid, table, nu1, codes, prm, limit, touched, samples, A, tol,
                 trusted_step_size, trusted_chord, chord_tol, max_step, max_iterations, stall,
                 noise, rounding, tail_cut, last_break, Vinv, lowest, other_codes,
                 other_prm, whole_iterations, most, adapt, refine, fold_t, fold_g):
    """
    Take a plain continuation step in one call: RodTracker._contact_advance's common case.

    From the solution ``vec0`` (its factorization ``lu0``, ``piv0`` as scipy's getrf gives them)
    along a path whose pose rate r gives ``rhs`` = sens r (the solution's pose sensitivities
    times r, numpy's product, as RodSolver.tangent computes it), to the pose (``p``, ``qb``)
    the path ends at, from ``guess`` (the pose stream's extrapolation): the tangent
    -J^-1 sens r and its bound's measure (RodTracker._largest_change, the force unknowns at
    the indices ``forces`` relative to 1 + |f|); where the bound does not shorten the step,
    RodSolver.solve with ``trusted`` and ``fail_fast`` (Newton, chord steps on a Jacobian
    within 1e-4, as RodSolver._polish) and, on the solution, :func:`accepted`. The other
    arguments are those of :func:`evaluate` and :func:`accepted`, the contact arc lengths'
    bound ``limit``, and the solver's tolerances and bounds. Where the bound does shorten it,
    with ``whole_iterations`` 1, the step is taken whole as RodTracker._whole_step takes it
    (the same solve, at most one Newton step), unless (``adapt``, ``n`` below the solver's
    ``most``) the tangent's end has a Chebyshev tail above ``refine`` at n or n is below the
    ladder: RodTracker._contact_advance then goes to the full count first. Nor is it taken where
    the tangent announces a fold within the step from the one recorded before it (``fold_t``
    < 0 on this step's parameter, its ``fold_g`` = 1 / norm(tangent)^2; inf: none), as
    RodTracker._fold_limit announces it: the general path locates that fold first.

    Returns (status, tangent, vec, lu, piv, sens, evaluations, factorizations, points, normals,
    tip, frame, tail_depth, depth, where, checked, branch_error, branch_change, least, det, s,
    f, forces, force, moment, above, clear): status 0 solved, 3 solved whole (a step the bound
    would shorten); 1 the bound shortens the step and it is not taken whole here, or the
    tangent is not finite (nothing solved: the general path takes the step); 2 the solve failed
    where RodSolver.solve raises ConvergenceError (the same solve from the same guess: the
    general path goes on as after its own failed trial step). piv is 0-based as scipy's, the
    counts those spent, and checked :func:`_checks_hold` of the solution (the checks' bound
    ``tail_cut``). Of a solution also: how far it lies from the tangent's prediction vec0 + tan
    and how far that is from vec0 (max norms, as tracker._off_branch measures them), the
    least of its forces and of 1 - s at ``last_break`` (the arc length of the last contact
    where it is a side contact, or -1), :func:`det_measure` of its factorization, its
    :func:`contact_loads`, its :func:`coefficient_tail` from degree ``lowest`` (``Vinv``
    (n, n); empty where n <= lowest) and :func:`clear_of`'s bound of its distance to the
    obstacles ``other_codes``, ``other_prm`` (-inf where nothing was solved). Status 1 also
    where a fold is announced within the step.
    """
    size0 = vec0.size
    piv1 = np.empty(size0, np.int32)
    for i in range(size0):
        piv1[i] = piv0[i] + 1
    # the tangent, -J^-1 (sens rate) (``rhs`` = sens rate, numpy's product as the tangent's)
    tan = rhs.copy()
    _lu_solve(lu0, piv1, tan, 78)
    finite = True
    for i in range(size0):
        tan[i] = -tan[i]
        if not math.isfinite(tan[i]):
            finite = False
    # RodTracker._largest_change: |tan|, each force's entry relative to 1 + |f|; its max
    weighted = np.abs(tan)
    for j in range(forces.size):
        o = forces[j]
        weighted[o] = abs(tan[o] * (1.0 / (1.0 + abs(vec0[o]))))
    big = 0.0
    for i in range(size0):
        if weighted[i] > big:
            big = weighted[i]
    status = 0
    if not finite:
        return _unsolved(1, tan, 0, 0)
    # RodTracker._fold_limit at the step's start: g = 1 / norm(tan)^2 against the tangent
    # recorded before the step (on this step's parameter); a fold announced within the
    # sub-step (the bound's, or the whole step) is the general path's
    g = fold_measure(tan)
    if fold_g < math.inf and g < 0.5 * fold_g:
        reach = max_change / big if big > 0.0 and max_change / big < 1.0 else 1.0
        if g * (0.0 - fold_t) / (fold_g - g) < reach:
            return _unsolved(1, tan, 0, 0)
    if big > 0.0 and max_change / big < 1.0:
        # the bound shortens the step: RodTracker._contact_advance then takes it whole from
        # the stream's prediction where the first Newton step converges it (whole_iterations
        # 1: _whole_step's solve), unless it goes to the full point count first (adapt: the
        # tangent's end asks for more points than the solution's n, below the solver's most)
        refused = whole_iterations <= 0
        if not refused and adapt and n < most:
            if n < lowest + 2:
                refused = True
            else:
                ahead = vec0 + tan
                tail = coefficient_tail(Vinv, ahead, n, kinds.size, lowest)
                refused = tail[n - 2 - lowest] > refine
        if refused:
            return _unsolved(1, tan, 0, 0)
        status = 3
        max_iterations = whole_iterations
    # RodSolver.solve with ``trusted`` and ``fail_fast``: Newton from the guess; where a step
    # is short enough, chord steps on its Jacobian (RodSolver._polish)
    evaluations = 0
    factorizations = 0
    # (run-time booleans: literal ones would compile evaluate once more for their types)
    yes = kinds.size > 0
    no = not yes
    vec = guess.copy()
    last = math.inf
    shortest = math.inf
    since = 0
    newton = 0
    for it in range(max_iterations):
        evaluations += 1
        res, J, sens, finite = evaluate(vec, qb, n, kinds, tau, sp, T, p, shape, grid, table,
                                        nu1, codes, prm, yes, yes)
        factorizations += 1
        if not finite:
            break
        size = res.size
        piv = np.empty(size, np.int32)
        nn = np.empty(1, np.int32)
        nn[0] = size
        info = np.zeros(1, np.int32)
        _getrf(nn.ctypes, nn.ctypes, J.ctypes, nn.ctypes, piv.ctypes, info.ctypes)
        if info[0] != 0:
            break
        rmax = 0.0
        for i in range(size):
            if abs(res[i]) > rmax:
                rmax = abs(res[i])
        _lu_solve(J, piv, res, 78)
        step_size = _largest(res)
        if not step_size <= max_step:
            break
        at = vec
        vec = vec - res
        if not _breaks_hold(vec, n, kinds, limit):
            break
        settled = (step_size <= tol or (last <= trusted_chord
                                        and step_size * step_size * step_size / (last * last)
                                        <= tol)
                   or (last < math.inf and step_size <= noise and step_size > 0.25 * last)
                   or (it == 0 and step_size <= trusted_step_size))
        failed = False
        if not settled and step_size <= trusted_chord and not step_size > 0.1 * last:
            chord_last = math.inf
            for _ in range(3):
                evaluations += 1
                res2, _, _, _ = evaluate(vec, qb, n, kinds, tau, sp, T, p, shape, grid, table,
                                         nu1, codes, prm, no, no)
                _lu_solve(J, piv, res2, 78)
                s2 = _largest(res2)
                if not s2 <= max_step:
                    failed = True
                    break
                if s2 > 0.1 * chord_last:
                    break
                vec = vec - res2
                if not _breaks_hold(vec, n, kinds, limit):
                    failed = True
                    break
                if s2 <= chord_tol * 1e-2:
                    settled = True
                    break
                chord_last = s2
        if failed:
            break
        if settled:
            return _trusted_solution(status, vec, tan, J, piv, sens, evaluations,
                                     factorizations, vec0,
                                     forces, last_break, n, kinds, tau, sp, T, p, codes, prm,
                                     touched, samples, A, grid, table, tail_cut, Vinv, lowest,
                                     other_codes, other_prm)
        newton += 1
        if newton >= 3 and step_size > 0.9 * last:
            break  # fail_fast: Newton is not contracting
        if step_size < 0.9 * shortest:
            shortest = step_size
            since = 0
        else:
            since += 1
            if since >= stall and newton >= 2 * stall and step_size > noise:
                if rmax <= rounding:
                    # the equations hold to rounding where the steps level off
                    return _trusted_solution(status, at, tan, J, piv, sens, evaluations,
                                             factorizations, vec0, forces, last_break, n,
                                             kinds, tau, sp, T, p, codes, prm, touched,
                                             samples, A, grid, table, tail_cut, Vinv, lowest,
                                             other_codes, other_prm)
                break
        last = step_size
    return _unsolved(2, tan, evaluations, factorizations)


@_kernel
def parabola_tail(end, s, A, grid, table):
    """
    Return the unloaded offsets (m, 2) from ``end`` to the arc lengths ``s`` on the parabola.

    In the (d1, d2) components of the frame at ``end``: RodShape.intrinsic_offset of a
    parabolic whisker (its chord helper, with u from :func:`_parabola_u`).
    """
    ua = _parabola_u(np.array([end]), A, grid, table)[0]
    ub = _parabola_u(s, A, grid, table)
    root = math.sqrt(1.0 + ua * ua)
    c, sn = 1.0 / root, ua / root
    out = np.empty((s.size, 2))
    for i in range(s.size):
        dx = (ub[i] - ua) / (2.0 * A)
        dy = (ub[i] * ub[i] - ua * ua) / (4.0 * A)
        out[i, 0] = c * dx + sn * dy
        out[i, 1] = -sn * dx + c * dy
    return out


@_kernel
def parabola_tip(end, A, grid, table):
    """
    Return (dx, dy, phi): the tip's offset from ``end`` and the turn of the unloaded parabola.

    RodShape.tail of a parabolic whisker: the offset in the (d1, d2) components of the frame at
    ``end`` (as :func:`parabola_tail` at s = 1) and the slope it turns through to the tip.
    """
    ua = _parabola_u(np.array([end]), A, grid, table)[0]
    ub = _parabola_u(np.array([1.0]), A, grid, table)[0]
    root = math.sqrt(1.0 + ua * ua)
    c, sn = 1.0 / root, ua / root
    dx = (ub - ua) / (2.0 * A)
    dy = (ub * ub - ua * ua) / (4.0 * A)
    return c * dx + sn * dy, -sn * dx + c * dy, math.atan(ub) - math.atan(ua)


@_kernel
def _segment_of(x, breaks, sp):
    """Return the segment of arc length x and its coordinate z in [-1, 1] (_Layout.locate)."""
    k = breaks.size
    c = 0
    while c < k and breaks[c] < x:
        c += 1
    if c > k - 1:
        c = k - 1
    a = 0.0 if c == 0 else breaks[c - 1]
    b = breaks[c]
    if sp <= 0.0:
        tau = (x - a) / (b - a)
    else:
        tau = math.log((sp - x) / (sp - a)) / math.log((sp - b) / (sp - a))
    return c, min(max(2.0 * tau - 1.0, -1.0), 1.0)


@_kernel
def sample(s, vec, n, breaks, w, r, sp, cheb):
    """
    Return the centerline (m, 3) at arc lengths ``s`` inside the segments (s <= the last break).

    Each point is located in its segment (local coordinate x in [-1, 1], the node map inverted
    as model._Layout.locate) and the segment's tangents are integrated from its first node by
    the Chebyshev integration matrix ``cheb`` ((n + 1) x n, nodal values -> integral from -1).
    """
    m = s.size
    out = np.empty((m, 3))
    T = np.empty(n + 1)
    for p in range(m):
        x = s[p]
        c, z = _segment_of(x, breaks, sp)
        T[0] = 1.0
        T[1] = z
        for d in range(2, n + 1):
            T[d] = T[d - 1] * (2.0 * z) - T[d - 2]
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        for j in range(n):
            wj = 0.0
            for d in range(n + 1):
                wj += T[d] * cheb[d, j]
            i = c * n + j
            qw, qx, qy, qz = vec[4 * i], vec[4 * i + 1], vec[4 * i + 2], vec[4 * i + 3]
            wj *= w[i]
            a0 += wj * (qw * qw + qx * qx - qy * qy - qz * qz)
            a1 += wj * 2.0 * (qx * qy + qw * qz)
            a2 += wj * 2.0 * (qx * qz - qw * qy)
        first = c * n
        out[p, 0] = r[first, 0] + 0.5 * a0
        out[p, 1] = r[first, 1] + 0.5 * a1
        out[p, 2] = r[first, 2] + 0.5 * a2
    return out


@_kernel
def free_frame(s, A, grid, table):
    """
    Return (x, y, phi, kappa0) of the unloaded whisker at arc length s, in its base frame.

    RodShape.free_frame of a parabolic whisker y = A x^2 (its u by :func:`_parabola_u`), or of
    a straight one (A = 0).
    """
    if A == 0.0:
        return s, 0.0, 0.0, 0.0
    u = _parabola_u(np.full(1, s), A, grid, table)[0]
    return u / (2.0 * A), u * u / (4.0 * A), math.atan(u), 2.0 * A / (1.0 + u * u) ** 1.5


@_kernel
def _free_distance(code, prm, R, p, A, grid, table, s):
    """Return the signed distance of the unloaded whisker's point at s, placed at (R, p)."""
    x, y, _, _ = free_frame(s, A, grid, table)
    return distance(code, prm, p[0] + x * R[0, 0] + y * R[0, 1],
                    p[1] + x * R[1, 0] + y * R[1, 1], p[2] + x * R[2, 0] + y * R[2, 1])


@_kernel
def free_minimum(code, prm, R, p, A, grid, table, s, lo, hi, iterations, xtol):
    """
    Return (found, s*, d(s*), d(lo), d(hi)): the unloaded whisker's least distance near s.

    The whisker placed at (R, p) (its base frame's axes, columns, and base point); Newton on
    d'(s) = n . t from s, d''(s) = t . H t + n . t' (the obstacle's normal n and distance
    Hessian H at the point, t the tangent, t' = kappa0 times the normal), kept in [lo, hi], as
    the tracker's _newton_minimum does: a step out of the bracket stops at its end, taken
    where d still falls toward it there; not found where d'' <= 0 or Newton has not settled to
    ``xtol`` in ``iterations``.
    """
    normal = np.empty((1, 3))
    hess = np.empty((1, 3, 3))
    found = False
    bound = math.nan
    for _ in range(iterations):
        x, y, phi, kappa = free_frame(s, A, grid, table)
        c, sn = math.cos(phi), math.sin(phi)
        t0 = c * R[0, 0] + sn * R[0, 1]
        t1 = c * R[1, 0] + sn * R[1, 1]
        t2 = c * R[2, 0] + sn * R[2, 1]
        dt0 = kappa * (c * R[0, 1] - sn * R[0, 0])
        dt1 = kappa * (c * R[1, 1] - sn * R[1, 0])
        dt2 = kappa * (c * R[2, 1] - sn * R[2, 0])
        surface(code, prm, p[0] + x * R[0, 0] + y * R[0, 1], p[1] + x * R[1, 0] + y * R[1, 1],
                p[2] + x * R[2, 0] + y * R[2, 1], normal, hess, 0)
        n0, n1, n2 = normal[0, 0], normal[0, 1], normal[0, 2]
        d1 = n0 * t0 + n1 * t1 + n2 * t2
        if bound == bound and (d1 <= 0.0 if bound == hi else d1 >= 0.0):
            s, found = bound, True
            break
        h0 = hess[0, 0, 0] * t0 + hess[0, 0, 1] * t1 + hess[0, 0, 2] * t2
        h1 = hess[0, 1, 0] * t0 + hess[0, 1, 1] * t1 + hess[0, 1, 2] * t2
        h2 = hess[0, 2, 0] * t0 + hess[0, 2, 1] * t1 + hess[0, 2, 2] * t2
        d2 = (t0 * h0 + t1 * h1 + t2 * h2) + (n0 * dt0 + n1 * dt1 + n2 * dt2)
        if not (d2 > 0.0 and math.isfinite(d1)):
            break
        step = d1 / d2
        s, bound = s - step, math.nan
        if s > hi or s < lo:
            s = hi if s > hi else lo
            bound = s
        elif abs(step) <= xtol:
            found = True
            break
    return (found, s, _free_distance(code, prm, R, p, A, grid, table, s),
            _free_distance(code, prm, R, p, A, grid, table, lo),
            _free_distance(code, prm, R, p, A, grid, table, hi))


@_kernel
def free_samples(codes, prm, R, p, points):
    """
    Return each obstacle's least signed distance to sampled points and the first sample there.

    The points (m, 3) are the unloaded whisker's samples in its base frame, placed at (R, p)
    (p + R x); (dmin (k,), index (k,)) per obstacle, as numpy's min and argmin of
    ``signed_distance`` over the placed points.
    """
    k = codes.size
    dmin = np.full(k, math.inf)
    index = np.zeros(k, np.int64)
    for i in range(points.shape[0]):
        f0, f1, f2 = points[i, 0], points[i, 1], points[i, 2]
        x = p[0] + (f0 * R[0, 0] + f1 * R[0, 1] + f2 * R[0, 2])
        y = p[1] + (f0 * R[1, 0] + f1 * R[1, 1] + f2 * R[1, 2])
        z = p[2] + (f0 * R[2, 0] + f1 * R[2, 1] + f2 * R[2, 2])
        for c in range(k):
            d = distance(codes[c], prm[c], x, y, z)
            if d < dmin[c]:
                dmin[c] = d
                index[c] = i
    return dmin, index


@_kernel
def stream_guess(rows, vecs, start, v0, target, orders, weights, tol):
    """
    Return (k, guess): a pose stream's next solution extrapolated by a polynomial of degree k.

    RodTracker._extrapolate's rule in loops: ``rows`` (m, 7) are the last m poses (p, q) before
    ``start`` (the current one) and ``vecs`` (m, size) their solutions, ``v0`` the current
    solution and ``target`` the next pose. Every quaternion is taken on the side of start's;
    for each degree k of ``orders`` (highest first, ``weights[o, :k + 2]`` the (k+1)-th
    difference's binomial weights, oldest first) that the poses allow, where the (k+1)-th
    difference of the last k + 2 poses (target's included) is within ``tol`` times the last
    step, the guess is the polynomial through the last k + 1 solutions at target (the same
    difference of the solutions set to zero). (-1, empty) where no degree qualifies or the
    step is zero.
    """
    m = rows.shape[0]
    total = m + 2
    R = np.empty((total, 7))
    for i in range(m):
        for j in range(7):
            R[i, j] = rows[i, j]
    for j in range(7):
        R[m, j] = start[j]
        R[m + 1, j] = target[j]
    rw, rx, ry, rz = start[3], start[4], start[5], start[6]
    for i in range(total):
        if R[i, 3] * rw + R[i, 4] * rx + R[i, 5] * ry + R[i, 6] * rz < 0.0:
            for j in range(3, 7):
                R[i, j] = -R[i, j]
    squares = 0.0
    for j in range(7):
        d = R[total - 1, j] - R[total - 2, j]
        squares += d * d
    step = math.sqrt(squares)
    if step == 0.0:
        return -1, np.zeros(0)
    for o in range(orders.size):
        k = orders[o]
        if k + 2 > total or k > m:
            continue  # too short a history yet
        first = total - (k + 2)
        squares = 0.0
        for j in range(7):
            d = 0.0
            for i in range(k + 2):
                d += weights[o, i] * R[first + i, j]
            squares += d * d
        if math.sqrt(squares) <= tol * step:
            size = v0.size
            guess = np.empty(size)
            for j in range(size):
                acc = 0.0
                for i in range(k):
                    acc += weights[o, i] * vecs[m - k + i, j]
                acc += weights[o, k] * v0[j]
                guess[j] = -acc
            return k, guess
    return -1, np.zeros(0)
