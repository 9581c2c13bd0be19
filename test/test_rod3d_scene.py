"""3D scenes: validation, the scene-file mapping and YAML files (round trips, planar files)."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import yaml

from vibrissa_ros.core.errors import ParameterError
from vibrissa_ros.core.rod3d.obstacles import Cylinder, Plane, Prism, Sphere
from vibrissa_ros.core.rod3d.scene import Scene3D
from vibrissa_ros.core.scenes.scene import PegObstacle, PolygonObstacle, Scene
from vibrissa_ros.scan.scene_file import dump_scene3d, is_3d_scene, load_scene, load_scene3d

CONFIG = Path(__file__).resolve().parents[1] / "config"
#: the scene files shipped (config/scene_*.yaml holding obstacles; the others are node parameters)
SCENE_FILES = sorted(p for p in CONFIG.glob("scene_*.yaml")
                     if "obstacles" in (yaml.safe_load(p.read_text()) or {})
                     and not is_3d_scene(p))  # the planar ones (scene_sphere_m.yaml is 3D)

MIXED_3D = """\
obstacles:
  - {type: sphere, center: [0.3, 0.5, 0.1], r: 0.05}
  - {type: cylinder, name: pole, point: [0.0, 0.6, 0.0], axis: [0.0, 0.0, 2.0], r: 0.03}
  - {type: plane, point: [0.0, 0.0, -0.2], normal: [0.0, 0.0, 1.0]}
  - {type: sphere, center: [-0.3, 0.9, 0.0], r: 0.1}
  - {type: peg, x: -0.35, y: 0.45, r: 0.03}
  - {type: polygon, vertices: [[0.3, 0.6], [0.5, 0.6], [0.5, 0.8], [0.4, 0.7], [0.3, 0.8]]}
  - {type: parabola, p0: 0.3, k: 2.0, placement: {x: 1.0, y: 0.3, rotation: -1.5707963267948966}}
