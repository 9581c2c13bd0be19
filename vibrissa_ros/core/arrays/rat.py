"""
The rat's mystacial pad from the published morphology (Belli et al. 2018, Towal et al. 2011).

Sources (the project's reference sheet on the rat array gathers them): Belli, Bresee, Graff &
Hartmann 2018, PLoS ONE 13:e0194981 (every parameter from the basepoint), as the lab's released
code computes it (WHISKiT Physics, ``compute_parameters.m``); Towal et al. 2011, PLoS Comput
Biol 7:e1001120 (RatMap: arc length and curvature linear in row and column); Belli et al. 2017,
J Neurophysiol 117:1807 (base diameter); Quist et al. 2011 (Young's modulus), Quist & Hartmann
2012 (taper).

Numbering. The equations use Belli numbering: row r = 1 (A) ... 5 (E) and column c with the Greek
column = 1; a whisker's ``column`` here is the standard one (Greek = 0), so c = column + 1. With
this numbering Towal's equations give C2 an arc length of 35.0 mm and a = 0.0233 /mm, the values
Quist & Hartmann 2012 quote for a C2 (test/test_rat_array.py checks it).

Head frame (WHISKiT's): x lateral toward the right side, y rostral, z dorsal [m]; origin at
Belli's basepoint-sphere centre. Belli's basepoint, as WHISKiT computes it (not the textbook
spherical map): x = rbp cos(theta_bp), y = rbp sin(theta_bp), z = rbp sin(phi_bp).

Orientation. WHISKiT draws the unloaded right-side whisker in its own frame as (x, 0, -A x^2) and
orients it by R_w = Rz(theta_w - 90 deg) Ry(-phi_w) Rx(zeta_w) (active rotations of column vectors,
applied right to left: roll zeta_w about the whisker's axis, then elevation phi_w, then azimuth).
The 3D whisker here leaves along its base frame's +x and curves toward +y: its base frame is
WHISKiT's whisker frame turned by Rx(-90 deg) (+y_base = -z_whiskit), so the base quaternion is
that of R = Rz(theta_w - 90 deg) Ry(-phi_w) Rx(zeta_w - 90 deg). The base tangent's azimuth from
+x is theta_w - 90 deg and its elevation phi_w, whatever the Euler convention.

Sides. The left side is the mirror image of the right in the head's midsagittal plane x = 0:
position (x, y, z) -> (-x, y, z); the base frame's +x and +y axes (tangent and direction of
curvature) are mirrored, and its +z = x cross y follows: R_left = M R_right diag(1, 1, -1) with
M = diag(-1, 1, 1) (WHISKiT: theta_w -> -theta_w, zeta_w -> -zeta_w). Shapes are equal.

Whiskers. ``belli2018``: WHISKiT's 30 per side (A0-A4, B0-B4, C0-C6, D0-D6, E1-E6), every
parameter from Belli's equations. ``towal2011``: Towal's 31 per side (adds B5); arc length and
curvature from Towal's row/column fits. The sheet gives Towal's basepoint ellipsoid without the map
from (theta_BP, phi_BP) to the ellipsoid and gives no Towal angles of emergence, so base points
and orientations of ``towal2011`` are Belli's equations evaluated at the same row and column (an
honest hybrid: Towal's shapes on Belli's pad, said in the array's description).
"""

from __future__ import annotations

import math
from typing import Dict, Tuple

import numpy as np

from ..errors import ParameterError
from ..rod3d.pose import quat_from_matrix
from .array import ROWS, WhiskerArray, WhiskerSpec
from .whisking import ROW_SLOPES

MODELS = ("belli2018", "towal2011")
SIDES = ("left", "right", "both")
#: WHISKiT's whiskers per side (standard columns, Greek = 0)
BELLI_COLUMNS: Dict[str, Tuple[int, ...]] = {
    "A": tuple(range(0, 5)), "B": tuple(range(0, 5)), "C": tuple(range(0, 7)),
    "D": tuple(range(0, 7)), "E": tuple(range(1, 7))}
#: Towal et al. 2011's whiskers per side
TOWAL_COLUMNS: Dict[str, Tuple[int, ...]] = {
    "A": tuple(range(0, 5)), "B": tuple(range(0, 6)), "C": tuple(range(0, 7)),
    "D": tuple(range(0, 7)), "E": tuple(range(1, 7))}
#: Young's modulus [Pa]: Quist et al. 2011, 3.34 +- 1.48 GPa (WHISKiT uses 5 GPa)
YOUNGS_MODULUS = 3.34e9
#: Poisson ratio (Elastica3D's default)
POISSON = 0.38
#: base radius / tip radius (Quist & Hartmann 2012; Elastica3D's default)
TAPER_RATIO = 15.0
_MM = 1e-3


