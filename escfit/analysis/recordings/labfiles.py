"""Classroom data-logger files: Vernier Logger Pro ``.cmbl``, Vernier and PASCO CSV exports, and
Arduino serial logs.

**Vernier ``.cmbl``** (Logger Pro 3, XML): ``<Document>`` holding one ``<DataSet>`` per run
(``<DataSetName>Run 1</DataSetName>``), each with ``<DataColumn>`` elements: ``<DataObjectName>``
(``Time``, ``Angle``, ``Position``), ``<ColumnUnits>`` (``s``, ``°``, ``rad``, ``m``) and
``<ColumnCells>`` holding one number per line (an empty line: no value).  Built from the layout
real files show (the column/cell structure is the same in Graphical Analysis's ``.gambl`` XML);
no writer code is public.

**Vernier CSV** (Logger Pro and Graphical Analysis "Export CSV"): a header of
``"Run 1: Time (s)","Run 1: Angle (°)",...`` (or ``Latest: ...``, ``Data Set 1: ...``), one block of
columns per run side by side; or numbered names ``Time 1,Position 1,Time 2,Position 2`` (units in
brackets after the number), read when every run has its time column.  **PASCO Capstone CSV**: ``Time (s) Run #1,Angle (rad) Run #1,...``, runs side
by side, shorter runs padded with empty cells.  Both are read by the shared table reader; the
run (``[recording] run``, default 1, or the only one) selects the columns, whose names lose the
run label.

**Arduino serial logs**: lines such as ``Time: 123 ms, Angle: 4.5`` (firmware
``Serial.print`` of ``name: value [unit]`` pairs separated by commas or semicolons, e.g.
ferrucci-franco/from_galileo_to_arduino ``galileo_to_arduino.ino``), with stray text lines
(``Start.``, ``Done.``, boot messages) among them: the lines with the most common set of names
are the table, the others are counted in a note.  A log without a time (a bare number per
line) is a one-column table: read it with ``sample_rate``.
"""

from __future__ import annotations

import hashlib
import re
from collections import Counter
from pathlib import Path

import numpy as np

from ...core.errors import DataError
from ...core.tabletext import decode_lenient, numbered_lines, parse_number
from .packed import XML_MAX_BYTES, parse_xml, read_capped
from .columns import Columns, series_from_columns
from .rawtable import scan_text, table_columns
from .recording_spec import RecordingSpec, header_role
from .series import TimeSeries

__all__ = ["read_cmbl", "read_run_csv", "read_arduino_log", "sniff_run_csv", "sniff_arduino_log",
           "write_cmbl"]

_VERNIER_RUN = re.compile(r"^\s*(Run\s*\d+|Latest|Last|Data\s*Set\s*\d*)\s*:\s*(.+)$", re.I)
_PASCO_RUN = re.compile(r"^(.*?)\s*Run\s*#\s*(\d+)\s*$", re.I)
_NUMBERED_RUN = re.compile(r"^\s*(.*?[^\d\s])\s*(\d+)\s*(\([^()]*\)|\[[^\[\]]*\])?\s*$")
# Graphical Analysis' export puts the run first: ``1 Time``, ``1 Position``, ``7: Position``
_RUN_FIRST = re.compile(r"^\s*(\d+)\s*:?\s+([^\d\s].*?)\s*$")
_PAIR = re.compile(r"\s*([A-Za-z_][\w .]*?)\s*[:=]\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([A-Za-zµ°/]*)\s*")


