"""Text tables as written by loggers, trackers and lab scripts, read into a TimeSeries.

:func:`~escfit.balance.recordings.rawseries.read_raw_series` sends every file that is not MATLAB here;
the options of a :class:`~escfit.balance.recordings.recording_spec.RecordingSpec` settle what the file
does not say.  Detected automatically:

- comment lines starting with ``#``, ``%`` or ``//`` (``# key: value`` ones become metadata,
  ``release_s`` the release instant), blank lines, and above the table title lines and
  separator lines of dashes (``-----``, ``=====``);
- the delimiter, from the last lines: tab, semicolon, comma or runs of whitespace (a decimal
  comma goes with semicolons, tabs or spaces), or a single column;
- a header line whose names may carry units (``Time ( s )``, ``Position(deg)``, ``t [s]``,
  ``angle_deg``, ``t_s``) and say which column is the time and which the angle
  (:func:`~escfit.balance.recordings.recording_spec.header_role`); ambiguous or unknown names are
  refused, naming the columns and the option to set.  Without a header, 2 columns are
  (time, angle), 1 column is the angle on a uniform clock, 3 or more need ``angle_column``
  (the time is column 1 unless ``time_column`` or ``sample_rate`` says otherwise);
- a metadata header over a single column: a line of names and a line of values such as
  ``rate,units`` / ``500,deg`` or ``sample_rate`` / ``1000`` (names in
  :data:`~escfit.balance.recordings.rawsteps.FILE_OPTIONS`, as ``# key: value`` comments may give
  them too); the ``[recording]`` options win over them.

A last row with too few fields (a logger stopped mid-line) is dropped with a note;
anywhere else it is an error.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...core.errors import DataError
from .rawsteps import FILE_OPTIONS, build_series, file_options, merge_file_meta
from .recording_spec import COUNT_WORDS, RecordingSpec, header_role, rad_per_unit, seconds_per_unit
from .series import TimeSeries

__all__ = ["read_raw_table"]

DELIMITERS = (("tab", "\t"), ("semicolon", ";"), ("comma", ","), ("whitespace", None))
_COMMENT = re.compile(r"^\s*(#|%|//)")
_SEPARATOR = re.compile(r"^\s*[-=_*+| ]*[-=_*]{3,}[-=_*+| ]*$")
_META = re.compile(r"^\s*(?:#+|%+|//+)\s*([A-Za-z_][\w.\-]*)\s*:\s*(.*?)\s*$")


@dataclass
class _Layout:
    delimiter_name: str
    delimiter: str | None
    decimal_comma: bool
    ncols: int
    header: list[str] | None = None
    header_line: int = 0
    rows: list[list[str]] = field(default_factory=list)
    lines: list[int] = field(default_factory=list)
    options: dict[str, tuple[str, str]] = field(default_factory=dict)  # key -> (value, where)
    titles: list[str] = field(default_factory=list)
    meta_lines: list[int] = field(default_factory=list)


def _decode(raw: bytes, where: str, notes: list[str]) -> str:
    if not raw.strip():
        raise DataError("empty file", where)
    if b"\x00" in raw[:8192]:
        raise DataError("a binary file, not a text table", where)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
        if sum(not (c.isprintable() or c.isspace()) for c in text[:8192]) > 0.01 * min(len(text), 8192):
            raise DataError("a binary file, not a text table", where) from None
        notes.append("not UTF-8, decoded as Latin-1")
    if text.lstrip()[:1] in ("{", "["):
        try:
            json.loads(text)
        except (ValueError, RecursionError):
            return text
        raise DataError("a JSON file, not a table of samples", where)
    return text


def _split(line: str, delim: str | None) -> list[str]:
    s = line.strip()
    if delim is None:
        return s.split()
    if s.endswith(delim):
        s = s[:-1]
    if delim == "\t":
        return [f.strip() for f in s.split("\t")]
    return [f.strip() for f in next(csv.reader([s], delimiter=delim))]


def _split_any(line: str) -> list[str]:
    """A metadata or header line on its own: the first of tab, semicolon, comma it contains, else spaces."""
    for delim in ("\t", ";", ","):
        if delim in line:
            return _split(line, delim)
    return line.split()


def _is_number(text: str, decimal_comma: bool) -> bool:
    try:
        float(text.replace(",", ".") if decimal_comma else text)
    except ValueError:
        return False
    return True


def _detect(sample: list[str], where: str) -> tuple[str, str | None, bool, int]:
    """(name, delimiter, decimal comma, columns) from lines of the table's body."""
    need = 0.9 * len(sample)
    for name, delim in DELIMITERS:
        rows = [_split(s, delim) for s in sample]
        n, count = Counter(len(r) for r in rows).most_common(1)[0]
        if n < 2 or count < need:
            continue
        for dc in (False, True) if delim != "," else (False,):
            if sum(len(r) == n and all(_is_number(f, dc) for f in r) for r in rows) >= need:
                return name, delim, dc, n
    for dc in (False, True):
        if sum(_is_number(s.strip(), dc) for s in sample) >= need:
            return "one column", None, dc, 1
    raise DataError("cannot find a table of numbers: the last lines do not split into numeric columns at tabs, "
                    "semicolons, commas or spaces", where)


