"""Atomic file output: write to a temporary file beside the target, then rename.

A failed run therefore never leaves a partial file, and an existing file is replaced only
when the caller says so (``force=True``).  Commands check their outputs before any work with
:func:`refuse_clobbering_inputs` (an output is never an input, nor another output) and
:func:`check_output_folder`.  The file gets the permissions an ordinary
``open(path, "w")`` would give (0644 under the usual umask 022), not the 0600 of
:func:`tempfile.mkstemp`: results are for colleagues and web servers too.
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from .errors import ResultsError

__all__ = ["atomic_path", "refuse_existing", "existing_kind", "refuse_folder_syntax", "name_limit", "refuse_clobbering_inputs", "check_output_folder", "current_umask",
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


# What stands at an output path, by ``stat`` file type (see :func:`existing_kind`)
KINDS = {stat.S_IFREG: "regular file", stat.S_IFDIR: "folder", stat.S_IFLNK: "symbolic link",
         stat.S_IFIFO: "FIFO (named pipe)", stat.S_IFSOCK: "socket", stat.S_IFCHR: "character device",
         stat.S_IFBLK: "block device"}
# A temporary beside the target is named ``.<name>.<8 random characters>.part``
TEMPORARY_EXTRA = len("..12345678.part")


def existing_kind(path: str | Path) -> str | None:
    """What is at ``path`` itself (a symbolic link is not followed): ``None`` when nothing is,
    else ``"regular file"``, ``"folder"``, ``"symbolic link"``, ``"FIFO (named pipe)"``, ..."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return None
    except OSError as exc:
        if exc.errno in (errno.ENAMETOOLONG, errno.ENOTDIR):  # nothing can be there; the name is judged later
            return None  # e.g. a name too long: refused by check_output_folder with its own words
        raise ResultsError(f"cannot use this output path ({exc.strerror or exc})", str(path)) from None
    return KINDS.get(stat.S_IFMT(mode), "special file")


def refuse_folder_syntax(path: str | Path) -> None:
    """Refuse an output written as a folder (``res/``): a file name cannot end with a separator."""
    text = os.fspath(path)
    if isinstance(text, str) and (text.endswith("/") or (os.altsep and text.endswith(os.altsep))):
        raise ResultsError("ends with '/', so it names a folder; give a file name", text)


def refuse_existing(path: str | Path, force: bool) -> None:
    """Refuse to replace what is at ``path``.

    Nothing there: fine.  A regular file: replaced only with ``force``.  Anything else (a
    device such as ``/dev/null``, a FIFO, a socket, a folder, a symbolic link, dangling or
    not) is never replaced, ``force`` or not: renaming a new file over it would destroy
    something that is not an earlier result.

    Raises
    ------
    ResultsError
        Naming the path and what is there.
    """
    refuse_folder_syntax(path)
    kind = existing_kind(path)
    if kind is None:
        return
    if kind != "regular file":
        raise ResultsError(f"is a {kind}, not a results file; only a regular file is ever replaced (--force "
                           "or not): choose another name", str(path))
    if not force:
        raise ResultsError("output file exists; pass --force to replace it", str(path))


def name_limit(folder: str | Path) -> int:
    """The longest file name (bytes) the file system of ``folder`` takes (255 where unknown)."""
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return 255


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


def check_output_folder(path: str | Path, role: str = "output", *, companions: int = 0) -> None:
    """Refuse, before any work, an output whose folder is missing, not a folder or not writable,
    or whose name (with its temporary's additions) is longer than the file system takes.

    Parameters
    ----------
    companions
        Bytes that files written beside the output add to its stem (a Markdown report's
        ``<stem>_<figure>.png``), so that their names are checked too.

    Raises
    ------
    ResultsError
        Naming the output, its role and the folder.
    """
    refuse_folder_syntax(path)
    target = Path(path)
    folder = target.parent
    if existing_kind(target) == "folder":
        raise ResultsError(f"{role} is a folder; give a file name", str(target))
    if not folder.exists():
        raise ResultsError(f"the folder of {role} does not exist ({folder}); create it first", str(target))
    if not folder.is_dir():
        raise ResultsError(f"the folder of {role} is not a folder ({folder} is a file)", str(target))
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ResultsError(f"the folder of {role} is not writable ({folder})", str(target))
    limit = name_limit(folder)
    name, stem = len(os.fsencode(target.name)), len(os.fsencode(target.stem))
    allowed = min(limit - TEMPORARY_EXTRA, limit - companions + (name - stem))
    if name > allowed:
        raise ResultsError(f"the file name of {role} is {name} bytes long; at most {allowed} fit this file system "
                           "(with the additions of its temporary and companion files): choose a shorter name",
                           str(target))


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
    refuse_folder_syntax(path)
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
