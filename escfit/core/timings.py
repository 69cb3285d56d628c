"""Wall and CPU seconds of a command's phases (``escfit fit --timings``).

A phase is timed by wrapping it in :func:`phase`; phases of the same name add up, and a phase
opened inside another is counted in the inner one only (the outer one is charged what is left),
so the rows never count a second twice.  :func:`table` lays the rows out with the start-up
(interpreter start to the first phase, read from ``/proc`` where there is one) and the rest of
the process (argument checks, output between phases) so that the rows add up to the whole
command.  CPU seconds are the process's (``time.process_time``: every thread, this process
only; numba and BLAS run in it).

Recording costs two clock reads per phase, so the hooks stay in place whether or not the
timings are printed.
"""

from __future__ import annotations

import os
import time
from contextlib import contextmanager
from typing import Iterator

__all__ = ["phase", "phases", "reset", "since_process_start", "table"]

# name -> [wall s, cpu s], in the order first seen
_TOTALS: dict[str, list[float]] = {}
# the clocks of the open phases, innermost last: [name, wall start, cpu start, wall of inner phases, cpu of inner]
_OPEN: list[list] = []
# wall and CPU clocks when this module was imported: the fallback start of the process
_IMPORTED = (time.perf_counter(), time.process_time())


def since_process_start() -> tuple[float, float]:
    """Wall and CPU seconds since this process started.

    The wall clock is read from ``/proc/self/stat`` and ``/proc/uptime`` (Linux, 10 ms
    resolution); elsewhere it counts from this module's import, which misses the interpreter's
    own start (a few tens of ms).
    """
    cpu = time.process_time()
    try:
        with open("/proc/self/stat", "rb") as fh:
            # the command name (field 2) may hold spaces: count fields after its closing bracket
            started_ticks = int(fh.read().rsplit(b")", 1)[1].split()[19])
        with open("/proc/uptime", "rb") as fh:
            uptime = float(fh.read().split()[0])
        wall = uptime - started_ticks / os.sysconf("SC_CLK_TCK")
        if wall >= 0:
            return wall, cpu
    except (OSError, ValueError, IndexError):
        pass
    return time.perf_counter() - _IMPORTED[0], cpu


@contextmanager
def phase(name: str) -> Iterator[None]:
    """Time the enclosed block as phase ``name`` (wall and CPU seconds, added to earlier ones)."""
    own = _TOTALS.setdefault(name, [0.0, 0.0])  # listed in the order the phases start
    entry = [name, time.perf_counter(), time.process_time(), 0.0, 0.0]
    _OPEN.append(entry)
    try:
        yield
    finally:
        wall = time.perf_counter() - entry[1]
        cpu = time.process_time() - entry[2]
        _OPEN.remove(entry)
        own[0] += wall - entry[3]
        own[1] += cpu - entry[4]
        if _OPEN:  # charged to this phase, not again to the one around it
            _OPEN[-1][3] += wall
            _OPEN[-1][4] += cpu


def phases() -> dict[str, tuple[float, float]]:
    """The phases timed so far: name -> (wall s, CPU s), in the order they first ran."""
    return {k: (v[0], v[1]) for k, v in _TOTALS.items()}


def reset() -> None:
    """Forget the phases timed so far (tests, or several commands in one process)."""
    _TOTALS.clear()
    _OPEN.clear()


def table(startup: tuple[float, float] | None = None) -> str:
    """The phases as a text table, with the start-up before them and the rest of the process.

    Parameters
    ----------
    startup
        Wall and CPU seconds from the process's start to the command's first phase (see
        :func:`since_process_start`); without it the table holds the timed phases only.

    Returns
    -------
    str
        One row per phase, ``phase  wall s  CPU s``, and a total: the process so far when
        ``startup`` is given.
    """
    rows = [("start-up", *startup)] if startup is not None else []
    rows += [(name, wall, cpu) for name, (wall, cpu) in phases().items()]
    if startup is not None:
        wall_now, cpu_now = since_process_start()
        rest = (wall_now - sum(r[1] for r in rows), cpu_now - sum(r[2] for r in rows))
        rows.append(("other", max(rest[0], 0.0), max(rest[1], 0.0)))
        rows.append(("total (process)", wall_now, cpu_now))
    else:
        rows.append(("total", sum(r[1] for r in rows), sum(r[2] for r in rows)))
    width = max(len(r[0]) for r in rows)
    lines = [f"{'phase':<{width}}  {'wall s':>8}  {'CPU s':>8}"]
    lines += [f"{name:<{width}}  {wall:8.3f}  {cpu:8.3f}" for name, wall, cpu in rows]
    return "\n".join(lines)