def _header_names(line: str, lay: _Layout) -> list[str] | None:
    """The header's names if ``line`` splits into the table's columns, else None."""
    if lay.ncols == 1:
        names = [line.strip()]
    elif lay.delimiter is not None:
        names = _split(line, lay.delimiter)
    else:  # whitespace: keep "Time ( s )" and "t [s]" together, else try runs of 2+ spaces or tabs
        names = []
        for tok in line.split():
            if names and (tok[0] in "([" or names[-1].count("(") > names[-1].count(")")
                          or names[-1].count("[") > names[-1].count("]")):
                names[-1] += " " + tok
            else:
                names.append(tok)
        if len(names) != lay.ncols:
            names = [f for f in re.split(r"\s{2,}|\t", line.strip()) if f]
    names = [n.strip().strip('"').strip("'").strip() for n in names]
    if len(names) != lay.ncols or any(_is_number(n, lay.decimal_comma) for n in names):
        return None
    return names


def _layout(body: list[tuple[int, str]], where: str) -> _Layout:
    k = max(1, min(40, len(body) // 2))
    sample = [s for _, s in body[-k - 1:-1] if not _SEPARATOR.match(s)] if len(body) > 3 else [s for _, s in body]
    lay = _Layout(*_detect(sample or [body[-1][1]], f"{where}:{body[-1][0]}"))

    def numeric(i: int) -> bool:
        f = _split(body[i][1], lay.delimiter)
        return len(f) == lay.ncols and all(_is_number(x, lay.decimal_comma) for x in f)

    start = next((i for i in range(len(body)) if numeric(i) and (i + 1 == len(body) or numeric(i + 1)
                                                                   or i + 2 == len(body))), None)
    if start is None:
        raise DataError("no two consecutive rows of numbers found", where)
    # a row with a bad value just above the numbers is a data row (its error is reported), not a title
    while start > 0 and lay.ncols > 1 and not _SEPARATOR.match(body[start - 1][1]):
        f = _split(body[start - 1][1], lay.delimiter)
        if len(f) != lay.ncols or not any(_is_number(x, lay.decimal_comma) for x in f):
            break
        start -= 1
    pre = [(n, s) for n, s in body[:start] if not _SEPARATOR.match(s)]
    data = body[start:]
    if pre and lay.ncols == 1:
        _metadata_header(pre, data, lay, where)
    if pre and not lay.options:
        names = _header_names(pre[-1][1], lay)
        # under a dashed line, names that say nothing about time or angle are a title, not a header
        underlined = _SEPARATOR.match(body[start - 1][1]) is not None
        if names is not None and not (underlined and not any(header_role(h)[0] for h in names)):
            lay.header, lay.header_line = names, pre[-1][0]
            pre = pre[:-1]
    lay.titles = [s.strip() for _, s in pre]
    lay.rows = [_split(s, lay.delimiter) for _, s in data]
    lay.lines = [n for n, _ in data]
    return lay


def _describe(lay: _Layout) -> str:
    kind = f"header on line {lay.header_line}" if lay.header else "no header"
    if lay.meta_lines:
        kind = f"metadata header on lines {lay.meta_lines[0]}-{lay.meta_lines[1]}"
    sep = f"{lay.delimiter_name}-separated" if lay.ncols > 1 else "one column"
    return f"text table, {sep}{', decimal comma' if lay.decimal_comma else ''}, {kind}"


def _metadata_header(pre: list[tuple[int, str]], data: list[tuple[int, str]], lay: _Layout, where: str) -> None:
    """Names and values above a single column (``rate,units`` / ``500,deg``) become file options."""
    def keys(line: str) -> list[str]:
        return [n.strip().lower() for n in _split_any(line)]

    if keys(pre[-1][1]) and all(n in FILE_OPTIONS for n in keys(pre[-1][1])):
        names, (line, text) = keys(pre[-1][1]), data.pop(0)  # values are the first "data" row
        lay.meta_lines = [pre[-1][0], line]
        del pre[-1:]
    elif len(pre) >= 2 and keys(pre[-2][1]) and all(n in FILE_OPTIONS for n in keys(pre[-2][1])):
        names, (line, text) = keys(pre[-2][1]), pre[-1]
        lay.meta_lines = [pre[-2][0], line]
        del pre[-2:]
    else:
        return
    values = _split_any(text)
    if len(values) != len(names):
        raise DataError(f"metadata header names {len(names)} keys ({', '.join(names)}) but this line has "
                        f"{len(values)} values", f"{where}:{line}")
    for key, value in zip(names, values):
        lay.options[key] = (value, f"{where}:{line} [{key}]")


def _index(col: str | int | tuple, lay: _Layout, key: str, where: str) -> int:
    if isinstance(col, tuple):
        raise DataError(f"[recording] {key} = {list(col)!r}: lists of columns are for .mat files", where)
    if isinstance(col, int):
        if col > lay.ncols:
            raise DataError(f"[recording] {key} = {col}, but the table has {lay.ncols} columns", where)
        return col - 1
    if lay.header is None:
        raise DataError(f"[recording] {key} = {col!r}, but the table has no header; give a 1-based position", where)
    hits = [i for i, h in enumerate(lay.header) if h == col] or \
        [i for i, h in enumerate(lay.header) if h.strip().lower() == col.strip().lower()]
    if len(hits) != 1:
        what = "no column" if not hits else "several columns"
        raise DataError(f"[recording] {key} = {col!r}: {what} of that name in the header {lay.header}",
                        f"{where}:{lay.header_line}")
    return hits[0]


def _choose(lay: _Layout, spec: RecordingSpec, rate: float | None, where: str) -> tuple[int | None, int]:
    """(time column or None for a uniform clock, angle column), 0-based."""
    t = None if spec.time_column is None else _index(spec.time_column, lay, "time_column", where)
    a = None if spec.angle_column is None else _index(spec.angle_column, lay, "angle_column", where)
    uniform = spec.sample_rate is not None or (t is None and rate is not None and lay.ncols == 1)
    hint = "set [recording] angle_column (name or 1-based position)"
    if lay.header is None:
        if a is None:
            if lay.ncols > 2:
                raise DataError(f"{lay.ncols} columns and no header: cannot tell which is the angle; {hint}, e.g. "
                                f"angle_column = 2 (column 1 is taken as the time unless time_column or sample_rate "
                                f"says otherwise)", f"{where}:{lay.lines[0]}")
            a = lay.ncols - 1 if t != lay.ncols - 1 else 0
        if t is None and not uniform and lay.ncols > 1:
            t = 0 if a != 0 else (1 if lay.ncols == 2 else None)
    else:
        kinds = [header_role(h)[0] for h in lay.header]
        if a is None:
            hits = [i for i, k in enumerate(kinds) if k == "angle" and i != t]
            if lay.ncols == 1 and kinds[0] != "time":
                hits = [0]
            if len(hits) != 1:
                what = "no column looks like" if not hits else "several columns could be"
                raise DataError(f"{what} the angle in the header {lay.header}; {hint}",
                                f"{where}:{lay.header_line}")
            a = hits[0]
        if t is None and not uniform:
            hits = [i for i, k in enumerate(kinds) if k == "time" and i != a]
            if len(hits) != 1:
                what = "no column looks like" if not hits else "several columns could be"
                raise DataError(f"{what} the time in the header {lay.header}; set [recording] time_column "
                                "(name or 1-based position) or sample_rate", f"{where}:{lay.header_line}")
            t = hits[0]
    if t is None and not uniform:
        what = "a single column of angles" if lay.ncols == 1 else f"angle column {a + 1}"
        raise DataError(f"no clock for {what}: set [recording] sample_rate or time_column", f"{where}:{lay.lines[0]}")
    if t == a:
        raise DataError(f"the time and the angle are the same column ({a + 1})", where)
    return t, a


def _floats(lay: _Layout, col: int, label: str, where: str) -> np.ndarray:
    """A column as floats; the first text or non-finite cell is refused with its line."""
    cells = [r[col].replace(",", ".") if lay.decimal_comma else r[col] for r in lay.rows]
    try:
        values = np.array(cells, dtype=float)
    except ValueError:
        i = next((i for i, c in enumerate(cells) if not _is_number(c, False)), None)
        if i is not None:
            raise DataError(f"expected a number, got {lay.rows[i][col]!r}", f"{where}:{lay.lines[i]} [{label}]") \
                from None
        values = np.array([float(c) for c in cells])
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        i = int(bad[0])
        raise DataError(f"value {lay.rows[i][col]!r} is not a finite number", f"{where}:{lay.lines[i]} [{label}]")
    return values


def _scan(text: str, where: str) -> tuple[dict[str, str], dict[str, tuple[str, str]], list[tuple[int, str]]]:
    """``# key: value`` metadata (value, and value with its location) and the other non-blank lines."""
    meta: dict[str, str] = {}
    located: dict[str, tuple[str, str]] = {}
    body: list[tuple[int, str]] = []
    for n, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        if _COMMENT.match(line):
            m = _META.match(line)
            if m:
                meta[m.group(1).lower()] = m.group(2)
                located[m.group(1).lower()] = (m.group(2), f"{where}:{n} [{m.group(1)}]")
            continue
        body.append((n, line))
    if not body:
        raise DataError("no table: only comments and blank lines", where)
    return meta, located, body


def read_raw_table(path: str | Path, spec: RecordingSpec | None = None) -> TimeSeries:
    """Read a text table (see the module docstring) into a TimeSeries.

    Raises
    ------
    DataError
        As :func:`~escfit.balance.recordings.rawseries.read_raw_series`.
    """
    spec = spec or RecordingSpec()
    where = str(path)
    raw = Path(path).read_bytes()
    notes: list[str] = []
    meta, located, body = _scan(_decode(raw, where, notes), where)
    lay = _layout(body, where)
    if lay.rows and len(lay.rows[-1]) < lay.ncols and len(lay.rows) > 1:
        notes.append(f"the last row (line {lay.lines[-1]}) has {len(lay.rows[-1])} of {lay.ncols} fields and was "
                     "dropped as truncated")
        del lay.rows[-1], lay.lines[-1]
    if not lay.rows:
        raise DataError("no data rows after the header", where)
    for f, n in zip(lay.rows, lay.lines):
        if len(f) != lay.ncols:
            names = f" ({', '.join(lay.header)})" if lay.header else ""
            raise DataError(f"expected {lay.ncols} fields{names}, found {len(f)}", f"{where}:{n}")
    opts = file_options({**located, **lay.options})
    rate = spec.sample_rate if spec.sample_rate is not None else opts.get("sample_rate")
    t_col, a_col = _choose(lay, spec, rate, where)
    label = (lambda i: lay.header[i]) if lay.header else (lambda i: f"column {i + 1}")
    named = (lambda i: f"{label(i)} (column {i + 1})") if lay.header else label
    reader = {"source_format": _describe(lay), **({"title": " / ".join(lay.titles)} if lay.titles else {})}
    theta_raw = _floats(lay, a_col, label(a_col), where)
    if t_col is None:
        time, reader["time_column"] = np.arange(theta_raw.size) / rate, f"row number / {rate:g} Hz"
    else:
        tu = header_role(lay.header[t_col])[1] if lay.header else None
        factor = 1.0 if tu is None else seconds_per_unit(tu, f"{where}:{lay.header_line} [{label(t_col)}]")
        time = _floats(lay, t_col, label(t_col), where) * factor
        reader["time_column"] = named(t_col) + (f", {tu}" if factor != 1.0 else "")
    theta = theta_raw * _rad_factor(lay, a_col, spec, opts, notes, reader, where)
    reader["angle_column"] = named(a_col)
    release = math.nan
    if "release_s" in meta:
        try:
            release = float(meta["release_s"])
        except ValueError:
            raise DataError(f"release_s must be a number, got {meta['release_s']!r}", located["release_s"][1]) \
                from None
    row_where = (lambda i: f"{where}:{lay.lines[i]} [{label(t_col)}]") if t_col is not None else \
        (lambda i: f"{where}:{lay.lines[i]}")
    return build_series(time, theta, spec, source=where, sha256=hashlib.sha256(raw).hexdigest(),
                        meta=merge_file_meta(meta, reader), notes=notes, where_of_row=row_where, release_s=release)


def _rad_factor(lay: _Layout, col: int, spec: RecordingSpec, opts: dict, notes: list[str], reader: dict[str, str],
                where: str) -> float:
    """Radians per raw reading: ``scale`` times the unit's factor (options, else header, else file, else rad)."""
    name = lay.header[col] if lay.header else f"column {col + 1}"
    head_unit = header_role(name)[1] if lay.header else None
    unit = spec.angle_unit or head_unit or opts.get("angle_unit")
    scale = spec.scale if spec.scale is not None else opts.get("scale", 1.0)
    cpt = spec.counts_per_turn if spec.counts_per_turn is not None else opts.get("counts_per_turn")
    if unit is None:
        unit = "rad"
        notes.append("no angle unit in the file or the options, rad assumed")
        reader["angle_unit_assumed"] = "rad"
    elif spec.angle_unit and head_unit and head_unit != spec.angle_unit:
        notes.append(f"column {name!r} is labelled {head_unit!r}, read as {spec.angle_unit!r} times scale "
                     f"{scale:g} as the options say")
    try:
        if head_unit and not spec.angle_unit:
            factor = rad_per_unit(unit, cpt, f"{where}:{lay.header_line} [{name}]",
                                  hint="; set [recording] angle_unit and scale")
        else:
            factor = rad_per_unit(unit, cpt, where)
    except DataError as exc:
        msg = f"column {name!r}: {exc.message}" if head_unit and not spec.angle_unit else exc.message
        raise DataError(msg, exc.where) from None
    reader["angle_unit"] = unit + (f" ({cpt:g} per turn)" if cpt is not None and unit.lower() in COUNT_WORDS else "")
    if scale != 1.0:
        reader["scale"] = f"{scale:g}"
    return scale * factor
