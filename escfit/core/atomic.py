"""Atomic file output: write to a temporary file beside the target, then rename.

A failed run therefore never leaves a partial file, and an existing file is replaced only
when the caller says so (``force=True``).  Commands check their outputs before any work with
:func:`refuse_clobbering_inputs` (an output is never an input, nor another output) and
:func:`check_output_folder`.  The file gets the permissions an ordinary
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

__all__ = ["atomic_path", "refuse_existing", "refuse_clobbering_inputs", "check_output_folder", "current_umask",
           "new_file_mode"]


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
        raise ResultsError("output file exists; pass --force to replace it", str(path))


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether ``a`` and ``b`` name one file: equal resolved paths (symlinks, ``./x`` and ``x``),
    or, when both exist, one inode (hard links)."""
    if Path(a).resolve() == Path(b).resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # either is missing or unreadable: not the same existing file
        return False


def refuse_clobbering_inputs(outputs: dict[str, str | Path | None], inputs: dict[str, str | Path | None]) -> None:
    """Refuse an output that is one of the command's inputs or another of its outputs.

    Checked before any work, so that ``--force`` can never replace the data, the scene or a
    file the same command writes twice.

    Parameters
    ----------
    outputs
        Output role (as the user names it, e.g. ``"--out"``) to path; ``None`` paths are skipped.
    inputs
        Input role (e.g. ``"data"``, ``"scene"``) to path; ``None`` paths are skipped.

    Raises
    ------
    ResultsError
        Naming the output and both roles, e.g. ``results.h5: --out is the data file``.
    """
    seen = [(role, path) for role, path in inputs.items() if path is not None]
    for role, path in outputs.items():
        if path is None:
            continue
        for other_role, other in seen:
            if same_file(path, other):
                raise ResultsError(f"{role} is the {other_role} file; choose another output name", str(path))
        seen.append((role, path))


def check_output_folder(path: str | Path, role: str = "output") -> None:
    """Refuse, before any work, an output whose folder is missing, not a folder or not writable.

    Raises
    ------
    ResultsError
        Naming the output, its role and the folder.
    """
    target = Path(path)
    folder = target.parent
    if target.is_dir():
        raise ResultsError(f"{role} is a folder; give a file name", str(target))
    if not folder.exists():
        raise ResultsError(f"the folder of {role} does not exist ({folder}); create it first", str(target))
    if not folder.is_dir():
        raise ResultsError(f"the folder of {role} is not a folder ({folder} is a file)", str(target))
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ResultsError(f"the folder of {role} is not writable ({folder})", str(target))


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
