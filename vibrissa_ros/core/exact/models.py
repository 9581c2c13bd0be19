"""
Whisker models behind one interface: the equations of a contact branch in the contact frame.

The tracker (:mod:`vibrissa_ros.core.exact.tracker`) follows equilibria of a model against a
profile. It works in the *contact frame*: foot at the origin, undeformed whisker along +y, and
mirrored (x -> -x) when the whisker bends counter-clockwise, so that every model only ever solves
the clockwise case (paper §2, WH1). A contact branch is described by two unknowns ``z = (alpha,
mu)`` where ``alpha`` is the profile slope at the contact (contact frame); the tracker solves

    load_point(phase, z) = Q(alpha)    (the whisker's contact point lies on the profile)

where Q is the profile point of slope alpha. Each model says which inequalities bound each phase
(:meth:`events`) and what happens when one becomes an equality (:meth:`transition`).
"""

from __future__ import annotations

import math
from typing import Dict, Tuple

import numpy as np

from .elastica import family, family_centerline, family_domain_ok
from ..errors import ModelAssumptionError
from ..state import Phase

HALF_PI = 0.5 * math.pi


class ElasticaModel:
    """
    The inextensible Euler-Bernoulli elastica clamped at the foot (paper §2).

    Unknowns: phase 1 (tangential) ``z = (alpha, lam)`` with lam = 1/sqrt(f); phase 2 (tip)
    ``z = (alpha, gamma)`` with gamma = pi/2 - phi(1), the tip's rotation.
    """

    name = "elastica"
    #: near zero force the branch ends where the straight whisker touches (located on the pose)
    release_by_gap = True

    def __init__(self):
        self._memo_key = None
        self._memo = None

    def _values(self, alpha: float, gamma: float):
        """Return the value-only family, remembered for the last arguments (one state's values)."""
        key = (alpha, gamma)
        if key != self._memo_key:
            self._memo = family(alpha, gamma, False)
            self._memo_key = key
        return self._memo

    # -- branch equations ------------------------------------------------------------------
    def load_point(self, phase: Phase, z) -> Tuple[float, float, float, float, float, float]:
        """
        Return the contact point on the whisker and its Jacobian.

        As (Px, Py, dPx/dz0, dPx/dz1, dPy/dz0, dPy/dz1).
        """
        alpha, mu = z
        ca, sa = math.cos(alpha), math.sin(alpha)
        if phase == Phase.TANGENTIAL:
            fam = family(alpha, HALF_PI - alpha)
            A, N = fam.A, fam.N
            # d/dalpha along gamma = pi/2 - alpha (delta = 0): (A' - N) a + (A + N') n, N' = -A/2
            ga = fam.A_a - fam.A_g - N
            gn = A + fam.N_a - fam.N_g
            cx = A * ca - N * sa
            cy = A * sa + N * ca
            return (
                mu * cx,
                mu * cy,
                mu * (ga * ca - gn * sa),
                cx,
                mu * (ga * sa + gn * ca),
                cy,
            )
        fam = family(alpha, mu)
        A, N, S = fam.A, fam.N, fam.S
        cx = A * ca - N * sa
        cy = A * sa + N * ca
        # C_alpha = (A_a - N) a + (A + N_a) n ; C_gamma = A_g a + N_g n ; P = C / S
        ua, un = fam.A_a - N, A + fam.N_a
        cax, cay = ua * ca - un * sa, ua * sa + un * ca
        cgx, cgy = fam.A_g * ca - fam.N_g * sa, fam.A_g * sa + fam.N_g * ca
        inv = 1.0 / S
        inv2 = inv * inv
        return (
            cx * inv,
            cy * inv,
            (cax * S - cx * fam.S_a) * inv2,
            (cgx * S - cx * fam.S_g) * inv2,
            (cay * S - cy * fam.S_a) * inv2,
            (cgy * S - cy * fam.S_g) * inv2,
        )

    def valid(self, phase: Phase, z) -> bool:
        """Whether ``z`` lies where the branch equations are defined."""
        alpha, mu = z
        if not (math.isfinite(alpha) and math.isfinite(mu)):
            return False
        if phase == Phase.TANGENTIAL:
            return -HALF_PI < alpha < HALF_PI and mu > 0.0
        return family_domain_ok(alpha, mu)

    def events(self, phase: Phase, z) -> Dict[str, float]:
        """
        Functions that are positive inside the phase; a zero is an event.

        phase 1: ``tip`` = 1 - s1 (the contact reaches the tip, paper eq. 13);
        phase 2: ``tangential`` = delta = phi(1) - alpha (the tip becomes tangent to the profile),
        ``wh1`` = gamma/2 + alpha (kappa(0) -> 0: an inflection would appear, WH1 fails).
        """
        alpha, mu = z
        if phase == Phase.TANGENTIAL:
            fam = self._values(alpha, HALF_PI - alpha)
            return {"tip": 1.0 - mu * fam.S}
        return {"tangential": HALF_PI - alpha - mu, "wh1": 0.5 * mu + alpha}

    def transition(self, phase: Phase, event: str, z) -> Tuple[Phase, Tuple[float, float]]:
        """Return the phase and unknowns on the other side of ``event``."""
        alpha, mu = z
        if phase == Phase.TANGENTIAL and event == "tip":
            return Phase.TIP, (alpha, HALF_PI - alpha)
        if phase == Phase.TIP and event == "tangential":
            fam = self._values(alpha, HALF_PI - alpha)
            return Phase.TANGENTIAL, (alpha, 1.0 / fam.S)
        if event == "wh1":
            raise ModelAssumptionError(
                "the base moment would change sign (an inflection point would appear): the "
                "whisker leaves the model's working hypothesis WH1 here; this branch is not "
                "modelled"
            )
        raise AssertionError(f"no transition for event {event!r} in phase {phase!r}")

    def touch_start(self, alpha0: float, penetration: float) -> Tuple[Phase, Tuple[float, float]]:
        """
        Guess of the tip-contact branch just after first touch.

        Linear beam theory: a tip force f along (sin a, -cos a) deflects the tip by f sin(a)/3
        along x and rotates it by f sin(a)/2; the tip must take up the straight whisker's
        ``penetration`` along the normal.
        """
        sa = math.sin(alpha0)
        f = 3.0 * penetration / (sa * sa)
        return Phase.TIP, (alpha0, max(0.5 * f * sa, 1e-300))

    def tip_rotation(self, phase: Phase, z) -> float:
        """Return gamma = pi/2 - phi(1) (contact frame); small values mean a nearly zero force."""
        return HALF_PI - z[0] if phase == Phase.TANGENTIAL else z[1]

    def step_scale(self, phase: Phase, z) -> float:
        """
        Return the scale of the continuation's steps.

        lam = 1/sqrt(f) grows without bound as a tangential contact runs to a point of the profile
        parallel to the whisker (f -> 0), and is followed in steps proportional to it.
        """
        return max(1.0, z[1]) if phase == Phase.TANGENTIAL else 1.0

    def released(self, phase: Phase, z) -> bool:
        """
        Tell whether a tangential contact's force has vanished.

        That is f < 1e-12: the whisker is straight to ~1e-12, touching the profile where its
        tangent turns parallel to the whisker.
        """
        return phase == Phase.TANGENTIAL and z[1] > 1e6

    # -- results ---------------------------------------------------------------------------
    def contact_quantities(self, phase: Phase, z):
        """(f, m0, s1, tip_slope, tip_offset) in the contact frame; tip_offset = tip - contact."""
        alpha, mu = z
        if phase == Phase.TANGENTIAL:
            fam = self._values(alpha, HALF_PI - alpha)
            s1 = mu * fam.S
            free = 1.0 - s1
            return 1.0 / (mu * mu), -fam.A / mu, s1, alpha, (free * math.cos(alpha),
                                                             free * math.sin(alpha))
        fam = self._values(alpha, mu)
        return fam.S * fam.S, -fam.A * fam.S, 1.0, HALF_PI - mu, (0.0, 0.0)

    def centerline_contact_frame(self, phase: Phase, z, n: int) -> np.ndarray:
        alpha, mu = z
        s = np.linspace(0.0, 1.0, n)
        if phase == Phase.TANGENTIAL:
            gamma = HALF_PI - alpha
            sqrt_f = 1.0 / mu
            s1 = mu * family(alpha, gamma, False).S
        else:
            gamma = mu
            sqrt_f = family(alpha, gamma, False).S
            s1 = 1.0
        loaded = s <= s1
        pts = np.empty((n, 2))
        pts[loaded] = family_centerline(alpha, gamma, sqrt_f, s[loaded])
        if not loaded.all():
            p1 = family_centerline(alpha, gamma, sqrt_f, [s1])[0]
            rest = s[~loaded] - s1
            pts[~loaded, 0] = p1[0] + rest * math.cos(alpha)
            pts[~loaded, 1] = p1[1] + rest * math.sin(alpha)
        return pts


