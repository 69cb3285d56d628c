"""Sphinx extension: pages added to ``docs/`` appear in the navigation even before the index names them.

Each model family and area keeps its page at ``docs/<name>.md``.  A new page that the index's
tables of contents do not name yet would stop a build run with warnings as errors
("document isn't included in any toctree"); this extension adds such pages to a last "More"
section of the navigation instead, and says so in the build log, so that they can be given
their place in ``docs/index.md``.
"""

from __future__ import annotations

import re
from pathlib import Path

from sphinx.util import logging

logger = logging.getLogger(__name__)


def _unlisted(srcdir: Path, index_text: str) -> list[str]:
    named = set(re.findall(r"^\s*([\w./-]+)\s*$", index_text, re.M))
    out = []
    for page in sorted(srcdir.glob("*.md")):
        name = page.stem
        if name.startswith("_") or name == "index" or name in named:
            continue
        out.append(name)
    return out


def add_unlisted(app, docname, source):
    if docname != app.config.root_doc:
        return
    extra = _unlisted(Path(app.srcdir), source[0])
    if extra:
        logger.info(f"pages not yet placed in index.md, listed under 'More': {', '.join(extra)}")
        source[0] += "\n\n```{toctree}\n:caption: More\n:maxdepth: 1\n:hidden:\n\n" + "\n".join(extra) + "\n```\n"


def reread_index(app, env, added, changed, removed):
    """The index is read on every build, so a page added or removed since the last one is seen."""
    return [app.config.root_doc]


def setup(app):
    app.connect("source-read", add_unlisted)
    app.connect("env-get-outdated", reread_index)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
