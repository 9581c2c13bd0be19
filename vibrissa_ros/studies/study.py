"""
A study: a grid and/or a seeded random sample of scans read from a YAML file (one task = one scan).

A study file names, block by block, the axes of the study. Every number may be a scalar, a list (a
grid axis: the study takes every value) or a random draw ``{uniform: [lo, hi]}`` /
``{loguniform: [lo, hi]}`` where a block allows it. The tasks are the product of the blocks::

    seed: 7                          # random draws and sensor noise (default 0)
    whisker:   {model: [elastica, rigid], spring_stiffness: 3}
               # a real whisker: {taper: [1, 0.2, 0.0667], curvature_k0: [0, 0.5]}
    obstacles:                       # a list of obstacle families
      - profile: parabola
        params: {p0: [0.2, 0.35], k: [0.5, 1, 2]}
      - profile: ellipse
        samples: 10                  # 10 random ellipses
        params: {p0: {uniform: [0.15, 0.5]}, a: {uniform: [0.3, 1.0]}, b: {uniform: [1.0, 2.0]}}
    placement: {x: 0, y: 0, rotation_deg: [-10, 0, 10], samples: 1}
    motion:                          # a block or a list of blocks
      - {from: -2, to: 2, step: 0.05, back: [false, true]}              # the foot slides along x
      - whisk: {x: 0, y: 0, from_deg: 60, to_deg: 120, step_deg: 1, back: true}
    noise:     {force_stddev: 0.001, torque_stddev: 0.001}          # optional

A sliding motion moves the foot along the x-axis from ``from`` to ``to`` by ``step`` [L], heading
+y (the paper's scan, ``vibrissa scan --from --to --step``). A whisking motion keeps the foot at
(``x``, ``y``) [L] and turns its heading from ``from_deg`` to ``to_deg`` by ``step_deg`` [deg,
counter-clockwise from +x: 90 is the paper's set-up], and back with ``back`` (``vibrissa scan
--whisk X,Y``). A peg, ``{profile: peg, params: {x: [-0.3, 0.3], y: 0.6, r: 0.05}}`` (a disk
centred at (x, y), r = 0 a point), is placed by its own parameters: a study with pegs has no
placement (other than 0).

A scene file (doc/guide/scenes.md: several obstacles, friction) is an obstacle too::

    obstacles:
      - scene: scene_two_pegs.yaml    # or a list of files (a grid axis); relative to the study
        friction: [0, 0.1, 0.3]       # optional: the scene's global Coulomb coefficient

``friction`` overrides the scene's global coefficient (``vibrissa scan --friction``); an obstacle
with its own coefficient in the file keeps it. A scene task runs what ``vibrissa scan --scene``
runs (:mod:`vibrissa_ros.scan.scene_scan`); the whisker block's taper and curvature apply. A scene
places its own obstacles (no placement), and the rigid model (one contact) is refused with scenes.
The scene files are read when the study is read: their text travels with the tasks, so workers
need no shared file system, and it is part of the study's digest (a changed scene file is another
study).

Random draws are seeded: an obstacle's random parameters are drawn once per obstacle (so the same
object is swept under every whisker, placement and motion), a placement's once per obstacle and
placement sample. Each task's noise has its own seed, derived from the study's seed and the task's
index, and stored with the task.

Everything is validated before anything runs: a bad study raises :class:`StudyError` with one line
saying where and what is allowed. Errors the mechanics raise while a task runs (a model assumption
left, an unreachable pose) are not study errors: they are recorded as that task's failure.
"""

from __future__ import annotations

import functools
import hashlib
import itertools
import math
import os
import shlex
from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..core.errors import ParameterError, VibrissaError
from ..core.general.model import GeneralWhiskerModel, WhiskerShape
from ..core.exact.models import MODELS, make_model
from ..core.profiles import PROFILE_PARAMETERS as _ALL_PROFILE_PARAMETERS
from ..core.profiles import ConvexProfile, make_profile
from ..core.scan import ScanResult, run_poses, run_scan, scan_grid, whisk_poses
from ..core.state import FootPose

#: obstacles a study can scan: every profile of ``vibrissa scan`` (a peg is computed by the general
#: whisker model, as ``vibrissa scan --solver auto`` picks it)
PROFILE_PARAMETERS = dict(_ALL_PROFILE_PARAMETERS)

