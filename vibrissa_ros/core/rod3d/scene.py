"""
Scenes of the 3D whisker: obstacles in space, their validation and the scene-file mapping.

A :class:`Scene3D` holds :mod:`~.obstacles` values: spheres, infinite cylinders, half-spaces and
the prisms along z of planar scene obstacles. Its mapping (the YAML form of
:mod:`vibrissa_ros.scan.scene_file`, lengths in whisker lengths L)::

    obstacles:
      - {type: sphere, center: [0.3, 0.5, 0.1], r: 0.05}
      - {type: cylinder, point: [0.0, 0.6, 0.0], axis: [0.0, 0.0, 1.0], r: 0.03}
      - {type: plane, point: [0.0, 0.0, -0.2], normal: [0.0, 0.0, 1.0]}
      - {type: peg, x: -0.35, y: 0.45, r: 0.03}          # every planar type: its prism

Every planar scene file is therefore a 3D scene. The planar entries are built by the planar
scenes' own :func:`~vibrissa_ros.core.scenes.scene.obstacle_from_dict`, so their validation and
messages are the planar ones. The 3D whisker is frictionless: a scene or obstacle ``friction``
of 0 (or none) is accepted, any other is refused, unless the caller asks to drop it
(``drop_friction``: a planar scene with friction read as the same obstacles without it).

Validation: names unique, every obstacle valid, and no two obstacles overlapping or touching
where that is cheap to decide exactly: a sphere against anything (the other's signed distance at
its centre), two cylinders (the distance of their axes), two prisms (their planar outlines, as
the planar scene checks them), a cylinder along z and a prism, and a half-space against a
half-space or cylinder parallel to it. A half-space and an obstacle *not* parallel to it always
meet (they cannot be apart), and may: a pole standing on a floor, two walls meeting in a corner.
Other pairs (a tilted cylinder or a vertical half-space against a prism) are not checked.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from typing import Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .obstacles import SOLID_TYPES, SOLIDS, Cylinder, Obstacle3D, Plane, Prism, Sphere
from ..errors import ParameterError
from ..scenes.scene import OBSTACLE_TYPES, Obstacle, Scene, obstacle_from_dict

#: every obstacle type of a 3D scene file: the solids, then the planar types (as prisms)
TYPES_3D = SOLID_TYPES + OBSTACLE_TYPES
#: keys every 3D-only obstacle entry may have besides its shape
COMMON_KEYS_3D = ("type", "name", "friction")
#: shape keys of the 3D-only types, all required
SOLID_KEYS: Dict[str, Tuple[str, ...]] = {
    "sphere": ("center", "r"),
    "cylinder": ("point", "axis", "r"),
    "plane": ("point", "normal"),
}
_SOLID_HINT = {
    "sphere": "sphere: center [x, y, z], r",
    "cylinder": "cylinder: point [x, y, z], axis [ax, ay, az], r",
    "plane": "plane: point [x, y, z], normal [nx, ny, nz] (pointing away from the obstacle)",
}
#: keys of a scene mapping
SCENE_KEYS = ("friction", "obstacles")
#: |cos| of the angle below which an axis counts as parallel to a plane (exact tests only)
_PARALLEL = 1e-12


def _frictionless(what: str, value: Any, drop: bool) -> None:
    """Accept a friction coefficient of 0 or None (any valid one when ``drop``), else raise."""
    if value is None:
        return
    try:
        mu = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{what}friction = {value!r} must be a number") from None
    if not (math.isfinite(mu) and mu >= 0.0):
        raise ParameterError(f"{what}friction = {value!r} is not allowed; the Coulomb "
                             "coefficient must be finite and >= 0")
    if mu != 0.0 and not drop:
        raise ParameterError(
            f"{what}friction = {value!r} is not allowed; the 3D whisker is frictionless "
            "(friction is planar-only for now): give 0 or leave it out")


def obstacle3d_from_dict(entry: Mapping[str, Any], name: str,
                         drop_friction: bool = False) -> Obstacle3D:
    """
    Build one 3D obstacle from its scene-file entry.

    Parameters
    ----------
    entry : mapping
        The entry: ``type`` (one of :data:`TYPES_3D`), ``name``, ``friction`` (0 or absent)
        and the type's keys (:data:`SOLID_KEYS`; a planar type: the planar scene's keys).
    name : str
        The name used when the entry has none.
    drop_friction : bool, optional
        True: ignore a nonzero ``friction`` instead of refusing it.

    Returns
    -------
    Obstacle3D
        The obstacle; a planar type gives its :class:`~.obstacles.Prism`.

    Raises
    ------
    ParameterError
        Naming the offending key and what is allowed: an unknown type or key, a missing key, a
        bad value, or a nonzero friction.

    """
    if not isinstance(entry, Mapping):
        raise ParameterError(f"must be a mapping with a 'type' key, got {entry!r}")
    kind = entry.get("type")
    if kind is None:
        raise ParameterError(f"key 'type' is missing; allowed types: {', '.join(TYPES_3D)}")
    if kind not in TYPES_3D:
        raise ParameterError(f"unknown obstacle type {kind!r}; allowed: {', '.join(TYPES_3D)}")
    if kind not in SOLID_KEYS:  # a planar type: the planar scene's validation, then its prism
        entry = dict(entry)
        label = str(entry.get("name") or name)
        _frictionless(f"{label}: ", entry.get("friction"), drop_friction)
        entry.pop("friction", None)
        return Prism(obstacle_from_dict(entry, name))
    allowed = COMMON_KEYS_3D + SOLID_KEYS[kind]
    unknown = [k for k in entry if k not in allowed]
    if unknown:
        raise ParameterError(f"{kind}: unknown key(s) {', '.join(map(repr, unknown))}; allowed: "
                             f"{', '.join(allowed)}")
    name = str(entry.get("name") or name)
    for key in SOLID_KEYS[kind]:
        if key not in entry:
            raise ParameterError(f"{name}: key '{key}' is required ({_SOLID_HINT[kind]})")
    _frictionless(f"{name}: ", entry.get("friction"), drop_friction)
    shape = [entry[key] for key in SOLID_KEYS[kind]]
    return SOLIDS[kind](*shape, name=name)


@dataclass(frozen=True)
class Scene3D:
    """
    Obstacles of the 3D whisker (dimensionless lengths), frictionless.

    Validated on construction (see the module's docstring). The parameters are the
    dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    obstacles : sequence of Obstacle3D or Obstacle
        At least one obstacle; a planar scene obstacle is taken as its
        :class:`~.obstacles.Prism`. Unnamed ones (name left at the kind's default) are named by
        kind and index among that kind (``sphere0``, ``peg1``, ...). Stored as a tuple.

    Raises
    ------
    ParameterError
        When there is no obstacle, something is not an obstacle, two obstacles share a name,
        or two obstacles overlap or touch (where checked).

    """

    obstacles: Tuple[Obstacle3D, ...]

    def __post_init__(self):
        if isinstance(self.obstacles, (Obstacle3D, Obstacle)):
            raise ParameterError("a scene's obstacles must be a sequence of obstacles")
        obstacles = list(self.obstacles)
        if not obstacles:
            raise ParameterError("a scene needs at least one obstacle")
        counts: Dict[str, int] = {}
        named: List[Obstacle3D] = []
        for i, ob in enumerate(obstacles):
            if isinstance(ob, Obstacle):
                ob = Prism(ob)
            if not isinstance(ob, Obstacle3D):
                raise ParameterError(f"obstacle {i}: not an obstacle: {ob!r}")
            if ob.name == ob.kind:  # unnamed: the kind and its index among that kind
                ob = replace(ob, name=f"{ob.kind}{counts.get(ob.kind, 0)}")
            counts[ob.kind] = counts.get(ob.kind, 0) + 1
            named.append(ob)
        names = [ob.name for ob in named]
        for i, nm in enumerate(names):
            if nm in names[:i]:
                raise ParameterError(f"obstacle {i}: name {nm!r} is used twice; names must be "
                                     "unique")
        object.__setattr__(self, "obstacles", tuple(named))
        self._check_overlaps()

    # -- container ------------------------------------------------------------------------------
    def __iter__(self) -> Iterator[Obstacle3D]:
        return iter(self.obstacles)

    def __len__(self) -> int:
        return len(self.obstacles)

    def __getitem__(self, index: int) -> Obstacle3D:
        return self.obstacles[index]

    @property
    def names(self) -> Tuple[str, ...]:
        """Return the obstacles' names, in order."""
        return tuple(ob.name for ob in self.obstacles)

    @property
    def is_planar(self) -> bool:
        """Tell whether every obstacle is a prism (the scene is a planar scene extruded)."""
        return all(isinstance(ob, Prism) for ob in self.obstacles)

    def describe(self) -> str:
        """
        Return one line: the number of obstacles and each one's description.

        Returns
        -------
        str
            The description.

        """
        parts = "; ".join(ob.describe() for ob in self.obstacles)
        return f"3D scene of {len(self)} obstacle(s): {parts}"

    # -- geometry -------------------------------------------------------------------------------
    def signed_distances(self, points) -> np.ndarray:
        """
        Return every obstacle's signed distance of the points, negative inside.

        Parameters
        ----------
        points : array_like
            Points (m, 3) [L] (one point (3,) is read as (1, 3)).

        Returns
        -------
        numpy.ndarray
            d (k, m) [L]: row i is obstacle i's.

        """
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        return np.array([ob.signed_distance(p) for ob in self.obstacles]).reshape(len(self), -1)

    def signed_distance(self, points) -> np.ndarray:
        """
        Return the signed distance of the points to the nearest obstacle, negative inside one.

        Parameters
        ----------
        points : array_like
            Points (m, 3) [L].

        Returns
        -------
        numpy.ndarray
            d (m,) [L].

        """
        return np.min(self.signed_distances(points), axis=0)

    # -- scene files ----------------------------------------------------------------------------
    def to_dict(self) -> Dict[str, Any]:
        """
        Return the scene as a scene file's mapping; :meth:`from_dict` reads it back.

        Returns
        -------
        dict
            ``{'obstacles': [entry, ...]}``, lengths in L.

        """
        return {"obstacles": [ob.to_dict() for ob in self.obstacles]}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], drop_friction: bool = False) -> "Scene3D":
        """
        Build a scene from a scene file's mapping: ``obstacles`` (and ``friction``, 0).

        Parameters
        ----------
        data : mapping
            The mapping (lengths in L).
        drop_friction : bool, optional
            True: ignore nonzero friction coefficients (of the scene or of its obstacles)
            instead of refusing them, e.g. to read a planar scene file with friction.

        Returns
        -------
        Scene3D
            The scene.

        Raises
        ------
        ParameterError
            Naming the obstacle's index and the key: unknown keys, types or values, a nonzero
            friction, a repeated name or overlapping obstacles.

        """
        if not isinstance(data, Mapping):
            raise ParameterError("a scene must be a mapping with the key 'obstacles'")
        unknown = [k for k in data if k not in SCENE_KEYS]
        if unknown:
            raise ParameterError(f"unknown scene key(s) {', '.join(map(repr, unknown))}; "
                                 f"allowed: {', '.join(SCENE_KEYS)}")
        _frictionless("scene ", data.get("friction"), drop_friction)
        entries = data.get("obstacles")
        if not isinstance(entries, (list, tuple)) or not entries:
            raise ParameterError("key 'obstacles' must be a non-empty list of obstacles")
        obstacles = []
        counts: Dict[str, int] = {}
        for i, entry in enumerate(entries):
            kind = entry.get("type") if isinstance(entry, Mapping) else None
            kind = kind if isinstance(kind, str) else "obstacle"
            try:
                obstacles.append(obstacle3d_from_dict(entry, f"{kind}{counts.get(kind, 0)}",
                                                      drop_friction))
            except ParameterError as exc:
                raise ParameterError(f"obstacle {i}: {exc}") from None
            counts[kind] = counts.get(kind, 0) + 1
        return cls(tuple(obstacles))

    @classmethod
    def from_planar(cls, scene: Scene, drop_friction: bool = False) -> "Scene3D":
        """
        Return the 3D scene of a planar scene's obstacles (their prisms along z).

        Parameters
        ----------
        scene : Scene
            The planar scene.
        drop_friction : bool, optional
            True: drop nonzero friction coefficients instead of refusing them.

        Returns
        -------
        Scene3D
            The prisms, with the planar obstacles' names.

        Raises
        ------
        ParameterError
            When a friction coefficient is not 0 (unless ``drop_friction``).

        """
        _frictionless("scene ", scene.friction, drop_friction)
        obstacles = []
        for ob in scene.obstacles:
            if drop_friction:
                ob = replace(ob, friction=None)
            obstacles.append(Prism(ob))
        return cls(tuple(obstacles))

    # -- validation -----------------------------------------------------------------------------
    def _check_overlaps(self) -> None:
        obs = self.obstacles
        for i, a in enumerate(obs):
            for j in range(i + 1, len(obs)):
                b = obs[j]
                gap = _gap(a, b)
                if gap is not None and gap <= 0.0:
                    raise ParameterError(
                        f"obstacles {i} ({a.name}) and {j} ({b.name}) overlap or touch (gap "
                        f"{gap:.3g} L); obstacles must be apart")


