"""The package's shape: what colcon, ros2 run, CI and a new user rely on."""

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _readme_commands():
    text = (ROOT / "README.md").read_text()
    quick = text.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```\n(.+?)\n```", quick)


def test_ci_runs_the_readme_test_command_verbatim():
    main_job, test_command = _readme_commands()
    assert "pytest" in test_command and "vibrissa sweep --launch config/default.yaml" in main_job
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert test_command in ci


def test_package_xml_is_a_valid_format_3_ament_python_package():
    from catkin_pkg.package import parse_package

    pkg = parse_package(str(ROOT / "package.xml"))
    pkg.validate()
    assert pkg.name == "vibrissa_ros"
    assert pkg.package_format == 3
    assert pkg.get_build_type() == "ament_python"
    assert "@" in pkg.maintainers[0].email


def test_scripts_install_where_ros2_run_looks():
    cfg = (ROOT / "setup.cfg").read_text()
    assert "script_dir=$base/lib/vibrissa_ros" in cfg
    assert "install_scripts=$base/lib/vibrissa_ros" in cfg
    assert (ROOT / "resource" / "vibrissa_ros").exists()


@pytest.mark.parametrize("path", sorted((ROOT / "vibrissa_ros" / "core").glob("*.py")), ids=lambda p: p.name)
def test_the_core_imports_nothing_from_ros(path):
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    assert not names & {"rclpy", "rosidl_runtime_py", "geometry_msgs", "std_msgs", "mcap", "matplotlib"}
