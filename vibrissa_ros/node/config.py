"""
The two nodes' parameters: names, SI units, defaults, ranges, and the configurations they build.

No rclpy here. The names are a contract (tests, parameter files and users rely on them); the
machinery (types, ranges, reasons) is :mod:`vibrissa_ros.node.parameters`, shared by both nodes.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any, Dict, Mapping, Optional, Tuple

from ..core.errors import ParameterError
from ..core.general.model import GeneralWhiskerModel, WhiskerShape
from ..core.exact.models import make_model
from ..core.profiles import ConvexProfile, Peg, make_profile
from ..core.rod3d import DEFAULT_POISSON, RodShape, Scene3D
from ..core.rod3d.model import POINTS_TOLERANCE, POINTS_TOLERANCE_RANGE
from ..core.scenes.scene import Scene
from .edge import NS_PER_S, Units
from .parameters import ParameterSpec, nonnegative, positive, validate

MODELS = ("elastica", "rigid", "rod3d")
#: the 3D whisker (doc/guide/node.md, "3D whisker"): a Kirchhoff rod among obstacles in space
ROD3D = "rod3d"
#: obstacle type -> (core parameter name, node parameter name) of its shape parameters
SHAPE_PARAMETERS = {
    "parabola": (("k", "obstacle.k"),),
    "catenary": (("c", "obstacle.c"),),
    "circle": (("R", "obstacle.radius"),),
    "two_circles": (("R_left", "obstacle.radius_left"), ("R_right", "obstacle.radius_right")),
    "ellipse": (("a", "obstacle.a"), ("b", "obstacle.b")),
    "peg": (("r", "obstacle.peg_radius"),),
}
#: obstacle.type of a scene file (several obstacles, friction: doc/guide/node.md, "Scenes in the
#: node")
SCENE = "scene"
#: the key under which a recorded configuration carries the scene file's text (not a parameter:
#: ``vibrissa resim`` rebuilds the scene from it, whatever became of the file)
SCENE_TEXT = "obstacle.scene_text"
#: relative tolerance between whisker.bending_stiffness and E pi r^4 / 4 when a file gives both
EI_TOLERANCE = 1e-6
#: rounding of nu = EI/GJ - 1 taken as the end of [0, 0.5] it is nearest
NU_TOLERANCE = 1e-12


def _frame(name: str, default: str, description: str) -> ParameterSpec:
    return ParameterSpec(name, default, description, read_only=True, nonempty=True, resets=False)


_WHISKER = (
    positive("whisker.length", 0.1, "length L of the whisker", "m", maximum=1e3),
    positive("whisker.bending_stiffness", 5e-4, "bending stiffness EI of the whisker at its base "
             "(elastica); used when whisker.youngs_modulus is 0", "N m^2", maximum=1e9),
    nonnegative("whisker.youngs_modulus", 0.0, "Young's modulus E of the whisker; > 0: the base "
                "stiffness is E pi r^4 / 4 with r = whisker.base_radius (bending_stiffness then "
                "stays at its default or agrees to 1e-6); 0: whisker.bending_stiffness is used",
                "Pa", maximum=1e15),
    nonnegative("whisker.base_radius", 0.0, "radius r of the whisker at its base (with "
                "whisker.youngs_modulus)", "m", maximum=1e3),
    ParameterSpec("whisker.taper", 1.0, "tip radius / base radius of a conical whisker (1: "
                  "uniform); the stiffness falls as (1 - (1 - taper) s/L)^4", minimum=0.0,
                  maximum=1.0, exclusive_minimum=True),
    ParameterSpec("whisker.curvature_k0", 0.0, "intrinsic curvature at the base (k0 + k1 s, "
                  "counter-clockwise positive; dimensionless k0 L)", "1/m"),
    ParameterSpec("whisker.curvature_k1", 0.0, "rate of change of the intrinsic curvature along "
                  "the whisker (dimensionless k1 L^2)", "1/m^2"),
)
#: the 3D whisker's own parameters (model rod3d)
_WHISKER_3D = (
    ParameterSpec("whisker.poisson", DEFAULT_POISSON, "rod3d: Poisson ratio nu of the whisker; "
                  "its torsional stiffness is GJ = EI / (1 + nu) (not with "
                  "whisker.torsional_stiffness)", minimum=0.0, maximum=0.5),
    nonnegative("whisker.torsional_stiffness", 0.0, "rod3d: torsional stiffness GJ at the base; "
                "> 0: nu = EI / GJ - 1, which must be in [0, 0.5] (whisker.poisson then stays at "
                "its default); 0: from whisker.poisson", "N m^2", maximum=1e9),
    ParameterSpec("whisker.parabola", 0.0, "rod3d: the unloaded whisker is the parabola "
                  "y = A x^2 in its own plane (its base at the vertex; dimensionless A L, "
                  "|A L| <= 10); 0: the curvature k0 + k1 s (not with curvature_k0/k1)", "1/m"),
    ParameterSpec("whisker.roll", 0.0, "rod3d: the whisker's rotation about its own axis (base "
                  "frame +x): its plane of curvature is the base frame's x-y plane rolled by this "
                  "angle", "rad", minimum=-2.0 * math.pi, maximum=2.0 * math.pi),
    ParameterSpec("solver.points_tolerance", POINTS_TOLERANCE, "rod3d: the discretization "
                  "error asked of the whisker, in whisker lengths: 1e-11 resolves it to the "
                  "solver's own convergence; coarser takes fewer points, faster (array_node's "
                  "parameter of the same name)", minimum=POINTS_TOLERANCE_RANGE[0],
                  maximum=POINTS_TOLERANCE_RANGE[1]),
)
_FRAMES = (
    _frame("world_frame", "world", "frame of the foot poses, the obstacle and the contact point"),
    _frame("base_frame", "whisker_base",
           "frame of the whisker's base (REP 103: +x along the undeformed whisker); the wrench "
           "is in it"),
)
_INPUT = (
    nonnegative("input.z_tolerance", 1e-6,
                "largest |z| of an input pose (the whisker moves in z = 0)", "m", resets=False),
    nonnegative("input.angle_tolerance", 1e-6, "largest |roll|, |pitch| of an input pose", "rad",
                resets=False),
)

#: whisker_node's parameters
PARAMETERS: Tuple[ParameterSpec, ...] = (
    _WHISKER
    + _WHISKER_3D
    + (
        ParameterSpec(
            "model",
            "elastica",
            "whisker model: 'elastica' (paper §2), 'rigid' (paper §3) or 'rod3d' (the 3D "
            "Kirchhoff whisker among obstacles in space; obstacle.type scene)",
            choices=MODELS,
        ),
        positive(
            "rigid.spring_stiffness",
            0.015,
            "pivot stiffness c of the rigid model; c = 3 EI/L matches the elastica's "
            "small-deflection tip stiffness",
            "N m/rad",
            maximum=1e9,
        ),
        ParameterSpec(
            "obstacle.type",
            "parabola",
            "obstacle profile: parabola, catenary, circle, two_circles or ellipse (they open "
            "towards world +y, lowest point at apex_x, apex_y), peg (a pole: a disk at "
            "peg_x, peg_y of radius peg_radius), or scene (the obstacles and friction of "
            "obstacle.scene_file)",
            choices=tuple(SHAPE_PARAMETERS) + (SCENE,),
        ),
        ParameterSpec(
            "obstacle.scene_file",
            "",
            "scene: a scene YAML file (doc/guide/scenes.md) with lengths in metres; a relative "
            "path is taken from the working directory, package://<package>/<path> from the "
            "package's share folder; model rod3d: a 3D scene file (spheres, cylinders, planes "
            "and every planar type as a prism along z)",
        ),
        positive("obstacle.k", 10.0, "parabola: y = apex_y + k (x - apex_x)^2 / 2", "1/m"),
        positive("obstacle.c", 0.06, "catenary: y = apex_y + c (cosh((x - apex_x)/c) - 1)", "m"),
        positive(
            "obstacle.radius",
            0.1,
            "circle: radius (lower arc of the circle through the apex)",
            "m",
        ),
        positive(
            "obstacle.radius_left", 0.08, "two_circles: radius of the arc left of the apex", "m"
        ),
        positive(
            "obstacle.radius_right", 0.16, "two_circles: radius of the arc right of the apex", "m"
        ),
        positive("obstacle.a", 0.14, "ellipse: semi-axis along x", "m"),
        positive("obstacle.b", 0.09, "ellipse: semi-axis along y", "m"),
        ParameterSpec("obstacle.peg_x", 0.0, "peg: x of its centre in the world frame", "m"),
        ParameterSpec("obstacle.peg_y", 0.05, "peg: y of its centre in the world frame", "m"),
        nonnegative("obstacle.peg_radius", 0.0, "peg: radius of the pole (0: a point)", "m"),
        ParameterSpec(
            "obstacle.apex_x", 0.0, "x of the obstacle's lowest point in the world frame", "m"
        ),
        ParameterSpec(
            "obstacle.apex_y",
            0.03,
            "y of the obstacle's lowest point in the world frame (p0 = apex_y / length for "
            "a foot on the world x-axis)",
            "m",
        ),
    )
    + _FRAMES
    + (
        ParameterSpec(
            "centerline.points",
            41,
            "number of points of the published centerline",
            minimum=2,
            maximum=10000,
            resets=False,
        ),
        nonnegative(
            "centerline.max_rate",
            30.0,
            "highest rate of the centerline topic (a visualization: it costs more than all "
            "other outputs together); 0 publishes it for every pose",
            "Hz",
            maximum=1e6,
            resets=False,
        ),
    )
    + _INPUT
    + (
        ParameterSpec(
            "noise.enabled",
            False,
            "add the seeded sensor-noise model to the published " "wrench",
            resets=False,
        ),
        ParameterSpec(
            "noise.seed",
            0,
            "seed of the sensor-noise generator (the same seed, the same " "readings)",
            minimum=0,
            maximum=2**62,
            resets=False,
        ),
        nonnegative(
            "noise.force_stddev",
            0.0,
            "standard deviation of the Gaussian noise on force x and y",
            "N",
            resets=False,
        ),
        nonnegative(
            "noise.torque_stddev",
            0.0,
            "standard deviation of the Gaussian noise on torque z",
            "N m",
            resets=False,
        ),
        ParameterSpec("noise.force_bias_x", 0.0, "constant bias of force x", "N", resets=False),
        ParameterSpec("noise.force_bias_y", 0.0, "constant bias of force y", "N", resets=False),
        ParameterSpec("noise.torque_bias", 0.0, "constant bias of torque z", "N m", resets=False),
        nonnegative(
            "noise.force_step", 0.0, "quantization step of the force (0: none)", "N", resets=False
        ),
        nonnegative(
            "noise.torque_step",
            0.0,
            "quantization step of the torque (0: none)",
            "N m",
            resets=False,
        ),
        ParameterSpec(
            "record.path",
            "",
            "record every input pose and output topic to this MCAP file (rosbag2 layout); "
            "empty: off. Setting it at runtime starts a new recording, '' finishes the "
            "current one",
            resets=False,
        ),
        positive(
            "diagnostics.period",
            1.0,
            "period of the /diagnostics status",
            "s",
            maximum=3600.0,
            read_only=True,
            resets=False,
        ),
    )
)

SPECS: Dict[str, ParameterSpec] = {spec.name: spec for spec in PARAMETERS}


@dataclass(frozen=True)
class WhiskerConfig:
    """
    A validated configuration of whisker_node and the core objects it builds (dimensionless).

    Made by :func:`build_config`; the parameters are the dataclass's fields, kept as attributes
    of the same names.

    Parameters
    ----------
    values : mapping of str to object
        The validated parameter values by name (SI units), defaults filled in.
    profile : ConvexProfile or None
        The obstacle in whisker lengths; for a scene, its one profile or peg when it has no
        friction (the single-contact problem), else None.
    model : object
        The whisker model the tracker uses (elastica, rigid or the general model).
    units : Units
        The scales between SI and the core's dimensionless units.
    scene : Scene or None, optional
        ``obstacle.type`` = scene: the scene (whisker lengths); None otherwise.
    scene_text : str, optional
        The scene file's text.
    friction : tuple of float, optional
        The scene's Coulomb coefficients, one per obstacle.
    shape : WhiskerShape, optional
        The whisker's shape (taper, intrinsic curvature) for the scene tracker and the models.
    scene3d : Scene3D or None, optional
        ``model`` = rod3d: the 3D scene (whisker lengths); None otherwise.
    rod_shape : RodShape or None, optional
        ``model`` = rod3d: the 3D whisker's shape (taper, intrinsic curvature or parabola,
        Poisson ratio; dimensionless); None otherwise.

    """

    values: Mapping[str, Any]
    profile: Optional[ConvexProfile]
    model: Any
    units: Units
    #: obstacle.type = scene: the scene (whisker lengths), its file's text, its friction
    #: coefficients (one per obstacle) and the whisker's shape for the scene tracker
    scene: Optional[Scene] = None
    scene_text: str = ""
    friction: Tuple[float, ...] = ()
    shape: WhiskerShape = WhiskerShape()
    #: model = rod3d: the 3D scene (whisker lengths) and the 3D whisker's shape
    scene3d: Optional[Scene3D] = None
    rod_shape: Optional[RodShape] = None

    @property
    def rod3d(self) -> bool:
        """Tell whether the 3D whisker runs (``model`` = rod3d)."""
        return self.scene3d is not None

    @property
    def roll(self) -> float:
        """Return the whisker's roll about its own axis relative to the base frame [rad]."""
        return float(self.values["whisker.roll"])

    @property
    def multi_contact(self) -> bool:
        """
        Whether the scene tracker runs (several obstacles, or friction).

        A scene of one profile or peg without friction is the single-contact problem: its
        :attr:`profile` is set and the single-contact tracker runs, as ``vibrissa scan --scene``
        does.
        """
        return self.scene is not None and self.profile is None

    @property
    def record_values(self) -> Dict[str, Any]:
        """Return the parameter values as a log records them (a scene's text included)."""
        values = dict(self.values)
        if self.scene is not None or self.scene3d is not None:
            values[SCENE_TEXT] = self.scene_text
        return values

    @property
    def world_frame(self) -> str:
        return self.values["world_frame"]

    @property
    def base_frame(self) -> str:
        return self.values["base_frame"]

    def fresh_model(self):
        """
        Return the model for a new tracker.

        The general model keeps warm starts, so a reset whisker gets its own: the same poses then
        give the same numbers as a fresh core run.
        """
        if isinstance(self.model, GeneralWhiskerModel):
            return GeneralWhiskerModel(self.model.shape, self.model.n)
        return self.model

    def describe(self) -> str:
        """One line: model, length, obstacle and where its apex is."""
        v = self.values
        if self.scene3d is not None:
            return self._describe_rod3d()
        if self.scene is not None:
            return self._describe_whisker() + (
                f", obstacle.scene_file {v['obstacle.scene_file']!r}: "
                f"{self.scene.describe()} (lengths in L) in '{v['world_frame']}'")
        shape = ", ".join(f"{node}={v[node]!r} {SPECS[node].unit}"
                          for _, node in SHAPE_PARAMETERS[v["obstacle.type"]])
        if v["obstacle.type"] == "peg":
            where = f"centred at ({v['obstacle.peg_x']!r}, {v['obstacle.peg_y']!r}) m"
        else:
            where = f"with apex at ({v['obstacle.apex_x']!r}, {v['obstacle.apex_y']!r}) m"
        return (
            f"{self._describe_whisker()}, obstacle "
            f"{v['obstacle.type']} ({shape}) {where} in '{v['world_frame']}'"
        )

    def _describe_rod3d(self) -> str:
        v, shape = self.values, self.rod_shape
        ei = self.units.moment * self.units.length
        if shape.parabola is not None:
            curve = f"parabola A={v['whisker.parabola']!r} 1/m"
        else:
            curve = (f"k0={v['whisker.curvature_k0']!r} 1/m, "
                     f"k1={v['whisker.curvature_k1']!r} 1/m^2")
        tolerance = v["solver.points_tolerance"]
        coarse = (f", points_tolerance={tolerance!r} L" if tolerance != POINTS_TOLERANCE
                  else "")
        return (f"rod3d whisker L={v['whisker.length']!r} m, taper={v['whisker.taper']!r}, "
                f"{curve}, roll={v['whisker.roll']!r} rad, EI={ei!r} N m^2, "
                f"nu={shape.poisson!r}{coarse}, obstacle.scene_file "
                f"{v['obstacle.scene_file']!r}: {self.scene3d.describe()} (lengths in L) in "
                f"'{v['world_frame']}'")

    def _describe_whisker(self) -> str:
        v = self.values
        whisker = ""
        ei = self.units.moment * self.units.length
        if v["model"] != "rigid":
            solver = "scene tracker" if self.multi_contact else self.model.name
            whisker = (f", taper={v['whisker.taper']!r}, k0={v['whisker.curvature_k0']!r} 1/m, "
                       f"k1={v['whisker.curvature_k1']!r} 1/m^2, EI={ei!r} N m^2 ({solver})")
        return f"{v['model']} whisker L={v['whisker.length']!r} m{whisker}"


