"""
Sphinx configuration of the vibrissa_ros documentation.

Build it with ``sphinx-build -W --keep-going doc doc/_build/html`` (what test/test_docs.py
runs) or with ``rosdoc2 build --package-path .`` (see building.md). rosdoc2 copies this
folder into a build directory of its own and executes this file from there, so nothing here
may rely on ``__file__`` pointing into the source tree: the package is found by import, and
the local extensions beside this file (``_ext``) through ``__file__``'s folder, which rosdoc2
copies with it.
"""

import os
import sys
from pathlib import Path

_HERE = Path(__file__).resolve().parent
if (_HERE.parent / "package.xml").is_file():  # sphinx-build on the source tree
    sys.path.insert(0, str(_HERE.parent))
sys.path.insert(0, str(_HERE / "_ext"))

import vibrissa_ros  # noqa: E402, F401 - fails here, not in autodoc, if it cannot be imported

project = "vibrissa_ros"
author = "vibrissa_ros maintainers"
copyright = "vibrissa_ros maintainers, Apache-2.0"
release = version = "0.1.0"

extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.doctest",
    "sphinx.ext.mathjax",
    "vibrissa_figures",
]

# rosdoc2 removes extensions it does not know unless this is set (numpydoc, vibrissa_figures)
rosdoc2_settings = {"allow_other_extensions": True}

templates_path = ["_templates"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = master_doc = "index"
# rosdoc2 adds its own files beside ours (sphinx-apidoc pages, copies of this folder and of the
# README, its output folder): they are not part of this site
exclude_patterns = ["_build", "sphinx_output", "modules.rst", "vibrissa_ros*.rst", "interfaces",
                    "user_docs", "user_docs*.rst", "standard_docs", "standards.rst", "__*"]
nitpicky = False

myst_enable_extensions = ["dollarmath", "deflist", "colon_fence"]
myst_heading_anchors = 3

autosummary_generate = True
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
# every object of the API reference (see building.md): has a docstring (GL08); documents every
# parameter it takes (PR01), none it does not take (PR02), in the signature's order (PR03), each
# with a type (PR04, PR10: "name : type") and a description (PR07); a function that returns a
# value has a Returns section (RT01), its entries described (RT03), a single value by its type
# alone (RT02); a generator a Yields section (YD01); the sections are numpydoc's (GL06), in their
# order (GL07)
numpydoc_validation_checks = {"GL06", "GL07", "GL08", "PR01", "PR02", "PR03", "PR04", "PR07",
                              "PR10", "RT01", "RT02", "RT03", "YD01"}
# Phase is an IntEnum: its call signature is Enum's functional API (value, names, module, ...),
# not parameters of ours, so PR01 cannot hold; its docstring names the members instead
numpydoc_validation_exclude = {r"\.__\w+__$", r"\._\w+$",
                               r"^vibrissa_ros\.core\.state\.Phase$"}


html_theme = "sphinx_rtd_theme"
html_title = "vibrissa_ros"
html_show_sourcelink = False

# the figures run the project's own commands (vibrissa_figures): where they find config/
vibrissa_root = os.environ.get("VIBRISSA_ROOT", "")
