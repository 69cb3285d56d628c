"""Geneva recordings: driver-speed traces and terminal speeds, their CSV files and readers.

Two kinds of data:

* :class:`SpeedTrace`, a measured driver-speed trace from release at rest (``t = 0``);
* :class:`TerminalSpeeds`, terminal peak and minimum driver speeds at several spring torques,
  the form of Meyer's Appendix E tables (rows that share one true mu: a fit estimates mu
  from one run family).

Both files are CSV with the unit of every column in its header cell, ``name [unit]`` (any
pint unit of the right dimension; converted on reading), ``#`` comment lines (``# key: value``
comments are kept as metadata):

* speed trace: ``time [s], speed [rad/s]`` and optionally ``sd [rad/s]`` (the standard
  deviation of each reading; used as known noise when the scene gives no
  ``[observation] sigma``);
* terminal speeds: ``K [lbf*inch]`` (or ``torque [N*m]``), ``peak_speed [rad/s]``,
  ``min_speed [rad/s]``, optionally ``sd [rad/s]`` and Meyer's other columns ``mu [1]``,
  ``rise_time [s]``, ``period [s]`` (``mu``, the friction his run used, lets a fit select
  one run family from a whole table; the others are not fitted).

Values are SI inside: s, rad/s, N*m.  Every reader refuses bad input with a
:class:`~escfit.core.errors.DataError` naming the file, line and column.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pint

from ..core.csvtable import refuses_unreadable
from ..core.atomic import atomic_path
from ..core.csvtable import Table, read_table
from ..core.errors import DataError, UnitError
from ..core.units import angular_frequency_factor, registry

__all__ = ["SpeedTrace", "TerminalSpeeds", "read_speed_trace", "read_terminal_speeds", "write_speed_trace",
           "detect_format", "read_data", "FORMATS"]

_HEADER = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*\[([^\]]*)\]\s*$")

# column name -> (canonical unit, what it is) of each format; a file may hold only these
TRACE_COLUMNS = {"time": ("s", "a time"), "speed": ("rad/s", "an angular speed"),
                 "sd": ("rad/s", "an angular speed")}
TERMINAL_COLUMNS = {"K": ("N*m", "a torque"), "torque": ("N*m", "a torque"),
                    "peak_speed": ("rad/s", "an angular speed"), "min_speed": ("rad/s", "an angular speed"),
                    "sd": ("rad/s", "an angular speed"), "mu": ("", "dimensionless"),
                    "rise_time": ("s", "a time"), "period": ("s", "a time")}


def _as_sd(sd, n: int, source: str) -> np.ndarray | None:
    """A per-reading standard deviation array (a scalar is broadcast), or ``None``."""
    if sd is None:
        return None
    arr = np.broadcast_to(np.asarray(sd, float), (n,)).copy() if np.ndim(sd) == 0 else np.asarray(sd, float)
    if arr.shape != (n,):
        raise DataError(f"sd must be a number or one value per reading ({n}), got shape {arr.shape}", source)
    if not (np.all(np.isfinite(arr)) and np.all(arr > 0)):
        raise DataError(f"sd must be positive, got {sd!r}" if np.ndim(sd) == 0 else "sd must be positive and finite",
                        source)
    return arr


@dataclass(frozen=True)
class SpeedTrace:
    """A measured driver-speed trace, released at rest at ``t = 0``.

    Attributes
    ----------
    time
        Sample times, s (increasing, non-negative).
    speed
        Driver speed, rad/s.
    sd
        Standard deviation of the readings, rad/s: a number or one per reading (stored as
        an array), or ``None`` when unknown (the scene's ``[observation] sigma`` then gives it).
    source, sha256
        The file the data came from (for messages and provenance) and its SHA-256 (``""``
        for data made in memory).
    meta
        ``# key: value`` comments of the file.
    """

    time: np.ndarray
    speed: np.ndarray
    sd: np.ndarray | float | None = None
    source: str = "speed trace"
    sha256: str = ""
    meta: dict = field(default_factory=dict)

    kind = "speed-trace"

    def __post_init__(self) -> None:
        t, w = np.asarray(self.time, float), np.asarray(self.speed, float)
        if t.ndim != 1 or t.shape != w.shape or t.size < 3:
            raise DataError(f"time and speed must be 1-D of equal length >= 3, got {t.shape} and {w.shape}",
                            self.source)
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(w))):
            raise DataError("time or speed holds a non-finite value", self.source)
        if t[0] < 0 or np.any(np.diff(t) <= 0):
            raise DataError("times must be non-negative and strictly increasing", self.source)
        object.__setattr__(self, "time", t)
        object.__setattr__(self, "speed", w)
        object.__setattr__(self, "sd", _as_sd(self.sd, t.size, self.source))


@dataclass(frozen=True)
class TerminalSpeeds:
    """Terminal peak and minimum driver speeds at several spring torques.

    Attributes
    ----------
    torque
        Nominal spring torque of each run, N*m.
    peak, minimum
        Terminal peak and minimum driver speed, rad/s.
    sd
        Standard deviation of every speed, rad/s (a number, or one per run applying to both
        its speeds), or ``None`` when unknown.
    source, sha256
        Provenance (file and its SHA-256, ``""`` in memory).
    mu
        Friction coefficient each run used (Meyer's ``mu`` column), or ``None``.
    lines
        File line of each run (for messages), or ``None``.
    meta
        ``# key: value`` comments of the file.
    """

    torque: np.ndarray
    peak: np.ndarray
    minimum: np.ndarray
    sd: np.ndarray | float | None = None
    source: str = "terminal speeds"
    sha256: str = ""
    mu: np.ndarray | None = None
    lines: np.ndarray | None = None
    meta: dict = field(default_factory=dict)

    kind = "terminal-speeds"

    def __post_init__(self) -> None:
        k, p, m = (np.asarray(v, float) for v in (self.torque, self.peak, self.minimum))
        if k.ndim != 1 or not (k.shape == p.shape == m.shape) or k.size < 1:
            raise DataError(f"torque, peak and minimum must be 1-D of equal length, got {k.shape}, {p.shape}, "
                            f"{m.shape}", self.source)
        if not (np.all(k > 0) and np.all(p > 0) and np.all(m >= 0) and np.all(np.isfinite(k + p + m))):
            raise DataError("torques and peak speeds must be positive, minimum speeds non-negative", self.source)
        if np.any(m > p):
            raise DataError("a minimum speed exceeds its peak speed", self.source)
        object.__setattr__(self, "torque", k)
        object.__setattr__(self, "peak", p)
        object.__setattr__(self, "minimum", m)
        object.__setattr__(self, "sd", _as_sd(self.sd, k.size, self.source))
        if self.mu is not None:
            mu = np.asarray(self.mu, float)
            if mu.shape != k.shape:
                raise DataError(f"mu must hold one value per run ({k.size}), got shape {mu.shape}", self.source)
            object.__setattr__(self, "mu", mu)

    def select(self, rows: np.ndarray) -> "TerminalSpeeds":
        """The runs ``rows`` (indices or a boolean mask)."""
        pick = lambda a: None if a is None else np.asarray(a)[rows]  # noqa: E731
        return TerminalSpeeds(self.torque[rows], self.peak[rows], self.minimum[rows], pick(self.sd), self.source,
                              self.sha256, pick(self.mu), pick(self.lines), dict(self.meta))


# -- reading -----------------------------------------------------------------------------------------------
def _header_line(path: Path) -> int:
    """Line number of the header (the first line that is neither blank nor a comment)."""
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        s = line.strip()
        if s and not s.startswith("#"):
            return n
    return 1


def _columns(table: Table, allowed: dict[str, tuple[str, str]], what: str) -> dict[str, tuple[str, float]]:
    """Logical column name -> (header cell, factor to the canonical unit), checked against ``allowed``."""
    where = f"{table.path}:{_header_line(Path(table.path))}"
    out: dict[str, tuple[str, float]] = {}
    for cell in table.header:
        m = _HEADER.match(cell)
        if not m:
            raise DataError(f"header cell {cell!r} must read 'name [unit]' (e.g. 'speed [rad/s]', 'mu [1]')", where)
        name, unit = m.group(1), m.group(2).strip()
        if name not in allowed:
            raise DataError(f"unknown column {name!r} in a {what} file; allowed: {sorted(allowed)}", where)
        if name in out:
            raise DataError(f"column {name!r} appears twice", where)
        target, dimension = allowed[name]
        try:
            if target == "rad/s":  # an angular speed: Hz counts turns, as for every angular frequency
                factor = _angular_speed_factor(unit, dimension, name, where)
            else:
                q = registry().Quantity(1.0, unit if unit not in ("", "1") else "dimensionless")
                factor = float(q.to(target or "dimensionless").magnitude)
        except pint.DimensionalityError:
            raise DataError(f"column {name!r}: unit {unit!r} is not {dimension} ({target or 'dimensionless'})",
                            where) from None
        except DataError:
            raise
        except Exception as exc:  # pint raises several types for unknown units
            raise DataError(f"column {name!r}: unknown unit {unit!r} ({exc})", where) from None
        out[name] = (cell, factor)
    return out


def _angular_speed_factor(unit: str, dimension: str, name: str, where: str) -> float:
    """rad/s per ``unit`` (rad/s, rpm, deg/s; Hz is turns per second): :func:`~escfit.core.units.angular_frequency`'s rule."""
    try:
        return angular_frequency_factor(unit, where)
    except UnitError:
        raise DataError(f"column {name!r}: unit {unit!r} is not {dimension} (rad/s, rpm, deg/s or Hz = turn/s)",
                        where) from None


def _values(table: Table, cols: dict[str, tuple[str, float]], name: str, **checks) -> np.ndarray:
    cell, factor = cols[name]
    return np.asarray(table.floats(cell, **checks), float) * factor


def read_speed_trace(path: str | Path) -> SpeedTrace:
    """Read a driver-speed trace CSV (``time [s], speed [rad/s]`` and optionally ``sd [rad/s]``).

    Raises
    ------
    DataError
        Missing file, a header cell without a unit or with the wrong dimension, an unknown or
        missing column, a non-numeric cell, a negative or non-increasing time, a non-positive
        sd, fewer than 3 readings; the message names the file, line and column.
    """
    table = read_table(path)
    cols = _columns(table, TRACE_COLUMNS, "speed-trace")
    missing = sorted({"time", "speed"} - set(cols))
    if missing:
        raise DataError(f"a speed trace needs the columns time [s] and speed [rad/s]; missing {missing}", str(path))
    t = _values(table, cols, "time", nonneg=True)
    w = _values(table, cols, "speed")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise DataError(f"times must be strictly increasing: {table.rows[i][table.header.index(cols['time'][0])]!r} "
                        f"follows {table.rows[i - 1][table.header.index(cols['time'][0])]!r}",
                        f"{table.path}:{table.lines[i]} [{cols['time'][0]}]")
    sd = _values(table, cols, "sd", positive=True) if "sd" in cols else None
    if t.size < 3:
        raise DataError(f"a speed trace needs at least 3 readings, got {t.size}", str(path))
    return SpeedTrace(t, w, sd, str(path), table.sha256, dict(table.meta))


def read_terminal_speeds(path: str | Path) -> TerminalSpeeds:
    """Read terminal speeds in Meyer's table layout (``K [lbf*inch], peak_speed [rad/s], min_speed [rad/s]``).

    Raises
    ------
    DataError
        As :func:`read_speed_trace`, and a minimum speed above its peak.
    """
    table = read_table(path)
    cols = _columns(table, TERMINAL_COLUMNS, "terminal-speeds")
    if "K" in cols and "torque" in cols:
        raise DataError("give the torque once: columns 'K' and 'torque' are the same quantity", str(path))
    tname = "K" if "K" in cols else "torque"
    missing = sorted({tname, "peak_speed", "min_speed"} - set(cols))
    if missing:
        raise DataError("terminal speeds need the columns K [lbf*inch] (or torque [N*m]), peak_speed [rad/s] and "
                        f"min_speed [rad/s]; missing {missing}", str(path))
    k = _values(table, cols, tname, positive=True)
    peak = _values(table, cols, "peak_speed", positive=True)
    low = _values(table, cols, "min_speed", nonneg=True)
    above = np.flatnonzero(low > peak)
    if above.size:
        i = int(above[0])
        raise DataError(f"min_speed {low[i]:g} rad/s exceeds peak_speed {peak[i]:g} rad/s",
                        f"{table.path}:{table.lines[i]} [{cols['min_speed'][0]}]")
    sd = _values(table, cols, "sd", positive=True) if "sd" in cols else None
    mu = _values(table, cols, "mu", nonneg=True) if "mu" in cols else None
    return TerminalSpeeds(k, peak, low, sd, str(path), table.sha256, mu, np.asarray(table.lines), dict(table.meta))


FORMATS = {"speed-trace": read_speed_trace, "terminal-speeds": read_terminal_speeds}


@refuses_unreadable
def detect_format(path: str | Path) -> str:
    """``"speed-trace"`` or ``"terminal-speeds"``, from the file's header columns.

    Raises
    ------
    DataError
        The file is missing, empty, or its header fits neither format (naming the columns).
    """
    table = read_table(path)
    names = {m.group(1) for m in map(_HEADER.match, table.header) if m}
    if {"time", "speed"} <= names:
        return "speed-trace"
    if {"peak_speed", "min_speed"} <= names and names & {"K", "torque"}:
        return "terminal-speeds"
    raise DataError(f"not a Geneva recording: header {table.header} has neither 'time [s], speed [rad/s]' (a speed "
                    "trace) nor 'K [lbf*inch], peak_speed [rad/s], min_speed [rad/s]' (terminal speeds)",
                    f"{table.path}:{_header_line(Path(table.path))}")


@refuses_unreadable
def read_data(path: str | Path, fmt: str | None = None) -> SpeedTrace | TerminalSpeeds:
    """Read a Geneva recording of format ``fmt`` (detected from the header when ``None``)."""
    fmt = fmt or detect_format(path)
    if fmt not in FORMATS:
        raise DataError(f"unknown Geneva format {fmt!r}; known: {sorted(FORMATS)}", str(path))
    return FORMATS[fmt](path)


# -- writing -----------------------------------------------------------------------------------------------
def write_speed_trace(path: str | Path, trace: SpeedTrace, *, comments: list[str] | None = None, with_sd: bool = True,
                      force: bool = False) -> None:
    """Write ``trace`` in the CSV format :func:`read_speed_trace` reads (exact round trip).

    Parameters
    ----------
    comments
        Comment lines written first (``"key: value"`` ones are read back as metadata).
    with_sd
        Write the ``sd [rad/s]`` column when the trace has an sd (leave it out for data whose
        noise the scene should give or estimate).
    force
        Replace an existing file.
    """
    lines = [f"# {c}" for c in (comments or [])]
    sd = trace.sd if with_sd else None
    lines.append("time [s],speed [rad/s]" + (",sd [rad/s]" if sd is not None else ""))
    for i in range(trace.time.size):
        row = [repr(float(trace.time[i])), repr(float(trace.speed[i]))]
        if sd is not None:
            row.append(repr(float(sd[i])))
        lines.append(",".join(row))
    with atomic_path(path, force=force) as tmp:
        tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
