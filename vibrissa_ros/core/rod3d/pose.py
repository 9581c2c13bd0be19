"""
The 3D whisker's base pose and the quaternion arithmetic it needs.

A base pose is a position p [L] and a unit quaternion q = (qw, qx, qy, qz) (Hamilton product,
scalar first) that rotates base-frame vectors into the world: v_world = R(q) v_base. The unloaded
whisker leaves along the base frame's +x and curves toward its +y. The planar foot pose
(x, y, heading) is the base pose (x, y, 0) with q the rotation about z by the heading
(:meth:`BasePose.from_planar`).

Between two poses the tracker follows the path with p linear and q along the shorter great arc
(slerp) in the path parameter t in [0, 1]: for planar poses this is the planar tracker's path
(heading linear in t, the short way round).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Tuple

import numpy as np

from ..errors import InvalidPoseError

#: largest | |q| - 1 | accepted (and normalised away)
UNIT_TOLERANCE = 1e-6


def quat_multiply(a, b) -> np.ndarray:
    """
    Return the Hamilton product a * b of quaternions (..., 4), scalar first.

    Parameters
    ----------
    a, b : array_like
        Quaternions (..., 4).

    Returns
    -------
    numpy.ndarray
        The products (..., 4).

    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.ndim == 1 and b.ndim == 1:
        aw, ax, ay, az = a.tolist()
        bw, bx, by, bz = b.tolist()
        return np.array((aw * bw - ax * bx - ay * by - az * bz,
                         aw * bx + ax * bw + ay * bz - az * by,
                         aw * by - ax * bz + ay * bw + az * bx,
                         aw * bz + ax * by - ay * bx + az * bw))
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack((
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ), axis=-1)


def quat_matrix(q) -> np.ndarray:
    """
    Return the rotation matrices (..., 3, 3) of unit quaternions (..., 4).

    Parameters
    ----------
    q : array_like
        Unit quaternions (..., 4), scalar first.

    Returns
    -------
    numpy.ndarray
        R(q) (..., 3, 3): its columns are the base frame's axes in the world.

    """
    q = np.asarray(q, dtype=float)
    if q.ndim == 1:
        w, x, y, z = q.tolist()
        return np.array((
            (w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)),
            (2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)),
            (2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z)))
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack((
        np.stack((w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)), -1),
        np.stack((2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)), -1),
        np.stack((2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z), -1),
    ), axis=-2)


def quat_from_matrix(R) -> np.ndarray:
    """
    Return the unit quaternion (4,) of a rotation matrix (3, 3), with qw >= 0.

    Parameters
    ----------
    R : array_like
        A rotation matrix (3, 3).

    Returns
    -------
    numpy.ndarray
        q (4,), scalar first.

    """
    # in floats (the arrays' tracker converts a frame per whisker and tick): the same operations,
    # in the same order, as on the array
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = np.asarray(R, dtype=float).tolist()
    t = r00 + r11 + r22
    cands = (1.0 + t, 1.0 + 2 * r00 - t, 1.0 + 2 * r11 - t, 1.0 + 2 * r22 - t)
    k = cands.index(max(cands))
    r = 0.5 * math.sqrt(max(cands[k], 0.0))
    f = 0.25 / r
    if k == 0:
        q = (r, (r21 - r12) * f, (r02 - r20) * f, (r10 - r01) * f)
    elif k == 1:
        q = ((r21 - r12) * f, r, (r01 + r10) * f, (r02 + r20) * f)
    elif k == 2:
        q = ((r02 - r20) * f, (r01 + r10) * f, r, (r12 + r21) * f)
    else:
        q = ((r10 - r01) * f, (r02 + r20) * f, (r12 + r21) * f, r)
    return np.array(q) if q[0] >= 0.0 else -np.array(q)


def quat_about(axis, angle: float) -> np.ndarray:
    """
    Return the unit quaternion of a rotation by ``angle`` [rad] about the unit ``axis``.

    Parameters
    ----------
    axis : array_like
        The rotation axis (3,), unit length.
    angle : float
        The angle [rad], right-handed.

    Returns
    -------
    numpy.ndarray
        q (4,), scalar first.

    """
    axis = np.asarray(axis, dtype=float)
    h = 0.5 * float(angle)
    return np.concatenate(([math.cos(h)], math.sin(h) * axis))


