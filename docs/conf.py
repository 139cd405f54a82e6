"""Sphinx configuration of the stencil_cad documentation.

Build: ``sphinx-build -W --keep-going -n -b html docs docs/_build/html`` (warnings are errors,
every cross-reference must resolve); ``tests/docs/test_docs_site.py`` builds the site and checks
that every internal link and anchor resolves and that every command, flag and config key is in it.
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
sys.path.insert(0, str(HERE.parent))

import stencil_cad  # noqa: E402

project = "stencil_cad"
author = "the stencil_cad authors"
copyright = "the stencil_cad authors, MIT licence"  # noqa: A001
release = stencil_cad.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "stencil_refs",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "_ext", "make_*.py"]
# `## Heading` gets an anchor that `[text](page.md#heading)` links to.
myst_heading_anchors = 3
myst_enable_extensions = ["colon_fence"]

# Every cross-reference between pages must resolve: documents, section labels, commands and flags
# (:option:), config keys (:confval:). References in docstrings to Python objects are not checked
# here: docstrings name internal modules and other projects' types that this site does not
# document (and intersphinx would need the internet); they render as code.
nitpicky = True
nitpick_ignore_regex = [(r"py:.*", r".*")]

autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_typehints_format = "short"
autodoc_default_options = {"members": True, "show-inheritance": False}
napoleon_google_docstring = True
napoleon_numpy_docstring = False

html_theme = "furo"
html_title = "stencil_cad"
html_static_path: list[str] = []
