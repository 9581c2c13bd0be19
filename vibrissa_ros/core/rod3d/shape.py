"""
The 3D whisker's shape and stiffness: taper, intrinsic curvature, torsional stiffness.

Dimensionless (L = 1, EI_b = the bending stiffness at the base). The whisker is a solid cone of
circular section: bending stiffness B(s) = (1 - (1 - taper) s)^4, torsional stiffness
C(s) = G J(s) = B(s) / (1 + nu) (J = 2 I, G = E / (2 (1 + nu))), with nu the Poisson ratio.

The unloaded whisker lies in the plane of its base frame's x and y axes: it leaves along +x and
bends toward +y with the intrinsic curvature kappa0(s), either linear in arc length
(kappa0 = k0 + k1 s, the planar general whisker's) or the parabola y = A x^2 that morphology
papers fit to rat whiskers (Towal et al. 2011, Belli et al. 2018), arc length measured from the
parabola's vertex. For the parabola, with u = 2 A x,

    s = (u sqrt(1 + u^2) + asinh(u)) / (4 A),                    (arc length of y = A x^2)
    kappa0 = 2 A / (1 + u^2)^(3/2),   intrinsic slope phi0 = atan(u),

and u(s) is found by Newton's method (convex, monotone: converges from above in a few steps).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Tuple

import numpy as np
from scipy.integrate import quad

from ..errors import ParameterError

#: Poisson ratio of keratin used by Elastica3D (default)
DEFAULT_POISSON = 0.38
_NEWTON_STEPS = 60


def _number(key: str, value) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"whisker {key} = {value!r} is not a number") from None
    if not math.isfinite(value):
        raise ParameterError(f"whisker {key} = {value!r} must be finite")
    return value


@lru_cache(maxsize=1)
def _gauss():
    return np.polynomial.legendre.leggauss(48)


@dataclass(frozen=True)
class RodShape:
    """
    Taper, intrinsic curvature and Poisson ratio of a 3D whisker (dimensionless).

    The defaults are the paper's whisker (uniform, straight) with keratin's Poisson ratio. The
    parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    taper : float, optional
        rho = tip radius / base radius in (0, 1]; B(s) = (1 - (1 - rho) s)^4 [EI_b].
    k0, k1 : float, optional
        Intrinsic curvature kappa0(s) = k0 + k1 s [1/L] toward the base frame's +y;
        ``|k0| + |k1| <= 20``. Not together with ``parabola``.
    parabola : float or None, optional
        The coefficient A [1/L] of the parabola y = A x^2 the unloaded whisker follows in its own
        plane (from its vertex at the base); ``|A| <= 10``. None: the linear curvature.
    poisson : float, optional
        Poisson ratio nu in [0, 0.5]: C(s) = B(s) / (1 + nu).

    Raises
    ------
    ParameterError
        When a field is not a finite number or out of its range, or when both a parabola and a
        linear curvature are given.

    """

    taper: float = 1.0
    k0: float = 0.0
    k1: float = 0.0
    parabola: float | None = None
    poisson: float = DEFAULT_POISSON

    def __post_init__(self):
        for key in ("taper", "k0", "k1", "poisson"):
            object.__setattr__(self, key, _number(key, getattr(self, key)))
        if self.parabola is not None:
            object.__setattr__(self, "parabola", _number("parabola", self.parabola))
            if self.k0 != 0.0 or self.k1 != 0.0:
                raise ParameterError(
                    "whisker parabola and curvature k0/k1 are exclusive: give one shape"
                )
            if abs(self.parabola) > 10.0:
                raise ParameterError(
                    f"whisker parabola A = {self.parabola!r} [1/L] must satisfy |A| <= 10"
                )
            if self.parabola == 0.0:
                object.__setattr__(self, "parabola", None)
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
        if not 0.0 <= self.poisson <= 0.5:
            raise ParameterError(
                f"whisker poisson = {self.poisson!r} must be in [0, 0.5]"
            )

    @property
    def is_straight(self) -> bool:
        """Tell whether the unloaded whisker is straight."""
        return self.parabola is None and self.k0 == 0.0 and self.k1 == 0.0

    @property
    def torsion_ratio(self) -> float:
        """C / B = 1 / (1 + nu)."""
        return 1.0 / (1.0 + self.poisson)

    def stiffness(self, s):
        """
        Return the bending stiffness B(s) [EI_b].

        Parameters
        ----------
        s : array_like
            Arc lengths [L].

        Returns
        -------
        numpy.ndarray
            B at ``s``.

        """
        return (1.0 - (1.0 - self.taper) * np.asarray(s, dtype=float)) ** 4

    def stiffness_slope(self, s):
        """
        Return dB/ds [EI_b / L].

        Parameters
        ----------
        s : array_like
            Arc lengths [L].

        Returns
        -------
        numpy.ndarray
            dB/ds at ``s``.

        """
        a = 1.0 - self.taper
        return -4.0 * a * (1.0 - a * np.asarray(s, dtype=float)) ** 3

    def _u(self, s):
        """Return u = 2 A x(s) on the parabola (Newton on the arc length from a table's guess)."""
        a = self.parabola
        s = np.asarray(s, dtype=float)
        target = 4.0 * abs(a) * s
        grid, table = self._u_table()
        if s.ndim == 0:
            return math.copysign(1.0, a) * self._u_one(float(s), float(target), grid, table)
        # linear interpolation on the fine table is within ~1e-7 of the root; F is convex and
        # increasing, so Newton converges quadratically: two steps reach rounding (tested)
        u = np.interp(s, grid, table, right=np.nan)
        u = np.where(np.isnan(u), 0.5 * target, u)   # beyond the table: from above, as there
        steps = 2 if np.all(s <= grid[-1]) else _NEWTON_STEPS
        for _ in range(steps):
            root = np.sqrt(1.0 + u * u)
            u = u - (u * root + np.arcsinh(u) - target) / (2.0 * root)
        return math.copysign(1.0, a) * u

    @staticmethod
    def _u_one(s, target, grid, table):
        """Return u for one arc length, in plain floats (as :meth:`_u`)."""
        if s > grid[-1]:
            u = 0.5 * target
            steps = _NEWTON_STEPS
        else:
            u = float(np.interp(s, grid, table))
            steps = 2
        for _ in range(steps):
            root = math.sqrt(1.0 + u * u)
            u -= (u * root + math.asinh(u) - target) / (2.0 * root)
        return u

    def _u_table(self):
        """u(s) on 2049 arc lengths in [0, 1.5], solved to rounding (cached)."""
        table = self.__dict__.get("_table")
        if table is None:
            grid = np.linspace(0.0, 1.5, 2049)
            target = 4.0 * abs(self.parabola) * grid
            u = 0.5 * target      # above the root: Newton decreases monotonically to it
            for _ in range(_NEWTON_STEPS):
                root = np.sqrt(1.0 + u * u)
                du = (u * root + np.arcsinh(u) - target) / (2.0 * root)
                u = u - du
                if np.all(np.abs(du) <= 4e-16 * (1.0 + np.abs(u))):
                    break
            table = (grid, u)
            object.__setattr__(self, "_table", table)
        return table

    def curvature(self, s):
        """
        Return the intrinsic curvature kappa0(s) [1/L] (toward the base frame's +y).

        Parameters
        ----------
        s : array_like
            Arc lengths [L].

        Returns
        -------
        numpy.ndarray
            kappa0 at ``s``.

        """
        s = np.asarray(s, dtype=float)
        if self.parabola is None:
            return self.k0 + self.k1 * s
        u = self._u(s)
        return 2.0 * self.parabola / (1.0 + u * u) ** 1.5

    def curvature_slope(self, s):
        """
        Return d kappa0 / ds [1/L^2].

        Parameters
        ----------
        s : array_like
            Arc lengths [L].

        Returns
        -------
        numpy.ndarray
            The derivative of kappa0 at ``s``.

        """
        s = np.asarray(s, dtype=float)
        if self.parabola is None:
            return self.k1 + 0.0 * s
        u = self._u(s)
        return -12.0 * self.parabola ** 2 * u / (1.0 + u * u) ** 3

    def curvature_and_slope(self, s):
        """
        Return kappa0(s) and d kappa0 / ds together (one parabola inversion for both).

        Parameters
        ----------
        s : array_like
            Arc lengths [L].

        Returns
        -------
        tuple of numpy.ndarray
            (kappa0 [1/L], d kappa0 / ds [1/L^2]) at ``s``.

        """
        s = np.asarray(s, dtype=float)
        if self.parabola is None:
            return self.k0 + self.k1 * s, self.k1 + 0.0 * s
        u = self._u(s)
        w = 1.0 + u * u
        return 2.0 * self.parabola / w ** 1.5, -12.0 * self.parabola ** 2 * u / w ** 3

    def intrinsic_slope(self, s):
        """
        Return the unloaded whisker's slope in its plane, int_0^s kappa0 [rad].

        Parameters
        ----------
        s : array_like
            Arc lengths [L].

        Returns
        -------
        numpy.ndarray
            The slope phi0 at ``s``, relative to the base frame's +x.

        """
        s = np.asarray(s, dtype=float)
        if self.parabola is None:
            return self.k0 * s + 0.5 * self.k1 * s * s
        return np.arctan(self._u(s))

    def intrinsic_offset(self, s_a: float, s_b) -> np.ndarray:
        """
        Return the unloaded displacement from s_a to s_b in the body frame at s_a.

        The part of the whisker beyond its last contact carries no load and keeps its intrinsic
        shape: a plane curve in the (d1, d2) plane of the frame at s_a.

        Parameters
        ----------
        s_a : float
            Start arc length [L].
        s_b : array_like
            End arc lengths [L] (>= s_a).

        Returns
        -------
        numpy.ndarray
            Offsets (m, 2) in (d1, d2) components [L].

        """
        s_b = np.atleast_1d(np.asarray(s_b, dtype=float))
        out = np.zeros((s_b.size, 2))
        if self.is_straight:
            out[:, 0] = s_b - s_a
            return out
        if self.parabola is not None:
            out[:, 0], out[:, 1] = self._parabola_offset(float(self._u(s_a)), self._u(s_b))
            return out
        x, w = _gauss()
        phi_a = float(self.intrinsic_slope(s_a))
        for i, sb in enumerate(s_b):
            if sb <= s_a:
                continue
            u = s_a + 0.5 * (sb - s_a) * (x + 1.0)
            th = self.intrinsic_slope(u) - phi_a
            half = 0.5 * (sb - s_a)
            out[i] = half * (w @ np.cos(th)), half * (w @ np.sin(th))
        return out

    def tail(self, s_a: float) -> Tuple[Tuple[float, float], float]:
        """
        Return the unloaded part from s_a to the tip: its offset and its turn.

        Parameters
        ----------
        s_a : float
            Where the unloaded part starts [L], in [0, 1].

        Returns
        -------
        tuple
            ((dx, dy), phi): the tip's offset from s_a in the (d1, d2) components of the frame
            at s_a [L], and the slope the unloaded part turns through [rad].

        """
        s_a = float(s_a)
        if self.is_straight:
            return (1.0 - s_a, 0.0), 0.0
        if self.parabola is not None:
            u_a, u_b = float(self._u(s_a)), self._tip_u()
            return self._parabola_offset(u_a, u_b), math.atan(u_b) - math.atan(u_a)
        off = self.intrinsic_offset(s_a, [1.0])[0]
        turn = float(self.intrinsic_slope(1.0) - self.intrinsic_slope(s_a))
        return (float(off[0]), float(off[1])), turn

    def _parabola_offset(self, u_a: float, u_b):
        """Return the chord from u_a to u_b on the parabola in the frame at u_a: (dx, dy)."""
        a = self.parabola
        dx = (u_b - u_a) / (2.0 * a)
        dy = (u_b * u_b - u_a * u_a) / (4.0 * a)
        root = math.sqrt(1.0 + u_a * u_a)
        c, sn = 1.0 / root, u_a / root
        return c * dx + sn * dy, -sn * dx + c * dy

    def _tip_u(self) -> float:
        """Return u at the tip (cached)."""
        u = self.__dict__.get("_u_tip")
        if u is None:
            u = float(self._u(1.0))
            object.__setattr__(self, "_u_tip", u)
        return u

    def compliance(self, s: float = 1.0) -> Tuple[float, float]:
        """
        Return the small-load compliances at arc length ``s``.

        They are the deflection per unit transverse force, int_0^s (s - u)^2 / B(u) du
        [L^3/EI_b], and the rotation per unit couple about a bending axis, int_0^s 1 / B(u) du
        [L/EI_b] (times 1 + nu for a twisting couple).

        Parameters
        ----------
        s : float, optional
            Where the load acts [L].

        Returns
        -------
        tuple of float
            (deflection compliance, rotation compliance).

        """
        s = float(s)
        return (float(quad(lambda u: (s - u) ** 2 / float(self.stiffness(u)), 0.0, s,
                           epsabs=0.0, epsrel=1e-10, limit=200)[0]),
                float(quad(lambda u: 1.0 / float(self.stiffness(u)), 0.0, s, epsabs=0.0,
                           epsrel=1e-10, limit=200)[0]))

    def free_frame(self, s: float) -> Tuple[float, float, float, float]:
        """
        Return the unloaded whisker at one arc length in its base frame, in plain floats.

        :meth:`free_centerline` for one arc length, without its arrays, with the slope and the
        curvature: the touch search minimizes the distance over s with a few such points per
        base pose.

        Parameters
        ----------
        s : float
            Arc length [L].

        Returns
        -------
        tuple of float
            (x, y, phi, kappa0): the point [L], the slope against the base frame's +x [rad]
            and the intrinsic curvature [1/L] there.

        """
        s = float(s)
        if self.parabola is not None:
            a = self.parabola
            u = self._u(s)
            return u / (2.0 * a), u * u / (4.0 * a), math.atan(u), 2.0 * a / (1.0 + u * u) ** 1.5
        if self.is_straight:
            return s, 0.0, 0.0, 0.0
        x, y = (float(v) for v in self.intrinsic_offset(0.0, [s])[0])
        return x, y, self.k0 * s + 0.5 * self.k1 * s * s, self.k0 + self.k1 * s

    def free_centerline(self, s) -> np.ndarray:
        """
        Return points of the unloaded whisker in its base frame, shape (m, 3).

        Parameters
        ----------
        s : array_like
            Arc lengths [L].

        Returns
        -------
        numpy.ndarray
            Points (m, 3), z = 0.

        """
        off = self.intrinsic_offset(0.0, s)
        return np.column_stack((off, np.zeros(len(off))))
