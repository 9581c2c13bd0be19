"""
Scenes: several obstacles in the world frame, their validation and their geometry.

An obstacle is an immutable value with a ``kind`` ("peg", "polygon", "curve" or a profile
family of :mod:`profiles`), a ``name`` ("peg0", "polygon1", ...), its shape ``params``, its own
Coulomb ``friction`` (None: the scene's) and its boundary as :mod:`boundary` features: smooth
``arcs`` joined at ``vertices`` (corners), oriented so that the obstacle lies to the LEFT of
each arc's direction of travel.

- :class:`PegObstacle` (x, y, r >= 0): a :class:`~boundary.CircleArc`, or for r = 0 a point,
  one vertex with the full cone (turn 2 pi) and no arc.
- :class:`PolygonObstacle` (vertices, closed, convex or not): counter-clockwise
  :class:`~boundary.SegmentArc` edges, one :class:`~boundary.Vertex` per corner (convex or
  reflex), ``vertex_arcs[i]`` = (incoming edge, outgoing edge) of corner i.
- :class:`CurveObstacle` (points with strictly increasing x, side above/below): the region
  above/below the natural cubic spline through the points continued along its end tangents,
  one :class:`~boundary.GraphArc`.
- :class:`ProfileObstacle` (a profile family, placed by a rigid motion): the region above the
  profile's curve (for the circle, ellipse and two circles: the strip above the lower arc, as the
  single-obstacle tracker has it), one :class:`~boundary.ProfileArc` plus the strip's two
  straight walls as :class:`~boundary.RayArc` where the profile ends at a finite point.

Geometric queries (all exact to rounding; the solvers locate touches by root finding on them):
``signed_distance(points)`` (Euclidean distance to the boundary, negative inside, vectorised),
``closest(x, y)`` (the nearest feature with its parameter), ``contains(x, y)``, and
``outline(n, window)`` (closed polygons for drawing; an infinite obstacle is cut at the window).

:class:`Scene` holds the obstacles and the global friction, validates them together (no overlaps)
and converts to and from plain dictionaries (the YAML format, :mod:`vibrissa_ros.scan.scene_file`).
Lengths are in whisker lengths L (dimensionless), like the rest of the core.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from .boundary import (
    Arc, CircleArc, GraphArc, ProfileArc, RayArc, SegmentArc, TWO_PI, Vertex,
)
from ..errors import InvalidPoseError, ParameterError
from ..profiles import PROFILE_PARAMETERS, SIZE_RANGE, ConvexProfile, Peg, make_profile

#: profile families an obstacle may be (the peg is its own obstacle type)
FAMILIES = tuple(name for name in PROFILE_PARAMETERS if name != "peg")
#: families whose curve ends at a finite point with a vertical tangent (their obstacle is the
#: strip above the lower arc, bounded by two straight walls)
STRIP_FAMILIES = ("circle", "two_circles", "ellipse")
#: obstacle types of a scene
OBSTACLE_TYPES = ("peg", "polygon", "curve") + FAMILIES

#: a window (x_min, y_min, x_max, y_max) [L]
Window = Tuple[float, float, float, float]

#: sub-intervals per spline piece for the bounds that screen a curve's pieces
_SUB = 8


@dataclass(frozen=True)
class Closest:
    """
    The boundary feature of an obstacle nearest to a point.

    Either an arc (``arc_index`` set, ``u`` its parameter) or a corner (``vertex_index`` set,
    ``u`` None). The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    distance : float
        The signed distance to the boundary [L], negative inside.
    x, y : float
        The nearest boundary point [L].
    feature : Arc or Vertex
        The nearest feature.
    arc_index : int or None, optional
        For an arc: its index into the obstacle's ``arcs``.
    u : float or None, optional
        For an arc: the nearest point's parameter on it; None at a corner.
    vertex_index : int or None, optional
        For a corner: its index into the obstacle's ``vertices``.

    """

    distance: float
    x: float
    y: float
    feature: Union[Arc, Vertex]
    arc_index: Optional[int] = None
    u: Optional[float] = None
    vertex_index: Optional[int] = None

    @property
    def on_vertex(self) -> bool:
        """Tell whether the nearest feature is a corner."""
        return self.vertex_index is not None


def _finite(what: str, key: str, value: Any) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{what}: {key} = {value!r} must be a number") from None
    if not math.isfinite(value):
        raise ParameterError(f"{what}: {key} = {value!r} must be finite")
    lo, hi = SIZE_RANGE
    if abs(value) > hi:
        raise ParameterError(f"{what}: {key} = {value!r} is too far; |{key}| must be <= {hi:g} L")
    return value


def _size(what: str, key: str, value: float) -> float:
    lo, hi = SIZE_RANGE
    if not lo <= value <= hi:
        raise ParameterError(
            f"{what}: {key} = {value!r} is not allowed; it must be within [{lo:g}, {hi:g}] (in "
            "units of the whisker's length)"
        )
    return value


def _friction(what: str, value: Any) -> Optional[float]:
    if value is None:
        return None
    try:
        mu = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{what}: friction = {value!r} must be a number") from None
    if not (math.isfinite(mu) and mu >= 0.0):
        raise ParameterError(
            f"{what}: friction = {mu!r} is not allowed; the Coulomb coefficient must be finite "
            "and >= 0")
    return mu


def _point_list(what: str, key: str, value: Any) -> Tuple[Tuple[float, float], ...]:
    try:
        pts = [tuple(p) for p in value]
    except TypeError:
        raise ParameterError(f"{what}: {key} must be a list of [x, y] points") from None
    if not all(len(p) == 2 for p in pts):
        raise ParameterError(f"{what}: {key} must be a list of [x, y] points")
    return tuple((_finite(what, f"{key}[{i}] x", p[0]), _finite(what, f"{key}[{i}] y", p[1]))
                 for i, p in enumerate(pts))


def _ray_distance(px, py, x0, y0, dx, dy, sign):
    """Distance from points to the ray (x0, y0) + tau (dx, dy), sign * tau >= 0 (unit dx, dy)."""
    tau = (px - x0) * dx + (py - y0) * dy
    tau = np.maximum(tau, 0.0) if sign > 0 else np.minimum(tau, 0.0)
    return np.hypot(px - (x0 + tau * dx), py - (y0 + tau * dy)), tau


class Obstacle:
    """
    Base class of a scene's obstacles (immutable values; see the module's docstring).

    Subclasses give ``kind``, ``params``, ``arcs``, ``vertices``, ``vertex_arcs``, ``bounded``,
    :meth:`signed_distance`, :meth:`closest`, :meth:`extent` and :meth:`_pieces`.
    """

    name: str
    friction: Optional[float]
    kind: str = "obstacle"
    bounded: bool = True

    # -- queries ------------------------------------------------------------------------------
    def signed_distance(self, points) -> np.ndarray:
        """Return the distances (m,) of points (m, 2) to the boundary, negative inside [L]."""
        raise NotImplementedError

    def closest(self, x: float, y: float) -> Closest:
        """Return the boundary feature nearest to (x, y), with the signed distance."""
        raise NotImplementedError

    def contains(self, x: float, y: float) -> bool:
        """Tell whether (x, y) lies strictly inside the obstacle."""
        return bool(self.signed_distance(np.array([[x, y]], dtype=float))[0] < 0.0)

    def extent(self) -> Window:
        """Bounding box of the obstacle's finite part (its data points for an infinite one)."""
        raise NotImplementedError

    def describe(self) -> str:
        """One line: name, kind, shape and friction."""
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        mu = "" if self.friction is None else f", friction={self.friction!r}"
        return f"{self.name}: {self.kind}({args}{mu})"

    @property
    def params(self) -> Dict[str, Any]:
        raise NotImplementedError

    def to_dict(self) -> Dict[str, Any]:
        """Return the obstacle as written in a scene file (``type`` first)."""
        out: Dict[str, Any] = {"type": self.kind, "name": self.name}
        out.update(self.params)
        if self.friction is not None:
            out["friction"] = self.friction
        return out

    # -- drawing ------------------------------------------------------------------------------
    def outline(self, n: int = 200, window: Optional[Window] = None) -> Tuple[np.ndarray, ...]:
        """
        Return closed polygons (k, 2) to fill, first point repeated last [L].

        An infinite obstacle needs ``window``: its boundary inside the window, closed along the
        window's edge on the obstacle's side. A point peg is one point (1, 2).
        """
        raise NotImplementedError

    def boundary_samples(self, n: int, window: Optional[Window] = None
                         ) -> List[Tuple[Optional[int], np.ndarray, np.ndarray]]:
        """
        Sample the boundary: per arc (arc index, parameters (k,), points (k, 2)).

        The corners are the ends of their arcs; a point peg is (None, empty, its point (1, 2)).
        Infinite arcs are sampled where they cross ``window`` (required then).
        """
        raise NotImplementedError

    def boundary_lines(self, n: int = 200, window: Optional[Window] = None
                       ) -> Tuple[np.ndarray, ...]:
        """
        Return the boundary as polylines (k, 2) in the arcs' order [L], for drawing.

        A bounded obstacle: one closed polyline (first point repeated; a point peg: its point,
        (1, 2)). An infinite one: its parts inside ``window``, cut at the window's edge.
        """
        pieces = sorted(self.boundary_samples(n, window), key=lambda item: item[0] or 0)
        pts = np.vstack([p for _, _, p in pieces])
        if self.bounded:
            if len(pts) > 1 and not np.array_equal(pts[0], pts[-1]):
                pts = np.vstack((pts, pts[:1]))
            return (pts,)
        return tuple(clip_polyline(pts, self._check_window(window)))

    def _check_window(self, window):
        if window is None:
            raise ParameterError(f"{self.name}: an infinite obstacle needs a window to be drawn")
        x0, y0, x1, y1 = (float(v) for v in window)
        if not (x1 > x0 and y1 > y0):
            raise ParameterError(f"window {window!r} must be (x_min, y_min, x_max, y_max)")
        return x0, y0, x1, y1