def build_config(values: Mapping[str, Any]) -> WhiskerConfig:
    """
    Validate whisker_node's parameter values (SI); build the core's profile, model and units.

    Parameters
    ----------
    values : mapping of str to object
        Parameter values by name (SI units). Values missing take their defaults; keys that are
        not parameters (a log's ``node``, ``resets``) are ignored.

    Returns
    -------
    WhiskerConfig
        The validated configuration, with the core's profile (or scene), model and units.

    Raises
    ------
    ParameterError
        Naming the parameter, its value and what is allowed.

    """
    recorded_scene = values.get(SCENE_TEXT)
    values = validate(PARAMETERS, values)
    length = values["whisker.length"]
    if values["model"] == ROD3D:
        return _rod3d_config(values, recorded_scene)
    _check_planar(values)
    if values["obstacle.type"] == SCENE:
        return _scene_config(values, recorded_scene)
    if values["obstacle.type"] == "peg":
        profile = Peg(values["obstacle.peg_x"] / length, values["obstacle.peg_y"] / length,
                      values["obstacle.peg_radius"] / length, scan_checks=False)
    else:
        params = {"p0": values["obstacle.apex_y"] / length}
        for core_name, node_name in SHAPE_PARAMETERS[values["obstacle.type"]]:
            size = values[node_name]
            params[core_name] = size * length if SPECS[node_name].unit == "1/m" else size / length
        profile = make_profile(values["obstacle.type"], params, scan_checks=False)
        profile = profile.placed(values["obstacle.apex_x"] / length, 0.0, 0.0)
    shape = whisker_shape(values)
    if values["model"] == "elastica":
        units = Units.elastica(length, base_stiffness(values))
        model = whisker_model(shape, profile)
    else:
        if not shape.is_paper:
            raise ParameterError(
                f"model = 'rigid' is a rigid whisker on a spring (paper §3): it has no taper or "
                f"intrinsic curvature (whisker.taper = {values['whisker.taper']!r}, "
                f"whisker.curvature_k0 = {values['whisker.curvature_k0']!r}, "
                f"whisker.curvature_k1 = {values['whisker.curvature_k1']!r}); use model "
                f"'elastica' or taper 1 and curvature 0")
        if isinstance(profile, Peg):
            raise ParameterError("obstacle.type = 'peg' needs model 'elastica' (the rigid model "
                                 "covers the paper's convex profiles only)")
        units = Units.rigid(length, values["rigid.spring_stiffness"])
        model = make_model(values["model"])
    return WhiskerConfig(values, profile, model, units, shape=shape)


