"""
Style checks as ROS 2 Python packages run them (ament_flake8, ament_pep257), by pytest.

The configuration is ament's own: flake8 with ament_flake8.ini's settings (line length 99, its
ignore list) and pydocstyle with the "ament" convention (pep257 minus D100-D107, D203, D212,
D404). ``NOT_YET`` lists what is not checked yet, with what still fails there.
"""

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MAX_LINE_LENGTH = 99
FLAKE8_IGNORE = ["B902", "C816", "D100", "D101", "D102", "D103", "D104", "D105", "D106", "D107",
                 "D203", "D212", "D404", "I202"]
PEP257_IGNORE = ["D100", "D101", "D102", "D103", "D104", "D105", "D106", "D107", "D203", "D212",
                 "D404"]
# not checked yet: cli.py (10 flake8 findings, lines over 99 columns, and 2 pep257 ones, D401),
# the tests and the benchmarks (236 flake8 findings, nearly all lines over 99 columns)
NOT_YET = ("test", "bench", "vibrissa_ros/cli.py")


def _checked():
    files = [ROOT / "setup.py"] + sorted((ROOT / "vibrissa_ros").rglob("*.py"))
    return [str(f) for f in files
            if not any(str(f.relative_to(ROOT)) == p
                       or str(f.relative_to(ROOT)).startswith(p + "/")
                       for p in NOT_YET)]


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


@pytest.mark.parametrize("part", NOT_YET)
def test_what_is_not_checked_yet_exists(part):
    assert (ROOT / part).exists()