#: the keys each block allows (a new axis of the study is a new key here, with the code that
#: computes it)
TOP_KEYS = ("description", "seed", "whisker", "obstacles", "placement", "motion", "noise")
WHISKER_KEYS = ("model", "spring_stiffness", "taper", "curvature_k0", "curvature_k1")
OBSTACLE_KEYS = ("profile", "params", "samples")
SCENE_KEYS = ("scene", "friction")
PLACEMENT_KEYS = ("x", "y", "rotation_deg", "samples")
MOTION_KEYS = ("from", "to", "step", "back", "whisk")
WHISK_KEYS = ("x", "y", "from_deg", "to_deg", "step_deg", "back")
NOISE_KEYS = (
    "force_stddev",
    "torque_stddev",
    "force_bias_x",
    "force_bias_y",
    "torque_bias",
    "force_step",
    "torque_step",
)
RANDOM_KINDS = ("uniform", "loguniform")
#: at most this many tasks in one study (a study file that would expand further is refused)
MAX_TASKS = 10_000_000


class StudyError(VibrissaError, ValueError):
    """The study file is not a valid study (unknown key, empty range, wrong type, ...)."""


def param_column(profile: str, key: str) -> str:
    """
    Return the dataset column of a profile parameter.

    Its own name (p0, k, R, ...), except a peg's centre and radius: ``peg_x``, ``peg_y``,
    ``peg_r`` (the columns ``x``, ``y`` are the placement's).
    """
    return f"peg_{key}" if profile == "peg" else key


@dataclass(frozen=True)
class SceneRef:
    """
    A scene file of a study task: as given, where it was read, its text and the friction.

    ``file`` is the path as the study gives it; ``path`` the file read (relative to the directory
    ``vibrissa batch`` ran in, or absolute); ``friction`` the scene's global Coulomb coefficient
    for this task (the study's override, else the file's).
    """

    file: str
    path: str
    text: str = field(repr=False)
    friction: Optional[float] = None

    def load(self):
        """Return the :class:`~vibrissa_ros.core.scenes.scene.Scene` (parsed once per process)."""
        return _scene_from_text(self.text, self.path)


@functools.lru_cache(maxsize=32)
def _scene_from_text(text: str, label: str):
    import yaml

    from ..core.scenes.scene import Scene

    try:
        return Scene.from_dict(yaml.safe_load(text))
    except ParameterError as exc:
        raise ParameterError(f"{label}: {exc}") from None


@dataclass(frozen=True)
class Whisk:
    """
    A whisking motion: the foot fixed at (x, y) [L], the heading sweeping [deg].

    Headings are counter-clockwise from +x (90: the paper's set-up, the whisker along +y), from
    ``from_deg`` to ``to_deg`` inclusive by ``step_deg`` (the task's ``back`` adds the way back).
    """

    x: float
    y: float
    from_deg: float
    to_deg: float
    step_deg: float


@dataclass(frozen=True)
class Noise:
    """
    Sensor-noise levels of a task, in the scan's dimensionless units.

    Force in EI/L^2, moment in EI/L.
    """

    force_stddev: float = 0.0
    torque_stddev: float = 0.0
    force_bias_x: float = 0.0
    force_bias_y: float = 0.0
    torque_bias: float = 0.0
    force_step: float = 0.0
    torque_step: float = 0.0