def resolve_scene_file(path: str) -> str:
    """
    Return the file ``obstacle.scene_file`` names.

    ``package://<package>/<path>``: in the package's share folder (the ament index, as after
    sourcing a workspace); ``~`` is expanded; a relative path is taken from the working directory.
    Raises :class:`ParameterError` with the reason.
    """
    if not path.strip():
        raise ParameterError("obstacle.type = 'scene' needs obstacle.scene_file: the path of a "
                             "scene YAML file with lengths in metres")
    if path.startswith("package://"):
        package, _, rest = path[len("package://"):].partition("/")
        if not package or not rest:
            raise ParameterError(f"obstacle.scene_file = {path!r}: a package path is "
                                 "package://<package>/<path in its share folder>")
        try:
            from ament_index_python.packages import (
                PackageNotFoundError,
                get_package_share_directory,
            )
        except ImportError as exc:  # pragma: no cover - a dependency of the package
            raise ParameterError(f"obstacle.scene_file = {path!r}: package paths need "
                                 f"ament_index_python ({exc})") from None
        try:
            share = get_package_share_directory(package)
        except (PackageNotFoundError, LookupError, ValueError, OSError) as exc:
            share = _own_share(package)
            if share is None:
                raise ParameterError(f"obstacle.scene_file = {path!r}: package {package!r} is "
                                     f"not in the ament index ({exc}); source its workspace or "
                                     "give a file path") from None
        return os.path.join(share, rest)
    return os.path.abspath(os.path.expanduser(path))