def clip_polyline(pts: np.ndarray, window: Window) -> List[np.ndarray]:
    """Cut a polyline (k, 2) to the window: the pieces inside it (Liang-Barsky per segment)."""
    x0, y0, x1, y1 = window
    out: List[List[Tuple[float, float]]] = []
    current: List[Tuple[float, float]] = []
    for (ax, ay), (bx, by) in zip(pts[:-1], pts[1:]):
        dx, dy = bx - ax, by - ay
        t0, t1 = 0.0, 1.0
        inside = True
        for p, q in ((-dx, ax - x0), (dx, x1 - ax), (-dy, ay - y0), (dy, y1 - ay)):
            if p == 0.0:
                if q < 0.0:
                    inside = False
                    break
                continue
            r = q / p
            if p < 0.0:
                t0 = max(t0, r)
            else:
                t1 = min(t1, r)
            if t0 > t1:
                inside = False
                break
        if not inside:
            if len(current) > 1:
                out.append(current)
            current = []
            continue
        start = (ax + t0 * dx, ay + t0 * dy)
        end = (ax + t1 * dx, ay + t1 * dy)
        if not current or current[-1] != start:
            if len(current) > 1:
                out.append(current)
            current = [start]
        current.append(end)
        if t1 < 1.0:
            out.append(current)
            current = []
    if len(current) > 1:
        out.append(current)
    return [np.array(piece) for piece in out]


def clip_polygon(ring: np.ndarray, window: Window) -> np.ndarray:
    """Cut a closed polygon (k, 2) to the window (Sutherland-Hodgman), closed again."""
    x0, y0, x1, y1 = window
    pts = [tuple(p) for p in ring[:-1]] if np.array_equal(ring[0], ring[-1]) else [
        tuple(p) for p in ring]
    edges = ((0, x0, 1.0), (0, x1, -1.0), (1, y0, 1.0), (1, y1, -1.0))
    for axis, bound, sign in edges:
        if not pts:
            break
        kept = []
        for k, cur in enumerate(pts):
            prev = pts[k - 1]
            cin = sign * (cur[axis] - bound) >= 0.0
            pin = sign * (prev[axis] - bound) >= 0.0
            if cin != pin:
                t = (bound - prev[axis]) / (cur[axis] - prev[axis])
                kept.append((prev[0] + t * (cur[0] - prev[0]), prev[1] + t * (cur[1] - prev[1])))
            if cin:
                kept.append(cur)
        pts = kept
    if not pts:
        return np.empty((0, 2))
    return np.array(pts + pts[:1])


# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PegObstacle(Obstacle):
    """
    A peg (pole): the disk of radius r >= 0 about (x, y); r = 0 is a point (one vertex).

    Parameters
    ----------
    x, y : float
        The centre [L], finite.
    r : float, optional
        The radius [L]: 0 (a point) or within [1e-6, 1e6].
    name : str, optional
        The obstacle's name; left at the default, :class:`Scene` numbers it by kind
        (``peg0``, ``peg1``, ...).
    friction : float or None, optional
        The obstacle's own Coulomb coefficient, finite and >= 0; None: the scene's.

    Raises
    ------
    ParameterError
        When a number is not finite or out of its range.

    """

    x: float
    y: float
    r: float = 0.0
    name: str = "peg"
    friction: Optional[float] = None
    kind: str = field(default="peg", init=False)
    arcs: Tuple[Arc, ...] = field(init=False, repr=False, compare=False)
    vertices: Tuple[Vertex, ...] = field(init=False, repr=False, compare=False)
    vertex_arcs: Tuple[Tuple[Optional[int], Optional[int]], ...] = field(
        init=False, repr=False, compare=False)

    def __post_init__(self):
        what = self.name
        object.__setattr__(self, "x", _finite(what, "x", self.x))
        object.__setattr__(self, "y", _finite(what, "y", self.y))
        r = _finite(what, "r", self.r)
        if r < 0.0:
            raise ParameterError(f"{what}: r = {r!r} is not allowed; the radius r must be >= 0")
        if r != 0.0:
            _size(what, "r", r)
        object.__setattr__(self, "r", r)
        object.__setattr__(self, "friction", _friction(what, self.friction))
        if r > 0.0:
            arcs, vertices, links = (CircleArc(self.x, self.y, r),), (), ()
        else:
            arcs = ()
            vertices = (Vertex(self.x, self.y, -math.pi, math.pi),)
            links = ((None, None),)
        object.__setattr__(self, "arcs", arcs)
        object.__setattr__(self, "vertices", vertices)
        object.__setattr__(self, "vertex_arcs", links)

    @property
    def params(self):
        return {"x": self.x, "y": self.y, "r": self.r}

    @property
    def is_point(self) -> bool:
        return self.r == 0.0

    def profile(self) -> Peg:
        """Return the same peg as the single-obstacle tracker's :class:`~profiles.Peg`."""
        return Peg(self.x, self.y, self.r, scan_checks=False)

    def signed_distance(self, points):
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        return np.hypot(p[:, 0] - self.x, p[:, 1] - self.y) - self.r

    def closest(self, x, y):
        dx, dy = x - self.x, y - self.y
        d = math.hypot(dx, dy)
        if self.r == 0.0:
            return Closest(d, self.x, self.y, self.vertices[0], vertex_index=0)
        u = math.atan2(dx, -dy)  # the arc's point of outward normal towards (x, y)
        return Closest(d - self.r, self.x + self.r * math.sin(u), self.y - self.r * math.cos(u),
                       self.arcs[0], arc_index=0, u=u)

    def extent(self):
        return self.x - self.r, self.y - self.r, self.x + self.r, self.y + self.r

    def boundary_samples(self, n, window=None):
        if self.r == 0.0:
            return [(None, np.empty(0), np.array([[self.x, self.y]]))]
        u = np.linspace(-math.pi, math.pi, max(n, 8))
        pts = np.column_stack((self.x + self.r * np.sin(u), self.y - self.r * np.cos(u)))
        pts[-1] = pts[0]  # closed exactly
        return [(0, u, pts)]

    def outline(self, n=200, window=None):
        return (self.boundary_samples(n)[0][2],)


