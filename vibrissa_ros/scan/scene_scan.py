"""
A scene's scan, as ``vibrissa scan --scene`` and a study's scene task both compute it.

One code path for both, so that a study's rows equal the command's value for value: a scene of one
convex profile or peg without friction is the single-contact problem, solved by the single-contact
tracker exactly as ``--profile`` would (its states and events seen through the scene contract);
any other scene runs the multi-contact :func:`~vibrissa_ros.core.scan.run_scene`.
``friction`` overrides the scene's global Coulomb coefficient (``vibrissa scan --friction``); an
obstacle with its own coefficient keeps it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence

from ..core.errors import VibrissaError
from ..core.general.model import GeneralWhiskerModel, WhiskerShape
from ..core.exact.models import make_model
from ..core.profiles import Peg
from ..core.scan import ScanResult, run_poses, run_scan, run_scene
from ..core.scenes.scene import Scene

SOLVERS = ("auto", "exact", "numeric")


def elastica_model(shape: WhiskerShape, solver: str, profile):
    """
    Return the single-contact elastica model that ``--solver`` picks for this whisker and profile.

    The exact closed forms for the paper's uniform straight whisker against a convex profile
    (``auto`` and ``exact``), the general collocation solver otherwise (``numeric``, or ``auto``
    for a peg or a tapered or curved whisker).
    """
    exact_ok = shape.is_paper and not isinstance(profile, Peg)
    if solver == "exact" and not exact_ok:
        why = "a peg" if isinstance(profile, Peg) else "a tapered or curved whisker"
        raise VibrissaError(
            "--solver exact: the closed forms cover a uniform straight whisker (taper 1, "
            f"curvature 0) against a convex profile, not {why}; use --solver numeric or auto"
        )
    if solver == "exact" or (solver == "auto" and exact_ok):
        return make_model("elastica")
    return GeneralWhiskerModel(shape)


def scene_friction(scene: Scene, friction: Optional[float] = None) -> List[float]:
    """Return each obstacle's Coulomb coefficient: its own, else ``friction`` or the scene's."""
    default = scene.friction if friction is None else float(friction)
    return [default if ob.friction is None else ob.friction for ob in scene]


@dataclass(frozen=True)
class SceneScan:
    """
    A scene scan, checked and ready to run (:func:`plan_scene_scan`).

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    scene : Scene
        The scene (whisker lengths).
    path : tuple
        The paper's x0 values of a slide (floats) or the foot poses (:class:`FootPose`).
    by_pose : bool
        ``path`` holds foot poses, not x0 values.
    shape : WhiskerShape
        The whisker's taper and intrinsic curvature.
    friction : tuple of float
        Each obstacle's Coulomb coefficient.
    single : ConvexProfile or None, optional
        The profile of a frictionless one-profile scene (else None).
    model : object, optional
        The single-contact model of a frictionless one-profile scene (else None).

    """

    scene: Scene
    path: tuple
    by_pose: bool
    shape: WhiskerShape
    friction: tuple
    single: object = None
    model: object = None

    def run(self) -> ScanResult:
        """
        Compute the scan; raise a :class:`VibrissaError` where the mechanics cannot go on.

        The states and events follow the scene contract (``contacts``; the scene event kinds);
        ``event_steps`` as :class:`~vibrissa_ros.core.scan.ScanResult`'s.
        """
        if self.single is not None:
            result = (run_poses(self.single, self.path, model=self.model) if self.by_pose
                      else run_scan(self.single, list(self.path), model=self.model))
            return ScanResult(tuple(as_scene_state(s) for s in result.states),
                              tuple(as_scene_event(e) for e in result.events),
                              result.event_steps)
        return run_scene(list(self.scene), list(self.path), shape=self.shape,
                         friction=list(self.friction))


def plan_scene_scan(scene: Scene, grid=None, poses: Optional[Sequence] = None,
                    shape: Optional[WhiskerShape] = None, solver: str = "auto",
                    friction: Optional[float] = None) -> SceneScan:
    """
    Check a scene scan before it runs: the solver, the friction override, the first foot.

    Parameters
    ----------
    scene : Scene
        The scene (whisker lengths).
    grid : iterable of float, optional
        The x0 values of a slide; used when ``poses`` is None.
    poses : sequence of FootPose, optional
        The foot poses (a whisk, ``--poses``).
    shape : WhiskerShape, optional
        The whisker's taper and intrinsic curvature; None: the paper's whisker.
    solver : {'auto', 'exact', 'numeric'}, optional
        ``--solver``: the closed forms (``exact``, the paper's uniform straight whisker against
        one convex profile without friction), the collocation solvers (``numeric``) or whichever
        applies (``auto``).
    friction : float, optional
        A Coulomb coefficient for every obstacle without its own, instead of the scene's.

    Returns
    -------
    SceneScan
        The checked scan, ready to :meth:`~SceneScan.run`.

    Raises
    ------
    VibrissaError
        Saying what is wrong: a solver that does not cover the scene, or a first foot inside or
        on an obstacle (:class:`InvalidPoseError`).

    """
    shape = WhiskerShape() if shape is None else shape
    coefficients = scene_friction(scene, friction)
    single = scene.single_profile() if not any(coefficients) else None
    model = None
    if single is not None:
        # one convex profile or peg without friction: the single-contact problem itself, solved
        # exactly as --profile would (identical numbers)
        model = elastica_model(shape, solver, single)
    elif solver == "exact":
        raise VibrissaError(
            "--solver exact: the closed forms cover one convex profile without friction; this "
            "scene needs --solver numeric or auto")
    by_pose = poses is not None
    path = tuple(poses) if by_pose else tuple(float(x) for x in grid)
    first = path[0]
    scene.check_foot(*((first.x, first.y) if by_pose else (first, 0.0)))
    return SceneScan(scene, path, by_pose, shape, tuple(coefficients), single, model)


def as_scene_state(state):
    """Return a single-contact state as a scene state (its one contact, frictionless)."""
    from ..core.scenes.tracker import SceneContact

    contacts = ()
    if int(state.phase) != 0:
        kind = "tip" if int(state.phase) == 2 else "side"
        contacts = (SceneContact(0, kind, float(state.s1), float(state.contact[0]),
                                 float(state.contact[1]), float(state.fx), float(state.fy),
                                 float(state.f), 0.0, "slip"),)
    return _SingleSceneState(state, contacts)


class _SingleSceneState:
    """A single-contact WhiskerState seen through the scene contract (adds ``contacts``)."""

    def __init__(self, state, contacts):
        self._state = state
        self.contacts = contacts

    def __getattr__(self, name):
        return getattr(self._state, name)

    def __getstate__(self):
        return (self._state, self.contacts)

    def __setstate__(self, data):
        self._state, self.contacts = data


def as_scene_event(event):
    """Return a single-contact event as a scene event (touch, tip, tangential, ..., reset)."""
    from ..core.scenes.tracker import SceneEvent

    kind = {"touch": "touch", "release": "release", "snap": "snap", "reset": "reset"}.get(
        event.kind, "phase")
    if event.kind == "phase":
        kind = "tip" if int(event.to_phase) == 2 else "tangential"
    contact = "tip" if int(event.from_phase if event.kind != "touch" else event.to_phase) == 2 \
        else "side"
    if kind == "reset":
        return SceneEvent(kind, event.pose, reason=event.reason)
    return SceneEvent(kind, event.pose, 0, contact, None)
