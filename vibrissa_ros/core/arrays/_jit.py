"""
Compiled kernels of the array's tick: base frames, clearance test, the tick's rows (numba).

The same operations as the numpy code they stand for (:meth:`.whisking.Whisking.rotations`'s
Euler angles, :meth:`.tracker.ArrayTracker._clear`'s sampled distances and the SI rows of
:meth:`.tracker.ArrayTracker._collect`), as loops over the whiskers in one call each: a tick of
30 whiskers spent ~45 us in numpy's calls on (30, 3, 3) arrays for its frames, ~90 us for its
clearance test and ~60 us for its rows. The tests compare them with the numpy code (to
rounding: numpy's 3 x 3 products may sum in another order). They are used where
:data:`vibrissa_ros.core.rod3d._jit.ENABLED` (numba present, ``VIBRISSA_NO_JIT`` not set);
compiled by :func:`vibrissa_ros.core.rod3d._jit.warm_up` with the solver's kernels.
"""

from __future__ import annotations

import math
import os

import numpy as np

from ..rod3d import _jit as _rod3d_jit

ENABLED = _rod3d_jit.ENABLED

if _rod3d_jit.numba is not None:
    # (the clearance kernel compiles rod3d's distance into its own: both files key its cache)
    _rod3d_jit.shared_cache(__file__, "vibrissa_ros_arrays_",
                            also=(os.path.abspath(_rod3d_jit.__file__),))

    def _kernel(func):
        return _rod3d_jit.numba.njit(cache=True, nogil=True)(func)
else:  # pragma: no cover
    def _kernel(func):
        return func

_distance = _rod3d_jit.distance


@_kernel
def frames(theta, theta0, phi, zeta, dphi, dzeta, left, R_head):
    """
    Return every whisker's base frame R_head Rz(a) Ry(b) Rx(c) Rx(-90 deg) (k, 3, 3) at theta.

    a = theta0 + theta, b = -(phi + dphi theta), c = zeta + dzeta theta (one of each per
    whisker); a left-side whisker's frame is mirrored (M W F, M = diag(-1, 1, 1),
    F = diag(1, 1, -1)), as :meth:`~.whisking.Whisking.rotations` does.
    """
    k = theta.size
    out = np.empty((k, 3, 3))
    W = np.empty((3, 3))
    for i in range(k):
        a = theta0[i] + theta[i]
        b = -(phi[i] + dphi[i] * theta[i])
        c = zeta[i] + dzeta[i] * theta[i]
        ca, sa, cb, sb = math.cos(a), math.sin(a), math.cos(b), math.sin(b)
        cc, sc = math.cos(c), math.sin(c)
        # Rz(a) Ry(b) Rx(c), then Rx(-90 deg): columns (m0, -m2, m1)
        m00, m01, m02 = ca * cb, ca * sb * sc - sa * cc, ca * sb * cc + sa * sc
        m10, m11, m12 = sa * cb, sa * sb * sc + ca * cc, sa * sb * cc - ca * sc
        m20, m21, m22 = -sb, cb * sc, cb * cc
        W[0, 0], W[0, 1], W[0, 2] = m00, -m02, m01
        W[1, 0], W[1, 1], W[1, 2] = m10, -m12, m11
        W[2, 0], W[2, 1], W[2, 2] = m20, -m22, m21
        if left[i]:
            W[0, 0], W[0, 1] = -W[0, 0], -W[0, 1]
            W[1, 2], W[2, 2] = -W[1, 2], -W[2, 2]
        for r in range(3):
            for col in range(3):
                out[i, r, col] = (R_head[r, 0] * W[0, col] + R_head[r, 1] * W[1, col]
                                  + R_head[r, 2] * W[2, col])
    return out


@_kernel
def _least(R, p, free, i, stride, codes, prm):
    """Return the least signed distance of whisker i's samples (every stride-th) at (R, p)."""
    d = math.inf
    for j in range(0, free.shape[1], stride):
        f0, f1, f2 = free[i, j, 0], free[i, j, 1], free[i, j, 2]
        x = p[i, 0] + (f0 * R[i, 0, 0] + f1 * R[i, 0, 1] + f2 * R[i, 0, 2])
        y = p[i, 1] + (f0 * R[i, 1, 0] + f1 * R[i, 1, 1] + f2 * R[i, 1, 2])
        z = p[i, 2] + (f0 * R[i, 2, 0] + f1 * R[i, 2, 1] + f2 * R[i, 2, 2])
        for c in range(codes.size):
            dc = _distance(codes[c], prm[c], x, y, z)
            if dc < d:
                d = dc
    return d


