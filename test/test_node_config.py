"""The node's parameter contract and what it builds (no ROS needed)."""

import math

import pytest

from vibrissa_ros.core import ParameterError, PlacedProfile
from vibrissa_ros.node_config import PARAMETERS, SPECS, build_config

CONTRACT = [
    "whisker.length", "whisker.bending_stiffness", "model", "rigid.spring_stiffness", "obstacle.type",
    "obstacle.k", "obstacle.c", "obstacle.radius", "obstacle.radius_left", "obstacle.radius_right",
    "obstacle.a", "obstacle.b", "obstacle.apex_x", "obstacle.apex_y", "world_frame", "base_frame",
]


def test_contract_names_are_declared_with_units_and_descriptions():
    for name in CONTRACT:
        assert name in SPECS, name
        assert SPECS[name].description
    for name in ("whisker.length", "obstacle.k", "obstacle.apex_x", "rigid.spring_stiffness"):
        assert SPECS[name].unit
    assert SPECS["obstacle.k"].unit == "1/m"
    assert SPECS["world_frame"].read_only and SPECS["base_frame"].read_only


def test_defaults_build_the_papers_parabola_in_whisker_units():
    cfg = build_config({})
    assert cfg.units.length == 0.1
    assert cfg.units.force == pytest.approx(5e-4 / 0.01) and cfg.units.moment == pytest.approx(5e-3)
    assert cfg.profile.params == {"p0": pytest.approx(0.3), "k": pytest.approx(1.0)}
    assert cfg.model.name == "elastica"


@pytest.mark.parametrize(
    "kind, extra, core",
    [
        ("catenary", {"obstacle.c": 0.06}, {"c": 0.6}),
        ("circle", {"obstacle.radius": 0.2}, {"R": 2.0}),
        ("two_circles", {"obstacle.radius_left": 0.08, "obstacle.radius_right": 0.16}, {"R_left": 0.8, "R_right": 1.6}),
        ("ellipse", {"obstacle.a": 0.14, "obstacle.b": 0.09}, {"a": 1.4, "b": 0.9}),
    ],
)
def test_shapes_are_converted_to_whisker_lengths_and_placed_at_the_apex(kind, extra, core):
    cfg = build_config({"obstacle.type": kind, "obstacle.apex_x": 0.25, "obstacle.apex_y": 0.5, **extra})
    assert isinstance(cfg.profile, PlacedProfile)
    for key, value in core.items():
        assert cfg.profile.params[key] == pytest.approx(value)
    assert cfg.profile.point(0.0) == pytest.approx((2.5, 5.0))  # apex, in L, even far from the foot line


def test_rigid_model_uses_the_spring_stiffness():
    cfg = build_config({"model": "rigid", "rigid.spring_stiffness": 0.03})
    assert cfg.model.name == "rigid"
    assert cfg.units.moment == 0.03 and cfg.units.force == pytest.approx(0.3)


@pytest.mark.parametrize(
    "values, words",
    [
        ({"whisker.length": 0.0}, ["whisker.length", "> 0"]),
        ({"whisker.bending_stiffness": -1.0}, ["whisker.bending_stiffness", "> 0"]),
        ({"model": "beam"}, ["model", "'elastica', 'rigid'"]),
        ({"model": "rigid", "rigid.spring_stiffness": 0.0}, ["rigid.spring_stiffness", "> 0"]),
        ({"obstacle.type": "cone"}, ["obstacle.type", "allowed", "ellipse"]),
        ({"obstacle.k": -2.0}, ["obstacle.k", "1/m", "> 0"]),
        ({"obstacle.type": "circle", "obstacle.radius": 0.0}, ["obstacle.radius", "> 0"]),
        ({"obstacle.apex_y": math.nan}, ["obstacle.apex_y", "finite"]),
        ({"world_frame": ""}, ["world_frame", "frame id"]),
        ({"centerline.points": 1}, ["centerline.points", "[2, 10000]"]),
    ],
)
def test_bad_values_are_rejected_with_the_reason(values, words):
    with pytest.raises(ParameterError) as info:
        build_config(values)
    for word in words:
        assert word in str(info.value)


def test_every_parameter_has_a_default_of_its_type():
    for spec in PARAMETERS:
        assert isinstance(spec.default, (bool, int, float, str))