def _own_share(package: str) -> Optional[str]:
    """
    Return this package's share folder without the ament index, or None.

    A pip install puts it under the environment's prefix; a source checkout (editable install)
    has the same layout (config/, launch/, package.xml) at its root.
    """
    if package != "vibrissa_ros":
        return None
    import sys

    # this file is <checkout>/vibrissa_ros/node/config.py
    checkout = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    for folder in (os.path.join(sys.prefix, "share", package), checkout):
        if os.path.isfile(os.path.join(folder, "package.xml")):
            return folder
    return None


def _check_planar(values: Mapping[str, Any]) -> None:
    """Refuse the 3D whisker's own parameters with a planar model (they would be ignored)."""
    for name, unit in (("whisker.parabola", "1/m"), ("whisker.roll", "rad")):
        if values[name] != 0.0:
            raise ParameterError(
                f"{name} = {values[name]!r} {unit} is a parameter of the 3D whisker: it needs "
                f"model 'rod3d' (model is {values['model']!r}; the planar whisker bends in its "
                "base frame's x-y plane with the curvature curvature_k0 + curvature_k1 s)")
    tolerance = values["solver.points_tolerance"]
    if tolerance != POINTS_TOLERANCE:
        raise ParameterError(
            f"solver.points_tolerance = {tolerance!r} is a parameter of the 3D whisker: it "
            f"needs model 'rod3d' (model is {values['model']!r}; the planar models are exact "
            f"closed forms or solved to their own tolerance; leave it at {POINTS_TOLERANCE!r})")