@_kernel
def clearance(R, p, R_prev, p_prev, length, free, stride, reach, codes, prm):
    """
    Tell which whiskers are certified clear of the obstacles along the tick (k,) bool.

    Whisker i moves by at most m = norm(p - p_prev) + angle(R_prev^T R) L (every point of it,
    along the straight pose path); its unloaded centerline, sampled at ``free[i]`` ((k, m, 3)
    in its base frame [m]) with the samples L / (2 (m - 1)) = ``reach[i]`` apart at most from
    every point, is placed at (R, p). Clear: every stride-th sample farther than
    stride reach + m (+ 1e-12 L), or else every sample farther than reach + m (+ 1e-12 L).
    """
    k = R.shape[0]
    clear = np.empty(k, np.bool_)
    for i in range(k):
        dx, dy, dz = p[i, 0] - p_prev[i, 0], p[i, 1] - p_prev[i, 1], p[i, 2] - p_prev[i, 2]
        trace = 0.0
        for r in range(3):
            for col in range(3):
                trace += R_prev[i, r, col] * R[i, r, col]
        cos = min(1.0, max(-1.0, 0.5 * (trace - 1.0)))
        motion = math.sqrt(dx * dx + dy * dy + dz * dz) + math.acos(cos) * length[i]
        tol = 1e-12 * length[i]
        if _least(R, p, free, i, stride, codes, prm) > stride * reach[i] + motion + tol:
            clear[i] = True
        else:
            clear[i] = _least(R, p, free, i, 1, codes, prm) > reach[i] + motion + tol
    return clear


@_kernel
def _quaternion(R, i, quat, j):
    """Write the quaternion of R[i] into quat[j] (quat_from_matrix's operations)."""
    r00, r01, r02 = R[i, 0, 0], R[i, 0, 1], R[i, 0, 2]
    r10, r11, r12 = R[i, 1, 0], R[i, 1, 1], R[i, 1, 2]
    r20, r21, r22 = R[i, 2, 0], R[i, 2, 1], R[i, 2, 2]
    t = r00 + r11 + r22
    c0, c1, c2, c3 = 1.0 + t, 1.0 + 2 * r00 - t, 1.0 + 2 * r11 - t, 1.0 + 2 * r22 - t
    k = 0
    best = c0
    if c1 > best:
        k, best = 1, c1
    if c2 > best:
        k, best = 2, c2
    if c3 > best:
        k, best = 3, c3
    r = 0.5 * math.sqrt(max(best, 0.0))
    f = 0.25 / r
    if k == 0:
        q0, q1, q2, q3 = r, (r21 - r12) * f, (r02 - r20) * f, (r10 - r01) * f
    elif k == 1:
        q0, q1, q2, q3 = (r21 - r12) * f, r, (r01 + r10) * f, (r02 + r20) * f
    elif k == 2:
        q0, q1, q2, q3 = (r02 - r20) * f, (r01 + r10) * f, r, (r12 + r21) * f
    else:
        q0, q1, q2, q3 = (r10 - r01) * f, (r02 + r20) * f, (r12 + r21) * f, r
    if not q0 >= 0.0:
        q0, q1, q2, q3 = -q0, -q1, -q2, -q3
    quat[j, 0], quat[j, 1], quat[j, 2], quat[j, 3] = q0, q1, q2, q3


@_kernel
def poses(R, p, length, which):
    """
    Return the whiskers ``which``'s base positions p / L (m, 3) and quaternions (m, 4).

    The same operations, in the same order, as :meth:`.tracker.ArrayTracker._pose` before
    :meth:`~vibrissa_ros.core.rod3d.pose.BasePose._of_floats` normalises the quaternion:
    :func:`~vibrissa_ros.core.rod3d.pose.quat_from_matrix` (the largest of the four
    candidates, the first where two tie; q0 >= 0).
    """
    m = which.size
    pos = np.empty((m, 3))
    quat = np.empty((m, 4))
    for j in range(m):
        i = which[j]
        for a in range(3):
            pos[j, a] = p[i, a] / length[i]
        _quaternion(R, i, quat, j)
    return pos, quat


