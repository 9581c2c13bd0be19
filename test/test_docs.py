"""
The documentation site (doc/): it builds with warnings as errors, and what it shows runs.

The HTML build fails on a broken reference, a figure command that fails (every figure is drawn by
the command shown above it) or a docstring of the API reference that misses a section numpydoc
requires (``numpydoc_validation_checks`` in doc/conf.py). The doctest builder then runs every
``>>>`` example, of the pages and of the docstrings, on the same doctrees; and every shell command
of the getting-started page runs, in order, in an empty folder.
"""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("sphinx")
pytest.importorskip("myst_parser")
pytest.importorskip("numpydoc")

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "doc"
BIN = Path(sys.executable).parent


def _sphinx(builder, doctrees, out):
    cmd = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", builder,
           "-d", str(doctrees), str(DOC), str(out)]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=ROOT)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    base = tmp_path_factory.mktemp("site")
    proc = _sphinx("html", base / "doctrees", base / "html")
    return base, proc


def test_the_site_builds_with_warnings_as_errors(site):
    base, proc = site
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert (base / "html" / "index.html").is_file()


def test_the_examples_run(site):
    base, proc = site
    assert proc.returncode == 0, "the HTML build failed"
    doctest = _sphinx("doctest", base / "doctrees", base / "doctest")
    assert doctest.returncode == 0, doctest.stdout + doctest.stderr
    report = (base / "doctest" / "output.txt").read_text()
    assert (re.search(r"\b0 failures in tests", report)
            and not re.search(r"[1-9]\d* failures? in", report))
    # the run's total (the summary at the end), not the first page's count
    assert int(re.findall(r"(\d+) tests", report)[-1]) >= 20, report


def test_the_two_questions_are_one_click_from_the_index(site):
    """
    The index links to both questions' answers.

    'How do I run a whisking study?' and 'what exactly does m0 mean?'
    """
    base, _ = site
    index = (base / "html" / "index.html").read_text()
    assert 'href="getting-started.html#first-whisking-study"' in index
    assert 'href="observables.html#term-m0"' in index
    assert 'id="term-m0"' in (base / "html" / "observables.html").read_text()


def test_every_figure_is_drawn_by_the_build(site):
    """No pasted pictures: the pages' images are the ones the figure extension drew."""
    base, _ = site
    sources = [p for p in DOC.rglob("*") if p.suffix in (".md", ".rst")]
    for page in sources:
        text = page.read_text()
        assert not re.search(r"!\[[^\]]*\]\(", text), f"{page}: a pasted image"
        assert ".. image::" not in text and "{image}" not in text, f"{page}: a pasted image"
    drawn = sum(page.read_text().count("{vibrissa-figure}") for page in sources)
    images = list((base / "html" / "_images").glob("*.png"))
    assert drawn >= 7 and len(images) == drawn, images


def _blocks(page):
    return re.findall(r"```bash\n(.+?)```", (DOC / page).read_text(), re.S)


def _readme_commands():
    quick = (ROOT / "README.md").read_text().split("## Quick start", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```\n(.+?)\n```", quick)


def test_getting_started_shows_the_readme_commands():
    install, tests = _blocks("getting-started.md")[:2]
    assert [install.strip(), tests.strip()] == _readme_commands()


def test_the_getting_started_commands_run(tmp_path, ros_env):
    """Each command block of the getting-started page, in order, in one empty folder."""
    (tmp_path / "config").symlink_to(ROOT / "config")
    env = dict(ros_env, PATH=f"{BIN}{os.pathsep}{ros_env.get('PATH', '')}")
    install, _tests, *rest = _blocks("getting-started.md")
    # the install is this environment's; the test command is this suite; the main job runs
    first_run = install.strip().rsplit(" && ", 1)[1].replace(".venv/bin/", "")
    for block in [first_run] + rest:
        proc = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", block], cwd=tmp_path, env=env,
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, f"{block}\n{proc.stdout}\n{proc.stderr}"
    assert (tmp_path / "sweep.csv").read_text().count("\n") == 1602
    for name in ("scan.csv", "events.json", "scan.png", "catenary_sweep.csv", "run.mcap",
                 "run_export.csv", "whisk_study/manifest.json"):
        assert (tmp_path / name).is_file(), name