def _scene_text(values: Mapping[str, Any], recorded: Optional[str]) -> str:
    """Return the text of obstacle.scene_file (``recorded``: a log's record of it, if any)."""
    if isinstance(recorded, str):
        return recorded
    name = values["obstacle.scene_file"]
    path = resolve_scene_file(name)
    try:
        with open(path, encoding="utf-8") as stream:
            return stream.read()
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc)
        raise ParameterError(f"obstacle.scene_file = {name!r}: cannot read {path!r}: "
                             f"{reason}") from None


def _load_scene(loader, values: Mapping[str, Any], text: str):
    """Read a scene's text with ``loader`` in metres; errors name obstacle.scene_file."""
    try:
        # YAML text (a path never reaches here): the file's lines, or a log's record of them
        return loader(text if "\n" in text else text + "\n",
                      length_scale=values["whisker.length"])
    except ParameterError as exc:
        reason = str(exc)
        if reason.startswith("scene text: "):
            reason = reason[len("scene text: "):]
        raise ParameterError(f"obstacle.scene_file = {values['obstacle.scene_file']!r}: "
                             f"{reason}") from None


def _scene_config(values: Dict[str, Any], recorded: Optional[str]) -> WhiskerConfig:
    """Build the configuration of obstacle.type = scene (``recorded``: a log's scene text)."""
    from ..scan.scene_file import load_scene

    if values["model"] != "elastica":
        raise ParameterError("obstacle.type = 'scene' needs model 'elastica' (the rigid model has "
                             "one obstacle and one contact)")
    text = _scene_text(values, recorded)
    scene = _load_scene(load_scene, values, text)
    shape = whisker_shape(values)
    friction = tuple(scene.mu_of(i) for i in range(len(scene)))
    units = Units.elastica(values["whisker.length"], base_stiffness(values))
    single = scene.single_profile() if not any(friction) else None
    # one profile or peg without friction: the single-contact problem, solved as for pegs and
    # profiles (identical numbers); otherwise the scene tracker (its model: the general one)
    model = whisker_model(shape, single) if single is not None else GeneralWhiskerModel(shape)
    return WhiskerConfig(values, single, model, units, scene, text, friction, shape)