def read_cmbl(path: str | Path, spec: RecordingSpec | None = None) -> TimeSeries:
    """Read a Vernier Logger Pro ``.cmbl`` file (see the module docstring)."""
    spec = spec or RecordingSpec()
    where = str(path)
    raw = read_capped(path, XML_MAX_BYTES, "a Logger Pro file")
    root = parse_xml(raw.lstrip(b"\xef\xbb\xbf"), where)
    sets = list(root.iter("DataSet"))
    if not sets:
        raise DataError("no <DataSet> in the XML: not a Logger Pro file", where)
    runs = [(s.findtext("DataSetName") or f"set {k + 1}").strip() for k, s in enumerate(sets)]
    with_cells = [k for k, s in enumerate(sets) if any((c.findtext("ColumnCells") or "").strip()
                                                       for c in s.iter("DataColumn"))]
    if spec.run is not None:
        if spec.run > len(sets):
            raise DataError(f"[recording] run = {spec.run}, but the file has {len(sets)} data set(s): {runs}", where)
        pick = spec.run - 1
    elif len(with_cells) == 1:
        pick = with_cells[0]
    else:
        raise DataError(f"{len(with_cells)} data sets hold values ({', '.join(runs[k] for k in with_cells)}); set "
                        "[recording] run (1-based, in that order)", where)
    names, units, values = [], [], {}
    for col in sets[pick].iter("DataColumn"):
        cells = (col.findtext("ColumnCells") or "").strip("\n").split("\n")
        v = np.array([parse_number(c) if parse_number(c) is not None else np.nan for c in cells], dtype=float)
        if not (col.findtext("ColumnCells") or "").strip():
            continue
        names.append((col.findtext("DataObjectName") or f"column {len(names) + 1}").strip())
        units.append((col.findtext("ColumnUnits") or "").strip() or None)
        values[len(names) - 1] = v
    if not names:
        raise DataError(f"data set {runs[pick]!r} holds no values", where)
    n = max(v.size for v in values.values())
    values = {k: np.concatenate([v, np.full(n - v.size, np.nan)]) for k, v in values.items()}
    cols = Columns(where, names, [], [], units=units, values=values,
                   describe=f"Vernier Logger Pro .cmbl, data set {runs[pick]!r}, columns {names}")
    return series_from_columns(cols, spec, sha256=hashlib.sha256(raw).hexdigest())


def write_cmbl(runs: dict[str, dict[str, tuple[str, list[float]]]]) -> str:
    """A minimal ``.cmbl`` document in Logger Pro's layout (for tests): ``{run: {name: (unit, values)}}``."""
    parts = ['<?xml version="1.0" encoding="UTF-8"?>\n<Document>\n']
    for run, columns in runs.items():
        parts.append(f"<DataSet>\n<DataSetName>{run}</DataSetName>\n")
        for name, (unit, values) in columns.items():
            cells = "\n".join("" if v != v else repr(float(v)) for v in values)
            parts.append(f"<DataColumn>\n<DataObjectName>{name}</DataObjectName>\n<ColumnUnits>{unit}</ColumnUnits>\n"
                         f"<ColumnCells>\n{cells}\n</ColumnCells>\n</DataColumn>\n")
        parts.append("</DataSet>\n")
    parts.append("</Document>\n")
    return "".join(parts)


def _numbered(name: str) -> tuple[str, str] | None:
    """(run number, quantity with its unit) of a numbered column name, run last (Logger Pro's
    ``Time 1``, ``Position 1 (m)``) or first (Graphical Analysis' ``1 Time``, ``7: Position``)."""
    m = _NUMBERED_RUN.match(name)
    if m:
        return m.group(2), m.group(1) + (f" {m.group(3)}" if m.group(3) else "")
    m = _RUN_FIRST.match(name)
    if m:
        return m.group(1), m.group(2)
    return None


def _numbered_runs(header: list[str]) -> bool:
    """Whether every name is a quantity numbered by its run (:func:`_numbered`) and every run has
    its time column."""
    found = [_numbered(h) for h in header]
    if len(header) < 2 or not all(found):
        return False
    timed = {run for run, what in found if header_role(what)[0] == "time"}
    return timed == {run for run, _ in found}


def _run_of(name: str, numbered: bool = False) -> tuple[str | None, str]:
    if numbered:
        run, what = _numbered(name)
        return f"Run {int(run)}", what
    m = _VERNIER_RUN.match(name)
    if m:
        return re.sub(r"\s+", " ", m.group(1)).title(), m.group(2).strip()
    m = _PASCO_RUN.match(name)
    if m:
        return f"Run {int(m.group(2))}", m.group(1).strip()
    return None, name


def sniff_run_csv(header: list[str]) -> str | None:
    """``"vernier-csv"`` or ``"pasco-csv"`` when a header's names carry run labels, else None."""
    if header and all(_VERNIER_RUN.match(h) for h in header) or _numbered_runs(header):
        return "vernier-csv"
    if header and sum(bool(_PASCO_RUN.match(h)) for h in header) >= max(1, len(header) - 1):
        return "pasco-csv"
    return None


