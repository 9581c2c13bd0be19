"""The rat's whisker array: published numbers, mirror symmetry, the array file and the CLI."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from vibrissa_ros.cli import main
from vibrissa_ros.core.arrays import WhiskerArray, WhiskerSpec, rat_array
from vibrissa_ros.core.arrays.rat import (
    base_diameter,
    belli_basepoint,
    belli_emergence,
    belli_position,
    belli_shape,
    emergence_rotation,
    towal_shape,
)
from vibrissa_ros.core.errors import ParameterError
from vibrissa_ros.core.rod3d.pose import quat_matrix
from vibrissa_ros.scan.array_file import dump_array, load_array

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config" / "rat_array.yaml"


def test_the_check_whisker_has_the_published_numbers():
    # Belli c = 1, r = 1: WHISKiT's RA0, the Greek alpha (rat_array.md's check whisker)
    theta, phi, r = belli_basepoint(1, 1)
    assert round(theta, 1) == -35.2 and round(phi, 2) == 43.19 and round(r, 3) == 7.472
    assert tuple(round(v, 4) for v in belli_position(theta, phi, r)) == (6.1056, -4.3070, 5.1139)
    s, a = belli_shape(theta)
    assert round(s, 3) == 53.835 and round(a, 6) == 0.006352
    assert tuple(round(v, 2) for v in belli_emergence(theta, phi)) == (32.79, 51.60, 43.56)


def test_the_generated_ra0_carries_the_check_numbers_in_si_units():
    w = rat_array("right")["RA0"]
    assert (w.row, w.column, w.side) == ("A", 0, "right")
    np.testing.assert_allclose(w.base_position, (6.1056e-3, -4.3070e-3, 5.1139e-3), atol=6e-8)
    assert round(w.length * 1e3, 3) == 53.835 and round(w.parabola * 1e-3, 6) == 0.006352
    # the base tangent's azimuth from +x is theta_w - 90 and its elevation phi_w
    t = quat_matrix(w.base_quaternion)[:, 0]
    assert math.degrees(math.atan2(t[1], t[0])) + 90.0 == pytest.approx(32.78874, abs=1e-9)
    assert math.degrees(math.asin(t[2])) == pytest.approx(51.5976, abs=1e-9)


def test_the_unloaded_whisker_bends_as_whiskit_draws_it():
    # WHISKiT: the whisker (x, 0, -A x^2) in its frame, rotated by Rz(th-90) Ry(-ph) Rx(ze)
    th, ph, ze = belli_emergence(*belli_basepoint(3, 3)[:2])
    c, s = np.cos(np.radians(th - 90)), np.sin(np.radians(th - 90))
    rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    c, s = np.cos(np.radians(-ph)), np.sin(np.radians(-ph))
    ry = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    c, s = np.cos(np.radians(ze)), np.sin(np.radians(ze))
    rx = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    x = np.linspace(0.0, 1.0, 5)
    whiskit = (rz @ ry @ rx @ np.vstack((x, 0 * x, -0.3 * x * x))).T
    ours = (emergence_rotation(th, ph, ze) @ np.vstack((x, 0.3 * x * x, 0 * x))).T
    np.testing.assert_allclose(ours, whiskit, atol=1e-14)


def test_the_average_rats_c1_is_close_to_the_models_c1_not_c2():
    # Belli 2018's measured average rat, its "C2" in Belli numbering = the standard C1:
    # S 45.2 mm, A 0.00885 /mm, theta_w 56.9, phi_w 11.0, zeta_w 21.5 (deg)
    right = rat_array("right")
    c1, c2 = right["RC1"], right["RC2"]
    th, ph, ze = belli_emergence(*belli_basepoint(3, 2)[:2])
    assert abs(th - 56.9) < 4 and abs(ph - 11.0) < 2 and abs(ze - 21.5) < 1
    assert abs(c1.length * 1e3 - 45.2) < abs(c2.length * 1e3 - 45.2)
    assert c1.parabola * 1e-3 == pytest.approx(0.00885, rel=0.1)
    # the base diameter fit at the average rat's S: 0.1605 mm
    assert round(base_diameter(45.2, 3, 1), 4) == 0.1605


def test_towal_c2_is_quist_and_hartmanns_c2():
    s, a = towal_shape(3, 3)
    assert round(s, 1) == 35.0 and round(a, 4) == 0.0233
    w = rat_array("right", "towal2011")["RC2"]
    assert round(w.length * 1e3, 1) == 35.0 and round(w.parabola * 1e-3, 4) == 0.0233


@pytest.mark.parametrize("model, count", [("belli2018", 30), ("towal2011", 31)])
def test_whiskers_per_side(model, count):
    for side in ("left", "right"):
        array = rat_array(side, model)
        assert len(array) == count and {w.side for w in array} == {side}
    assert len(rat_array("both", model)) == 2 * count


@pytest.mark.parametrize("model", ["belli2018", "towal2011"])
def test_left_is_the_right_mirrored_in_x(model):
    both = rat_array("both", model)
    mirror = np.diag([-1.0, 1.0, 1.0])
    for right in both.side("right"):
        left = both["L" + right.name[1:]]
        np.testing.assert_allclose(left.base_position, mirror @ np.array(right.base_position),
                                   atol=1e-18)
        r_right, r_left = quat_matrix(right.base_quaternion), quat_matrix(left.base_quaternion)
        np.testing.assert_allclose(r_left[:, :2], mirror @ r_right[:, :2], atol=1e-14)
        assert np.linalg.det(r_left) == pytest.approx(1.0)
        assert left.shape == right.shape
        assert (left.length, left.parabola, left.base_radius, left.taper) == (
            right.length, right.parabola, right.base_radius, right.taper)
        # the unloaded whiskers' points are mirror images
        a, b = right.shape.free_centerline(np.linspace(0, 1, 7)), left.shape.free_centerline(
            np.linspace(0, 1, 7))
        np.testing.assert_allclose((r_left @ b.T).T, (mirror @ r_right @ a.T).T, atol=1e-14)


def test_every_whisker_is_physical():
    for w in rat_array("both", "towal2011"):
        assert 0.0 < w.taper < 1.0 and w.base_radius > 0.0 and w.length > 0.0
        assert 0.0 < w.parabola * w.length < 1.0
    rod = rat_array().rod("RC2")
    np.testing.assert_allclose(rod.pose.p * rod.length, rat_array()["RC2"].base_position)
    assert rod.shape.parabola == pytest.approx(rat_array()["RC2"].parabola * rod.length)


def _same_whiskers(a, b, rel=1e-14):
    """Every whisker's fields equal, numbers to ``rel`` (libraries may differ in the last bit)."""
    assert len(a) == len(b) and a.description == b.description
    for wa, wb in zip(a, b):
        for f in dataclasses.fields(wa):
            va, vb = getattr(wa, f.name), getattr(wb, f.name)
            if isinstance(va, tuple) and va and isinstance(va[0], float):
                assert np.allclose(va, vb, rtol=rel, atol=rel * max(map(abs, va))), (wa.name,
                                                                                     f.name)
            elif isinstance(va, float):
                assert math.isclose(va, vb, rel_tol=rel, abs_tol=rel), (wa.name, f.name)
            else:
                assert va == vb, (wa.name, f.name)