def _rod3d_config(values: Dict[str, Any], recorded: Optional[str]) -> WhiskerConfig:
    """Build the configuration of model = rod3d (``recorded``: a log's scene text)."""
    from ..scan.scene_file import load_scene3d

    if values["obstacle.type"] != SCENE:
        raise ParameterError(
            f"model = 'rod3d' needs obstacle.type 'scene' (it is {values['obstacle.type']!r}): "
            "the 3D whisker's obstacles come from a scene file in metres (obstacle.scene_file: "
            "spheres, cylinders, planes, and every planar type as a prism along z)")
    if values["noise.enabled"]:
        raise ParameterError("noise.enabled = True is not allowed with model 'rod3d': the "
                             "sensor-noise model is planar (force x, y and torque z)")
    ei = base_stiffness(values)
    shape = rod_shape(values, ei)
    text = _scene_text(values, recorded)
    scene = _load_scene(load_scene3d, values, text)
    units = Units.elastica(values["whisker.length"], ei)
    return WhiskerConfig(values, None, None, units, scene_text=text, scene3d=scene,
                         rod_shape=shape)


def rod_shape(values: Mapping[str, Any], bending_stiffness: float) -> RodShape:
    """
    Return the 3D whisker's shape in whisker lengths from the node's parameters (SI).

    Parameters
    ----------
    values : mapping of str to object
        Validated parameter values (SI): ``whisker.taper``, ``whisker.curvature_k0``,
        ``whisker.curvature_k1``, ``whisker.parabola``, ``whisker.poisson`` and
        ``whisker.torsional_stiffness``.
    bending_stiffness : float
        EI at the base [N m^2] (:func:`base_stiffness`).

    Returns
    -------
    RodShape
        Taper, k0 L and k1 L^2 or the parabola's A L, and the Poisson ratio (from
        ``whisker.torsional_stiffness`` GJ > 0: nu = EI / GJ - 1).

    Raises
    ------
    ParameterError
        One line naming the parameters: poisson and torsional_stiffness both given, nu out of
        [0, 0.5], parabola together with a curvature, or a shape out of the core's range.

    """
    length = values["whisker.length"]
    nu, gj = values["whisker.poisson"], values["whisker.torsional_stiffness"]
    if gj > 0.0:
        if nu != SPECS["whisker.poisson"].default:
            raise ParameterError(
                f"whisker.torsional_stiffness = {gj!r} N m^2 and whisker.poisson = {nu!r} both "
                "set the torsional stiffness (nu = EI/GJ - 1): give one of the two, not both")
        nu = bending_stiffness / gj - 1.0
        if -NU_TOLERANCE <= nu < 0.0 or 0.5 < nu <= 0.5 + NU_TOLERANCE:
            nu = min(max(nu, 0.0), 0.5)  # rounding of EI / GJ at the ends of the range
        if not 0.0 <= nu <= 0.5:
            raise ParameterError(
                f"whisker.torsional_stiffness = {gj!r} N m^2 gives nu = EI/GJ - 1 = {nu!r} with "
                f"EI = {bending_stiffness!r} N m^2: nu must be in [0, 0.5], GJ in [EI/1.5, EI] = "
                f"[{bending_stiffness / 1.5!r}, {bending_stiffness!r}] N m^2")
    k0, k1, a = (values["whisker.curvature_k0"], values["whisker.curvature_k1"],
                 values["whisker.parabola"])
    if a != 0.0 and (k0 != 0.0 or k1 != 0.0):
        raise ParameterError(
            f"whisker.parabola = {a!r} 1/m and whisker.curvature_k0 = {k0!r} 1/m, "
            f"whisker.curvature_k1 = {k1!r} 1/m^2 both give the intrinsic shape: give the "
            "parabola or the curvature, not both")
    try:
        return RodShape(values["whisker.taper"], k0 * length, k1 * length**2,
                        parabola=a * length if a != 0.0 else None, poisson=nu)
    except ParameterError as exc:
        if a != 0.0:
            what = f"whisker.parabola = {a!r} 1/m (A L = {a * length!r})"
        else:
            what = (f"whisker.curvature_k0 = {k0!r} 1/m, whisker.curvature_k1 = {k1!r} 1/m^2 "
                    f"(k0 L = {k0 * length!r}, k1 L^2 = {k1 * length**2!r})")
        raise ParameterError(f"{what}: {exc}") from None