class RigidModel:
    """
    The rigid one-link whisker on a torsional spring at the foot (paper §3).

    Units of the paper's §3: length L, moment c (the spring's stiffness), force c/L. With
    ``stiffness`` = k the reported f, fx, fy and m0 are multiplied by k, i.e. expressed in units of
    EI when c = k EI/L (k = 3 matches the elastica's small-deflection tip stiffness).

    Unknowns: mode 1 (tangential, rod slope phi = alpha) ``z = (alpha, s1)``; mode 2 (tip)
    ``z = (alpha, gamma)`` with gamma = pi/2 - phi, the rod's rotation from upright. Geometry
    (paper §3): s1 (cos phi, sin phi) is the contact point relative to the foot. Statics: the
    spring moment pi/2 - phi balances the contact force's moment f s1 cos(phi - alpha), so
    f = (pi/2 - alpha)/s1 in mode 1 and f = gamma / cos(phi - alpha) in mode 2. The branch folds
    exactly where the rod becomes orthogonal to the profile (phi = alpha + pi/2, where f -> inf):
    d x0 / d alpha = rho cos(phi - alpha) / cos(phi) vanishes there, so the tracker snaps there
    and no sampled state ever reaches the singular point.

    Parameters
    ----------
    stiffness : float, optional
        k, finite and > 0: the reported f, fx, fy and m0 are multiplied by it (above).

    Raises
    ------
    ParameterError
        When ``stiffness`` is not finite and > 0.

    """

    name = "rigid"
    release_by_gap = False

    def __init__(self, stiffness: float = 1.0):
        stiffness = float(stiffness)
        if not (math.isfinite(stiffness) and stiffness > 0.0):
            from ..errors import ParameterError

            raise ParameterError(f"rigid spring stiffness = {stiffness!r} must be finite and > 0")
        self.stiffness = stiffness

    def load_point(self, phase: Phase, z):
        alpha, mu = z
        if phase == Phase.TANGENTIAL:
            ca, sa = math.cos(alpha), math.sin(alpha)
            return mu * ca, mu * sa, -mu * sa, ca, mu * ca, sa
        sg, cg = math.sin(mu), math.cos(mu)  # tip (cos phi, sin phi) = (sin gamma, cos gamma)
        return sg, cg, 0.0, cg, 0.0, -sg

    def valid(self, phase: Phase, z) -> bool:
        alpha, mu = z
        if not (math.isfinite(alpha) and math.isfinite(mu) and -HALF_PI < alpha < HALF_PI):
            return False
        if phase == Phase.TANGENTIAL:
            return mu > 0.0
        return -HALF_PI < mu < math.pi

    def events(self, phase: Phase, z) -> Dict[str, float]:
        """
        Return the event functions of ``phase`` at ``z``.

        Mode 1: ``tip`` = 1 - s1; mode 2: ``tangential`` = phi - alpha, ``release`` = gamma
        (the spring unloads: f = 0).
        """
        alpha, mu = z
        if phase == Phase.TANGENTIAL:
            return {"tip": 1.0 - mu}
        return {"tangential": HALF_PI - mu - alpha, "release": mu}

    def transition(self, phase: Phase, event: str, z):
        alpha, mu = z
        if phase == Phase.TANGENTIAL and event == "tip":
            return Phase.TIP, (alpha, HALF_PI - alpha)
        if phase == Phase.TIP and event == "tangential":
            return Phase.TANGENTIAL, (alpha, 1.0)
        if phase == Phase.TIP and event == "release":
            return Phase.FREE, None
        raise AssertionError(f"no transition for event {event!r} in phase {phase!r}")

    def touch_start(self, alpha0: float, penetration: float):
        """Start a touch: turning the rod clockwise by gamma moves its tip by gamma along +x."""
        return Phase.TIP, (alpha0, penetration / math.sin(alpha0))

    def tip_rotation(self, phase: Phase, z) -> float:
        return HALF_PI - z[0] if phase == Phase.TANGENTIAL else z[1]

    def step_scale(self, phase: Phase, z) -> float:
        return 1.0

    def released(self, phase: Phase, z) -> bool:
        """Mode 1 unloads where the profile's tangent turns parallel to the upright rod."""
        return phase == Phase.TANGENTIAL and HALF_PI - z[0] < 1e-12

    def contact_quantities(self, phase: Phase, z):
        alpha, mu = z
        k = self.stiffness
        if phase == Phase.TANGENTIAL:
            free = 1.0 - mu
            return (
                k * (HALF_PI - alpha) / mu,
                k * (alpha - HALF_PI),
                mu,
                alpha,
                (free * math.cos(alpha), free * math.sin(alpha)),
            )
        phi = HALF_PI - mu
        return k * mu / math.cos(phi - alpha), -k * mu, 1.0, phi, (0.0, 0.0)

    def centerline_contact_frame(self, phase: Phase, z, n: int) -> np.ndarray:
        alpha, mu = z
        phi = alpha if phase == Phase.TANGENTIAL else HALF_PI - mu
        s = np.linspace(0.0, 1.0, n)
        return np.column_stack((s * math.cos(phi), s * math.sin(phi)))


MODELS = {"elastica": ElasticaModel, "rigid": RigidModel}


def make_model(name: str, **options):
    """
    Make a model by name: ``elastica`` or ``rigid`` (option ``stiffness``).

    Parameters
    ----------
    name : {'elastica', 'rigid'}
        The model: :class:`ElasticaModel` (paper §2) or :class:`RigidModel` (paper §3).
    **options
        Passed to the model's constructor: ``stiffness`` for the rigid model.

    Returns
    -------
    ElasticaModel or RigidModel
        The model.

    Raises
    ------
    ParameterError
        For an unknown model name (the message lists the allowed ones).

    """
    from ..errors import ParameterError

    if name not in MODELS:
        raise ParameterError(f"unknown model {name!r}; allowed: {', '.join(MODELS)}")
    return MODELS[name](**options)