def read_run_csv(path: str | Path, spec: RecordingSpec | None = None, *, program: str = "Vernier/PASCO") -> TimeSeries:
    """Read a Vernier or PASCO CSV export with runs side by side (see the module docstring)."""
    spec = spec or RecordingSpec()
    where = str(path)
    raw = Path(path).read_bytes()
    notes: list[str] = []
    _, _, body = scan_text(decode_lenient(raw, where, notes), where)
    cols = table_columns(body, where, notes)
    if cols.names is None:
        raise DataError("no header naming the runs' columns", where)
    numbered = _numbered_runs(cols.names)
    labelled = [_run_of(n, numbered) for n in cols.names]
    runs = list(dict.fromkeys(r for r, _ in labelled if r is not None))
    if not runs:
        raise DataError(f"no run labels ('Run 1: ...', '... Run #1') in the header {cols.names}", where)
    if spec.run is not None:
        if spec.run > len(runs):
            raise DataError(f"[recording] run = {spec.run}, but the header has {len(runs)} run(s): {runs}",
                            f"{where}:{cols.header_line}")
        run = runs[spec.run - 1]
    elif len(runs) == 1:
        run = runs[0]
    else:
        clockless = spec.sample_rate is None and spec.time_column is None and \
            not any(header_role(what)[0] == "time" for _, what in labelled)
        also = ("; the runs have no time column either: set [recording] sample_rate (or --sample-rate) to the "
                "logger's rate too") if clockless else ""
        raise DataError(f"{len(runs)} runs side by side ({', '.join(runs)}); set [recording] run (1-based){also}",
                        f"{where}:{cols.header_line}")
    keep = [j for j, (r, _) in enumerate(labelled) if r in (run, None)]
    cols.names = [labelled[j][1] for j in keep]
    cols.cells = [cols.cells[j] for j in keep]
    cols.units = [cols.units[j] for j in keep] if cols.units else None
    cols.kinds = [cols.kinds[j] for j in keep] if cols.kinds else []
    cols.describe = f"{program} CSV export, {run} of {len(runs)} ({cols.describe})"
    return series_from_columns(cols, spec, sha256=hashlib.sha256(raw).hexdigest())


def _pairs(line: str) -> list[tuple[str, str, str]] | None:
    parts = re.split(r"[,;\t]", line.strip())
    out = []
    for p in parts:
        if not p.strip():
            continue
        m = _PAIR.fullmatch(p)
        if not m:
            return None
        out.append((m.group(1).strip(), m.group(2), m.group(3)))
    return out or None


def sniff_arduino_log(text: str) -> bool:
    """Whether most of the first lines are ``name: value`` pairs."""
    lines = [s for _, s in numbered_lines(text[:6000]) if s.strip()][:40]
    return len(lines) >= 3 and sum(_pairs(s) is not None for s in lines) >= 0.6 * len(lines)


def read_arduino_log(path: str | Path, spec: RecordingSpec | None = None) -> TimeSeries:
    """Read an Arduino serial log of ``name: value [unit]`` lines (see the module docstring)."""
    where = str(path)
    raw = Path(path).read_bytes()
    notes: list[str] = []
    parsed = [(n, s, _pairs(s)) for n, s in numbered_lines(decode_lenient(raw, where, notes)) if s.strip()]
    shapes = Counter(tuple(k for k, _, _ in p) for _, _, p in parsed if p)
    if not shapes:
        raise DataError("no 'name: value' lines (e.g. 'Time: 123 ms, Angle: 4.5')", where)
    keys, count = shapes.most_common(1)[0]
    rows = [(n, p) for n, _, p in parsed if p and tuple(k for k, _, _ in p) == keys]
    stray = len(parsed) - len(rows)
    if stray:
        first = next(n for n, _, p in parsed if not p or tuple(k for k, _, _ in p) != keys)
        notes.append(f"{stray} line(s) that are not '{': .., '.join(keys)}: ..' left out (first: line {first})")
    units = []
    for j in range(len(keys)):
        seen = {p[j][2] for _, p in rows if p[j][2]}
        units.append(seen.pop() if len(seen) == 1 else None)
    cols = Columns(where, list(keys), [[p[j][1] for _, p in rows] for j in range(len(keys))], [n for n, _ in rows],
                   units=units, describe=f"serial log of '{', '.join(keys)}' lines", notes=notes)
    return series_from_columns(cols, spec, sha256=hashlib.sha256(raw).hexdigest())
