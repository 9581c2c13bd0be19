"""
Boundary features of scene obstacles: smooth arcs and corners (vertices), world frame.

Every obstacle's boundary is a chain of smooth *arcs* joined at *vertices* (corners). An arc is
parametrized by a real parameter u and oriented so that the obstacle lies to the LEFT of its
direction of travel (cos phi, sin phi):

    point(u) = (x(u), y(u)),  d point/du = speed(u) (cos phi(u), sin phi(u)),  speed > 0,
    outward normal n(u) = (sin phi, -cos phi)   (the direction of a frictionless contact force
                                                 on the whisker),
    curvature of the boundary = dphi/du / speed (> 0 where the obstacle is locally convex).

This is the convention of the convex profiles (``profiles.py``): there u is the slope alpha,
phi = alpha, speed = rho(alpha). A vertex joins an incoming arc (tangent angle ``phi_in``) to
an outgoing one (``phi_out``); it is convex (touchable from outside) when the left turn
phi_out - phi_in lies in (0, pi], and its normal cone is the set of outward normals
(sin phi, -cos phi) for phi in [phi_in, phi_out] (a vertex is the limit of a rounded corner).
A point peg is a vertex with the full cone (phi_out = phi_in + 2 pi).

Lengths are in whisker lengths L (dimensionless), like the rest of the core.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Optional, Tuple

import numpy as np
from scipy.interpolate import CubicSpline

from ..errors import ParameterError
from ..profiles import ConvexProfile, PlacedProfile, TwoCircles

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class ArcPoint:
    """
    An arc's geometry at one parameter value.

    ``x, y`` the point, ``phi`` the tangent angle (obstacle to the left), ``dphi`` = dphi/du,
    ``speed`` = d(arc length)/du > 0.
    """

    x: float
    y: float
    phi: float
    dphi: float
    speed: float

    @property
    def normal(self) -> Tuple[float, float]:
        """Return the outward unit normal, (sin phi, -cos phi)."""
        return math.sin(self.phi), -math.cos(self.phi)

    @property
    def tangent(self) -> Tuple[float, float]:
        """Return the unit tangent, (cos phi, sin phi): the obstacle is to its left."""
        return math.cos(self.phi), math.sin(self.phi)


class Arc:
    """
    Base class of a smooth boundary arc on [u_min, u_max] (infinite ends allowed).

    ``periodic`` arcs (a peg's circle) accept every real u (period ``u_max - u_min``).
    Subclasses implement :meth:`at`; :meth:`sigma_between` integrates the speed.
    """

    u_min: float = -math.inf
    u_max: float = math.inf
    periodic: bool = False

    def at(self, u: float) -> ArcPoint:
        """Return the geometry at scalar parameter ``u``."""
        raise NotImplementedError

    def contains(self, u: float) -> bool:
        """Tell whether ``u`` is a point of the arc (its closed parameter interval)."""
        return self.periodic or self.u_min <= u <= self.u_max

    def sigma_between(self, u_a: float, u_b: float) -> float:
        """
        Arc length from u_a to u_b (negative when u_b < u_a): Gauss-Legendre, 48 points.

        The interval is split at the arc's :meth:`breaks` (where the speed is not smooth, e.g. a
        spline's knots), so every piece is integrated to rounding.
        """
        if u_a == u_b:
            return 0.0
        lo, hi = min(u_a, u_b), max(u_a, u_b)
        cuts = [lo] + [b for b in self.breaks() if lo < b < hi] + [hi]
        total = sum(self._gauss_length(a, b) for a, b in zip(cuts[:-1], cuts[1:]))
        return float(total if u_b > u_a else -total)

    def breaks(self) -> Tuple[float, ...]:
        """Parameters where the speed is not smooth (none for an analytic arc)."""
        return ()

    def _gauss_length(self, a: float, b: float) -> float:
        x, w = _gauss()
        half = 0.5 * (b - a)
        u = a + half * (x + 1.0)
        return float(half * sum(wi * self.at(float(ui)).speed for ui, wi in zip(u, w)))

    def project(self, x: float, y: float) -> Tuple[float, float]:
        """
        Return (u, d): the arc's point nearest to (x, y) and its signed distance along the normal.

        d > 0 on the outer side (away from the obstacle). Seeded on a grid of the arc's range (or
        a window about the point for unbounded arcs), refined by Newton on the foot-point
        condition (p - point(u)) . t(u) = 0, and clamped to the arc's ends.
        """
        lo, hi = self._seed_range(x, y)
        grid = np.linspace(lo, hi, 65)
        best = min(grid, key=lambda u: _dist2(self.at(float(u)), x, y))
        u = float(best)
        for _ in range(40):
            p = self.at(u)
            c, s = math.cos(p.phi), math.sin(p.phi)
            dx, dy = x - p.x, y - p.y
            g = dx * c + dy * s  # (p - b) . t
            d = dx * s - dy * c  # (p - b) . n
            dg = -p.speed + d * p.dphi  # d/du of (p - b) . t
            if dg >= 0.0:
                break
            step = -g / dg
            d2 = dx * dx + dy * dy
            for _ in range(30):  # damped: the distance must not grow
                u_new = u + step
                if not self.periodic:
                    u_new = min(max(u_new, self._lo), self._hi)
                q = self.at(u_new)
                if math.isfinite(q.x) and _dist2(q, x, y) <= d2 * (1.0 + 1e-12):
                    break
                step *= 0.5
            else:
                break
            if abs(u_new - u) <= 1e-15 * max(1.0, abs(u)):
                u = u_new
                break
            u = u_new
        p = self.at(u)
        return u, (x - p.x) * math.sin(p.phi) - (y - p.y) * math.cos(p.phi)

    @property
    def _lo(self) -> float:
        """Smallest parameter used numerically (open ends are at infinity for profiles)."""
        return self.u_min + 1e-9 * max(1.0, abs(self.u_min))

    @property
    def _hi(self) -> float:
        return self.u_max - 1e-9 * max(1.0, abs(self.u_max))

    def _seed_range(self, x: float, y: float) -> Tuple[float, float]:
        lo, hi = self._lo, self._hi
        if not math.isfinite(lo):
            lo = -0.5 * math.pi + 1e-9
        if not math.isfinite(hi):
            hi = 0.5 * math.pi - 1e-9
        return lo, hi

    def sample(self, n: int, u_from: Optional[float] = None,
               u_to: Optional[float] = None) -> np.ndarray:
        """``n`` points of the arc from u_from to u_to (default: its finite range), (n, 2)."""
        a = self.u_min if u_from is None else u_from
        b = self.u_max if u_to is None else u_to
        if not (math.isfinite(a) and math.isfinite(b)):
            raise ValueError("an infinite arc needs an explicit parameter range to sample")
        return np.array([(p.x, p.y) for p in (self.at(float(u)) for u in np.linspace(a, b, n))])


def _dist2(p: ArcPoint, x: float, y: float) -> float:
    return (p.x - x) ** 2 + (p.y - y) ** 2


@lru_cache(maxsize=1)
def _gauss():
    return np.polynomial.legendre.leggauss(48)


@dataclass(frozen=True)
class CircleArc(Arc):
    """A full circle of radius r > 0 about (cx, cy), counter-clockwise: u = phi (periodic)."""

    cx: float
    cy: float
    r: float
    u_min: float = field(default=-math.pi, init=False)
    u_max: float = field(default=math.pi, init=False)
    periodic: bool = field(default=True, init=False)

    def __post_init__(self):
        if not self.r > 0.0:
            raise ParameterError(f"circle arc: radius {self.r!r} must be > 0")

    def at(self, u):
        s, c = math.sin(u), math.cos(u)
        return ArcPoint(self.cx + self.r * s, self.cy - self.r * c, u, 1.0, self.r)

    def sigma_between(self, u_a, u_b):
        return self.r * (u_b - u_a)

    def project(self, x, y):
        u = math.atan2(x - self.cx, -(y - self.cy))
        return u, math.hypot(x - self.cx, y - self.cy) - self.r


@dataclass(frozen=True)
class SegmentArc(Arc):
    """The straight edge from (x0, y0) to (x1, y1), obstacle to its left: u = arc length."""

    x0: float
    y0: float
    x1: float
    y1: float
    u_min: float = field(default=0.0, init=False)
    u_max: float = field(init=False)
    _phi: float = field(init=False, repr=False)

    def __post_init__(self):
        length = math.hypot(self.x1 - self.x0, self.y1 - self.y0)
        if not length > 0.0:
            raise ParameterError("segment arc: its two ends coincide")
        object.__setattr__(self, "u_max", length)
        object.__setattr__(self, "_phi", math.atan2(self.y1 - self.y0, self.x1 - self.x0))

    def at(self, u):
        c, s = math.cos(self._phi), math.sin(self._phi)
        return ArcPoint(self.x0 + u * c, self.y0 + u * s, self._phi, 0.0, 1.0)

    def sigma_between(self, u_a, u_b):
        return u_b - u_a

    def project(self, x, y):
        c, s = math.cos(self._phi), math.sin(self._phi)
        u = min(max((x - self.x0) * c + (y - self.y0) * s, 0.0), self.u_max)
        p = self.at(u)
        return u, (x - p.x) * s - (y - p.y) * c


@dataclass(frozen=True)
class RayArc(Arc):
    """
    A half-line through (x, y) of direction phi, obstacle to its left: u = signed arc length.

    ``incoming``: the ray comes from infinity and ends at (x, y) (u <= 0); otherwise it starts
    there and goes to infinity (u >= 0). The straight walls of a profile's strip are rays.
    """

    x: float
    y: float
    phi: float
    incoming: bool = False
    u_min: float = field(init=False)
    u_max: float = field(init=False)

    def __post_init__(self):
        object.__setattr__(self, "u_min", -math.inf if self.incoming else 0.0)
        object.__setattr__(self, "u_max", 0.0 if self.incoming else math.inf)

    def at(self, u):
        c, s = math.cos(self.phi), math.sin(self.phi)
        return ArcPoint(self.x + u * c, self.y + u * s, self.phi, 0.0, 1.0)

    def project(self, x, y):
        c, s = math.cos(self.phi), math.sin(self.phi)
        u = min(max((x - self.x) * c + (y - self.y) * s, self.u_min), self.u_max)
        p = self.at(u)
        return u, (x - p.x) * s - (y - p.y) * c

    def sigma_between(self, u_a, u_b):
        return u_b - u_a


@dataclass(frozen=True)
class ProfileArc(Arc):
    """A (placed) convex profile of ``profiles.py``: u = its slope alpha, speed = rho(alpha)."""

    profile: ConvexProfile
    u_min: float = field(init=False)
    u_max: float = field(init=False)

    def __post_init__(self):
        object.__setattr__(self, "u_min", float(self.profile.alpha_min))
        object.__setattr__(self, "u_max", float(self.profile.alpha_max))

    def at(self, u):
        x, y = self.profile.point(u)
        return ArcPoint(float(x), float(y), u, 1.0, float(self.profile.radius_of_curvature(u)))

    def breaks(self):
        """Return the slope where two circles meet (their radii differ there), else none."""
        prof, shift = self.profile, 0.0
        while isinstance(prof, PlacedProfile):
            prof, shift = prof.base, shift + prof.rotation
        return (shift,) if isinstance(prof, TwoCircles) else ()


@dataclass(frozen=True)
class GraphArc(Arc):
    """
    The graph y = g(x) of a natural cubic spline through ``points`` (x strictly increasing).

    Beyond the first and last points it goes on along its end tangents (a natural spline's
    second derivative vanishes there, so the continuation is C2). ``side`` "above": the obstacle
    is the region above the graph, u = x; "below": the region below, u = -x (so that the
    obstacle stays to the left of the direction of travel).
    """

    points: Tuple[Tuple[float, float], ...]
    side: str = "above"
    u_min: float = field(default=-math.inf, init=False)
    u_max: float = field(default=math.inf, init=False)
    _spline: CubicSpline = field(init=False, repr=False, compare=False)
    _knots: Tuple[float, ...] = field(init=False, repr=False, compare=False)
    _pieces: Tuple[Tuple[float, float, float, float], ...] = field(init=False, repr=False,
                                                                   compare=False)

    def __post_init__(self):
        pts = np.asarray(self.points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
            raise ParameterError("curve: needs at least 3 points [x, y]")
        if not np.all(np.diff(pts[:, 0]) > 0.0):
            raise ParameterError("curve: point x values must be strictly increasing")
        if self.side not in ("above", "below"):
            raise ParameterError(f"curve: side {self.side!r} must be 'above' or 'below'")
        sp = CubicSpline(pts[:, 0], pts[:, 1], bc_type="natural")
        object.__setattr__(self, "_spline", sp)
        # the pieces as plain floats: evaluated by Horner's rule without scipy's call overhead
        object.__setattr__(self, "_knots", tuple(float(k) for k in sp.x))
        object.__setattr__(self, "_pieces", tuple(tuple(float(v) for v in col) for col in sp.c.T))

    def height(self, x: float) -> Tuple[float, float, float]:
        """Return g(x), g'(x), g''(x), continued linearly beyond the end points."""
        knots = self._knots
        xe = min(max(x, knots[0]), knots[-1])
        i = min(max(bisect_right(knots, xe) - 1, 0), len(knots) - 2)
        t = xe - knots[i]
        a0, a1, a2, a3 = self._pieces[i]
        g = ((a0 * t + a1) * t + a2) * t + a3
        d1 = (3.0 * a0 * t + 2.0 * a1) * t + a2
        if x != xe:
            return g + d1 * (x - xe), d1, 0.0
        return g, d1, 6.0 * a0 * t + 2.0 * a1

    def breaks(self):
        """Return the spline's knots (in u)."""
        knots = self._spline.x if self.side == "above" else -self._spline.x[::-1]
        return tuple(float(k) for k in knots)

    def _seed_range(self, x, y):
        u = x if self.side == "above" else -x
        sp = self._spline
        span = float(sp.x[-1] - sp.x[0])
        g = self.height(x)[0]
        reach = abs(y - g) + 0.05 * span
        return u - reach, u + reach

    def at(self, u):
        x = u if self.side == "above" else -u
        g, d1, d2 = self.height(x)
        q = 1.0 + d1 * d1
        speed = math.sqrt(q)
        if self.side == "above":
            return ArcPoint(x, g, math.atan(d1), d2 / q, speed)
        return ArcPoint(x, g, math.atan(d1) + math.pi, -d2 / q, speed)


@dataclass(frozen=True)
class Vertex:
    """
    A corner at (x, y), where two arcs meet.

    The arc ending there has the tangent angle ``phi_in``, the one starting there ``phi_out``.

    ``phi_out - phi_in`` is the left turn in (-pi, pi] (2 pi for a point peg). Convex corners
    (turn > 0) can be touched from outside; the contact force lies in the normal cone
    {(sin phi, -cos phi): phi in [phi_in, phi_out]}.
    """

    x: float
    y: float
    phi_in: float
    phi_out: float

    @property
    def turn(self) -> float:
        return self.phi_out - self.phi_in

    @property
    def convex(self) -> bool:
        return self.turn > 0.0

    def in_cone(self, fx: float, fy: float, widen: float = 0.0) -> bool:
        """Tell whether the force (fx, fy) on the whisker is in the normal cone (+- widen rad)."""
        if self.turn >= TWO_PI:
            return True
        phi = math.atan2(fx, -fy)  # (sin phi, -cos phi) ~ (fx, fy)
        mid = 0.5 * (self.phi_in + self.phi_out)
        d = math.remainder(phi - mid, TWO_PI)
        return abs(d) <= 0.5 * self.turn + widen
