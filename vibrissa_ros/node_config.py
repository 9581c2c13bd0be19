"""The whisker node's parameters: names, SI units, defaults, validation and what they build.

No rclpy here. The names are a contract (tests, parameter files and users rely on them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Dict, Mapping, Optional, Tuple

from .core.errors import ParameterError
from .core.models import make_model
from .core.profiles import ConvexProfile, make_profile
from .frames import Units


@dataclass(frozen=True)
class ParameterSpec:
    """One node parameter: its default (which fixes its type), unit and description."""

    name: str
    default: Any
    description: str
    unit: str = ""
    read_only: bool = False
    minimum: Optional[float] = None
    maximum: Optional[float] = None
    resets: bool = True  # a runtime change rebuilds the whisker (free state)


PARAMETERS: Tuple[ParameterSpec, ...] = (
    ParameterSpec("whisker.length", 0.1, "length L of the whisker", "m", minimum=1e-6, maximum=1e3),
    ParameterSpec("whisker.bending_stiffness", 5e-4, "bending stiffness EI of the whisker (elastica)", "N m^2",
                  minimum=1e-15, maximum=1e9),
    ParameterSpec("model", "elastica", "whisker model: 'elastica' (paper §2) or 'rigid' (paper §3)"),
    ParameterSpec("rigid.spring_stiffness", 0.015,
                  "pivot stiffness c of the rigid model; c = 3 EI/L matches the elastica's small-deflection "
                  "tip stiffness", "N m/rad", minimum=1e-15, maximum=1e9),
    ParameterSpec("obstacle.type", "parabola",
                  "obstacle profile: parabola, catenary, circle, two_circles or ellipse; it opens towards world +y"),
    ParameterSpec("obstacle.k", 10.0, "parabola: y = apex_y + k (x - apex_x)^2 / 2", "1/m", minimum=0.0),
    ParameterSpec("obstacle.c", 0.06, "catenary: y = apex_y + c (cosh((x - apex_x)/c) - 1)", "m", minimum=0.0),
    ParameterSpec("obstacle.radius", 0.1, "circle: radius (lower arc of the circle through the apex)", "m",
                  minimum=0.0),
    ParameterSpec("obstacle.radius_left", 0.08, "two_circles: radius of the arc left of the apex", "m", minimum=0.0),
    ParameterSpec("obstacle.radius_right", 0.16, "two_circles: radius of the arc right of the apex", "m",
                  minimum=0.0),
    ParameterSpec("obstacle.a", 0.14, "ellipse: semi-axis along x", "m", minimum=0.0),
    ParameterSpec("obstacle.b", 0.09, "ellipse: semi-axis along y", "m", minimum=0.0),
    ParameterSpec("obstacle.apex_x", 0.0, "x of the obstacle's lowest point in the world frame", "m"),
    ParameterSpec("obstacle.apex_y", 0.03,
                  "y of the obstacle's lowest point in the world frame (p0 = apex_y / length for a foot on the "
                  "world x-axis)", "m"),
    ParameterSpec("world_frame", "world", "frame of the foot poses, the obstacle and the contact point",
                  read_only=True, resets=False),
    ParameterSpec("base_frame", "whisker_base",
                  "frame of the whisker's base (REP 103: +x along the undeformed whisker); the wrench is in it",
                  read_only=True, resets=False),
    ParameterSpec("centerline.points", 41, "number of points of the published centerline", minimum=2,
                  maximum=10000, resets=False),
    ParameterSpec("centerline.max_rate", 30.0,
                  "highest rate of the centerline topic (a visualization: it costs more than all other outputs "
                  "together); 0 publishes it for every pose", "Hz", minimum=0.0, maximum=1e6, resets=False),
    ParameterSpec("input.z_tolerance", 1e-6, "largest |z| of an input pose (the whisker moves in z = 0)", "m",
                  minimum=0.0, resets=False),
    ParameterSpec("input.angle_tolerance", 1e-6, "largest |roll|, |pitch| of an input pose", "rad", minimum=0.0,
                  resets=False),
    ParameterSpec("noise.enabled", False, "add the seeded sensor-noise model to the published wrench", resets=False),
    ParameterSpec("noise.seed", 0, "seed of the sensor-noise generator (the same seed, the same readings)",
                  minimum=0, maximum=2**62, resets=False),
    ParameterSpec("noise.force_stddev", 0.0, "standard deviation of the Gaussian noise on force x and y", "N",
                  resets=False),
    ParameterSpec("noise.torque_stddev", 0.0, "standard deviation of the Gaussian noise on torque z", "N m",
                  resets=False),
    ParameterSpec("noise.force_bias_x", 0.0, "constant bias of force x", "N", resets=False),
    ParameterSpec("noise.force_bias_y", 0.0, "constant bias of force y", "N", resets=False),
    ParameterSpec("noise.torque_bias", 0.0, "constant bias of torque z", "N m", resets=False),
    ParameterSpec("noise.force_step", 0.0, "quantization step of the force (0: none)", "N", resets=False),
    ParameterSpec("noise.torque_step", 0.0, "quantization step of the torque (0: none)", "N m", resets=False),
    ParameterSpec("record.path", "",
                  "record every input pose and output topic to this MCAP file (rosbag2 layout); empty: off. "
                  "Setting it at runtime starts a new recording, '' finishes the current one", resets=False),
    ParameterSpec("diagnostics.period", 1.0, "period of the /diagnostics status", "s", minimum=0.01,
                  maximum=3600.0, read_only=True, resets=False),
)

SPECS: Dict[str, ParameterSpec] = {spec.name: spec for spec in PARAMETERS}

#: obstacle type -> (core parameter name, node parameter name) of its shape parameters
SHAPE_PARAMETERS = {
    "parabola": (("k", "obstacle.k"),),
    "catenary": (("c", "obstacle.c"),),
    "circle": (("R", "obstacle.radius"),),
    "two_circles": (("R_left", "obstacle.radius_left"), ("R_right", "obstacle.radius_right")),
    "ellipse": (("a", "obstacle.a"), ("b", "obstacle.b")),
}


@dataclass(frozen=True)
class WhiskerConfig:
    """A validated configuration and the core objects it builds (dimensionless)."""

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
        v = self.values
        shape = ", ".join(f"{node}={v[node]!r} {SPECS[node].unit}" for _, node in SHAPE_PARAMETERS[v["obstacle.type"]])
        return (
            f"{v['model']} whisker L={v['whisker.length']!r} m, obstacle {v['obstacle.type']} ({shape}) with apex at "
            f"({v['obstacle.apex_x']!r}, {v['obstacle.apex_y']!r}) m in '{v['world_frame']}'"
        )


def _finite(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParameterError(f"{name} = {value!r} must be a number")
    value = float(value)
    if not math.isfinite(value):
        raise ParameterError(f"{name} = {value!r} must be finite")
    return value


def _positive(name: str, value: Any, unit: str) -> float:
    value = _finite(name, value)
    if value <= 0.0:
        raise ParameterError(f"{name} = {value!r} {unit} is not allowed: it must be > 0")
    return value


def build_config(values: Mapping[str, Any]) -> WhiskerConfig:
    """Validate a full set of parameter values (SI) and build the core's profile, model and units.

    Raises :class:`ParameterError` naming the parameter, its value and what is allowed.
    """
    values = {spec.name: values.get(spec.name, spec.default) for spec in PARAMETERS}
    length = _positive("whisker.length", values["whisker.length"], "m")
    model_name = values["model"]
    if model_name not in ("elastica", "rigid"):
        raise ParameterError(f"model = {model_name!r} is not allowed; allowed: 'elastica', 'rigid'")
    if model_name == "elastica":
        units = Units.elastica(length, _positive("whisker.bending_stiffness", values["whisker.bending_stiffness"], "N m^2"))
        model = make_model("elastica")
    else:
        units = Units.rigid(length, _positive("rigid.spring_stiffness", values["rigid.spring_stiffness"], "N m/rad"))
        model = make_model("rigid")
    kind = values["obstacle.type"]
    if kind not in SHAPE_PARAMETERS:
        raise ParameterError(f"obstacle.type = {kind!r} is not allowed; allowed: {', '.join(SHAPE_PARAMETERS)}")
    apex_x = _finite("obstacle.apex_x", values["obstacle.apex_x"])
    apex_y = _finite("obstacle.apex_y", values["obstacle.apex_y"])
    params = {"p0": apex_y / length}
    for core_name, node_name in SHAPE_PARAMETERS[kind]:
        unit = SPECS[node_name].unit
        size = _positive(node_name, values[node_name], unit)
        params[core_name] = size * length if unit == "1/m" else size / length
    profile = make_profile(kind, params, scan_checks=False).placed(apex_x / length, 0.0, 0.0)
    for name in ("world_frame", "base_frame"):
        if not isinstance(values[name], str) or not values[name].strip():
            raise ParameterError(f"{name} = {values[name]!r} must be a non-empty frame id")
    points = values["centerline.points"]
    if isinstance(points, bool) or not isinstance(points, int) or not 2 <= points <= 10000:
        raise ParameterError(f"centerline.points = {points!r} must be an integer in [2, 10000]")
    for name in ("input.z_tolerance", "input.angle_tolerance", "centerline.max_rate"):
        if _finite(name, values[name]) < 0.0:
            raise ParameterError(f"{name} = {values[name]!r} must be >= 0")
    _positive("diagnostics.period", values["diagnostics.period"], "s")
    for name in ("noise.force_stddev", "noise.torque_stddev", "noise.force_step", "noise.torque_step"):
        if _finite(name, values[name]) < 0.0:
            raise ParameterError(f"{name} = {values[name]!r} must be >= 0")
    for name in ("noise.force_bias_x", "noise.force_bias_y", "noise.torque_bias"):
        _finite(name, values[name])
    if not isinstance(values["noise.enabled"], bool):
        raise ParameterError(f"noise.enabled = {values['noise.enabled']!r} must be true or false")
    if isinstance(values["noise.seed"], bool) or not isinstance(values["noise.seed"], int) or values["noise.seed"] < 0:
        raise ParameterError(f"noise.seed = {values['noise.seed']!r} must be an integer >= 0")
    if not isinstance(values["record.path"], str):
        raise ParameterError(f"record.path = {values['record.path']!r} must be a file path or ''")
    return WhiskerConfig(values, profile, model, units)