"""


def mixed():
    return load_scene3d(MIXED_3D)


# -- the scene value ----------------------------------------------------------------------------
def test_names_default_by_kind_and_explicit_names_stay():
    scene = mixed()
    assert scene.names == ("sphere0", "pole", "plane0", "sphere1", "peg0", "polygon0",
                           "parabola0")
    assert [ob.kind for ob in scene] == ["sphere", "cylinder", "plane", "sphere", "peg",
                                         "polygon", "parabola"]
    assert isinstance(scene[4], Prism) and scene[4].planar.name == "peg0"
    assert len(scene) == 7 and not scene.is_planar


def test_the_constructor_takes_obstacles_and_planar_obstacles():
    scene = Scene3D([Sphere((0.0, 0.0, 1.0), 0.2), PegObstacle(0.0, 0.5, 0.1),
                     Sphere((0.0, 0.0, -1.0), 0.2, name="low")])
    assert scene.names == ("sphere0", "peg0", "low")
    assert isinstance(scene.obstacles, tuple) and isinstance(scene[1], Prism)
    assert scene == Scene3D.from_dict(scene.to_dict())
    assert hash(scene) == hash(Scene3D.from_dict(scene.to_dict()))
    with pytest.raises(dataclasses.FrozenInstanceError):
        scene.obstacles = ()


@pytest.mark.parametrize("obstacles, words", [
    ([], "at least one obstacle"),
    (["sphere"], "not an obstacle"),
    ([Sphere((0, 0, 0), 1.0, name="a"), Sphere((5, 0, 0), 1.0, name="a")], "used twice"),
    ([Sphere((0, 0, 0), 1.0), Sphere((1.5, 0, 0), 0.5)], "overlap or touch (gap 0 L)"),
    ([Sphere((0, 0, 0), 1.0), Plane((0, 0, -0.5), (0, 0, 1))], "overlap"),
    ([Sphere((0, 0, 0), 0.1), Prism(PolygonObstacle([[-1, -1], [1, -1], [0, 1]]))], "overlap"),
    ([Cylinder((0, 0, 0), (1, 0, 0), 0.2), Cylinder((0, 0.3, 0), (1, 0, 0), 0.2)], "overlap"),
    ([Cylinder((0, 0, 0), (1, 0, 0), 0.2), Cylinder((0, 0, 0.3), (0, 1, 0), 0.2)], "overlap"),
    ([Plane((0, 0, 0), (0, 0, 1)), Plane((0, 0, -1), (0, 0, -1))], "overlap"),
    ([Plane((0, 0, 0), (0, 0, 1)), Cylinder((0, 0, 0.1), (1, 1, 0), 0.2)], "overlap"),
    ([Cylinder((0, 0.5, 7), (0, 0, -1), 0.05), PegObstacle(0, 0.55, 0.02)], "overlap"),
    ([PegObstacle(0, 0, 1.0), PegObstacle(1.5, 0, 0.6)], "overlap or touch (gap -0.1 L)"),
])
def test_bad_scenes_are_refused(obstacles, words):
    with pytest.raises(ParameterError) as info:
        Scene3D(obstacles)
    assert words in str(info.value) and "\n" not in str(info.value)


def test_obstacles_apart_or_unable_to_be_apart_are_accepted():
    Scene3D([
        Plane((0, 0, -1), (0, 0, 1)),                      # a floor
        Cylinder((0.5, 0.5, 0), (0, 0, 1), 0.05),           # a pole standing on it
        Plane((2, 0, 0), (-1, 0, 0)),                       # a wall meeting the floor
        Cylinder((0, 0, 1), (1, 0, 0), 0.2),                # two bars crossing apart
        Cylinder((0, 0, 1.5), (0, 1, 0), 0.2),
        Sphere((-0.5, -0.5, 0.0), 0.2),
        PegObstacle(-0.5, 0.5, 0.1),                        # a peg's prism on the floor too
        Plane((0, 0, 3), (0, 0, -1)),                       # a ceiling, apart from the floor
    ])


def test_signed_distances_per_obstacle():
    scene = mixed()
    pts = np.array([[0.0, 0.0, 0.0], [0.3, 0.5, 0.3], [1.0, 1.0, -1.0]])
    d = scene.signed_distances(pts)
    assert d.shape == (7, 3)
    for i, ob in enumerate(scene):
        np.testing.assert_array_equal(d[i], ob.signed_distance(pts))
    np.testing.assert_array_equal(scene.signed_distance(pts), d.min(axis=0))
    assert d[0, 1] == pytest.approx(0.15) and d[2, 2] == pytest.approx(-0.8)
    assert scene.signed_distances([0.0, 0.0, 0.0]).shape == (7, 1)


def test_describe_is_one_line():
    line = mixed().describe()
    assert "\n" not in line and line.startswith("3D scene of 7 obstacle(s)")
    assert "pole: cylinder(" in line and "prism along z" in line


# -- scene files --------------------------------------------------------------------------------
def test_yaml_round_trip(tmp_path):
    scene = mixed()
    path = tmp_path / "scene.yaml"
    text = dump_scene3d(scene, path)
    assert path.read_text(encoding="utf-8") == text
    back = load_scene3d(path)
    assert back == scene and back.to_dict() == scene.to_dict()
    assert load_scene3d(str(path)) == scene and load_scene3d(text) == scene
    assert scene.to_dict()["obstacles"][1] == {
        "type": "cylinder", "name": "pole", "point": [0.0, 0.6, 0.0], "axis": [0.0, 0.0, 1.0],
        "r": 0.03}
    assert "friction" not in yaml.safe_load(text)


def test_yaml_round_trip_in_metres(tmp_path):
    scene, length = mixed(), 0.03
    path = tmp_path / "metres.yaml"
    dump_scene3d(scene, path, length_scale=length)
    data = yaml.safe_load(path.read_text())
    cyl, plane = data["obstacles"][1], data["obstacles"][2]
    assert cyl["point"] == pytest.approx([0.0, 0.018, 0.0]) and cyl["r"] == pytest.approx(9e-4)
    assert cyl["axis"] == [0.0, 0.0, 1.0] and plane["normal"] == [0.0, 0.0, 1.0]  # unscaled
    assert data["obstacles"][0]["center"] == pytest.approx([0.009, 0.015, 0.003])
    back = load_scene3d(path, length_scale=length)
    assert back.names == scene.names
    for a, b in zip(back, scene):
        pts = np.random.default_rng(1).uniform(-1.0, 1.0, size=(20, 3))
        np.testing.assert_allclose(a.signed_distance(pts), b.signed_distance(pts), atol=1e-12)


@pytest.mark.parametrize("path", SCENE_FILES, ids=lambda p: p.name)
def test_every_planar_scene_file_loads_as_3d(path):
    length = 0.03 if path.name.endswith("_m.yaml") else 1.0  # the node's file is in metres
    planar = load_scene(path, length_scale=length)
    scene = load_scene3d(path, length_scale=length, drop_friction=True)
    assert not is_3d_scene(path) and scene.is_planar
    assert scene.names == tuple(ob.name for ob in planar)
    assert [ob.kind for ob in scene] == [ob.kind for ob in planar]
    pts = np.random.default_rng(5).uniform(-1.0, 1.5, size=(30, 3))
    np.testing.assert_array_equal(scene.signed_distance(pts), planar.signed_distance(pts[:, :2]))
    assert load_scene3d(dump_scene3d(scene)) == scene
    frictionless = planar.friction == 0.0 and all(ob.friction in (None, 0.0) for ob in planar)
    if frictionless:
        assert load_scene3d(path, length_scale=length) == scene
    else:  # the 3D whisker is frictionless: refused unless asked to drop it
        with pytest.raises(ParameterError, match=rf"^{path}: .*friction = 0\.\d+ is not allowed; "
                                                 r"the 3D whisker is frictionless \(friction is "
                                                 r"planar-only for now\)"):
            load_scene3d(path, length_scale=length)


def test_the_shipped_scene_files_are_found():
    assert {p.name for p in SCENE_FILES} >= {"scene_contour.yaml", "scene_mixed.yaml",
                                             "scene_two_pegs.yaml"}


def test_from_planar_matches_the_planar_scene():
    planar = Scene([PegObstacle(0.0, 0.4, 0.04), PegObstacle(-0.2, 0.85, 0.03, friction=0.3)])
    with pytest.raises(ParameterError, match="peg1: friction = 0.3 is not allowed"):
        Scene3D.from_planar(planar)
    scene = Scene3D.from_planar(planar, drop_friction=True)
    assert scene.names == ("peg0", "peg1")
    assert scene == load_scene3d("obstacles: [{type: peg, x: 0.0, y: 0.4, r: 0.04},"
                                 " {type: peg, x: -0.2, y: 0.85, r: 0.03}]")
    with pytest.raises(ParameterError, match="scene friction = 0.2 is not allowed"):
        Scene3D.from_planar(Scene([PegObstacle(0.0, 0.4, 0.04)], friction=0.2))


def test_is_3d_scene():
    assert is_3d_scene(MIXED_3D)
    assert is_3d_scene(yaml.safe_load(MIXED_3D))
    assert not is_3d_scene("obstacles: [{type: peg, x: 0.0, y: 0.4}]")
    assert not is_3d_scene({"friction": 0.0})


@pytest.mark.parametrize("entry, key", [
    ("{type: sphere, center: [0, 0, 0], r: 0.1, radius: 2}", "'radius'"),
    ("{type: cylinder, point: [0, 0, 0], axis: [0, 0, 0], r: 0.1}", "axis = "),
    ("{type: cylinder, point: [0, 0, 0], axis: [0, 0, 1], r: -0.1}", "r = "),
    ("{type: sphere, center: [0, 0, 0], r: 0}", "r = "),
    ("{type: plane, point: [0, 0, 0], normal: [0, 0, 0]}", "normal = "),
    ("{type: plane, point: [0, 0], normal: [0, 0, 1]}", "point = "),
    ("{type: sphere, center: [0, 0, .nan], r: 1}", "center[2] = "),
    ("{type: sphere, center: [0, 0, 0]}", "key 'r' is required"),
    ("{type: cube, size: 1}", "unknown obstacle type 'cube'"),
    ("{type: sphere, center: [0, 0, 0], r: 1, friction: 0.2}", "friction = 0.2"),
    ("{type: peg, x: 0, y: 0, r: 0.1, z: 1}", "'z'"),
    ("{type: peg, x: 0, y: 0, r: -0.1}", "r = "),
])
def test_bad_entries_are_refused_naming_file_and_key(tmp_path, entry, key):
    path = tmp_path / "bad.yaml"
    path.write_text(f"obstacles:\n  - {{type: sphere, center: [5, 5, 5], r: 0.1}}\n  - {entry}\n")
    with pytest.raises(ParameterError) as info:
        load_scene3d(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: obstacle 1: ")
    assert key in message


def test_unknown_keys_name_what_is_allowed(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("obstacles: [{type: cylinder, point: [0, 0, 0], axis: [0, 0, 1], r: 1, "
                    "height: 2}]\n")
    with pytest.raises(ParameterError, match=r"unknown key\(s\) 'height'; allowed: type, name, "
                                             r"friction, point, axis, r$"):
        load_scene3d(path)
    path.write_text("obstacles: [{type: sphere, center: [0, 0, 0], r: 1}]\nunits: m\n")
    with pytest.raises(ParameterError, match=rf"^{path}: unknown scene key\(s\) 'units'; "
                                             "allowed: friction, obstacles$"):
        load_scene3d(path)


@pytest.mark.parametrize("text, words", [
    ("friction: 0.0\nobstacles: [{type: sphere, center: [0, 0, 0], r: 1, friction: 0}]", None),
    ("friction: 0.1\nobstacles: [{type: sphere, center: [0, 0, 0], r: 1}]",
     "scene friction = 0.1 is not allowed"),
    ("obstacles: [{type: peg, x: 0, y: 0.4, r: 0.1, friction: 0.3}]",
     "obstacle 0: peg0: friction = 0.3 is not allowed"),
    ("obstacles: [{type: peg, x: 0, y: 0.4, r: 0.1, friction: -1}]",
     "obstacle 0: peg0: friction = -1 is not allowed; the Coulomb coefficient"),
    ("obstacles: []", "key 'obstacles' must be a non-empty list"),
    ("- 1\n- 2\n", "a scene file is a mapping"),
])
def test_friction_and_scene_level_errors(text, words):
    if words is None:
        assert len(load_scene3d(text)) == 1
        return
    with pytest.raises(ParameterError) as info:
        load_scene3d(text)
    assert str(info.value).startswith("scene text: ") and words in str(info.value)


def test_drop_friction_keeps_the_obstacles():
    text = "friction: 0.1\nobstacles: [{type: peg, x: 0, y: 0.4, r: 0.1, friction: 0.3}]"
    scene = load_scene3d(text, drop_friction=True)
    assert scene.to_dict() == {"obstacles": [{"type": "peg", "name": "peg0", "x": 0.0, "y": 0.4,
                                              "r": 0.1}]}


@pytest.mark.parametrize("scale", [0.0, -1.0, float("nan"), "1"])
def test_length_scale_must_be_a_length(scale):
    with pytest.raises(ParameterError, match="length_scale"):
        load_scene3d(MIXED_3D, length_scale=scale)


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(ParameterError, match="missing.yaml"):
        load_scene3d(tmp_path / "missing.yaml")
