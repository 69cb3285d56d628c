"""Text tables as written by loggers, trackers and lab scripts, read into a TimeSeries.

:func:`~escfit.analysis.recordings.rawseries.read_raw_series` sends every text file that is not
another known format here; the options of a
:class:`~escfit.analysis.recordings.recording_spec.RecordingSpec` settle what the file does not say.
The cells are tokenized by :mod:`escfit.core.tabletext` (the one path under every text format);
detected automatically:

- comment lines starting with ``#``, ``%`` or ``//`` (``# key: value`` ones become metadata,
  ``release_s`` the release instant), blank lines, and above the table title lines and
  separator lines of dashes (``-----``, ``=====``);
- the delimiter and decimal mark, from the last lines (:func:`~escfit.core.tabletext.detect_dialect`);
  columns of times of day, date-times, dates, flags or names may stand beside the numbers;
- a header line whose names may carry units (``Time ( s )``, ``Position(deg)``, ``t [s]``,
  ``angle_deg``, ``t_s``), and under it a row of units (``(ms),(V)``, as PicoScope writes it);
  ambiguous or unknown names are refused, naming the columns and the option to set.  Without a
  header, 2 columns are (time, angle), 1 column is the angle on a uniform clock, 3 or more need
  ``angle_column``;
- a metadata header over a single column: a line of names and a line of values such as
  ``rate,units`` / ``500,deg`` or ``sample_rate`` / ``1000`` (names in
  :data:`~escfit.analysis.recordings.rawsteps.FILE_OPTIONS`); the ``[recording]`` options win.

A last row with too few fields (a logger stopped mid-line) is dropped with a note; anywhere
else it is an error.  The columns then go to
:func:`~escfit.analysis.recordings.columns.series_from_columns`.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

from ...core.errors import DataError
from ...core.tabletext import Dialect, cell_kind, decode_lenient, detect_dialect, numbered_lines, parse_number, \
    split_fields
from .columns import Columns, series_from_columns
from .rawsteps import FILE_OPTIONS
from .recording_spec import RecordingSpec, header_role
from .series import TimeSeries

__all__ = ["read_raw_table", "scan_text", "table_columns"]

MAX_COLUMNS = 1000  # more fields on a line are not columns of a record (a channel written along one line)
_COMMENT = re.compile(r"^\s*(#|%|//)")
_SEPARATOR = re.compile(r"^\s*[-=_*+| ]*[-=_*]{3,}[-=_*+| ]*$")
_META = re.compile(r"^\s*(?:#+|%+|//+)\s*([A-Za-z_][\w.\-]*)\s*:\s*(.*?)\s*$")
_UNIT_CELL = re.compile(r"\s*[(\[]\s*([^()\[\]]{0,20}?)\s*[)\]]\s*")


@dataclass
class _Layout:
    dialect: Dialect
    ncols: int
    header: list[str] | None = None
    header_line: int = 0
    units: list[str | None] | None = None
    rows: list[list[str]] = field(default_factory=list)
    lines: list[int] = field(default_factory=list)
    options: dict[str, tuple[str, str]] = field(default_factory=dict)  # key -> (value, where)
    titles: list[str] = field(default_factory=list)
    meta_lines: list[int] = field(default_factory=list)
    file_meta: dict[str, str] = field(default_factory=dict)


def _split(line: str, dialect: Dialect) -> list[str]:
    fields = split_fields(line, dialect.delimiter)
    if dialect.trailing and len(fields) > 1 and fields[-1] == "" and line.rstrip(" \r\n").endswith(dialect.delimiter):
        fields.pop()
    return fields


def _split_any(line: str) -> list[str]:
    """A metadata or header line on its own: the first of tab, semicolon, comma it contains, else spaces."""
    for delim in ("\t", ";", ","):
        if delim in line:
            return split_fields(line, delim)
    return line.split()


def _is_number(text: str, decimal_comma: bool) -> bool:
    return parse_number(text, decimal_comma) is not None


def _row_fits(fields: list[str], lay: _Layout, kinds: list[str]) -> bool:
    """Whether a line's cells are a data row: the table's width, numbers where the table has numbers."""
    if len(fields) != lay.ncols:
        return False
    dc = lay.dialect.decimal_comma
    if not kinds:
        return all(_is_number(x, dc) for x in fields)
    return all(_is_number(x, dc) if k == "number" else True for x, k in zip(fields, kinds)) and \
        any(k == "number" and _is_number(x, dc) and not math.isnan(parse_number(x, dc)) for x, k in zip(fields, kinds))


def _column_kinds(sample: list[list[str]], n: int, dc: bool) -> list[str]:
    """The kind of each column (number, clock, datetime, date, flag, text) from sample rows; empty
    when every cell is a number."""
    kinds = []
    for j in range(n):
        seen = [cell_kind(r[j], dc) for r in sample if len(r) == n]
        seen = [k for k in seen if k != "missing"] or ["number"]
        kinds.append(max(set(seen), key=seen.count))
    return [] if all(k == "number" for k in kinds) else kinds


def _header_names(line: str, lay: _Layout) -> list[str] | None:
    """The header's names if ``line`` splits into the table's columns, else None."""
    if lay.ncols == 1:
        names = [line.strip()]
    elif lay.dialect.delimiter is not None:
        names = _split(line, lay.dialect)
        filled = [n for n in names if n.strip()]
        if len(filled) == 1 and len(filled[0].split()) == lay.ncols:  # a header spaced above tab-separated data
            names = filled[0].split()
        elif len(filled) == 1 and len(filled[0].split(",")) == lay.ncols:  # comma-separated above tab-separated
            names = filled[0].split(",")
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
    names = [_unquoted(n) for n in names]
    if len(names) != lay.ncols or any(_is_number(n, lay.dialect.decimal_comma) and n for n in names):
        return None
    return names


def _unquoted(name: str) -> str:
    """A header cell without its surrounding quotes (a trailing prime, ``X'``, is part of the name)."""
    name = name.strip()
    while len(name) >= 2 and name[0] == name[-1] and name[0] in "\"'":
        name = name[1:-1].strip()
    return name.strip('"').strip() if name.count('"') == 1 else name


def _unit_row(line: str, lay: _Layout) -> list[str | None] | None:
    """A row of units under the header (``(ms),(V)``, ``s;deg``), or None."""
    cells = _split(line, lay.dialect) if lay.dialect.delimiter is not None else line.split()
    if len(cells) != lay.ncols:
        return None
    out = []
    for c in cells:
        m = _UNIT_CELL.fullmatch(c.strip('"'))
        if not m:
            return None
        out.append(m.group(1) or None)
    return out


def _refuse_wide(lines: list[str], where: str) -> None:
    """Refuse lines of more than :data:`MAX_COLUMNS` fields before any is parsed (a counted guess:
    the most frequent separator's count, spaces included)."""
    fields = max((max(s.count(d) for d in ",;\t ") + 1 for s in lines), default=0)
    if fields > MAX_COLUMNS:
        raise DataError(f"about {fields} fields on a line: a table of samples has one row per sample (a time and "
                        "the readings); one channel sampled at a fixed rate is read with one number per line and "
                        "--sample-rate (or [recording] sample_rate)", where)


def _layout(body: list[tuple[int, str]], where: str) -> _Layout:
    k = max(1, min(40, len(body) // 2))
    sample = [s for _, s in body[-k - 1:-1] if not _SEPARATOR.match(s)] if len(body) > 3 else [s for _, s in body]
    _refuse_wide(sample or [body[-1][1]], f"{where}:{body[-1][0]}")
    dialect, ncols = detect_dialect(sample or [body[-1][1]], f"{where}:{body[-1][0]}")
    head = body[0][1].rstrip(" \r\n")
    if dialect.delimiter is not None and ncols > 1 and sample and \
            all(s.rstrip(" \r\n").endswith(dialect.delimiter) for s in sample) and \
            (head.endswith(dialect.delimiter) or len(split_fields(head, dialect.delimiter)) == ncols - 1):
        dialect, ncols = replace(dialect, trailing=True), ncols - 1  # every row closed by a delimiter
    lay = _Layout(dialect, ncols)
    kinds = _column_kinds([_split(s, dialect) for s in sample], ncols, dialect.decimal_comma) if ncols > 1 else []

    def numeric(i: int) -> bool:
        return _row_fits(_split(body[i][1], lay.dialect), lay, kinds)

    start = next((i for i in range(len(body)) if numeric(i) and (i + 1 == len(body) or numeric(i + 1)
                                                                   or i + 2 == len(body))), None)
    if start is None:
        raise DataError("no two consecutive rows of numbers found", where)
    # a row with a bad value just above the numbers is a data row (its error is reported), not a title
    while start > 0 and lay.ncols > 1 and not _SEPARATOR.match(body[start - 1][1]):
        f = _split(body[start - 1][1], lay.dialect)
        if len(f) != lay.ncols or not any(_is_number(x, dialect.decimal_comma) and x for x in f) \
                or _unit_row(body[start - 1][1], lay) is not None:
            break
        start -= 1
    pre = [(n, s) for n, s in body[:start] if not _SEPARATOR.match(s)]
    data = body[start:]
    if pre and lay.ncols == 1:
        _metadata_header(pre, data, lay, where)
    if pre and not lay.options:
        units = _unit_row(pre[-1][1], lay) if len(pre) >= 2 else None
        names = _header_names(pre[-2 if units else -1][1], lay)
        if units and names is not None:
            lay.units = units
            pre = pre[:-1]
        # under a dashed line, names that say nothing about time or angle are a title, not a header
        underlined = _SEPARATOR.match(body[start - 1][1]) is not None
        if names is not None and not (underlined and not any(header_role(h)[0] for h in names)):
            lay.header, lay.header_line = names, pre[-1][0]
            pre = pre[:-1]
    if lay.header is None and pre and lay.ncols > 2 and dialect.delimiter == ",":
        _refuse_split_decimal_commas(pre[-1], lay.ncols, where)
    lay.titles = [s.strip() for _, s in pre]
    lay.rows = [_split(s, lay.dialect) for _, s in data]
    lay.lines = [n for n, _ in data]
    lay.kinds = kinds  # type: ignore[attr-defined]
    return lay


def _refuse_split_decimal_commas(line: tuple[int, str], ncols: int, where: str) -> None:
    """A header of names one short of the rows' fields, over comma-separated rows: numbers
    written with a decimal comma and not quoted (``0,02,44.3365``) split in two; reading on
    would drop the header and take the integer part for the clock."""
    names = split_fields(line[1], ",")
    if len(names) < ncols <= 2 * len(names) and all(n.strip() and not _is_number(n, False) for n in names):
        raise DataError(f"the header names {len(names)} columns ({', '.join(n.strip() for n in names)}) but every row has "
                        f"{ncols} comma-separated fields: a number written with a decimal comma and not quoted "
                        "(0,02 read as 0 and 02)? save the file with decimal points, or with ';' between the fields",
                        f"{where}:{line[0]}")


def _describe(lay: _Layout) -> str:
    kind = f"header on line {lay.header_line}" if lay.header else "no header"
    if lay.meta_lines:
        kind = f"metadata header on lines {lay.meta_lines[0]}-{lay.meta_lines[1]}"
    if lay.units:
        kind += " and a row of units"
    sep = f"{lay.dialect.name}-separated" if lay.ncols > 1 else "one column"
    return f"text table, {sep}{', decimal comma' if lay.dialect.decimal_comma else ''}, {kind}"


def _metadata_header(pre: list[tuple[int, str]], data: list[tuple[int, str]], lay: _Layout, where: str) -> None:
    """Names and values above a single column (``rate,units`` / ``500,deg``) become file options."""
    def keys(line: str) -> list[str]:
        return [n.strip().lower() for n in _split_any(line)]

    def options(line: str) -> bool:  # names of which one at least is an option (others are kept as metadata)
        names = keys(line)
        return bool(names) and any(n in FILE_OPTIONS for n in names) and not any(_is_number(n, False) for n in names)

    if options(pre[-1][1]):
        names, (line, text) = keys(pre[-1][1]), data.pop(0)  # values are the first "data" row
        lay.meta_lines = [pre[-1][0], line]
        del pre[-1:]
    elif len(pre) >= 2 and options(pre[-2][1]):
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
        lay.file_meta[key] = value


def scan_text(text: str, where: str) -> tuple[dict[str, str], dict[str, tuple[str, str]], list[tuple[int, str]]]:
    """``# key: value`` metadata (value, and value with its location) and the other non-blank lines."""
    meta: dict[str, str] = {}
    located: dict[str, tuple[str, str]] = {}
    body: list[tuple[int, str]] = []
    for n, line in numbered_lines(text):
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


def table_columns(body: list[tuple[int, str]], where: str, notes: list[str]) -> Columns:
    """The columns of a table's lines (comments and blank lines already out)."""
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
    cells = [[r[j] for r in lay.rows] for j in range(lay.ncols)]
    cols = Columns(where, lay.header, cells, lay.lines, lay.dialect.decimal_comma, lay.header_line, lay.units,
                   describe=_describe(lay), options=dict(lay.options), notes=notes,
                   kinds=list(getattr(lay, "kinds", [])))
    cols.meta.update(lay.file_meta)
    if lay.titles:
        cols.meta["title"] = " / ".join(lay.titles)
    return cols


def read_raw_table(path: str | Path, spec: RecordingSpec | None = None) -> TimeSeries:
    """Read a text table (see the module docstring) into a TimeSeries.

    Raises
    ------
    DataError
        As :func:`~escfit.analysis.recordings.rawseries.read_raw_series`.
    """
    where = str(path)
    raw = Path(path).read_bytes()
    notes: list[str] = []
    text = decode_lenient(raw, where, notes)
    if text.lstrip()[:1] in ("{", "["):
        try:
            json.loads(text)
        except (ValueError, RecursionError):
            pass
        else:
            raise DataError("a JSON file, not a table of samples", where)
    meta, located, body = scan_text(text, where)
    cols = table_columns(body, where, notes)
    cols.meta = {**meta, **cols.meta}
    cols.options = {**located, **cols.options}
    release = math.nan
    if "release_s" in meta:
        try:
            release = float(meta["release_s"])
        except ValueError:
            raise DataError(f"release_s must be a number, got {meta['release_s']!r}", located["release_s"][1]) \
                from None
    return series_from_columns(cols, spec, sha256=hashlib.sha256(raw).hexdigest(), release_s=release)
