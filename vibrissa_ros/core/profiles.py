"""
Smooth strictly convex obstacle profiles in the paper's slope parametrization.

A profile is the lower boundary of a convex obstacle that lies *above* it. Every point of the
boundary is named by the slope angle ``alpha`` of its tangent (paper §2, "Supposition"):

    x = xi(alpha),  y = eta(alpha),  xi(0) = 0, eta(0) = p0,  curvature > 0.

Convexity means xi'(alpha) = rho(alpha) cos(alpha), eta'(alpha) = rho(alpha) sin(alpha) with the
radius of curvature rho > 0, so a profile is fully described by its point and rho. The outward
normal of the obstacle at ``alpha`` is (sin alpha, -cos alpha): the contact force on the whisker
points along it.

All lengths are in units of the whisker length L (the paper's units). A new profile is one small
subclass of :class:`ConvexProfile` giving ``point`` and ``radius_of_curvature``
(doc/guide/python.md, "Adding a convex profile").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, ClassVar, Dict, Mapping, Tuple

import numpy as np
from scipy.optimize import brentq

from .errors import ParameterError

HALF_PI = 0.5 * math.pi


class ConvexProfile:
    """
    Base class: a smooth strictly convex curve parametrized by its tangent slope alpha [rad].

    Subclasses implement :meth:`point` and :meth:`radius_of_curvature` for scalar alpha in the open
    interval (``alpha_min``, ``alpha_max``); everything else is derived. Closed forms of
    :meth:`alpha_at_x` may be given for speed.
    """

    #: the profile's name in the scan contract and the node's ``obstacle.type``
    name: ClassVar[str] = "profile"
    alpha_min: float = -HALF_PI
    alpha_max: float = HALF_PI

    # -- what a subclass provides -------------------------------------------------------------
    def point(self, alpha: float) -> Tuple[float, float]:
        """Return the profile's point of scalar slope alpha, (xi(alpha), eta(alpha))."""
        raise NotImplementedError

    def radius_of_curvature(self, alpha: float) -> float:
        """rho(alpha) = d(arc length)/d(alpha) > 0 for a scalar slope alpha."""
        raise NotImplementedError

    @property
    def params(self) -> Dict[str, float]:
        """Return the shape parameters by their contract names."""
        raise NotImplementedError

    # -- derived ------------------------------------------------------------------------------
    def xi(self, alpha):
        """Return the x coordinate of the profile point of slope ``alpha`` (scalar or array)."""
        return self._vectorized(lambda a: self.point(a)[0], alpha)

    def eta(self, alpha):
        """Return the y coordinate of the profile point of slope ``alpha`` (scalar or array)."""
        return self._vectorized(lambda a: self.point(a)[1], alpha)

    def dxi(self, alpha):
        """Return d xi / d alpha = rho cos(alpha)."""
        return self._vectorized(lambda a: self.radius_of_curvature(a) * math.cos(a), alpha)

    def deta(self, alpha):
        """Return d eta / d alpha = rho sin(alpha)."""
        return self._vectorized(lambda a: self.radius_of_curvature(a) * math.sin(a), alpha)

    @staticmethod
    def _vectorized(fun: Callable[[float], float], alpha):
        if np.ndim(alpha) == 0:
            return fun(float(alpha))
        return np.array([fun(float(a)) for a in np.ravel(alpha)]).reshape(np.shape(alpha))

    def in_domain(self, alpha: float) -> bool:
        return self.alpha_min < alpha < self.alpha_max

    def alpha_at_x(self, x: float) -> float:
        """
        Return the slope alpha with xi(alpha) = x (xi increases: the profile is a graph over x).

        Raises :class:`ParameterError` when no point of the profile has that abscissa.
        """
        lo, hi = self._open_bracket()
        if not (self.point(lo)[0] < x < self.point(hi)[0]):
            raise ParameterError(f"{self.name}: no profile point at x = {x!r}")
        return brentq(lambda a: self.point(a)[0] - x, lo, hi, xtol=1e-15, rtol=1e-15)

    def height_at_x(self, x: float) -> float:
        """Return eta at abscissa x (the profile as a graph y(x)); ParameterError if no point."""
        return self.point(self.alpha_at_x(x))[1]

    def alpha_at_height(self, y: float, side: int) -> float:
        """Return the slope alpha on the right (side=+1) or left (side=-1) flank at eta = y."""
        lo, hi = self._open_bracket()
        a_min = self.lowest_alpha()
        a0, a1 = (a_min, hi) if side > 0 else (lo, a_min)
        g = lambda a: self.point(a)[1] - y  # noqa: E731
        if not (g(a0) <= 0.0 <= g(a1) or g(a1) <= 0.0 <= g(a0)):
            raise ParameterError(
                f"{self.name}: the {'right' if side > 0 else 'left'} flank does not reach "
                f"height {y!r}"
            )
        return brentq(g, a0, a1, xtol=1e-15, rtol=1e-15)

    def lowest_alpha(self) -> float:
        """Slope of the lowest point (alpha = 0 unless the profile is rotated)."""
        return 0.0

    def _open_bracket(self) -> Tuple[float, float]:
        eps = 1e-9
        return self.alpha_min + eps, self.alpha_max - eps

    def placed(self, x: float = 0.0, y: float = 0.0, rotation: float = 0.0) -> "ConvexProfile":
        """
        Return this profile moved rigidly.

        It is rotated by ``rotation`` [rad] about its own origin, then translated by (x, y).
        """
        if x == 0.0 and y == 0.0 and rotation == 0.0:
            return self
        return PlacedProfile(self, x, y, rotation)

    def describe(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        return f"{self.name}({args})"


#: sizes of a profile (radii, semi-axes, the catenary's c, 1/k of the parabola) in whisker lengths:
#: outside this range the shape is degenerate for the model (a wall of zero width, a flat plane)
SIZE_RANGE = (1e-6, 1e6)


def _positive(profile: str, name: str, value: float, inverse: bool = False) -> float:
    """Check a shape size within SIZE_RANGE (``inverse``: curvature-like, 1/value in range)."""
    value = float(value)
    lo, hi = SIZE_RANGE
    if inverse:
        lo, hi = 1.0 / hi, 1.0 / lo
    if not (math.isfinite(value) and lo <= value <= hi):
        raise ParameterError(
            f"{profile}: {name} = {value!r} is not allowed; {name} must be > 0, within "
            f"[{lo:g}, {hi:g}] (in units of the whisker's length)"
        )
    return value


def _p0(profile: str, value: float, scan: bool = True) -> float:
    value = float(value)
    if not scan:
        if not math.isfinite(value):
            raise ParameterError(f"{profile}: p0 = {value!r} must be finite")
        return value
    if not (math.isfinite(value) and 0.0 < value < 1.0):
        raise ParameterError(
            f"{profile}: p0 = {value!r} is not allowed; p0 (apex height over the foot's line, in "
            "whisker lengths) must be in (0, 1)"
        )
    return value


def _reaches_height_one(profile: str, what: str, height: float, scan: bool = True) -> None:
    if scan and not height > 1.0:
        raise ParameterError(
            f"{profile}: {what} = {height!r} must exceed 1 (the whisker's length): the model "
            "assumes the profile reaches height 1 on both sides"
        )


@dataclass(frozen=True)
class Parabola(ConvexProfile):
    """
    y = p0 + k x^2 / 2; xi = tan(a)/k, eta = p0 + tan(a)^2/(2k) (the paper's example, k = 1).

    Parameters
    ----------
    p0 : float
        The apex height over the foot's line [L]; in (0, 1) with ``scan_checks``.
    k : float, optional
        The curvature at the apex [1/L]; 1/k within [1e-6, 1e6].
    scan_checks : bool, optional
        Enforce the paper's scan set-up (p0 in (0, 1), the profile reaching height 1 on both
        sides); without it only the shape is validated (see :func:`make_profile`).

    Raises
    ------
    ParameterError
        When a parameter is out of its range.

    """

    p0: float
    k: float = 1.0
    scan_checks: bool = field(default=True, repr=False, compare=False)
    name: ClassVar[str] = "parabola"

    def __post_init__(self):
        object.__setattr__(self, "p0", _p0(self.name, self.p0, self.scan_checks))
        object.__setattr__(self, "k", _positive(self.name, "k", self.k, inverse=True))

    @property
    def params(self):
        return {"p0": self.p0, "k": self.k}

    def point(self, alpha):
        t = math.tan(alpha)
        return t / self.k, self.p0 + 0.5 * t * t / self.k

    def radius_of_curvature(self, alpha):
        c = math.cos(alpha)
        return 1.0 / (self.k * c * c * c)

    def alpha_at_x(self, x):
        return math.atan(self.k * x)

    def height_at_x(self, x):
        return self.p0 + 0.5 * self.k * x * x


@dataclass(frozen=True)
class Catenary(ConvexProfile):
    """
    y = p0 + c (cosh(x/c) - 1); xi = c asinh(tan a), eta = p0 + c (sec a - 1).

    Parameters
    ----------
    p0 : float
        The apex height over the foot's line [L]; in (0, 1) with ``scan_checks``.
    c : float
        The catenary's parameter, its radius of curvature at the apex [L]; within [1e-6, 1e6].
    scan_checks : bool, optional
        Enforce the paper's scan set-up (p0 in (0, 1), the profile reaching height 1 on both
        sides); without it only the shape is validated (see :func:`make_profile`).

    Raises
    ------
    ParameterError
        When a parameter is out of its range.

    """

    p0: float
    c: float
    scan_checks: bool = field(default=True, repr=False, compare=False)
    name: ClassVar[str] = "catenary"

    def __post_init__(self):
        object.__setattr__(self, "p0", _p0(self.name, self.p0, self.scan_checks))
        object.__setattr__(self, "c", _positive(self.name, "c", self.c))

    @property
    def params(self):
        return {"p0": self.p0, "c": self.c}

    def point(self, alpha):
        return (self.c * math.asinh(math.tan(alpha)),
                self.p0 + self.c * (1.0 / math.cos(alpha) - 1.0))

    def radius_of_curvature(self, alpha):
        c = math.cos(alpha)
        return self.c / (c * c)

    def alpha_at_x(self, x):
        # atan(sinh(u)) is the Gudermannian gd(u) = 2 atan(tanh(u/2)): the same value without
        # sinh's overflow for |u| > 710 (far from a narrow catenary)
        return 2.0 * math.atan(math.tanh(0.5 * x / self.c))

    def height_at_x(self, x):
        u = abs(x) / self.c
        if u > 700.0:  # cosh overflows: the profile is higher than any whisker there
            return math.inf
        return self.p0 + self.c * (math.cosh(u) - 1.0)


@dataclass(frozen=True)
class Circle(ConvexProfile):
    """
    Lower arc of the circle of radius R centred at (0, p0 + R): (R sin a, p0 + R(1 - cos a)).

    Parameters
    ----------
    p0 : float
        The apex height over the foot's line [L]; in (0, 1) with ``scan_checks``.
    R : float
        The radius [L]; within [1e-6, 1e6], and p0 + R > 1 with ``scan_checks``.
    scan_checks : bool, optional
        Enforce the paper's scan set-up (p0 in (0, 1), the profile reaching height 1 on both
        sides); without it only the shape is validated (see :func:`make_profile`).

    Raises
    ------
    ParameterError
        When a parameter is out of its range.

    """

    p0: float
    R: float
    scan_checks: bool = field(default=True, repr=False, compare=False)
    name: ClassVar[str] = "circle"

    def __post_init__(self):
        object.__setattr__(self, "p0", _p0(self.name, self.p0, self.scan_checks))
        object.__setattr__(self, "R", _positive(self.name, "R", self.R))
        _reaches_height_one(self.name, "p0 + R", self.p0 + self.R, self.scan_checks)

    @property
    def params(self):
        return {"p0": self.p0, "R": self.R}

    def point(self, alpha):
        return self.R * math.sin(alpha), self.p0 + self.R * (1.0 - math.cos(alpha))

    def radius_of_curvature(self, alpha):
        return self.R

    def alpha_at_x(self, x):
        if not abs(x) < self.R:
            raise ParameterError(f"{self.name}: no profile point at x = {x!r}")
        return math.asin(x / self.R)


@dataclass(frozen=True)
class TwoCircles(ConvexProfile):
    """
    Two circular arcs tangent to y = p0 at x = 0 (the paper's asymmetric example, Fig. 2.4).

    The left arc (radius R_left) for x < 0, the right arc (radius R_right) for x >= 0.

    Parameters
    ----------
    p0 : float
        The apex height over the foot's line [L]; in (0, 1) with ``scan_checks``.
    R_left, R_right : float
        The radii of the left and the right arc [L]; within [1e-6, 1e6], and p0 + R > 1 with
        ``scan_checks``.
    scan_checks : bool, optional
        Enforce the paper's scan set-up (p0 in (0, 1), the profile reaching height 1 on both
        sides); without it only the shape is validated (see :func:`make_profile`).

    Raises
    ------
    ParameterError
        When a parameter is out of its range.

    """

    p0: float
    R_left: float
    R_right: float
    scan_checks: bool = field(default=True, repr=False, compare=False)
    name: ClassVar[str] = "two_circles"

    def __post_init__(self):
        object.__setattr__(self, "p0", _p0(self.name, self.p0, self.scan_checks))
        object.__setattr__(self, "R_left", _positive(self.name, "R_left", self.R_left))
        object.__setattr__(self, "R_right", _positive(self.name, "R_right", self.R_right))
        _reaches_height_one(self.name, "p0 + R_left", self.p0 + self.R_left, self.scan_checks)
        _reaches_height_one(self.name, "p0 + R_right", self.p0 + self.R_right, self.scan_checks)

    @property
    def params(self):
        return {"p0": self.p0, "R_left": self.R_left, "R_right": self.R_right}

    def radius_of_curvature(self, alpha):
        return self.R_right if alpha >= 0.0 else self.R_left

    def point(self, alpha):
        r = self.radius_of_curvature(alpha)
        return r * math.sin(alpha), self.p0 + r * (1.0 - math.cos(alpha))

    def alpha_at_x(self, x):
        r = self.R_right if x >= 0.0 else self.R_left
        if not abs(x) < r:
            raise ParameterError(f"{self.name}: no profile point at x = {x!r}")
        return math.asin(x / r)


@dataclass(frozen=True)
class Ellipse(ConvexProfile):
    """
    Lower arc of the ellipse with semi-axes a (x) and b (y) centred at (0, p0 + b).

    The point of outward normal (sin a, -cos a) is (a^2 sin, p0 + b - b^2 cos) / D with
    D = sqrt(a^2 sin^2 + b^2 cos^2); rho = (a b)^2 / D^3.

    Parameters
    ----------
    p0 : float
        The apex height over the foot's line [L]; in (0, 1) with ``scan_checks``.
    a, b : float
        The semi-axes along x and along y [L]; within [1e-6, 1e6], and p0 + b > 1 with
        ``scan_checks``.
    scan_checks : bool, optional
        Enforce the paper's scan set-up (p0 in (0, 1), the profile reaching height 1 on both
        sides); without it only the shape is validated (see :func:`make_profile`).

    Raises
    ------
    ParameterError
        When a parameter is out of its range.

    """

    p0: float
    a: float
    b: float
    scan_checks: bool = field(default=True, repr=False, compare=False)
    name: ClassVar[str] = "ellipse"

    def __post_init__(self):
        object.__setattr__(self, "p0", _p0(self.name, self.p0, self.scan_checks))
        object.__setattr__(self, "a", _positive(self.name, "a", self.a))
        object.__setattr__(self, "b", _positive(self.name, "b", self.b))
        _reaches_height_one(self.name, "p0 + b", self.p0 + self.b, self.scan_checks)

    @property
    def params(self):
        return {"p0": self.p0, "a": self.a, "b": self.b}

    def _d(self, alpha):
        s, c = math.sin(alpha), math.cos(alpha)
        return s, c, math.hypot(self.a * s, self.b * c)

    def point(self, alpha):
        s, c, d = self._d(alpha)
        return self.a * self.a * s / d, self.p0 + self.b - self.b * self.b * c / d

    def radius_of_curvature(self, alpha):
        _, _, d = self._d(alpha)
        ab = self.a * self.b
        return ab * ab / (d * d * d)

    def alpha_at_x(self, x):
        if not abs(x) < self.a:
            raise ParameterError(f"{self.name}: no profile point at x = {x!r}")
        return math.atan(x * self.b / (self.a * math.sqrt(self.a * self.a - x * x)))


@dataclass(frozen=True)
class PlacedProfile(ConvexProfile):
    """
    A profile moved by a planar rigid motion.

    It is rotated by ``rotation`` about its own origin, then translated by (x, y). The slope of
    every point shifts by ``rotation``.

    Parameters
    ----------
    base : ConvexProfile
        The profile moved.
    x, y : float, optional
        The translation [L].
    rotation : float, optional
        The rotation about the base profile's origin [rad], counter-clockwise.

    Raises
    ------
    ParameterError
        When x, y or rotation is not finite.

    """

    base: ConvexProfile
    x: float = 0.0
    y: float = 0.0
    rotation: float = 0.0
    _cos: float = field(init=False, repr=False)
    _sin: float = field(init=False, repr=False)

    def __post_init__(self):
        for key in ("x", "y", "rotation"):
            value = float(getattr(self, key))
            if not math.isfinite(value):
                raise ParameterError(f"placement: {key} = {value!r} must be finite")
            object.__setattr__(self, key, value)
        object.__setattr__(self, "_cos", math.cos(self.rotation))
        object.__setattr__(self, "_sin", math.sin(self.rotation))
        object.__setattr__(self, "alpha_min", self.base.alpha_min + self.rotation)
        object.__setattr__(self, "alpha_max", self.base.alpha_max + self.rotation)

    @property
    def name(self):  # type: ignore[override]
        return self.base.name

    @property
    def params(self):
        return dict(self.base.params)

    def point(self, alpha):
        bx, by = self.base.point(alpha - self.rotation)
        return self.x + self._cos * bx - self._sin * by, self.y + self._sin * bx + self._cos * by

    def radius_of_curvature(self, alpha):
        return self.base.radius_of_curvature(alpha - self.rotation)

    def lowest_alpha(self):
        return self.base.lowest_alpha() + self.rotation

    def alpha_at_x(self, x):
        if self.rotation == 0.0:
            return self.base.alpha_at_x(x - self.x)
        return super().alpha_at_x(x)

    def placed(self, x=0.0, y=0.0, rotation=0.0):
        c, s = math.cos(rotation), math.sin(rotation)
        return PlacedProfile(
            self.base, x + c * self.x - s * self.y, y + s * self.x + c * self.y,
            self.rotation + rotation
        )

    def describe(self):
        return (f"{self.base.describe()} placed at ({self.x!r}, {self.y!r}) "
                f"rotated {self.rotation!r} rad")


@dataclass(frozen=True)
class Peg(ConvexProfile):
    """
    A peg (pole): the disk of radius r >= 0 centred at (x, y); r = 0 is a point.

    Every slope occurs on a disk: the point of outward normal (sin a, -cos a) is
    (x + r sin a, y - r cos a), rho = r; a whisker may touch it anywhere, side first or tip first.
    A point (r = 0) takes side contact only: a tip that reaches it slips off (a snap).

    Parameters
    ----------
    x, y : float
        The centre [L].
    r : float, optional
        The radius [L], >= 0; 0 is a point.
    scan_checks : bool, optional
        Accepted like every profile's (:func:`make_profile` passes it); a peg has no apex
        height or reach to check.

    Raises
    ------
    ParameterError
        When x, y or r is not finite, or r < 0.

    """

    x: float
    y: float
    r: float = 0.0
    scan_checks: bool = field(default=True, repr=False, compare=False)
    name: ClassVar[str] = "peg"
    alpha_min: ClassVar[float] = -math.inf
    alpha_max: ClassVar[float] = math.inf

    def __post_init__(self):
        for key in ("x", "y", "r"):
            value = float(getattr(self, key))
            if not math.isfinite(value):
                raise ParameterError(f"{self.name}: {key} = {value!r} must be finite")
            object.__setattr__(self, key, value)
        if self.r < 0.0:
            raise ParameterError(
                f"{self.name}: r = {self.r!r} is not allowed; the radius r must be >= 0")

    @property
    def params(self):
        return {"x": self.x, "y": self.y, "r": self.r}

    @property
    def is_point(self) -> bool:
        return self.r == 0.0

    def point(self, alpha):
        return self.x + self.r * math.sin(alpha), self.y - self.r * math.cos(alpha)

    def radius_of_curvature(self, alpha):
        return self.r

    def signed_distance(self, px, py):
        """Distance from points to the peg's boundary (negative inside); arrays allowed."""
        return np.hypot(np.asarray(px) - self.x, np.asarray(py) - self.y) - self.r

    def normal_slope(self, px: float, py: float) -> float:
        """Return the slope alpha of the boundary point nearest to (px, py) (normal towards it)."""
        return math.atan2(px - self.x, -(py - self.y))

    def alpha_at_x(self, x):
        raise ParameterError(f"{self.name}: a peg is not a graph over x")

    def placed(self, x=0.0, y=0.0, rotation=0.0):
        c, s = math.cos(rotation), math.sin(rotation)
        return Peg(x + c * self.x - s * self.y, y + s * self.x + c * self.y, self.r,
                   self.scan_checks)


#: profile classes by their contract names
PROFILES: Dict[str, type] = {
    cls.name: cls for cls in (Parabola, Catenary, Circle, TwoCircles, Ellipse, Peg)
}

#: parameter names of each profile, in contract order, with defaults where the paper gives one
PROFILE_PARAMETERS: Dict[str, Dict[str, float | None]] = {
    "parabola": {"p0": None, "k": 1.0},
    "catenary": {"p0": None, "c": None},
    "circle": {"p0": None, "R": None},
    "two_circles": {"p0": None, "R_left": None, "R_right": None},
    "ellipse": {"p0": None, "a": None, "b": None},
    "peg": {"x": None, "y": None, "r": 0.0},
}


def make_profile(name: str, params: Mapping[str, float],
                 scan_checks: bool = True) -> ConvexProfile:
    """
    Build a profile from its contract name and parameters, with errors that say what is allowed.

    Parameters
    ----------
    name : str
        The contract name: ``parabola``, ``catenary``, ``circle``, ``two_circles``, ``ellipse`` or
        ``peg``.
    params : mapping of str to float
        The profile's parameters by their contract names; a parameter the paper gives a default
        for (the parabola's k = 1, the peg's r = 0) may be left out.
    scan_checks : bool, optional
        Enforce the paper's scan set-up (p0 in (0, 1), the profile reaching height 1 on both
        sides, relative to a foot on the x-axis); without it only the shape is validated and p0
        is simply the apex height (used where the foot moves freely in the plane, e.g. the ROS
        node).

    Returns
    -------
    ConvexProfile
        The profile, an instance of the class of that name.

    Raises
    ------
    ParameterError
        For an unknown profile name, an unknown or missing parameter, or a parameter out of its
        range; the message says what is allowed.

    """
    if name not in PROFILES:
        raise ParameterError(f"unknown profile {name!r}; allowed: {', '.join(PROFILES)}")
    allowed = PROFILE_PARAMETERS[name]
    unknown = sorted(set(params) - set(allowed))
    if unknown:
        raise ParameterError(
            f"{name}: unknown parameter(s) {', '.join(unknown)}; allowed: {', '.join(allowed)}"
        )
    values = {}
    for key, default in allowed.items():
        if key in params:
            values[key] = float(params[key])
        elif default is not None:
            values[key] = default
        else:
            raise ParameterError(f"{name}: parameter {key} is required ({', '.join(allowed)})")
    return PROFILES[name](**values, scan_checks=scan_checks)
