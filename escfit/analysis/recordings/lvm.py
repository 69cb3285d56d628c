"""LabVIEW measurement files (``.lvm``, "Write To Measurement File"), read into a TimeSeries.

Built from National Instruments' description of the format (LabVIEW Measurement File, header
keys as below) and two real files of ladisk/lvm_read (``data/short.lvm``, Writer_Version 2, and
``data/long_single_header_multi_ch.lvm``, Writer_Version 0.92; MIT; ``../shared/realdata/
labview_impact_ladisk``).

Layout: a file header (``LabVIEW Measurement``, then ``key<sep>value`` lines: ``Separator``
``Tab`` or ``Comma``, ``Decimal_Separator`` (``.`` unless given), ``Multi_Headings``,
``X_Columns`` ``No`` / ``One`` / ``Multi``, ``Date``, ``Time`` ...) closed by
``***End_of_Header***``; then one or more segments, each a channel header (``Channels``,
``Samples``, ``Y_Unit_Label``, ``X_Dimension``, ``X0``, ``Delta_X`` per channel) closed by
``***End_of_Header***``, a line of column names (``X_Value``, the channels, ``Comment``) and the
rows.  With ``X_Columns No`` the X_Value cells are empty and the time is ``X0 + row * Delta_X``;
with ``One`` the first column is the time; with ``Multi`` every channel has its own X column
(the first is used).

Quirks handled: ``Samples`` counts that disagree with the rows (records appended under one
header; read on one clock, with a note), a decimal comma declared in the header, the header's
time written with a decimal comma while the data use a point, several segments (joined in
order; a segment whose X0 restarts is continued on the running clock, with a note).
"""

from __future__ import annotations

import hashlib
from pathlib import Path


from ...core.errors import DataError
from ...core.tabletext import decode_lenient, numbered_lines, parse_number
from .columns import Columns, series_from_columns
from .recording_spec import RecordingSpec
from .series import TimeSeries

__all__ = ["read_lvm", "sniff_lvm"]

_END = "***End_of_Header***"


def sniff_lvm(text: str) -> bool:
    """Whether text starts like a LabVIEW measurement file."""
    return text.lstrip("\ufeff").startswith("LabVIEW Measurement")


def _kv(line: str, sep: str) -> tuple[str, list[str]]:
    parts = [p.strip() for p in line.split(sep)]
    while len(parts) > 1 and parts[-1] == "":
        parts.pop()
    return parts[0], parts[1:]


def read_lvm(path: str | Path, spec: RecordingSpec | None = None) -> TimeSeries:
    """Read a LabVIEW ``.lvm`` file (see the module docstring).

    Raises
    ------
    DataError
        Not an LVM file, a header without its end, a row of the wrong width, and the column
        refusals of :func:`~escfit.analysis.recordings.columns.series_from_columns`.
    """
    where = str(path)
    raw = Path(path).read_bytes()
    notes: list[str] = []
    lines = numbered_lines(decode_lenient(raw, where, notes))
    if not lines or not sniff_lvm(lines[0][1]):
        raise DataError("does not start with 'LabVIEW Measurement': not an .lvm file", f"{where}:1")
    sep = "\t"
    head: dict[str, str] = {}
    i = 1
    while i < len(lines) and not lines[i][1].strip().startswith(_END):
        key, vals = _kv(lines[i][1], "\t" if "\t" in lines[i][1] else ",")
        if key:
            head[key] = vals[0] if vals else ""
        i += 1
    if i >= len(lines):
        raise DataError(f"no '{_END}' after the file header", where)
    sep = "," if head.get("Separator", "Tab").lower().startswith("comma") else "\t"
    dc = head.get("Decimal_Separator", ".") == ","
    x_cols = head.get("X_Columns", "No").lower()
    names: list[str] | None = None
    units: list[str | None] = []
    rows: list[list[str]] = []
    row_lines: list[int] = []
    clock: tuple[float, float] | None = None
    announced = 0
    segments = 0
    i += 1
    while i < len(lines):
        n, s = lines[i]
        key, vals = _kv(s, sep)
        if key == "Channels" or (key and key in ("Samples", "X0", "Delta_X") and names is None):
            chan: dict[str, list[str]] = {}
            while i < len(lines) and not lines[i][1].strip().startswith(_END):
                k, v = _kv(lines[i][1], sep)
                if k:
                    chan[k] = v
                i += 1
            if i + 1 >= len(lines):
                raise DataError(f"a channel header without '{_END}' and column names", f"{where}:{n}")
            i += 1
            head_line, header = lines[i]
            cells = [c.strip() for c in header.split(sep)]
            segment_names = [c for c in cells if c and c not in ("X_Value", "Comment")]
            segments += 1
            if names is None:
                names, header_at = segment_names, head_line
                units = [u or None for u in chan.get("Y_Unit_Label", [])][:len(names)]
                units += [None] * (len(names) - len(units))
                x0 = parse_number((chan.get("X0") or ["0"])[0], dc)
                dx = parse_number((chan.get("Delta_X") or ["nan"])[0], dc)
                if dx is not None and x0 is not None and dx > 0:
                    clock = (x0, dx)
            elif segment_names != names:
                raise DataError(f"a segment with other channels {segment_names} than the first {names}",
                                f"{where}:{head_line}")
            samples = parse_number((chan.get("Samples") or ["0"])[0])
            announced += int(samples) if samples is not None and 0 <= samples < 1e12 else 0
            i += 1
            continue
        if s.strip() and names is not None:
            cells = [c.strip() for c in s.split(sep)]
            if x_cols == "no" and cells and cells[0] == "":
                cells = cells[1:]
            elif x_cols == "multi":
                cells = cells[:1] + cells[1::2] if len(cells) > 1 else cells
            rows.append(cells)
            row_lines.append(n)
        i += 1
    if names is None or not rows:
        raise DataError("no channel header and data rows after the file header", where)
    width = len(names) + (1 if x_cols in ("one", "multi") else 0)
    rows = [r[:width] if len(r) > width and all(c == "" for c in r[width:]) else r for r in rows]
    if rows and len(rows[-1]) < width and len(rows) > 1:
        notes.append(f"the last row (line {row_lines[-1]}) has {len(rows[-1])} of {width} fields and was dropped as "
                     "truncated")
        rows, row_lines = rows[:-1], row_lines[:-1]
    for r, n in zip(rows, row_lines):
        if len(r) != width:
            raise DataError(f"expected {width} fields ({', '.join(names)}), found {len(r)}", f"{where}:{n}")
    if announced and announced != len(rows):
        notes.append(f"{len(rows)} rows under header(s) announcing {announced} samples per channel "
                     f"({segments} segment(s)): read as one record on one clock")
    if x_cols in ("one", "multi"):
        names = ["X_Value"] + names
        units = ["s" if head.get("X_Dimension", "Time") else None] + units
        clock = None
    cols = Columns(where, names, [[r[j] for r in rows] for j in range(len(names))], row_lines, dc, header_at, units,
                   describe=f"LabVIEW measurement file (Writer_Version {head.get('Writer_Version', '?')}, "
                            f"{'comma' if sep == ',' else 'tab'}-separated{', decimal comma' if dc else ''}, "
                            f"X_Columns {head.get('X_Columns', 'No')})",
                   notes=notes, uniform_clock=clock,
                   meta={k.lower(): v for k, v in head.items() if k in ("Date", "Time", "Operator", "Description")})
    return series_from_columns(cols, spec, sha256=hashlib.sha256(raw).hexdigest())
