"""A fresh working folder for a command run in-process (what click's ``isolated_filesystem`` gave,
which click 8.5 deprecates)."""

from __future__ import annotations

import contextlib
import tempfile
from pathlib import Path


@contextlib.contextmanager
def new_folder(parent: Path):
    """Change into a new empty folder under ``parent`` for the block; yield its path (text)."""
    here = tempfile.mkdtemp(dir=parent)
    with contextlib.chdir(here):
        yield here