@_kernel
def quaternions(R):
    """
    Return the unit quaternion of each rotation matrix R[i], q0 >= 0: (k, 3, 3) in, (k, 4) out.

    :func:`.tracker.quats_from_matrices`'s, with the same operations (the tick's rows take
    their base frames so: ~50 us in numpy for 30 whiskers).
    """
    k = R.shape[0]
    quat = np.empty((k, 4))
    for i in range(k):
        _quaternion(R, i, quat, i)
    return quat


@_kernel
def collect(R, p, free_tip, length, force_scale, moment_scale, moved, mrows, loaded, lrows):
    """
    Return the tick's rows in SI units, as :meth:`.tracker.ArrayTracker._collect` makes them.

    ``R`` (k, 3, 3), ``p`` (k, 3): the base frames and points of the tick; ``free_tip`` (k, 3)
    the unloaded tips in the base frames [m]. ``mrows`` (m, 10) for the whiskers ``moved``
    (stepped, or failed and kept their state): the base quaternion (w, x, y, z), base point
    and tip [L] of their states; their base frames are the quaternions' rotation matrices,
    with :func:`..rod3d.pose.quat_matrix`'s operations (the same floats as their poses'
    ``rotation``). ``lrows`` (l, 11) for the whiskers ``loaded`` (in contact): force,
    moment, first contact point [L], its s and f. Returns (p, R, tip, force, moment, point,
    arc, normal, force in the base frame, moment in the base frame).
    """
    k = R.shape[0]
    p_out = p.copy()
    Rb = R.copy()
    tip = np.empty((k, 3))
    for i in range(k):
        for a in range(3):
            tip[i, a] = p[i, a] + (R[i, a, 0] * free_tip[i, 0] + R[i, a, 1] * free_tip[i, 1]
                                   + R[i, a, 2] * free_tip[i, 2])
    for j in range(moved.size):
        i = moved[j]
        L = length[i]
        w, x, y, z = mrows[j, 0], mrows[j, 1], mrows[j, 2], mrows[j, 3]
        Rb[i, 0, 0] = w * w + x * x - y * y - z * z
        Rb[i, 0, 1] = 2 * (x * y - w * z)
        Rb[i, 0, 2] = 2 * (x * z + w * y)
        Rb[i, 1, 0] = 2 * (x * y + w * z)
        Rb[i, 1, 1] = w * w - x * x + y * y - z * z
        Rb[i, 1, 2] = 2 * (y * z - w * x)
        Rb[i, 2, 0] = 2 * (x * z - w * y)
        Rb[i, 2, 1] = 2 * (y * z + w * x)
        Rb[i, 2, 2] = w * w - x * x - y * y + z * z
        for a in range(3):
            p_out[i, a] = mrows[j, 4 + a] * L
            tip[i, a] = mrows[j, 7 + a] * L
    force = np.zeros((k, 3))
    moment = np.zeros((k, 3))
    point = np.zeros((k, 3))
    arc = np.zeros(k)
    normal = np.zeros(k)
    for j in range(loaded.size):
        i = loaded[j]
        for a in range(3):
            force[i, a] = lrows[j, a] * force_scale[i]
            moment[i, a] = lrows[j, 3 + a] * moment_scale[i]
            point[i, a] = lrows[j, 6 + a] * length[i]
        arc[i] = lrows[j, 9] * length[i]
        normal[i] = lrows[j, 10] * force_scale[i]
    force_base = np.zeros((k, 3))
    moment_base = np.zeros((k, 3))
    for j in range(loaded.size):
        i = loaded[j]
        for a in range(3):
            force_base[i, a] = (Rb[i, 0, a] * force[i, 0] + Rb[i, 1, a] * force[i, 1]
                                + Rb[i, 2, a] * force[i, 2])
            moment_base[i, a] = (Rb[i, 0, a] * moment[i, 0] + Rb[i, 1, a] * moment[i, 1]
                                 + Rb[i, 2, a] * moment[i, 2])
    return p_out, Rb, tip, force, moment, point, arc, normal, force_base, moment_base
