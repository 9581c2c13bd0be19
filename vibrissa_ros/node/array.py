"""
What array_node does, without ROS: its parameters, its configuration, its inputs, its tick.

array_node runs a whole whisker array (:class:`~vibrissa_ros.core.arrays.ArrayTracker`) against
a 3D scene in metres. A tick takes the head pose (the last accepted one) and every whisker's
protraction angle, steps the array and returns its :class:`~vibrissa_ros.core.arrays.ArrayStep`.
Protraction angles come from the built-in cosine whisk (``whisk.source: builtin``) or from
outside as joint states (``external``): one joint per whisker (named by the whisker), one per
row (``row_A`` ... ``row_E``: every whisker of that row) or one joint ``whisk`` for all of them.

Bad input raises :class:`~vibrissa_ros.node.edge.BadInput` with the reason counted on
/diagnostics; the state is kept. :func:`output_rows` is the layout of the node's one message per
tick (``ARRAY_FIELDS``), shared by the node, ``vibrissa resim`` and the tests.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Dict, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..core.arrays import ArrayStep, ArrayTracker, CosineWhisk, WhiskerArray
from ..core.arrays.partition import MAX_WORKERS, PartitionedArrayTracker
from ..core.errors import ConvergenceError, ParameterError
from ..core.rod3d import BasePose, Scene3D
from ..core.rod3d.model import POINTS_TOLERANCE, POINTS_TOLERANCE_RANGE
from .config import resolve_scene_file
from .edge import BadInput, spatial_pose
from .parameters import ParameterSpec, nonnegative, positive, validate

SOURCES = ("builtin", "external")
SIDES = ("both", "right", "left")
#: the joint that drives every whisker at once (the built-in whisk's own angle is recorded so)
ALL_JOINT = "whisk"
#: the prefix of a row's joint (``row_C``: every whisker of row C)
ROW_PREFIX = "row_"
#: the largest protraction angle taken from outside [rad]: beyond, the input is dropped
MAX_PROTRACTION = 0.5 * math.pi
#: the keys under which a recorded configuration carries the array and scene files' text
ARRAY_TEXT = "array.text"
SCENE_TEXT = "scene.text"


def _read_only(spec: ParameterSpec) -> ParameterSpec:
    return ParameterSpec(**{**spec.__dict__, "read_only": True})


#: array_node's parameters (every one read-only: a new array or scene is a new node)
ARRAY_PARAMETERS: Tuple[ParameterSpec, ...] = tuple(_read_only(s) for s in (
    ParameterSpec("array.file", "package://vibrissa_ros/config/rat_array.yaml",
                  "the whisker array file (YAML, SI units in the head frame); a relative path is "
                  "taken from the working directory, package://<package>/<path> from the "
                  "package's share folder"),
    ParameterSpec("array.side", "both", "the whiskers of the array run: both sides, or only "
                  "the right or the left one", choices=SIDES),
    ParameterSpec("scene.file", "", "a 3D scene file with lengths in metres (spheres, cylinders, "
                  "planes, prisms), path or package://; '' = no obstacle (whisking in the air)"),
    ParameterSpec("whisk.source", "builtin", "builtin: the cosine whisk, one tick per timer "
                  "period (rate); external: protraction angles from ~/whisk (JointState), one "
                  "tick per accepted JointState or head pose", choices=SOURCES),
    positive("whisk.frequency", 8.0, "builtin whisk frequency", "Hz", maximum=100.0),
    ParameterSpec("whisk.retraction", -math.radians(20.0), "protraction angle at full "
                  "retraction (relative to each whisker's rest orientation); every whisker "
                  "starts there", "rad", minimum=-MAX_PROTRACTION, maximum=MAX_PROTRACTION),
    ParameterSpec("whisk.protraction", math.radians(20.0), "protraction angle at full "
                  "protraction (>= whisk.retraction)", "rad", minimum=-MAX_PROTRACTION,
                  maximum=MAX_PROTRACTION),
    ParameterSpec("whisk.realtime", True, "builtin whisk: true: tick k is at k / rate seconds "
                  "of the clock (an overrun skips ticks); false: every tick advances the whisk "
                  "by exactly 1 / rate (slower than real time when the solver cannot keep up)"),
    positive("rate", 1000.0, "builtin whisk: ticks per second (the timer); a tick that "
             "overruns skips the timer ticks it missed", "Hz", maximum=10000.0),
    ParameterSpec("head.x", 0.0, "head position x in world_frame until a head pose arrives",
                  "m"),
    ParameterSpec("head.y", 0.0, "head position y", "m"),
    ParameterSpec("head.z", 0.0, "head position z", "m"),
    ParameterSpec("head.qx", 0.0, "head orientation quaternion x (unit, with qy, qz, qw)"),
    ParameterSpec("head.qy", 0.0, "head orientation quaternion y"),
    ParameterSpec("head.qz", 0.0, "head orientation quaternion z"),
    ParameterSpec("head.qw", 1.0, "head orientation quaternion w"),
    ParameterSpec("world_frame", "world", "frame of the head poses, obstacles, shapes and "
                  "contacts", nonempty=True),
    ParameterSpec("head_frame", "head", "the head's frame; whisker base frames are "
                  "<head_frame>/<name>", nonempty=True),
    nonnegative("display.rate", 30.0, "highest rate of ~/shapes and ~/contacts (0: off)", "Hz",
                maximum=1000.0),
    ParameterSpec("display.points", 21, "points per whisker on ~/shapes", minimum=2,
                  maximum=1000),
    nonnegative("wrench.rate", 0.0, "rate of the per-whisker ~/<name>/wrench topics (0: none "
                "created)", "Hz", maximum=1000.0),
    positive("diagnostics.period", 1.0, "period of /diagnostics", "s", maximum=3600.0),
    ParameterSpec("record.path", "", "record to this MCAP file; '' = off"),
    ParameterSpec("executor", "single_threaded", "the rclpy executor that spins the node",
                  choices=("single_threaded", "events")),
    ParameterSpec("solver.adapt_points", True, "solve each whisker in contact on as few "
                  "Chebyshev points per segment as its solution needs (the same wrenches as "
                  "the full count to ~1e-13, faster); false: always its shape's full count"),
    ParameterSpec("solver.points_tolerance", POINTS_TOLERANCE, "discretization error asked of "
                  "each whisker, in whisker lengths: 1e-11 resolves it to the solver's own "
                  "convergence; coarser takes fewer points, faster (on the rat's pad 1e-8 moved "
                  "the base wrenches by ~3e-11 of their largest value, ~20% faster ticks)",
                  minimum=POINTS_TOLERANCE_RANGE[0], maximum=POINTS_TOLERANCE_RANGE[1]),
    ParameterSpec("solver.workers", 1, "processes the whiskers are dealt to (whisker i to "
                  "i mod workers; the same results): 1 steps every whisker in the node's "
                  "process; more pays only where each gets a core of its own (on 2 shared "
                  "vCPUs 2 were slower)", minimum=1, maximum=MAX_WORKERS),
))


@dataclass(frozen=True)
class ArrayConfig:
    """
    array_node's validated configuration: the parameters and what they build.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    values : dict
        Every parameter's value.
    array : WhiskerArray
        The whiskers run (the side chosen).
    scene : Scene3D or None
        The obstacles, metres, world frame; None: no obstacle.
    whisk : CosineWhisk
        The built-in whisk (also gives the initial protraction, its retraction).
    head : BasePose
        The head pose of the parameters (position [m]).
    array_text, scene_text : str
        The files' text, recorded so that a log rebuilds the run whatever became of the files.

    """

    values: Dict[str, Any]
    array: WhiskerArray
    scene: Optional[Scene3D]
    whisk: CosineWhisk
    head: BasePose
    array_text: str
    scene_text: str

    @property
    def record_values(self) -> Dict[str, Any]:
        """Return the parameters and the files' text, as the log's configuration record."""
        return {**self.values, ARRAY_TEXT: self.array_text, SCENE_TEXT: self.scene_text}

    @property
    def builtin(self) -> bool:
        """Return whether the built-in whisk drives the ticks."""
        return self.values["whisk.source"] == "builtin"

    def describe(self) -> str:
        """Return one line: the whiskers, the scene, the whisk."""
        names = ", ".join(ob.name for ob in self.scene or ()) or "no obstacle"
        v = self.values
        whisk = (f"built-in whisk {v['whisk.frequency']:g} Hz between "
                 f"{math.degrees(v['whisk.retraction']):g} and "
                 f"{math.degrees(v['whisk.protraction']):g} deg at {v['rate']:g} ticks/s"
                 if self.builtin else "whisking from ~/whisk")
        return f"{len(self.array)} whiskers ({v['array.side']}), scene: {names}; {whisk}"


def _read(name: str, value: str) -> str:
    try:
        path = resolve_scene_file(value)
    except ParameterError as exc:
        raise ParameterError(str(exc).replace("obstacle.scene_file", name)) from None
    try:
        with open(path, encoding="utf-8") as stream:
            return stream.read()
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc)
        raise ParameterError(f"{name} = {value!r}: cannot read {path!r}: {reason}") from None


def _array_of(text: str, label: str) -> WhiskerArray:
    import yaml

    from ..scan.array_file import _TEXT_KEYS, _yaml_number

    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ParameterError(f"array.file = {label!r}: not valid YAML: "
                             f"{str(exc).splitlines()[0]}") from None
    if isinstance(data, dict) and isinstance(data.get("whiskers"), list):
        data = dict(data, whiskers=[
            {k: (v if k in _TEXT_KEYS else _yaml_number(v)) for k, v in e.items()}
            if isinstance(e, dict) else e for e in data["whiskers"]])
    try:
        return WhiskerArray.from_dict(data)
    except ParameterError as exc:
        raise ParameterError(f"array.file = {label!r}: {exc}") from None


def build_array_config(values: Mapping[str, Any],
                       recorded: Optional[Mapping[str, str]] = None) -> ArrayConfig:
    """
    Validate array_node's parameters and build its configuration.

    Parameters
    ----------
    values : mapping of str to object
        Parameter values (missing ones at their defaults).
    recorded : mapping of str to str, optional
        A log's record of the files' text (``array.text``, ``scene.text``): used instead of
        reading the files.

    Returns
    -------
    ArrayConfig
        The configuration.

    Raises
    ------
    ParameterError
        One line naming the parameter (or the file, whisker and key) and what is allowed.

    """
    from ..scan.scene_file import load_scene3d

    values = validate(ARRAY_PARAMETERS, values)
    recorded = recorded or {}
    array_text = recorded.get(ARRAY_TEXT)
    if not isinstance(array_text, str):
        array_text = _read("array.file", values["array.file"])
    array = _array_of(array_text, values["array.file"])
    if values["array.side"] != "both":
        array = array.side(values["array.side"])
    if values["solver.workers"] > len(array):
        raise ParameterError(f"solver.workers = {values['solver.workers']} is not allowed; the "
                             f"array has {len(array)} whiskers: from 1 to {len(array)}")
    scene_text = recorded.get(SCENE_TEXT)
    if not isinstance(scene_text, str):
        scene_text = _read("scene.file", values["scene.file"]) if values["scene.file"] else ""
    scene = None  # no obstacle: whisking in the air
    if scene_text.strip():
        try:
            scene = load_scene3d(scene_text if "\n" in scene_text else scene_text + "\n")
        except ParameterError as exc:
            raise ParameterError(f"scene.file = {values['scene.file']!r}: {exc}") from None
    whisk = CosineWhisk(values["whisk.frequency"], values["whisk.retraction"],
                        values["whisk.protraction"])
    try:
        position, q = spatial_pose([values[f"head.{k}"] for k in "xyz"],
                                   [values[f"head.q{k}"] for k in "xyzw"])
    except BadInput as exc:
        raise ParameterError(f"head.*: {exc}") from None
    return ArrayConfig(values, array, scene, whisk, BasePose(position, q), array_text,
                       scene_text)


# -- inputs ---------------------------------------------------------------------------------------
def head_pose(frame_id: str, world_frame: str, position: Sequence[float],
              quaternion: Sequence[float]) -> BasePose:
    """
    Return a received head pose checked.

    Parameters
    ----------
    frame_id : str
        The message's frame; it must be ``world_frame``.
    world_frame : str
        The node's world frame.
    position : sequence of float
        (x, y, z) [m].
    quaternion : sequence of float
        (x, y, z, w), ROS order.

    Returns
    -------
    BasePose
        The head pose (position [m], the unit quaternion).

    Raises
    ------
    BadInput
        ``wrong_frame_id``, ``not_finite`` or ``quaternion_not_unit``.

    """
    if frame_id != world_frame:
        raise BadInput("wrong_frame_id", f"head pose in frame {frame_id!r}; the node takes "
                       f"head poses in {world_frame!r}")
    p, q = spatial_pose(position, quaternion)
    return BasePose(p, q)


class JointMap:
    """
    Protraction angles of every whisker from joint names: whisker names, rows, or ``whisk``.

    Parameters
    ----------
    array : WhiskerArray
        The whiskers (their order is the tick's).

    """

    def __init__(self, array: WhiskerArray):
        self.names = array.names
        self._index = {name: (i,) for i, name in enumerate(array.names)}
        rows: Dict[str, list] = {}
        for i, w in enumerate(array):
            rows.setdefault(ROW_PREFIX + w.row, []).append(i)
        self._index.update({name: tuple(ix) for name, ix in rows.items()})
        self._index[ALL_JOINT] = tuple(range(len(array)))

    def angles(self, names: Sequence[str], positions: Sequence[float],
               previous: np.ndarray) -> np.ndarray:
        """
        Return every whisker's protraction after a joint state.

        Parameters
        ----------
        names : sequence of str
            Joint names: whisker names, ``row_<letter>`` or ``whisk``; whiskers not named keep
            their previous angle.
        positions : sequence of float
            One angle [rad] per name.
        previous : numpy.ndarray
            (k,) the angles so far.

        Returns
        -------
        numpy.ndarray
            (k,) the new angles [rad].

        Raises
        ------
        BadInput
            ``joint_lengths`` (not one position per name, or no name), ``joint_names`` (an
            unknown or repeated name), ``not_finite`` or ``out_of_range`` (an angle beyond
            :data:`MAX_PROTRACTION`).

        """
        names, positions = list(names), list(positions)
        if not names or len(names) != len(positions):
            raise BadInput("joint_lengths", f"joint state with {len(names)} names and "
                           f"{len(positions)} positions; one position per name is required")
        if len(set(names)) != len(names):
            raise BadInput("joint_names", f"joint state names a joint twice: {names}")
        unknown = [n for n in names if n not in self._index]
        if unknown:
            raise BadInput("joint_names", f"unknown joint(s) {unknown[:5]}; joints are the "
                           f"whiskers' names ({self.names[0]}, ...), row_<A-E> or "
                           f"{ALL_JOINT!r}")
        values = np.asarray(positions, dtype=float)
        if not np.all(np.isfinite(values)):
            raise BadInput("not_finite", f"joint state has a non-finite position: {positions}")
        if np.any(np.abs(values) > MAX_PROTRACTION):
            raise BadInput("out_of_range", f"protraction angle beyond {MAX_PROTRACTION:.4g} rad "
                           f"(90 deg): {positions}")
        out = np.array(previous, dtype=float)
        # the whole array first, then rows, then single whiskers: the most specific name wins
        order = sorted(range(len(names)), key=lambda j: -len(self._index[names[j]]))
        for j in order:
            out[list(self._index[names[j]])] = values[j]
        return out


# -- the output layout ----------------------------------------------------------------------------
#: one row per whisker of the node's ~/wrenches message: (name, numpy type, unit, meaning)
ARRAY_FIELDS: Tuple[Tuple[str, str, str, str], ...] = (
    ("x", "<f8", "m", "base point, world frame"),
    ("y", "<f8", "m", ""),
    ("z", "<f8", "m", ""),
    ("qx", "<f8", "", "base frame orientation in the world frame (x, y, z, w)"),
    ("qy", "<f8", "", ""),
    ("qz", "<f8", "", ""),
    ("qw", "<f8", "", ""),
    ("fx", "<f8", "N", "force on the whisker's base (the follicle sensor's reading), base frame"),
    ("fy", "<f8", "N", ""),
    ("fz", "<f8", "N", ""),
    ("mx", "<f8", "N m", "moment about the base point, base frame"),
    ("my", "<f8", "N m", ""),
    ("mz", "<f8", "N m", ""),
    ("theta", "<f8", "rad", "protraction angle"),
    ("s", "<f8", "m", "arc length of the contact nearest the base (0: none)"),
    ("f", "<f8", "N", "its normal force (0: none)"),
    ("cx", "<f8", "m", "its point, world frame (0: none)"),
    ("cy", "<f8", "m", ""),
    ("cz", "<f8", "m", ""),
    ("index", "<u4", "", "the whisker's index in ~/whiskers"),
    ("contacts", "<u4", "", "number of contacts"),
    ("kind", "u1", "", "contact nearest the base: 0 none, 1 side, 2 tip"),
    ("obstacle", "u1", "", "its obstacle's index in the scene + 1 (0: none)"),
    ("solved", "u1", "", "1: the whisker's solver ran this tick, 0: certified free"),
    ("error", "u1", "", "1: the whisker's step failed this tick (it kept its state)"),
)
KINDS = {"": 0, "side": 1, "tip": 2}
ARRAY_DTYPE = np.dtype([(name, kind) for name, kind, _, _ in ARRAY_FIELDS])
#: the float fields lead the row, packed: their bytes are one block of float64s (finite's view)
_FLOATS = sum(1 for _, kind, _, _ in ARRAY_FIELDS if kind == "<f8")
assert all(ARRAY_DTYPE.fields[name][1] == 8 * i and kind == "<f8"
           for i, (name, kind, _, _) in enumerate(ARRAY_FIELDS[:_FLOATS]))
#: the wrench columns compared by ``vibrissa resim``
WRENCH_FIELDS = ("fx", "fy", "fz", "mx", "my", "mz")


def output_rows(step: ArrayStep, scene: Scene3D) -> np.ndarray:
    """
    Return a tick as one structured row per whisker (:data:`ARRAY_DTYPE`).

    Parameters
    ----------
    step : ArrayStep
        The tick.
    scene : Scene3D or None
        The scene (for the obstacles' indices).

    Returns
    -------
    numpy.ndarray
        (k,) rows of :data:`ARRAY_DTYPE`, SI units.

    """
    k = len(step.names)
    rows = np.zeros(k, dtype=ARRAY_DTYPE)
    rows["x"], rows["y"], rows["z"] = step.base_position.T
    q = step.base_quaternion
    rows["qw"], rows["qx"], rows["qy"], rows["qz"] = q.T
    rows["fx"], rows["fy"], rows["fz"] = step.force_base.T
    rows["mx"], rows["my"], rows["mz"] = step.moment_base.T
    rows["theta"] = step.protraction
    rows["s"], rows["f"] = step.contact_s, step.contact_f
    rows["cx"], rows["cy"], rows["cz"] = step.contact_point.T
    rows["index"] = np.arange(k)
    rows["contacts"] = step.contacts
    rows["kind"] = [KINDS.get(kind, 0) for kind in step.contact_kind]
    names = {ob.name: i + 1 for i, ob in enumerate(scene or ())}
    rows["obstacle"] = [names.get(name, 0) for name in step.contact_obstacle]
    rows["solved"] = step.solved
    failed = {e.whisker for e in step.errors}
    rows["error"] = [name in failed for name in step.names]
    return rows


def finite(rows: np.ndarray) -> bool:
    """
    Return whether every float field of the rows is finite.

    Parameters
    ----------
    rows : numpy.ndarray
        Rows of :data:`ARRAY_DTYPE`.

    Returns
    -------
    bool
        True when no value is NaN or infinite.

    """
    rows = np.ascontiguousarray(rows, dtype=ARRAY_DTYPE).reshape(-1)
    # the float fields' bytes of every row, as (k, _FLOATS) float64s: one isfinite call
    # (~3 us for 30 whiskers, where a call per field took ~30 us)
    raw = rows.view(np.uint8).reshape(len(rows), ARRAY_DTYPE.itemsize)
    return bool(np.isfinite(raw[:, :8 * _FLOATS].view("<f8")).all())


# -- the pipeline ---------------------------------------------------------------------------------
#: what the node's error says can be done when a worker process of the array ended
_RESET_STARTS = "~/reset starts it again, every whisker unloaded, in new worker processes"


class ArrayPipeline:
    """
    The node's state without ROS: the tracker, the head pose and the protraction so far.

    Parameters
    ----------
    config : ArrayConfig
        The configuration.

    Raises
    ------
    InvalidPoseError
        When a whisker cuts an obstacle at the initial pose (head pose of the parameters, every
        whisker at ``whisk.retraction``).

    """

    def __init__(self, config: ArrayConfig):
        self.config = config
        self.joints = JointMap(config.array)
        self.head = config.head
        self.theta = np.full(len(config.array), config.whisk.retraction)
        options = dict(adapt_points=config.values["solver.adapt_points"],
                       points_tolerance=config.values["solver.points_tolerance"])
        workers = int(config.values["solver.workers"])
        if workers > 1:
            self.tracker = PartitionedArrayTracker(config.array, config.scene, self.head,
                                                   self.theta, workers=workers, **options)
        else:
            self.tracker = ArrayTracker(config.array, config.scene, self.head, self.theta,
                                        **options)
        self._reset = False

    def close(self) -> None:
        """End the tracker's worker processes, if it has any (``solver.workers`` > 1)."""
        if isinstance(self.tracker, PartitionedArrayTracker):
            self.tracker.close()

    def request_reset(self) -> None:
        """
        Re-place every whisker unloaded before the next tick (``~/reset``).

        The next tick first re-places each whisker, unloaded and without its history, at its
        pose of the last tick (:meth:`ArrayTracker.reset`), then steps the array: its answer
        carries an event ``reset`` per whisker re-placed, and an error for each whisker that
        would cut an obstacle unloaded there (a whisker pressed on one), which keeps its state.
        Where a worker process of the array has ended (``solver.workers`` > 1), the next tick
        starts the parts afresh instead, every whisker unloaded at that tick's pose
        (:meth:`PartitionedArrayTracker.restart`); where a whisker would cut an obstacle there,
        that tick fails saying so, and the request is done (ask again once the whisk has
        taken the whisker off the obstacle).
        """
        self._reset = True

    def set_head(self, frame_id: str, position, quaternion) -> None:
        """Take a head pose (checked, :func:`head_pose`); raises BadInput, state kept."""
        self.head = head_pose(frame_id, self.config.values["world_frame"], position, quaternion)

    def set_joints(self, names, positions) -> None:
        """Take a joint state (checked, :meth:`JointMap.angles`); raises BadInput, state kept."""
        self.theta = self.joints.angles(names, positions, self.theta)

    def tick(self) -> ArrayStep:
        """Step the array to the current head pose and protraction (after a requested reset)."""
        failed = getattr(self.tracker, "failed", None)  # (a worker process ended)
        if not self._reset:
            if failed is None:
                try:
                    return self.tracker.step(self.head, self.theta)
                except ConvergenceError:
                    failed = getattr(self.tracker, "failed", None)
                    if failed is None:
                        raise
            raise ConvergenceError(f"{failed}; the array cannot go on: {_RESET_STARTS}")
        self._reset = False
        if failed is None:
            try:
                placed = self.tracker.reset()
            except ConvergenceError:  # (a worker ended since the last tick: started again)
                failed = getattr(self.tracker, "failed", None)
                if failed is None:
                    raise
        if failed is not None:
            try:
                return self.tracker.restart(self.head, self.theta, reason=(
                    f"reset on request, the array started again ({failed})"))
            except ConvergenceError as exc:  # (a new worker that did not start)
                raise ConvergenceError(f"{exc}; the array cannot go on: {_RESET_STARTS}"
                                       ) from None
        step = self.tracker.step(self.head, self.theta)
        return replace(step, events=placed.events + step.events,
                       errors=placed.errors + step.errors)


__all__ = ["ARRAY_DTYPE", "ARRAY_FIELDS", "ARRAY_PARAMETERS", "ArrayConfig", "ArrayPipeline",
           "JointMap", "build_array_config", "finite", "head_pose", "output_rows"]
