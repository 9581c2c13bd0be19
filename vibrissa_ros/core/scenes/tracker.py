"""
Quasistatic tracking in a scene: several obstacles, several contacts at once, Coulomb friction.

A :class:`SceneTracker` holds the current equilibrium (a configuration of contacts solved by
:class:`~.multicontact.MultiContactSolver`). :meth:`SceneTracker.step` moves the foot along the
straight path (x, y, heading linear in the path parameter t in [0, 1]) to a new pose and follows
the equilibrium by natural-parameter continuation in t (tangent predictor, chord-Newton
corrector). After every accepted sub-step it evaluates the configuration's inequalities; where
one of them crosses zero, or where the whisker starts to cut an obstacle it does not touch yet,
the crossing is located by root finding in t (Brent, to 1e-14) and the configuration changes:

=====================  ===============================================================
event                  change of the configuration
=====================  ===============================================================
``touch``              a new contact with zero force (side, corner, tip or tip_corner)
``release``            a contact's normal force returns to zero: the contact is dropped
``tip``                a side contact reaches the tip (s = 1): side -> tip
``tangential``         the tip's slope reaches the obstacle's: tip -> side
``corner``             a contact slides to the end of an edge: side -> corner, tip -> tip_corner
``edge``               a corner's force leaves the corner's normal cone: corner -> side,
                       tip_corner -> tip on the adjacent edge
``slip``               a sticking contact reaches ``|T| = mu N``: stick -> slip
``stick``              a slipping contact's slip rate returns to zero: slip -> stick
``merge``              two contacts on one arc meet: they become one
``snap``               the equilibrium folds (Newton finds no solution beyond t): the
                       whisker jumps; the contact that cannot be held is dropped
=====================  ===============================================================

Every loop is bounded; all of them draw on one budget of solver evaluations per step
(``max_evaluations``). A step returns a state or raises a VibrissaError and keeps the state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, List, Optional, Sequence, Tuple

import numpy as np
import scipy.linalg as sla
from scipy.optimize import brentq, minimize_scalar

from .boundary import TWO_PI, Vertex
from ..errors import (
    ConvergenceError,
    InvalidPoseError,
    ModelAssumptionError,
    ParameterError,
    VibrissaError,
)
from ..general.model import WhiskerShape
from ..path_check import obstacle_on_path
from .multicontact import ContactMode, MultiContactSolver
from ..state import FootPose, Phase
from ..exact.tracker import _Path, _as_pose

#: largest change of the slopes and contact parameters in one sub-step
_MAX_CHANGE = 0.05
#: largest foot displacement (L) or rotation (rad) in one sub-step (touch detection sampling)
_MAX_MOVE = 0.05
_H_MIN = 1e-12
_EVENT_XTOL = 1e-14
_MAX_EVENTS = 64
_MAX_SUBSTEPS = 20000
#: penetration below which a sample point counts as cutting an obstacle
_CUT = -1e-10
#: points sampling the whisker for touch detection (and their spacing)
_SAMPLES = np.linspace(0.0, 1.0, 81)
_SPACING = 1.0 / 80.0
_NUMERICAL_ERRORS = (ArithmeticError, ValueError, np.linalg.LinAlgError)
#: the clearance an obstacle out of the whisker's reach is counted with (its box is > 1.1 away)
_FAR = 0.1
#: geometric switches of one contact; two at one pose mean neither configuration goes on
_SWITCHES = ("tip", "tangential", "end_min", "end_max", "edge_in", "edge_out")
#: how far along the path [L] a switch's new configuration is probed (see _switch_goes_back)
_SWITCH_PROBE = 1e-7


@dataclass(frozen=True)
class SceneContact:
    """
    One contact of a scene state (world frame, dimensionless).

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    obstacle : int
        The obstacle's index in the scene.
    kind : {'side', 'corner', 'tip', 'tip_corner'}
        What touches what (doc/guide/scenes.md).
    s : float
        The whisker's arc length at the contact.
    x, y : float
        The contact point.
    fx, fy : float
        The force of the obstacle on the whisker.
    N, T : float
        Its normal and its tangential (friction) part.
    state : {'stick', 'slip'}
        The contact's friction state.
    u : float or None, optional
        The feature's parameter at the contact.

    """

    obstacle: int
    kind: str
    s: float
    x: float
    y: float
    fx: float
    fy: float
    N: float
    T: float
    state: str
    u: Optional[float] = None

    @property
    def report_kind(self) -> str:
        """Return the contract's kind: side, tip or corner (a corner on the side or the tip)."""
        return {"side": "side", "tip": "tip", "corner": "corner", "tip_corner": "corner"}[
            self.kind]


@dataclass(frozen=True)
class SceneState:
    """
    One quasistatic equilibrium in a scene.

    The scan contract's single-contact columns (phase, alpha, s1, f, contact) describe the
    contact nearest the foot. The parameters are the dataclass's fields, kept as attributes of
    the same names (world frame, dimensionless).

    Parameters
    ----------
    pose : FootPose
        The foot pose.
    contacts : tuple of SceneContact
        The contacts, ordered from the foot to the tip.
    fx, fy, m0 : float
        The total base load, what the follicle's sensor measures: the sum of the contact forces
        and their moment about the foot, counter-clockwise positive.
    tip : tuple of float
        The position (x, y) of the whisker's tip.
    tip_slope : float
        The whisker's slope at its tip [rad].
    configuration : object, optional
        The solver's configuration of the contacts (internal: it samples the centerline).
    solver : object, optional
        The solver that computed the state (internal: it samples the centerline).

    """

    pose: FootPose
    contacts: Tuple[SceneContact, ...]
    fx: float
    fy: float
    m0: float
    tip: Tuple[float, float]
    tip_slope: float
    configuration: Any = field(default=None, compare=False, repr=False)
    solver: Any = field(default=None, compare=False, repr=False)

    @property
    def x0(self) -> float:
        return self.pose.x

    @property
    def nearest(self) -> Optional[SceneContact]:
        return self.contacts[0] if self.contacts else None

    @property
    def phase(self) -> Phase:
        c = self.nearest
        if c is None:
            return Phase.FREE
        return Phase.TIP if c.kind in ("tip", "tip_corner") else Phase.TANGENTIAL

    @property
    def alpha(self) -> Optional[float]:
        """Direction of the nearest contact's force: F = f (sin alpha, -cos alpha)."""
        c = self.nearest
        return None if c is None else math.atan2(c.fx, -c.fy)

    @property
    def f(self) -> float:
        c = self.nearest
        return 0.0 if c is None else math.hypot(c.fx, c.fy)

    @property
    def s1(self) -> Optional[float]:
        c = self.nearest
        return None if c is None else c.s

    @property
    def contact(self) -> Optional[Tuple[float, float]]:
        c = self.nearest
        return None if c is None else (c.x, c.y)

    def centerline(self, n: int = 101) -> np.ndarray:
        """``n`` >= 2 points from foot to tip, world frame, shape (n, 2)."""
        n = int(n)
        if n < 2:
            raise ValueError(f"n = {n} points: need at least 2")
        cfg = self.configuration
        return self.solver.centerline(cfg.modes, cfg.vector, self.pose, np.linspace(0, 1, n))


