"""The node's parameter contract and what it builds (no ROS needed)."""

import json
import math
from pathlib import Path

import pytest

from vibrissa_ros.core import ParameterError, PlacedProfile
from vibrissa_ros.core.rod3d import Plane, Sphere
from vibrissa_ros.node.config import PARAMETERS, SPECS, build_config

CONTRACT = [
    "whisker.length", "whisker.bending_stiffness", "model", "rigid.spring_stiffness",
    "obstacle.type", "obstacle.k", "obstacle.c", "obstacle.radius", "obstacle.radius_left",
    "obstacle.radius_right", "obstacle.a", "obstacle.b", "obstacle.apex_x", "obstacle.apex_y",
    "world_frame", "base_frame",
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
    assert (cfg.units.force == pytest.approx(5e-4 / 0.01)
            and cfg.units.moment == pytest.approx(5e-3))
    assert cfg.profile.params == {"p0": pytest.approx(0.3), "k": pytest.approx(1.0)}
    assert cfg.model.name == "elastica"


@pytest.mark.parametrize(
    "kind, extra, core",
    [
        ("catenary", {"obstacle.c": 0.06}, {"c": 0.6}),
        ("circle", {"obstacle.radius": 0.2}, {"R": 2.0}),
        ("two_circles", {"obstacle.radius_left": 0.08, "obstacle.radius_right": 0.16},
         {"R_left": 0.8, "R_right": 1.6}),
        ("ellipse", {"obstacle.a": 0.14, "obstacle.b": 0.09}, {"a": 1.4, "b": 0.9}),
    ],
)
def test_shapes_are_converted_to_whisker_lengths_and_placed_at_the_apex(kind, extra, core):
    cfg = build_config({"obstacle.type": kind, "obstacle.apex_x": 0.25, "obstacle.apex_y": 0.5,
                        **extra})
    assert isinstance(cfg.profile, PlacedProfile)
    for key, value in core.items():
        assert cfg.profile.params[key] == pytest.approx(value)
    # apex, in L, even far from the foot line
    assert cfg.profile.point(0.0) == pytest.approx((2.5, 5.0))


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


RAT = {"whisker.length": 0.03, "whisker.youngs_modulus": 3.3e9, "whisker.base_radius": 5e-5,
       "whisker.taper": 1.0 / 15.0, "whisker.curvature_k0": 1.0 / 0.06,
       "whisker.curvature_k1": -100.0, "obstacle.type": "peg", "obstacle.peg_x": 0.003,
       "obstacle.peg_y": 0.015, "obstacle.peg_radius": 3e-4}


def test_whisker_shape_peg_and_youngs_modulus_build_the_general_model_in_whisker_units():
    cfg = build_config(RAT)
    assert cfg.model.name == "general"
    shape = cfg.model.shape
    assert (shape.taper, shape.k0, shape.k1) == pytest.approx((1 / 15, 0.5, -100.0 * 0.03**2),
                                                              rel=1e-15)
    ei = 3.3e9 * math.pi * 5e-5**4 / 4
    assert cfg.units.moment == pytest.approx(ei / 0.03, rel=1e-15)
    assert cfg.units.force == pytest.approx(ei / 0.03**2, rel=1e-15)
    assert (cfg.profile.name, cfg.profile.x, cfg.profile.y, cfg.profile.r) == (
        "peg", pytest.approx(0.1), pytest.approx(0.5), pytest.approx(0.01))
    assert cfg.fresh_model() is not cfg.model and cfg.fresh_model().shape == shape
    assert "peg" in cfg.describe() and "general" in cfg.describe()


def test_the_model_is_picked_like_scan_solver_auto():
    # the paper's whisker against a convex profile
    assert build_config({}).model.name == "elastica"
    assert build_config({"whisker.taper": 0.5}).model.name == "general"
    assert build_config({"whisker.curvature_k1": 1.0}).model.name == "general"
    # a peg: the general solver
    assert build_config({"obstacle.type": "peg"}).model.name == "general"
    ei = 2e9 * math.pi * 1e-4**4 / 4
    same = build_config({"whisker.youngs_modulus": 2e9, "whisker.base_radius": 1e-4,
                         "whisker.bending_stiffness": ei})
    assert same.units.moment * 0.1 == pytest.approx(ei, rel=1e-12)


@pytest.mark.parametrize(
    "values, words",
    [
        ({"whisker.taper": 0.0}, ["whisker.taper", "> 0.0 and <= 1.0"]),
        ({"whisker.taper": 1.5}, ["whisker.taper", "<= 1.0"]),
        ({"whisker.curvature_k0": 300.0}, ["whisker.curvature_k0", "<= 20"]),
        ({"whisker.youngs_modulus": -1.0}, ["whisker.youngs_modulus", "in [0.0, "]),
        ({"whisker.youngs_modulus": 3e9}, ["whisker.base_radius", "> 0"]),
        ({"whisker.youngs_modulus": 3e9, "whisker.base_radius": 1e-4,
          "whisker.bending_stiffness": 1e-3},
         ["disagrees", "not both"]),
        ({"obstacle.type": "peg", "obstacle.peg_radius": -1e-3}, ["obstacle.peg_radius", ">= 0"]),
        ({"model": "rigid", "whisker.taper": 0.5}, ["rigid", "taper"]),
        ({"model": "rigid", "whisker.curvature_k0": 1.0}, ["rigid", "curvature"]),
        ({"model": "rigid", "obstacle.type": "peg"}, ["peg", "elastica"]),
    ],
)
def test_new_whisker_and_peg_parameters_are_refused_with_a_reason(values, words):
    with pytest.raises(ParameterError) as err:
        build_config(values)
    for word in words:
        assert word in str(err.value)


# -- the 3D whisker (model rod3d) -----------------------------------------------------------------
SPHERE_M = Path(__file__).resolve().parents[1] / "config" / "scene_sphere_m.yaml"
ROD3D = {"model": "rod3d", "whisker.length": 0.03, "whisker.youngs_modulus": 3.3e9,
         "whisker.base_radius": 5e-5, "whisker.taper": 0.5, "whisker.parabola": 10.0,
         "whisker.roll": 0.5, "obstacle.type": "scene", "obstacle.scene_file": str(SPHERE_M)}


def test_rod3d_builds_the_3d_whisker_and_scene_in_whisker_lengths():
    cfg = build_config(ROD3D)
    assert cfg.rod3d and cfg.profile is None and cfg.scene is None
    ei = 3.3e9 * math.pi * 5e-5**4 / 4
    assert cfg.units.force == pytest.approx(ei / 0.03**2, rel=1e-15)
    assert cfg.units.moment == pytest.approx(ei / 0.03, rel=1e-15)
    shape = cfg.rod_shape
    assert (shape.taper, shape.parabola, shape.poisson) == pytest.approx((0.5, 0.3, 0.38),
                                                                         rel=1e-15)
    assert shape.k0 == shape.k1 == 0.0 and cfg.roll == 0.5
    ball, floor = cfg.scene3d
    assert isinstance(ball, Sphere) and isinstance(floor, Plane)
    assert ball.center == pytest.approx((0.02 / 0.03, 0.4, 0.002 / 0.03), rel=1e-15)
    assert ball.r == pytest.approx(0.004 / 0.03, rel=1e-15)
    assert floor.point[2] == pytest.approx(-0.2) and floor.normal == (0.0, 0.0, 1.0)
    assert "rod3d" in cfg.describe() and "sphere" in cfg.describe()


def test_rod3d_torsional_stiffness_gives_the_poisson_ratio():
    ei = 3.3e9 * math.pi * 5e-5**4 / 4
    cfg = build_config(dict(ROD3D, **{"whisker.torsional_stiffness": ei / 1.25}))
    assert cfg.rod_shape.poisson == pytest.approx(0.25, rel=1e-12)
    assert build_config(dict(ROD3D, **{"whisker.torsional_stiffness": ei})).rod_shape.poisson == 0
    curved = build_config(dict(ROD3D, **{"whisker.parabola": 0.0, "whisker.curvature_k0": 20.0,
                                         "whisker.curvature_k1": -100.0}))
    assert (curved.rod_shape.k0, curved.rod_shape.k1) == pytest.approx((0.6, -0.09))
    assert curved.rod_shape.parabola is None


def test_rod3d_configuration_round_trips_through_its_record_without_the_file(tmp_path):
    scene = tmp_path / "sphere.yaml"
    scene.write_text(SPHERE_M.read_text())
    cfg = build_config(dict(ROD3D, **{"obstacle.scene_file": str(scene),
                                      "whisker.poisson": 0.3, "solver.points_tolerance": 1e-8}))
    record = json.loads(json.dumps(cfg.record_values))  # as the log stores it
    scene.unlink()
    again = build_config(record)
    assert again.scene3d == cfg.scene3d and again.rod_shape == cfg.rod_shape
    assert again.units == cfg.units and again.roll == cfg.roll
    assert again.values == cfg.values and again.values["solver.points_tolerance"] == 1e-8
    # a log written before the parameter existed: the default, the resolution it ran at
    del record["solver.points_tolerance"]
    assert build_config(record).values["solver.points_tolerance"] == 1e-11


@pytest.mark.parametrize(
    "values, words",
    [
        ({"whisker.poisson": 0.3, "whisker.torsional_stiffness": 1e-8},
         ["whisker.torsional_stiffness", "whisker.poisson", "not both"]),
        ({"whisker.torsional_stiffness": 1e-9}, ["nu = EI/GJ - 1", "[0, 0.5]"]),
        ({"whisker.torsional_stiffness": 1e-6}, ["nu = EI/GJ - 1", "[0, 0.5]"]),
        ({"whisker.curvature_k0": 5.0}, ["whisker.parabola", "whisker.curvature_k0",
                                         "not both"]),
        ({"whisker.parabola": 400.0}, ["whisker.parabola = 400.0 1/m", "|A| <= 10"]),
        ({"whisker.poisson": 0.6}, ["whisker.poisson", "[0.0, 0.5]"]),
        ({"whisker.roll": math.inf}, ["whisker.roll", "finite"]),
        ({"obstacle.type": "parabola"}, ["model = 'rod3d' needs obstacle.type 'scene'"]),
        ({"noise.enabled": True}, ["noise.enabled", "rod3d", "planar"]),
        ({"model": "elastica"}, ["whisker.parabola = 10.0 1/m", "needs model 'rod3d'"]),
        ({"model": "elastica", "whisker.parabola": 0.0}, ["whisker.roll = 0.5 rad",
                                                          "needs model 'rod3d'"]),
        ({"model": "elastica", "whisker.parabola": 0.0, "whisker.roll": 0.0,
          "solver.points_tolerance": 1e-8}, ["solver.points_tolerance = 1e-08",
                                             "needs model 'rod3d'"]),
        ({"solver.points_tolerance": 1e-5}, ["solver.points_tolerance", "1e-06"]),
        ({"solver.points_tolerance": 1e-13}, ["solver.points_tolerance", "1e-12"]),
    ],
)
def test_bad_rod3d_parameters_are_refused_with_one_clear_message(values, words):
    with pytest.raises(ParameterError) as err:
        build_config(dict(ROD3D, **values))
    message = str(err.value)
    assert "\n" not in message
    for word in words:
        assert word in message


def test_rod3d_refuses_a_scene_with_friction_naming_the_file(tmp_path):
    scene = tmp_path / "sticky.yaml"
    scene.write_text("obstacles:\n  - {type: sphere, center: [0.02, 0.012, 0.0], r: 0.004, "
                     "friction: 0.3}\n")
    with pytest.raises(ParameterError) as err:
        build_config(dict(ROD3D, **{"obstacle.scene_file": str(scene)}))
    assert str(err.value).startswith(f"obstacle.scene_file = {str(scene)!r}: ")
    assert "frictionless" in str(err.value)