def test_the_shipped_config_equals_a_fresh_generation():
    # to the last bits: the file was written on numpy 2.x, and numpy 1.x's trigonometry and
    # sums may round a quaternion's component the other way
    _same_whiskers(load_array(CONFIG), rat_array("both", "belli2018"))
    assert "vibrissa array rat --side both --model belli2018" in CONFIG.read_text().splitlines()[0]


def test_yaml_round_trip_keeps_every_field(tmp_path):
    array = rat_array("left", "towal2011")
    path = tmp_path / "a.yaml"
    dump_array(array, path, header="made by a test")
    back = load_array(path)
    assert back == array and back.description == array.description
    curved = WhiskerArray((WhiskerSpec("X1", "right", "C", 1, (0, 0, 0), (1, 0, 0, 0), 0.03,
                                       1e-4, 0.1, 3e9, 0.3, k0=10.0, k1=-50.0),))
    dump_array(curved, path)
    assert load_array(path) == curved


def _write(tmp_path, entry):
    good = rat_array("right").to_dict()["whiskers"][0]
    good.update(entry)
    good = {k: v for k, v in good.items() if v is not None}
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump({"whiskers": [rat_array("right")["RC2"].to_dict(), good]}))
    return path


@pytest.mark.parametrize("entry, key", [
    ({"length": -0.01}, "length"),
    ({"taper": 1.5}, "taper"),
    ({"poisson": 0.7}, "poisson"),
    ({"side": "up"}, "side"),
    ({"row": "F"}, "row"),
    ({"column": 9}, "column"),
    ({"base_radius": 0.0}, "base_radius"),
    ({"youngs_modulus": "hard"}, "youngs_modulus"),
    ({"base_position": [0.0, 1.0]}, "base_position"),
    ({"base_quaternion": [1.0, 1.0, 0.0, 0.0]}, "base_quaternion"),
    ({"parabola": 1e6}, "parabola"),
    ({"k0": 1.0}, "parabola"),
    ({"colour": "black"}, "colour"),
    ({"name": "RC2"}, "name"),
])
def test_bad_files_are_refused_in_one_line_naming_file_whisker_and_key(tmp_path, entry, key):
    path = _write(tmp_path, entry)
    with pytest.raises(ParameterError) as err:
        load_array(path)
    message = str(err.value)
    assert "\n" not in message and message.startswith(str(path))
    assert "whisker RA0" in message or "whisker RC2" in message
    assert key in message


def test_a_missing_key_and_a_bad_top_level_are_named(tmp_path):
    path = tmp_path / "m.yaml"
    entry = rat_array("right")["RB1"].to_dict()
    del entry["length"]
    path.write_text(yaml.safe_dump({"whiskers": [entry]}))
    with pytest.raises(ParameterError, match=r"m\.yaml: whisker RB1: missing key 'length'"):
        load_array(path)
    path.write_text("whiskers: []\nhead: rat\n")
    with pytest.raises(ParameterError, match=r"m\.yaml: whisker array: unknown key 'head'"):
        load_array(path)
    path.write_text("whiskers: [\n")
    with pytest.raises(ParameterError, match=r"m\.yaml: not valid YAML"):
        load_array(path)


def test_bad_generator_arguments_are_refused():
    with pytest.raises(ParameterError, match="side"):
        rat_array("top")
    with pytest.raises(ParameterError, match="model"):
        rat_array(model="mouse")


def test_the_cli_writes_a_loadable_file(tmp_path, capsys):
    out = tmp_path / "rat.yaml"
    assert main(["array", "rat", "--side", "right", "--model", "towal2011", "-o", str(out)]) == 0
    assert load_array(out) == rat_array("right", "towal2011")
    assert main(["array", "rat"]) == 0
    text = capsys.readouterr().out
    (tmp_path / "stdout.yaml").write_text(text)
    assert load_array(tmp_path / "stdout.yaml") == rat_array()
    with pytest.raises(SystemExit) as exit_:
        main(["array", "rat", "--side", "top"])
    assert exit_.value.code == 2