def base_stiffness(values: Mapping[str, Any]) -> float:
    """
    Return EI at the whisker's base [N m^2]: ``whisker.bending_stiffness``, or E pi r^4 / 4.

    With ``whisker.youngs_modulus`` E > 0, ``whisker.base_radius`` r must be > 0 and
    ``whisker.bending_stiffness`` must be left at its default or agree with E pi r^4 / 4 to
    :data:`EI_TOLERANCE` (relative); otherwise :class:`ParameterError` says which to drop.
    """
    ei, modulus, radius = (values["whisker.bending_stiffness"], values["whisker.youngs_modulus"],
                           values["whisker.base_radius"])
    if modulus == 0.0:
        return ei
    if radius <= 0.0:
        raise ParameterError(f"whisker.youngs_modulus = {modulus!r} Pa needs whisker.base_radius "
                             f"> 0 m (it is {radius!r}); or set youngs_modulus 0 and give "
                             "whisker.bending_stiffness")
    from_modulus = modulus * math.pi * radius**4 / 4.0
    default = SPECS["whisker.bending_stiffness"].default
    if ei != default and abs(ei - from_modulus) > EI_TOLERANCE * from_modulus:
        raise ParameterError(
            f"whisker.bending_stiffness = {ei!r} N m^2 disagrees with whisker.youngs_modulus = "
            f"{modulus!r} Pa and whisker.base_radius = {radius!r} m (E pi r^4 / 4 = "
            f"{from_modulus!r} N m^2): give one of the two, not both")
    return from_modulus