@dataclass(frozen=True)
class SceneEvent:
    """
    Something that happened during a step, located on the path: kind, where, which contact.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    kind : str
        The event's kind (doc/guide/scenes.md; ``reset``: the whisker was placed unloaded at the
        new pose).
    pose : FootPose
        The foot pose where it happened.
    obstacle : int or None, optional
        The index of the obstacle concerned.
    contact_kind : str, optional
        The kind of the contact concerned (side, corner, tip or tip_corner).
    s : float or None, optional
        The contact's arc length on the whisker.
    reason : str, optional
        Why a ``reset`` happened (the refusal of the step, or a request); empty for other kinds.

    """

    kind: str
    pose: FootPose
    obstacle: Optional[int] = None
    contact_kind: str = ""
    s: Optional[float] = None
    #: why a ``reset`` happened (the refusal of the step, or a request); empty for other kinds
    reason: str = field(default="", compare=False)

    @property
    def x0(self) -> float:
        return self.pose.x


@dataclass(frozen=True)
class SceneStepResult:
    """The new state, the events crossed in order, the sub-steps and solver evaluations used."""

    state: SceneState
    events: Tuple[SceneEvent, ...]
    substeps: int = 0
    evaluations: int = 0


class SceneTracker:
    """
    Follow the whisker's equilibrium among the obstacles of a scene.

    Parameters
    ----------
    obstacles : sequence
        Obstacles with ``arcs``, ``vertices`` (boundary features) and ``signed_distance(points)``
        (core/scenes/scene.py).
    pose : FootPose or float, optional
        Start pose: the whisker is placed there unloaded; it must not cut an obstacle. A float
        is the paper's x0.
    shape : WhiskerShape, optional
        The whisker's taper and intrinsic curvature; None: the paper's whisker.
    friction : sequence of float, optional
        Coulomb coefficient of each obstacle (default 0), finite and >= 0.
    n : int, optional
        Chebyshev points per segment of the multi-contact solver; None: its default.
    max_evaluations : int, optional
        Solver evaluations one step may use before it raises ConvergenceError.
    recover : bool, optional
        A step that cannot be followed re-places the whisker unloaded at the new pose when it is
        free there (an event ``reset``); False raises instead (doc/mechanics/decisions.md,
        "Recovery").

    """

    def __init__(self, obstacles: Sequence[Any], pose=2.0, shape: Optional[WhiskerShape] = None,
                 friction: Optional[Sequence[float]] = None, n: Optional[int] = None,
                 max_evaluations: int = 10_000, recover: bool = True):
        self.obstacles = tuple(obstacles)
        self.shape = shape if shape is not None else WhiskerShape()
        self.solver = MultiContactSolver(self.shape) if n is None else MultiContactSolver(
            self.shape, n)
        mu = [0.0] * len(self.obstacles) if friction is None else [float(m) for m in friction]
        if len(mu) != len(self.obstacles):
            raise ParameterError("friction: one coefficient per obstacle")
        for m in mu:
            if not (math.isfinite(m) and m >= 0.0):
                raise ParameterError(f"friction coefficient {m!r} must be finite and >= 0")
        self.friction = tuple(mu)
        #: bounding boxes of the bounded obstacles (None: unbounded), to skip the far ones
        self._boxes = tuple(tuple(ob.extent()) if getattr(ob, "bounded", False)
                            and hasattr(ob, "extent") else None for ob in self.obstacles)
        for i, ob in enumerate(self.obstacles):
            if not ob.arcs and any(v.turn >= TWO_PI for v in ob.vertices):
                raise ParameterError(
                    f"obstacle {i} is a point peg (r = 0): the scene tracker needs r > 0 (a point "
                    "is supported as the only obstacle, without friction: --profile peg)")
        self.max_evaluations = int(max_evaluations)
        self.recover = bool(recover)
        #: motion [L] a sub-step may always make near an obstacle: half the thinnest peg's radius,
        #: at most 1e-3 (what can pass between two sub-steps without cutting at either)
        radii = [ob.r for ob in self.obstacles if getattr(ob, "r", 0.0) > 0.0]
        self._floor = min([1e-3] + [0.5 * r for r in radii])
        self._clearance = 0.0
        pose = _as_pose(pose)
        self._start = 0
        self._check_placeable(pose, "the initial pose")
        self._place(pose)

    def _check_placeable(self, pose: FootPose, what: str) -> None:
        """Raise InvalidPoseError unless the unloaded whisker is clear of every obstacle."""
        cut = self._penetration((), np.zeros(0), pose)
        if cut is not None:
            raise InvalidPoseError(
                f"{what} {pose} puts the unloaded whisker inside obstacle {cut[0]} "
                f"(at arc length {cut[1]:.3g}); place it where the whisker is free")

    def _place(self, pose: FootPose) -> None:
        """Place the whisker unloaded at pose, as a new tracker does (no warm start kept)."""
        self._modes: Tuple[ContactMode, ...] = ()
        self._vec = np.zeros(0)
        self._pose = pose
        self._forget()
        self._state = self._make_state(pose, self._modes, self._vec)

    def _forget(self) -> None:
        """Drop the step size and caches carried between steps: a free whisker is its pose."""
        self._h = 1.0
        self._lu_cache = None
        self._values_cache = None
        self._clear_end = 0.0  # the clearance at the pose: unknown

    # -- public ------------------------------------------------------------------------------
    @property
    def state(self) -> SceneState:
        return self._state

    @property
    def pose(self) -> FootPose:
        return self._pose

    def step(self, pose) -> SceneStepResult:
        """
        Move the foot along the straight path to ``pose`` and follow the equilibrium.

        Headings as :meth:`QuasistaticTracker.step
        <vibrissa_ros.core.exact.tracker.QuasistaticTracker.step>` takes them: in (-pi, pi],
        turned the short way round.

        Parameters
        ----------
        pose : FootPose or float
            The new foot pose (a float is the paper's x0).

        Returns
        -------
        SceneStepResult
            The new state and the events crossed.

        Raises
        ------
        InvalidPoseError
            The pose is not valid input, or a step that fails puts the foot inside an obstacle
            (the state is kept).
        ModelAssumptionError, ConvergenceError
            The step cannot be followed (the reason names the foot's path where it passes
            through an obstacle) and the unloaded whisker would cut an obstacle at
            ``pose``, or ``recover`` is off; the state is kept. When the whisker is free there it
            is re-placed instead, and the result has one event ``reset``
            (doc/mechanics/decisions.md, "Recovery").

        """
        target = _as_pose(pose)
        self._start = self.solver.evaluations
        try:
            return self._step_checked(target)
        except (ModelAssumptionError, ConvergenceError) as exc:
            cause = self._foot_path_cause(target, exc)
            if cause is not exc:
                if isinstance(cause, InvalidPoseError) or not self.recover:
                    raise cause from None
                exc = cause
            if not self.recover:
                raise
            spent = self._spent()
            try:
                result = self.reset(target, reason=str(exc))
            except InvalidPoseError:
                raise exc from None
            return SceneStepResult(result.state, result.events, 0, spent + result.evaluations)

    def _foot_path_cause(self, target: FootPose, exc: VibrissaError) -> VibrissaError:
        """
        Return the error a failed step is reported with: the foot's own path, where it is to blame.

        As the 3D whisker's (:meth:`RodTracker._base_path_cause
        <vibrissa_ros.core.rod3d.tracker.RodTracker._base_path_cause>`): looked at only once a
        step has failed, at 33 points of the foot's straight path; a foot inside an obstacle at
        the target is an InvalidPoseError, one that passes through an obstacle on the way a
        ModelAssumptionError that says so (it used to fail on the budget, saying only that).
        """
        found = obstacle_on_path((self._pose.x, self._pose.y), (target.x, target.y),
                                 self.obstacles, _CUT)
        if found is None:
            return exc
        k, at_end, depth = found
        name = self.obstacles[k].name
        if at_end:
            return InvalidPoseError(f"the foot pose {target} is inside {name} "
                                    f"({depth:.3g} L deep)")
        return ModelAssumptionError(
            f"the foot's path from {self._pose} to {target} passes through {name}: a foot "
            f"cannot move through an obstacle ({exc})")

    def reset(self, pose=None, reason: str = "reset on request") -> SceneStepResult:
        """
        Place the whisker unloaded at ``pose``, forgetting its history.

        The tracker is then exactly a new tracker placed there.

        Parameters
        ----------
        pose : FootPose or float, optional
            Where to place it; default: the current foot pose.
        reason : str
            Why, carried by the event.

        Returns
        -------
        SceneStepResult
            The unloaded state and one event ``reset``.

        Raises
        ------
        InvalidPoseError
            The unloaded whisker would cut an obstacle at ``pose`` (the state is kept).

        """
        target = self._pose if pose is None else _as_pose(pose)
        start = self.solver.evaluations
        self._check_placeable(target, "the reset pose")
        self._place(target)
        event = SceneEvent("reset", target, reason=reason)
        return SceneStepResult(self._state, (event,), 0, self.solver.evaluations - start)

    def _step_checked(self, target: FootPose) -> SceneStepResult:
        try:
            return self._step(target)
        except VibrissaError:
            raise
        except _NUMERICAL_ERRORS as exc:
            raise ConvergenceError(
                f"the step from {self._pose} to {target} failed numerically "
                f"({type(exc).__name__}: {exc})") from exc

    # -- the step ----------------------------------------------------------------------------
    def _spent(self) -> int:
        return self.solver.evaluations - self._start

    def _check_budget(self) -> None:
        if self._spent() > self.max_evaluations:
            raise ConvergenceError(
                f"the step used more than {self.max_evaluations} solver evaluations without "
                "settling")

    def _step(self, target: FootPose) -> SceneStepResult:
        path = _Path(self._pose, target)
        if path.length == 0.0:
            return SceneStepResult(self._state, (), 0, 0)
        modes, vec = self._modes, self._vec
        t = 0.0
        events: List[SceneEvent] = []
        dpose = (path.dx, path.dy, path.dh)
        h = min(1.0, _MAX_MOVE / path.length, self._h)
        values = self._event_values(modes, vec, path.pose(0.0), dpose)
        for key, v in list(values.items()):
            if key[0] == "stick" and v < 0.0:
                # the motion reverses the slip: the contact sticks where the step starts, unless
                # sticking there needs more than mu N the same way (then the slip goes on: the
                # quasistatic Coulomb problem has no sticking solution, Painleve's case)
                s_modes, s_vec, ev = self._transition(modes, vec, path, 0.0, ("event", key),
                                                      dpose)
                s_values = self._event_values(s_modes, s_vec, path.pose(0.0), dpose)
                c = key[1]
                back = "slip+" if modes[c].slip_sign < 0 else "slip-"
                if s_values.get((back, c), 1.0) < 0.0:
                    continue
                modes, vec, values = s_modes, s_vec, s_values
                events.append(ev)
        substeps = 0
        last_switch = None
        # a lower bound on the whisker's distance from the obstacles at t: no sub-step of the free
        # whisker (a rigid motion) moves a point of it farther than that (or than the floor), so
        # no obstacle is passed between two sub-steps, however long the step
        clear = self._clear_end if events == [] else 0.0
        while t < 1.0:
            substeps += 1
            if substeps > _MAX_SUBSTEPS or len(events) > _MAX_EVENTS:
                raise ConvergenceError(f"the step to {target} did not progress along its path")
            self._check_budget()
            allowed = max(clear, self._floor)
            t_new = min(1.0, t + h)
            if not modes and (t_new - t) * path.length > allowed:
                t_new = t + allowed / path.length  # the unloaded whisker moves rigidly
            try:
                new_vec, iters = self._advance(modes, vec, path, t, t_new, dpose)
            except ConvergenceError:
                if h > _H_MIN:
                    h *= 0.25
                    continue
                # the equilibrium folds at t: the whisker snaps
                modes, vec, ev = self._snap(modes, vec, path, t, dpose)
                events.append(ev)
                values = self._event_values(modes, vec, path.pose(t), dpose)
                h = _H_MIN * 16
                clear = 0.0
                continue
            pose_new = path.pose(t_new)
            # the slip rates' signs from the corrector's Jacobian (a crossing is then located
            # with fresh ones)
            lu = self._lu_cache[1] if self._lu_cache and self._lu_cache[0] == modes else None
            new_values = self._event_values(modes, new_vec, pose_new, dpose, lu)
            crossed = [key for key, v in new_values.items()
                       if v < 0.0 and values.get(key, 1.0) >= 0.0]
            cut = self._penetration(modes, new_vec, pose_new)
            if crossed or cut is not None:
                found = self._first_event(modes, vec, path, t, t_new, dpose, crossed, cut)
                if found is None:  # nothing crossed after all: take the sub-step
                    t, vec = t_new, new_vec
                    values = self._event_values(modes, vec, pose_new, dpose)
                    clear = self._clearance if cut is None else 0.0
                    continue
                t_star, what = found
                vec_star = self._solve_at(modes, vec, path, t, t_star, dpose)
                if (what[0] == "event" and what[1][0] in _SWITCHES and last_switch
                        and abs(t_star - last_switch[0]) <= 1e-12
                        and last_switch[1] == what[1][1]):
                    # side -> tip -> side (or corner -> edge -> corner) at one pose: neither
                    # configuration goes on (the tip slides off the edge or corner): a snap
                    modes, vec, ev = self._snap(modes, vec_star, path, t_star, dpose,
                                                only=what[1][1])
                    last_switch = None
                else:
                    modes, vec, ev = self._transition(modes, vec_star, path, t_star, what, dpose)
                    last_switch = ((t_star, what[1][1]) if what[0] == "event"
                                   and what[1][0] in _SWITCHES else None)
                    if last_switch and self._switch_goes_back(modes, vec, path, t_star, dpose,
                                                              what[1][1]):
                        # the new configuration's own switch back is violated at once: a corner
                        # of the branch, decided a fixed distance along the path (not by the
                        # sub-step's length): neither configuration goes on, a snap
                        if ev is not None:
                            events.append(ev)
                        modes, vec, ev = self._snap(modes, vec, path, t_star, dpose,
                                                    only=what[1][1])
                        last_switch = None
                if ev is not None:
                    events.append(ev)
                t = t_star
                if ev is not None and ev.kind == "touch":
                    modes, vec, t = self._first_friction(modes, vec, path, t, t_new, dpose)
                values = self._event_values(modes, vec, path.pose(t), dpose)
                h = max(h * 0.25, 1e-6)
                clear = 0.0
                continue
            t, vec, values = t_new, new_vec, new_values
            clear = self._clearance
            if iters <= 4 + len(modes):
                h = min(1.0, h * 2.0, _MAX_MOVE / path.length)
        turns = path.p1.heading - (path.h0 + path.dh)
        if modes and abs(turns) > math.pi:
            # the step crossed heading +-pi: its slopes follow the path's continuous heading,
            # the state the target's, a whole turn apart
            K = self.solver.layout(modes)[0]
            vec = vec.copy()
            vec[:K] += turns
        state = self._make_state(path.p1, modes, vec)
        self._modes, self._vec, self._pose, self._state = modes, vec, path.p1, state
        self._h = max(h, 1e-3)
        if not modes:
            self._forget()
        self._clear_end = clear  # (a function of the state: kept for a free whisker too)
        return SceneStepResult(state, tuple(events), substeps, self._spent())

    def _switch_goes_back(self, modes, vec, path, t, dpose, c) -> bool:
        """
        Tell whether contact c's geometric switches are violated just past a switch at t.

        At a switch (side -> tip, tip -> side, ...) the new configuration's switch back starts
        at zero; its sign a fixed 1e-7 L along the path decides whether the new configuration
        goes on. Judging it at the next sub-step instead made the outcome depend on the
        sub-step's length (a long step could pass over the brief violation).
        """
        if path.length == 0.0 or t >= 1.0:
            return False
        t_probe = min(1.0, t + _SWITCH_PROBE / path.length)
        try:
            probe = self._solve_at(modes, vec, path, t, t_probe, dpose)
        except ConvergenceError:
            return False   # a fold just past the switch: the step loop handles it
        values = self._event_values(modes, probe, path.pose(t_probe), dpose)
        return any(v < 0.0 for (kind, k), v in values.items()
                   if k == c and kind in _SWITCHES)

    def _advance(self, modes, vec, path, t, t_new, dpose):
        """Predictor-corrector from (t, vec) to t_new; the sub-step's change is bounded."""
        if not modes:
            return vec, 0
        pose0 = path.pose(t)
        # the factorized Jacobian is kept while the configuration stays (chord iterations; the
        # solver refreshes it when they stall)
        if self._lu_cache is not None and self._lu_cache[0] == modes:
            lu = self._lu_cache[1]
        else:
            _, J = self.solver.residual(modes, vec, pose0)
            lu = sla.lu_factor(J, check_finite=False)
        tan = self.solver.tangent(modes, vec, pose0, dpose, lu=lu)
        dt = t_new - t
        change = self._change(modes, tan) * dt
        if change > _MAX_CHANGE:
            raise ConvergenceError("sub-step too large")
        guess = vec + dt * tan
        before = self.solver.evaluations
        # a fresh Jacobian at the predicted point: Newton converges quadratically from there (a
        # Jacobian from the step's start converges only linearly, at ~ the step's size)
        new, lu = self.solver.solve(modes, path.pose(t_new), guess, max_iter=8)
        self._lu_cache = (modes, lu)  # for the next sub-step's tangent
        if self._change(modes, new - vec) > 2.0 * _MAX_CHANGE:
            raise ConvergenceError("sub-step jumped")
        return new, self.solver.evaluations - before

    def _change(self, modes, dv) -> float:
        """Largest change of the slopes and geometric contact unknowns (forces excluded)."""
        K, offsets, _ = self.solver.layout(modes)
        big = float(np.max(np.abs(dv[:K]))) if K else 0.0
        for m, o in zip(modes, offsets):
            if m.kind in ("side",):
                big = max(big, abs(dv[o]), abs(dv[o + 1]))
            elif m.kind == "corner":
                big = max(big, abs(dv[o]))
            elif m.kind == "tip":
                big = max(big, abs(dv[o]))
        return big

    def _solve_at(self, modes, vec, path, t, t_target, dpose):
        """Solve the configuration at t_target, continued from (t, vec) in small pieces."""
        if not modes or t_target == t:
            return vec
        pieces = 1
        for _ in range(12):
            try:
                cur, tc = vec, t
                for k in range(1, pieces + 1):
                    tk = t + (t_target - t) * k / pieces
                    pose0 = path.pose(tc)
                    tan = self.solver.tangent(modes, cur, pose0, dpose)
                    cur, _ = self.solver.solve(modes, path.pose(tk), cur + (tk - tc) * tan,
                                               max_iter=12)
                    tc = tk
                return cur
            except ConvergenceError:
                pieces *= 2
                self._check_budget()
        raise ConvergenceError(
            f"no equilibrium found at {path.pose(t_target)} with the whisker's present contacts "
            f"({', '.join(f'{m.kind} on obstacle {m.obstacle}' for m in modes)})")

    # -- events ------------------------------------------------------------------------------
    def _event_values(self, modes, vec, pose, dpose, lu=None):
        """Evaluate the configuration's inequalities (each >= 0 while it holds), by (name, c)."""
        out = {}
        if not modes:
            return out
        moving = any(m.mu > 0.0 and not m.stick and m.kind != "tip_corner" for m in modes)
        key = (modes, pose, vec.tobytes())
        if not moving and self._values_cache is not None and self._values_cache[0] == key:
            return dict(self._values_cache[1])  # (without slip rates they ignore the motion)
        out = self._event_values_new(modes, vec, pose, dpose, lu)
        self._values_cache = (key, dict(out)) if not moving else None
        return out

    def _event_values_new(self, modes, vec, pose, dpose, lu):
        out = {}
        cfg = self.solver.configuration(modes, vec, pose)
        need_rate = any(m.mu > 0.0 and not m.stick and m.kind != "tip_corner" for m in modes)
        rates = self._slip_rates(modes, vec, pose, dpose, lu) if need_rate else None
        prev_s = 0.0
        for c, (m, sol) in enumerate(zip(modes, cfg.contacts)):
            if m.kind == "tip_corner":
                V = m.feature
                mid = _cone_mid(V)
                out[("release", c)] = sol.fx * math.sin(mid) - sol.fy * math.cos(mid)
                if V.turn < TWO_PI:
                    ang = math.atan2(sol.fx, -sol.fy)
                    d = math.remainder(ang - mid, TWO_PI)
                    widen = math.atan(m.mu)
                    out[("edge_in", c)] = d + 0.5 * V.turn + widen
                    out[("edge_out", c)] = 0.5 * V.turn + widen - d
                continue
            out[("release", c)] = sol.N
            if m.kind in ("side", "corner"):
                if c == len(modes) - 1:
                    out[("tip", c)] = 1.0 - sol.s
                if c > 0:
                    out[("merge", c)] = sol.s - prev_s
                prev_s = sol.s
            if m.kind in ("side", "tip"):
                arc = m.feature
                if not arc.periodic:
                    if math.isfinite(arc.u_min):
                        out[("end_min", c)] = sol.u - arc.u_min
                    if math.isfinite(arc.u_max):
                        out[("end_max", c)] = arc.u_max - sol.u
            if m.kind == "tip":
                p = m.feature.at(sol.u)
                out[("tangential", c)] = math.sin(cfg.tip_slope - p.phi)
            if m.kind == "corner":
                V = m.feature
                th = cfg.theta[(c + 1) * self.solver.n - 1]
                nx, ny = -m.e * math.sin(th), m.e * math.cos(th)
                if V.turn < TWO_PI:
                    mid = _cone_mid(V)
                    d = math.remainder(math.atan2(nx, -ny) - mid, TWO_PI)
                    out[("edge_in", c)] = d + 0.5 * V.turn
                    out[("edge_out", c)] = 0.5 * V.turn - d
            if m.mu > 0.0:
                if m.stick:
                    out[("slip+", c)] = m.mu * sol.N - sol.T
                    out[("slip-", c)] = m.mu * sol.N + sol.T
                elif rates is not None:
                    out[("stick", c)] = m.slip_sign * rates[c]
        return out

    def _slip_rates(self, modes, vec, pose, dpose, lu=None):
        """dq/dt of every contact along the path (from the tangent)."""
        tan = self.solver.tangent(modes, vec, pose, dpose, lu=lu)
        K, offsets, _ = self.solver.layout(modes)
        out = []
        for m, o in zip(modes, offsets):
            if m.kind == "side":
                speed = m.feature.at(vec[o + 1]).speed
                out.append(speed * tan[o + 1] - m.e * tan[o])
            elif m.kind == "corner":
                out.append(-tan[o])
            elif m.kind == "tip":
                out.append(m.feature.at(vec[o]).speed * tan[o])
            else:
                out.append(0.0)
        return out

    def _first_event(self, modes, vec, path, t, t_new, dpose, crossed, cut):
        """Locate the earliest crossing in (t, t_new]: (t_star, what)."""
        best = None
        for key in crossed:
            def g(tau, key=key):
                v = self._solve_at(modes, vec, path, t, tau, dpose)
                return self._event_values(modes, v, path.pose(tau), dpose).get(key, 0.0)
            t_star = self._root(g, t, t_new, strict=key[0] == "stick")
            if t_star is None:
                continue  # the estimated slip rate's sign was wrong: no crossing
            if best is None or t_star < best[0] - 1e-15 or (
                    abs(t_star - best[0]) <= 1e-15 and key[0] == "release"):
                best = (t_star, ("event", key))
        if cut is not None:
            obstacle, s_cut = cut

            def gap(tau):
                v = self._solve_at(modes, vec, path, t, tau, dpose)
                return self._gap(modes, v, path.pose(tau), obstacle, s_cut)[0]

            g0 = gap(t)
            if g0 > 0.0:
                t_star = self._root(gap, t, t_new)
            elif g0 > -1e-12:  # touching exactly at the start of the sub-step (to rounding)
                t_star = t
            else:
                raise ModelAssumptionError(
                    f"the whisker cuts obstacle {obstacle} next to an existing contact at "
                    f"{path.pose(t)} (e.g. a contact on a concave part curved more than the "
                    "whisker): not modelled")
            if best is None or t_star < best[0] - 1e-12:
                best = (t_star, ("touch", (obstacle, s_cut)))
        return best

    def _root(self, g, a, b, strict=False):
        ga, gb = g(a), g(b)
        if ga == 0.0:
            return a
        if ga * gb > 0.0:
            if strict and abs(gb) > 1e-12:
                return None
            # the crossing is at the end of the interval within rounding
            return b
        return brentq(g, a, b, xtol=_EVENT_XTOL, rtol=4 * np.finfo(float).eps, maxiter=200)

    # -- touches -----------------------------------------------------------------------------
    def _points(self, modes, vec, pose, s):
        return self.solver.centerline(modes, vec, pose, s)

    def _penetration(self, modes, vec, pose):
        """
        Return the first (obstacle, s) where the whisker cuts an obstacle, or None.

        The whisker is sampled at its collocation nodes (and every 1/80 L beyond the last
        contact); around every local minimum of an obstacle's distance that could hide a cut
        between samples (closer than half the local spacing: the distance changes at most as
        fast as the arc length) it is resampled densely (33 points), so that a shallow cut of a
        small obstacle is not missed. The neighbourhood of a contact (2/80 L) is left to that
        contact's own events.

        Also records in ``self._clearance`` a lower bound on the distance of the whisker (away
        from its contacts) from every obstacle: the sampled distances less half the local
        spacing (the distance is 1-Lipschitz in s); an obstacle out of reach counts 0.1.
        """
        s_all = pts = None
        first = None
        clearance = _FAR
        held = [(m.obstacle, sc) for m, sc in zip(modes, self._contact_s(modes, vec))]
        for i, ob in enumerate(self.obstacles):
            box = self._boxes[i]
            if box is not None:
                dx = max(box[0] - pose.x, 0.0, pose.x - box[2])
                dy = max(box[1] - pose.y, 0.0, pose.y - box[3])
                if dx * dx + dy * dy > 1.21:
                    continue  # out of reach of a whisker of length 1 (by 0.1 at least)
            elif float(ob.signed_distance(np.array([[pose.x, pose.y]]))[0]) > 1.1:
                continue
            if pts is None:
                s_all, pts = self.solver.node_points(modes, vec, pose, _SPACING)
                gaps = np.diff(s_all)
                local = np.zeros(s_all.size)
                local[:-1] = gaps
                np.maximum(local[1:], gaps, out=local[1:])
            d = ob.signed_distance(pts)
            for oi, sc in held:
                if oi == i:
                    d[np.abs(s_all - sc) <= 2.0 * _SPACING] = np.inf
            clearance = min(clearance, float(np.min(d - 0.5 * local)))
            cut = None
            bad = np.nonzero(d < _CUT)[0]
            if bad.size:
                run = bad[: int(np.argmax(np.diff(np.r_[bad, bad[-1] + 2]) > 1)) + 1]
                cut = float(s_all[run[np.argmin(d[run])]])
            else:
                near = d < 0.5 * local
                near[1:] &= d[1:] <= d[:-1]
                near[:-1] &= d[:-1] <= d[1:]
                # next to a contact's neighbourhood the distance falls towards the contact
                masked = np.isinf(d)
                near[1:] &= ~masked[:-1]
                near[:-1] &= ~masked[1:]
                for j in np.nonzero(near)[0]:
                    lo = s_all[max(j - 1, 0)]
                    hi = s_all[min(j + 1, len(s_all) - 1)]
                    s_fine = np.linspace(lo, hi, 33)
                    d_fine = ob.signed_distance(self._points(modes, vec, pose, s_fine))
                    k = int(np.argmin(d_fine))
                    if d_fine[k] < _CUT:
                        cut = float(s_fine[k])
                        break
            if cut is not None and (first is None or cut < first[1]):
                first = (i, cut)
        self._clearance = clearance
        return first

    def _contact_s(self, modes, vec):
        return self.solver.breaks_of(modes, vec) if modes else []

    def _gap(self, modes, vec, pose, obstacle, s_near):
        """Smallest signed distance to ``obstacle`` of the whisker near arc length s_near."""
        ob = self.obstacles[obstacle]
        step = _SAMPLES[1] - _SAMPLES[0]
        lo, hi = max(0.0, s_near - 4.0 * step), min(1.0, s_near + 4.0 * step)
        s_fine = np.linspace(lo, hi, 97)
        d_fine = ob.signed_distance(self._points(modes, vec, pose, s_fine))
        for m, sc in zip(modes, self._contact_s(modes, vec)):
            if m.obstacle == obstacle:  # not the contacts this obstacle already has
                d_fine[np.abs(s_fine - sc) <= 2.0 * step] = np.inf
        k = int(np.argmin(d_fine))
        if not math.isfinite(d_fine[k]):
            return math.inf, s_near
        lo, hi = s_fine[max(k - 1, 0)], s_fine[min(k + 1, 96)]

        def d(s):
            p = self._points(modes, vec, pose, np.array([s]))
            return float(ob.signed_distance(p)[0])

        res = minimize_scalar(d, bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-11, "maxiter": 200})
        s_best, d_best = float(res.x), float(res.fun)
        for s_end in (lo, hi):
            if s_end in (0.0, 1.0):
                v = d(s_end)
                if v < d_best:
                    s_best, d_best = s_end, v
        return d_best, s_best

    def _new_contact(self, modes, vec, pose, obstacle, s_near):
        """Return the mode and unknowns of a contact touching at the located pose (no force)."""
        _, s = self._gap(modes, vec, pose, obstacle, s_near)
        ob = self.obstacles[obstacle]
        px, py = self._points(modes, vec, pose, np.array([s]))[0]
        theta = self._theta_at(modes, vec, pose, np.array([s]))[0]
        kind_tip = s >= 1.0 - 1e-9
        feature, index, u = _nearest_feature(ob, px, py)
        mu = self.friction[obstacle]
        if isinstance(feature, Vertex):
            if kind_tip:
                if feature.turn >= TWO_PI:
                    raise ModelAssumptionError(
                        f"the tip reaches the point obstacle {obstacle} head-on at {pose}: a "
                        "point "
                        "cannot hold the tip")
                mode = ContactMode("tip_corner", feature, obstacle, index, mu)
                return mode, np.array([0.0, 0.0]), 1.0
            mid = _cone_mid(feature)
            e = 1 if (-math.sin(theta) * math.sin(mid) - math.cos(theta) * math.cos(mid)) > 0 \
                else -1
            mode = ContactMode("corner", feature, obstacle, index, mu, stick=False, e=e,
                               anchor=(0.0, s))
            return mode, np.array([s, 0.0]), s
        p = feature.at(u)
        e = 1 if math.cos(theta - p.phi) >= 0.0 else -1
        if kind_tip:  # starts frictionless: the first motion decides (_first_friction)
            mode = ContactMode("tip", feature, obstacle, index, mu, stick=False, anchor=(u, 1.0))
            return mode, np.array([u, 0.0]), 1.0
        # a side contact starts slipping (its direction is found from the first motion, see
        # _transition): a tangential force along a whisker that is still unloaded bends nothing,
        # so sticking with zero load is not determined
        mode = ContactMode("side", feature, obstacle, index, mu, stick=False, e=e,
                           anchor=(u, s))
        return mode, np.array([s, u, 0.0]), s

    # -- configuration changes ---------------------------------------------------------------
    def _params(self, modes, vec):
        K, offsets, size = self.solver.layout(modes)
        return [vec[o:o + m.size].copy() for m, o in zip(modes, offsets)]

    def _theta_at(self, modes, vec, pose, s):
        """Return the whisker's slope at arc lengths s (spectral interpolation per segment)."""
        s = np.asarray(s, dtype=float)
        n = self.solver.n
        out = np.empty(s.size)
        breaks = self.solver.breaks_of(modes, vec) if modes else []
        a, th_end = 0.0, pose.heading
        done = np.zeros(s.size, dtype=bool)
        from .multicontact import _node_variable
        for j, b in enumerate(breaks):
            th = vec[j * n:(j + 1) * n]
            inside = (~done) & (s <= b)
            if np.any(inside):
                tt = _node_variable(self.shape, s[inside], a, b)
                out[inside] = np.polynomial.chebyshev.chebval(2 * tt - 1, self.solver._Vinv @ th)
                done |= inside
            a, th_end = b, float(th[-1])
        rest = ~done
        out[rest] = th_end + self.shape.intrinsic_slope(s[rest]) - float(
            self.shape.intrinsic_slope(a))
        return out

    def _rebuild(self, old_modes, old_vec, pose, new_modes, new_params):
        """Build a new configuration's vector: slopes resampled, the contacts' unknowns given."""
        breaks = []
        for m, p in zip(new_modes, new_params):
            breaks.append(float(p[0]) if m.on_side else 1.0)
        thetas, a = [], 0.0
        from .multicontact import _Segment
        for b in breaks:
            seg = _Segment(self.shape, self.solver._t, self.solver._S, a, b)
            thetas.append(self._theta_at(old_modes, old_vec, pose, seg.s))
            a = b
        parts = thetas + [np.asarray(p, dtype=float) for p in new_params]
        return np.concatenate(parts) if parts else np.zeros(0)

    def _transition(self, modes, vec, path, t, what, dpose):
        """Apply the located event ``what`` at t: the new (modes, vector) and the event."""
        pose = path.pose(t)
        params = self._params(modes, vec)
        modes = list(modes)
        if what[0] == "touch":
            obstacle, s_near = what[1]
            mode, p, s = self._new_contact(modes, vec, pose, obstacle, s_near)
            index = sum(1 for m, q in zip(modes, params) if (q[0] if m.on_side else 1.0) < s)
            new_modes = modes[:index] + [mode] + modes[index:]
            new_params = params[:index] + [p] + params[index:]
            new_vec = self._rebuild(modes, vec, pose, new_modes, new_params)
            new_vec = self._settle(new_modes, new_vec, pose)
            settled = self.solver.configuration(tuple(new_modes), new_vec, pose)
            s_new = settled.contacts[index].s
            return (tuple(new_modes), new_vec,
                    SceneEvent("touch", pose, obstacle, mode.kind, s_new))
        name, c = what[1]
        m = modes[c]
        p = params[c]
        cfg = self.solver.configuration(modes, vec, pose)
        sol = cfg.contacts[c]
        ev_kind = name
        if name == "release":
            del modes[c]
            del params[c]
        elif name == "tip":  # side/corner reaches the tip
            if m.kind == "side":
                modes[c] = m.with_(kind="tip", anchor=(sol.u, 1.0))
                params[c] = np.concatenate(([sol.u], p[2:]))
            else:
                if m.feature.turn >= TWO_PI:  # a point cannot hold the tip: it slips off
                    del modes[c]
                    del params[c]
                    ev_kind = "snap"
                else:
                    modes[c] = m.with_(kind="tip_corner", stick=False)
                    params[c] = np.array([sol.fx, sol.fy])
        elif name == "tangential":  # tip -> side at s = 1
            p_arc = m.feature.at(sol.u)
            e = 1 if math.cos(cfg.tip_slope - p_arc.phi) >= 0.0 else -1
            modes[c] = m.with_(kind="side", e=e, anchor=(sol.u, 1.0))
            params[c] = np.concatenate(([1.0 - 1e-15], p))
        elif name in ("end_min", "end_max"):
            arc = m.feature
            u_end = arc.u_min if name == "end_min" else arc.u_max
            found = _vertex_at(self.obstacles[m.obstacle], arc.at(u_end))
            if found is None:
                raise ModelAssumptionError(
                    f"a contact slides off the open end of obstacle {m.obstacle}'s boundary (the "
                    f"end of its curve) at {pose}: the whisker would leave the modelled boundary")
            index, V = found
            ev_kind = "corner"
            if m.kind == "side":
                th = cfg.theta[(c + 1) * self.solver.n - 1]
                e = 1 if (-math.sin(th) * math.sin(arc.at(u_end).phi)
                          - math.cos(th) * math.cos(arc.at(u_end).phi)) >= 0.0 else -1
                tau_t = math.cos(th - arc.at(u_end).phi)
                modes[c] = m.with_(kind="corner", feature=V, feature_index=index, e=e,
                                   anchor=(0.0, sol.s))
                extra = [sol.T * tau_t] if modes[c].has_tangential_unknown else []
                params[c] = np.array([sol.s, sol.N] + extra)
            else:
                modes[c] = m.with_(kind="tip_corner", feature=V, feature_index=index,
                                   stick=False)
                params[c] = np.array([sol.fx, sol.fy])
        elif name in ("edge_in", "edge_out"):
            V = m.feature
            found = _arc_at_vertex(self.obstacles[m.obstacle], V, incoming=name == "edge_in")
            if found is None:
                raise ModelAssumptionError(
                    f"a corner contact of obstacle {m.obstacle} leaves its corner at {pose} "
                    "onto no edge")
            index, arc, u = found
            ev_kind = "edge"
            pa = arc.at(u)
            if m.kind == "corner":
                th = cfg.theta[(c + 1) * self.solver.n - 1]
                e = 1 if math.cos(th - pa.phi) >= 0.0 else -1
                modes[c] = m.with_(kind="side", feature=arc, feature_index=index, e=e,
                                   anchor=(u, sol.s))
                Tn = sol.fx * math.cos(pa.phi) + sol.fy * math.sin(pa.phi)
                Nn = sol.fx * math.sin(pa.phi) - sol.fy * math.cos(pa.phi)
                extra = [Tn] if modes[c].has_tangential_unknown else []
                params[c] = np.array([sol.s, u, Nn] + extra)
            else:
                Tn = sol.fx * math.cos(pa.phi) + sol.fy * math.sin(pa.phi)
                Nn = sol.fx * math.sin(pa.phi) - sol.fy * math.cos(pa.phi)
                slip = -1 if name == "edge_in" else 1
                if m.mu > 0.0:
                    modes[c] = m.with_(kind="tip", feature=arc, feature_index=index,
                                       stick=False, slip_sign=slip, anchor=(u, 1.0))
                else:
                    modes[c] = m.with_(kind="tip", feature=arc, feature_index=index,
                                       stick=False, slip_sign=0, anchor=(u, 1.0))
                del Tn
                params[c] = np.array([u, Nn])
        elif name in ("slip+", "slip-"):
            sign = 1 if name == "slip+" else -1  # T reached +mu N: the whisker slides in -t
            modes[c] = m.with_(stick=False, slip_sign=-sign)
            params[c] = p[:-1]
            ev_kind = "slip"
        elif name == "stick":
            modes[c] = m.with_(stick=True, slip_sign=0,
                               anchor=(sol.u if sol.u is not None else 0.0, sol.s))
            params[c] = np.concatenate((p, [sol.T]))
        elif name == "merge":
            prev = modes[c - 1]
            if prev.feature is not m.feature or m.kind != "side" or prev.kind != "side":
                raise ModelAssumptionError(
                    f"two contacts of different features meet at {pose}: not modelled")
            q = params[c - 1]
            q[2] = q[2] + p[2]
            if prev.has_tangential_unknown and len(p) > 3:
                q[3] = q[3] + p[3]
            del modes[c]
            del params[c]
        else:  # pragma: no cover - every event name is handled above
            raise AssertionError(name)
        new_vec = self._rebuild(cfg.modes, vec, pose, modes, params)
        new_vec = self._settle(tuple(modes), new_vec, pose)
        return tuple(modes), new_vec, SceneEvent(ev_kind, pose, m.obstacle, m.kind, sol.s)

    def _first_friction(self, modes, vec, path, t, t_end, dpose):
        """
        Decide whether a contact just made sticks or slips.

        At the touch the force is zero and a force along the still unloaded whisker bends
        nothing, so the sticking solution is not determined there. The first motion decides:
        the contact is followed frictionless over a tiny probe step (the foot moves 1e-5 L), then
        solved sticking (held at the touch point); it sticks if that needs |T| <= mu N, and slips
        against the sticking force's direction otherwise. The probe step becomes part of the path.
        """
        c = next((i for i, m in enumerate(modes) if m.mu > 0.0 and m.kind != "tip_corner"
                  and not m.stick and m.slip_sign == 0), None)
        if c is None:
            return modes, vec, t
        m = modes[c]
        dt = min(1e-5 / path.length, 0.5 * (t_end - t))
        if dt <= 0.0:
            return modes, vec, t
        pose_p = path.pose(t + dt)
        touch = self.solver.configuration(modes, vec, path.pose(t)).contacts[c]
        anchor = (touch.u if touch.u is not None else 0.0, touch.s)
        free = tuple(x.with_(mu=0.0) if i == c else x for i, x in enumerate(modes))
        vec_p = self._solve_at(free, vec, path, t, t + dt, dpose)
        stick = list(modes)
        stick[c] = m.with_(stick=True, slip_sign=0, anchor=anchor)
        params = self._params(modes, vec_p)
        params[c] = np.concatenate((params[c], [0.0]))
        try:
            guess = self._rebuild(modes, vec_p, pose_p, stick, params)
            sv = self._settle(tuple(stick), guess, pose_p)
            sol = self.solver.configuration(tuple(stick), sv, pose_p).contacts[c]
            if abs(sol.T) <= m.mu * sol.N:
                return tuple(stick), sv, t + dt
            sign = -1 if sol.T > 0.0 else 1  # slip against the force sticking would need
        except ConvergenceError:
            sign = 1 if self._slip_rates(free, vec_p, pose_p, dpose)[c] >= 0.0 else -1
        slip = list(modes)
        slip[c] = m.with_(slip_sign=sign)
        sv = self._settle(tuple(slip), vec_p, pose_p)
        return tuple(slip), sv, t + dt

    def _settle(self, modes, vec, pose):
        if not modes:
            return vec
        new, _ = self.solver.solve(modes, pose, vec, max_iter=30)
        return new

    def _snap(self, modes, vec, path, t, dpose, only=None):
        """At a fold: drop the contact that cannot be held (the one nearest the tip first)."""
        pose = path.pose(t)
        params = self._params(modes, vec)
        for c in reversed(range(len(modes))):
            if only is not None and c != only:
                continue
            new_modes = modes[:c] + modes[c + 1:]
            new_params = params[:c] + params[c + 1:]
            try:
                new_vec = self._rebuild(modes, vec, pose, new_modes, new_params)
                new_vec = self._settle(new_modes, new_vec, pose)
            except ConvergenceError:
                continue
            values = self._event_values(new_modes, new_vec, pose, dpose)
            if any(v < -1e-9 for v in values.values()):
                continue
            if self._penetration(new_modes, new_vec, pose) is not None:
                continue
            # a contact dropped while its force is zero is a release, not a jump
            gone = self.solver.configuration(modes, vec, pose).contacts[c]
            kind = "release" if abs(gone.N) + abs(gone.T) <= 1e-9 else "snap"
            return new_modes, new_vec, SceneEvent(kind, pose, modes[c].obstacle,
                                                  modes[c].kind, gone.s)
        raise ModelAssumptionError(
            f"the equilibrium folds at {pose} and no configuration with one contact less is "
            "admissible (the whisker would jump into another contact): not modelled")

    # -- states ------------------------------------------------------------------------------
    def _make_state(self, pose, modes, vec) -> SceneState:
        cfg = self.solver.configuration(modes, vec, pose)
        contacts = []
        for m, sol in zip(modes, cfg.contacts):
            state = "stick" if (m.stick and m.mu > 0.0) or m.kind == "tip_corner" else "slip"
            contacts.append(SceneContact(m.obstacle, m.kind, sol.s, sol.x, sol.y, sol.fx, sol.fy,
                                         sol.N, sol.T, state, sol.u))
        return SceneState(pose, tuple(contacts), cfg.fx, cfg.fy, cfg.m0, cfg.tip, cfg.tip_slope,
                          cfg, self.solver)


