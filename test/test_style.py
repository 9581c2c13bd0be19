"""
Style checks as ROS 2 Python packages run them (ament_flake8, ament_pep257), by pytest.

The configuration is ament's own: flake8 with ament_flake8.ini's settings (line length 99, its
ignore list) and pydocstyle with the "ament" convention (pep257 minus D100-D107, D203, D212,
D404). Every Python file of the checkout is checked: the package, its tests, the benchmarks, the
docs' scripts and setup.py; a test fails if a tracked Python file lies outside them.
"""

import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MAX_LINE_LENGTH = 99
FLAKE8_IGNORE = ["B902", "C816", "D100", "D101", "D102", "D103", "D104", "D105", "D106", "D107",
                 "D203", "D212", "D404", "I202"]
PEP257_IGNORE = ["D100", "D101", "D102", "D103", "D104", "D105", "D106", "D107", "D203", "D212",
                 "D404"]
# what is checked: files and directories (their .py files, at any depth) of the checkout
CHECKED = ("setup.py", "vibrissa_ros", "test", "bench", "doc")


def _checked():
    files = []
    for part in CHECKED:
        path = ROOT / part
        files += [path] if path.is_file() else sorted(path.rglob("*.py"))
    return [str(f) for f in files]


def _tracked_python_files():
    """Return the .py files git tracks in the checkout (None outside a git checkout)."""
    try:
        proc = subprocess.run(["git", "ls-files", "-z", "--", "*.py"], cwd=ROOT,
                              capture_output=True, text=True, timeout=60)
    except OSError:  # no git
        return None
    if proc.returncode != 0:  # not a git checkout (an sdist, a colcon copy)
        return None
    return {ROOT / name for name in proc.stdout.split("\0") if name}


def test_flake8():
    from flake8.api import legacy

    guide = legacy.get_style_guide(max_line_length=MAX_LINE_LENGTH, extend_ignore=FLAKE8_IGNORE,
                                   show_source=True)
    report = guide.check_files(_checked())
    assert report.total_errors == 0, "flake8 found errors (printed above)"


def test_pep257():
    import pydocstyle

    errors = [str(e) for e in pydocstyle.check(_checked(), ignore=PEP257_IGNORE)]
    assert not errors, "\n".join(errors)


def test_every_tracked_python_file_is_checked():
    tracked = _tracked_python_files()
    if tracked is None:
        pytest.skip("not a git checkout: the tracked files are unknown")
    assert tracked, "git lists no Python file: the checkout is not where this test expects it"
    checked = {Path(f) for f in _checked()}
    missing = sorted(str(f.relative_to(ROOT)) for f in tracked - checked)
    assert not missing, f"Python files outside the style checks (add them to CHECKED): {missing}"


@pytest.mark.parametrize("part", CHECKED)
def test_what_is_checked_exists(part):
    assert (ROOT / part).exists()
