"""
The two nodes' parameters: names, SI units, defaults, ranges, and the configurations they build.

No rclpy here. The names are a contract (tests, parameter files and users rely on them); the
machinery (types, ranges, reasons) is :mod:`vibrissa_ros.parameters`, shared by both nodes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Dict, Mapping, Tuple

from .core.errors import ParameterError
from .core.models import make_model
from .core.profiles import ConvexProfile, make_profile
from .edge import NS_PER_S, Units
from .parameters import ParameterSpec, nonnegative, positive, validate

MODELS = ("elastica", "rigid")
#: obstacle type -> (core parameter name, node parameter name) of its shape parameters
SHAPE_PARAMETERS = {
    "parabola": (("k", "obstacle.k"),),
    "catenary": (("c", "obstacle.c"),),
    "circle": (("R", "obstacle.radius"),),
    "two_circles": (("R_left", "obstacle.radius_left"), ("R_right", "obstacle.radius_right")),
    "ellipse": (("a", "obstacle.a"), ("b", "obstacle.b")),
}


def _frame(name: str, default: str, description: str) -> ParameterSpec:
    return ParameterSpec(name, default, description, read_only=True, nonempty=True, resets=False)


_WHISKER = (
    positive("whisker.length", 0.1, "length L of the whisker", "m", maximum=1e3),
    positive("whisker.bending_stiffness", 5e-4, "bending stiffness EI of the whisker (elastica)",
             "N m^2", maximum=1e9),
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
    + (
        ParameterSpec(
            "model",
            "elastica",
            "whisker model: 'elastica' (paper §2) or 'rigid' (paper §3)",
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
            "obstacle profile: parabola, catenary, circle, two_circles or ellipse; it opens "
            "towards world +y",
            choices=tuple(SHAPE_PARAMETERS),
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
    """A validated configuration of whisker_node and the core objects it builds (dimensionless)."""

    values: Mapping[str, Any]
    profile: ConvexProfile
    model: Any
    units: Units

    @property
    def world_frame(self) -> str:
        return self.values["world_frame"]

    @property
    def base_frame(self) -> str:
        return self.values["base_frame"]

    def describe(self) -> str:
        """One line: model, length, obstacle and where its apex is."""
        v = self.values
        shape = ", ".join(f"{node}={v[node]!r} {SPECS[node].unit}"
                          for _, node in SHAPE_PARAMETERS[v["obstacle.type"]])
        return (
            f"{v['model']} whisker L={v['whisker.length']!r} m, obstacle {v['obstacle.type']} "
            f"({shape}) with apex at ({v['obstacle.apex_x']!r}, {v['obstacle.apex_y']!r}) m in "
            f"'{v['world_frame']}'"
        )


def build_config(values: Mapping[str, Any]) -> WhiskerConfig:
    """
    Validate whisker_node's parameter values (SI); build the core's profile, model and units.

    Values missing from ``values`` take their defaults; keys that are not parameters (a log's
    ``node``, ``resets``) are ignored. Raises :class:`ParameterError` naming the parameter, its
    value and what is allowed.
    """
    values = validate(PARAMETERS, values)
    length = values["whisker.length"]
    if values["model"] == "elastica":
        units = Units.elastica(length, values["whisker.bending_stiffness"])
    else:
        units = Units.rigid(length, values["rigid.spring_stiffness"])
    model = make_model(values["model"])
    params = {"p0": values["obstacle.apex_y"] / length}
    for core_name, node_name in SHAPE_PARAMETERS[values["obstacle.type"]]:
        size = values[node_name]
        params[core_name] = size * length if SPECS[node_name].unit == "1/m" else size / length
    profile = make_profile(values["obstacle.type"], params, scan_checks=False)
    return WhiskerConfig(values, profile.placed(values["obstacle.apex_x"] / length, 0.0, 0.0),
                         model, units)


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
    """A validated configuration of contour_node."""

    values: Mapping[str, Any]
    units: Units

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
        return (
            f"elastica whisker L={v['whisker.length']!r} m, EI={v['whisker.bending_stiffness']!r}"
            f" N m^2; poses in '{v['world_frame']}', wrenches in '{v['base_frame']}'"
        )


def build_contour_config(values: Mapping[str, Any]) -> ContourConfig:
    """Validate contour_node's parameter values; raises :class:`ParameterError` with the reason."""
    values = validate(CONTOUR_PARAMETERS, values)
    return ContourConfig(values, Units.elastica(values["whisker.length"],
                                                values["whisker.bending_stiffness"]))


__all__ = ["PARAMETERS", "SPECS", "CONTOUR_PARAMETERS", "CONTOUR_SPECS", "WhiskerConfig",
           "ContourConfig", "build_config", "build_contour_config", "ParameterError"]