@dataclass(frozen=True)
class Task:
    """
    One scan of a study: everything needed to compute it, and nothing else.

    ``params`` are the profile's parameters as (name, value) pairs in contract order;
    ``rotation_deg`` turns the obstacle about its apex (counter-clockwise), then (``x``, ``y``)
    moves it. The motion is a slide of the foot along x (``sweep_from``, ``sweep_to``,
    ``sweep_step``) or, when ``whisk`` is given, a whisk (the sweep fields are then None); ``back``
    adds the way back to either. Lengths in whisker lengths L.
    """

    index: int
    model: str
    spring_stiffness: Optional[float]
    profile: str
    params: Tuple[Tuple[str, float], ...]
    x: float
    y: float
    rotation_deg: float
    sweep_from: Optional[float]
    sweep_to: Optional[float]
    sweep_step: Optional[float]
    back: bool
    noise: Optional[Noise] = None
    noise_seed: Optional[int] = None
    #: the whisker's shape (the general whisker, core.general): taper rho = tip / base radius,
    #: intrinsic curvature k0 + k1 s [1/L]; (1, 0, 0) is the paper's uniform straight whisker
    taper: float = 1.0
    curvature_k0: float = 0.0
    curvature_k1: float = 0.0
    #: a whisking motion (None: the foot slides along x)
    whisk: Optional[Whisk] = None
    #: a scene file (profile "scene", no params): ``vibrissa scan --scene``
    scene: Optional[SceneRef] = None

    @property
    def motion(self) -> str:
        """Return ``"sweep"`` (the foot slides along x) or ``"whisk"`` (the heading sweeps)."""
        return "sweep" if self.whisk is None else "whisk"

    def param_columns(self) -> Dict[str, float]:
        """Return the profile parameters by their dataset columns (:func:`param_column`)."""
        return {param_column(self.profile, k): v for k, v in self.params}

    def obstacle(self) -> ConvexProfile:
        return place_obstacle(
            make_profile(self.profile, dict(self.params)), self.x, self.y, self.rotation_deg
        )

    def grid(self) -> np.ndarray:
        """
        Return the scan's path grid, one value per pose.

        The foot positions x0 [L] of a slide; the headings [deg] of a whisk.
        """
        if self.whisk is not None:
            w = self.whisk
            return scan_grid(w.from_deg, w.to_deg, w.step_deg, self.back)
        return scan_grid(self.sweep_from, self.sweep_to, self.sweep_step, self.back)

    def foot_poses(self) -> Optional[Tuple[FootPose, ...]]:
        """Return the foot poses of a whisk (``vibrissa scan --whisk``'s); None for a slide."""
        if self.whisk is None:
            return None
        w = self.whisk
        return whisk_poses(w.x, w.y, w.from_deg, w.to_deg, w.step_deg, self.back)

    def run(self) -> ScanResult:
        """Compute the task's scan with the functions ``vibrissa scan`` calls."""
        if self.scene is not None:
            from ..scan.scene_scan import plan_scene_scan

            shape = WhiskerShape(self.taper, self.curvature_k0, self.curvature_k1)
            whisk = self.whisk is not None
            grid, poses = (None, self.foot_poses()) if whisk else (self.grid(), None)
            return plan_scene_scan(
                self.scene.load(), grid, poses, shape, "auto", self.scene.friction
            ).run()
        if self.whisk is not None:
            return run_poses(self.obstacle(), self.foot_poses(), model=self.whisker_model())
        return run_scan(self.obstacle(), self.grid(), model=self.whisker_model())

    def whisker_model(self):
        """
        Return the model ``vibrissa scan --solver auto`` picks for this task.

        The exact elastica for the paper's whisker against a convex profile, the general solver
        for a tapered or curved one or a peg, the rigid model with its stiffness.
        """
        shape = WhiskerShape(self.taper, self.curvature_k0, self.curvature_k1)
        if self.model == "elastica" and (not shape.is_paper or self.profile == "peg"):
            return GeneralWhiskerModel(shape)
        if self.model == "rigid":
            return make_model(
                "rigid", stiffness=1.0 if self.spring_stiffness is None else self.spring_stiffness
            )
        return make_model(self.model)

    def scan_command(self) -> str:
        """
        Return the ``vibrissa scan`` command that computes this task's poses and events.

        The command computes them without noise.
        """
        if self.scene is not None:
            words = ["vibrissa", "scan", "--scene", shlex.quote(self.scene.path)]
            words += [f"--friction={self.scene.friction!r}"]
        else:
            words = ["vibrissa", "scan", "--profile", self.profile]
        for key, value in self.params:
            words += ["--param", f"{key}={value!r}"]
        words += ["--model", self.model]
        if self.spring_stiffness is not None:
            words += ["--spring-stiffness", repr(self.spring_stiffness)]
        if self.taper != 1.0:
            words += [f"--taper={self.taper!r}"]
        if (self.curvature_k0, self.curvature_k1) != (0.0, 0.0):
            words += [f"--curvature={self.curvature_k0!r},{self.curvature_k1!r}"]
        if (self.x, self.y, self.rotation_deg) != (0.0, 0.0, 0.0):
            words += [f"--place={self.x!r},{self.y!r},{self.rotation_deg!r}"]
        if self.whisk is not None:
            w = self.whisk
            words += [
                f"--whisk={w.x!r},{w.y!r}",
                f"--from={w.from_deg!r}",
                f"--to={w.to_deg!r}",
                f"--step={w.step_deg!r}",
            ]
        else:
            words += [
                f"--from={self.sweep_from!r}",
                f"--to={self.sweep_to!r}",
                f"--step={self.sweep_step!r}",
            ]
        if self.back:
            words.append("--back")
        return " ".join(words + ["--csv", f"task-{self.index}.csv"])


