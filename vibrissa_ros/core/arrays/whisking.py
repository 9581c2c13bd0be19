"""
Whisking: each whisker's base frame as a function of its protraction angle.

Convention (Knutsen et al. 2008's kinematics as RatMap and WHISKiT use them). A whisker's rest
orientation, written for a right-side whisker as Belli et al. 2018's angles of emergence,

    R = Rz(theta_w - 90 deg) Ry(-phi_w) Rx(zeta_w) Rx(-90 deg)

(:func:`~vibrissa_ros.core.arrays.rat.emergence_rotation`: theta_w - 90 deg is the azimuth of
the base tangent about the head's dorsal axis z, from lateral +x toward rostral +y; phi_w its
elevation; zeta_w the roll about the whisker's own axis) is read back from any base quaternion
(:func:`emergence_angles`). A protraction by theta [rad] turns the
whisker to

    theta_w + theta,  phi_w + (dphi/dtheta) theta,  zeta_w + (dzeta/dtheta) theta,

with the whisker's own slopes (the array file's ``whisking`` key; the rat's per row,
:data:`ROW_SLOPES`). Protraction is positive forward (rostral, toward +y of the head frame) on both
sides: a left-side whisker is whisked as the mirror image of its right-side twin
(:func:`~vibrissa_ros.core.arrays.rat.mirror_rotation`). The base point does not move. At
theta = 0 the rest orientation is reproduced to rounding.

The built-in whisk (:class:`CosineWhisk`) drives every whisker with the same theta(t), a cosine
between a retraction and a protraction angle, as WHISKiT's simple whisk does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Sequence, Tuple

import numpy as np

from ..errors import ParameterError
from ..rod3d import _jit
from . import _jit as _arrays_jit

#: (dphi/dtheta, dzeta/dtheta) per row: Knutsen et al. 2008 / Hobbs et al. 2016 after RatMap's
#: head-pitch correction of 13.8 deg, the values WHISKiT uses
ROW_SLOPES: Dict[str, Tuple[float, float]] = {
    "A": (0.398, -0.900), "B": (0.591, -0.284), "C": (0.578, 0.243), "D": (0.393, 0.449),
    "E": (0.217, 0.744)}

_RIGHT_ANGLE = 0.5 * math.pi
#: the head's midsagittal mirror and the base frame's flip that keep a mirrored frame proper
_MIRROR = np.diag((-1.0, 1.0, 1.0))
_FLIP = np.diag((1.0, 1.0, -1.0))
#: Rx(-90 deg) and its inverse: the base frame (curving toward +y) from WHISKiT's (toward -z)
_RX_M90 = np.array(((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, -1.0, 0.0)))
_RX_P90 = _RX_M90.T


def _right_frame(R: np.ndarray, side: str) -> np.ndarray:
    """Return the right-side twin of a base frame (itself on the right side)."""
    return R if side == "right" else _MIRROR @ R @ _FLIP


def emergence_angles(R, side: str = "right") -> Tuple[float, float, float]:
    """
    Return the angles of emergence of a base frame (the inverse of the rest orientation).

    Parameters
    ----------
    R : array_like
        The base frame (3, 3) in the head frame (columns: its axes).
    side : str, optional
        ``right`` or ``left`` (a left-side frame is read as its right-side mirror twin).

    Returns
    -------
    tuple of float
        (theta_w, phi_w, zeta_w) [rad] with R = Rz(theta_w - 90 deg) Ry(-phi_w) Rx(zeta_w)
        Rx(-90 deg) for the right-side twin; phi_w in [-90, 90] deg.

    Raises
    ------
    ParameterError
        When ``side`` is neither left nor right.

    """
    if side not in ("left", "right"):
        raise ParameterError(f"side = {side!r} is not allowed; side is left or right")
    M = _right_frame(np.asarray(R, dtype=float), side) @ _RX_P90  # Rz(a) Ry(b) Rx(c)
    b = -math.asin(max(-1.0, min(1.0, float(M[2, 0]))))
    a = math.atan2(float(M[1, 0]), float(M[0, 0]))
    c = math.atan2(float(M[2, 1]), float(M[2, 2]))
    return a + _RIGHT_ANGLE, -b, c


def protraction_angles(protraction, size: int) -> np.ndarray:
    """
    Return the protraction angles of ``size`` whiskers, checked: one for all, or one each.

    Parameters
    ----------
    protraction : float or array_like
        [rad].
    size : int
        The number of whiskers.

    Returns
    -------
    numpy.ndarray
        (size,) a new, writeable array (a read-only one would compile a second version of the
        kernels that take it).

    Raises
    ------
    ParameterError
        When an angle is not finite or there is neither one nor ``size`` of them.

    """
    theta = np.array(protraction, dtype=float)
    if theta.ndim == 0:
        theta = np.full(size, float(theta))
    if theta.shape != (size,) or not np.all(np.isfinite(theta)):
        raise ParameterError(f"protraction = {np.asarray(protraction).tolist()!r} is not "
                             f"allowed; it is one finite angle [rad] or {size} of them, one "
                             "per whisker")
    return theta


def _rotations(a, b, c) -> np.ndarray:
    """Return Rz(a) Ry(b) Rx(c) for arrays of angles (k,), shape (k, 3, 3)."""
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    out = np.empty(np.shape(a) + (3, 3))
    out[..., 0, 0] = ca * cb
    out[..., 0, 1] = ca * sb * sc - sa * cc
    out[..., 0, 2] = ca * sb * cc + sa * sc
    out[..., 1, 0] = sa * cb
    out[..., 1, 1] = sa * sb * sc + ca * cc
    out[..., 1, 2] = sa * sb * cc - ca * sc
    out[..., 2, 0] = -sb
    out[..., 2, 1] = cb * sc
    out[..., 2, 2] = cb * cc
    return out


class Whisking:
    """
    The base frames of many whiskers as functions of their protraction angles (vectorized).

    Parameters
    ----------
    rotations : sequence of array_like
        Each whisker's rest base frame (3, 3) in the head frame.
    sides : sequence of str
        Each whisker's side, ``left`` or ``right``.
    slopes : sequence of (float, float)
        Each whisker's (dphi/dtheta, dzeta/dtheta).

    Raises
    ------
    ParameterError
        When the sequences differ in length, or a side is neither left nor right.

    """

    def __init__(self, rotations: Sequence, sides: Sequence[str],
                 slopes: Sequence[Tuple[float, float]]):
        if not len(rotations) == len(sides) == len(slopes):
            raise ParameterError(f"whisking: {len(rotations)} rotations, {len(sides)} sides and "
                                 f"{len(slopes)} slopes: one of each per whisker")
        angles = np.array([emergence_angles(R, side) for R, side in zip(rotations, sides)])
        self.size = len(sides)
        self._theta = angles[:, 0].reshape(-1) - _RIGHT_ANGLE
        self._phi = np.ascontiguousarray(angles[:, 1].reshape(-1))
        self._zeta = np.ascontiguousarray(angles[:, 2].reshape(-1))
        slopes = np.asarray(slopes, dtype=float).reshape(-1, 2)
        self._dphi = np.ascontiguousarray(slopes[:, 0])
        self._dzeta = np.ascontiguousarray(slopes[:, 1])
        self._left = np.array([side == "left" for side in sides])

    def rotations(self, protraction, head=None) -> np.ndarray:
        """
        Return every whisker's base frame at the given protraction.

        Parameters
        ----------
        protraction : float or array_like
            theta [rad]: one angle for every whisker, or one per whisker.
        head : array_like, optional
            A rotation (3, 3) of the head frame in the world: the frames are then given in
            the world (``head @ R``).

        Returns
        -------
        numpy.ndarray
            R (k, 3, 3): base frames in the head frame (in the world with ``head``).

        Raises
        ------
        ParameterError
            When ``protraction`` is not finite or has the wrong length.

        """
        theta = protraction_angles(protraction, self.size)
        if _jit.ENABLED:  # one compiled call (the same operations)
            if not _jit.WARM:
                _jit.warm_up()
            R_head = np.eye(3) if head is None else np.array(head, dtype=float)
            return _arrays_jit.frames(theta, self._theta, self._phi, self._zeta, self._dphi,
                                      self._dzeta, self._left, R_head)
        R = _rotations(self._theta + theta, -(self._phi + self._dphi * theta),
                       self._zeta + self._dzeta * theta) @ _RX_M90
        if self._left.any():
            R[self._left] = _MIRROR @ R[self._left] @ _FLIP
        return R if head is None else np.asarray(head, dtype=float) @ R


@dataclass(frozen=True)
class CosineWhisk:
    """
    A periodic whisk: theta(t) a cosine between a retraction and a protraction angle.

    theta(t) = retraction + (protraction - retraction) (1 - cos(2 pi f (t - t0))) / 2: at t0
    fully retracted, half a period later fully protracted. The parameters are the dataclass's
    fields, kept as attributes of the same names.

    Parameters
    ----------
    frequency : float
        f [Hz], > 0 (rats whisk at 5-10 Hz in exploration).
    retraction : float
        theta at full retraction [rad], relative to the rest orientation.
    protraction : float
        theta at full protraction [rad], >= retraction.
    start : float, optional
        t0 [s].

    Raises
    ------
    ParameterError
        When a value is not finite, the frequency is not > 0, or protraction < retraction.

    """

    frequency: float = 8.0
    retraction: float = -math.radians(20.0)
    protraction: float = math.radians(20.0)
    start: float = 0.0

    def __post_init__(self):
        for key in ("frequency", "retraction", "protraction", "start"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value):
                raise ParameterError(f"whisk {key} = {value!r} is not allowed; it is a finite "
                                     "number (angles in rad, frequency in Hz, start in s)")
            object.__setattr__(self, key, float(value))
        if self.frequency <= 0.0:
            raise ParameterError(f"whisk frequency = {self.frequency!r} is not allowed; it is > 0 "
                                 "[Hz]")
        if self.protraction < self.retraction:
            raise ParameterError(f"whisk protraction = {self.protraction!r} is not allowed; it is "
                                 f">= the retraction ({self.retraction!r}) [rad]")

    def angle(self, t: float) -> float:
        """
        Return theta(t) [rad].

        Parameters
        ----------
        t : float
            Time [s].

        Returns
        -------
        float
            The protraction angle.

        """
        phase = 2.0 * math.pi * self.frequency * (float(t) - self.start)
        return self.retraction + (self.protraction - self.retraction) * 0.5 * (
            1.0 - math.cos(phase))