# ------------------------------------------------------------------------------------------------
def _segments_cross(p1, p2, q1, q2) -> bool:
    """Tell whether the closed segments p1p2 and q1q2 have a point in common."""
    def orient(a, b, c):
        v = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        return 0 if v == 0.0 else (1 if v > 0.0 else -1)

    def on(a, b, c):  # c on segment ab, given collinear
        return (min(a[0], b[0]) <= c[0] <= max(a[0], b[0])
                and min(a[1], b[1]) <= c[1] <= max(a[1], b[1]))

    o1, o2, o3, o4 = orient(p1, p2, q1), orient(p1, p2, q2), orient(q1, q2, p1), orient(q1, q2, p2)
    if o1 != o2 and o3 != o4:
        return True
    return ((o1 == 0 and on(p1, p2, q1)) or (o2 == 0 and on(p1, p2, q2))
            or (o3 == 0 and on(q1, q2, p1)) or (o4 == 0 and on(q1, q2, p2)))


@dataclass(frozen=True)
class PolygonObstacle(Obstacle):
    """
    A closed polygon, convex or not, through ``points`` (stored counter-clockwise).

    Edge i runs from corner i to corner i + 1 (a :class:`~boundary.SegmentArc`, u = arc length
    from corner i); corner i joins edge i - 1 (incoming) to edge i (outgoing).

    Parameters
    ----------
    points : sequence of (float, float)
        The corners [x, y] [L], at least 3, in either orientation; a closed list (the first
        point repeated last) is accepted.
    name : str, optional
        The obstacle's name; left at the default, :class:`Scene` numbers it by kind
        (``polygon0``, ``polygon1``, ...).
    friction : float or None, optional
        The obstacle's own Coulomb coefficient, finite and >= 0; None: the scene's.

    Raises
    ------
    ParameterError
        When there are fewer than 3 corners, two of them coincide, an edge is longer than
        1e6 L, or the polygon intersects itself or encloses no area.

    """

    points: Tuple[Tuple[float, float], ...]
    name: str = "polygon"
    friction: Optional[float] = None
    kind: str = field(default="polygon", init=False)
    arcs: Tuple[SegmentArc, ...] = field(init=False, repr=False, compare=False)
    vertices: Tuple[Vertex, ...] = field(init=False, repr=False, compare=False)
    vertex_arcs: Tuple[Tuple[int, int], ...] = field(init=False, repr=False, compare=False)
    _a: np.ndarray = field(init=False, repr=False, compare=False)
    _d: np.ndarray = field(init=False, repr=False, compare=False)
    _len2: np.ndarray = field(init=False, repr=False, compare=False)
    _pseudo: np.ndarray = field(init=False, repr=False, compare=False)
    _edge_list: tuple = field(init=False, repr=False, compare=False)
    _pseudo_list: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        what = self.name
        pts = list(_point_list(what, "vertices", self.points))
        if len(pts) > 3 and pts[0] == pts[-1]:
            pts = pts[:-1]  # a closed list: the first point repeated last
        n = len(pts)
        if n < 3:
            raise ParameterError(f"{what}: needs at least 3 vertices [x, y], got {n}")
        arr = np.array(pts)
        lo, hi = SIZE_RANGE
        for i in range(n):
            j = (i + 1) % n
            length = math.hypot(*(arr[j] - arr[i]))
            if length < lo:
                raise ParameterError(
                    f"{what}: vertices {i} and {j} coincide (edge length {length!r} < {lo:g} L); "
                    "give each corner once")
            if length > hi:
                raise ParameterError(f"{what}: edge {i} is {length!r} L long, more than {hi:g}")
        for i in range(n):
            for j in range(i + 1, n):
                if j == i + 1 or (i == 0 and j == n - 1):
                    continue  # adjacent edges share a corner
                if _segments_cross(pts[i], pts[(i + 1) % n], pts[j], pts[(j + 1) % n]):
                    raise ParameterError(
                        f"{what}: self-intersecting (edges {i} and {j} cross); give the corners "
                        "in order along the boundary")
        area2 = float(np.sum(arr[:, 0] * np.roll(arr[:, 1], -1)
                             - np.roll(arr[:, 0], -1) * arr[:, 1]))
        diameter = max(math.hypot(*(a - b)) for a in arr for b in arr)
        if abs(area2) / diameter < lo:
            raise ParameterError(
                f"{what}: zero area (width {abs(area2) / diameter!r} L < {lo:g}); the vertices "
                "must enclose a region")
        for i in range(n):  # adjacent edges folding back onto each other (a spike)
            a, b, c = arr[i - 1], arr[i], arr[(i + 1) % n]
            u, v = b - a, c - b
            if u[0] * v[1] - u[1] * v[0] == 0.0 and u @ v < 0.0:
                raise ParameterError(
                    f"{what}: self-intersecting (edges fold back at vertex {i}); give the corners "
                    "in order along the boundary")
        if area2 < 0.0:  # clockwise: reverse so that the inside is to the left of every edge
            arr = arr[::-1]
            pts = pts[::-1]
        object.__setattr__(self, "points", tuple(pts))
        object.__setattr__(self, "friction", _friction(what, self.friction))
        arcs = tuple(SegmentArc(*pts[i], *pts[(i + 1) % n]) for i in range(n))
        phis = [arc.at(0.0).phi for arc in arcs]
        vertices = tuple(Vertex(pts[i][0], pts[i][1], phis[i - 1],
                                phis[i - 1] + math.remainder(phis[i] - phis[i - 1], TWO_PI))
                         for i in range(n))
        object.__setattr__(self, "arcs", arcs)
        object.__setattr__(self, "vertices", vertices)
        object.__setattr__(self, "vertex_arcs", tuple(((i - 1) % n, i) for i in range(n)))
        d = np.roll(arr, -1, axis=0) - arr
        len2 = np.sum(d * d, axis=1)
        normals = np.column_stack((d[:, 1], -d[:, 0])) / np.sqrt(len2)[:, None]
        object.__setattr__(self, "_a", arr)
        object.__setattr__(self, "_d", d)
        object.__setattr__(self, "_len2", len2)
        # the angle-weighted pseudo-normal of a corner (2-d: the sum of its edges' normals) gives
        # the sign of points whose nearest boundary point is that corner
        object.__setattr__(self, "_pseudo", normals + np.roll(normals, 1, axis=0))
        object.__setattr__(self, "_edge_list", tuple(
            (float(a[0]), float(a[1]), float(e[0]), float(e[1]), float(l2))
            for a, e, l2 in zip(arr, d, len2)))
        object.__setattr__(self, "_pseudo_list", tuple((float(v[0]), float(v[1]))
                                                       for v in self._pseudo))

    @property
    def params(self):
        return {"vertices": [list(p) for p in self.points]}

    @property
    def area(self) -> float:
        a = self._a
        return 0.5 * float(np.sum(a[:, 0] * np.roll(a[:, 1], -1) - np.roll(a[:, 0], -1) * a[:, 1]))

    def _nearest(self, p):
        """For points (m, 2): nearest edge index, its clamped parameter t in [0, 1], distance."""
        rel = p[:, None, :] - self._a[None, :, :]  # (m, n, 2)
        t = np.clip(np.einsum("mnk,nk->mn", rel, self._d) / self._len2, 0.0, 1.0)
        diff = rel - t[:, :, None] * self._d[None, :, :]
        dist2 = np.einsum("mnk,mnk->mn", diff, diff)
        j = np.argmin(dist2, axis=1)
        rows = np.arange(len(p))
        return j, t[rows, j], np.sqrt(dist2[rows, j]), diff[rows, j]

    def _nearest_one(self, x: float, y: float):
        """Do what :meth:`_nearest` and the sign do, for one point in plain floats."""
        best = None
        for j, (ax, ay, dx, dy, len2) in enumerate(self._edge_list):
            rx, ry = x - ax, y - ay
            t = min(max((rx * dx + ry * dy) / len2, 0.0), 1.0)
            ex, ey = rx - t * dx, ry - t * dy
            d2 = ex * ex + ey * ey
            if best is None or d2 < best[0]:
                best = (d2, j, t, ex, ey)
        d2, j, t, ex, ey = best
        if 0.0 < t < 1.0:
            _, _, dx, dy, _ = self._edge_list[j]
            side = dy * ex - dx * ey
        else:
            px, py = self._pseudo_list[j if t <= 0.0 else (j + 1) % len(self._edge_list)]
            side = px * ex + py * ey
        dist = math.sqrt(d2)
        return j, t, (-dist if side < 0.0 else dist)

    def signed_distance(self, points):
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        if len(p) == 1:
            return np.array([self._nearest_one(float(p[0, 0]), float(p[0, 1]))[2]])
        j, t, dist, diff = self._nearest(p)
        n = len(self._a)
        corner = np.where(t <= 0.0, j, (j + 1) % n)
        d = self._d[j]
        side = np.where((t > 0.0) & (t < 1.0),
                        d[:, 1] * diff[:, 0] - d[:, 0] * diff[:, 1],  # outward normal . (p - q)
                        np.einsum("mk,mk->m", self._pseudo[corner], diff))
        return np.where(side < 0.0, -dist, dist)

    def closest(self, x, y):
        j, t, sd = self._nearest_one(float(x), float(y))
        n = len(self._a)
        if 0.0 < t < 1.0:
            u = t * self.arcs[j].u_max
            q = self.arcs[j].at(u)
            return Closest(sd, q.x, q.y, self.arcs[j], arc_index=j, u=u)
        k = j if t <= 0.0 else (j + 1) % n
        v = self.vertices[k]
        return Closest(sd, v.x, v.y, v, vertex_index=k)

    def extent(self):
        return (float(self._a[:, 0].min()), float(self._a[:, 1].min()),
                float(self._a[:, 0].max()), float(self._a[:, 1].max()))

    def boundary_samples(self, n, window=None):
        out = []
        for i, arc in enumerate(self.arcs):
            u = np.linspace(0.0, arc.u_max, max(2, n // len(self.arcs)))
            out.append((i, u, arc.sample(len(u))))
        return out

    def outline(self, n=200, window=None):
        return (np.vstack((self._a, self._a[:1])),)


# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CurveObstacle(Obstacle):
    """
    The region above (or below) a smooth curve y = g(x) through ``points`` (x increasing).

    g is the natural cubic spline through the points, continued along its end tangents; the
    boundary is one :class:`~boundary.GraphArc` (u = x above, u = -x below). Non-convex.

    Parameters
    ----------
    points : sequence of (float, float)
        At least 3 points [x, y] [L] with strictly increasing x.
    side : {'above', 'below'}, optional
        Whether the obstacle is the region above or below the curve.
    name : str, optional
        The obstacle's name; left at the default, :class:`Scene` numbers it by kind
        (``curve0``, ``curve1``, ...).
    friction : float or None, optional
        The obstacle's own Coulomb coefficient, finite and >= 0; None: the scene's.

    Raises
    ------
    ParameterError
        When there are fewer than 3 points, their x do not increase strictly (by at
        least 1e-6 L), or ``side`` is neither.

    """

    points: Tuple[Tuple[float, float], ...]
    side: str = "above"
    name: str = "curve"
    friction: Optional[float] = None
    kind: str = field(default="curve", init=False)
    arcs: Tuple[GraphArc, ...] = field(init=False, repr=False, compare=False)
    vertices: Tuple[Vertex, ...] = field(default=(), init=False, repr=False, compare=False)
    vertex_arcs: Tuple[Tuple[int, int], ...] = field(default=(), init=False, repr=False,
                                                     compare=False)
    bounded: bool = field(default=False, init=False, repr=False, compare=False)
    _tables: tuple = field(init=False, repr=False, compare=False)
    _box_list: tuple = field(init=False, repr=False, compare=False)
    _coef_list: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        what = self.name
        pts = _point_list(what, "points", self.points)
        if len(pts) < 3:
            raise ParameterError(f"{what}: needs at least 3 points [x, y], got {len(pts)}")
        xs = [p[0] for p in pts]
        for i in range(len(xs) - 1):
            if not xs[i + 1] > xs[i]:
                raise ParameterError(
                    f"{what}: points must have strictly increasing x (point {i + 1}: x = "
                    f"{xs[i + 1]!r} after {xs[i]!r}); the curve is a graph y(x)")
            if xs[i + 1] - xs[i] < SIZE_RANGE[0]:
                raise ParameterError(
                    f"{what}: points {i} and {i + 1} are {xs[i + 1] - xs[i]!r} L apart in x, "
                    f"less than {SIZE_RANGE[0]:g}")
        if self.side not in ("above", "below"):
            raise ParameterError(
                f"{what}: side = {self.side!r} is not allowed; side must be 'above' or 'below'")
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "friction", _friction(what, self.friction))
        object.__setattr__(self, "arcs", (GraphArc(pts, self.side),))
        object.__setattr__(self, "_tables", self._build_tables())
        knots, c, h, boxes, _, _ = self._tables
        object.__setattr__(self, "_box_list", tuple(tuple(tuple(float(v) for v in b) for b in sub)
                                                    for sub in boxes))
        object.__setattr__(self, "_coef_list", tuple(tuple(float(v) for v in col)
                                                     for col in c.T))

    @property
    def params(self):
        return {"points": [list(p) for p in self.points], "side": self.side}

    @property
    def graph(self) -> GraphArc:
        return self.arcs[0]

    def height(self, x) -> np.ndarray:
        """Return g(x) for an array of x, continued linearly beyond the end points."""
        knots, c, _, _, _, rays = self._tables
        x = np.asarray(x, dtype=float)
        i = np.clip(np.searchsorted(knots, x, side="right") - 1, 0, len(knots) - 2)
        t = np.clip(x, knots[0], knots[-1]) - knots[i]
        g = ((c[0][i] * t + c[1][i]) * t + c[2][i]) * t + c[3][i]
        (_, _, dx0, dy0, _), (_, _, dx1, dy1, _) = rays
        return g + np.where(x < knots[0], dy0 / dx0 * (x - knots[0]), 0.0) + np.where(
            x > knots[-1], dy1 / dx1 * (x - knots[-1]), 0.0)

    def _distance(self, p):
        """Unsigned distance of points (m, 2) to the graph and the nearest point's x."""
        if len(p) == 1:
            d, x = self._distance_one(float(p[0, 0]), float(p[0, 1]))
            return np.array([d]), np.array([x])
        px, py = p[:, 0], p[:, 1]
        knots, c, h, boxes, samples, rays = self._tables
        # the two rays beyond the end points
        best, best_x = None, None
        for x0, y0, dx, dy, sign in rays:
            dist, tau = _ray_distance(px, py, x0, y0, dx, dy, sign)
            xq = x0 + tau * dx
            if best is None:
                best, best_x = dist, xq
            else:
                better = dist < best
                best, best_x = np.where(better, dist, best), np.where(better, xq, best_x)
        # screening: an upper bound from samples of the curve, a lower bound per cubic piece
        # from its bounding box; only the pieces that may hold the nearest point are solved
        upper = np.minimum(best, np.min(np.hypot(px[:, None] - samples[None, :, 0],
                                                 py[:, None] - samples[None, :, 1]), axis=1))
        x_, y_ = px[:, None, None], py[:, None, None]
        gx = np.maximum(np.maximum(boxes[None, :, :, 0] - x_, x_ - boxes[None, :, :, 2]), 0.0)
        gy = np.maximum(np.maximum(boxes[None, :, :, 1] - y_, y_ - boxes[None, :, :, 3]), 0.0)
        lower = np.min(np.hypot(gx, gy), axis=2)
        rows, piece = np.nonzero(lower <= upper[:, None] * (1.0 + 1e-9) + 1e-300)
        if len(rows) == 0:
            return best, best_x
        # on a piece, the stationary points of the squared distance are the roots of a quintic
        # in s = t / h on [0, 1]: all found at once as companion-matrix eigenvalues
        c0, c1, c2, c3 = c[0][piece], c[1][piece], c[2][piece], c[3][piece]
        hp, xi = h[piece], knots[:-1][piece]
        qx, qy = px[rows], py[rows]
        A = c3 - qy
        coef = np.stack([c2 * A + xi - qx, c2 * c2 + 2.0 * c1 * A + 1.0,
                         3.0 * c1 * c2 + 3.0 * c0 * A, 4.0 * c0 * c2 + 2.0 * c1 * c1,
                         5.0 * c0 * c1, 3.0 * c0 * c0])
        coef = coef * hp[None, :] ** np.arange(6)[:, None]
        scale = np.max(np.abs(coef), axis=0)
        scale = np.where(scale > 0.0, scale, 1.0)
        # a vanishing leading coefficient (a straight piece): perturb it; its roots then run off
        # to |s| ~ 1e3 while those in [0, 1] move by ~1e-15 (and are polished below)
        lead = np.where(np.abs(coef[5]) < 1e-14 * scale, 1e-14 * scale, coef[5])
        comp = np.zeros((len(rows), 5, 5))
        comp[:, 1:, :-1] = np.eye(4)
        comp[:, :, 4] = -(coef[:5] / lead).T
        roots = np.linalg.eigvals(comp)  # (pairs, 5)
        real = np.abs(roots.imag) <= 1e-7 * (1.0 + np.abs(roots.real))
        s = np.where(real, np.clip(roots.real, 0.0, 1.0), 0.0)
        s = np.concatenate((s, np.zeros((len(rows), 1)), np.ones((len(rows), 1))), axis=1)
        t = s * hp[:, None]
        g = ((c0[:, None] * t + c1[:, None]) * t + c2[:, None]) * t + c3[:, None]
        d2 = (xi[:, None] + t - qx[:, None]) ** 2 + (g - qy[:, None]) ** 2
        k = np.argmin(d2, axis=1)
        pair = np.arange(len(rows))
        d2_pair, t_pair = d2[pair, k], t[pair, k]
        # the best pair of each point (rows are sorted: the first of each group after lexsort)
        order = np.lexsort((d2_pair, rows))
        first = np.ones(len(order), dtype=bool)
        first[1:] = rows[order][1:] != rows[order][:-1]
        win = order[first]
        r = rows[win]
        a0, a1, a2, a3 = c0[win], c1[win], c2[win], c3[win]
        tq, hi, x_i = t_pair[win], hp[win], xi[win]
        ux, uy = px[r], py[r]
        # polish: Newton on the stationarity condition within the piece
        for _ in range(3):
            gv = ((a0 * tq + a1) * tq + a2) * tq + a3 - uy
            g1 = (3.0 * a0 * tq + 2.0 * a1) * tq + a2
            g2 = 6.0 * a0 * tq + 2.0 * a1
            f = x_i + tq - ux + gv * g1
            df = 1.0 + g1 * g1 + gv * g2
            step = np.where(df > 0.0, f / np.where(df > 0.0, df, 1.0), 0.0)
            tq = np.clip(tq - step, 0.0, hi)
        gv = ((a0 * tq + a1) * tq + a2) * tq + a3
        dist = np.minimum(np.hypot(x_i + tq - ux, gv - uy), np.sqrt(d2_pair[win]))
        better = dist < best[r]
        best, best_x = best.copy(), best_x.copy()
        best[r] = np.where(better, dist, best[r])
        best_x[r] = np.where(better, x_i + tq, best_x[r])
        return best, best_x

    def _distance_one(self, px: float, py: float) -> Tuple[float, float]:
        """Do what :meth:`_distance` does, for one point in plain floats (the solvers' case)."""
        knots, c, h, boxes, samples, rays = self._tables
        best, best_x = math.inf, math.nan
        for x0, y0, dx, dy, sign in rays:
            tau = (px - x0) * dx + (py - y0) * dy
            tau = max(tau, 0.0) if sign > 0 else min(tau, 0.0)
            d = math.hypot(px - (x0 + tau * dx), py - (y0 + tau * dy))
            if d < best:
                best, best_x = d, x0 + tau * dx
        upper = min(best, float(np.min(np.hypot(samples[:, 0] - px, samples[:, 1] - py))))
        found = []
        limit = upper * (1.0 + 1e-9) + 1e-300
        for i, piece_boxes in enumerate(self._box_list):
            for bx0, by0, bx1, by1 in piece_boxes:
                if math.hypot(max(bx0 - px, 0.0, px - bx1), max(by0 - py, 0.0, py - by1)) <= limit:
                    found.append(i)
                    break
        if not found:
            return best, best_x
        comp = np.zeros((len(found), 5, 5))
        comp[:, 1:, :-1] = np.eye(4)
        for row, i in enumerate(found):
            c0, c1, c2, c3 = self._coef_list[i]
            A, hi = c3 - py, h[i]
            coef = [c2 * A + knots[i] - px, c2 * c2 + 2.0 * c1 * A + 1.0,
                    3.0 * c1 * c2 + 3.0 * c0 * A, 4.0 * c0 * c2 + 2.0 * c1 * c1,
                    5.0 * c0 * c1, 3.0 * c0 * c0]
            coef = [ck * hi ** k for k, ck in enumerate(coef)]
            scale = max(abs(ck) for ck in coef) or 1.0
            lead = coef[5] if abs(coef[5]) >= 1e-14 * scale else 1e-14 * scale
            comp[row, :, 4] = [-ck / lead for ck in coef[:5]]
        roots = np.linalg.eigvals(comp)
        win = None
        for row, i in enumerate(found):
            c0, c1, c2, c3 = self._coef_list[i]
            hi, xi = h[i], knots[i]
            cands = [0.0, hi] + [min(max(r.real, 0.0), 1.0) * hi for r in roots[row]
                                 if abs(r.imag) <= 1e-7 * (1.0 + abs(r.real))]
            for t in cands:
                g = ((c0 * t + c1) * t + c2) * t + c3
                d2 = (xi + t - px) ** 2 + (g - py) ** 2
                if win is None or d2 < win[0]:
                    win = (d2, i, t)
        d2, i, t = win
        c0, c1, c2, c3 = self._coef_list[i]
        hi, xi = h[i], knots[i]
        for _ in range(3):  # polish: Newton on the stationarity condition within the piece
            gv = ((c0 * t + c1) * t + c2) * t + c3 - py
            g1 = (3.0 * c0 * t + 2.0 * c1) * t + c2
            df = 1.0 + g1 * g1 + gv * (6.0 * c0 * t + 2.0 * c1)
            if df > 0.0:
                t = min(max(t - (xi + t - px + gv * g1) / df, 0.0), hi)
        g = ((c0 * t + c1) * t + c2) * t + c3
        d = min(math.hypot(xi + t - px, g - py), math.sqrt(d2))
        return (d, xi + t) if d < best else (best, best_x)

    def _build_tables(self):
        """Spline pieces, their bounding boxes, samples and the end rays, for the distance."""
        sp = self.graph._spline
        knots, c = np.asarray(sp.x), np.asarray(sp.c)
        h = np.diff(knots)
        boxes, samples = [], []
        for i in range(len(h)):
            a0, a1, a2, a3 = c[:, i]
            # the cubic's extremes: the roots of g' (and the ends of each sub-interval)
            crit = []
            if a0 != 0.0:
                disc = a1 * a1 - 3.0 * a0 * a2
                if disc >= 0.0:
                    crit = [(-a1 + sq) / (3.0 * a0) for sq in (math.sqrt(disc), -math.sqrt(disc))]
            elif a1 != 0.0:
                crit = [-a2 / (2.0 * a1)]
            # the piece's bounding box is the union of _SUB boxes (a tighter lower bound)
            cuts = np.linspace(0.0, h[i], _SUB + 1)
            sub = []
            for lo, hi in zip(cuts[:-1], cuts[1:]):
                ts = np.array([lo, hi] + [t for t in crit if lo < t < hi])
                ys = ((a0 * ts + a1) * ts + a2) * ts + a3
                sub.append((knots[i] + lo, ys.min(), knots[i] + hi, ys.max()))
            boxes.append(sub)
            samples.append(np.column_stack((knots[i] + cuts,
                                            ((a0 * cuts + a1) * cuts + a2) * cuts + a3)))
        rays = []
        for end, sign in ((0, -1), (-1, 1)):
            x0 = float(knots[end])
            y0, k = float(sp(x0)), float(sp(x0, 1))
            norm = math.hypot(1.0, k)
            rays.append((x0, y0, 1.0 / norm, k / norm, sign))
        return knots, c, h, np.array(boxes), np.vstack(samples), tuple(rays)  # boxes (n, _SUB, 4)

    def signed_distance(self, points):
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        dist, _ = self._distance(p)
        below = p[:, 1] - self.height(p[:, 0])  # > 0: above the graph
        inside = below > 0.0 if self.side == "above" else below < 0.0
        return np.where(inside, -dist, dist)

    def closest(self, x, y):
        p = np.array([[x, y]], dtype=float)
        dist, xq = self._distance(p)
        xq = float(xq[0])
        sd = float(self.signed_distance(p)[0])
        u = xq if self.side == "above" else -xq
        q = self.graph.at(u)
        return Closest(sd, q.x, q.y, self.graph, arc_index=0, u=u)

    def extent(self):
        xs = [p[0] for p in self.points]
        ys = [p[1] for p in self.points]
        return min(xs), min(ys), max(xs), max(ys)

    def _x_range(self, window):
        x0, _, x1, _ = self._check_window(window)
        return x0, x1

    def boundary_samples(self, n, window=None):
        x0, x1 = self._x_range(window)
        xs = np.union1d(np.linspace(x0, x1, max(n, 8)),
                        [p[0] for p in self.points if x0 < p[0] < x1])
        pts = np.column_stack((xs, self.height(xs)))
        u = xs if self.side == "above" else -xs[::-1]
        return [(0, u, pts if self.side == "above" else pts[::-1])]

    def outline(self, n=200, window=None):
        x0, y0, x1, y1 = self._check_window(window)
        pts = self.boundary_samples(n, window)[0][2]
        if self.side == "above":
            top = max(y1, float(pts[:, 1].max())) + 1.0
            ring = np.vstack((pts, [[x1, top], [x0, top]], pts[:1]))
        else:
            bottom = min(y0, float(pts[:, 1].min())) - 1.0
            ring = np.vstack((pts, [[x0, bottom], [x1, bottom]], pts[:1]))
        ring = clip_polygon(ring, (x0, y0, x1, y1))
        return (ring,) if len(ring) else ()


# ------------------------------------------------------------------------------------------------
#: slope grid of the support-function search (per family kind)
_GRID = 721


@dataclass(frozen=True)
class ProfileObstacle(Obstacle):
    """
    A profile family of :mod:`profiles` (shape ``shape``), placed by a rigid motion.

    The profile is rotated by ``rotation`` [rad] about its own origin (the foot's origin of the
    single-obstacle set-up; the apex is at (0, p0) before the motion), then moved by (x, y). The
    obstacle is the region above the profile's curve in its own frame; for the circle, ellipse and
    two circles the strip above the lower arc, bounded by the straight walls going up from the
    arc's ends (as the single-obstacle tracker has it). All these regions are convex.

    Parameters
    ----------
    family : str
        A profile family of :mod:`profiles` other than the peg: ``parabola``, ``catenary``,
        ``circle``, ``two_circles`` or ``ellipse``.
    shape : mapping or tuple of (str, float)
        The family's parameters by their contract names (:func:`~profiles.make_profile`, without
        the scan checks); stored as a tuple of (name, value) pairs.
    x, y : float, optional
        The translation [L].
    rotation : float, optional
        The rotation about the profile's own origin [rad].
    name : str, optional
        The obstacle's name; empty: the family's name.
    friction : float or None, optional
        The obstacle's own Coulomb coefficient, finite and >= 0; None: the scene's.

    Raises
    ------
    ParameterError
        For an unknown family, a shape :func:`~profiles.make_profile` rejects, or a placement
        that is not finite.

    """

    family: str
    shape: Tuple[Tuple[str, float], ...]
    x: float = 0.0
    y: float = 0.0
    rotation: float = 0.0
    name: str = ""
    friction: Optional[float] = None
    profile: ConvexProfile = field(init=False, repr=False, compare=False)
    base: ConvexProfile = field(init=False, repr=False, compare=False)
    arcs: Tuple[Arc, ...] = field(init=False, repr=False, compare=False)
    vertices: Tuple[Vertex, ...] = field(default=(), init=False, repr=False, compare=False)
    vertex_arcs: Tuple[Tuple[int, int], ...] = field(default=(), init=False, repr=False,
                                                     compare=False)
    bounded: bool = field(default=False, init=False, repr=False, compare=False)
    _grid: Tuple[np.ndarray, np.ndarray] = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        if self.family not in FAMILIES:
            raise ParameterError(
                f"unknown profile family {self.family!r}; allowed: {', '.join(FAMILIES)}")
        what = self.name or self.family
        if not self.name:
            object.__setattr__(self, "name", self.family)
        shape = self.shape if isinstance(self.shape, Mapping) else dict(self.shape)
        base = make_profile(self.family, shape, scan_checks=False)
        object.__setattr__(self, "shape", tuple(base.params.items()))
        for key in ("x", "y", "rotation"):
            object.__setattr__(self, key, _finite(what, f"placement {key}", getattr(self, key)))
        object.__setattr__(self, "friction", _friction(what, self.friction))
        profile = base.placed(self.x, self.y, self.rotation)
        object.__setattr__(self, "base", base)
        object.__setattr__(self, "profile", profile)
        arc = ProfileArc(profile)
        if self.family in STRIP_FAMILIES:
            left, right = arc.at(arc.u_min), arc.at(arc.u_max)
            arcs = (RayArc(left.x, left.y, left.phi, incoming=True), arc,
                    RayArc(right.x, right.y, right.phi))
        else:
            arcs = (arc,)
        object.__setattr__(self, "arcs", arcs)
        if self.family in STRIP_FAMILIES:
            alphas = np.linspace(base.alpha_min, base.alpha_max, _GRID)
        else:
            alphas = np.linspace(base.alpha_min, base.alpha_max, _GRID + 2)[1:-1]
        pts = np.array([base.point(float(a)) for a in alphas])
        support = pts[:, 0] * np.sin(alphas) - pts[:, 1] * np.cos(alphas)
        object.__setattr__(self, "_grid", (alphas, support))

    @property
    def kind(self):  # type: ignore[override]
        return self.family

    @property
    def params(self):
        return dict(self.shape)

    @property
    def placement(self) -> Dict[str, float]:
        return {"x": self.x, "y": self.y, "rotation": self.rotation}

    def to_dict(self):
        out = super().to_dict()
        if (self.x, self.y, self.rotation) != (0.0, 0.0, 0.0):
            out["placement"] = self.placement
        return out

    def describe(self):
        line = super().describe()
        if (self.x, self.y, self.rotation) != (0.0, 0.0, 0.0):
            line += f" placed at ({self.x!r}, {self.y!r}) rotated {self.rotation!r} rad"
        return line

    # -- geometry in the profile's own frame ----------------------------------------------------
    def _to_base(self, p):
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        dx, dy = p[:, 0] - self.x, p[:, 1] - self.y
        return c * dx + s * dy, -s * dx + c * dy

    def _from_base(self, u, v):
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        return self.x + c * u - s * v, self.y + s * u + c * v

    def _g(self, a, u, v):
        """(p - q(a)) . t(a): the slope derivative of the support gap (base frame)."""
        qx, qy = self.base.point(a)
        return (u - qx) * math.cos(a) + (v - qy) * math.sin(a)

    def _solve(self, u: float, v: float, j: int) -> float:
        """Return the slope maximizing (p - q(a)) . n(a) near grid index j (base frame)."""
        alphas = self._grid[0]
        last = len(alphas) - 1
        strip = self.family in STRIP_FAMILIES
        lo_end = alphas[0] if strip else self.base.alpha_min + 1e-13
        hi_end = alphas[last] if strip else self.base.alpha_max - 1e-13
        lo = alphas[j - 1] if j > 0 else lo_end
        hi = alphas[j + 1] if j < last else hi_end
        glo, ghi = self._g(lo, u, v), self._g(hi, u, v)
        if glo > 0.0 and ghi > 0.0:
            return hi  # the maximum is at the end of the range (a wall of a strip)
        if glo < 0.0 and ghi < 0.0:
            return lo
        if glo == 0.0:
            return lo
        if ghi == 0.0:
            return hi
        return brentq(self._g, lo, hi, args=(u, v), xtol=1e-15, rtol=1e-15, maxiter=200)

    def _nearest(self, p):
        """Base-frame slopes of the nearest boundary points and the signed distances."""
        u, v = self._to_base(p)
        alphas, support = self._grid
        gap = (u[:, None] * np.sin(alphas)[None, :] - v[:, None] * np.cos(alphas)[None, :]
               - support[None, :])
        best = np.argmax(gap, axis=1)
        a_star = np.array([self._solve(float(ui), float(vi), int(j))
                           for ui, vi, j in zip(u, v, best)])
        q = np.array([self.base.point(float(a)) for a in a_star]).reshape(-1, 2)
        # signed distance of a convex region: max over its supporting lines (p - q) . n
        sd = (u - q[:, 0]) * np.sin(a_star) - (v - q[:, 1]) * np.cos(a_star)
        return a_star, u, v, q, sd

    def signed_distance(self, points):
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        return self._nearest(p)[4]

    def closest(self, x, y):
        a_star, u, v, q, sd = self._nearest(np.array([[x, y]], dtype=float))
        a, sd = float(a_star[0]), float(sd[0])
        if self.family in STRIP_FAMILIES:
            g = self._g(a, float(u[0]), float(v[0]))
            ends = ((0, self.base.alpha_min, -1.0), (2, self.base.alpha_max, 1.0))
            for index, end, sign in ends:
                if a == end and sign * g > 0.0:  # on the wall above that end
                    wall = self.arcs[index]
                    pt = wall.at(g)
                    return Closest(sd, pt.x, pt.y, wall, arc_index=index, u=g)
        qx, qy = self._from_base(float(q[0, 0]), float(q[0, 1]))
        index = 1 if self.family in STRIP_FAMILIES else 0
        return Closest(sd, qx, qy, self.arcs[index], arc_index=index, u=a + self.rotation)

    def extent(self):
        apex = self.profile.point(self.profile.lowest_alpha())
        return apex[0], apex[1], apex[0], apex[1]

    def _alpha_range(self, window):
        """Base-frame slopes whose points cover the window (the whole arc for a strip)."""
        x0, y0, x1, y1 = self._check_window(window)
        corners = np.array([[x0, y0], [x0, y1], [x1, y0], [x1, y1]])
        u, _ = self._to_base(corners)
        reach = float(np.max(np.abs(u))) + 1.0
        base = self.base
        if self.family in STRIP_FAMILIES:
            return base.alpha_min, base.alpha_max, reach
        return base.alpha_at_x(-reach), base.alpha_at_x(reach), reach

    def boundary_samples(self, n, window=None):
        x0, y0, x1, y1 = self._check_window(window)
        a0, a1, _ = self._alpha_range(window)
        alphas = np.linspace(a0, a1, max(n, 8))
        q = np.array([self.base.point(float(a)) for a in alphas])
        wx, wy = self._from_base(q[:, 0], q[:, 1])
        if self.family not in STRIP_FAMILIES:
            return [(0, alphas + self.rotation, np.column_stack((wx, wy)))]
        out = [(1, alphas + self.rotation, np.column_stack((wx, wy)))]
        corners = np.array([[x0, y0], [x0, y1], [x1, y0], [x1, y1]])
        for index in (0, 2):  # the walls, up to beyond the window's farthest corner
            wall = self.arcs[index]
            far = float(np.max(np.hypot(corners[:, 0] - wall.x, corners[:, 1] - wall.y)))
            us = np.linspace(-far, 0.0, 32) if wall.incoming else np.linspace(0.0, far, 32)
            out.append((index, us, wall.sample(len(us), us[0], us[-1])))
        return out

    def outline(self, n=200, window=None):
        x0, y0, x1, y1 = self._check_window(window)
        a0, a1, reach = self._alpha_range(window)
        alphas = np.linspace(a0, a1, max(n, 8))
        q = np.array([self.base.point(float(a)) for a in alphas])
        # close far above the arc (the obstacle's side, in its own frame), beyond the window
        far = (math.hypot(x1 - x0, y1 - y0) + reach
               + float(np.max(np.abs(q[:, 1]))) + abs(self.x) + abs(self.y))
        top = float(np.max(q[:, 1])) + far
        ring = np.vstack((q, [[q[-1, 0], top], [q[0, 0], top]], q[:1]))
        wx, wy = self._from_base(ring[:, 0], ring[:, 1])
        ring = clip_polygon(np.column_stack((wx, wy)), (x0, y0, x1, y1))
        return (ring,) if len(ring) else ()


# ------------------------------------------------------------------------------------------------
#: keys every obstacle entry may have besides its shape
COMMON_KEYS = ("type", "name", "friction")
#: shape keys per obstacle type (profile families: their parameters and ``placement``)
OBSTACLE_KEYS: Dict[str, Tuple[str, ...]] = {
    "peg": ("x", "y", "r"),
    "polygon": ("vertices",),
    "curve": ("points", "side"),
    **{family: tuple(PROFILE_PARAMETERS[family]) + ("placement",) for family in FAMILIES},
}
PLACEMENT_KEYS = ("x", "y", "rotation", "rotation_deg")


def obstacle_from_dict(entry: Mapping[str, Any], name: str) -> Obstacle:
    """
    Build one obstacle from its scene-file entry (``type`` and the keys of :data:`OBSTACLE_KEYS`).

    Raises :class:`ParameterError` naming the offending key and what is allowed.
    """
    if not isinstance(entry, Mapping):
        raise ParameterError(f"must be a mapping with a 'type' key, got {entry!r}")
    kind = entry.get("type")
    if kind is None:
        raise ParameterError(f"key 'type' is missing; allowed types: {', '.join(OBSTACLE_TYPES)}")
    if kind not in OBSTACLE_KEYS:
        raise ParameterError(
            f"unknown obstacle type {kind!r}; allowed: {', '.join(OBSTACLE_TYPES)}")
    allowed = COMMON_KEYS + OBSTACLE_KEYS[kind]
    unknown = [k for k in entry if k not in allowed]
    if unknown:
        raise ParameterError(
            f"{kind}: unknown key(s) {', '.join(map(repr, unknown))}; allowed: "
            f"{', '.join(allowed)}")
    name = str(entry.get("name") or name)
    friction = entry.get("friction")
    if kind == "peg":
        for key in ("x", "y"):
            if key not in entry:
                raise ParameterError(f"{name}: key '{key}' is required (peg: x, y, r)")
        return PegObstacle(entry["x"], entry["y"], entry.get("r", 0.0), name, friction)
    if kind == "polygon":
        if "vertices" not in entry:
            raise ParameterError(f"{name}: key 'vertices' is required ([[x, y], ...], >= 3)")
        return PolygonObstacle(entry["vertices"], name, friction)
    if kind == "curve":
        if "points" not in entry:
            raise ParameterError(f"{name}: key 'points' is required ([[x, y], ...], >= 3)")
        return CurveObstacle(entry["points"], entry.get("side", "above"), name, friction)
    shape = {k: entry[k] for k in PROFILE_PARAMETERS[kind] if k in entry}
    place = entry.get("placement") or {}
    if not isinstance(place, Mapping):
        raise ParameterError(f"{name}: key 'placement' must be a mapping {{x, y, rotation}}")
    bad = [k for k in place if k not in PLACEMENT_KEYS]
    if bad:
        raise ParameterError(
            f"{name}: unknown placement key(s) {', '.join(map(repr, bad))}; allowed: "
            f"{', '.join(PLACEMENT_KEYS)} (rotation in rad, or rotation_deg in degrees)")
    if "rotation" in place and "rotation_deg" in place:
        raise ParameterError(f"{name}: placement has both rotation and rotation_deg; give one")
    rotation = place.get("rotation", 0.0)
    if "rotation_deg" in place:
        rotation = math.radians(_finite(name, "placement rotation_deg", place["rotation_deg"]))
    try:
        return ProfileObstacle(kind, shape, place.get("x", 0.0), place.get("y", 0.0), rotation,
                               name, friction)
    except ParameterError as exc:
        raise ParameterError(f"{name}: {exc}") from None


# ------------------------------------------------------------------------------------------------
class Scene:
    """
    Obstacles with a global Coulomb friction coefficient (dimensionless lengths).

    Validated on construction: friction finite and >= 0, names unique, and no two obstacles
    overlapping or touching (checked exactly for bounded obstacles; two infinite ones are
    checked within a window around all the obstacles' data, :meth:`window`).

    Parameters
    ----------
    obstacles : sequence of Obstacle
        At least one obstacle. Unnamed ones (name left at the kind's default) are named by kind
        and index among that kind (``peg0``, ``polygon1``, ...).
    friction : float, optional
        The global Coulomb coefficient, finite and >= 0, for obstacles without their own.

    Raises
    ------
    ParameterError
        When there is no obstacle, something is not an obstacle, the friction is out of its
        range, two obstacles share a name, or two obstacles overlap or touch.

    """

    def __init__(self, obstacles: Sequence[Obstacle], friction: float = 0.0):
        obstacles = list(obstacles)
        if not obstacles:
            raise ParameterError("a scene needs at least one obstacle")
        mu = _friction("scene", friction)
        self.friction: float = 0.0 if mu is None else mu
        counts: Dict[str, int] = {}
        named = []
        for ob in obstacles:
            if not isinstance(ob, Obstacle):
                raise ParameterError(f"not an obstacle: {ob!r}")
            default = ob.kind
            if ob.name == default:  # unnamed: the kind and its index among that kind
                ob = replace(ob, name=f"{default}{counts.get(default, 0)}")
            counts[ob.kind] = counts.get(ob.kind, 0) + 1
            named.append(ob)
        names = [ob.name for ob in named]
        for i, nm in enumerate(names):
            if nm in names[:i]:
                raise ParameterError(f"obstacle {i}: name {nm!r} is used twice; names must be "
                                     "unique")
        self.obstacles: Tuple[Obstacle, ...] = tuple(named)
        self._check_overlaps()

    # -- container ------------------------------------------------------------------------------
    def __iter__(self) -> Iterator[Obstacle]:
        return iter(self.obstacles)

    def __len__(self) -> int:
        return len(self.obstacles)

    def __getitem__(self, index: int) -> Obstacle:
        return self.obstacles[index]

    def __eq__(self, other) -> bool:
        return (isinstance(other, Scene) and self.friction == other.friction
                and self.obstacles == other.obstacles)

    def __repr__(self) -> str:
        return f"Scene({list(self.obstacles)!r}, friction={self.friction!r})"

    def mu_of(self, index: int) -> float:
        """Coulomb coefficient of obstacle ``index``: its own, else the scene's."""
        own = self.obstacles[index].friction
        return self.friction if own is None else own

    def describe(self) -> str:
        """One line: the obstacles and the friction."""
        parts = "; ".join(ob.describe() for ob in self.obstacles)
        return f"scene of {len(self)} obstacle(s), friction {self.friction!r}: {parts}"

    def to_dict(self) -> Dict[str, Any]:
        """Return the scene as a scene file's mapping (``Scene.from_dict`` reads it back)."""
        return {"friction": self.friction, "obstacles": [ob.to_dict() for ob in self.obstacles]}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "Scene":
        """
        Build a scene from a scene file's mapping: ``friction`` and ``obstacles``.

        Errors name the obstacle's index and the key.
        """
        if not isinstance(data, Mapping):
            raise ParameterError("a scene must be a mapping with keys 'obstacles' and 'friction'")
        unknown = [k for k in data if k not in ("friction", "obstacles")]
        if unknown:
            raise ParameterError(f"unknown scene key(s) {', '.join(map(repr, unknown))}; "
                                 "allowed: friction, obstacles")
        entries = data.get("obstacles")
        if not isinstance(entries, (list, tuple)) or not entries:
            raise ParameterError("key 'obstacles' must be a non-empty list of obstacles")
        obstacles = []
        counts: Dict[str, int] = {}
        for i, entry in enumerate(entries):
            kind = entry.get("type") if isinstance(entry, Mapping) else None
            kind = kind if isinstance(kind, str) else "obstacle"
            try:
                default = f"{kind}{counts.get(kind, 0)}"
                obstacles.append(obstacle_from_dict(entry, default))
            except ParameterError as exc:
                raise ParameterError(f"obstacle {i}: {exc}") from None
            counts[kind] = counts.get(kind, 0) + 1
        return cls(obstacles, data.get("friction", 0.0) if data.get("friction") is not None
                   else 0.0)

    # -- the one-obstacle shorthand -----------------------------------------------------------
    def single_profile(self) -> Optional[ConvexProfile]:
        """
        Return the plain profile of a one-obstacle scene of a peg or a profile family, else None.

        ``--profile`` is this case: the single-obstacle tracker runs on the returned object.
        """
        if len(self) != 1:
            return None
        ob = self.obstacles[0]
        if isinstance(ob, PegObstacle):
            return ob.profile()
        if isinstance(ob, ProfileObstacle):
            return ob.profile
        return None

    # -- geometry -------------------------------------------------------------------------------
    def signed_distance(self, points) -> np.ndarray:
        """Distance (m,) of points (m, 2) to the nearest obstacle, negative inside one [L]."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        return np.min([ob.signed_distance(p) for ob in self.obstacles], axis=0)

    def closest(self, x: float, y: float) -> Tuple[int, Closest]:
        """Return the obstacle index and boundary feature nearest to (x, y)."""
        found = [ob.closest(x, y) for ob in self.obstacles]
        i = int(np.argmin([c.distance for c in found]))
        return i, found[i]

    def check_foot(self, x: float, y: float) -> None:
        """Raise :class:`InvalidPoseError` if the foot (x, y) is inside or on an obstacle."""
        for i, ob in enumerate(self.obstacles):
            d = float(ob.signed_distance(np.array([[x, y]], dtype=float))[0])
            if d <= 0.0:
                where = "inside" if d < 0.0 else "on the boundary of"
                raise InvalidPoseError(
                    f"the foot ({x!r}, {y!r}) is {where} obstacle {i} ({ob.name}); place the foot "
                    "outside every obstacle")

    def window(self, margin: float = 1.0) -> Window:
        """Return a box around every obstacle's finite data, widened by ``margin`` [L]."""
        boxes = np.array([ob.extent() for ob in self.obstacles])
        x0, y0 = boxes[:, 0].min(), boxes[:, 1].min()
        x1, y1 = boxes[:, 2].max(), boxes[:, 3].max()
        return (float(x0 - margin), float(y0 - margin), float(x1 + margin), float(y1 + margin))

    # -- validation -----------------------------------------------------------------------------
    def _check_overlaps(self) -> None:
        window = self.window(margin=2.0)
        for i, a in enumerate(self.obstacles):
            for j in range(i + 1, len(self.obstacles)):
                b = self.obstacles[j]
                gap = min(_min_gap(a, b, window), _min_gap(b, a, window))
                if gap <= 0.0:
                    raise ParameterError(
                        f"obstacles {i} ({a.name}) and {j} ({b.name}) overlap or touch (gap "
                        f"{gap:.3g} L); obstacles must be apart")


def _min_gap(a: Obstacle, b: Obstacle, window: Window, n: int = 400) -> float:
    """Smallest signed distance to ``b`` of ``a``'s boundary (within ``window`` if infinite)."""
    best = math.inf
    for index, us, pts in a.boundary_samples(n, window):
        d = b.signed_distance(pts)
        k = int(np.argmin(d))
        best = min(best, float(d[k]))
        if index is None or len(us) < 3:
            continue
        arc = a.arcs[index]
        lo, hi = us[max(k - 1, 0)], us[min(k + 1, len(us) - 1)]

        def gap(u, arc=arc):
            q = arc.at(float(u))
            return float(b.signed_distance(np.array([[q.x, q.y]]))[0])

        res = minimize_scalar(gap, bounds=(lo, hi), method="bounded", options={"xatol": 1e-12})
        best = min(best, float(res.fun))
    return best
