"""Input files must be regular files: what else is there is named, not read.

A FIFO or ``/dev/stdin`` would block the reader until someone writes to it, ``/dev/zero`` or
``/dev/urandom`` would be read until the memory is full, a socket cannot be read at all; each
was reported "not found", which sends the user looking for a missing file.  Symbolic links
are followed (a link to a recording is a recording).
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from .errors import DataError, EscfitError

__all__ = ["input_kind", "check_input_file"]

KINDS = {stat.S_IFDIR: "folder", stat.S_IFIFO: "FIFO (named pipe)", stat.S_IFSOCK: "socket",
         stat.S_IFCHR: "character device", stat.S_IFBLK: "block device"}


def input_kind(path: str | Path) -> str | None:
    """``None`` for a regular file (after following links), ``"missing"`` when nothing is there
    (or a link points nowhere), else what is there (``"FIFO (named pipe)"``, ``"folder"``, ...)."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return "missing"
    except OSError as exc:
        return f"unreadable path ({exc.strerror or exc})"
    if stat.S_ISREG(mode):
        return None
    return KINDS.get(stat.S_IFMT(mode), "special file")


def check_input_file(path: str | Path, role: str, error: type[EscfitError] = DataError, *,
                     folder_ok: bool = False) -> None:
    """Refuse an input ``path`` that is not a regular file, naming the role and what is there.

    Parameters
    ----------
    role
        What the file is for, e.g. ``"data"`` or ``"scene"``: ``"data file not found"``.
    error
        The error class raised.
    folder_ok
        Accept a folder (inputs that may be folders of recordings).
    """
    kind = input_kind(path)
    if kind is None or (folder_ok and kind == "folder"):
        return
    if kind == "missing":
        raise error(f"{role} file not found", str(path))
    raise error(f"is a {kind}, not a {role} file; give a regular file", str(path))
