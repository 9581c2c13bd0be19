"""
A 3D scene's scan, as ``vibrissa scan --scene S.yaml --poses P.csv`` computes it (3D poses).

The 3D whisker (:mod:`vibrissa_ros.core.rod3d`) is placed unloaded at the first base pose and
follows the poses in order, each a quasistatic step along the straight path from the previous
one (position linear, orientation along the shorter great arc). As the planar scene scan
(:mod:`~vibrissa_ros.scan.scene_scan`): the scan is checked before it runs
(:func:`plan_scene_scan3d`: the first pose must leave the unloaded whisker clear of every
obstacle), a step that cannot be followed re-places the unloaded whisker where it is clear
there (an event ``reset``), and any other failure stops the scan with an error naming the pose.

Everything is dimensionless and in the world frame: lengths in whisker lengths L, forces in
EI_b/L^2, moments in EI_b/L. The 3D whisker is frictionless.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional, Sequence, Tuple

from ..core.errors import InvalidPoseError, ParameterError, VibrissaError
from ..core.rod3d import BasePose, RodShape, RodTracker, Scene3D
from ..core.rod3d.model import POINTS_TOLERANCE, _points_tolerance


def _pose_number(index: int) -> str:
    return f"pose {index}"


def _located(exc: VibrissaError, where: str) -> VibrissaError:
    """Return ``exc`` with ``where`` in front of its message (same class: same exit status)."""
    try:
        located = type(exc)(f"{where}: {exc}")
    except TypeError:  # an error class with its own constructor: keep it as it is
        return exc
    located.__cause__ = exc.__cause__
    return located


@dataclass(frozen=True)
class Scan3DResult:
    """
    The outcome of a 3D scan.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    states : tuple of RodState
        One equilibrium per pose, in order.
    events : tuple of RodEvent
        The events crossed, in order.
    event_steps : tuple of int
        For each event, the index of the pose whose step crossed it.

    """

    states: Tuple
    events: Tuple
    event_steps: Tuple[int, ...]


@dataclass(frozen=True)
class SceneScan3D:
    """
    A 3D scene scan, checked and ready to run (:func:`plan_scene_scan3d`).

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    scene : Scene3D
        The obstacles (whisker lengths).
    poses : tuple of BasePose
        The base poses, in order.
    shape : RodShape
        The whisker's taper, intrinsic curvature and Poisson ratio.
    where : callable
        ``where(i)`` names pose ``i`` in error messages (e.g. its file and line).
    points_tolerance : float, optional
        The discretization error asked of the whisker, in its length (the
        :class:`RodTracker`'s; default 1e-11, resolved to the solver's convergence).

    """

    scene: Scene3D
    poses: Tuple[BasePose, ...]
    shape: RodShape
    where: Callable[[int], str] = _pose_number
    points_tolerance: float = POINTS_TOLERANCE

    def tracker(self) -> RodTracker:
        """
        Return a tracker with the unloaded whisker at the first pose.

        Returns
        -------
        RodTracker
            The tracker (``recover`` on: a step that cannot be followed re-places the whisker
            where it is clear).

        Raises
        ------
        InvalidPoseError
            When the unloaded whisker cuts an obstacle at the first pose (the message names it).

        """
        try:
            return RodTracker(self.scene, self.poses[0], shape=self.shape, recover=True,
                              points_tolerance=self.points_tolerance)
        except VibrissaError as exc:
            raise _located(exc, self.where(0)) from None

    def run(self) -> Scan3DResult:
        """
        Compute the scan; raise a :class:`VibrissaError` naming the pose where it cannot go on.

        Returns
        -------
        Scan3DResult
            One state per pose, the events and the pose of each event's step.

        Raises
        ------
        VibrissaError
            Of the tracker's class (InvalidPoseError, ModelAssumptionError, ConvergenceError),
            its message starting with :attr:`where` of the pose the step went to.

        """
        tracker = self.tracker()
        states, events, steps = [tracker.state], [], []
        for i, pose in enumerate(self.poses[1:], start=1):
            try:
                result = tracker.step(pose)
            except VibrissaError as exc:
                raise _located(exc, self.where(i)) from None
            states.append(result.state)
            events.extend(result.events)
            steps.extend([i] * len(result.events))
        return Scan3DResult(tuple(states), tuple(events), tuple(steps))


def plan_scene_scan3d(scene: Scene3D, poses: Sequence[BasePose],
                      shape: Optional[RodShape] = None,
                      where: Optional[Callable[[int], str]] = None,
                      points_tolerance: float = POINTS_TOLERANCE) -> SceneScan3D:
    """
    Check a 3D scene scan before it runs: at least one pose, the whisker clear at the first.

    Parameters
    ----------
    scene : Scene3D
        The obstacles (whisker lengths); a planar scene's obstacles are prisms along z.
    poses : sequence of BasePose
        The base poses, in order (dimensionless, world frame).
    shape : RodShape, optional
        The whisker; None: the paper's (uniform, straight, Poisson ratio 0.38).
    where : callable, optional
        ``where(i)`` names pose ``i`` in error messages; default ``pose i``.
    points_tolerance : float, optional
        The discretization error asked of the whisker, in its length, 1e-12 to 1e-6 (default
        1e-11: resolved to the solver's convergence; coarser: fewer points, faster).

    Returns
    -------
    SceneScan3D
        The checked scan, ready to :meth:`~SceneScan3D.run`.

    Raises
    ------
    ParameterError
        When there is no pose, or ``points_tolerance`` is out of its range.
    InvalidPoseError
        When a pose is not a :class:`BasePose`, or the unloaded whisker cuts an obstacle at the
        first pose (the message starts with ``where(0)``).

    Examples
    --------
    >>> import math
    >>> from vibrissa_ros.core.rod3d import BasePose, Scene3D, Sphere
    >>> from vibrissa_ros.scan.scene_scan3d import plan_scene_scan3d
    >>> scene = Scene3D((Sphere((0.0, 0.6, 0.04), 0.1),))
    >>> turn = (math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4))  # whisker along +y
    >>> poses = [BasePose((x, 0.0, 0.0), turn) for x in (0.2, 0.0, -0.2)]
    >>> result = plan_scene_scan3d(scene, poses).run()
    >>> [e.kind for e in result.events]
    ['touch', 'release']
    >>> round(result.states[1].force[2], 4)  # the sphere pushes the whisker down (-z)
    -0.8595

    """
    poses = tuple(poses)
    if not poses:
        raise ParameterError("a 3D scan needs at least one base pose")
    for i, pose in enumerate(poses):
        if not isinstance(pose, BasePose):
            raise InvalidPoseError(f"{(where or _pose_number)(i)}: {pose!r} is not a BasePose")
    plan = SceneScan3D(scene, poses, RodShape() if shape is None else shape,
                       where or _pose_number, _points_tolerance(points_tolerance))
    plan.tracker()
    return plan