def place_obstacle(
    profile: ConvexProfile, x: float = 0.0, y: float = 0.0, rotation_deg: float = 0.0
) -> ConvexProfile:
    """
    Place the obstacle: turn it, then move it.

    The obstacle is turned by ``rotation_deg`` [deg] counter-clockwise about its apex (0, p0),
    then moved by (``x``, ``y``) [L]: its apex ends at (x, p0 + y).
    """
    if (x, y, rotation_deg) == (0.0, 0.0, 0.0):
        return profile
    if "p0" not in profile.params:
        raise ParameterError(
            f"a placement applies to the convex profiles; a {profile.name} is placed by its own "
            f"parameters ({', '.join(profile.params)})"
        )
    theta = math.radians(rotation_deg)
    p0 = profile.params["p0"]
    # PlacedProfile rotates about the origin: shift so that the apex (0, p0) lands on (x, p0 + y)
    return profile.placed(x + p0 * math.sin(theta), y + p0 - p0 * math.cos(theta), theta)


@dataclass(frozen=True)
class Study:
    """
    A validated study: its source text, its digest and its tasks in order.

    Made by :func:`parse_study`; the parameters are the dataclass's fields, kept as attributes of
    the same names.

    Parameters
    ----------
    text : str
        The study's YAML source text.
    digest : str
        The SHA-256 hex digest of the text and of the scene files' texts (a changed scene file is
        another study).
    seed : int
        The study's seed (>= 0) of the random draws and the sensor noise.
    tasks : tuple of Task
        The tasks (one scan each), in order.
    param_names : tuple of str
        The profile parameter columns the study uses (:func:`param_column`), in a stable order.
    has_noise : bool
        Whether a task adds sensor noise.
    has_whisking : bool, optional
        Whether a task whisks (the dataset then has pose and whisking columns).
    has_scenes : bool, optional
        Whether a task scans a scene file (the dataset then has scene, friction, contacts
        columns).

    """

    text: str
    digest: str
    seed: int
    tasks: Tuple[Task, ...]
    #: the profile parameter columns the study uses (:func:`param_column`), in a stable order
    param_names: Tuple[str, ...]
    has_noise: bool
    #: whether a task whisks (the dataset then has pose and whisking columns)
    has_whisking: bool = False
    #: whether a task scans a scene file (the dataset then has scene, friction, contacts columns)
    has_scenes: bool = False

    @property
    def poses(self) -> int:
        """How many poses the study computes (every task's grid length, summed)."""
        return sum(len(t.grid()) for t in self.tasks)


# -- reading --------------------------------------------------------------------------------------


def load_study(path: str) -> Study:
    """
    Read and validate a study file; raise :class:`StudyError` (one line) if it is invalid.

    Parameters
    ----------
    path : str
        The study file (YAML, UTF-8). Scene files are found relative to its directory.

    Returns
    -------
    Study
        The validated study.

    Raises
    ------
    StudyError
        In one line: the file is missing or unreadable, or the study is invalid.

    """
    try:
        with open(path, encoding="utf-8") as stream:
            text = stream.read()
    except FileNotFoundError:
        raise StudyError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise StudyError(f"{path}: cannot be read ({exc})") from None
    return parse_study(text, os.path.dirname(path))