def slerp(q_a: np.ndarray, q_b: np.ndarray, t: float) -> np.ndarray:
    """
    Return the rotation a fraction ``t`` of the way from q_a to q_b along the shorter arc.

    Parameters
    ----------
    q_a, q_b : numpy.ndarray
        Unit quaternions (4,).
    t : float
        The path parameter in [0, 1].

    Returns
    -------
    numpy.ndarray
        The unit quaternion (4,), q_a at t = 0 and +-q_b at t = 1.

    """
    qa = tuple(np.asarray(q_a, dtype=float).tolist())
    return np.array(_slerp(qa, tuple(np.asarray(q_b, dtype=float).tolist()), float(t)))


def _relative(qa, qb):
    """
    Return conj(q_a) * q_b on the shorter arc (w >= 0), in floats, from tuples (w, x, y, z).

    :func:`quat_multiply`'s products (conj(q_a)'s signs folded into them: the same floats).
    """
    aw, ax, ay, az = qa
    bw, bx, by, bz = qb
    rw = aw * bw + ax * bx + ay * by + az * bz
    rx = aw * bx - ax * bw - ay * bz + az * by
    ry = aw * by + ax * bz - ay * bw - az * bx
    rz = aw * bz - ax * by + ay * bx - az * bw
    if rw < 0.0:
        return -rw, -rx, -ry, -rz
    return rw, rx, ry, rz


def _slerp(qa, qb, t: float):
    """
    :func:`slerp` in floats, on tuples: q_a * (cos(t h), sin(t h) v / |v|).

    (cos h, v) = conj(q_a) * q_b on the shorter arc (the products of :func:`quat_multiply`).
    |v| is numpy's dot of an array (3,) (as ``np.linalg.norm`` computes it), so that the path's
    poses do not depend on how the arithmetic is written: :meth:`BasePose.at` calls this.
    """
    aw, ax, ay, az = qa
    rw, rx, ry, rz = _relative(qa, qb)
    v = np.array((rx, ry, rz))
    sin_half = math.sqrt(float(v.dot(v)))
    if sin_half == 0.0:
        return (aw, ax, ay, az)
    half = math.atan2(sin_half, rw)
    c, s = math.cos(t * half), math.sin(t * half)
    sw, sx, sy, sz = c, s * rx / sin_half, s * ry / sin_half, s * rz / sin_half
    return (aw * sw - ax * sx - ay * sy - az * sz,
            aw * sx + ax * sw + ay * sz - az * sy,
            aw * sy - ax * sz + ay * sw + az * sx,
            aw * sz + ax * sy - ay * sx + az * sw)


def quat_conjugate(q) -> np.ndarray:
    """
    Return the conjugate (the inverse rotation) of unit quaternions (..., 4).

    Parameters
    ----------
    q : array_like
        Quaternions (..., 4).

    Returns
    -------
    numpy.ndarray
        (qw, -qx, -qy, -qz).

    """
    q = np.array(q, dtype=float)
    q[..., 1:] *= -1.0
    return q


