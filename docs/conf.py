"""Sphinx configuration of the cortex-ti documentation.

Build (warnings are errors; the gallery's examples run)::

    python -m pip install -e '.[docs]'
    python -m sphinx -W -b html docs docs/_build/html

Pages are Markdown (MyST). The toctrees of guide/, method/, validation/ and derivations/ pick up
every page in their folder by glob, so a new page joins the site without editing an index.
"""

from __future__ import annotations

import logging
import os
import sys
from datetime import date
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # document (and run the examples against) this checkout
os.environ.setdefault("CORTEX_TI_THREADS", "2")

import cortex_ti  # noqa: E402

project = "cortex-ti"
author = "the cortex-ti developers"
copyright = f"{date.today().year}, {author}"
release = cortex_ti.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = [
    "_build",
    "Thumbs.db",
    ".DS_Store",
    "examples/GALLERY_HEADER.rst",
    "auto_examples/*.ipynb",
    "auto_examples/*.py",
    "auto_examples/*.zip",
    "auto_examples/*.md5",
    "auto_examples/*.json",
    "sg_execution_times.rst",
]

# MyST: headings get anchors (links like page.md#a-heading), $...$ maths, definition lists
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath", "deflist", "colon_fence"]

# API reference from the docstrings
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_typehints = "description"
autodoc_member_order = "bysource"
napoleon_numpy_docstring = True
napoleon_google_docstring = False
# The docstrings were written for readers of the code, not for reST: some use |x| for a norm
# (a substitution in reST) or indent freely. Their reST complaints are shown as messages, not
# warnings (see _DocstringMarkup below), until they are cleaned after the merge; every page written
# for the site is held to -W. Ambiguous type names in signatures (Scene is re-exported by
# cortex_ti.scene) and the command-line options named in docstrings are not cross-referenced.
suppress_warnings = ["ref.python", "ref.option"]
nitpicky = False

# The example gallery: docs/examples/*.py, run at every build (small meshes, seconds each)
sphinx_gallery_conf = {
    "examples_dirs": ["examples"],
    "gallery_dirs": ["auto_examples"],
    "filename_pattern": r"/plot_",
    "ignore_pattern": r"__init__\.py",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "abort_on_example_error": True,
    "only_warn_on_example_error": False,
    "image_scrapers": ("matplotlib",),
    "matplotlib_animations": False,
    "reset_modules": ("matplotlib",),
    "min_reported_time": 1,
    "show_memory": False,
    "plot_gallery": os.environ.get("CORTEX_TI_DOCS_GALLERY", "True"),
}

html_theme = "furo"
html_title = f"cortex-ti {release}"
html_static_path: list[str] = []
html_theme_options = {"navigation_with_keys": True}


class _DocstringMarkup(logging.Filter):
    """reST complaints about the package's docstrings (and autosummary's copies of their first
    lines) become messages instead of warnings, so -W holds the pages to account, not the code."""

    def filter(self, record: logging.LogRecord) -> bool:
        where = str(getattr(record, "location", "") or "")
        if record.levelno >= logging.WARNING and ("docstring of" in where or "<autosummary>" in where):
            record.levelno, record.levelname = logging.INFO, "INFO"
            record.msg = f"docstring markup (not an error): {record.msg}"
        return True


_DOCUMENTING = {"module": ""}


def _note_module(app, what, name, obj, options, lines):
    """Which module autodoc is documenting (its docstring comes before its members)."""
    if what == "module":
        _DOCUMENTING["module"] = name


def _skip_reexport(app, what, name, obj, skip, options):
    """A module that is not a package documents only what it defines: a name it imports from
    another module of the package (a public face like ``io.trajectory``, kept for the import paths
    users have) is documented where it is defined, once; the package's ``__init__`` pages list their
    exports as before."""
    module = sys.modules.get(_DOCUMENTING["module"])
    if what != "module" or module is None or hasattr(module, "__path__"):
        return None
    home = getattr(obj, "__module__", None)
    if isinstance(home, str) and home.startswith("cortex_ti.") and home != module.__name__:
        return True
    return None


def setup(app):
    logging.getLogger("sphinx.sphinx.util.docutils").addFilter(_DocstringMarkup())
    app.connect("autodoc-process-docstring", _note_module)
    app.connect("autodoc-skip-member", _skip_reexport)
