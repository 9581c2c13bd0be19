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


CORE = ROOT / "vibrissa_ros" / "core"


@pytest.mark.parametrize("path", sorted(CORE.rglob("*.py")),
                         ids=lambda p: str(p.relative_to(CORE)))
def test_the_core_imports_nothing_from_ros(path):
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    assert not names & {"rclpy", "rosidl_runtime_py", "geometry_msgs", "std_msgs", "mcap",
                        "matplotlib"}


PACKAGE = ROOT / "vibrissa_ros"
ROS_ONLY = {"rclpy"}


def _imports(path):
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


@pytest.mark.parametrize("path", sorted(p for p in PACKAGE.rglob("*.py") if "ros" not in
                                        p.relative_to(PACKAGE).parts[:-1]),
                         ids=lambda p: str(p.relative_to(PACKAGE)))
def test_rclpy_is_imported_only_in_the_ros_subpackage(path):
    assert not _imports(path) & ROS_ONLY


def _modules_imported(path):
    """Every module ``path`` imports, relative imports resolved to absolute names."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    package = parts[:-1]  # an __init__ imports relative to its own package, as a module does
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - (node.level - 1)] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            names.add(module)
            names.update(f"{module}.{a.name}" for a in node.names)
    return names


CHECKS = "vibrissa_ros.core.checks"


@pytest.mark.parametrize("path", sorted(p for p in PACKAGE.rglob("*.py")
                                        if "checks" not in p.relative_to(PACKAGE).parts),
                         ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_product_module_imports_an_independent_check(path):
    """core/checks holds second solvers for tests and benchmarks: no product path uses them."""
    used = {m for m in _modules_imported(path) if m == CHECKS or m.startswith(CHECKS + ".")}
    assert not used, f"{path.relative_to(ROOT)} imports {sorted(used)}"


def test_the_import_resolver_sees_a_check_import():
    """The test above would catch a product module that imports a check, relatively or not."""
    module = ROOT / "vibrissa_ros" / "core" / "general" / "inverse.py"
    names = _modules_imported(module)
    assert "vibrissa_ros.core.general.model.WhiskerShape" in names
    assert "vibrissa_ros.core.exact.inverse" in names
    checks = _modules_imported(ROOT / "vibrissa_ros" / "core" / "checks" / "general_shooting.py")
    assert "vibrissa_ros.core.general.inverse.loaded_whisker_rhs" in checks


def test_the_core_keeps_its_public_names():
    """The core's public API did not move with its modules: every name of __all__ imports."""
    import vibrissa_ros.core as core

    assert {"QuasistaticTracker", "GeneralWhiskerModel", "ElasticaModel", "Parabola", "FootPose",
            "run_scan", "tip_loaded_elastica", "VibrissaError"} <= set(core.__all__)
    for name in core.__all__:
        assert getattr(core, name) is not None, name


def test_the_ros_free_adapters_import_without_ros():
    """CLI, scan I/O, MCAP, plots, reconstruction, log tools: importable with rclpy missing."""
    import subprocess
    import sys

    code = ("import sys; sys.modules['rclpy'] = None\n"
            "import vibrissa_ros.cli, vibrissa_ros.scan.scan_io, vibrissa_ros.logs.mcap_log, "
            "vibrissa_ros.scan.plots, vibrissa_ros.node.reconstruction, vibrissa_ros.logs.tools, "
            "vibrissa_ros.node.edge, vibrissa_ros.node.pipeline, vibrissa_ros.node.config\n"
            "assert vibrissa_ros.cli.main(['scan', '--profile', 'parabola', '--param', 'p0=0.3',"
            " '--from', '2', '--to', '1.9', '--step', '0.1', '--csv', '-']) == 0\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr


def _launch_files():
    return sorted((ROOT / "launch").glob("*.launch.xml"))


def _console_scripts():
    tree = ast.parse((ROOT / "setup.py").read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and " = " in node.value \
                and ":" in node.value:
            yield node.value.split(" = ")[0].strip()


def _substitute(text, args):
    for name, value in args.items():
        text = text.replace(f"$(var {name})", value)
    text = text.replace("$(find-pkg-share vibrissa_ros)", str(ROOT))
    assert "$(" not in text, f"unresolved substitution in {text!r}"
    return text


def _flat(tree, prefix=""):
    for key, value in tree.items():
        if isinstance(value, dict):
            yield from _flat(value, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}"


@pytest.mark.parametrize("path", _launch_files(), ids=lambda p: p.name)
def test_launch_files_name_only_what_exists(path):
    import xml.etree.ElementTree as ET

    import yaml

    from vibrissa_ros.node.config import CONTOUR_SPECS, SPECS

    specs = {"whisker_node": SPECS, "contour_node": CONTOUR_SPECS}
    root = ET.parse(path).getroot()
    assert root.tag == "launch"
    args = {a.get("name"): a.get("default", "") for a in root.iter("arg")}
    assert all(a.get("description") for a in root.iter("arg"))
    nodes = list(root.iter("node"))
    assert nodes
    scripts = set(_console_scripts())
    for node in nodes:
        assert node.get("pkg") == "vibrissa_ros"
        exe = node.get("exec")
        assert exe in scripts, exe
        for param in node.iter("param"):
            if param.get("from") is not None:
                params_file = Path(_substitute(param.get("from"), args))
                assert params_file.is_file(), params_file
                tree = yaml.safe_load(params_file.read_text())
                names = set(_flat(next(iter(tree.values()))["ros__parameters"]))
                if exe == "whisker_node":  # a whisker's file: every key is one of its parameters
                    assert names <= set(SPECS), names - set(SPECS)
            else:
                assert param.get("name") in specs[exe], param.get("name")
                _substitute(param.get("value"), args)
        for remap in node.iter("remap"):
            _substitute(remap.get("to"), args)
            assert remap.get("from").startswith("~/")


def test_launch_files_are_installed(installed):
    share = installed / "vibrissa_ros" / "share" / "vibrissa_ros"
    for path in _launch_files():
        assert (share / "launch" / path.name).read_text() == path.read_text()
    assert (share / "config" / "default.yaml").is_file()