def parse_study(text: str, base_dir: Optional[str] = None, read_scenes: bool = True) -> Study:
    """
    Validate a study given as YAML text and expand it into its tasks.

    A study of ``kind: array`` is an array study
    (:func:`~vibrissa_ros.studies.array_study.parse_array_study`), returned as an
    :class:`~vibrissa_ros.studies.array_study.ArrayStudy`.

    Parameters
    ----------
    text : str
        The study's YAML text.
    base_dir : str, optional
        Where scene files are found relative to (default: the working directory).
    read_scenes : bool, optional
        With False the scene files (and an array study's array file) are not read (the tasks
        then carry no scene text): enough for the dataset's columns, not to run the tasks.

    Returns
    -------
    Study or ArrayStudy
        The validated study, expanded into its tasks.

    Raises
    ------
    StudyError
        In one line, what is invalid.

    """
    import yaml

    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        problem = getattr(exc, "problem", None) or "not valid YAML"
        raise StudyError(f"not a YAML study file{where}: {problem}") from None
    if not isinstance(doc, dict):
        raise StudyError("a study is a YAML mapping with the keys " + ", ".join(TOP_KEYS))
    if "kind" in doc:
        if doc["kind"] != "array":
            raise StudyError(f"kind = {_show(doc['kind'])} is not allowed; kind is array (a "
                             "whisker array's study), or left out (scans of one whisker)")
        from .array_study import parse_array_study

        return parse_array_study(doc, text, base_dir, read_scenes)
    _keys("study", doc, TOP_KEYS, required=("obstacles", "motion"))
    seed = _integer("seed", doc.get("seed", 0), minimum=0)
    if "description" in doc and not isinstance(doc["description"], str):
        raise StudyError("description must be a string")
    whiskers = _whiskers(doc.get("whisker", {}))
    obstacles = _obstacles(doc["obstacles"], seed, base_dir, read_scenes)
    scene_at = next((i for i, ob in enumerate(obstacles) if ob[2] is not None), None)
    if scene_at is not None and any(w[0] == "rigid" for w in whiskers):
        raise StudyError(
            "whisker.model 'rigid' cannot scan a scene file (obstacles with a 'scene' key): the "
            "rigid model has one contact; scan scenes with the elastica"
        )
    placement = _block("placement", doc.get("placement", {}), PLACEMENT_KEYS)
    motions = _motions(doc["motion"])
    noises = _noises(doc.get("noise"))

    tasks: List[Task] = []
    place_axes = {
        k: _axis(f"placement.{k}", placement.get(k, 0.0)) for k in ("x", "y", "rotation_deg")
    }
    place_samples = _integer("placement.samples", placement.get("samples", 1), minimum=1)
    place_random = any(isinstance(v, _Random) for axis in place_axes.values() for v in axis)
    if place_samples > 1 and not place_random:
        raise StudyError("placement.samples > 1 needs a random placement ({uniform: [lo, hi]})")
    placements = []  # per obstacle: [(x, y, rotation_deg)]
    for ob_index, (name, params, scene) in enumerate(obstacles):
        rows = []
        for combo_index, combo in enumerate(_grid("placement", place_axes)):
            for sample in range(place_samples):
                rng = np.random.default_rng([seed, 2, ob_index, combo_index, sample])
                rows.append(tuple(_draw(combo[k], rng) for k in ("x", "y", "rotation_deg")))
        placements.append(rows)
        if scene is not None and any(row != (0.0, 0.0, 0.0) for row in rows):
            raise StudyError(
                "placement turns a convex profile about its apex and moves it; a scene file "
                f"({scene.file}) places its own obstacles: scan scenes in a study without "
                "placement (or with placement 0)"
            )
        if name == "peg" and any(row != (0.0, 0.0, 0.0) for row in rows):
            raise StudyError(
                f"placement turns a convex profile about its apex and moves it; obstacles"
                f"[{ob_index}] is a peg, placed by its own params x, y: scan pegs in a study "
                "without placement (or with placement 0)"
            )
    count = len(whiskers) * sum(len(p) for p in placements) * len(motions) * len(noises)
    if count > MAX_TASKS:
        raise StudyError(
            f"the study expands to {count:,} tasks; at most {MAX_TASKS:,} are allowed"
        )
    for model, stiffness, shape in whiskers:
        for ob_index, (name, params, scene) in enumerate(obstacles):
            for x, y, rot in placements[ob_index]:
                for sweep_from, sweep_to, step, back, whisk in motions:
                    for noise in noises:
                        index = len(tasks)
                        tasks.append(
                            Task(
                                index,
                                model,
                                stiffness,
                                name,
                                params,
                                x,
                                y,
                                rot,
                                sweep_from,
                                sweep_to,
                                step,
                                back,
                                noise,
                                None if noise is None else _noise_seed(seed, index),
                                *shape,
                                whisk,
                                scene,
                            )
                        )
    if not tasks:
        raise StudyError("the study has no task")
    names: List[str] = []
    for profile in PROFILE_PARAMETERS:
        if any(ob[0] == profile for ob in obstacles):
            columns = [param_column(profile, k) for k in PROFILE_PARAMETERS[profile]]
            names += [c for c in columns if c not in names]
    digest = hashlib.sha256(text.encode("utf-8"))
    seen = set()
    for _, _, scene in obstacles:  # a scene file's text is part of the study
        if scene is not None and scene.path not in seen:
            seen.add(scene.path)
            digest.update(f"\0{scene.file}\0{scene.text}".encode("utf-8"))
    whisking = any(m[4] is not None for m in motions)
    return Study(
        text,
        digest.hexdigest(),
        seed,
        tuple(tasks),
        tuple(names),
        noises != [None],
        whisking,
        scene_at is not None,
    )


def _noise_seed(seed: int, index: int) -> int:
    """Return the task's own noise seed: independent per task, reproducible from (seed, index)."""
    return int(
        np.random.SeedSequence([seed, 3, index]).generate_state(1, np.uint64)[0] >> np.uint64(1)
    )


# -- blocks ---------------------------------------------------------------------------------------


