"""One run at a time per results file: an operating-system lock beside it.

Two runs of one fit (two ``--resume`` of one interrupted run, typed in two terminals) would
both sample from one checkpoint; the first to finish writes the results and deletes the
checkpoint, the second does all the work and is then refused ("output file exists") with
nothing left to resume.  :func:`output_lock` holds an exclusive ``flock`` on
``.<results name>.lock`` beside the results file for the whole run; a second run finds it
held and is refused before any work, naming the holder's pid.

The kernel drops the lock however its holder ends (``kill -9`` included).  The holder removes
the file when it is done; one a killed holder left behind is taken over by the next run (it is
not held) and removed when that run is done.  A run that locked a file another run removed in
the meantime notices that the name no longer points at it and locks again.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Iterator

from .errors import ResultsError

__all__ = ["output_lock", "lock_path"]


def lock_path(out: str | Path) -> Path:
    """The lock file of results file ``out``: ``.<name>.lock`` beside it."""
    out = Path(out)
    return out.with_name(f".{out.name}.lock")


@contextlib.contextmanager
def output_lock(out: str | Path) -> Iterator[Path]:
    """Hold the lock of results file ``out`` for the duration of the block.

    Raises
    ------
    ResultsError
        Another process holds it (the message names its pid), or the lock file cannot be made.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: no lock
        yield lock_path(out)
        return
    path = lock_path(out)
    fd = _acquire(path, fcntl)
    try:
        yield path
    finally:
        with contextlib.suppress(OSError):
            os.unlink(path)  # while still held: no other run can be between its open and its lock of it
        with contextlib.suppress(OSError):
            fcntl.flock(fd, fcntl.LOCK_UN)
        os.close(fd)


def _acquire(path: Path, fcntl) -> int:
    for _ in range(100):  # another run removing the file between our open and our lock: try again
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise ResultsError(f"cannot create the lock file {path.name} ({exc.strerror or exc})",
                               str(path.parent)) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(fd)
            os.close(fd)
            raise ResultsError(f"another escfit run{holder} is writing this results file; wait for it to finish, or "
                               "choose another --out", str(path.with_name(path.name[1:-len('.lock')]))) from None
        except OSError:  # a file system without locks: run unlocked, as before
            return fd
        try:
            same = os.stat(path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            with contextlib.suppress(OSError):
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
            return fd
        os.close(fd)
    raise ResultsError(f"cannot take the lock file {path.name}: it keeps being replaced", str(path.parent))


def _holder(fd: int) -> str:
    try:
        pid = os.pread(fd, 32, 0).decode().strip()
    except (OSError, UnicodeDecodeError):
        return ""
    return f" (pid {pid})" if pid.isdigit() else ""