def belli_basepoint(r: int, c: int) -> Tuple[float, float, float]:
    """
    Return Belli 2018's basepoint angles and radius of row ``r`` and column ``c``.

    Parameters
    ----------
    r : int
        Row, 1 (A) ... 5 (E).
    c : int
        Column in Belli numbering (Greek = 1).

    Returns
    -------
    tuple of float
        (theta_bp [deg], phi_bp [deg], r_bp [mm]): theta_bp = 13.4 c - 48.6,
        phi_bp = 1.49 r^2 - 26.3 r + 68.0,
        r_bp = 0.000511 theta_bp^2 - 0.0295 theta_bp - 0.0162 phi_bp + 6.5.

    """
    theta = 13.4 * c - 48.6
    phi = 1.49 * r * r - 26.3 * r + 68.0
    radius = 0.000511 * theta * theta - 0.0295 * theta - 0.0162 * phi + 6.5
    return theta, phi, radius


def belli_position(theta_bp: float, phi_bp: float, r_bp: float) -> Tuple[float, float, float]:
    """
    Return the right-side basepoint [mm] as WHISKiT computes it from Belli's angles.

    Parameters
    ----------
    theta_bp, phi_bp : float
        Basepoint angles [deg].
    r_bp : float
        Basepoint radius [mm].

    Returns
    -------
    tuple of float
        (r cos theta, r sin theta, r sin phi) [mm] in the head frame (x lateral, y rostral,
        z dorsal).

    """
    t, p = math.radians(theta_bp), math.radians(phi_bp)
    return r_bp * math.cos(t), r_bp * math.sin(t), r_bp * math.sin(p)


def belli_shape(theta_bp: float) -> Tuple[float, float]:
    """
    Return Belli 2018's arc length and parabola coefficient.

    Parameters
    ----------
    theta_bp : float
        Basepoint azimuth [deg].

    Returns
    -------
    tuple of float
        (S [mm], A [1/mm]): S = exp(-0.0246 theta_bp + 3.12), A = 0.000240 theta_bp + 0.0148.

    """
    return math.exp(-0.0246 * theta_bp + 3.12), 0.000240 * theta_bp + 0.0148


def belli_emergence(theta_bp: float, phi_bp: float) -> Tuple[float, float, float]:
    """
    Return Belli 2018's angles of emergence of the right-side whisker.

    Parameters
    ----------
    theta_bp, phi_bp : float
        Basepoint angles [deg].

    Returns
    -------
    tuple of float
        (theta_w, phi_w, zeta_w) [deg]: theta_w = 0.598 theta_bp - 0.314 phi_bp + 67.4,
        phi_w = 1.04 phi_bp + 6.68, zeta_w = 0.876 theta_bp + 0.845 phi_bp + 37.9.

    """
    return (0.598 * theta_bp - 0.314 * phi_bp + 67.4, 1.04 * phi_bp + 6.68,
            0.876 * theta_bp + 0.845 * phi_bp + 37.9)


def towal_shape(r: int, c: int) -> Tuple[float, float]:
    """
    Return Towal 2011's arc length and parabola coefficient of row ``r``, column ``c``.

    Parameters
    ----------
    r : int
        Row, 1 (A) ... 5 (E).
    c : int
        Column in Belli numbering (Greek = 1), as the lab's toolbox evaluates the fits.

    Returns
    -------
    tuple of float
        (S [mm], a [1/mm]): S = -7.9312 c + 2.2224 r + 52.111,
        a = exp(1 / (-0.02052 c - 0.2045)).

    """
    return -7.9312 * c + 2.2224 * r + 52.111, math.exp(1.0 / (-0.02052 * c - 0.2045))


def base_diameter(length_mm: float, r: int, column: int) -> float:
    """
    Return the base diameter of Belli et al. 2017 [mm], as WHISKiT codes it.

    Parameters
    ----------
    length_mm : float
        Arc length S [mm].
    r : int
        Row, 1 (A) ... 5 (E).
    column : int
        Standard column (Greek = 0), as WHISKiT evaluates this fit.

    Returns
    -------
    float
        d_base = 0.041 + 0.002 S + 0.011 r - 0.0039 column [mm].

    """
    return 0.041 + 0.002 * length_mm + 0.011 * r - 0.0039 * column