def _whiskers(block) -> List[Tuple[str, Optional[float], Tuple[float, float, float]]]:
    """(model, spring stiffness, (taper, k0, k1)) for every whisker of the study."""
    block = _block("whisker", block, WHISKER_KEYS)
    models = _values("whisker.model", block.get("model", "elastica"), kind=str)
    for name in models:
        if name not in MODELS:
            raise StudyError(
                f"whisker.model = {name!r} is not allowed; allowed: {', '.join(MODELS)}"
            )
    if len(set(models)) != len(models):
        raise StudyError("whisker.model lists a model twice")
    stiffnesses: List[Optional[float]] = [None]
    if "spring_stiffness" in block:
        if "rigid" not in models:
            raise StudyError(
                "whisker.spring_stiffness applies to the rigid model; whisker.model has no 'rigid'"
            )
        stiffnesses = _values("whisker.spring_stiffness", block["spring_stiffness"], positive=True)
    tapers = _values("whisker.taper", block.get("taper", 1.0), positive=True)
    for rho in tapers:
        if not rho <= 1.0:
            raise StudyError(f"whisker.taper = {rho!r} is not allowed; the taper lies in (0, 1]")
    k0s = _values("whisker.curvature_k0", block.get("curvature_k0", 0.0))
    k1s = _values("whisker.curvature_k1", block.get("curvature_k1", 0.0))
    shapes = list(itertools.product(tapers, k0s, k1s))
    for shape in shapes:
        try:
            WhiskerShape(*shape)
        except VibrissaError as exc:
            raise StudyError(f"whisker: {exc}") from None
    out: List[Tuple[str, Optional[float], Tuple[float, float, float]]] = []
    for name in models:
        if name == "rigid":
            if shapes != [(1.0, 0.0, 0.0)]:
                raise StudyError(
                    "whisker.taper and whisker.curvature_k0/k1 apply to the elastica; the rigid "
                    "model is a straight rod"
                )
            out += [(name, k, shapes[0]) for k in stiffnesses]
        else:
            out += [(name, None, shape) for shape in shapes]
    return out


_Obstacle = Tuple[str, Tuple[Tuple[str, float], ...], Optional[SceneRef]]


def _obstacles(block, seed: int, base_dir: Optional[str], read_scenes: bool) -> List[_Obstacle]:
    """Return (profile, params, scene) of every obstacle: a profile, or ("scene", (), scene)."""
    if isinstance(block, dict):
        block = [block]
    if not isinstance(block, list) or not block:
        raise StudyError(
            "obstacles must be a non-empty list of {profile, params, samples} or "
            "{scene, friction} blocks"
        )
    out: List[_Obstacle] = []
    for i, entry in enumerate(block):
        where = f"obstacles[{i}]"
        if isinstance(entry, dict) and "scene" in entry:
            out += _scenes(where, entry, base_dir, read_scenes)
            continue
        entry = _block(where, entry, OBSTACLE_KEYS, required=("profile",))
        name = entry["profile"]
        if name not in PROFILE_PARAMETERS:
            raise StudyError(
                f"{where}.profile = {name!r} is not allowed; "
                f"allowed: {', '.join(PROFILE_PARAMETERS)}"
            )
        allowed = PROFILE_PARAMETERS[name]
        params = _block(
            f"{where}.params",
            entry.get("params", {}),
            tuple(allowed),
            required=tuple(k for k, d in allowed.items() if d is None),
        )
        # a peg's centre lies anywhere, its radius is >= 0 (0: a point); the convex profiles'
        # shape parameters are > 0, their apex height p0 is checked by the profile
        axes = {
            k: _axis(
                f"{where}.params.{k}",
                params[k],
                positive=name != "peg" and k != "p0",
                nonnegative=name == "peg" and k == "r",
            )
            for k in allowed
            if k in params
        }
        samples = _integer(f"{where}.samples", entry.get("samples", 1), minimum=1)
        random = any(isinstance(v, _Random) for axis in axes.values() for v in axis)
        if samples > 1 and not random:
            raise StudyError(
                f"{where}.samples > 1 needs a random parameter ({{uniform: [lo, hi]}})"
            )
        for combo_index, combo in enumerate(_grid(f"{where}.params", axes)):
            for sample in range(samples):
                rng = np.random.default_rng([seed, 1, i, combo_index, sample])
                values = {k: _draw(combo[k], rng) for k in allowed if k in combo}
                try:
                    profile = make_profile(name, values)
                except VibrissaError as exc:
                    what = f"sample {sample}" if random else "values"
                    raise StudyError(f"{where} {what} {values}: {exc}") from None
                out.append((name, tuple(profile.params.items()), None))
    return out


