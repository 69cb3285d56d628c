"""From named columns to a TimeSeries: the step every table-like reader shares.

A reader (a text table, a phyphox export, a CASSY file, a LabVIEW file ...) hands over a
:class:`Columns`: the columns' names and units as the file gives them, their cells or values, the
line of each row.  :func:`series_from_columns` picks the time and the signal column (by the
``[recording]`` options, else by the names: :func:`~escfit.analysis.recordings.recording_spec.header_role`),
converts them to SI (s; rad, rad/s or m), drops rows without a reading with a note, and hands the
result to :func:`~escfit.analysis.recordings.rawsteps.build_series`.  Refusals name the file, the
line and column, and the option to set.

Time columns may hold numbers (with a unit in the header, else s), times of day
(``16:04:31.273``) or date-times: those count in seconds from the first row (a time of day passing
midnight goes on), with a note.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace

import numpy as np

from ...core.errors import DataError
from ...core.tabletext import column_floats, parse_number, time_seconds
from ...core.units import angular_frequency_factor, registry
from .rawsteps import build_series, file_options, merge_file_meta
from .still_column import refuse_still
from .recording_spec import COUNT_WORDS, RecordingSpec, header_role, rad_per_unit, safe_unit_text, seconds_per_unit
from .candidates import TEXT_KINDS as _TEXT_KINDS
from .candidates import measured_candidates
from .series import TimeSeries
from ...analysis.quantity import label_quantity

__all__ = ["Columns", "series_from_columns", "signal_role"]

_VELOCITY_WORDS = ("gyro", "omega", "angular velocity", "angular_velocity", "angularvelocity", "rotation rate",
                   "rate gyro", "angular speed", "winkelgeschwindigkeit", "rotation x", "rotation y", "rotation z")
_DISPLACEMENT_WORDS = ("displacement", "position", "distance", "weg", "s", "x", "y", "z", "auslenkung", "elongation")


@dataclass
class Columns:
    """A table as a reader found it.

    Attributes
    ----------
    where : str
        The file (for messages).
    names : list of str or None
        Column names (None: the file has no header; columns are called ``column k``).
    cells : list of list of str
        The cells, column by column (text as in the file).
    lines : list of int
        File line of each row.
    decimal_comma : bool
        Whether the numbers use a decimal comma.
    header_line : int
        Line of the header (for messages); 0 when there is none.
    units : list of (str or None) or None
        Units the format gives each column besides the name (a unit row, a channel's unit).
    values : dict of int to ndarray
        Columns already converted by the reader (XML formats), by index; ``cells`` may be empty there.
    describe : str
        How the file was read (``source_format`` in the series' metadata).
    meta, options, notes
        The file's metadata (strings), options it gives itself (``{key: (value, where)}``, see
        :func:`~escfit.analysis.recordings.rawsteps.file_options`) and the reader's notes.
    uniform_clock : (float, float) or None
        ``(t0, dt)``, s: a clock the format declares (LabVIEW's X0 and Delta_X) for a table
        without a time column.
    """

    where: str
    names: list[str] | None
    cells: list[list[str]]
    lines: list[int]
    decimal_comma: bool = False
    header_line: int = 0
    units: list[str | None] | None = None
    values: dict[int, np.ndarray] = field(default_factory=dict)
    describe: str = ""
    meta: dict[str, str] = field(default_factory=dict)
    options: dict[str, tuple[str, str]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    uniform_clock: tuple[float, float] | None = None
    kinds: list[str] = field(default_factory=list)

    @property
    def ncols(self) -> int:
        return len(self.names) if self.names is not None else max(len(self.cells), len(self.values))

    def label(self, i: int) -> str:
        return self.names[i] if self.names is not None else f"column {i + 1}"

    def named(self, i: int) -> str:
        return f"{self.label(i)} (column {i + 1})" if self.names is not None else self.label(i)

    def unit(self, i: int) -> str | None:
        """The column's unit: the format's, else the one in its name."""
        if self.units is not None and i < len(self.units) and self.units[i]:
            return self.units[i]
        return header_role(self.names[i])[1] if self.names is not None else None

    def at(self, row: int, i: int) -> str:
        return f"{self.where}:{self.lines[row]} [{self.label(i)}]" if self.lines else f"{self.where} [{self.label(i)}]"

    def kind(self, i: int) -> str:
        return self.kinds[i] if i < len(self.kinds) else "number"


def signal_role(name: str, unit: str | None) -> str | None:
    """``"angle"``, ``"angular_velocity"``, ``"displacement"``, ``"time"`` or None for a column name and unit."""
    role, head_unit = header_role(name if unit is None else f"{name} ({unit})")
    unit = unit or head_unit
    dim = _dimension(unit)
    if dim == "angular_velocity":
        return "angular_velocity"
    low = re.sub(r"\s*([(\[].*|/.*)$", "", name.strip().lower())
    if any(w in low for w in _VELOCITY_WORDS) and dim in (None, "angular_velocity"):
        return "angular_velocity"
    # CASSY's path symbol s (``s / m``, ``Weg s_A1 / m``) is a length, not the time
    if role is not None and not (role in ("angle", "time") and dim == "length"):
        return role
    if dim == "length" and (low in _DISPLACEMENT_WORDS or set(re.split(r"[\s_]+", low)) & set(_DISPLACEMENT_WORDS)):
        return "displacement"
    return None if role == "time" and dim == "length" else role


def _dimension(unit: str | None) -> str | None:
    if not unit or not safe_unit_text(unit) or unit.strip().lower() in COUNT_WORDS:
        return None
    try:
        q = registry().parse_expression(unit.strip())
        dim = q.dimensionality
    except Exception:
        return None
    if dim == registry().parse_expression("rad/s").dimensionality and "rad" in str(q.to_root_units().units) + unit \
            or unit.strip() in ("°/s", "deg/s", "rpm", "1/s"):
        return "angular_velocity"
    if dim == registry().meter.dimensionality:
        return "length"
    return None


def _index(col, cols: Columns, key: str) -> int:
    where = cols.where
    if isinstance(col, tuple):
        raise DataError(f"[recording] {key} = {list(col)!r}: lists of columns are for .mat files", where)
    if isinstance(col, int):
        if col > cols.ncols:
            raise DataError(f"[recording] {key} = {col}, but the table has {cols.ncols} columns", where)
        return col - 1
    if cols.names is None:
        raise DataError(f"[recording] {key} = {col!r}, but the table has no header; give a 1-based position", where)
    hits = [i for i, h in enumerate(cols.names) if h == col] or \
        [i for i, h in enumerate(cols.names) if h.strip().lower() == col.strip().lower()]
    if len(hits) != 1:
        what = "no column" if not hits else "several columns"
        raise DataError(f"[recording] {key} = {col!r}: {what} of that name in the header {cols.names}",
                        f"{where}:{cols.header_line}" if cols.header_line else where)
    return hits[0]


def _hint_other_quantities(cols: Columns, roles: list[str | None]) -> str:
    volts = [i for i in range(cols.ncols) if (cols.unit(i) or "").strip() in ("V", "mV", "volt", "volts")]
    if volts:
        return (f" (column {cols.label(volts[0])!r} holds a sensor's volts: an angle sensor's needs angle_column = "
                f"{cols.label(volts[0])!r}, angle_unit = the angle's unit (\"deg\" or \"rad\") and scale = the angle "
                "per volt; a rate or a position: velocity_column or displacement_column with its unit and scale)")
    for role, key in (("angular_velocity", "velocity_column"), ("displacement", "displacement_column")):
        hits = [i for i, r in enumerate(roles) if r == role]
        if len(hits) > 1:
            hits = measured_candidates(cols, hits)
        if len(hits) > 1:  # several: the shapes choose, or the user
            choice = _shape_choice(cols, hits, roles, key)
            if choice is None or choice.chosen is None:
                listing = f": {choice.listing()}" if choice is not None and choice.scores else ""
                return (f" (columns {', '.join(repr(cols.label(i)) for i in hits)} look like "
                        f"{role.replace('_', ' ')}, and none is clearly the free decay{listing}; set [recording] "
                        f"{key})")
            hits = [hits[[cols.label(i) for i in hits].index(choice.chosen)]]
            return (f" (column {cols.label(hits[0])!r} looks like {role.replace('_', ' ')}: set [recording] {key}; "
                    f"{choice.reason})")
        if hits:
            return f" (column {cols.label(hits[0])!r} looks like {role.replace('_', ' ')}: set [recording] {key})"
    return ""


def _choose(cols: Columns, spec: RecordingSpec, rate: float | None) -> tuple[int | None, int]:
    """(time column or None for a uniform clock, signal column), 0-based."""
    quantity = spec.quantity
    key = {"angle": "angle_column", "angular_velocity": "velocity_column", "displacement": "displacement_column"}[
        quantity]
    where, n = cols.where, cols.ncols
    t = None if spec.time_column is None else _index(spec.time_column, cols, "time_column")
    a = None if spec.signal_column is None else _index(spec.signal_column, cols, key)
    uniform = spec.sample_rate is not None or cols.uniform_clock is not None or \
        (t is None and rate is not None and n == 1)
    hint = f"set [recording] {key} (name or 1-based position)"
    first = f"{where}:{cols.lines[0]}" if cols.lines else where
    texts = [i for i in range(n) if cols.kind(i) in _TEXT_KINDS]
    clocks = [i for i in range(n) if cols.kind(i) in ("clock", "datetime")]
    numeric = [i for i in range(n) if i not in texts and i not in clocks]
    if cols.names is None:
        if a is None:
            if len(numeric) > 2 or (len(numeric) == 2 and clocks):
                rest = [i for i in numeric if i != t and (clocks or uniform or i != numeric[0])]
                clock = t if t is not None else (numeric[0] if not (clocks or uniform) else None)
                roles0 = ["time" if i == clock else None for i in range(n)]
                choice = _shape_choice(cols, rest, roles0, key) if quantity == "angle" else None
                example = cols.label(rest[0]) if choice is None or choice.chosen is None else choice.chosen
                shapes = f"; by shape: {choice.listing()}" if choice is not None and choice.scores else ""
                exc = DataError(f"{n} columns and no header: cannot tell which is the angle; {hint}, e.g. "
                                f"{key} = {int(example.split()[-1]) if example.startswith('column ') else example!r} "
                                f"(column {numeric[0] + 1} is taken as the time unless time_column or sample_rate "
                                f"says otherwise){shapes}", first)
                exc.channel_choice = _by_position(cols, choice)
                raise exc
            if not numeric:
                raise DataError(f"no column of numbers to read; {hint}", first)
            a = numeric[-1] if t != numeric[-1] else numeric[0]
            if t is None and not uniform and not clocks and len(numeric) == 2:
                a = _second_is_clock(cols, numeric, a)
        if t is None and not uniform and n > 1:
            if clocks:
                t = clocks[0]
            else:  # column 1 is the time, unless it is the angle: then column 2 of two
                t = 0 if a != 0 else (1 if n == 2 else None)
    else:
        roles = [signal_role(h, cols.units[i] if cols.units and i < len(cols.units) else None)
                 for i, h in enumerate(cols.names)]
        roles = [None if i in texts else r for i, r in enumerate(roles)]
        roles = _mark_companions(cols, roles, numeric)
        if a is None:
            hits = [i for i, r in enumerate(roles) if r == quantity and i != t]
            if n == 1 and roles[0] != "time":
                hits = [0]
            if len(hits) > 1:
                hits = measured_candidates(cols, hits)
            choice = None
            if len(hits) > 1:  # names cannot tell: the shapes may
                choice = _shape_choice(cols, hits, roles, key)
                hits = [hits[[cols.label(i) for i in hits].index(choice.chosen)]] if choice.chosen else hits
            if len(hits) != 1:
                what = "no column looks like" if not hits else "several columns could be"
                other = _hint_other_quantities(cols, roles) if quantity == "angle" and not hits else ""
                if not hits and quantity == "angle" and not other:
                    choice = _shape_choice(cols, [i for i, r in enumerate(roles) if r is None and i != t
                                                  and i not in clocks and i not in texts], roles, key)
                shapes = f"; by shape: {choice.listing()}" if choice is not None and choice.scores else ""
                exc = DataError(f"{what} the {quantity.replace('_', ' ')} in the header {_shown(cols)}; {hint}"
                                f"{other}{shapes}", f"{where}:{cols.header_line}" if cols.header_line else where)
                exc.channel_choice = _by_position(cols, choice)
                raise exc
            if choice is not None:
                cols.notes.append(choice.note())
                cols.meta["analysis"] = choice.note()
            a = hits[0]
        if t is None and not uniform:
            hits = [i for i, r in enumerate(roles) if r == "time" and i != a and i not in texts]
            hits = hits or [i for i in clocks if i != a]
            hits = hits or _rising_clock(cols, [i for i in numeric if i != a and roles[i] != "uncertainty"])
            if len(hits) > 1:
                hits = _finest_clock(cols, hits)
            if not hits and numeric == [a]:
                raise DataError(_NO_CLOCK.format(what=f"a single column ({cols.label(a)!r})"), first)
            if len(hits) != 1:
                what = "no column looks like" if not hits else "several columns could be"
                raise DataError(f"{what} the time in the header {cols.names}; set [recording] time_column "
                                "(name or 1-based position) or sample_rate",
                                f"{where}:{cols.header_line}" if cols.header_line else where)
            t = hits[0]
    if t is None and not uniform:
        if numeric == [a]:
            raise DataError(_NO_CLOCK.format(what="a single column of numbers"), first)
        raise DataError(f"no clock for {quantity.replace('_', ' ')} column {a + 1}: set [recording] sample_rate "
                        "or time_column", first)
    if t == a:
        raise DataError(f"the time and the {quantity.replace('_', ' ')} are the same column ({a + 1})", where)
    if cols.kind(a) in _TEXT_KINDS + ("clock", "datetime"):
        raise DataError(f"column {cols.label(a)!r} holds {cols.kind(a)}s, not numbers; {hint}", where)
    refuse_still(lambda i: _floats(cols, i), cols.label, a, [i for i in numeric if i not in (a, t)], hint, cols.where)
    return t, a


def _mark_companions(cols: Columns, roles: list[str | None], numeric: list[int]) -> list[str | None]:
    """Roles with the columns that are uncertainties of others (:func:`~escfit.analysis.roles.companions`)
    marked ``"uncertainty"``, with a note; only columns whose names could be one are read."""
    from ...analysis.roles import base_name, companions

    words = ("unc", "err", "sigma", "std", "delta", "fehler", "'", "′", "σ", "δ")
    bases = [base_name(h) for h in cols.names]
    maybe = [i for i in numeric if any(w in bases[i] for w in words)
             or any(bases[i][1:].lstrip(" _") == b for b in bases if b)]
    if not maybe:
        return roles
    found = companions(cols.names, _parsed(cols, maybe))
    if not found:
        return roles
    said = ", ".join(f"{cols.label(i)!r}" + (f" (of {cols.label(j)!r})" if j is not None else "")
                     for i, j in found.items())
    cols.notes.append(f"uncertainty columns, never negative and named as such, are neither the time nor the signal: "
                      f"{said}")
    return ["uncertainty" if i in found else r for i, r in enumerate(roles)]


def _rising_clock(cols: Columns, candidates: list[int]) -> list[int]:
    """``[the column]`` that alone rises at every row, taken as the clock with a note; else ``[]``."""
    from ...analysis.roles import rising_clock

    found = rising_clock(_parsed(cols, candidates))
    if found is None:
        return []
    cols.notes.append(f"column {cols.label(found)!r} taken as the time: no name says which column is, and it alone "
                      "rises at every row ([recording] time_column chooses another)")
    return [found]


def _second_is_clock(cols: Columns, numeric: list[int], a: int) -> int:
    """The signal of a headerless pair of columns: the first when the second alone rises at every
    row (a ``reading, time`` log), with a note; else ``a``."""
    from ...analysis.roles import rising_clock

    if rising_clock(_parsed(cols, numeric)) != numeric[1]:
        return a
    cols.notes.append(f"column {numeric[1] + 1} taken as the time: the file has no header, and it alone rises at every "
                      f"row ([recording] time_column chooses another)")
    return numeric[0]


def _parsed(cols: Columns, indices: list[int]) -> dict[int, np.ndarray]:
    """The columns of ``indices`` that parse as numbers, by index."""
    out = {}
    for i in indices:
        try:
            out[i] = _floats(cols, i)
        except DataError:
            continue
    return out


def _provisional_time(cols: Columns, roles: list[str | None], candidates: list[int]) -> np.ndarray:
    """Times for scoring candidate columns' shapes: the one time column's readings in s, else the row number."""
    times = [i for i, r in enumerate(roles) if r == "time" and i not in candidates and cols.kind(i) == "number"]
    if not times:
        from ...analysis.roles import rising_clock

        found = rising_clock(_parsed(cols, [i for i in range(cols.ncols) if roles[i] != "uncertainty"
                                            and cols.kind(i) == "number"]))  # a rising column is no one's signal
        times = [found] if found is not None else []
    if len(times) == 1:
        try:
            values = _floats(cols, times[0])
            unit = cols.unit(times[0]) if cols.names is not None else None
            values = values * (seconds_per_unit(unit, cols.where) if unit else 1.0)
            steps = np.diff(values[np.isfinite(values)])
            if np.all(steps > 0):
                return values
            if np.all(steps >= 0) and np.any(steps > 0) and np.isfinite(values).all():  # stamps rounded: a line
                rows = np.arange(values.size, dtype=float)
                return np.polyval(np.polyfit(rows, values, 1), rows)
        except DataError:
            pass
    return np.arange(len(cols.lines) if cols.lines else max(len(v) for v in cols.values.values()), dtype=float)


def _shape_choice(cols: Columns, candidates: list[int], roles: list[str | None], key: str):
    """:func:`~escfit.analysis.channel.choose_channel` over candidate columns (those that parse as numbers)."""
    from ...analysis.channel import choose_channel

    values = {cols.label(i): v for i, v in _parsed(cols, candidates).items() if np.isfinite(v).sum() >= 20}
    if not values:
        return None
    time = _provisional_time(cols, roles, candidates)
    if time.size != next(iter(values.values())).size:
        return None
    units = {cols.label(i): cols.unit(i) for i in candidates}
    return choose_channel(time, values, units=units, key=key)


def _drive_off(cols: Columns, spec: RecordingSpec, time: np.ndarray, signal: np.ndarray, used: tuple):
    """A drive logged in another numeric column and switched off within the record
    (:func:`~escfit.analysis.switch_off.drive_switched_off`), or None; not looked for when the
    user set ``start`` or ``release``, or for amplitude tables."""
    if spec.start is not None or spec.release is not None or spec.readings != "samples":
        return None
    from ...analysis.switch_off import drive_switched_off

    others = [i for i in range(cols.ncols) if i not in used and cols.kind(i) == "number"]
    columns = {cols.label(i): v for i, v in _parsed(cols, others).items() if v.size == signal.size}
    if not columns or time.size != signal.size:
        return None
    return drive_switched_off(time, columns, signal)


def _by_position(cols: Columns, choice):
    """The choice with 1-based positions for a table without a header (for ``escfit init``)."""
    if choice is None:
        return None
    return replace(choice, positions={cols.label(i): i + 1 for i in range(cols.ncols)})


_NO_CLOCK = ("{what} and no time: set the samples per second with [recording] sample_rate (e.g. "
             "sample_rate = \"50 Hz\") or --sample-rate 50")


def _shown(cols: Columns) -> list[str]:
    """The header's names, with the units a unit row or the format gives them."""
    return [f"{n} ({u})" if cols.units and i < len(cols.units) and cols.units[i] and u not in n else n
            for i, (n, u) in enumerate(zip(cols.names, cols.units or [None] * len(cols.names)))]


def _finest_clock(cols: Columns, hits: list[int]) -> list[int]:
    """Of several time columns, the one with the most distinct stamps (a note says so), or all of
    them when two tie (then the choice is refused as ambiguous)."""
    counts = {i: len(set(cols.cells[i])) if cols.cells else 0 for i in hits}
    best = max(counts.values())
    top = [i for i in hits if counts[i] == best]
    if len(top) == 1:
        rest = ", ".join(f"{cols.label(i)!r} ({counts[i]})" for i in hits if i != top[0])
        cols.notes.append(f"several time columns: {cols.label(top[0])!r} has the most distinct stamps ({best}) and is "
                          f"the clock; not {rest}; set [recording] time_column to choose another")
    return top


def _floats(cols: Columns, i: int) -> np.ndarray:
    """A numeric column (nan where missing); text is refused with its line."""
    if i in cols.values:
        return np.asarray(cols.values[i], dtype=float)
    values, bad = column_floats(cols.cells[i], cols.decimal_comma)
    if bad is not None:
        raise DataError(f"expected a number, got {cols.cells[i][bad]!r}", cols.at(bad, i))
    inf = np.flatnonzero(np.isinf(values))
    if inf.size:
        raise DataError(f"value {cols.cells[i][int(inf[0])]!r} is not a finite number", cols.at(int(inf[0]), i))
    return values


def _clock_floats(cols: Columns, i: int) -> np.ndarray:
    """Times of day or date-times as seconds from the first row (passing midnight)."""
    out = np.full(len(cols.lines), np.nan)
    for k, c in enumerate(cols.cells[i]):
        if parse_number(c) is not None and math.isnan(parse_number(c)):
            continue
        got = time_seconds(c)
        if got is None:
            raise DataError(f"expected a time of day or a date-time, got {c!r}", cols.at(k, i))
        out[k] = got[1]
    ok = np.isfinite(out)
    if cols.kind(i) == "clock" and ok.any():
        steps = np.diff(out[ok])
        out[ok] = out[ok] + 86400.0 * np.concatenate([[0], np.cumsum(steps < -43200.0)])
    first = out[ok][0] if ok.any() else 0.0
    origin = next(c for c, good in zip(cols.cells[i], ok) if good) if ok.any() else ""
    cols.notes.append(f"time from the {'times of day' if cols.kind(i) == 'clock' else 'date-times'} of column "
                      f"{cols.label(i)!r}, counted from {origin.strip()}")
    return out - first


def _si_factor(cols: Columns, col: int, spec: RecordingSpec, opts: dict, reader: dict[str, str]) -> float:
    """SI value per raw reading: ``scale`` times the unit's factor (options, else column, else file, else rad)."""
    quantity = spec.quantity
    name = cols.label(col)
    head_unit = cols.unit(col)
    given = spec.signal_unit
    file_unit = opts.get("angle_unit") if quantity == "angle" else None
    unit = given or head_unit or file_unit
    scale = spec.scale if spec.scale is not None else opts.get("scale", 1.0)
    cpt = spec.counts_per_turn if spec.counts_per_turn is not None else opts.get("counts_per_turn")
    at = f"{cols.where}:{cols.header_line} [{name}]" if cols.header_line else f"{cols.where} [{name}]"
    if quantity != "angle":
        key = "velocity_unit" if quantity == "angular_velocity" else "displacement_unit"
        if unit is None:
            raise DataError(f"column {name!r} gives no unit: set [recording] {key}", at)
        target = "rad/s" if quantity == "angular_velocity" else "m"
        volts = False
        try:
            q = registry().parse_expression(unit.strip().replace("°", "deg")) if safe_unit_text(unit) else None
            volts = q is not None and q.dimensionality == registry().volt.dimensionality
            if volts:
                factor = 1.0  # scale is the SI value per volt
            elif quantity == "angular_velocity":  # Hz counts turns, as for every angular frequency
                factor = angular_frequency_factor(unit.strip().replace("°", "deg"), at)
            else:
                factor = float(q.to(target).magnitude)
        except Exception:
            raise DataError(f"column {name!r}: {unit!r} is not a unit of {quantity.replace('_', ' ')}; set "
                            f"[recording] {key} (and scale)", at) from None
        if volts and spec.scale is None and "scale" not in opts:
            raise DataError(f"column {name!r} holds a sensor's volts: set [recording] scale, its "
                            f"{target} per volt", at)
        reader[key] = unit
        if scale != 1.0:
            reader["scale"] = f"{scale:g}"
        return scale * factor
    if unit is None:
        unit = "rad"
        cols.notes.append("no angle unit in the file or the options, rad assumed")
        reader["angle_unit_assumed"] = "rad"
    elif given and head_unit and head_unit != given:
        cols.notes.append(f"column {name!r} is labelled {head_unit!r}, read as {given!r} times scale "
                          f"{scale:g} as the options say")
    try:
        if head_unit and not given:
            factor = rad_per_unit(unit, cpt, at, hint="; set [recording] angle_unit and scale")
        else:
            factor = rad_per_unit(unit, cpt, cols.where)
    except DataError as exc:
        msg = f"column {name!r}: {exc.message}" if head_unit and not given else exc.message
        said = label_quantity(name, head_unit)
        if said in ("acceleration", "energy", "velocity", "displacement") and "not an angle unit" in msg:
            msg += (f" (a length: read it as a displacement with [recording] displacement_column = {name!r})"
                    if said == "displacement" else f" ({'an' if said[0] in 'ae' else 'a'} {said}: escfit fits "
                    "angles, angular velocities and displacements)")
        err = DataError(msg, exc.where)
        if said == "displacement" and "not an angle unit" in msg:
            err.other_quantity = ("displacement_column", name, head_unit)  # the option that reads it (escfit init)
        raise err from None
    reader["angle_unit"] = unit + (f" ({cpt:g} per turn)" if cpt is not None and unit.lower() in COUNT_WORDS else "")
    if scale != 1.0:
        reader["scale"] = f"{scale:g}"
    return scale * factor


def series_from_columns(cols: Columns, spec: RecordingSpec | None, *, sha256: str,
                        release_s: float = math.nan) -> TimeSeries:
    """Pick, convert and check the time and signal columns of ``cols`` (see the module docstring).

    Raises
    ------
    DataError
        Ambiguous or missing columns, text or non-finite values, units that are not of the
        quantity, and everything :func:`~escfit.analysis.recordings.rawsteps.build_series` refuses.
    """
    spec = spec or RecordingSpec()
    opts = file_options(cols.options)
    rate = spec.sample_rate if spec.sample_rate is not None else opts.get("sample_rate")
    t_col, a_col = _choose(cols, spec, rate)
    reader = {"source_format": cols.describe, **({"title": cols.meta.pop("title")} if "title" in cols.meta else {})}
    signal = _floats(cols, a_col)
    n = signal.size
    if t_col is None:
        if spec.sample_rate is None and cols.uniform_clock is not None:
            t0, dt = cols.uniform_clock
            time, reader["time_column"] = t0 + dt * np.arange(n), f"declared clock: {t0:g} s + row x {dt:g} s"
        else:
            time, reader["time_column"] = np.arange(n) / rate, f"row number / {rate:g} Hz"
    elif cols.kind(t_col) in ("clock", "datetime"):
        time = _clock_floats(cols, t_col)
        reader["time_column"] = cols.named(t_col)
    else:
        tu = spec.time_unit or cols.unit(t_col)  # the scene's unit wins over the header's
        at = f"{cols.where}:{cols.header_line} [{cols.label(t_col)}]" if cols.header_line else cols.where
        factor = 1.0 if tu is None else seconds_per_unit(tu, at)
        time = _floats(cols, t_col) * factor
        reader["time_column"] = cols.named(t_col) + (f", {tu}" if factor != 1.0 else "")
    drive = _drive_off(cols, spec, time, signal, (t_col, a_col))
    signal = signal * _si_factor(cols, a_col, spec, opts, reader)
    key = {"angle": "angle_column", "angular_velocity": "velocity_column", "displacement": "displacement_column"}
    reader[key[spec.quantity]] = cols.named(a_col)
    rows = np.arange(n)
    keep = np.isfinite(signal) & np.isfinite(time)
    if not keep.all():
        gone = np.flatnonzero(~keep)
        tail = gone.size and gone[0] == n - gone.size  # a column padded at its end (phyphox writes NaN there)
        lines = [cols.lines[i] for i in gone[:3]] if cols.lines else []
        cols.notes.append(f"{gone.size} row(s) without a reading (empty or NaN) dropped"
                          + (" at the end (a shorter column padded)" if tail else
                             f", first at line(s) {', '.join(map(str, lines))}" if lines else ""))
        if keep.sum() < 2:
            raise DataError(f"no rows with both a time and a reading in {cols.label(a_col)!r}", cols.where)
        if gone.size > 0.5 * n and not tail:
            raise DataError(f"{gone.size} of {n} rows have no reading in {cols.label(a_col)!r} or the time: not a "
                            "record of samples", cols.where)
        time, signal, rows = time[keep], signal[keep], rows[keep]
    label = cols.label(t_col) if t_col is not None else None

    def row_where(i: int) -> str:
        r = int(rows[i]) if i < rows.size else int(rows[-1])
        line = f"{cols.where}:{cols.lines[r]}" if cols.lines else cols.where
        return f"{line} [{label}]" if label is not None else line

    meta = merge_file_meta(cols.meta, reader)
    from_file = cols.unit(a_col) or (opts.get("angle_unit") if spec.quantity == "angle" else None)
    unit_from = "option" if spec.signal_unit else ("file" if from_file else "assumed")
    series = build_series(time, signal, spec, source=cols.where, sha256=sha256, meta=meta, notes=cols.notes,
                          where_of_row=row_where, release_s=release_s, label=cols.label(a_col), unit_from=unit_from,
                          not_before=drive)
    series.quantity = spec.quantity
    return series
