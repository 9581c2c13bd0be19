"""
Obstacles of the 3D whisker: spheres, infinite cylinders, half-spaces and prisms of planar ones.

Every obstacle is an immutable value in whisker lengths L (dimensionless) with a ``kind``, a
``name``, and its signed distance d(x): the Euclidean distance of x (3,) to the obstacle's
surface, negative inside. The outward unit normal is grad d, the direction of a frictionless
contact force on the whisker (doc/mechanics/rod3d.md).

- :class:`Sphere` (center, r > 0): d = norm(x - c) - r.
- :class:`Cylinder` (point, axis, r > 0), infinite along the unit ``axis`` a: with
  P = I - a a^T and rho = norm(P (x - p)) the distance from the axis, d = rho - r.
- :class:`Plane` (point, unit normal n): the obstacle is the half-space on the side opposite
  ``normal``, d = (x - p) . n.
- :class:`Prism` (a planar scene obstacle of :mod:`vibrissa_ros.core.scenes.scene`: peg,
  polygon, curve or a profile family): the infinite prism along z, d(x, y, z) = the planar
  signed distance of (x, y). Its corners (a polygon's vertices, a point peg) are *edges*: the
  vertical lines through them.

:meth:`surface` gives, at a query point x, the signed distance, the nearest surface point, the
normal, the Hessian of d at x (what a Newton solver on the contact conditions needs), and
whether the nearest feature is a smooth surface or an edge (a line):

- sphere: H = (I - n n^T) / norm(x - c); cylinder: H = (P - n n^T) / rho; plane: H = 0;
- a prism's smooth arc of boundary curvature k (> 0 where the obstacle is locally convex, the
  sign of :mod:`~vibrissa_ros.core.scenes.boundary`) at the nearest point, with planar unit
  tangent t: H = [[k / (1 + k d) t t^T, 0], [0, 0]]. (Along the normal line d grows at unit
  rate, and the level set at distance d is the parallel curve, of curvature k / (1 + k d): a
  disk of radius R gives k = 1/R, H = t t^T / (R + d) = (I - n n^T) / norm(x - c) as it must.)
- an edge, the line a + tau e (unit e), and the signed distance d: H = (P - n n^T) / d with
  P = I - e e^T (d > 0 outside; inside a reflex corner d < 0 and the same formula holds).

Where d is not differentiable (a sphere's centre, a cylinder's axis, a point on an edge, the
medial axis of a prism) :meth:`surface` still answers: ``normal`` is a valid outward direction
of the nearest feature (a fixed axis at a centre, the middle of the normal cone on an edge) and
``hessian`` is zero. Those points are never near a contact, where everything is smooth.

Every signed distance here is 1-Lipschitz, so d(center) - radius is a lower bound of d over the
ball (:meth:`~Obstacle3D.clearance_bound`): the cheap clearance test of the solvers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Dict, Optional, Sequence, Tuple

import numpy as np

from ..errors import ParameterError
from ..profiles import SIZE_RANGE
from ..scenes.scene import Obstacle

#: 3D-only obstacle types (the planar ones become :class:`Prism`)
SOLID_TYPES = ("sphere", "cylinder", "plane")
#: the z axis: every prism's direction
_Z = (0.0, 0.0, 1.0)
_ZERO3 = ((0.0, 0.0, 0.0),) * 3
#: shortest axis or normal accepted before normalising (a zero vector has no direction)
_MIN_DIRECTION = 1e-9

Vector = Tuple[float, float, float]


@dataclass(frozen=True, eq=False)
class SurfacePoint:
    """
    An obstacle's signed distance at a query point x, with its first and second derivatives.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    distance : float
        The signed distance d(x) [L], negative inside.
    point : numpy.ndarray
        The nearest surface point (3,) [L] (on an edge: the foot of x on its line).
    normal : numpy.ndarray
        The outward unit normal (3,) = grad d at x.
    hessian : numpy.ndarray
        The Hessian of d at x (3, 3) [1/L], symmetric (zero where d is not twice
        differentiable).
    feature : str, optional
        ``'surface'`` (a smooth part) or ``'edge'`` (a prism's corner, a point peg).
    edge : tuple of numpy.ndarray or None, optional
        For an edge: its line (a (3,), e (3,)), a point of it and its unit direction; else None.

    """

    distance: float
    point: np.ndarray
    normal: np.ndarray
    hessian: np.ndarray
    feature: str = "surface"
    edge: Optional[Tuple[np.ndarray, np.ndarray]] = None


# -- validation ----------------------------------------------------------------------------------
def _number(what: str, key: str, value: Any) -> float:
    """Return ``value`` as a finite float within +-1e6 L, else raise naming what and key."""
    if isinstance(value, bool):
        raise ParameterError(f"{what}: {key} = {value!r} must be a number")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{what}: {key} = {value!r} must be a number") from None
    if not math.isfinite(number):
        raise ParameterError(f"{what}: {key} = {value!r} must be finite")
    if abs(number) > SIZE_RANGE[1]:
        raise ParameterError(
            f"{what}: {key} = {value!r} is too far; it must be within +-{SIZE_RANGE[1]:g} L")
    return number


def _vector(what: str, key: str, value: Any) -> Vector:
    """Return three finite numbers [x, y, z], else raise naming ``what`` and ``key``."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 3:
        raise ParameterError(f"{what}: {key} = {value!r} must be a vector of 3 numbers [x, y, z]")
    return tuple(_number(what, f"{key}[{i}]", v) for i, v in enumerate(value))


def _direction(what: str, key: str, value: Any) -> Vector:
    """Return the unit vector along ``value`` (3 numbers, nonzero length)."""
    x, y, z = _vector(what, key, value)
    norm = math.sqrt(x * x + y * y + z * z)
    if not norm >= _MIN_DIRECTION:
        raise ParameterError(
            f"{what}: {key} = {list(value)!r} has length {norm!r}; it must be a direction "
            f"[x, y, z] of length >= {_MIN_DIRECTION:g} (it is normalised)")
    return (x / norm, y / norm, z / norm)


def _radius(what: str, value: Any) -> float:
    """Return the radius r as a float within [1e-6, 1e6] L, else raise."""
    r = _number(what, "r", value)
    lo, hi = SIZE_RANGE
    if not r > 0.0:
        raise ParameterError(f"{what}: r = {value!r} is not allowed; the radius r must be > 0 "
                             f"(within [{lo:g}, {hi:g}] L)")
    if not lo <= r <= hi:
        raise ParameterError(f"{what}: r = {value!r} is not allowed; the radius r must be within "
                             f"[{lo:g}, {hi:g}] L")
    return r


def _name(value: Any, kind: str) -> str:
    """Return the obstacle's name, a non-empty string."""
    if not isinstance(value, str) or not value:
        raise ParameterError(f"{kind}: name = {value!r} must be a non-empty string")
    return value


def _points(points) -> np.ndarray:
    """Return query points as a float array (m, 3)."""
    return np.asarray(points, dtype=float).reshape(-1, 3)


def _fmt(v: Sequence[float]) -> str:
    return "(" + ", ".join(f"{x:g}" for x in v) + ")"


# -- obstacles -----------------------------------------------------------------------------------
class Obstacle3D:
    """
    Base class of the 3D obstacles (immutable values; see the module's docstring).

    Subclasses give ``kind``, ``name``, :meth:`signed_distance`, :meth:`surface`,
    :meth:`to_dict`, :meth:`describe` and the one-point distance ``_distance_one``.
    """

    name: str
    kind: str = "obstacle"

    def signed_distance(self, points) -> np.ndarray:
        """
        Return the signed distances of points to the surface, negative inside.

        Parameters
        ----------
        points : array_like
            Points (m, 3) [L] (one point (3,) is read as (1, 3)).

        Returns
        -------
        numpy.ndarray
            d (m,) [L].

        """
        raise NotImplementedError

    def surface(self, point) -> SurfacePoint:
        """
        Return the signed distance at ``point`` with its gradient and Hessian.

        Parameters
        ----------
        point : array_like
            The query point x (3,) [L].

        Returns
        -------
        SurfacePoint
            Distance, nearest surface point, outward normal, Hessian at x, feature and edge.

        """
        raise NotImplementedError

    def _distance_one(self, x: float, y: float, z: float) -> float:
        """Return the signed distance of one point, in plain floats."""
        return float(self.signed_distance(np.array([[x, y, z]]))[0])

    def clearance_bound(self, center, radius: float) -> float:
        """
        Return a lower bound of the signed distance of every point within ``radius`` of center.

        The bound is d(center) - radius: a signed distance is 1-Lipschitz (it changes by at most
        the distance moved), so it is a true bound, and it is attained when the ball touches the
        surface from outside. Positive: the whole ball is clear of the obstacle.

        Parameters
        ----------
        center : array_like
            The ball's centre (3,) [L].
        radius : float
            The ball's radius [L], >= 0.

        Returns
        -------
        float
            The bound [L].

        """
        return self._distance_one(float(center[0]), float(center[1]),
                                  float(center[2])) - float(radius)

    def contains(self, point) -> bool:
        """
        Tell whether a point lies strictly inside the obstacle.

        Parameters
        ----------
        point : array_like
            The point (3,) [L].

        Returns
        -------
        bool
            True when d(point) < 0.

        """
        return self._distance_one(float(point[0]), float(point[1]), float(point[2])) < 0.0

    def to_dict(self) -> Dict[str, Any]:
        """
        Return the obstacle as written in a scene file (``type`` first, lengths in L).

        Returns
        -------
        dict
            The scene-file entry.

        """
        raise NotImplementedError

    def describe(self) -> str:
        """
        Return one line: name, kind and shape.

        Returns
        -------
        str
            The description.

        """
        raise NotImplementedError


def _inherit_docstrings(cls):
    """Give the public methods a subclass overrides without a docstring the base class's."""
    for key, member in vars(cls).items():
        base = getattr(Obstacle3D, key, None)
        if (callable(member) and not key.startswith("_") and not member.__doc__
                and base is not None):
            member.__doc__ = base.__doc__
    return cls


@_inherit_docstrings
@dataclass(frozen=True)
class Sphere(Obstacle3D):
    """
    A solid ball: d(x) = norm(x - center) - r.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    center : sequence of float
        The centre [x, y, z] [L], finite.
    r : float
        The radius [L], within [1e-6, 1e6].
    name : str, optional
        The obstacle's name; left at the default, :class:`~.scene.Scene3D` numbers it by kind
        (``sphere0``, ``sphere1``, ...).

    Raises
    ------
    ParameterError
        When a number is not finite or out of its range, or ``center`` is not 3 numbers.

    """

    center: Vector
    r: float
    name: str = "sphere"
    kind: str = field(default="sphere", init=False)

    def __post_init__(self):
        what = _name(self.name, "sphere")
        object.__setattr__(self, "center", _vector(what, "center", self.center))
        object.__setattr__(self, "r", _radius(what, self.r))
        object.__setattr__(self, "_center_array", np.array(self.center))

    def signed_distance(self, points) -> np.ndarray:
        p = _points(points) - self._center_array
        return np.sqrt(np.einsum("mk,mk->m", p, p)) - self.r

    def _distance_one(self, x, y, z):
        cx, cy, cz = self.center
        return math.sqrt((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) - self.r

    def surface(self, point) -> SurfacePoint:
        cx, cy, cz = self.center
        dx, dy, dz = float(point[0]) - cx, float(point[1]) - cy, float(point[2]) - cz
        rho = math.sqrt(dx * dx + dy * dy + dz * dz)
        r = self.r
        if rho > 0.0:
            nx, ny, nz = dx / rho, dy / rho, dz / rho
            f = 1.0 / rho
            hess = np.array(((f * (1.0 - nx * nx), -f * nx * ny, -f * nx * nz),
                             (-f * nx * ny, f * (1.0 - ny * ny), -f * ny * nz),
                             (-f * nx * nz, -f * ny * nz, f * (1.0 - nz * nz))))
        else:  # the centre: every direction is nearest; take +z
            nx, ny, nz = _Z
            hess = np.zeros((3, 3))
        return SurfacePoint(rho - r, np.array((cx + r * nx, cy + r * ny, cz + r * nz)),
                            np.array((nx, ny, nz)), hess)

    def to_dict(self) -> Dict[str, Any]:
        return {"type": "sphere", "name": self.name, "center": list(self.center), "r": self.r}

    def describe(self) -> str:
        return f"{self.name}: sphere(center={_fmt(self.center)}, r={self.r:g})"


@_inherit_docstrings
@dataclass(frozen=True)
class Cylinder(Obstacle3D):
    """
    A solid infinite circular cylinder: d(x) = rho - r, rho = distance of x from the axis.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    point : sequence of float
        A point [x, y, z] of the axis [L], finite.
    axis : sequence of float
        The axis direction [ax, ay, az], nonzero; stored normalised.
    r : float
        The radius [L], within [1e-6, 1e6].
    name : str, optional
        The obstacle's name; left at the default, :class:`~.scene.Scene3D` numbers it by kind.

    Raises
    ------
    ParameterError
        When a number is not finite or out of its range, a vector is not 3 numbers, or the
        axis has length 0.

    """

    point: Vector
    axis: Vector
    r: float
    name: str = "cylinder"
    kind: str = field(default="cylinder", init=False)

    def __post_init__(self):
        what = _name(self.name, "cylinder")
        object.__setattr__(self, "point", _vector(what, "point", self.point))
        object.__setattr__(self, "axis", _direction(what, "axis", self.axis))
        object.__setattr__(self, "r", _radius(what, self.r))
        # the vectors as arrays once: the trackers ask for distances of a few points at a time
        object.__setattr__(self, "_point_array", np.array(self.point))
        object.__setattr__(self, "_axis_array", np.array(self.axis))

    def signed_distance(self, points) -> np.ndarray:
        w = _points(points) - self._point_array
        a = self._axis_array
        radial = w - (w @ a)[:, None] * a
        return np.sqrt(np.einsum("mk,mk->m", radial, radial)) - self.r

    def _radial(self, x, y, z):
        px, py, pz = self.point
        ax, ay, az = self.axis
        wx, wy, wz = x - px, y - py, z - pz
        t = wx * ax + wy * ay + wz * az
        return t, wx - t * ax, wy - t * ay, wz - t * az

    def _distance_one(self, x, y, z):
        _, rx, ry, rz = self._radial(x, y, z)
        return math.sqrt(rx * rx + ry * ry + rz * rz) - self.r

    def surface(self, point) -> SurfacePoint:
        t, rx, ry, rz = self._radial(float(point[0]), float(point[1]), float(point[2]))
        ax, ay, az = self.axis
        rho = math.sqrt(rx * rx + ry * ry + rz * rz)
        if rho > 0.0:
            nx, ny, nz = rx / rho, ry / rho, rz / rho
            f = 1.0 / rho
            # (P - n n^T) / rho, P = I - a a^T
            xy, xz, yz = ax * ay + nx * ny, ax * az + nx * nz, ay * az + ny * nz
            hess = np.array(((f * (1.0 - ax * ax - nx * nx), -f * xy, -f * xz),
                             (-f * xy, f * (1.0 - ay * ay - ny * ny), -f * yz),
                             (-f * xz, -f * yz, f * (1.0 - az * az - nz * nz))))
        else:  # on the axis: take a fixed direction normal to it
            nx, ny, nz = _unit_normal_to(ax, ay, az)
            hess = np.zeros((3, 3))
        px, py, pz = self.point
        r = self.r
        foot = (px + t * ax + r * nx, py + t * ay + r * ny, pz + t * az + r * nz)
        return SurfacePoint(rho - r, np.array(foot), np.array((nx, ny, nz)), hess)

    def to_dict(self) -> Dict[str, Any]:
        return {"type": "cylinder", "name": self.name, "point": list(self.point),
                "axis": list(self.axis), "r": self.r}

    def describe(self) -> str:
        return (f"{self.name}: cylinder(point={_fmt(self.point)}, axis={_fmt(self.axis)}, "
                f"r={self.r:g})")


def _unit_normal_to(ax: float, ay: float, az: float) -> Vector:
    """Return a unit vector normal to the unit (ax, ay, az): its cross product with an axis."""
    if abs(az) < 0.9:  # a x z
        nx, ny, nz = ay, -ax, 0.0
    else:  # a x x
        nx, ny, nz = 0.0, az, -ay
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    return nx / norm, ny / norm, nz / norm


@_inherit_docstrings
@dataclass(frozen=True)
class Plane(Obstacle3D):
    """
    A solid half-space, on the side opposite ``normal``: d(x) = (x - point) . normal.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    point : sequence of float
        A point [x, y, z] of the bounding plane [L], finite.
    normal : sequence of float
        The outward normal [nx, ny, nz] (pointing away from the obstacle), nonzero; stored
        normalised.
    name : str, optional
        The obstacle's name; left at the default, :class:`~.scene.Scene3D` numbers it by kind.

    Raises
    ------
    ParameterError
        When a number is not finite or too large, a vector is not 3 numbers, or the normal has
        length 0.

    """

    point: Vector
    normal: Vector
    name: str = "plane"
    kind: str = field(default="plane", init=False)

    def __post_init__(self):
        what = _name(self.name, "plane")
        object.__setattr__(self, "point", _vector(what, "point", self.point))
        object.__setattr__(self, "normal", _direction(what, "normal", self.normal))
        object.__setattr__(self, "_point_array", np.array(self.point))
        object.__setattr__(self, "_normal_array", np.array(self.normal))

    def signed_distance(self, points) -> np.ndarray:
        return (_points(points) - self._point_array) @ self._normal_array

    def _distance_one(self, x, y, z):
        px, py, pz = self.point
        nx, ny, nz = self.normal
        return (x - px) * nx + (y - py) * ny + (z - pz) * nz

    def surface(self, point) -> SurfacePoint:
        x, y, z = float(point[0]), float(point[1]), float(point[2])
        d = self._distance_one(x, y, z)
        nx, ny, nz = self.normal
        return SurfacePoint(d, np.array((x - d * nx, y - d * ny, z - d * nz)),
                            np.array(self.normal), np.zeros((3, 3)))

    def to_dict(self) -> Dict[str, Any]:
        return {"type": "plane", "name": self.name, "point": list(self.point),
                "normal": list(self.normal)}

    def describe(self) -> str:
        return f"{self.name}: plane(point={_fmt(self.point)}, normal={_fmt(self.normal)})"


@_inherit_docstrings
@dataclass(frozen=True)
class Prism(Obstacle3D):
    """
    The infinite prism along z of a planar scene obstacle: d(x, y, z) = the planar d(x, y).

    The planar obstacle keeps its own validation and geometry (:mod:`~vibrissa_ros.core.scenes.
    scene`); the 3D whisker is frictionless, so a planar friction of 0 is dropped and any other
    is refused. The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    planar : Obstacle
        A planar scene obstacle (peg, polygon, curve or a profile family), in L.
    name : str, optional
        The prism's name; empty: the planar obstacle's. The planar obstacle is renamed to it.

    Raises
    ------
    ParameterError
        When ``planar`` is not a planar scene obstacle or has a nonzero friction coefficient.

    """

    planar: Obstacle
    name: str = ""

    def __post_init__(self):
        planar = self.planar
        if not isinstance(planar, Obstacle):
            raise ParameterError(f"prism: planar = {planar!r} must be a planar scene obstacle "
                                 "(peg, polygon, curve or a profile family)")
        name = self.name or planar.name
        _name(name, planar.kind)
        if planar.friction not in (None, 0.0):
            raise ParameterError(
                f"{name}: friction = {planar.friction!r} is not allowed; the 3D whisker is "
                "frictionless (friction is planar-only for now): give 0 or leave it out")
        if planar.friction is not None or planar.name != name:
            planar = replace(planar, name=name, friction=None)
        object.__setattr__(self, "planar", planar)
        object.__setattr__(self, "name", name)

    @property
    def kind(self) -> str:  # type: ignore[override]
        """Return the planar obstacle's type, e.g. 'peg', 'polygon' or 'parabola'."""
        return self.planar.kind

    def signed_distance(self, points) -> np.ndarray:
        return self.planar.signed_distance(_points(points)[:, :2])

    def _distance_one(self, x, y, z):
        return float(self.planar.signed_distance(np.array(((x, y),)))[0])

    def surface(self, point) -> SurfacePoint:
        x, y, z = float(point[0]), float(point[1]), float(point[2])
        near = self.planar.closest(x, y)
        d = float(near.distance)
        if near.vertex_index is not None:
            return self._edge_surface(x, y, z, d, near.feature)
        arc = near.feature.at(near.u)
        s, c = math.sin(arc.phi), math.cos(arc.phi)
        k = arc.dphi / arc.speed
        denom = 1.0 + k * d
        f = k / denom if denom > 0.0 else 0.0  # denom <= 0 only on the medial axis
        hess = np.array(((f * c * c, f * c * s, 0.0), (f * c * s, f * s * s, 0.0), _ZERO3[0]))
        return SurfacePoint(d, np.array((near.x, near.y, z)), np.array((s, -c, 0.0)), hess)

    def _edge_surface(self, x, y, z, d, vertex) -> SurfacePoint:
        """Return the surface data of a corner: the vertical line through it."""
        ex, ey = x - vertex.x, y - vertex.y
        rho = math.hypot(ex, ey)
        if rho > 0.0:
            sign = -1.0 if d < 0.0 else 1.0
            nx, ny = sign * ex / rho, sign * ey / rho
            f = sign / rho  # = 1 / d
            hess = np.array(((f * ny * ny, -f * nx * ny, 0.0), (-f * nx * ny, f * nx * nx, 0.0),
                             _ZERO3[0]))
        else:  # on the edge: the middle of its normal cone
            mid = 0.5 * (vertex.phi_in + vertex.phi_out)
            nx, ny = math.sin(mid), -math.cos(mid)
            hess = np.zeros((3, 3))
        line = (np.array((vertex.x, vertex.y, 0.0)), np.array(_Z))
        return SurfacePoint(d, np.array((vertex.x, vertex.y, z)), np.array((nx, ny, 0.0)), hess,
                            feature="edge", edge=line)

    def to_dict(self) -> Dict[str, Any]:
        return self.planar.to_dict()

    def describe(self) -> str:
        return f"{self.planar.describe()}, prism along z"


#: every 3D obstacle class by the scene file's type (planar types: :class:`Prism`)
SOLIDS = {"sphere": Sphere, "cylinder": Cylinder, "plane": Plane}
