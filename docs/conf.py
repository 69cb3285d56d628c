"""Sphinx configuration of escfit's documentation site.

Build it from a clone with the ``docs`` extra installed::

    pip install -e ".[docs]"
    sphinx-build -W --keep-going -b html docs docs/_build/html

Pages are Markdown (MyST); the CLI reference comes from the click commands (sphinx-click),
the API reference from the numpydoc docstrings (autodoc + numpydoc), and the scene-key
reference from the scene readers themselves (``_ext/escfit_scenekeys.py``).
"""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
# the checkout's escfit first, so a clone documents itself even when another copy is installed
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(DOCS / "_ext"))

from escfit import __version__  # noqa: E402

project = "escfit"
author = "the escfit authors"
copyright = "escfit authors, MIT licence"
version = release = __version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "numpydoc",
    "sphinx_click",
    "escfit_scenekeys",
    "escfit_sitepages",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "_readme_draft.md", "**/_*.md", "Thumbs.db", ".DS_Store"]
templates_path = []

# MyST: anchors for headings down to ### so pages can link to sections (#sampled-free-decays)
myst_heading_anchors = 3
myst_enable_extensions = ["colon_fence", "deflist", "attrs_block"]
# "--scene" in the click commands' help must stay two hyphens, not become a dash
smartquotes = False

# autodoc + numpydoc: the public facade only; members of classes are listed where a page asks
autodoc_member_order = "bysource"
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

html_theme = "furo"
html_title = f"escfit {release}"
html_static_path = []
html_theme_options = {
    "source_edit_link": None,
    "navigation_with_keys": True,
}
pygments_style = "sphinx"
pygments_dark_style = "monokai"