def _scenes(where: str, entry: Mapping, base_dir: Optional[str], read: bool) -> List[_Obstacle]:
    """Return the obstacles of a ``{scene: FILE or [FILES], friction: MU or [MUS]}`` entry."""
    entry = _block(where, entry, SCENE_KEYS, required=("scene",))
    files = entry["scene"] if isinstance(entry["scene"], list) else [entry["scene"]]
    if not files:
        raise StudyError(f"{where}.scene is an empty list; give at least one scene file")
    for name in files:
        if not isinstance(name, str) or not name.strip():
            raise StudyError(f"{where}.scene = {_show(name)} must be a scene file's path")
    if len(set(files)) != len(files):
        raise StudyError(f"{where}.scene lists a file twice")
    frictions: List[Optional[float]] = [None]
    if "friction" in entry:
        frictions = _values(f"{where}.friction", entry["friction"], nonnegative=True)
    out: List[_Obstacle] = []
    for name in files:
        path = os.path.normpath(os.path.join(base_dir or "", os.path.expanduser(name)))
        text, scene_friction = "", None
        if read:
            from ..scan.scene_file import load_scene

            try:
                with open(path, encoding="utf-8") as stream:
                    text = stream.read()
            except OSError as exc:
                raise StudyError(
                    f"{where}.scene = {name!r}: {path} cannot be read ({exc.strerror or exc})"
                ) from None
            except UnicodeDecodeError as exc:
                raise StudyError(f"{where}.scene = {name!r}: {path} is not text ({exc})") from None
            try:
                scene_friction = load_scene(path).friction
                _scene_from_text(text, path)
            except VibrissaError as exc:
                raise StudyError(f"{where}.scene = {name!r}: {exc}") from None
        for mu in frictions:
            ref = SceneRef(name, path, text, scene_friction if mu is None else mu)
            out.append(("scene", (), ref))
    return out


_Motion = Tuple[Optional[float], Optional[float], Optional[float], bool, Optional[Whisk]]


def _motions(block) -> List[_Motion]:
    """Return (sweep from, to, step, back, whisk) of every motion: a slide or a whisk."""
    blocks = block if isinstance(block, list) else [block]
    if not blocks:
        raise StudyError(
            "motion must be a {from, to, step, back} or {whisk: {...}} block or a non-empty list "
            "of them"
        )
    out = []
    for i, entry in enumerate(blocks):
        where = "motion" if not isinstance(block, list) else f"motion[{i}]"
        if isinstance(entry, dict) and "whisk" in entry:
            out += _whisks(where, entry)
            continue
        entry = _block(where, entry, MOTION_KEYS, required=("from", "to", "step"))
        axes = {
            k: _values(f"{where}.{k}", entry[k], positive=(k == "step"))
            for k in ("from", "to", "step")
        }
        axes["back"] = _values(f"{where}.back", entry.get("back", False), kind=bool)
        for combo in _grid(where, axes):
            motion = (combo["from"], combo["to"], combo["step"], combo["back"])
            _range(where, "from", "to", motion[0], motion[1])
            try:
                scan_grid(*motion)
            except VibrissaError as exc:
                raise StudyError(f"{where}: {exc}") from None
            out.append(motion + (None,))
    return out


def _whisks(where: str, entry: Mapping) -> list:
    """Return the motions of a ``{whisk: {x, y, from_deg, to_deg, step_deg, back}}`` block."""
    others = [k for k in entry if k != "whisk"]
    if others:
        raise StudyError(
            f"{where}: unknown key {others[0]!r} beside 'whisk'; a whisking motion is "
            "{whisk: {" + ", ".join(WHISK_KEYS) + "}}"
        )
    where = f"{where}.whisk"
    block = _block(where, entry["whisk"], WHISK_KEYS, required=("from_deg", "to_deg", "step_deg"))
    axes = {
        k: _values(f"{where}.{k}", block.get(k, 0.0), positive=(k == "step_deg"))
        for k in ("x", "y", "from_deg", "to_deg", "step_deg")
    }
    axes["back"] = _values(f"{where}.back", block.get("back", False), kind=bool)
    out = []
    for combo in _grid(where, axes):
        whisk = Whisk(*(combo[k] for k in ("x", "y", "from_deg", "to_deg", "step_deg")))
        _range(where, "from_deg", "to_deg", whisk.from_deg, whisk.to_deg)
        try:
            whisk_poses(whisk.x, whisk.y, whisk.from_deg, whisk.to_deg, whisk.step_deg)
        except VibrissaError as exc:
            raise StudyError(f"{where}: {exc}") from None
        out.append((None, None, None, combo["back"], whisk))
    return out


def _range(where: str, lo_key: str, hi_key: str, lo: float, hi: float) -> None:
    if lo == hi:
        raise StudyError(
            f"{where}: {lo_key} = {hi_key} = {lo!r} is an empty range; the motion needs "
            f"{lo_key} != {hi_key}"
        )


