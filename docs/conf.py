"""Sphinx configuration of the ballchain documentation site.

Build:  pip install -e ".[docs]"  then  sphinx-build -W -b html docs docs/_build
The markdown pages of docs/ are read as they are (MyST); the API reference comes from
the docstrings; the tables of the HDF5 layout and the sweep table's columns are generated
from the code's own descriptions at build time (docs/_ext/generated_tables.py), so they
cannot drift; the gallery (docs/examples/) runs at build time.
"""

import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent / "_ext"))

project = "ballchain"
author = "the ballchain developers"
copyright = "2026, the ballchain developers"
from ballchain import __version__ as release  # noqa: E402

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
    "generated_tables",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "data", "figures/cache", "examples/README.md", "**/.ipynb_checkpoints"]
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath"]  # $...$ and $$...$$: the pages' equations, rendered by MathJax
suppress_warnings = ["myst.xref_missing", "myst.header", "config.cache"]  # (links to repository files)
smartquotes = False  # options such as --initial stay two hyphens (not an en dash) in every page
html_theme = "furo"
html_title = f"ballchain {release}"
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "undoc-members": False}

os.environ.setdefault("MPLBACKEND", "Agg")
from figure_scraper import figure_scraper  # noqa: E402

sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",  # every plot_*.py example runs at build time (each takes seconds)
    "download_all_examples": False,
    "within_subsection_order": "FileNameSortKey",  # the examples in their numbered order
    "remove_config_comments": True,
    "image_scrapers": (figure_scraper, "matplotlib"),  # ours first: it leaves pyplot's figures to matplotlib's
    "capture_repr": ("_repr_html_", "__repr__"),  # the view (plotly, embedded) and tables show as HTML
}


def _plain_fields(app, what, name, obj, options, lines):
    """The parameter classes document their fields as ``name: text`` lines with indented
    continuations (plain text, read as it is in the source): shown preformatted."""
    if not name.startswith(("ballchain.model.", "ballchain.records.result.Result")) or what not in ("class",):
        return
    for k, line in enumerate(lines):
        if k > 0 and line and not line.startswith(" ") and ": " in line and lines[k - 1] == "":
            body = lines[k:]
            del lines[k:]
            lines.extend(["::", ""] + ["    " + ln for ln in body])
            return


def setup(app):
    app.connect("autodoc-process-docstring", _plain_fields)