def _gap(a: Obstacle3D, b: Obstacle3D) -> Optional[float]:
    """Return the gap of a and b (<= 0: they meet); None: not checked, or allowed to meet."""
    if isinstance(b, Sphere) and not isinstance(a, Sphere):
        a, b = b, a
    if isinstance(a, Sphere):  # exact: the ball meets b iff d_b(center) <= r
        return b.clearance_bound(a.center, a.r)
    kinds = (type(a), type(b))
    if kinds == (Cylinder, Cylinder):
        return _line_distance(a.point, a.axis, b.point, b.axis) - a.r - b.r
    if kinds == (Plane, Plane):
        na, nb = np.array(a.normal), np.array(b.normal)
        if float(na @ nb) <= -1.0 + _PARALLEL:  # facing each other: apart by the gap
            return float((np.array(b.point) - np.array(a.point)) @ na)
        return None  # two half-spaces that are not opposite always meet: allowed
    if Plane in kinds and Cylinder in kinds:
        plane, cyl = (a, b) if isinstance(a, Plane) else (b, a)
        if abs(float(np.array(plane.normal) @ np.array(cyl.axis))) > _PARALLEL:
            return None  # a cylinder not parallel to the plane crosses it: allowed
        return float(plane.signed_distance(np.array(cyl.point))[0]) - cyl.r
    if Prism in kinds and Cylinder in kinds:
        prism, cyl = (a, b) if isinstance(a, Prism) else (b, a)
        if abs(cyl.axis[2]) < 1.0 - _PARALLEL:
            return None  # a tilted cylinder against a planar outline: not checked
        return prism.clearance_bound(cyl.point, cyl.r)  # a disk's prism: exact
    if kinds == (Prism, Prism):
        try:
            Scene([a.planar, b.planar])
        except ParameterError as exc:  # the planar scene's overlap test, with its gap
            found = re.search(r"overlap or touch \(gap (\S+) L\)", str(exc))
            if found is None:
                raise
            return min(float(found.group(1)), 0.0)
        return math.inf
    return None  # a half-space against a prism, a tilted cylinder against a prism


def _line_distance(p1, a1, p2, a2) -> float:
    """Return the distance between the lines p1 + s a1 and p2 + t a2 (unit a1, a2)."""
    p1, a1, p2, a2 = (np.array(v, dtype=float) for v in (p1, a1, p2, a2))
    w = p2 - p1
    cross = np.cross(a1, a2)
    norm = float(np.linalg.norm(cross))
    if norm > 1e-12:
        return abs(float(w @ cross)) / norm
    return float(np.linalg.norm(w - (w @ a1) * a1))  # parallel


def has_solids(data: Any) -> bool:
    """
    Tell whether a scene mapping has an obstacle of a 3D-only type (sphere, cylinder, plane).

    Parameters
    ----------
    data : Any
        A scene file's mapping (anything else is no 3D scene).

    Returns
    -------
    bool
        True when some ``obstacles`` entry has a ``type`` of :data:`~.obstacles.SOLID_TYPES`.

    """
    if not isinstance(data, Mapping):
        return False
    entries = data.get("obstacles")
    if not isinstance(entries, Sequence) or isinstance(entries, str):
        return False
    return any(isinstance(e, Mapping) and e.get("type") in SOLID_TYPES for e in entries)
