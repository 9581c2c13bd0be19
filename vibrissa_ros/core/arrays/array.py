"""
A whisker array: each whisker's place on the head, its shape and its material, in SI units.

Conventions
-----------
Head frame
    Any right-handed frame fixed to the head; the rat's generator (:mod:`.rat`) uses WHISKiT's:
    x lateral (toward the right side), y rostral, z dorsal, origin at the mean of the basepoints.
    Positions are in metres.
Whisker base frame
    The 3D whisker's own (:class:`~vibrissa_ros.core.rod3d.pose.BasePose`): the unloaded
    whisker leaves its base along the base frame's +x and curves toward its +y. A whisker's
    ``base_quaternion`` (qw, qx, qy, qz), unit, scalar first, rotates base-frame vectors into the
    head frame: v_head = R(q) v_base.
Names, rows and columns
    Rows A-E (A dorsal). Columns in the standard numbering: 0 is the Greek (straddler) column
    (alpha, beta, gamma, delta caudal to rows A-D), 1-6 the numbered columns (rostral ones are
    shorter). The papers' released code ("Belli numbering") counts the Greek column as 1: its
    column c is ``column + 1`` here. A name is the side's letter, the row and the column: ``RC2``
    is the right C2, ``LA0`` the left alpha-row Greek whisker.
Dimensionless whiskers
    The mechanics core measures each whisker in its own length L (its arc length) and stiffness
    EI_b (at its base): :meth:`WhiskerArray.rod` gives the :class:`RodShape` (A L, k0 L, k1 L^2,
    taper, Poisson ratio) and the :class:`BasePose` whose position is the base point divided by
    that whisker's arc length (so one head frame in metres becomes one frame per whisker, in
    that whisker's L); the quaternion is unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Dict, Iterator, Mapping, Optional, Tuple, Union

from ..errors import InvalidPoseError, ParameterError
from ..rod3d.pose import UNIT_TOLERANCE, BasePose
from ..rod3d.shape import RodShape

SIDES = ("left", "right")
ROWS = ("A", "B", "C", "D", "E")
#: columns in the standard numbering (0: the Greek column)
COLUMNS = tuple(range(7))
#: the keys of one whisker's mapping (the array file's), in the order written
WHISKER_KEYS = ("name", "side", "row", "column", "base_position", "base_quaternion", "length",
                "parabola", "k0", "k1", "base_radius", "taper", "youngs_modulus", "poisson",
                "whisking")
#: the keys a whisker's mapping must have
REQUIRED_KEYS = ("name", "side", "row", "column", "base_position", "base_quaternion", "length",
                 "base_radius", "taper", "youngs_modulus", "poisson")
#: the keys of an array's mapping
ARRAY_KEYS = ("description", "whiskers")


def _fail(name: str, key: str, value, allowed: str):
    raise ParameterError(f"whisker {name}: {key} = {value!r} is not allowed; {allowed}")


def _real(name: str, key: str, value, allowed: str) -> float:
    """Return ``value`` as a finite float, or fail naming whisker and key."""
    if isinstance(value, bool):
        _fail(name, key, value, allowed)
    try:
        out = float(value)
    except (TypeError, ValueError):
        _fail(name, key, value, allowed)
    if not math.isfinite(out):
        _fail(name, key, value, allowed)
    return out


def _vector(name: str, key: str, value, size: int, allowed: str) -> Tuple[float, ...]:
    """Return ``value`` as a tuple of ``size`` finite floats, or fail naming whisker and key."""
    if isinstance(value, (str, bytes, Mapping)):
        _fail(name, key, value, allowed)
    try:
        values = tuple(value)
    except TypeError:
        _fail(name, key, value, allowed)
    if len(values) != size:
        _fail(name, key, value, allowed)
    return tuple(_real(name, key, v, allowed) for v in values)


@dataclass(frozen=True)
class WhiskerSpec:
    """
    One whisker of an array: where it sits on the head, its shape and its material (SI units).

    The parameters are the dataclass's fields, kept as attributes of the same names; numbers are
    stored as floats (``column`` as an int), vectors as tuples.

    Parameters
    ----------
    name : str
        Unique within the array, no whitespace, e.g. ``RC2`` (side letter, row, column).
    side : str
        ``left`` or ``right``.
    row : str
        Row letter ``A``-``E`` (A dorsal).
    column : int
        Column 0-6 in the standard numbering (0: the Greek column; Belli's c = column + 1).
    base_position : tuple of float
        The base point (x, y, z) in the head frame [m].
    base_quaternion : tuple of float
        (qw, qx, qy, qz), a unit quaternion (within 1e-6; stored as given) rotating the whisker's
        base frame (leaves along +x, curves toward +y) into the head frame.
    length : float
        Arc length S [m], > 0.
    base_radius : float
        Radius at the base [m], > 0.
    taper : float
        Tip radius / base radius, in (0, 1] (a solid cone).
    youngs_modulus : float
        E [Pa], > 0.
    poisson : float
        Poisson ratio nu in [0, 0.5].
    parabola : float or None, optional
        A [1/m] of the parabola y = A x^2 the unloaded whisker follows from its base (the
        morphology papers' shape); abs(A length) <= 10. Not with ``k0``/``k1``.
    k0, k1 : float, optional
        Intrinsic curvature kappa0(s) = k0 + k1 s, k0 [1/m], k1 [1/m^2];
        abs(k0 length) + abs(k1 length^2) <= 20. Not with ``parabola``.
    whisking : tuple of float, optional
        (dphi/dtheta, dzeta/dtheta): how elevation and roll follow protraction
        (:mod:`.whisking`); finite, each within [-5, 5]; default (0, 0).

    Raises
    ------
    ParameterError
        One line naming the whisker and the key and saying what is allowed.

    """

    name: str
    side: str
    row: str
    column: int
    base_position: Tuple[float, float, float]
    base_quaternion: Tuple[float, float, float, float]
    length: float
    base_radius: float
    taper: float
    youngs_modulus: float
    poisson: float
    parabola: Optional[float] = None
    k0: float = 0.0
    k1: float = 0.0
    whisking: Tuple[float, float] = (0.0, 0.0)

    def __post_init__(self):
        name = self.name
        if not isinstance(name, str) or not name or any(c.isspace() for c in name):
            raise ParameterError(f"whisker name = {name!r} is not allowed; a name is a non-empty "
                                 "string without whitespace (e.g. RC2)")
        put = object.__setattr__
        if self.side not in SIDES:
            _fail(name, "side", self.side, "side is left or right")
        if self.row not in ROWS:
            _fail(name, "row", self.row, "row is one of the letters A, B, C, D, E")
        if (isinstance(self.column, bool) or not isinstance(self.column, (int, float))
                or self.column != int(self.column) or int(self.column) not in COLUMNS):
            _fail(name, "column", self.column,
                  "column is an integer 0-6 (0: the Greek column, standard numbering)")
        put(self, "column", int(self.column))
        put(self, "base_position", _vector(name, "base_position", self.base_position, 3,
                                           "base_position is [x, y, z] in metres, finite"))
        q = _vector(name, "base_quaternion", self.base_quaternion, 4,
                    "base_quaternion is a unit quaternion [qw, qx, qy, qz]")
        norm = math.sqrt(sum(v * v for v in q))
        if abs(norm - 1.0) > UNIT_TOLERANCE:
            _fail(name, "base_quaternion", list(q),
                  f"base_quaternion [qw, qx, qy, qz] must have length 1 (within "
                  f"{UNIT_TOLERANCE:g}); its length is {norm:.9g}")
        put(self, "base_quaternion", q)
        for key, allowed, ok in (
                ("length", "length (arc length) is in metres, > 0", lambda v: v > 0.0),
                ("base_radius", "base_radius is in metres, > 0", lambda v: v > 0.0),
                ("taper", "taper (tip radius / base radius) is in (0, 1]",
                 lambda v: 0.0 < v <= 1.0),
                ("youngs_modulus", "youngs_modulus is in pascals, > 0", lambda v: v > 0.0),
                ("poisson", "poisson (Poisson ratio) is in [0, 0.5]", lambda v: 0.0 <= v <= 0.5),
                ("k0", "k0 is a finite curvature [1/m]", lambda v: True),
                ("k1", "k1 is a finite curvature slope [1/m^2]", lambda v: True)):
            value = _real(name, key, getattr(self, key), allowed)
            if not ok(value):
                _fail(name, key, getattr(self, key), allowed)
            put(self, key, value)
        slopes = _vector(name, "whisking", self.whisking, 2,
                         "whisking is [dphi/dtheta, dzeta/dtheta], finite, each within [-5, 5]")
        if any(abs(v) > 5.0 for v in slopes):
            _fail(name, "whisking", list(slopes),
                  "whisking is [dphi/dtheta, dzeta/dtheta], each within [-5, 5]")
        put(self, "whisking", slopes)
        if self.parabola is not None:
            put(self, "parabola", _real(name, "parabola", self.parabola,
                                        "parabola is a finite A [1/m] (y = A x^2)"))
            if self.k0 != 0.0 or self.k1 != 0.0:
                _fail(name, "parabola", self.parabola,
                      "give either parabola or the curvature k0/k1, not both")
            if abs(self.parabola * self.length) > 10.0:
                _fail(name, "parabola", self.parabola,
                      "|parabola * length| must be <= 10 "
                      f"(here {self.parabola * self.length:.6g})")
        elif abs(self.k0 * self.length) + abs(self.k1 * self.length ** 2) > 20.0:
            _fail(name, "k0", self.k0, "|k0 length| + |k1 length^2| must be <= 20 (the whisker "
                  "would curl more than about three turns)")

    @property
    def shape(self) -> RodShape:
        """Return the dimensionless :class:`RodShape` (A L, k0 L, k1 L^2, taper, poisson)."""
        L = self.length
        if self.parabola is not None:
            return RodShape(taper=self.taper, parabola=self.parabola * L, poisson=self.poisson)
        return RodShape(taper=self.taper, k0=self.k0 * L, k1=self.k1 * L * L,
                        poisson=self.poisson)

    @property
    def bending_stiffness(self) -> float:
        """EI at the base [N m^2]: E pi r^4 / 4 (solid circular section)."""
        return self.youngs_modulus * math.pi * self.base_radius ** 4 / 4.0

    def to_dict(self) -> Dict[str, Any]:
        """
        Return the whisker's mapping (the array file's entry), SI units.

        Returns
        -------
        dict
            Keys of :data:`WHISKER_KEYS`; ``parabola`` or ``k0``/``k1`` (the one in use);
            ``whisking`` when not (0, 0).

        """
        out: Dict[str, Any] = {}
        for key in WHISKER_KEYS:
            value = getattr(self, key)
            if key == "parabola" and value is None:
                continue
            if key in ("k0", "k1") and (self.parabola is not None
                                        or (self.k0 == 0.0 and self.k1 == 0.0)):
                continue
            if key == "whisking" and value == (0.0, 0.0):
                continue
            out[key] = list(value) if isinstance(value, tuple) else value
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], index: int = 0) -> "WhiskerSpec":
        """
        Build a whisker from its mapping; unknown and missing keys are refused.

        Parameters
        ----------
        data : mapping
            Keys of :data:`WHISKER_KEYS` (``parabola``, ``k0``, ``k1``, ``whisking`` optional).
        index : int, optional
            Its place in the array (0-based), to name it when it has no usable name.

        Returns
        -------
        WhiskerSpec
            The whisker.

        Raises
        ------
        ParameterError
            One line naming the whisker (its name, else ``#index``) and the key.

        """
        label = f"#{index}"
        if not isinstance(data, Mapping):
            raise ParameterError(f"whisker {label}: an entry is a mapping of keys "
                                 f"({', '.join(REQUIRED_KEYS)}), not {data!r}")
        name = data.get("name")
        if isinstance(name, str) and name and not any(c.isspace() for c in name):
            label = name
        for key in data:
            if key not in WHISKER_KEYS:
                raise ParameterError(f"whisker {label}: unknown key {key!r}; allowed keys: "
                                     f"{', '.join(WHISKER_KEYS)}")
        for key in REQUIRED_KEYS:
            if key not in data:
                raise ParameterError(f"whisker {label}: missing key {key!r}")
        kwargs = dict(data)
        kwargs.setdefault("k0", 0.0)
        kwargs.setdefault("k1", 0.0)
        return cls(**kwargs)


@dataclass(frozen=True)
class WhiskerRod:
    """
    One whisker ready for the mechanics core: dimensionless shape and pose, and its scales.

    Parameters
    ----------
    name : str
        The whisker's name.
    shape : RodShape
        Taper, intrinsic curvature (in 1/L of this whisker) and Poisson ratio.
    pose : BasePose
        The base in the head frame, position in this whisker's lengths (metres / ``length``).
    length : float
        L [m]: multiply dimensionless lengths by it.
    bending_stiffness : float
        EI_b [N m^2] at the base: forces scale by EI_b / L^2, moments by EI_b / L.

    """

    name: str
    shape: RodShape
    pose: BasePose
    length: float
    bending_stiffness: float


@dataclass(frozen=True)
class WhiskerArray:
    """
    Whiskers on a head: a tuple of :class:`WhiskerSpec` with unique names.

    Parameters
    ----------
    whiskers : tuple of WhiskerSpec
        At least one; names unique.
    description : str, optional
        Free text (where the array comes from).

    Raises
    ------
    ParameterError
        When there is no whisker, an entry is not a WhiskerSpec or two share a name.

    """

    whiskers: Tuple[WhiskerSpec, ...]
    description: str = ""

    def __post_init__(self):
        whiskers = tuple(self.whiskers)
        if not whiskers:
            raise ParameterError("whisker array: whiskers = [] is not allowed; an array has at "
                                 "least one whisker")
        seen = set()
        for i, w in enumerate(whiskers):
            if not isinstance(w, WhiskerSpec):
                raise ParameterError(f"whisker #{i}: {w!r} is not a WhiskerSpec")
            if w.name in seen:
                raise ParameterError(f"whisker {w.name}: name = {w.name!r} is not allowed; "
                                     "names must be unique in the array")
            seen.add(w.name)
        if not isinstance(self.description, str):
            raise ParameterError(f"whisker array: description = {self.description!r} is not "
                                 "allowed; a description is text")
        object.__setattr__(self, "whiskers", whiskers)

    def __len__(self) -> int:
        """Return the number of whiskers."""
        return len(self.whiskers)

    def __iter__(self) -> Iterator[WhiskerSpec]:
        """Iterate over the whiskers in order."""
        return iter(self.whiskers)

    @property
    def names(self) -> Tuple[str, ...]:
        """Return the whiskers' names, in order."""
        return tuple(w.name for w in self.whiskers)

    def __getitem__(self, key: Union[int, str]) -> WhiskerSpec:
        """
        Return a whisker by position or by name.

        Parameters
        ----------
        key : int or str
            Index, or name (e.g. ``RC2``).

        Returns
        -------
        WhiskerSpec
            The whisker.

        Raises
        ------
        KeyError
            When no whisker has that name.

        """
        if isinstance(key, str):
            for w in self.whiskers:
                if w.name == key:
                    return w
            raise KeyError(f"no whisker named {key!r} (the array has {', '.join(self.names)})")
        return self.whiskers[key]

    def side(self, side: str) -> "WhiskerArray":
        """
        Return the whiskers of one side.

        Parameters
        ----------
        side : str
            ``left`` or ``right``.

        Returns
        -------
        WhiskerArray
            That side's whiskers, in order.

        Raises
        ------
        ParameterError
            When ``side`` is not left or right, or the array has none on that side.

        """
        if side not in SIDES:
            raise ParameterError(f"side = {side!r} is not allowed; side is left or right")
        return WhiskerArray(tuple(w for w in self.whiskers if w.side == side), self.description)

    def rod(self, key: Union[int, str]) -> WhiskerRod:
        """
        Return one whisker for the mechanics core (dimensionless in its own length).

        Parameters
        ----------
        key : int or str
            Index or name.

        Returns
        -------
        WhiskerRod
            Its :class:`RodShape` (A L, k0 L, k1 L^2), its :class:`BasePose` in the head frame
            with the position divided by its arc length L, and L [m] and EI_b [N m^2].

        """
        w = self[key]
        try:
            pose = BasePose(tuple(v / w.length for v in w.base_position), w.base_quaternion)
        except InvalidPoseError as exc:  # pragma: no cover - the spec was checked
            raise ParameterError(f"whisker {w.name}: {exc}") from None
        return WhiskerRod(w.name, w.shape, pose, w.length, w.bending_stiffness)

    def rods(self) -> Tuple[WhiskerRod, ...]:
        """
        Return every whisker for the mechanics core, in order (see :meth:`rod`).

        Returns
        -------
        tuple of WhiskerRod
            One per whisker.

        """
        return tuple(self.rod(i) for i in range(len(self.whiskers)))

    def to_dict(self) -> Dict[str, Any]:
        """
        Return the array's mapping (the array file's content), SI units.

        Returns
        -------
        dict
            ``description`` (when not empty) and ``whiskers``: a list of whisker mappings.

        """
        out: Dict[str, Any] = {}
        if self.description:
            out["description"] = self.description
        out["whiskers"] = [w.to_dict() for w in self.whiskers]
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "WhiskerArray":
        """
        Build an array from its mapping; unknown keys are refused.

        Parameters
        ----------
        data : mapping
            ``whiskers`` (a list of whisker mappings, see :meth:`WhiskerSpec.from_dict`) and an
            optional ``description``.

        Returns
        -------
        WhiskerArray
            The array.

        Raises
        ------
        ParameterError
            One line naming the whisker (or the array) and the key.

        """
        if not isinstance(data, Mapping):
            raise ParameterError("whisker array: an array is a mapping with keys "
                                 f"{', '.join(ARRAY_KEYS)}, not {type(data).__name__}")
        for key in data:
            if key not in ARRAY_KEYS:
                raise ParameterError(f"whisker array: unknown key {key!r}; allowed keys: "
                                     f"{', '.join(ARRAY_KEYS)}")
        entries = data.get("whiskers")
        if not isinstance(entries, list):
            raise ParameterError(f"whisker array: whiskers = {entries!r} is not allowed; "
                                 "whiskers is a list of whisker mappings")
        description = data.get("description", "")
        if description is None:
            description = ""
        return cls(tuple(WhiskerSpec.from_dict(e, i) for i, e in enumerate(entries)),
                   description)