@dataclass(frozen=True)
class BasePose:
    """
    The pose of the 3D whisker's base: position [L] and orientation (unit quaternion).

    A quaternion within 1e-6 of unit length is normalised; the sign is kept (q and -q are the
    same rotation). The parameters are the dataclass's fields, kept as attributes of the same
    names.

    Parameters
    ----------
    position : tuple of float
        (x, y, z) of the base [L].
    quaternion : tuple of float, optional
        (qw, qx, qy, qz), scalar first; identity by default (whisker along +x, curving to +y).

    Raises
    ------
    InvalidPoseError
        When a value is not a finite number or the quaternion is not of unit length.

    """

    position: Tuple[float, float, float]
    quaternion: Tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)

    def __post_init__(self):
        pos = self._floats("position", self.position, ("x", "y", "z"))
        q = self._floats("quaternion", self.quaternion, ("qw", "qx", "qy", "qz"))
        norm = math.sqrt(sum(v * v for v in q))
        if abs(norm - 1.0) > UNIT_TOLERANCE:
            raise InvalidPoseError(
                f"base quaternion (qw, qx, qy, qz) = {tuple(q)} has length {norm:.9g}: it must "
                f"be a unit quaternion (length 1 within {UNIT_TOLERANCE:g})"
            )
        object.__setattr__(self, "position", pos)
        object.__setattr__(self, "quaternion", tuple(v / norm for v in q))

    @classmethod
    def _of_floats(cls, position: Tuple[float, float, float],
                   quaternion: Tuple[float, float, float, float]) -> "BasePose":
        """
        Return the pose of finite floats and a unit quaternion, without checking them (internal).

        For poses computed from checked ones (the arrays' tracker makes one per whisker and
        tick): the quaternion is normalised as the constructor does it, and nothing else
        differs.
        """
        if not all(map(math.isfinite, position)):
            return cls(tuple(position), tuple(quaternion))  # (which says what is wrong)
        pose = object.__new__(cls)
        norm = math.sqrt(sum(v * v for v in quaternion))
        object.__setattr__(pose, "position", tuple(position))
        object.__setattr__(pose, "quaternion", tuple(v / norm for v in quaternion))
        return pose

    @staticmethod
    def _floats(what, values, names):
        try:
            values = tuple(values)
        except TypeError:
            raise InvalidPoseError(f"base {what} {values!r} is not a sequence") from None
        if len(values) != len(names):
            raise InvalidPoseError(
                f"base {what} {values!r} must have {len(names)} values ({', '.join(names)})"
            )
        out = []
        for name, value in zip(names, values):
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise InvalidPoseError(f"base pose {name} = {value!r} is not a number") from None
            if not math.isfinite(value):
                raise InvalidPoseError(f"base pose {name} = {value!r} must be finite")
            out.append(value)
        return tuple(out)

    @classmethod
    def from_planar(cls, x: float, y: float = 0.0, heading: float = 0.5 * math.pi
                    ) -> "BasePose":
        """
        Return the 3D pose of a planar foot pose (x, y, heading).

        Parameters
        ----------
        x, y : float
            The foot's position in the plane z = 0 [L].
        heading : float, optional
            The undeformed whisker's heading [rad], counter-clockwise from +x.

        Returns
        -------
        BasePose
            Base at (x, y, 0), rotated about z by the heading.

        """
        h = 0.5 * float(heading)
        return cls((x, y, 0.0), (math.cos(h), 0.0, 0.0, math.sin(h)))

    @property
    def p(self) -> np.ndarray:
        """Return the position as an array (3,) [L]."""
        return np.array(self.position)

    @property
    def q(self) -> np.ndarray:
        """Return the quaternion as an array (4,)."""
        return np.array(self.quaternion)

    @property
    def rotation(self) -> np.ndarray:
        """R(q) (3, 3): the base frame's axes (columns) in the world (read-only, cached)."""
        R = self.__dict__.get("_rotation")
        if R is None:
            R = quat_matrix(self.q)
            R.setflags(write=False)
            object.__setattr__(self, "_rotation", R)
        return R

    @property
    def is_planar(self) -> bool:
        """Tell whether the base lies in z = 0 and turns about z only (the planar model)."""
        w, x, y, z = self.quaternion
        return self.position[2] == 0.0 and x == 0.0 and y == 0.0

    @property
    def heading(self) -> float:
        """Return the heading [rad] of a planar pose (the angle of its +x axis in the plane)."""
        w, x, y, z = self.quaternion
        return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))

    def at(self, other: "BasePose", t: float) -> "BasePose":
        """
        Return the pose a fraction ``t`` along the straight path to ``other``.

        Parameters
        ----------
        other : BasePose
            The end of the path.
        t : float
            The path parameter in [0, 1].

        Returns
        -------
        BasePose
            p linear in t, q along the shorter arc (slerp).

        """
        # (1 - t) p_a + t p_b and slerp in floats (the same operations as numpy's), without a
        # numpy call per operation: the tracker makes a pose per sub-step and per trial of an
        # event's location
        t = float(t)
        u = 1.0 - t
        (ax, ay, az), (bx, by, bz) = self.position, other.position
        return BasePose._of_floats((u * ax + t * bx, u * ay + t * by, u * az + t * bz),
                                   _slerp(self.quaternion, other.quaternion, t))
