"""Atomic file output: write to a temporary file beside the target, then rename.

A failed run therefore never leaves a partial file, and an existing file is replaced only
when the caller says so (``force=True``).  The file gets the permissions an ordinary
``open(path, "w")`` would give (0644 under the usual umask 022), not the 0600 of
:func:`tempfile.mkstemp`: results are for colleagues and web servers too.
"""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from .errors import ResultsError

__all__ = ["atomic_path", "refuse_existing", "current_umask", "new_file_mode"]


def current_umask() -> int:
    """The process's umask, read without changing it where the system allows.

    Linux reports it in ``/proc/self/status``; elsewhere it is set and restored at once
    (``os.umask`` has no read-only form), which is brief but not thread-safe.
    """
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def new_file_mode() -> int:
    """Permission bits of a new regular file under the current umask (``0o666 & ~umask``)."""
    return 0o666 & ~current_umask()


def refuse_existing(path: str | Path, force: bool) -> None:
    """Raise :class:`ResultsError` if ``path`` exists and ``force`` is false."""
    if Path(path).exists() and not force:
        raise ResultsError("output file exists; pass --force (force=True in Python) to replace it", str(path))


@contextmanager
def atomic_path(path: str | Path, *, force: bool = False) -> Iterator[Path]:
    """Yield a temporary path to write; on success it replaces ``path`` atomically.

    Parameters
    ----------
    path
        Final file name.  Its directory must exist.
    force
        Replace an existing file.  Checked before and again just before the rename.
    """
    target = Path(path)
    refuse_existing(target, force)
    if not target.parent.exists():
        raise ResultsError("output directory does not exist", str(target.parent))
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=target.parent)
    os.close(fd)
    os.chmod(tmp, new_file_mode())  # mkstemp makes 0600; results are for colleagues too
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        refuse_existing(target, force)
        os.replace(tmp_path, target)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()
