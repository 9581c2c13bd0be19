"""
The whole array in one call: every whisker's quasistatic equilibrium at a head pose and whisk.

Each whisker has its own bounded 3D tracker (:class:`~vibrissa_ros.core.rod3d.tracker.RodTracker`)
in its own units (its length L and base stiffness EI_b); the scene, the head pose and the results
are in SI units (metres, newtons) in the world frame, plus each whisker's wrench in its own base
frame.

A tick (:meth:`ArrayTracker.step`):

1. Whisking and the head pose give every whisker's base frame in the world (vectorized,
   :class:`~.whisking.Whisking`).
2. Clearance test, vectorized over the whole array: the unloaded whisker, sampled at
   ``samples`` points equally spaced in arc length (a first pass with every fourth of them and
   a four times wider margin; the rest only for the whiskers it does not clear), is placed at
   the new base frame and its distance d to the scene is taken. Every point of the continuous
   centerline lies within h = L / (2 (samples - 1)) of a sample, and every point of the
   whisker moves by at most m = norm(dp) + angle(dR) L between the previous tick and this one
   (the straight pose path a tracker follows). A whisker that was free at the previous tick
   and has d > h + m is free along the whole path: its result is the unloaded whisker (zero
   wrench), exactly what its tracker would return, and its tracker is not called.
3. Every other whisker's tracker steps from the previous tick's pose (a tracker skipped before is
   first re-placed unloaded at the last pose where it was certified clear: a free whisker has no
   history, so the result is the same as stepping it every tick).

One failing whisker never stops the others: its error is reported in the tick's ``errors``, its
tracker keeps its state (the wrench it reports is that state's) and the next tick steps on from
there.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple

import numpy as np

from ..errors import InvalidPoseError, ParameterError, VibrissaError, interrupted
from ..rod3d import _jit
from ..rod3d.model import POINTS_TOLERANCE, _points_tolerance, kernel_obstacles
from ..rod3d.pose import BasePose, quat_from_matrix, quat_matrix
from ..rod3d.scene import Scene3D
from ..rod3d.tracker import RodStepResult, RodTracker
from ..units import convert_lengths
from . import _jit as _arrays_jit
from .array import WhiskerArray
from .whisking import Whisking

#: default number of samples of the unloaded whisker in the clearance test
CLEARANCE_SAMPLES = 65
#: the clearance test's first pass takes every _COARSE-th sample (a spacing _COARSE times wider)
_COARSE = 4


@dataclass(frozen=True)
class WhiskerEvent:
    """
    An event of one whisker during a tick (touch, release, tip, tangential, snap, reset).

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    whisker : str
        The whisker's name.
    kind : str
        As :class:`~vibrissa_ros.core.rod3d.tracker.RodEvent`'s.
    obstacle : str or None
        The obstacle's name, when one is concerned.
    s : float or None
        The contact's arc length [m], when one is concerned.
    contacts_before, contacts_after : int
        The whisker's number of contacts before and after.
    reason : str
        Why a snap or a reset happened.

    """

    whisker: str
    kind: str
    obstacle: Optional[str]
    s: Optional[float]
    contacts_before: int
    contacts_after: int
    reason: str = ""


@dataclass(frozen=True)
class WhiskerError:
    """
    A whisker whose step failed in a tick (it kept its state; the others went on).

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    whisker : str
        The whisker's name.
    message : str
        The error's one line (what was wrong, what is allowed).

    """

    whisker: str
    message: str


def _frozen(a) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


def _sealed(a: np.ndarray) -> np.ndarray:
    """Return ``a`` (an array no one else holds) read-only, without a copy."""
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class ArrayStep:
    """
    One tick of the whole array: every whisker's base wrench and contact state (SI units).

    Arrays have one row per whisker, in the array's order, and are read-only. Forces are the
    total contact force on the whisker [N]; moments those of the contact forces about the
    whisker's base point [N m] (the follicle's reaction is their opposite). The parameters are
    the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    names : tuple of str
        The whiskers' names.
    head : BasePose
        The head pose in the world (position [m]).
    protraction : numpy.ndarray
        (k,) each whisker's protraction angle [rad].
    base_position : numpy.ndarray
        (k, 3) base points in the world [m].
    base_rotation : numpy.ndarray
        (k, 3, 3) base frames in the world (columns: the base frame's axes); the quaternions
        are :attr:`base_quaternion`.
    contacts : numpy.ndarray
        (k,) number of contacts (int).
    force, moment : numpy.ndarray
        (k, 3) in the world frame [N], [N m].
    force_base, moment_base : numpy.ndarray
        (k, 3) the same in each whisker's base frame.
    tip : numpy.ndarray
        (k, 3) tip positions in the world [m].
    contact_point : numpy.ndarray
        (k, 3) the contact nearest the base [m] (zeros where there is none).
    contact_s : numpy.ndarray
        (k,) its arc length from the base [m] (0 where there is none).
    contact_f : numpy.ndarray
        (k,) its normal force [N] (0 where there is none).
    contact_kind : tuple of str
        ``side``, ``tip`` or ``""`` (free).
    contact_obstacle : tuple of str
        The obstacle's name or ``""``.
    solved : numpy.ndarray
        (k,) bool: the whisker's tracker stepped (False: certified free by the clearance test).
    events : tuple of WhiskerEvent
        Events of this tick, whisker by whisker.
    errors : tuple of WhiskerError
        Whiskers whose step failed in this tick.

    """

    names: Tuple[str, ...]
    head: BasePose
    protraction: np.ndarray
    base_position: np.ndarray
    base_rotation: np.ndarray
    contacts: np.ndarray
    force: np.ndarray
    moment: np.ndarray
    force_base: np.ndarray
    moment_base: np.ndarray
    tip: np.ndarray
    contact_point: np.ndarray
    contact_s: np.ndarray
    contact_f: np.ndarray
    contact_kind: Tuple[str, ...]
    contact_obstacle: Tuple[str, ...]
    solved: np.ndarray
    events: Tuple[WhiskerEvent, ...] = ()
    errors: Tuple[WhiskerError, ...] = ()

    @property
    def base_quaternion(self) -> np.ndarray:
        """Return the base frames as unit quaternions (k, 4), (qw, qx, qy, qz), qw >= 0."""
        return quats_from_matrices(self.base_rotation)

    @property
    def in_contact(self) -> int:
        """Return the number of whiskers with at least one contact."""
        return int(np.count_nonzero(self.contacts))

    def index(self, name: str) -> int:
        """
        Return a whisker's row.

        Parameters
        ----------
        name : str
            The whisker's name.

        Returns
        -------
        int
            Its index.

        Raises
        ------
        KeyError
            When no whisker has that name.

        """
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no whisker named {name!r}") from None


def quats_from_matrices(R) -> np.ndarray:
    """
    Return the unit quaternions of rotation matrices, vectorized, with qw >= 0.

    Parameters
    ----------
    R : array_like
        Rotation matrices (k, 3, 3).

    Returns
    -------
    numpy.ndarray
        (k, 4), scalar first; the same as
        :func:`~vibrissa_ros.core.rod3d.pose.quat_from_matrix` row by row.

    """
    if _arrays_jit.ENABLED:
        # one compiled loop, the same operations (~2 us for 30 whiskers, ~50 us in numpy);
        # a writable C-ordered copy: one compiled version of the kernel for every caller
        if not _jit.WARM:
            _jit.warm_up()
        return _arrays_jit.quaternions(np.array(R, dtype=float, order="C").reshape(-1, 3, 3))
    return _quats_numpy(R)


def _quats_numpy(R) -> np.ndarray:
    """:func:`quats_from_matrices` in numpy (the reference its test compares with)."""
    R = np.asarray(R, dtype=float).reshape(-1, 3, 3)
    t = R[:, 0, 0] + R[:, 1, 1] + R[:, 2, 2]
    cands = np.stack((1.0 + t, 1.0 + 2 * R[:, 0, 0] - t, 1.0 + 2 * R[:, 1, 1] - t,
                      1.0 + 2 * R[:, 2, 2] - t), axis=1)
    k = np.argmax(cands, axis=1)
    r = 0.5 * np.sqrt(np.maximum(cands[np.arange(len(R)), k], 0.0))
    f = 0.25 / r
    a = (R[:, 2, 1] - R[:, 1, 2]) * f
    b = (R[:, 0, 2] - R[:, 2, 0]) * f
    c = (R[:, 1, 0] - R[:, 0, 1]) * f
    xy = (R[:, 0, 1] + R[:, 1, 0]) * f
    xz = (R[:, 0, 2] + R[:, 2, 0]) * f
    yz = (R[:, 1, 2] + R[:, 2, 1]) * f
    q = np.empty((len(R), 4))
    rows = (np.stack((r, a, b, c), 1), np.stack((a, r, xy, xz), 1),
            np.stack((b, xy, r, yz), 1), np.stack((c, xz, yz, r), 1))
    for j in range(4):
        q[k == j] = rows[j][k == j]
    q[q[:, 0] < 0.0] *= -1.0
    return q


def _scene_in_metres(scene) -> Optional[Scene3D]:
    if scene is None or isinstance(scene, Scene3D):
        return scene
    try:
        obstacles = tuple(scene)
    except TypeError:
        raise ParameterError(f"scene = {scene!r} is not allowed; a scene is a Scene3D (metres), "
                             "a sequence of 3D obstacles, or None (no obstacle)") from None
    return Scene3D(obstacles) if obstacles else None


def _as_head(head) -> BasePose:
    if head is None:
        return BasePose((0.0, 0.0, 0.0))
    if isinstance(head, BasePose):
        return head
    raise InvalidPoseError(f"head pose = {head!r} is not allowed; it is a BasePose (position [m], "
                           "unit quaternion)")


class ArrayTracker:
    """
    Every whisker of an array against one 3D scene, stepped together (see the module).

    Parameters
    ----------
    array : WhiskerArray
        The whiskers (SI units, head frame).
    scene : Scene3D, sequence or None
        The obstacles in the world frame, lengths in metres; None or an empty sequence: no
        obstacle (whisking in the air).
    head : BasePose, optional
        The initial head pose in the world (position [m]); default: the world's origin.
    protraction : float or array_like, optional
        The initial protraction [rad] (one for all, or one per whisker).
    samples : int, optional
        Points of the unloaded whisker in the clearance test, >= 9 and 1 more than a multiple
        of 4 (a first pass takes every fourth).
    max_evaluations : int, optional
        Each whisker tracker's budget of solver evaluations per step.
    adapt_points : bool, optional
        Each whisker in contact solved on as few points per segment as its solution needs
        (:class:`~vibrissa_ros.core.rod3d.tracker.RodTracker`'s ``adapt_points``); False: always
        its shape's full count, for comparisons.
    points_tolerance : float, optional
        Each whisker's discretization error asked for, in its own length
        (:class:`~vibrissa_ros.core.rod3d.model.RodSolver`): the default 1e-11 resolves every
        whisker to about the solver's own convergence; a coarser one (up to 1e-6) solves on
        fewer points, for speed (on the rat's pad at 1e-8 the base wrenches moved by ~3e-11 of
        their largest value, with the same events; ``bench/bench_array.py``).

    Raises
    ------
    InvalidPoseError
        When an unloaded whisker cuts an obstacle at the initial pose (naming the whisker).
    ParameterError
        When an argument is not allowed.

    """

    def __init__(self, array: WhiskerArray, scene, head: Optional[BasePose] = None,
                 protraction=0.0, samples: int = CLEARANCE_SAMPLES,
                 max_evaluations: int = 20000, adapt_points: bool = True,
                 points_tolerance: float = POINTS_TOLERANCE):
        if not isinstance(array, WhiskerArray):
            raise ParameterError(f"array = {array!r} is not allowed; it is a WhiskerArray")
        points_tolerance = _points_tolerance(points_tolerance)
        samples = int(samples)
        if samples < 9 or (samples - 1) % _COARSE:
            raise ParameterError(f"samples = {samples} is not allowed; the clearance test needs "
                                 f">= 9 points, a multiple of {_COARSE} plus 1 (e.g. 65)")
        self.array = array
        self.scene = _scene_in_metres(scene)
        self.names = array.names
        rods = array.rods()
        self._rods = rods
        self._length = np.array([w.length for w in array])
        self._force_scale = np.array([r.bending_stiffness / r.length ** 2 for r in rods])
        self._moment_scale = np.array([r.bending_stiffness / r.length for r in rods])
        self._base_head = np.array([w.base_position for w in array])
        self.whisking = Whisking([r.pose.rotation for r in rods], [w.side for w in array],
                                 [w.whisking for w in array])
        s = np.linspace(0.0, 1.0, samples)
        self._free = np.array([r.shape.free_centerline(s) * r.length for r in rods])
        self._free_tip = self._free[:, -1, :].copy()
        self._reach = 0.5 * self._length / (samples - 1)
        # the scene's obstacles as the kernels take them, where they know every one of them
        self._geometry = None
        if self.scene is not None and self.scene.obstacles and _jit.ENABLED:
            self._geometry = kernel_obstacles(self.scene.obstacles)
        if self.scene is None:  # whisking in the air
            self._scenes = [()] * len(rods)
        else:
            scene_dict = self.scene.to_dict()
            self._scenes = [Scene3D.from_dict(convert_lengths(scene_dict, r.length))
                            for r in rods]
        head = _as_head(head)
        R, p = self._frames(head, protraction)
        self._trackers: List[RodTracker] = []
        for i, rod in enumerate(rods):
            try:
                self._trackers.append(RodTracker(self._scenes[i], self._pose(R, p, i),
                                                 shape=rod.shape,
                                                 max_evaluations=max_evaluations,
                                                 adapt_points=adapt_points,
                                                 points_tolerance=points_tolerance))
            except InvalidPoseError as exc:
                raise InvalidPoseError(f"whisker {rod.name}: {exc}") from None
        self._R, self._p = R, p
        # True: skipped by the clearance test since the tick before the last (its tracker sits
        # at an older pose; the previous tick's pose is certified clear)
        self._stale = np.zeros(len(rods), bool)
        # the unloaded centerlines in the base frames, by point count (centerlines)
        self._free_cache: Dict[int, np.ndarray] = {}
        self._state = self._collect(head, self._protraction(protraction), R, p,
                                    np.ones(len(rods), bool), (), ())

    def __len__(self) -> int:
        """Return the number of whiskers."""
        return len(self._rods)

    @property
    def state(self) -> ArrayStep:
        """Return the last tick's result (the initial state before the first step)."""
        return self._state

    def tracker(self, name: str) -> RodTracker:
        """
        Return the single-whisker tracker of one whisker (in that whisker's own units).

        Parameters
        ----------
        name : str
            The whisker's name.

        Returns
        -------
        RodTracker
            Its tracker; its pose lags the array's while the clearance test skips it.

        """
        return self._trackers[self._state.index(name)]

    # -- kinematics ---------------------------------------------------------------------------
    def _protraction(self, protraction) -> np.ndarray:
        theta = np.asarray(protraction, dtype=float)
        return np.full(len(self._rods), float(theta)) if theta.ndim == 0 else theta.copy()

    def _frames(self, head: BasePose, protraction) -> Tuple[np.ndarray, np.ndarray]:
        R_head = head.rotation
        R = self.whisking.rotations(protraction, head=R_head)
        p = np.asarray(head.position) + self._base_head @ R_head.T
        return R, p

    def _pose(self, R, p, i) -> BasePose:
        # (from the checked head pose and protraction: finite, and a rotation matrix)
        return BasePose._of_floats((p[i] / self._length[i]).tolist(),
                                   quat_from_matrix(R[i]).tolist())

    def _poses(self, R, p, which) -> Dict[int, BasePose]:
        """Return the base poses of the whiskers ``which`` ({index: pose}), as :meth:`_pose`."""
        if not which:
            return {}
        if not _arrays_jit.ENABLED:
            return {i: self._pose(R, p, i) for i in which}
        # one compiled call for the positions and quaternions (the same operations)
        pos, quat = _arrays_jit.poses(R, p, self._length, np.array(which, dtype=np.int64))
        return {i: BasePose._of_floats(x, q)
                for i, x, q in zip(which, pos.tolist(), quat.tolist())}

    def whisker_poses(self, head: BasePose, protraction=0.0) -> Tuple[BasePose, ...]:
        """
        Return every whisker's base pose in its own units, as its tracker receives it.

        Parameters
        ----------
        head : BasePose
            The head pose (position [m]).
        protraction : float or array_like, optional
            [rad], one for all or one per whisker.

        Returns
        -------
        tuple of BasePose
            Position [L of that whisker], world orientation.

        """
        R, p = self._frames(_as_head(head), protraction)
        return tuple(self._pose(R, p, i) for i in range(len(self._rods)))

    # -- the tick -------------------------------------------------------------------------------
    def clearance(self, R: np.ndarray, p: np.ndarray) -> np.ndarray:
        """
        Return each unloaded whisker's sampled distance to the scene at the given base frames.

        Parameters
        ----------
        R : numpy.ndarray
            (k, 3, 3) base frames in the world.
        p : numpy.ndarray
            (k, 3) base points in the world [m].

        Returns
        -------
        numpy.ndarray
            (k,) the smallest signed distance of the samples [m]; the continuous whisker is
            at least this minus L / (2 (samples - 1)) away (inf without obstacles).

        """
        return self._distance(R, p, self._free)

    def _distance(self, R, p, free) -> np.ndarray:
        if self.scene is None:
            return np.full(len(R), np.inf)
        pts = p[:, None, :] + free @ R.transpose(0, 2, 1)
        if self._geometry is not None:
            if not _jit.WARM:  # every kernel at once, not one in the middle of a tick
                _jit.warm_up()
            d = _jit.least_distance(self._geometry[0], self._geometry[1], pts.reshape(-1, 3))
        else:
            d = self.scene.signed_distances(pts.reshape(-1, 3)).min(axis=0)
        return d.reshape(len(R), -1).min(axis=1)

    def _clear(self, R, p) -> np.ndarray:
        """Tell which whiskers are certified free along the tick (coarse samples, then fine)."""
        if self._geometry is not None:
            # one compiled call: the motion and both passes, as below
            if not _jit.WARM:  # every kernel at once, not one in the middle of a tick
                _jit.warm_up()
            return _arrays_jit.clearance(R, p, self._R, self._p, self._length, self._free,
                                         _COARSE, self._reach, self._geometry[0],
                                         self._geometry[1])
        dp = np.linalg.norm(p - self._p, axis=1)
        cos = 0.5 * ((self._R * R).sum(axis=(1, 2)) - 1.0)
        motion = dp + np.arccos(np.clip(cos, -1.0, 1.0)) * self._length
        tol = 1e-12 * self._length
        coarse = self._free[:, ::_COARSE]
        clear = self._distance(R, p, coarse) > _COARSE * self._reach + motion + tol
        rest = np.flatnonzero(~clear)
        if rest.size:
            clear[rest] = (self._distance(R[rest], p[rest], self._free[rest])
                           > self._reach[rest] + motion[rest] + tol[rest])
        return clear

    def step(self, head: BasePose, protraction=0.0) -> ArrayStep:
        """
        Move the head and the whiskers' protraction, and follow every whisker's equilibrium.

        Parameters
        ----------
        head : BasePose
            The new head pose in the world (position [m]).
        protraction : float or array_like, optional
            The new protraction [rad]: one angle for every whisker, or one per whisker.

        Returns
        -------
        ArrayStep
            The tick's result; whiskers whose step failed are listed in ``errors`` and report
            the state they kept.

        Raises
        ------
        InvalidPoseError
            When the head pose is not a BasePose.
        ParameterError
            When the protraction is not finite or has the wrong length (nothing moved).

        """
        head = _as_head(head)
        theta = self._protraction(protraction)
        R, p = self._frames(head, theta)
        clear = self._clear(R, p)
        events: List[WhiskerEvent] = []
        errors: List[WhiskerError] = []
        trackers = self._trackers
        # (those not certified free, and those in contact: each tracker's own state, which a
        # tick that stopped half-way, or a caller of tracker(name), may have changed)
        stepped = [i for i, free in enumerate(clear.tolist())
                   if not free or trackers[i].state.contacts]
        poses = self._poses(R, p, stepped)
        solved = np.zeros(len(self._rods), bool)
        solved[stepped] = True
        for i in stepped:
            tracker = trackers[i]
            try:
                if self._stale[i]:
                    # skipped at the previous tick: unloaded there, and certified clear by the
                    # clearance test, so placed without the tracker's own (exact) check
                    tracker._place(self._pose(self._R, self._p, i))
                    self._stale[i] = False
                result = tracker.step(poses[i])
            except VibrissaError as exc:
                errors.append(WhiskerError(self.names[i], str(exc)))
                continue
            except Exception as exc:  # noqa: BLE001 - one whisker never stops the others
                if interrupted(exc):  # (a Ctrl-C inside a compiled kernel: stop the tick)
                    raise
                # an error of the code itself (the tracker restores its state on any): said
                # as such, and the other whiskers go on
                errors.append(WhiskerError(self.names[i], f"internal error ({type(exc).__name__}"
                                           f": {exc}); the whisker keeps its state"))
                continue
            self._events(i, result, events)
        self._stale[~solved] = True  # (certified free and unloaded: not stepped)
        self._R, self._p = R, p
        self._state = self._collect(head, theta, R, p, solved, tuple(events), tuple(errors))
        return self._state

    def _events(self, i: int, result: RodStepResult, out: List[WhiskerEvent]) -> None:
        scene = self._scenes[i]
        for ev in result.events:
            out.append(WhiskerEvent(
                self.names[i], ev.kind,
                None if ev.obstacle is None else scene.obstacles[ev.obstacle].name,
                None if ev.s is None else float(ev.s * self._length[i]),
                ev.contacts_before, ev.contacts_after, ev.reason))

    def _collect(self, head, theta, R, p, solved, events, errors) -> ArrayStep:
        k = len(self._rods)
        contacts = np.zeros(k, dtype=int)
        kind = [""] * k
        obstacle = [""] * k
        # the stepped whiskers' rows, gathered in floats and scaled to SI in one call
        moved, loaded, mrows, lrows = [], [], [], []
        for i in np.flatnonzero(~self._stale).tolist():
            state = self._trackers[i].state
            if solved[i] and state.pose is not None:  # stepped, or failed and kept its state
                moved.append(i)
                # (the base frame is made from the quaternion in the kernel, as the pose's
                # ``rotation`` is: one numpy matrix per whisker less)
                mrows += state.pose.quaternion
                mrows += state.pose.position
                mrows += state.tip
            if not state.contacts:
                continue
            c = state.contacts[0]
            loaded.append(i)
            lrows += state.force
            lrows += state.moment
            lrows += c.point
            lrows.append(c.s)
            lrows.append(c.f)
            contacts[i] = len(state.contacts)
            kind[i] = c.kind
            obstacle[i] = c.name
        rows = (np.array(moved, dtype=np.int64), np.array(mrows, dtype=float).reshape(-1, 10),
                np.array(loaded, dtype=np.int64), np.array(lrows, dtype=float).reshape(-1, 11))
        scaled = (_arrays_jit.collect if _arrays_jit.ENABLED else _collect_numpy)(
            R, p, self._free_tip, self._length, self._force_scale, self._moment_scale, *rows)
        p, Rb, tip, force, moment, point, arc, normal, force_base, moment_base = scaled
        return ArrayStep(self.names, head, _frozen(theta), _sealed(p), _sealed(Rb),
                         _sealed(contacts), _sealed(force), _sealed(moment),
                         _sealed(force_base), _sealed(moment_base), _sealed(tip), _sealed(point),
                         _sealed(arc), _sealed(normal), tuple(kind), tuple(obstacle),
                         _sealed(solved.copy()), events, errors)

    def centerlines(self, n: int = 21) -> np.ndarray:
        """
        Return every whisker's centerline at the last tick, world frame.

        Parameters
        ----------
        n : int, optional
            Points per whisker, >= 2, equally spaced in arc length.

        Returns
        -------
        numpy.ndarray
            (k, n, 3) [m].

        Raises
        ------
        ParameterError
            When ``n`` < 2.

        """
        n = int(n)
        if n < 2:
            raise ParameterError(f"centerline points n = {n}: need at least 2")
        out = np.empty((len(self._rods), n, 3))
        free = self._free_lines(n)
        for i, tracker in enumerate(self._trackers):
            st = tracker.state
            if st.contacts and not self._stale[i]:
                out[i] = st.centerline(n) * self._length[i]
            else:
                out[i] = self._p[i] + free[i] @ self._R[i].T
        return out

    def _free_lines(self, n: int) -> np.ndarray:
        """Return every unloaded whisker's centerline in its base frame (k, n, 3) [m], kept."""
        lines = self._free_cache.get(n)
        if lines is None:
            s = np.linspace(0.0, 1.0, n)
            lines = np.array([rod.shape.free_centerline(s) * length
                              for rod, length in zip(self._rods, self._length)])
            self._free_cache = {n: lines}  # (the display's one count)
        return lines

    def reset(self) -> ArrayStep:
        """
        Re-place every whisker unloaded at the last tick's pose, forgetting its history.

        Returns
        -------
        ArrayStep
            The unloaded array (whiskers that cannot be placed there keep their state and are
            listed in ``errors``).

        """
        errors: List[WhiskerError] = []
        events: List[WhiskerEvent] = []
        for i, tracker in enumerate(self._trackers):
            try:
                result = tracker.reset(self._pose(self._R, self._p, i))
            except VibrissaError as exc:
                errors.append(WhiskerError(self.names[i], str(exc)))
                continue
            self._stale[i] = False
            self._events(i, result, events)
        head = self._state.head
        self._state = self._collect(head, np.asarray(self._state.protraction), self._R,
                                    self._p.copy(), np.ones(len(self._rods), bool),
                                    tuple(events), tuple(errors))
        return self._state


def describe(step: ArrayStep) -> str:
    """
    Return one line about a tick: whiskers in contact, the largest force, errors.

    Parameters
    ----------
    step : ArrayStep
        The tick.

    Returns
    -------
    str
        E.g. ``3 of 30 whiskers in contact (RC1 2 contacts ...); largest force 1.2e-4 N (RC1)``.

    """
    norms = np.linalg.norm(step.force, axis=1)
    parts = [f"{step.in_contact} of {len(step.names)} whiskers in contact"]
    if step.in_contact:
        j = int(np.argmax(norms))
        parts.append(f"largest force {norms[j]:.4g} N ({step.names[j]})")
    if step.errors:
        parts.append(f"{len(step.errors)} error(s): "
                     + "; ".join(f"{e.whisker}: {e.message}" for e in step.errors[:3]))
    return "; ".join(parts)


def _collect_numpy(R, p, free_tip, length, force_scale, moment_scale, moved, mrows, loaded,
                   lrows):
    """:func:`._jit.collect` in numpy (the reference its test compares with)."""
    k = len(R)
    tip = p + (R @ free_tip[:, :, None])[:, :, 0]
    p = p.copy()
    Rb = R.copy()
    if moved.size:
        L = length[moved, None]
        Rb[moved] = quat_matrix(mrows[:, :4])
        p[moved] = mrows[:, 4:7] * L
        tip[moved] = mrows[:, 7:10] * L
    force = np.zeros((k, 3))
    moment = np.zeros((k, 3))
    point = np.zeros((k, 3))
    arc = np.zeros(k)
    normal = np.zeros(k)
    if loaded.size:
        scale = force_scale[loaded]
        force[loaded] = lrows[:, 0:3] * scale[:, None]
        moment[loaded] = lrows[:, 3:6] * moment_scale[loaded, None]
        point[loaded] = lrows[:, 6:9] * length[loaded, None]
        arc[loaded] = lrows[:, 9] * length[loaded]
        normal[loaded] = lrows[:, 10] * scale
    Rt = Rb.transpose(0, 2, 1)
    force_base = (Rt @ force[:, :, None])[:, :, 0]
    moment_base = (Rt @ moment[:, :, None])[:, :, 0]
    return p, Rb, tip, force, moment, point, arc, normal, force_base, moment_base