def whisker_shape(values: Mapping[str, Any]) -> WhiskerShape:
    """Return the whisker's taper and intrinsic curvature in whisker lengths (k0 L, k1 L^2)."""
    length = values["whisker.length"]
    k0, k1 = values["whisker.curvature_k0"] * length, values["whisker.curvature_k1"] * length**2
    try:
        return WhiskerShape(values["whisker.taper"], k0, k1)
    except ParameterError as exc:
        raise ParameterError(
            f"whisker.curvature_k0 = {values['whisker.curvature_k0']!r} 1/m, "
            f"whisker.curvature_k1 = {values['whisker.curvature_k1']!r} 1/m^2 (k0 L = {k0!r}, "
            f"k1 L^2 = {k1!r}): {exc}") from None


def whisker_model(shape: WhiskerShape, profile: ConvexProfile):
    """
    Return the model ``vibrissa scan --solver auto`` picks.

    The exact elastica for a uniform straight whisker against a convex profile, the general
    (Chebyshev collocation) model otherwise.
    """
    if shape.is_paper and not isinstance(profile, Peg):
        return make_model("elastica")
    return GeneralWhiskerModel(shape)


#: contour_node's parameters
CONTOUR_PARAMETERS: Tuple[ParameterSpec, ...] = _WHISKER + _FRAMES + _INPUT + (
    nonnegative("min_force", 0.0, "readings with a smaller force are taken as no contact "
                "(noisy sensors)", "N", resets=False),
    nonnegative("max_pose_age", 0.1, "largest age of the pose paired with a wrench that has no "
                "pose of its own stamp", "s", maximum=3600.0, resets=False),
    ParameterSpec("max_points", 100000, "points kept in the accumulated contour", minimum=1,
                  maximum=10_000_000, resets=False),
)
CONTOUR_SPECS: Dict[str, ParameterSpec] = {spec.name: spec for spec in CONTOUR_PARAMETERS}


@dataclass(frozen=True)
class ContourConfig:
    """
    A validated configuration of contour_node.

    Made by :func:`build_contour_config`; the parameters are the dataclass's fields, kept as
    attributes of the same names.

    Parameters
    ----------
    values : mapping of str to object
        The validated parameter values by name (SI units), defaults filled in.
    units : Units
        The scales between SI and the core's dimensionless units (elastica).
    shape : WhiskerShape, optional
        The whisker's shape (taper, intrinsic curvature).

    """

    values: Mapping[str, Any]
    units: Units
    shape: WhiskerShape = WhiskerShape()

    @property
    def world_frame(self) -> str:
        return self.values["world_frame"]

    @property
    def base_frame(self) -> str:
        return self.values["base_frame"]

    @property
    def max_pose_age_ns(self) -> int:
        return int(self.values["max_pose_age"] * NS_PER_S)

    def describe(self) -> str:
        """One line: the whisker and the frames."""
        v = self.values
        ei = self.units.moment * self.units.length
        return (
            f"elastica whisker L={v['whisker.length']!r} m, EI={ei!r}"
            f" N m^2, taper={v['whisker.taper']!r}, k0={v['whisker.curvature_k0']!r} 1/m, "
            f"k1={v['whisker.curvature_k1']!r} 1/m^2; poses in '{v['world_frame']}', wrenches in "
            f"'{v['base_frame']}'"
        )


def build_contour_config(values: Mapping[str, Any]) -> ContourConfig:
    """
    Validate contour_node's parameter values; raises :class:`ParameterError` with the reason.

    Parameters
    ----------
    values : mapping of str to object
        Parameter values by name (SI units); values missing take their defaults.

    Returns
    -------
    ContourConfig
        The validated configuration.

    Raises
    ------
    ParameterError
        With the reason: the parameter, its value and what is allowed.

    """
    values = validate(CONTOUR_PARAMETERS, values)
    return ContourConfig(values, Units.elastica(values["whisker.length"], base_stiffness(values)),
                         whisker_shape(values))


__all__ = ["PARAMETERS", "SPECS", "SCENE", "SCENE_TEXT", "ROD3D", "resolve_scene_file",
           "rod_shape",
           "CONTOUR_PARAMETERS", "CONTOUR_SPECS", "WhiskerConfig",
           "ContourConfig", "build_config", "build_contour_config", "ParameterError"]
