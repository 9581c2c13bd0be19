"""
Every dependency has been looked up in the ROS distribution's rosdep database.

test/data/rosdep_keys.yaml records, for the rosdistro commit it names, where each key of
package.xml is defined and what each requirement of setup.py maps to (a rosdep key, or none and the
pip command that installs it); doc/rosdep.md tells users the outcome. These tests make a new
dependency fail until it is looked up and recorded there.
"""

import ast
import re
from pathlib import Path

import pytest

yaml = pytest.importorskip("yaml")

ROOT = Path(__file__).resolve().parents[1]
RECORD = ROOT / "test" / "data" / "rosdep_keys.yaml"
DATABASE = ("rosdep/python.yaml", "rosdep/base.yaml", "jazzy/distribution.yaml")


def _record():
    return yaml.safe_load(RECORD.read_text())


def _package_xml_keys():
    from catkin_pkg.package import parse_package

    pkg = parse_package(str(ROOT / "package.xml"))
    deps = (pkg.build_depends + pkg.buildtool_depends + pkg.build_export_depends
            + pkg.buildtool_export_depends + pkg.exec_depends + pkg.test_depends + pkg.doc_depends)
    return {d.name for d in deps}


def _requirement_lists(node):
    """Yield every list of string literals below an AST node."""
    for sub in ast.walk(node):
        if isinstance(sub, ast.List) and sub.elts and all(
                isinstance(e, ast.Constant) and isinstance(e.value, str) for e in sub.elts):
            yield [e.value for e in sub.elts]


def _setup_py_requirements():
    """Distribution names (normalized) of setup.py's install_requires and extras, unexecuted."""
    tree = ast.parse((ROOT / "setup.py").read_text())
    found = []
    for node in tree.body:
        # the requirement lists: module-level constants (ROS, PLOTS, ...) and setup()'s arguments
        if isinstance(node, ast.Assign) and all(
                isinstance(t, ast.Name) and t.id.isupper() for t in node.targets):
            found += [r for lst in _requirement_lists(node.value) for r in lst]
    for call in ast.walk(tree):
        if isinstance(call, ast.Call) and getattr(call.func, "id", None) == "setup":
            for kw in call.keywords:
                if kw.arg in ("install_requires", "extras_require"):
                    found += [r for lst in _requirement_lists(kw.value) for r in lst]
    names = {re.match(r"[A-Za-z0-9][A-Za-z0-9._-]*", r).group(0) for r in found}
    return {re.sub(r"[-_.]+", "-", n).lower() for n in names}


def test_the_record_names_the_rosdistro_commit_it_was_checked_against():
    source = _record()["rosdistro"]
    assert source["repository"] == "ros/rosdistro"
    assert re.fullmatch(r"[0-9a-f]{40}", source["commit"])
    assert source["distribution"] == "jazzy"


def test_every_package_xml_key_is_recorded_and_nothing_else():
    keys = set(_record()["keys"])
    in_xml = _package_xml_keys()
    assert in_xml - keys == set(), "look these keys up in rosdistro and record them"
    assert keys - in_xml == set(), "no longer in package.xml: remove them from the record"


@pytest.mark.parametrize("key", sorted(_record()["keys"]))
def test_every_package_xml_key_is_defined_in_the_database(key):
    # a key rosdep cannot resolve makes `rosdep install` fail: pip-only libraries stay out
    found = _record()["keys"][key]
    assert found.startswith(DATABASE), f"{key}: {found}"


def test_every_setup_py_requirement_is_recorded():
    requirements = _setup_py_requirements()
    assert {"numpy", "mcap", "dask", "mpmath"} <= requirements  # the parse sees the extras
    missing = requirements - set(_record()["requirements"])
    assert not missing, f"look these up in rosdistro and record them: {sorted(missing)}"


@pytest.mark.parametrize("name", sorted(_record()["requirements"]))
def test_every_requirement_maps_to_a_recorded_key_or_a_pip_command(name):
    record = _record()
    entry = record["requirements"][name]
    keys = entry["key"] if isinstance(entry["key"], list) else [entry["key"]]
    for key in keys:
        if key == "none":
            assert entry["install"].startswith("pip install "), name
        else:
            assert key in record["keys"] or key in record["other_keys"], (name, key)


def test_the_keys_package_xml_leaves_out_are_in_the_database_and_say_why():
    record = _record()
    for key, found in record["other_keys"].items():
        assert found.startswith(DATABASE) and "; " in found, key
        assert key not in record["keys"], key
