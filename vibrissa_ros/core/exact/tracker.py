"""
Quasistatic tracking: follow the whisker's equilibrium while the foot moves.

A :class:`QuasistaticTracker` holds the current equilibrium. :meth:`QuasistaticTracker.step`
moves the foot along the straight path (position and heading interpolated linearly) from the
current pose to a new one and follows the equilibrium branch continuously:

* free (phase 0): the straight whisker moves until its tip touches the profile; the touch is found
  by conservative advancement on the tip's distance to the obstacle and refined by root finding;
* in contact: pseudo-arclength continuation of the model's branch equations in (z, tau), where
  tau is the path parameter in units of L. Small steps take a fast path (one tangent predictor and
  Newton at the target). Events are found where a phase inequality becomes an equality, where the
  branch folds (tau reaches a local maximum: paper §2.2 criterion (c)) or where the contact force
  returns to zero, and each is located by root finding on the branch;
* at a fold the whisker snaps to the equilibrium that exists beyond it: straight and free, or in
  contact on the other flank when a straight whisker would cut into the obstacle.

Errors leave the tracker's state unchanged: a step is computed on locals and committed at the end.

Every step is bounded by design: each loop has a fixed iteration limit, and all of them draw on one
budget of model and profile evaluations per step (:attr:`TrackerOptions.max_evaluations`). A step
returns a state or raises a :class:`~.errors.VibrissaError`; no other exception type leaves it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import List, Optional, Tuple

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from ..errors import (
    ConvergenceError,
    InvalidPoseError,
    ModelAssumptionError,
    ParameterError,
    VibrissaError,
)
from .models import make_model
from ..profiles import ConvexProfile, PlacedProfile
from ..state import Event, FootPose, Phase, StepResult, WhiskerState, wrap_heading

HALF_PI = 0.5 * math.pi
_TWO_PI = 2.0 * math.pi

#: largest change of the unknowns a fast step may make without the careful continuation
_FAST_STEP = 0.02
#: largest pseudo-arclength step of the careful continuation
_H_MAX = 0.02
_H_MIN = 1e-13
_NEWTON_TOL = 1e-12
_EVENT_XTOL = 1e-15
#: largest |x|, |y| of a foot pose [L] and |heading| [rad]: beyond this the model's numbers are
#: meaningless (a whisker 1e6 of its lengths away from the world's origin)
MAX_POSE_MAGNITUDE = 1e6
#: events one step may cross before it is declared not to progress
_MAX_EVENTS = 64
#: continuation steps one branch segment may take
_MAX_CONTINUATION_STEPS = 20000
#: half the largest spacing of the 41 Chebyshev samples of the free whisker (a bound on how far
#: the smallest distance may lie below the sampled one: the distance is 1-Lipschitz in s)
_NODE_SLACK = 0.02
#: sampled local minima of the distance refined at most (a curved whisker near a peg)
_MAX_BASINS = 4
#: distance below which the peg's touch search predicts the touch and brackets it (the coarse
#: clearance, a lower bound within ~3e-4 L of the distance, at or above it: far)
_PEG_NEAR = 0.05
#: steps of the peg's touch search (each one a certified advance or a bracketed touch)
_MAX_TOUCH_STEPS = 20000
#: numerical exceptions that become ConvergenceError at the step boundary
_NUMERICAL_ERRORS = (ArithmeticError, ValueError, np.linalg.LinAlgError)


@dataclass(frozen=True)
class TrackerOptions:
    """
    Numerical settings of the tracker (defaults give events to ~1e-12 and states to ~1e-14).

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    fast_step : float, optional
        The largest change of the unknowns a fast step may make without the careful
        continuation.
    max_arclength_step : float, optional
        The largest pseudo-arclength step of the careful continuation.
    newton_tol : float, optional
        The Newton iterations stop when a correction is this small (relative to the unknowns
        where they exceed 1).
    max_evaluations : int, optional
        The model and profile evaluations one step may use before it raises ConvergenceError.
    recover : bool, optional
        A step that cannot be followed re-places the whisker unloaded at the new pose when it is
        free there (an event ``reset``); False raises instead (doc/mechanics/decisions.md,
        "Recovery").

    """

    fast_step: float = _FAST_STEP
    max_arclength_step: float = _H_MAX
    newton_tol: float = _NEWTON_TOL
    #: model and profile evaluations one step may use before it raises ConvergenceError
    max_evaluations: int = 100_000
    #: a step that cannot be followed re-places the whisker unloaded at the new pose when it is
    #: free there (an event ``reset``); False raises instead (doc/mechanics/decisions.md,
    #: "Recovery")
    recover: bool = True


class _Path:
    """
    The straight path of the foot from pose p0 (t = 0) to pose p1 (t = 1).

    The heading turns the short way round: by remainder(p1 - p0, 2 pi), in [-pi, pi] (a turn of
    exactly pi goes the way of the plain difference p1 - p0). The frame's heading h0 + t dh is
    continuous along the path; the poses it reports carry the heading wrapped into (-pi, pi].
    """

    __slots__ = ("p0", "p1", "x0", "y0", "h0", "dx", "dy", "dh", "length")

    def __init__(self, p0: FootPose, p1: FootPose):
        self.p0 = p0
        self.x0, self.y0, self.h0 = p0.x, p0.y, p0.heading
        self.dx = p1.x - p0.x
        self.dy = p1.y - p0.y
        dh = math.remainder(p1.heading - p0.heading, _TWO_PI)  # shortest rotation
        self.dh = dh
        self.p1 = p1
        self.length = math.hypot(self.dx, self.dy) + abs(dh)  # bound on the tip's path length

    def pose(self, t: float) -> FootPose:
        if t <= 0.0:
            return self.p0
        if t >= 1.0:
            return self.p1
        return FootPose(self.x0 + t * self.dx, self.y0 + t * self.dy,
                        wrap_heading(self.h0 + t * self.dh))

    def frame(self, t: float) -> Tuple[float, float, float]:
        return self.x0 + t * self.dx, self.y0 + t * self.dy, self.h0 + t * self.dh - HALF_PI


class _Contact:
    """
    Mutable bookkeeping of a contact branch during one step.

    ``jac`` optionally holds dR/dz (a00, a01, a10, a11) at (z, pose(t)), from the last Newton
    iteration; it is path independent and seeds the next step's predictor. ``carried``: the
    contact was carried over from the previous step and not yet moved (an event may sit exactly
    at its start).
    """

    __slots__ = ("phase", "side", "z", "t", "jac", "carried")

    def __init__(self, phase, side, z, t, jac=None, carried=False):
        self.phase, self.side, self.z, self.t, self.jac = phase, side, z, t, jac
        self.carried = carried


class QuasistaticTracker:
    """
    Follows the quasistatic equilibrium of a whisker scanning a convex obstacle.

    Parameters
    ----------
    profile : ConvexProfile
        The obstacle (world frame).
    pose : FootPose or float, optional
        Where the whisker is placed, straight and free; a float is the paper's x0 (foot at (x0, 0),
        heading pi/2).
    model : str or model instance, optional
        ``"elastica"`` (paper §2) or ``"rigid"`` (paper §3), or a model object.
    options : TrackerOptions, optional
        The numerical settings; None: the defaults.

    Raises
    ------
    InvalidPoseError
        If the straight whisker cuts the obstacle.
    ParameterError
        If ``profile`` is not a ConvexProfile.

    """

    def __init__(self, profile: ConvexProfile, pose=2.0, model="elastica", options=None):
        if not isinstance(profile, ConvexProfile):
            raise ParameterError(f"profile must be a ConvexProfile, got {type(profile).__name__}")
        self.profile = profile
        self.model = make_model(model) if isinstance(model, str) else model
        self._for_side = getattr(self.model, "for_side", None)
        self.options = options or TrackerOptions()
        # pegs and curved whiskers: contact may start on the whisker's side (see _find_touch_shape)
        self._shape_mode = (hasattr(profile, "signed_distance")
                            or not getattr(self.model, "is_straight", True))
        self._free_nodes = None
        self._free_chords = None
        pose = _as_pose(pose)
        self._work = 0
        self._budget = self.options.max_evaluations
        self._check_placeable(pose, "the initial pose")
        self._pose = pose
        self._left_at_end = False
        self._contact: Optional[_Contact] = None
        self._alpha_hint = 0.0
        self._state = self._free_state(pose)

    # -- public ------------------------------------------------------------------------------
    @property
    def state(self) -> WhiskerState:
        """Return the current equilibrium."""
        return self._state

    @property
    def pose(self) -> FootPose:
        return self._pose

    def step(self, pose) -> StepResult:
        """
        Move the foot along the straight path to ``pose`` and follow the equilibrium.

        The heading turns the short way round (by at most half a turn; exactly half a turn goes
        the way of the plain difference of the headings). Every heading is taken in (-pi, pi]:
        a pose and the same pose turned by whole turns give the same result.

        Parameters
        ----------
        pose : FootPose or float
            The new foot pose (a float is the paper's x0).

        Returns
        -------
        StepResult
            The new state and the events crossed.

        Raises
        ------
        InvalidPoseError
            The pose is not valid input, or puts the foot inside a peg (the state is kept).
        ModelAssumptionError, ConvergenceError
            The step cannot be followed (a foot's path through a peg is refused before it is
            followed) and the whisker cannot be re-placed unloaded at ``pose``
            (it would cut the obstacle there), or ``options.recover`` is off; the state is kept.
            When it can, the whisker is re-placed there instead and the result has one event
            ``reset`` whose ``reason`` is the refusal (doc/mechanics/decisions.md, "Recovery").

        """
        target = _as_pose(pose)
        self._work = 0
        try:
            return self._step_checked(target)
        except (ModelAssumptionError, ConvergenceError) as exc:
            if not self.options.recover:
                raise
            spent = self._work
            try:
                result = self.reset(target, reason=str(exc))
            except InvalidPoseError:
                raise exc from None
            return StepResult(result.state, result.events, 0, spent + result.evaluations)

    def reset(self, pose=None, reason: str = "reset on request") -> StepResult:
        """
        Place the whisker unloaded at ``pose``, forgetting its history.

        The tracker is then exactly a new tracker placed there (same results for the same poses
        from then on).

        Parameters
        ----------
        pose : FootPose or float, optional
            Where to place it; default: the current foot pose.
        reason : str
            Why, carried by the event.

        Returns
        -------
        StepResult
            The unloaded state and one event ``reset`` (from the phase before to phase 0).

        Raises
        ------
        InvalidPoseError
            The unloaded whisker would cut the obstacle at ``pose`` (the state is kept).

        """
        target = self._pose if pose is None else _as_pose(pose)
        self._work = 0
        self._check_placeable(target, "the reset pose")
        old = self._state.phase
        self._pose = target
        self._left_at_end = False
        self._contact = None
        self._forget()
        self._state = self._free_state(target)
        event = Event("reset", old, Phase.FREE, target, None, reason)
        return StepResult(self._state, (event,), 0, self._work)

    def _check_placeable(self, pose: FootPose, what: str) -> None:
        """Raise InvalidPoseError unless the unloaded whisker is clear of the obstacle at pose."""
        try:
            self._check_straight_free(pose, what=what)
        except VibrissaError:
            raise
        except _NUMERICAL_ERRORS as exc:
            raise InvalidPoseError(f"{what} {pose} cannot be placed: {exc}") from exc

    def _forget(self) -> None:
        """Drop every warm start: a free whisker carries nothing but its pose."""
        self._alpha_hint = 0.0
        forget = getattr(self.model, "forget", None)
        if forget is not None:
            forget()

    def _step_checked(self, target: FootPose) -> StepResult:
        try:
            return self._step(target)
        except VibrissaError:
            raise
        except _NUMERICAL_ERRORS as exc:
            raise ConvergenceError(
                f"the step from {_describe_pose(self._pose)} to {_describe_pose(target)} failed "
                f"numerically ({type(exc).__name__}: {exc})"
            ) from exc

    def _step(self, target: FootPose) -> StepResult:
        path = _Path(self._pose, target)
        contact = None
        if self._contact is not None:
            c = self._contact
            contact = _Contact(c.phase, c.side, c.z, 0.0, c.jac, carried=True)
        events: List[Event] = []
        substeps = 0
        t = 0.0
        exiting = False  # the tip has just left the profile at t (release, graze)
        if path.length == 0.0:
            return StepResult(self._state, (), 0, 0)
        self._check_foot_path(path)
        if contact is None:
            exiting = self._starts_leaving(path) or self._left_at_end
        for _ in range(4 * _MAX_EVENTS):
            if len(events) > _MAX_EVENTS:
                raise ConvergenceError(
                    f"the step to {target} crossed more than {_MAX_EVENTS} events without "
                    "reaching it"
                )
            if contact is None:
                t_touch = self._find_touch(path, t, exiting)
                if t_touch is None:
                    break
                started = self._start_contact(path, t_touch)
                if started is None:  # the tip only grazes the profile here: search on beyond it
                    t, exiting = t_touch, True
                    continue
                contact, ev = started
                events.append(ev)
                exiting = False
                continue
            outcome = self._follow_rest(path, contact)
            substeps += outcome[2]
            kind = outcome[0]
            if kind == "target":
                break
            if (kind == "phase" and outcome[1] == "tip"
                    and getattr(self.profile, "is_point", False)):
                # a point cannot hold the tip: it slips off
                contact, t, ev = self._snap(path, contact)
                events.append(ev)
                continue
            if kind == "phase":
                name = outcome[1]
                old = contact.phase
                new_phase, new_z = self.model.transition(old, name, contact.z)
                if new_phase == Phase.FREE:  # the contact force reached zero on the branch
                    events.append(self._event("release", old, new_phase, path, contact))
                    t, exiting = contact.t, True
                    contact = None
                    continue
                if self._switch_turns_back(path, contact.side, new_phase, new_z, contact.t):
                    # neither phase goes on forwards: the branch folds at the switch (a corner),
                    # and the whisker snaps there as at a smooth fold
                    contact, t, ev = self._snap(path, contact)
                    events.append(ev)
                    exiting = contact is None
                    continue
                events.append(self._event("phase", old, new_phase, path, contact))
                contact = _Contact(new_phase, contact.side, new_z, contact.t)
            elif kind == "release":
                ev = Event("release", contact.phase, Phase.FREE, path.pose(outcome[1]), None)
                events.append(ev)
                t, exiting = outcome[1], True
                contact = None
            elif kind == "fold":
                contact, t, ev = self._snap(path, contact)
                events.append(ev)
                exiting = contact is None
        else:
            raise ConvergenceError(f"the step to {target} did not progress along its path")
        final_pose = path.p1
        if contact is None:
            state = self._free_state(final_pose)
        else:
            state = self._contact_state(final_pose, contact.phase, contact.side, contact.z)
        # commit
        self._pose = final_pose
        # a release (or graze) exactly at the target: the next step starts leaving the obstacle
        self._left_at_end = (contact is None and exiting and t >= 1.0 - 1e-12
                             and hasattr(self.profile, "signed_distance"))
        self._contact = (
            None if contact is None
            else _Contact(contact.phase, contact.side, contact.z, 0.0, contact.jac)
        )
        if contact is None:
            self._forget()
        self._state = state
        return StepResult(state, tuple(events), substeps, self._work)

    def _check_foot_path(self, path: _Path) -> None:
        """
        Refuse a step whose foot would enter a peg, before following it.

        At the target it is invalid input (InvalidPoseError); on the way, the foot's straight
        path crossing the peg cannot be followed (ModelAssumptionError): a contact pressed by a
        foot coming at the peg creeps toward the foot (s1 -> 0, the force without bound) and the
        continuation's sub-steps shrink with it, so the step used to fail only at the end of
        its 20,000 sub-steps, after ~45 s.
        """
        if not hasattr(self.profile, "signed_distance"):
            return
        peg = self.profile  # (its signed distance, in floats: this runs at every step)
        if math.hypot(path.p1.x - peg.x, path.p1.y - peg.y) <= peg.r:
            raise InvalidPoseError(f"{_describe_pose(path.p1)} puts the whisker's foot inside "
                                   f"the obstacle ({peg.describe()})")
        # the foot's nearest approach to the peg's centre along the straight path
        ux, uy = path.x0 - peg.x, path.y0 - peg.y
        moved = path.dx * path.dx + path.dy * path.dy
        t = min(max(-(ux * path.dx + uy * path.dy) / moved, 0.0), 1.0) if moved > 0.0 else 0.0
        if math.hypot(ux + t * path.dx, uy + t * path.dy) < peg.r:
            raise ModelAssumptionError(
                f"the foot's path from {_describe_pose(path.p0)} to {_describe_pose(path.p1)} "
                f"passes through the obstacle ({peg.describe()}): a foot cannot move through it"
            )

    def _spend(self) -> None:
        """Count one model or profile evaluation against the step's budget."""
        self._work += 1
        if self._work > self._budget:
            raise ConvergenceError(
                f"the step used more than {self._budget} evaluations of the model without "
                "settling (TrackerOptions.max_evaluations)"
            )

    # -- free whisker ------------------------------------------------------------------------
    def _base_frame_point(self, x: float, y: float):
        prof = self.profile
        if isinstance(prof, PlacedProfile):
            c, s = math.cos(prof.rotation), math.sin(prof.rotation)
            dx, dy = x - prof.x, y - prof.y
            return prof.base, c * dx + s * dy, -s * dx + c * dy
        return prof, x, y

    def _gap(self, x: float, y: float) -> float:
        """
        Signed height of the point below the profile, in the profile's own frame (> 0 outside).

        The obstacle is the region above its lower boundary curve (for closed shapes: the strip
        above the lower arc).
        """
        self._spend()
        signed_distance = getattr(self.profile, "signed_distance", None)
        if signed_distance is not None:
            return float(signed_distance(x, y))
        base, u, v = self._base_frame_point(x, y)
        try:
            return base.height_at_x(u) - v
        except ParameterError:
            return math.inf

    def _tip(self, pose: FootPose) -> Tuple[float, float]:
        """Tip of the unloaded whisker (straight unless the model's whisker is curved)."""
        free_tip = getattr(self.model, "free_tip", None)
        if free_tip is None:
            return pose.x + math.cos(pose.heading), pose.y + math.sin(pose.heading)
        ux, uy, _ = free_tip()
        beta = pose.heading - HALF_PI
        c, s = math.cos(beta), math.sin(beta)
        return pose.x + c * ux - s * uy, pose.y + s * ux + c * uy

    def _tip_gap(self, path: _Path, t: float) -> float:
        return self._gap(*self._tip(path.pose(t)))

    def _distance(self, x: float, y: float) -> float:
        """
        Return a lower bound on the distance from a point outside the obstacle to the obstacle.

        The obstacle is convex, so every one of its supporting lines bounds the distance from
        below: the gap (p - q(a)) . n(a) of the point p beyond the tangent at the profile point
        q(a) of slope a (n(a) = (sin a, -cos a) the outward normal); the largest of them is the
        distance (the walls of a closed shape's strip are the lines at the ends of the slope
        interval). The gap is largest where (p - q(a)) . t(a) = 0, and its superlevel sets above
        zero are intervals of a, so a local maximum with a positive gap is the largest: it is
        found by safeguarded Newton from the last one, else by brentq where the interval's ends
        bracket it; failing both, brentq on a sign change found on a grid, the ends and the grid
        itself give the bound.
        """
        prof = self.profile

        def g(a):
            px, py = prof.point(a)
            return (x - px) * math.cos(a) + (y - py) * math.sin(a)

        def support_gap(a):
            px, py = prof.point(a)
            return (x - px) * math.sin(a) - (y - py) * math.cos(a)

        lo, hi = prof.alpha_min + 1e-12, prof.alpha_max - 1e-12
        a = min(max(self._alpha_hint, lo), hi)
        # safeguarded Newton from the last nearest point: a step that would leave the slope
        # interval, or the part of it known to lie on one side of the root (g > 0 below it, < 0
        # above), halves the way to that end instead (a cold start converges without brentq)
        blo, bhi = lo, hi
        for _ in range(40):
            px, py = prof.point(a)
            ca, sa = math.cos(a), math.sin(a)
            ga = (x - px) * ca + (y - py) * sa
            dg = -prof.radius_of_curvature(a) + (y - py) * ca - (x - px) * sa
            if dg >= 0.0:
                break
            if ga > 0.0:
                blo = a
            elif ga < 0.0:
                bhi = a
            step = ga / dg
            a_new = a - step
            if not (blo < a_new < bhi):
                a_new = 0.5 * (a + (bhi if step < 0.0 else blo))
                step = a - a_new
                if not (lo < a_new < hi) or a_new == a:
                    break
            a = a_new
            if abs(step) < 1e-13:
                value = support_gap(a)
                if value > 0.0:
                    self._alpha_hint = a
                    return value
                break
        if g(lo) > 0.0 > g(hi):  # one sign change over the whole interval (open profiles)
            a = brentq(g, lo, hi, xtol=1e-14)
            value = support_gap(a)
            if value > 0.0:
                self._alpha_hint = a
                return value
        grid = [lo + (hi - lo) * k / 16.0 for k in range(17)]
        best = max(support_gap(a) for a in grid)
        values = [g(a) for a in grid]
        for k in range(16):
            if values[k] > 0.0 > values[k + 1]:
                a = brentq(g, grid[k], grid[k + 1], xtol=1e-14)
                value = support_gap(a)
                if value > best:
                    best = value
                    self._alpha_hint = a
        return max(best, 0.0)

    def _rod_clearance(self, pose: FootPose) -> float:
        """Smallest gap along the straight whisker (convex in s: bounded scalar minimization)."""
        if self._shape_mode:
            return self._free_clearance(pose)[0]
        c, s = math.cos(pose.heading), math.sin(pose.heading)
        # (beyond the ends of a closed shape's lower arc the gap is inf: clipped for the minimizer)
        fun = lambda u: min(self._gap(pose.x + u * c, pose.y + u * s), 1e6)  # noqa: E731
        g0, g1 = fun(0.0), fun(1.0)
        res = minimize_scalar(fun, bounds=(0.0, 1.0), method="bounded", options={"xatol": 1e-10})
        return min(g0, g1, float(res.fun))

    def _check_straight_free(self, pose: FootPose, what: str) -> None:
        if self._gap(pose.x, pose.y) <= 0.0:
            raise InvalidPoseError(f"{what} puts the whisker's foot inside the obstacle")
        if self._rod_clearance(pose) <= 0.0:
            raise InvalidPoseError(
                f"{what} puts the straight whisker inside the obstacle "
                f"({self.profile.describe()}); place it where the straight whisker is free"
            )

    def _find_touch(self, path: _Path, t: float, exiting: bool = False) -> Optional[float]:
        """
        First t in [t, 1] where the straight whisker's tip reaches the profile (None: no touch).

        Conservative advancement: the tip moves at most ``path.length`` per unit t, so it cannot
        reach the obstacle before t + distance / length; near contact the sign change of the
        signed gap is bracketed and refined with brentq. ``exiting``: the tip lies on the profile
        at t and leaves it (a release or a graze); the search starts where it is out again.
        """
        if self._shape_mode:
            return self._find_touch_shape(path, t, exiting)
        if exiting:
            t = self._leave_profile(path, t)
            if t is None:
                return None
        t_touch = self._advance_to_touch(path, t)
        if t_touch is not None:
            self._check_tip_touch(path.pose(t_touch))
        return t_touch

    def _check_tip_touch(self, pose: FootPose) -> None:
        """Check that the first contact is the tip on the lower boundary curve; refuse all else."""
        tx, ty = self._tip(pose)
        gap = self._gap(tx, ty)
        if gap < -1e-9:
            raise ModelAssumptionError(
                f"at {_describe_pose(pose)}, the whisker's tip would enter the obstacle "
                f"({self.profile.describe()}) at ({tx:.4g}, {ty:.4g}) across its flank, not "
                "across its lower boundary: the model covers contact on the lower boundary only"
            )
        c, s = math.cos(pose.heading), math.sin(pose.heading)
        fun = lambda u: min(self._gap(pose.x + u * c, pose.y + u * s), 1e6)  # noqa: E731
        res = minimize_scalar(fun, bounds=(0.0, 0.999), method="bounded", options={"xatol": 1e-10})
        if min(fun(0.0), float(res.fun)) < -1e-9:
            u = 0.0 if fun(0.0) < -1e-9 else float(res.x)
            raise ModelAssumptionError(
                f"at {_describe_pose(pose)}, the whisker's side, {u:.3g} whisker lengths from "
                f"the foot at ({pose.x + u * c:.4g}, {pose.y + u * s:.4g}), would meet the "
                f"obstacle ({self.profile.describe()}) before its tip does: the model covers "
                "obstacles met tip first (the foot is moving into the obstacle)"
            )

    def _advance_to_touch(self, path: _Path, t: float) -> Optional[float]:
        """Conservative advancement from t to the first touch of the straight whisker's tip."""
        speed = path.length
        eps = 1e-10
        for _ in range(10000):
            gap = self._tip_gap(path, t)
            if gap <= 0.0:
                return t
            dist = self._distance(*self._tip(path.pose(t)))
            if dist <= eps:
                t_b = min(1.0, t + 8.0 * eps / speed)
                if self._tip_gap(path, t_b) < 0.0:
                    return brentq(lambda u: self._tip_gap(path, u), t, t_b, xtol=1e-16, rtol=1e-15)
                if t_b >= 1.0:
                    break
                t = t_b
                continue
            t_next = t + dist / speed
            if t_next >= 1.0:
                break
            t = t_next
        else:
            raise ConvergenceError(
                "the touch search did not terminate: the tip runs along the profile within 1e-10 "
                "without touching it"
            )
        end_gap = self._tip_gap(path, 1.0)
        if end_gap < 0.0:  # grazing tolerance: the crossing lies in the last sliver
            return brentq(lambda u: self._tip_gap(path, u), t, 1.0, xtol=1e-16, rtol=1e-15)
        if path.dh != 0.0 and self._rod_clearance(path.p1) <= 0.0:
            raise ModelAssumptionError(
                f"turning to {_describe_pose(path.p1)}, the whisker's side would sweep into the "
                f"obstacle ({self.profile.describe()}) before its tip touches it: the model "
                "covers obstacles met tip first"
            )
        return None

    def _starts_leaving(self, path: _Path) -> bool:
        """
        Tell whether a free whisker's tip on the profile moves out of the obstacle.

        The tip was released at the previous pose; its touch search must start beyond the
        profile, not touch at t = 0.
        """
        g0 = self._tip_gap(path, 0.0)
        if not -1e-12 <= g0 <= 1e-12:
            return False
        return self._tip_gap(path, min(1.0, 1e-8 / path.length)) > g0

    def _leave_profile(self, path: _Path, t: float) -> Optional[float]:
        """
        Find the first t' > t where the tip is outside the obstacle again.

        By doubling offsets from 1e-12 of the path; None if the path ends with the tip on the
        profile.
        """
        delta = 1e-12
        for _ in range(45):  # 1e-12 * 2**44 > 1
            t_out = min(1.0, t + delta)
            gap = self._tip_gap(path, t_out)
            if gap > 0.0:
                return t_out
            if t_out >= 1.0:
                break
            delta *= 2.0
        # (a release located on the force, f = 0, leaves the tip on the profile to ~1e-15)
        if gap < -1e-12:
            raise ConvergenceError(
                f"after leaving the profile at t = {t!r} the straight whisker's tip stays inside "
                "the obstacle: no equilibrium could be followed"
            )
        return None

    def _start_contact(self, path: _Path, t_touch: float) -> Optional[Tuple[_Contact, Event]]:
        if self._shape_mode:
            return self._start_contact_shape(path, t_touch)
        pose = path.pose(t_touch)
        tx, ty = self._tip(pose)
        base, u, _ = self._base_frame_point(tx, ty)
        alpha_w = base.alpha_at_x(u) + (self.profile.rotation
                                        if isinstance(self.profile, PlacedProfile) else 0.0)
        alpha_f = math.remainder(alpha_w - (pose.heading - HALF_PI), _TWO_PI)
        if not abs(alpha_f) < HALF_PI:
            raise ModelAssumptionError(
                f"at {_describe_pose(pose)}, the whisker's tip would first meet the obstacle "
                f"({self.profile.describe()}) at ({tx:.4g}, {ty:.4g}), where its surface is "
                f"turned {math.degrees(abs(alpha_f)):.1f} deg from facing the foot (90 deg or "
                "more: the tip would come at it from its far side); the model covers an obstacle "
                "whose lower boundary faces the foot"
            )
        if abs(alpha_f) < 1e-9:
            raise ModelAssumptionError(
                f"at {_describe_pose(pose)}, the whisker's tip meets the obstacle "
                f"({self.profile.describe()}) head-on at ({tx:.4g}, {ty:.4g}) (the contact force "
                "along the whisker's axis): the buckling that follows is not modelled"
            )
        side = 1 if alpha_f > 0.0 else -1
        alpha_c = abs(alpha_f)
        event = Event("touch", Phase.FREE, Phase.TIP, pose, alpha_w)
        # first contact state a small way along the path, from linear beam theory
        tau_left = (1.0 - t_touch) * path.length
        if tau_left <= 1e-13:
            return None  # the step ends where the tip touches: zero force, still free
        h = min(tau_left, 1e-3)
        for _ in range(40):
            t_s = 1.0 if h == tau_left else t_touch + h / path.length
            pen = -self._tip_gap(path, t_s) * math.cos(alpha_c)
            if pen > 0.0:
                phase, z = self._side_model(side).touch_start(alpha_c, pen)
                z = self._newton_fixed_t(path, phase, side, z, t_s)
                if z is not None:
                    return _Contact(phase, side, z, t_s), event
            h *= 0.25
        return None  # the tip only grazes the profile

    # -- free whisker of any shape, any obstacle (pegs, curved whiskers) ------------------------
    def _free_point(self, s: float) -> Tuple[float, float]:
        """Point at arc length s of the unloaded whisker, foot frame (heading along +y)."""
        if getattr(self.model, "is_straight", True):
            return 0.0, s
        return self.model.free_point(s)

    def _free_slope(self, s: float) -> float:
        """Slope of the unloaded whisker at arc length s relative to its heading [rad]."""
        if getattr(self.model, "is_straight", True):
            return 0.0
        shape = self.model.shape  # its intrinsic_slope, on a float
        return shape.k0 * s + 0.5 * shape.k1 * s * s

    def _free_sample(self):
        if self._free_nodes is None:
            s = 0.5 - 0.5 * np.cos(np.linspace(0.0, math.pi, 41))
            if getattr(self.model, "is_straight", True):
                pts = np.column_stack((np.zeros_like(s), s))
            else:
                from ..general.model import free_centerline

                pts = free_centerline(self.model.shape, s)
            self._free_nodes = (s, pts)
        return self._free_nodes

    def _world_gap(self, pose: FootPose, fx: float, fy: float) -> float:
        beta = pose.heading - HALF_PI
        c, s = math.cos(beta), math.sin(beta)
        return self._gap(pose.x + c * fx - s * fy, pose.y + s * fx + c * fy)

    def _free_clearance(self, pose: FootPose, coarse: bool = False) -> Tuple[float, float]:
        """
        Return (smallest gap along the unloaded whisker, its arc length).

        For a peg the gap is the Euclidean distance to the peg; for a curved whisker against a
        convex profile the vertical gap. ``coarse`` (pegs): farther than 1e-3 from the peg, a
        lower bound from the samples' chords is enough (:meth:`_peg_clearance_bound`). The
        samples bound the gap from below to within half their spacing (it is 1-Lipschitz in s),
        so every sampled local minimum that could hide the smallest gap is refined, not only the
        lowest one.
        """
        s, pts = self._free_sample()
        beta = pose.heading - HALF_PI
        c, sn = math.cos(beta), math.sin(beta)
        signed_distance = getattr(self.profile, "signed_distance", None)
        if coarse and signed_distance is not None:
            self._spend()
            bound, s_near = self._peg_clearance_bound(pose.x, pose.y, c, sn)
            if bound > 1e-3:
                return bound, s_near
        wx = pose.x + c * pts[:, 0] - sn * pts[:, 1]
        wy = pose.y + sn * pts[:, 0] + c * pts[:, 1]
        if signed_distance is not None:
            self._spend()
            d = signed_distance(wx, wy)
        else:
            d = np.array([self._gap(x, y) for x, y in zip(wx, wy)])
        i = int(np.argmin(d))
        best, s_best = float(d[i]), float(s[i])
        fun = lambda u: self._world_gap(pose, *self._free_point(u))  # noqa: E731
        last = len(s) - 1
        # the sampled local minima within the samples' slack of the lowest one, lowest first
        candidates = [j for j in np.argsort(d)
                      if d[j] <= best + 2.0 * _NODE_SLACK
                      and (j == 0 or d[j] <= d[j - 1]) and (j == last or d[j] <= d[j + 1])]
        if signed_distance is None or getattr(self.model, "is_straight", True):
            candidates = candidates[:1]  # one basin: the gap is convex along a straight whisker
        for j in candidates[:_MAX_BASINS]:
            lo, hi = s[max(j - 1, 0)], s[min(j + 1, last)]
            refined = (self._peg_nearest(pose, float(s[j]), lo, hi)
                       if signed_distance is not None else None)
            if refined is None:
                res = minimize_scalar(fun, bounds=(lo, hi), method="bounded",
                                      options={"xatol": 1e-12})
                refined = float(res.x)
            value = fun(refined)
            if value < best:
                best, s_best = value, refined
        return best, s_best

    def _peg_clearance_bound(self, x: float, y: float, c: float, sn: float):
        """
        Return (a lower bound on the peg's gap from the unloaded whisker, a node's s near it).

        The whisker's foot at (x, y), its frame turned by (cos, sin) = (c, sn). Between two
        samples h apart in arc length a curve of curvature at most kappa keeps within
        kappa h^2 / 8 of their chord (the sagitta of a circular arc bounds it), so the peg
        centre's distance from the samples' polyline, less that and the peg's radius, bounds
        the gap from below, within 1.9e-4 kappa L (3e-4 L for a rat-like whisker; the samples
        alone bound it within 0.02 L).
        """
        if self._free_chords is None:
            s, pts = self._free_sample()
            edges = np.diff(pts, axis=0)
            h = np.diff(s)
            shape = getattr(self.model, "shape", None)
            kappa = (0.0 if getattr(self.model, "is_straight", True)
                     else max(abs(shape.k0), abs(shape.k0 + shape.k1)))
            # the polyline of a straight whisker is the whisker; a rounding margin either way
            slack = kappa * float(np.max(h)) ** 2 / 8.0 + 1e-12
            self._free_chords = (s, pts[:-1], edges, np.einsum("ij,ij->i", edges, edges),
                                 slack)
        s, starts, edges, lengths2, slack = self._free_chords
        dx, dy = self.profile.x - x, self.profile.y - y
        # the peg's centre in the foot frame
        cx, cy = c * dx + sn * dy, -sn * dx + c * dy
        wx, wy = cx - starts[:, 0], cy - starts[:, 1]
        along = np.clip((wx * edges[:, 0] + wy * edges[:, 1]) / lengths2, 0.0, 1.0)
        d = np.hypot(wx - along * edges[:, 0], wy - along * edges[:, 1])
        j = int(np.argmin(d))
        return float(d[j]) - slack - self.profile.r, float(s[j])

    def _peg_nearest(self, pose: FootPose, s: float, lo: float, hi: float) -> Optional[float]:
        """
        Find the arc length in (lo, hi) of the unloaded whisker's point nearest to the peg centre.

        By Newton on (p(s) - c) . t(s) = 0 (derivative 1 + kappa0 (p - c) . n); None if it fails.
        """
        beta = pose.heading - HALF_PI
        cb, sb = math.cos(beta), math.sin(beta)
        # the peg's centre in the foot frame
        dx, dy = self.profile.x - pose.x, self.profile.y - pose.y
        cx, cy = cb * dx + sb * dy, -sb * dx + cb * dy
        straight = getattr(self.model, "is_straight", True)
        shape = None if straight else self.model.shape
        for _ in range(8):
            px, py = self._free_point(s)
            th = HALF_PI + self._free_slope(s)
            k = 0.0 if straight else shape.k0 + shape.k1 * s
            tx, ty = math.cos(th), math.sin(th)
            rx, ry = px - cx, py - cy
            g = rx * tx + ry * ty
            dg = 1.0 + k * (rx * -ty + ry * tx)
            if dg <= 0.0:
                return None
            step = g / dg
            s -= step
            if not lo - 1e-12 <= s <= hi + 1e-12:
                return None
            if abs(step) < 1e-14:
                return min(max(s, lo), hi)
        return None

    def _peg_side(self, pose: FootPose, s: float) -> int:
        """
        Tell the peg centre's side of the unloaded whisker at s.

        +1 when the peg's centre is to the left of the unloaded whisker at s, -1 right, 0 beyond
        its ends.
        """
        if not 0.0 < s < 1.0:
            return 0
        fx, fy = self._free_point(s)
        slope = self._free_slope(s)
        beta = pose.heading - HALF_PI
        cb, sb = math.cos(beta), math.sin(beta)
        px, py = pose.x + cb * fx - sb * fy, pose.y + sb * fx + cb * fy
        th = pose.heading + slope
        cross = math.cos(th) * (self.profile.y - py) - math.sin(th) * (self.profile.x - px)
        return 1 if cross > 0.0 else -1

    def _find_touch_shape(self, path: _Path, t: float, exiting: bool = False) -> Optional[float]:
        """
        First t in [t, 1] where the unloaded whisker meets the obstacle anywhere along it.

        Against a peg: :meth:`_find_touch_peg`. Against a convex profile (curved whisker) the
        clearance is sampled every 1e-3 L of motion and the sign change refined; farther from
        the obstacle than that the search advances by the certified lower bound on the distance
        (:meth:`_profile_clearance_bound`), so a long step costs what its approach needs.
        """
        if hasattr(self.profile, "signed_distance"):
            return self._find_touch_peg(path, t, exiting)
        clearance = lambda u: self._free_clearance(path.pose(u))[0]  # noqa: E731
        speed = path.length
        c0 = clearance(t)
        if c0 <= 0.0:  # touching (e.g. just released): a touch only if the whisker moves in
            t_b = min(1.0, t + 1e-9 / speed)
            c_b = clearance(t_b)
            if c_b <= 0.0 or t_b >= 1.0:
                return t if c_b <= 0.0 else None
            t, c0 = t_b, c_b
        for _ in range(100000):
            ahead = max(1e-3, self._profile_clearance_bound(path.pose(t)))
            if ahead > (1.0 - t) * speed:
                return None  # certified: the obstacle is farther than the whisker moves
            t_next = min(t + ahead / speed, 1.0)
            c1 = clearance(t_next)
            if c1 <= 0.0:
                if c1 == 0.0:
                    return t_next
                return brentq(clearance, t, t_next, xtol=1e-16, rtol=1e-15)
            if t_next >= 1.0:
                return None
            t, c0 = t_next, c1
        raise ConvergenceError("touch search did not terminate")

    def _profile_clearance_bound(self, pose: FootPose) -> float:
        """
        Return a lower bound on the distance of the unloaded whisker from a convex profile.

        The smallest of the samples' distance bounds (:meth:`_distance`) less half their
        spacing (the distance is 1-Lipschitz in s); 0 if a sample is not outside.
        """
        s, pts = self._free_sample()
        beta = pose.heading - HALF_PI
        c, sn = math.cos(beta), math.sin(beta)
        best = math.inf
        for fx, fy in pts:
            x, y = pose.x + c * fx - sn * fy, pose.y + sn * fx + c * fy
            if not self._gap(x, y) > 0.0:
                return 0.0
            best = min(best, self._distance(x, y))
        return max(best - _NODE_SLACK, 0.0)

    def _peg_relative(self, pose: FootPose, coarse: bool = False, reach: float = math.inf):
        """
        Return (gap, s, side) of the peg against the unloaded whisker at ``pose``.

        gap: the distance of the peg's boundary from the whisker (negative where they overlap;
        with ``coarse``, a lower bound if that is farther than ``reach`` or than the near zone,
        and then side is None); s: the arc length of the whisker point nearest to
        the peg's centre; side: the signed distance of the centre from the whisker's tangent line
        at s, positive on its left. Along the whisker (0 < s < 1) |side| is the centre's distance;
        beyond an end it is the distance from the tangent line there, so side is continuous as
        the centre moves round an end and changes sign only where the centre crosses the whisker
        or the straight continuation of one of its ends.
        """
        gap, s = self._free_clearance(pose, coarse)
        if coarse and gap > 1e-3 and (gap > reach or gap >= _PEG_NEAR):
            return gap, s, None
        if coarse and gap > 1e-3:
            # (the coarse clearance is a bound only above 1e-3; below, it was the exact one)
            gap, s = self._free_clearance(pose)
        wx, wy, tx, ty = self._free_point_world(pose, s)
        side = tx * (self.profile.y - wy) - ty * (self.profile.x - wx)
        return gap, s, side

    def _free_point_world(self, pose: FootPose, s: float):
        """Return the unloaded whisker's point and unit tangent at arc length s, world frame."""
        fx, fy = self._free_point(s)
        slope = self._free_slope(s)
        beta = pose.heading - HALF_PI
        cb, sb = math.cos(beta), math.sin(beta)
        th = pose.heading + slope
        return (pose.x + cb * fx - sb * fy, pose.y + sb * fx + cb * fy, math.cos(th),
                math.sin(th))

    def _peg_rates(self, path: _Path, pose: FootPose, s: float) -> Tuple[float, float]:
        """
        Rates along the path of the peg's gap and side at the whisker point s (rigid motion).

        The nearest point's own motion along the whisker is left out (exact for the gap, first
        order for the side): they only predict where to bracket the touch.
        """
        wx, wy, tx, ty = self._free_point_world(pose, s)
        vx = path.dx - path.dh * (wy - pose.y)
        vy = path.dy + path.dh * (wx - pose.x)
        rx, ry = self.profile.x - wx, self.profile.y - wy
        norm = math.hypot(rx, ry)
        gap_rate = -(rx * vx + ry * vy) / norm if norm > 0.0 else -math.hypot(vx, vy)
        side_rate = path.dh * (tx * rx + ty * ry) - (tx * vy - ty * vx)
        return gap_rate, side_rate

    def _find_touch_peg(self, path: _Path, t: float, exiting: bool) -> Optional[float]:
        """
        First t in [t, 1] where the unloaded whisker meets the peg (r >= 0), exactly.

        Every whisker point moves at most ``path.length`` per unit t, so the peg cannot be
        reached before t + gap / length: conservative advancement, which never steps over a
        touch. Near the peg the touch is predicted from the rates of the gap and of the centre's
        side (:meth:`_peg_relative`) and bracketed there: the gap turning negative (r > 0), or
        the side changing sign where the centre lies on the whisker (a point crossing it: its gap
        never turns negative), located by brentq; a prediction that brackets nothing falls back
        to the conservative advance. So a touch is found wherever along the step it lies, and
        the whisker passing a point without touching it (round its tip) is no touch.
        """
        speed = path.length
        gap_of = lambda u: self._peg_relative(path.pose(u))[0]  # noqa: E731
        side_of = lambda u: self._peg_relative(path.pose(u))[2]  # noqa: E731
        gap, s, side = self._peg_relative(path.pose(t), True, (1.0 - t) * speed)
        if gap <= 1e-12:
            # touching where the search starts (just released, or a graze): a touch only if the
            # whisker moves in; a point only if it crosses the whisker here
            t_b = min(1.0, t + 1e-9 / speed)
            gap_b, s_b, side_b = self._peg_relative(path.pose(t_b))
            if gap_b < 0.0:
                return t
            if not exiting and self.profile.r == 0.0 and gap_b <= 1e-9:
                t_a = max(0.0, t - 1e-9 / speed)
                side_a = self._peg_relative(path.pose(t_a))[2]
                if side_a * side_b < 0.0:
                    return t
            if t_b >= 1.0:
                return None
            t, gap, s, side = t_b, gap_b, s_b, side_b
        for _ in range(_MAX_TOUCH_STEPS):
            if t >= 1.0 or gap > (1.0 - t) * speed:
                return None  # certified: the peg is farther than the whisker moves
            if side is not None:
                found = self._bracket_peg_touch(path, t, gap, s, side, gap_of, side_of)
                if found is not None:
                    return found
            # certified: no touch before t + gap / speed (a graze closer than 1e-12 is no touch)
            t_next = min(1.0, t + max(gap, 4e-12) / speed)
            gap_n, s_n, side_n = self._peg_relative(path.pose(t_next), True,
                                                    (1.0 - t_next) * speed)
            if gap_n == 0.0:
                return t_next
            if gap_n < 0.0:
                return brentq(gap_of, t, t_next, xtol=1e-16, rtol=1e-15)
            if side is not None and side_n is not None and side * side_n < 0.0:
                # the centre crossed the whisker's line: on the whisker (a point) or beyond an end
                t_c = brentq(side_of, t, t_next, xtol=1e-16, rtol=1e-15)
                if gap_of(t_c) <= 1e-12:
                    return t_c
            t, gap, s, side = t_next, gap_n, s_n, side_n
        raise ConvergenceError("the touch search for the peg did not terminate")

    def _bracket_peg_touch(self, path, t, gap, s, side, gap_of, side_of) -> Optional[float]:
        """Return the touch predicted beyond t if a probe there brackets it, else None."""
        speed = path.length
        pose = path.pose(t)
        gap_rate, side_rate = self._peg_rates(path, pose, s)
        guesses = []
        if gap_rate < 0.0:
            guesses.append(-gap / gap_rate)
        if side * side_rate < 0.0:
            guesses.append(-side / side_rate)
        if not guesses:
            return None
        h = 1.5 * min(guesses) + 1e-12
        if h <= gap / speed:
            return None  # the conservative advance goes as far
        t_p = min(1.0, t + h)
        gap_p, _, side_p = self._peg_relative(path.pose(t_p))
        if gap_p < 0.0:
            return brentq(gap_of, t, t_p, xtol=1e-16, rtol=1e-15)
        if side * side_p < 0.0:
            t_c = brentq(side_of, t, t_p, xtol=1e-16, rtol=1e-15)
            gap_c = gap_of(t_c)
            if gap_c < 0.0:  # the centre crossed the whisker: the peg's edge reached it before
                return brentq(gap_of, t, t_c, xtol=1e-16, rtol=1e-15)
            if gap_c <= 1e-12:  # a point crossing the whisker
                return t_c
        return None

    def _start_contact_shape(self, path: _Path,
                             t_touch: float) -> Optional[Tuple[_Contact, Event]]:
        pose = path.pose(t_touch)
        _, s_star = self._free_clearance(pose)
        fx, fy = self._free_point(s_star)
        beta = pose.heading - HALF_PI
        cb, sb = math.cos(beta), math.sin(beta)
        wx, wy = pose.x + cb * fx - sb * fy, pose.y + sb * fx + cb * fy
        normal_slope = getattr(self.profile, "normal_slope", None)
        if normal_slope is not None:
            alpha_w = normal_slope(wx, wy)
        else:
            base, u, _ = self._base_frame_point(wx, wy)
            alpha_w = base.alpha_at_x(u) + (self.profile.rotation
                                            if isinstance(self.profile, PlacedProfile) else 0.0)
        slope = (0.0 if getattr(self.model, "is_straight", True)
                 else float(self.model.shape.intrinsic_slope(s_star)))
        theta_f = HALF_PI + slope
        if normal_slope is not None and s_star < 1.0 - 1e-9:
            # side touch of a peg: the normal is the whisker's (exact also for a point, r = 0)
            peg_side = self._peg_side(path.pose(max(t_touch - 1e-6 / path.length, 0.0)), s_star)
            alpha_w = beta + theta_f - (0.0 if peg_side >= 0 else math.pi)
        alpha_f = math.remainder(alpha_w - beta, _TWO_PI)
        side = 1 if math.cos(theta_f - alpha_f) > 0.0 else -1  # obstacle on the whisker's left: +1
        alpha_c = math.remainder(side * alpha_f, _TWO_PI)
        model = self._side_model(side)
        tip_first = s_star >= 1.0 - 1e-9
        if tip_first and getattr(self.profile, "is_point", False):
            raise ModelAssumptionError(
                "the tip meets a point obstacle head first: a point (peg radius 0) takes side "
                "contact only"
            )
        if tip_first:
            # the tip may touch where the obstacle's normal points along the tip's tangent or
            # behind it
            phi_c = theta_f if side > 0 else math.pi - theta_f
            closed_forms = not hasattr(model, "side_touch_start")  # their domain: |alpha| < pi/2
            if (not 0.0 < phi_c - alpha_c < math.pi
                    or (closed_forms and not abs(alpha_c) < HALF_PI)):
                raise ModelAssumptionError(
                    f"at {_describe_pose(pose)}, the whisker's tip would first meet the obstacle "
                    f"({self.profile.describe()}) at ({wx:.4g}, {wy:.4g}), where its surface "
                    "faces away from the tip's direction of travel: the contact force would pull "
                    "the tip away from the foot, which the model does not cover"
                )
            if abs(alpha_c) < 1e-9:
                raise ModelAssumptionError(
                    f"at {_describe_pose(pose)}, the whisker's tip meets the obstacle "
                    f"({self.profile.describe()}) head-on at ({wx:.4g}, {wy:.4g}) (the contact "
                    "force along the whisker's axis): the buckling that follows is not modelled"
                )
            event = Event("touch", Phase.FREE, Phase.TIP, pose, self._profile_slope(alpha_w))
            tau_left = (1.0 - t_touch) * path.length
            if tau_left <= 1e-13:
                return None
            h = min(tau_left, 1e-3)
            for _ in range(40):
                t_s = 1.0 if h == tau_left else t_touch + h / path.length
                tx, ty = self._tip(path.pose(t_s))
                gap = self._gap(tx, ty)
                pen = -gap if normal_slope is not None else -gap * math.cos(alpha_c)
                if pen > 0.0:
                    phase, z = model.touch_start(alpha_c, pen)
                    z = self._newton_fixed_t(path, phase, side, z, t_s)
                    if z is not None:
                        return _Contact(phase, side, z, t_s), event
                h *= 0.25
            return None
        side_touch_start = getattr(model, "side_touch_start", None)
        if side_touch_start is None:
            raise ModelAssumptionError(
                "the side of the whisker meets the obstacle first: the closed forms cover "
                "tip-first touches only; use the general (numeric) solver"
            )
        phase, z = side_touch_start(s_star, alpha_c)
        event = Event("touch", Phase.FREE, phase, pose, self._profile_slope(alpha_w))
        return _Contact(phase, side, z, t_touch), event

    # -- contact branch ----------------------------------------------------------------------
    def _profile_cf(self, path: _Path, side: int, alpha: float, t: float):
        """Profile point of contact-frame slope alpha at path parameter t, with d/dalpha, d/dt."""
        X, Y, beta = path.frame(t)
        aw = self._profile_slope(side * alpha + beta)
        prof = self.profile
        if not prof.alpha_min < aw < prof.alpha_max:
            raise ModelAssumptionError(self._off_the_end(path.pose(t), aw))
        px, py = prof.point(aw)
        rho = prof.radius_of_curvature(aw)
        c, s = math.cos(beta), math.sin(beta)
        dx, dy = px - X, py - Y
        qx = side * (c * dx + s * dy)
        qy = -s * dx + c * dy
        ca, sa = math.cos(alpha), math.sin(alpha)
        qax, qay = rho * ca, rho * sa
        db = path.dh
        mx = side * (c * path.dx + s * path.dy)
        my = -s * path.dx + c * path.dy
        qtx = side * db * (rho * ca + qy) - mx
        qty = side * db * (rho * sa - qx) - my
        return qx, qy, qax, qay, qtx, qty

    def _off_the_end(self, pose: FootPose, alpha: float) -> str:
        """Say, in the user's terms, that the contact would slide round an end of the profile."""
        prof = self.profile
        lo, hi = prof.alpha_min, prof.alpha_max
        end = hi if alpha >= hi else lo
        side = "right" if end == hi else "left"
        where = ""
        try:
            px, py = prof.point(end - math.copysign(1e-9, end - 0.5 * (lo + hi)))
            if math.hypot(px - pose.x, py - pose.y) < 1e3:
                where = f" at ({px:.4g}, {py:.4g})"
        except (ArithmeticError, ValueError):
            pass
        return (
            f"at {_describe_pose(pose)}, the contact would slide round the {side} end of the "
            f"obstacle's lower boundary{where} ({prof.describe()}): the whisker would wrap round "
            "the obstacle's flank, and the model covers contact on its lower boundary only "
            f"(world slopes {math.degrees(lo):.0f} to {math.degrees(hi):.0f} deg)"
        )

    def _residual(self, path, phase, side, z, t):
        """R = P(z) - Q(alpha, t) and its Jacobian rows w.r.t. (z0, z1, tau)."""
        self._spend()
        px, py, p00, p01, p10, p11 = self._side_model(side).load_point(phase, z)
        qx, qy, qax, qay, qtx, qty = self._profile_cf(path, side, z[0], t)
        inv_len = 1.0 / path.length
        return (
            (px - qx, py - qy),
            (p00 - qax, p01, -qtx * inv_len),
            (p10 - qay, p11, -qty * inv_len),
        )

    def _newton_fixed_t(self, path, phase, side, z, t, jac_out=None):
        """Newton on the branch equations at fixed t; None if it does not converge."""
        model = self.model
        z0, z1 = z
        tol = self.options.newton_tol
        for _ in range(12):
            if not model.valid(phase, (z0, z1)):
                return None
            try:
                (r0, r1), a, b = self._residual(path, phase, side, (z0, z1), t)
            except (ValueError, ZeroDivisionError):
                return None
            det = a[0] * b[1] - a[1] * b[0]
            if det == 0.0 or not math.isfinite(det):
                return None
            d0 = -(r0 * b[1] - r1 * a[1]) / det
            d1 = -(a[0] * r1 - b[0] * r0) / det
            z0 += d0
            z1 += d1
            if jac_out is not None:
                jac_out[:] = (a, b)
            if abs(d0) <= tol * max(1.0, abs(z0)) and abs(d1) <= tol * max(1.0, abs(z1)):
                return (float(z0), float(z1)) if model.valid(phase, (z0, z1)) else None
        return None

    def _jacobian(self, path, phase, side, Y):
        (r0, r1), a, b = self._residual(path, phase, side, (Y[0], Y[1]), Y[2] / path.length)
        return np.array([r0, r1]), np.array([a, b])

    @staticmethod
    def _tangent(J: np.ndarray, previous=None) -> np.ndarray:
        """
        Return the unit tangent of the branch.

        It is the kernel of the 2x3 Jacobian (cross product of its rows), oriented along
        increasing tau or along ``previous``. Scalar arithmetic: numpy's cross and norm cost more
        than the model evaluation on 3-vectors.
        """
        (a0, a1, a2), (b0, b1, b2) = J[0], J[1]
        t0, t1, t2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
        norm = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        if not norm > 0.0 or not math.isfinite(norm):
            raise ConvergenceError("the branch has no unique tangent here (singular Jacobian)")
        T = np.array((t0 / norm, t1 / norm, t2 / norm))
        if previous is None:
            if T[2] < 0.0:
                T = -T
        elif T @ previous < 0.0:
            T = -T
        return T

    def _events_of(self, phase, z, side=1):
        return self._side_model(side).events(phase, z)

    def _side_model(self, side: int):
        """
        Return the model in the contact frame of ``side``.

        Models whose whisker is not mirror-symmetric, e.g. an intrinsically curved one, give a
        mirrored copy for side -1.
        """
        if side >= 0 or self._for_side is None:
            return self.model
        return self._for_side(side)

    def _follow(self, path: _Path, contact: _Contact):
        """
        Follow the contact branch from contact.t towards t = 1.

        Returns (kind, detail, substeps) with kind 'target', 'phase' (detail: event name),
        'fold' or 'release' (detail: t); ``contact`` is updated in place to the located point.
        """
        phase, side = contact.phase, contact.side
        tau_end = path.length
        # -- fast path: tangent predictor to the target and Newton at fixed t ----------------
        fast = self._fast_step(path, contact)
        if fast:
            return "target", None, 1
        contact.jac = None
        Y = np.array([contact.z[0], contact.z[1], contact.t * path.length])
        R, J = self._jacobian(path, phase, side, Y)
        T = self._tangent(J)
        ev_a = self._events_of(phase, contact.z, side)
        # -- careful path: pseudo-arclength continuation --------------------------------------
        h = min(self.options.max_arclength_step, max(tau_end - Y[2], 1e-6))
        steps = 0
        while True:
            steps += 1
            if steps > _MAX_CONTINUATION_STEPS:
                raise ConvergenceError(
                    f"the continuation took more than {_MAX_CONTINUATION_STEPS} steps on one "
                    "branch without reaching the target pose"
                )
            Yp = Y + h * T
            Yn = self._corrector(path, phase, side, Yp, T, h)
            if Yn is None:
                released = (
                    self._check_release(path, phase, contact, Y, Yp)
                    if self.model.release_by_gap else None
                )
                if released is not None:
                    return "release", released, steps
                h *= 0.5
                if h < _H_MIN:
                    if self.model.released(phase, (Y[0], Y[1])):
                        contact.z, contact.t = ((float(Y[0]), float(Y[1])),
                                                float(Y[2]) / path.length)
                        return "release", contact.t, steps
                    self._raise_branch_end(path, phase, Y)
                continue
            Rn, Jn = self._jacobian(path, phase, side, Yn)
            Tn = self._tangent(Jn, T)
            zn = (Yn[0], Yn[1])
            ev_b = self._events_of(phase, zn, side)
            if contact.carried:
                # the previous step ended on an event to rounding (its function is <= 0 at the
                # start): it fires here if the branch moves on through it, not if it turns back
                contact.carried = False
                for k, v in ev_a.items():
                    if v <= 0.0 and ev_b[k] < v:
                        return "phase", k, steps
            found = []  # (kind, name)
            fold = T[2] > 0.0 >= Tn[2]
            if fold:
                found.append(("fold", None))
            for k, v in ev_b.items():
                if v <= 0.0 < ev_a[k]:
                    found.append(("phase", k))
            # (with a fold, _locate decides whether the target comes first)
            if Yn[2] >= tau_end and not fold:
                found.append(("target", None))
            if found:
                kind, name, Ystar = self._locate(path, phase, side, Y, Yn, T, Tn, found, tau_end)
                contact.z = (float(Ystar[0]), float(Ystar[1]))
                contact.t = min(float(Ystar[2]) / path.length, 1.0)
                if kind == "target":
                    # the located point lies on the branch at tau = tau_end (root finding on the
                    # branch parameter); Newton at fixed t only polishes it, and is not trusted
                    # next to a fold, where dR/dz is nearly singular
                    z = self._newton_fixed_t(path, phase, side, contact.z, 1.0)
                    if (z is not None
                            and abs(z[0] - contact.z[0]) + abs(z[1] - contact.z[1]) <= 1e-9):
                        contact.z = z
                    contact.t = 1.0
                return kind, name, steps
            if self.model.released(phase, zn):  # a tangential contact unloaded to rounding
                contact.z, contact.t = ((float(zn[0]), float(zn[1])),
                                        min(float(Yn[2]) / path.length, 1.0))
                return "release", contact.t, steps
            Y, T, ev_a = Yn, Tn, ev_b
            h = min(self.options.max_arclength_step * self.model.step_scale(phase, zn), h * 1.5)

    def _raise_branch_end(self, path, phase, Y):
        """Raise why the continuation cannot go on from Y (a model limit or numerical failure)."""
        t = float(Y[2]) / path.length
        z = (float(Y[0]), float(Y[1]))
        try:
            f, _, s1, _, _ = self.model.contact_quantities(phase, z)
        except _NUMERICAL_ERRORS:
            f, s1 = math.inf, 0.0
        if phase == Phase.TANGENTIAL and not s1 > 1e-6:
            raise ModelAssumptionError(
                f"at {_describe_pose(path.pose(t))}, the contact point slid down to the whisker's "
                f"foot (contact at arc length {s1:.3g}, force {f:.3g}): the foot is being driven "
                f"into the obstacle ({self.profile.describe()}), which the model does not cover"
            )
        try:
            near = [name for name, value in self.model.events(phase, z).items() if value < 1e-8]
        except _NUMERICAL_ERRORS:
            near = []
        for name in near:  # the branch ends on a phase boundary: a model limit (WH1) says so
            self.model.transition(phase, name, z)
        if abs(z[0]) > HALF_PI - 1e-6:
            raise ModelAssumptionError(
                f"at {_describe_pose(path.pose(t))}, the contact reached the end of the "
                f"obstacle's lower boundary ({self.profile.describe()}): there its surface turns "
                "parallel to the whisker, and the model covers contact on the lower boundary only"
            )
        raise ConvergenceError(
            f"at {_describe_pose(path.pose(t))}, the whisker's equilibrium in "
            f"{_PHASE_NAMES[int(phase)]} contact with the obstacle ({self.profile.describe()}) "
            "could not be followed further (no solution of the equilibrium equations was found "
            "nearby)"
        )

    def _follow_rest(self, path: _Path, contact: _Contact):
        """
        Run :meth:`_follow` on the rest of the path from contact.t.

        So the continuation's tau starts at 0 wherever the branch begins (a branch met after a
        long jump is followed with small numbers); results are mapped back to the whole path's t.
        """
        t0 = contact.t
        if t0 <= 0.0:
            return self._follow(path, contact)
        rest = _Path(path.pose(t0), path.p1)
        if rest.length == 0.0:
            return "target", None, 0
        contact.t = 0.0
        kind, detail, steps = self._follow(rest, contact)
        contact.t = 1.0 if contact.t >= 1.0 else t0 + contact.t * (1.0 - t0)
        if kind == "release":
            detail = t0 + detail * (1.0 - t0)
        return kind, detail, steps

    def _fast_step(self, path: _Path, contact: _Contact) -> bool:
        """
        Try one tangent predictor to t = 1 and Newton there.

        Accepted only when nothing can have happened in between: a small change, no event
        function changed sign and the branch did not turn (det dR/dz keeps its sign). Pure Python
        floats: this is the hot path.
        """
        if contact.t != 0.0:
            return False
        phase, side, (z0, z1) = contact.phase, contact.side, contact.z
        jac = contact.jac
        if jac is None:
            (_, _), a, b = self._residual(path, phase, side, (z0, z1), 0.0)
            jac = (a[0], a[1], b[0], b[1])
        a00, a01, a10, a11 = jac
        det_a = a00 * a11 - a01 * a10
        if det_a == 0.0 or not math.isfinite(det_a):
            return False
        qtx, qty = self._profile_cf(path, side, z0, 0.0)[4:]
        # dz/dt = -(dR/dz)^-1 dR/dt with dR/dt = -dQ/dt
        d0 = (a11 * qtx - a01 * qty) / det_a
        d1 = (a00 * qty - a10 * qtx) / det_a
        if abs(d0) + abs(d1) >= self.options.fast_step:
            return False
        out = [None, None]
        z = self._newton_fixed_t(path, phase, side, (z0 + d0, z1 + d1), 1.0, out)
        if z is None or abs(z[0] - z0) + abs(z[1] - z1) >= self.options.fast_step:
            return False
        a, b = out
        det_b = a[0] * b[1] - a[1] * b[0]
        if det_a * det_b <= 0.0:
            return False
        ev_a = self._events_of(phase, (z0, z1), side)
        if any(value <= 0.0 for value in ev_a.values()):
            return False  # an event sits at the start: the careful path decides whether it fires
        ev_b = self._events_of(phase, z, side)
        for key, value in ev_b.items():
            if value <= 0.0 < ev_a[key]:
                return False
        contact.z, contact.t, contact.jac = z, 1.0, (a[0], a[1], b[0], b[1])
        return True

    def _corrector(self, path, phase, side, Yp, T, h):
        """Solve [R(Y) = 0, T.(Y - Yp) = 0] by Newton; None if it fails or strays from Yp."""
        Y = Yp.copy()
        for it in range(8):
            if not self.model.valid(phase, (Y[0], Y[1])):
                return None
            try:
                R, J = self._jacobian(path, phase, side, Y)
            except (ValueError, ZeroDivisionError):
                return None
            d = _solve3(
                [list(J[0]), list(J[1]), list(T)],
                [-R[0], -R[1], -float(T @ (Y - Yp))],
            )
            if d is None:
                return None
            Y = Y + d
            if np.max(np.abs(d)) <= self.options.newton_tol * max(1.0, np.max(np.abs(Y))):
                if (np.linalg.norm(Y - Yp) > 0.5 * h + 1e-12
                        or not self.model.valid(phase, (Y[0], Y[1]))):
                    return None
                return Y
        return None

    def _solve_at(self, path, phase, side, i, p, guess):
        """Point of the branch with component i fixed to p (Newton on the other two)."""
        Y = guess.copy()
        Y[i] = p
        others = [j for j in range(3) if j != i]
        for _ in range(30):
            if not self.model.valid(phase, (Y[0], Y[1])):
                raise ConvergenceError("event location left the branch's domain")
            R, J = self._jacobian(path, phase, side, Y)
            try:
                d = np.linalg.solve(J[:, others], -R)
            except np.linalg.LinAlgError:
                raise ConvergenceError("event location met a singular branch Jacobian") from None
            if not np.all(np.isfinite(d)):
                raise ConvergenceError("event location diverged")
            Y[others] += d
            if np.max(np.abs(d)) <= 1e-15 * max(1.0, np.max(np.abs(Y))):
                return Y
        if np.max(np.abs(d)) <= 1e-10 * max(1.0, np.max(np.abs(Y))):
            return Y  # converged to rounding level (Newton stalls at a few ulps)
        raise ConvergenceError("event location did not converge on the branch")

    def _locate(self, path, phase, side, Ya, Yb, Ta, Tb, found, tau_end):
        """
        Locate the earliest of the events found between branch points Ya and Yb.

        The branch between them is parametrized by the component of the chord that changes most
        (never tau when the branch folds in between), and each event function is solved for with
        brentq on that parameter.
        """
        chord = Yb - Ya
        has_fold = any(kind == "fold" for kind, _ in found)
        candidates = [0, 1] if has_fold else [0, 1, 2]
        i = max(candidates, key=lambda j: abs(chord[j]))
        pa, pb = Ya[i], Yb[i]
        xtol = _EVENT_XTOL * max(1.0, abs(pa))

        def point(p):
            frac = (p - pa) / (pb - pa)
            return self._solve_at(path, phase, side, i, p, Ya + frac * chord)

        def tau_slope(p):
            _, J = self._jacobian(path, phase, side, point(p))
            return self._tangent(J, Ta)[2]

        kinds = {name: kind for kind, name in found}
        if has_fold:
            ends = {pa: Ta[2], pb: Tb[2]}
            p_fold = brentq(lambda p: ends[p] if p in ends else tau_slope(p), pa, pb, xtol=xtol,
                            rtol=1e-15)
            Yb = point(p_fold)
            pb = p_fold
            found = [(k, n) for k, n in found if k == "phase"]
            if Yb[2] >= tau_end:
                found.append(("target", None))
        best = (1.0, "fold", None, pb) if has_fold else None
        for kind, name in found:
            if kind == "target":
                g = lambda Y: Y[2] - tau_end  # noqa: E731
            else:
                g = lambda Y, name=name: (  # noqa: E731
                    self._events_of(phase, (Y[0], Y[1]), side)[name])
            ga, gb = g(Ya), g(Yb)
            if ga == 0.0:
                p_star = pa
            elif gb == 0.0 or ga * gb > 0.0:
                if ga * gb > 0.0:
                    continue
                p_star = pb
            else:
                ends = {pa: ga, pb: gb}  # endpoint values as bracketed, not re-solved
                p_star = brentq(lambda p: ends[p] if p in ends else g(point(p)), pa, pb,
                                xtol=xtol, rtol=1e-15)
            frac = (p_star - pa) / (pb - pa) if pb != pa else 0.0
            if best is None or frac < best[0]:
                best = (frac, kind, name, p_star)
        if best is None:
            raise ConvergenceError(f"could not locate event(s) {sorted(kinds)}")
        _, kind, name, p_star = best
        return kind, name, point(p_star)

    def _check_release(self, path, phase, contact, Y, Yp):
        """Near zero force the branch ends at the straight whisker touching the profile."""
        gamma = self.model.tip_rotation(phase, (Y[0], Y[1]))
        if gamma > 1e-2 or Yp[2] <= Y[2]:
            return None
        t_a = Y[2] / path.length
        t_b = min(1.0, Yp[2] / path.length)
        if t_b <= t_a:
            return None
        g_a, g_b = self._tip_gap(path, t_a), self._tip_gap(path, t_b)
        if g_a < 0.0 <= g_b:
            if g_b == 0.0:
                return t_b
            return brentq(lambda u: self._tip_gap(path, u), t_a, t_b, xtol=1e-16, rtol=1e-15)
        return None

    def _switch_turns_back(self, path, side, phase, z, t) -> bool:
        """
        Tell whether the branch of ``phase``, entered at a phase switch, lies behind the switch.

        At a switch (the contact at the tip, tangent to the obstacle) the two phases' branches
        meet, and the new phase's event that leads back sits at zero: its sign there is rounding.
        What decides is the direction. The new phase goes on if a short step forwards (tau
        increasing) on its branch keeps every event function positive. If not, the admissible
        parts of both phases lie behind the switch (the old phase ended there going forwards):
        there is no equilibrium nearby ahead, the branch of equilibria folds at the switch (a
        corner; e.g. a tapered whisker slipping off a peg over its tip) and the whisker snaps.
        One decision per switch, made on the branch itself: a switch is never undone at the
        point where it was made, so the phases cannot alternate there.
        """
        Y = np.array([z[0], z[1], t * path.length])
        _, J = self._jacobian(path, phase, side, Y)
        T = self._tangent(J)  # oriented along increasing tau
        # the step moves the event that sits at zero by ~1e-6 times its slope on the branch,
        # far above its rounding (~1e-14), and stays well inside the branch's other features
        h = 1e-6
        for _ in range(4):
            Yn = self._corrector(path, phase, side, Y + h * T, T, h)
            if Yn is not None:
                values = self._events_of(phase, (Yn[0], Yn[1]), side).values()
                return any(value <= 0.0 for value in values)
            h *= 0.125
        return False  # no step possible: the continuation decides, and says why it cannot go on

    # -- snapping ------------------------------------------------------------------------------
    def _snap(self, path: _Path, contact: _Contact):
        """At a fold: the whisker jumps to the equilibrium that exists beyond it."""
        t = contact.t
        pose = path.pose(t)
        from_phase = contact.phase
        tx, ty = self._tip(pose)
        if self._rod_clearance(pose) > 0.0:
            ev = Event("snap", from_phase, Phase.FREE, pose, self._world_alpha(pose, contact))
            return None, t, ev
        # the straight whisker would cut the obstacle: find the contact on the other side by
        # approaching this pose from a free pose further along the direction of travel
        new = self._approach_from_free(pose, path, contact.side)
        ev = Event("snap", from_phase, new.phase, pose, self._world_alpha(pose, contact))
        new.t = t
        return new, t, ev

    def _approach_from_free(self, pose: FootPose, path: _Path, side: int) -> _Contact:
        ux, uy = path.dx, path.dy
        norm = math.hypot(ux, uy)
        if norm == 0.0:  # pure rotation: move sideways, to the side the whisker snapped towards
            beta = pose.heading - HALF_PI
            ux, uy, norm = -side * math.cos(beta), -side * math.sin(beta), 1.0
        ux, uy = ux / norm, uy / norm
        d = 0.25
        while d < 1e3:
            start = FootPose(pose.x + d * ux, pose.y + d * uy, pose.heading)
            if self._gap(start.x, start.y) > 0.0 and self._rod_clearance(start) > 0.0:
                break
            d *= 2.0
        else:
            raise ModelAssumptionError("no free whisker pose found to settle the snap")
        helper = QuasistaticTracker(self.profile, start, self.model,
                                    replace(self.options, recover=False))
        result = helper.step(pose)
        if any(e.kind == "snap" for e in result.events) or helper._contact is None:
            raise ModelAssumptionError(
                "no equilibrium in contact exists after the snap at this pose")
        c = helper._contact
        return _Contact(c.phase, c.side, c.z, 0.0)

    # -- results -------------------------------------------------------------------------------
    def _world_alpha(self, pose: FootPose, contact: _Contact) -> float:
        return self._profile_slope(contact.side * contact.z[0] + pose.heading - HALF_PI)

    def _profile_slope(self, alpha: float) -> float:
        """
        Return a world slope as the profile takes it: whole turns removed.

        Into the profile's slope window (alpha_min, alpha_max) when it lies there modulo 2 pi,
        else next to it; into (-pi, pi] for a peg (every slope occurs on it).
        """
        lo, hi = self.profile.alpha_min, self.profile.alpha_max
        if math.isinf(hi - lo):
            return wrap_heading(alpha)
        if lo < alpha < hi:
            return alpha
        mid = 0.5 * (lo + hi)
        return mid + math.remainder(alpha - mid, _TWO_PI)

    def _event(self, kind, old, new, path, contact):
        pose = path.pose(contact.t)
        return Event(kind, old, new, pose, self._world_alpha(pose, contact))

    def _free_state(self, pose: FootPose) -> WhiskerState:
        tip = self._tip(pose)
        free_tip = getattr(self.model, "free_tip", None)
        return WhiskerState(
            phase=Phase.FREE,
            pose=pose,
            side=0,
            alpha=None,
            s1=None,
            tip_slope=pose.heading + (free_tip()[2] if free_tip is not None else 0.0),
            f=0.0,
            fx=0.0,
            fy=0.0,
            m0=0.0,
            contact=None,
            tip=tip,
            shape=(),
            model=self.model,
        )

    def _contact_state(self, pose: FootPose, phase: Phase, side: int, z) -> WhiskerState:
        f, m0_c, s1, phi1_c, (ox, oy) = self._side_model(side).contact_quantities(phase, z)
        beta = pose.heading - HALF_PI
        alpha_w = self._profile_slope(side * z[0] + beta)
        cx, cy = self.profile.point(alpha_w)
        # the tip: the contact point plus the contact-frame offset, turned into the world frame
        tx, ty = pose.contact_to_world(ox, oy, side)
        tip = (cx + tx - pose.x, cy + ty - pose.y)
        tip_slope = beta + (phi1_c if side > 0 else math.pi - phi1_c)
        return WhiskerState(
            phase=phase,
            pose=pose,
            side=side,
            alpha=alpha_w,
            s1=s1,
            tip_slope=tip_slope,
            f=f,
            fx=f * math.sin(alpha_w),
            fy=-f * math.cos(alpha_w),
            m0=side * m0_c,
            contact=(cx, cy),
            tip=tip,
            shape=(float(int(phase)), float(z[0]), float(z[1])),
            model=self._side_model(side),
        )


_PHASE_NAMES = {0: "no", 1: "tangential (side)", 2: "tip"}


def _describe_pose(pose: FootPose) -> str:
    """Return a foot pose in words: position [L] and heading [deg]."""
    return (f"the foot pose x = {pose.x:.6g}, y = {pose.y:.6g} (whisker lengths), heading "
            f"{math.degrees(pose.heading):.4g} deg")


def _solve3(m, b) -> Optional[np.ndarray]:
    """
    Solve the 3x3 system m x = b by Gaussian elimination with partial pivoting.

    Scalar arithmetic: for 3x3 systems in the continuation's inner loop this is several times
    faster than LAPACK through numpy. None when singular or not finite.
    """
    m = [row[:] + [bi] for row, bi in zip(m, b)]
    for col in range(3):
        piv = max(range(col, 3), key=lambda r: abs(m[r][col]))
        if not m[piv][col] != 0.0:
            return None
        m[col], m[piv] = m[piv], m[col]
        pc = m[col]
        for r in range(col + 1, 3):
            factor = m[r][col] / pc[col]
            if factor != 0.0:
                row = m[r]
                for k in range(col, 4):
                    row[k] -= factor * pc[k]
    x2 = m[2][3] / m[2][2]
    x1 = (m[1][3] - m[1][2] * x2) / m[1][1]
    x0 = (m[0][3] - m[0][1] * x1 - m[0][2] * x2) / m[0][0]
    if not (math.isfinite(x0) and math.isfinite(x1) and math.isfinite(x2)):
        return None
    return np.array((x0, x1, x2))


def _as_pose(pose) -> FootPose:
    """Check a foot pose (or the paper's x0) and return it with its heading in (-pi, pi]."""
    if isinstance(pose, (int, float, np.floating, np.integer)) and not isinstance(pose, bool):
        pose = FootPose(float(pose), 0.0, HALF_PI)
    if not isinstance(pose, FootPose):
        raise InvalidPoseError(f"a foot pose must be a FootPose or the paper's x0, got {pose!r}")
    if max(abs(pose.x), abs(pose.y), abs(pose.heading)) > MAX_POSE_MAGNITUDE:
        for key in ("x", "y", "heading"):
            value = getattr(pose, key)
            if abs(value) > MAX_POSE_MAGNITUDE:
                unit = "rad" if key == "heading" else "whisker lengths"
                raise InvalidPoseError(
                    f"foot pose {key} = {value!r} is out of range: |{key}| must be at most "
                    f"{MAX_POSE_MAGNITUDE:g} {unit}"
                )
    heading = wrap_heading(pose.heading)
    return pose if heading == pose.heading else FootPose(pose.x, pose.y, heading)