def _cone_mid(V: Vertex) -> float:
    return 0.5 * (V.phi_in + V.phi_out)


def _nearest_feature(obstacle, x, y):
    """(feature, index, u): the arc (with its parameter) or convex vertex nearest to (x, y)."""
    closest = getattr(obstacle, "closest", None)
    if closest is not None:  # a scene obstacle: global and exact
        near = closest(x, y)
        if near.on_vertex:
            return obstacle.vertices[near.vertex_index], near.vertex_index, None
        arc = obstacle.arcs[near.arc_index]
        for end in (arc.u_min, arc.u_max):
            # at an edge's end (to rounding) the touch is the corner's
            if math.isfinite(end) and abs(near.u - end) <= 1e-9 * max(1.0, abs(end)):
                found = _vertex_at(obstacle, arc.at(end))
                if found is not None and found[1].convex:
                    return found[1], found[0], None
        return arc, near.arc_index, near.u
    best = None
    for i, arc in enumerate(obstacle.arcs):
        u, d = arc.project(x, y)
        p = arc.at(u)
        dist = math.hypot(x - p.x, y - p.y)
        if best is None or dist < best[0]:
            best = (dist, arc, i, u)
    for i, V in enumerate(obstacle.vertices):
        if not V.convex:
            continue
        dist = math.hypot(x - V.x, y - V.y)
        if best is None or dist < best[0] - 1e-13:
            best = (dist, V, i, None)
    return best[1], best[2], best[3]


def _vertex_at(obstacle, p, tol=1e-9):
    for i, V in enumerate(obstacle.vertices):
        if math.hypot(V.x - p.x, V.y - p.y) <= tol:
            return i, V
    return None


def _arc_at_vertex(obstacle, V, incoming: bool, tol=1e-9):
    """Find the edge ending (incoming) or starting (outgoing) at corner V, and its u there."""
    for i, arc in enumerate(obstacle.arcs):
        u = arc.u_max if incoming else arc.u_min
        if not math.isfinite(u):
            continue
        p = arc.at(u)
        if math.hypot(V.x - p.x, V.y - p.y) <= tol:
            return i, arc, u
    return None
