"""Sphinx configuration of the documentation site (``make docs-site``).

Markdown throughout (MyST); the catalogue of scenarios, streams and suites is written from
the shipped files when the build starts (``_ext/catalogue.py``); the tutorials are
notebooks in MyST Markdown, executed on every build: an exception in one fails the build.
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

import flatland_ma  # noqa: E402

project = "flatland_ma"
author = "the flatland_ma authors"
copyright = "the flatland_ma authors"
release = flatland_ma.__version__
version = release

extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx_copybutton",
    "catalogue",
    "cli_page",
]

# Markdown (.md) is read by MyST; .md files with a kernel in their front matter are
# notebooks (the tutorials).
source_suffix = {".md": "myst-nb", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "_ext", "lifelong/*/*.json", "README.md", "**/.ipynb_checkpoints"]

myst_enable_extensions = ["colon_fence", "attrs_inline"]
myst_heading_anchors = 3

# Every tutorial runs on every build, start to end; any exception fails the build.
nb_execution_mode = "force"
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_execution_timeout = 1800  # seconds per cell: a kill for a hung cell, far above any cell's need
nb_merge_streams = True

autodoc_member_order = "bysource"
autodoc_typehints = "description"
# Methods inherited from Gymnasium and PettingZoo keep their docs there (Google style).
autodoc_inherit_docstrings = False
autodoc_default_options = {"members": True}
# pydantic's own machinery (model_config, model_fields, ...) is not part of this API.
autodoc_pydantic_skip = {"model_config", "model_fields", "model_computed_fields"}

html_theme = "furo"
html_title = f"flatland_ma {release}"
html_static_path = ["_static"]
html_css_files = ["catalogue.css"]
html_favicon = "images/favicon.png"
html_show_sourcelink = False
html_last_updated_fmt = None
copybutton_exclude = ".linenos, .gp, .go"


PUBLIC_CONSTANTS = {
    "AUTORESET_MODE",
    "GYM_AUTORESET_MODE",
    "RENDER_MODES",
    "KNOWN_RENDER_MODES",
    "VECTOR_RENDER_MODES",
    "SUITES",
    "SHIPPED",
    "SENSOR_KINDS",
    "RULE_KINDS",
    "PART_KINDS",
    "GENERATOR_KINDS",
    "EXTENSION_GROUP",
}
"""Module constants users read; the other upper-case ones (tuning constants of policies,
limits of readers) are the modules' own and stay off the API pages."""


def _skip_member(app, what, name, obj, skip, options):
    if name in autodoc_pydantic_skip:
        return True
    if what == "module" and name.isupper() and name not in PUBLIC_CONSTANTS:
        return True  # an internal constant (``name.isupper()``: no lower-case letter)
    return None


def setup(app):
    app.connect("autodoc-skip-member", _skip_member)