def _rz(deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array(((c, -s, 0.0), (s, c, 0.0), (0.0, 0.0, 1.0)))


def _ry(deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array(((c, 0.0, s), (0.0, 1.0, 0.0), (-s, 0.0, c)))


def _rx(deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array(((1.0, 0.0, 0.0), (0.0, c, -s), (0.0, s, c)))


def emergence_rotation(theta_w: float, phi_w: float, zeta_w: float) -> np.ndarray:
    """
    Return the right-side whisker's base frame in the head frame (columns: its axes).

    Parameters
    ----------
    theta_w, phi_w, zeta_w : float
        Belli's angles of emergence [deg].

    Returns
    -------
    numpy.ndarray
        R (3, 3) = Rz(theta_w - 90) Ry(-phi_w) Rx(zeta_w) Rx(-90): WHISKiT's orientation of its
        whisker frame, times the turn from the base frame here (+x along, +y toward the
        curvature) to WHISKiT's (+x along, curving toward -z).

    """
    return _rz(theta_w - 90.0) @ _ry(-phi_w) @ _rx(zeta_w) @ _rx(-90.0)


#: the head's midsagittal mirror (x -> -x)
MIRROR = np.diag((-1.0, 1.0, 1.0))


def mirror_rotation(R) -> np.ndarray:
    """
    Return the mirror image of a base frame in the midsagittal plane x = 0.

    Parameters
    ----------
    R : array_like
        A base frame (3, 3) in the head frame (columns: its axes).

    Returns
    -------
    numpy.ndarray
        M R diag(1, 1, -1): the tangent (+x) and the direction of curvature (+y) mirrored, +z
        their cross product (a proper rotation again).

    """
    return MIRROR @ np.asarray(R, dtype=float) @ np.diag((1.0, 1.0, -1.0))


def _whisker(side: str, row: str, column: int, model: str) -> WhiskerSpec:
    """Return one whisker of the model rat (right side computed, left mirrored)."""
    r, c = ROWS.index(row) + 1, column + 1
    theta_bp, phi_bp, r_bp = belli_basepoint(r, c)
    position = np.array(belli_position(theta_bp, phi_bp, r_bp)) * _MM
    R = emergence_rotation(*belli_emergence(theta_bp, phi_bp))
    if model == "belli2018":
        length_mm, a_mm = belli_shape(theta_bp)
    else:
        length_mm, a_mm = towal_shape(r, c)
    if side == "left":
        position = MIRROR @ position
        R = mirror_rotation(R)
    return WhiskerSpec(
        name=f"{side[0].upper()}{row}{column}", side=side, row=row, column=column,
        base_position=tuple(float(v) for v in position),
        base_quaternion=tuple(float(v) for v in quat_from_matrix(R)),
        length=length_mm * _MM, parabola=a_mm / _MM,
        base_radius=0.5 * base_diameter(length_mm, r, column) * _MM,
        taper=1.0 / TAPER_RATIO, youngs_modulus=YOUNGS_MODULUS, poisson=POISSON,
        whisking=ROW_SLOPES[row])


def rat_array(side: str = "both", model: str = "belli2018") -> WhiskerArray:
    """
    Return the rat's whisker array from the published equations.

    Taper rule: every whisker is a cone with tip radius = base radius / 15 (Quist & Hartmann
    2012's measured ratio, Elastica3D's default). The alternative, the radius slope fit of Belli
    2017 (r_tip = r_base - slope S), gives a tip radius <= 0 for 11 of the 30 whiskers of this
    model rat, and WHISKiT's halved version with a 1.5 um floor leaves 16 of 30 on the floor: a
    constant ratio keeps every whisker a physical cone (0 < taper < 1) whose stiffness scales
    with its own base diameter, which is the fit the data support.

    Parameters
    ----------
    side : str, optional
        ``left``, ``right`` or ``both`` (right side first, then left).
    model : str, optional
        ``belli2018`` (30 whiskers per side, every parameter from Belli et al. 2018) or
        ``towal2011`` (31 per side, Towal et al. 2011's arc lengths and curvatures on Belli's
        base points and orientations).

    Returns
    -------
    WhiskerArray
        Positions [m] and orientations in the head frame (x lateral toward the right, y
        rostral, z dorsal), arc lengths [m], parabola A [1/m], base radius [m], taper 1/15,
        E = 3.34 GPa, nu = 0.38.

    Raises
    ------
    ParameterError
        When ``side`` or ``model`` is not one of the allowed values.

    """
    if side not in SIDES:
        raise ParameterError(f"side = {side!r} is not allowed; side is left, right or both")
    if model not in MODELS:
        raise ParameterError(f"model = {model!r} is not allowed; model is "
                             f"{' or '.join(MODELS)}")
    columns = BELLI_COLUMNS if model == "belli2018" else TOWAL_COLUMNS
    sides = ("right", "left") if side == "both" else (side,)
    whiskers = tuple(_whisker(s, row, col, model)
                     for s in sides for row in ROWS for col in columns[row])
    if model == "belli2018":
        what = ("rat whisker array, Belli et al. 2018 model rat (every parameter from the "
                "basepoint, as WHISKiT computes it)")
    else:
        what = ("rat whisker array, Towal et al. 2011 arc lengths and curvatures on Belli et "
                "al. 2018 base points and angles of emergence")
    description = (f"{what}; base diameter Belli et al. 2017; taper 1/15; E {YOUNGS_MODULUS:g} "
                   f"Pa; nu {POISSON:g}; whisking slopes per row Knutsen et al. 2008 as RatMap "
                   "and WHISKiT use them; head frame x lateral (right), y rostral, z dorsal [m]; "
                   "left = right mirrored in x = 0")
    return WhiskerArray(whiskers, description)
