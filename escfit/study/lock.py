"""One batch at a time per results folder: an operating-system lock on a file in the folder.

Two ``fit-many`` runs writing into one folder would mix their units (some fitted with one
scene, some with another) and the last ``summary.nc`` would claim its own scene for all of
them.  :func:`folder_lock` holds an exclusive ``flock`` on ``<folder>/.escfit-fit-many.lock``
while a batch runs; a second batch finds it held and is refused before it writes anything.
The kernel drops the lock when the holder's file is closed or its process ends, however it
ends (``kill -9`` included), so a lock is never left stale.  The file stays behind (removing
it would let a third run lock a new file while the second still waits on the old one); what
it holds (the owner's pid, host and start time) is only read for the refusal message.

Within one process the lock is re-entrant for the thread holding it (:func:`fit_fleet`
writes its scene and then calls :func:`fit_many` under one lock); another thread of the same
process is refused like another process.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import json
import os
import socket
import threading
from pathlib import Path
from typing import Iterator

from ..core.errors import ResultsError

__all__ = ["LOCK_FILE", "FolderBusy", "folder_lock", "lock_owner"]

LOCK_FILE = ".escfit-fit-many.lock"

_held: dict[str, list] = {}  # folder (resolved) -> [fd, owning thread id, depth]
_guard = threading.Lock()


class FolderBusy(ResultsError):
    """Another batch holds the results folder's lock."""


def lock_owner(folder: str | Path) -> dict:
    """What the folder's lock file says about its holder (pid, host, started), or ``{}``."""
    try:
        text = (Path(folder) / LOCK_FILE).read_text(encoding="utf-8")
        owner = json.loads(text)
    except (OSError, ValueError):
        return {}
    return owner if isinstance(owner, dict) else {}


def _describe(owner: dict) -> str:
    if not owner.get("pid"):
        return "another fit-many"  # its holder has not written its name yet
    host = f" on {owner['host']}" if owner.get("host") else ""
    started = f", started {owner['started']}" if owner.get("started") else ""
    return f"another fit-many (pid {owner['pid']}{host}{started})"


@contextlib.contextmanager
def folder_lock(folder: str | Path) -> Iterator[Path]:
    """Hold the results folder's lock for the duration of the block.

    Parameters
    ----------
    folder
        An existing directory.

    Yields
    ------
    Path
        The lock file.

    Raises
    ------
    FolderBusy
        Another process (or another thread of this one) holds the lock; the message names its
        pid, host and start time.
    ResultsError
        The lock file cannot be created (a read-only folder, for instance).
    """
    d = Path(folder)
    path = d / LOCK_FILE
    key = os.path.realpath(d)
    me = threading.get_ident()
    with _guard:
        entry = _held.get(key)
        if entry is not None and entry[1] == me:
            entry[2] += 1
            reentered = True
        else:
            reentered = False
    if reentered:
        try:
            yield path
        finally:
            with _guard:
                entry[2] -= 1
        return
    if entry is not None:
        raise _busy(d, lock_owner(d))
    fd = _acquire(d, path)
    with _guard:
        _held[key] = [fd, me, 1]
    try:
        yield path
    finally:
        with _guard:
            _held.pop(key, None)
        _release(fd)


def _busy(folder: Path, owner: dict) -> FolderBusy:
    return FolderBusy(f"{_describe(owner)} is writing here; wait for it or choose another --out", str(folder))


def _acquire(folder: Path, path: Path) -> int:
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: no lock, as before
        return -1
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    except OSError as exc:
        raise ResultsError(f"cannot create the lock file {LOCK_FILE} ({exc.strerror or exc})", str(folder)) from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise _busy(folder, lock_owner(folder)) from None
    except OSError as exc:  # a file system without locks
        os.close(fd)
        raise ResultsError(f"cannot lock {LOCK_FILE} ({exc.strerror or exc})", str(folder)) from None
    owner = {"pid": os.getpid(), "host": socket.gethostname(),
             "started": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")}
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, (json.dumps(owner) + "\n").encode(), 0)
    except OSError:
        pass  # the lock holds all the same; only the refusal message of a second run is poorer
    return fd


def _release(fd: int) -> None:
    if fd < 0:
        return
    import fcntl

    with contextlib.suppress(OSError):
        fcntl.flock(fd, fcntl.LOCK_UN)
    os.close(fd)


def remove_stale_temporaries(folder: str | Path, names: list[str] | set[str]) -> list[str]:
    """Delete the hidden temporaries an earlier batch killed mid-write left in ``folder``.

    Only the names :func:`escfit.core.atomic.atomic_path` gives the temporaries of the files
    ``names`` (``.<name>.<8 random characters>.part``) are touched; call it while holding
    :func:`folder_lock`, when no other batch can be writing them.

    Returns
    -------
    list of str
        The names of the files removed.
    """
    d = Path(folder)
    owned = set(names)
    removed = []
    for p in d.glob(".*.part"):
        stem = p.name[1:-len(".part")]
        base, _, tag = stem.rpartition(".")
        if base in owned and len(tag) == 8 and p.is_file():
            with contextlib.suppress(FileNotFoundError):
                p.unlink()
                removed.append(p.name)
    return sorted(removed)
