"""Sphinx configuration of dynval's documentation site (build: ``python3 -m dynval.docs`` or
``python3 -m sphinx -W -b html docs docs/_build/html``)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # _ext: the site's small local extensions

import dynval  # noqa: E402  (the installed package, or the source tree on PYTHONPATH)

project = "dynval"
author = "the dynval developers"
copyright = "the dynval developers, MIT licence"
release = dynval.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.intersphinx",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
    "_ext.findings_table",
    "_ext.api_pages",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "protocol-only-port/*.py", "gallery/README.rst", "**/GALLERY_HEADER.rst"]
myst_enable_extensions = ["colon_fence", "dollarmath"]
myst_heading_anchors = 3
# The markdown documents are also read on the code host, where their links point at files of the
# checkout (python/..., ../README.md): those are not pages of the site, and say so once here rather
# than as hundreds of warnings. Every link between pages is still checked.
suppress_warnings = ["myst.xref_missing", "myst.header",
                     # Pygments has no lexer that takes PROTOCOL.md's Wolfram Language recipe whole
                     # ($Failed); the block is then shown unhighlighted, which is what a reader needs.
                     "misc.highlighting_failure"]

autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"members": True, "inherited-members": False, "show-inheritance": True}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

intersphinx_mapping = {}

html_theme = "pydata_sphinx_theme"
html_title = f"dynval {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "footer_start": ["copyright"],
    "footer_end": [],
}
html_static_path: list[str] = []

# The gallery's examples run at every build: a broken example fails the build.
sphinx_gallery_conf = {
    "examples_dirs": "gallery",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "abort_on_example_error": True,
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib",),
    "show_memory": False,
    "plot_gallery": os.environ.get("DYNVAL_DOCS_GALLERY", "True"),
}