def _noises(block) -> List[Optional[Noise]]:
    if block is None:
        return [None]
    block = _block("noise", block, NOISE_KEYS)
    axes = {}
    for key in NOISE_KEYS:
        if key in block:
            nonneg = key.endswith(("stddev", "step"))
            axes[key] = _values(f"noise.{key}", block[key], nonnegative=nonneg)
    return [Noise(**combo) for combo in _grid("noise", axes)]


# -- values ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Random:
    kind: str
    lo: float
    hi: float


def _draw(value, rng: np.random.Generator) -> float:
    if not isinstance(value, _Random):
        return value
    if value.kind == "uniform":
        return float(rng.uniform(value.lo, value.hi))
    return float(math.exp(rng.uniform(math.log(value.lo), math.log(value.hi))))


def _keys(
    where: str, block: Mapping, allowed: Sequence[str], required: Sequence[str] = ()
) -> None:
    for key in block:
        if key not in allowed:
            raise StudyError(f"{where}: unknown key {key!r}; allowed: {', '.join(allowed)}")
    for key in required:
        if key not in block:
            raise StudyError(f"{where}: key {key!r} is required")


def _block(
    where: str, block, allowed: Sequence[str], required: Sequence[str] = ()
) -> Dict[str, Any]:
    if not isinstance(block, dict):
        raise StudyError(
            f"{where} must be a mapping with the keys {', '.join(allowed)}, not {_show(block)}"
        )
    _keys(where, block, allowed, required)
    return block


def _show(value) -> str:
    text = repr(value)
    return text if len(text) < 40 else text[:37] + "..."


def _integer(where: str, value, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise StudyError(f"{where} = {_show(value)} must be an integer >= {minimum}")
    if value < minimum:
        raise StudyError(f"{where} = {value} must be >= {minimum}")
    return value


def _number(where: str, value, positive=False, nonnegative=False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        hint = ""
        if isinstance(value, str):
            try:
                hint = f" (YAML reads {value} as text: write {float(value)!r})"
            except ValueError:
                pass
        raise StudyError(f"{where} = {_show(value)} must be a number{hint}")
    value = float(value)
    if not math.isfinite(value):
        raise StudyError(f"{where} = {value!r} must be finite")
    if positive and not value > 0.0:
        raise StudyError(f"{where} = {value!r} must be > 0")
    if nonnegative and value < 0.0:
        raise StudyError(f"{where} = {value!r} must be >= 0")
    return value


def _values(where: str, value, kind=float, positive=False, nonnegative=False) -> list:
    """Check and return a scalar or a non-empty list of them (a grid axis)."""
    items = value if isinstance(value, list) else [value]
    if not items:
        raise StudyError(f"{where} is an empty list (an empty range); give at least one value")
    out = []
    for item in items:
        if kind is float:
            out.append(_number(where, item, positive, nonnegative))
        elif kind is bool:
            if not isinstance(item, bool):
                raise StudyError(f"{where} = {_show(item)} must be true or false")
            out.append(item)
        else:
            if not isinstance(item, str):
                raise StudyError(f"{where} = {_show(item)} must be a name")
            out.append(item)
    if len(set(out)) != len(out):
        raise StudyError(f"{where} lists a value twice")
    return out


def _axis(where: str, value, positive=False, nonnegative=False) -> list:
    """
    Check and return a number, a list of numbers or a random draw.

    The draw is ``{uniform: [lo, hi]}`` or ``{loguniform: [lo, hi]}``.
    """
    if isinstance(value, dict):
        if len(value) != 1 or next(iter(value)) not in RANDOM_KINDS:
            raise StudyError(
                f"{where} = {_show(value)}: a random value is one of "
                + ", ".join(f"{{{k}: [lo, hi]}}" for k in RANDOM_KINDS)
            )
        kind, bounds = next(iter(value.items()))
        if not isinstance(bounds, list) or len(bounds) != 2:
            raise StudyError(f"{where}.{kind} must be [lo, hi], not {_show(bounds)}")
        lo = _number(
            f"{where}.{kind}", bounds[0], positive or kind == "loguniform", nonnegative
        )
        hi = _number(f"{where}.{kind}", bounds[1], positive, nonnegative)
        if not lo < hi:
            raise StudyError(
                f"{where}.{kind} = [{lo!r}, {hi!r}] is an empty range; lo < hi is required"
            )
        return [_Random(kind, lo, hi)]
    return _values(where, value, positive=positive, nonnegative=nonnegative)


def _grid(where: str, axes: Mapping[str, list]) -> List[Dict[str, Any]]:
    """Every combination of the axes' values (each axis a checked, non-empty list), in order."""
    keys = list(axes)
    return [dict(zip(keys, combo)) for combo in itertools.product(*(axes[k] for k in keys))]
