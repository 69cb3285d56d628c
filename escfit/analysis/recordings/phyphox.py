"""phyphox exports (RWTH Aachen's phone-sensor app): a CSV file, or a ``.zip`` of one CSV per set.

Writer: phyphox-android ``app/src/main/java/de/rwth_aachen/phyphox/DataExport.java``
(``CsvFormat.export``, stored version 07559f67):

- the header holds every column name in double quotes, joined by the separator (a name starting
  with ``=``, ``+``, ``-`` or ``@`` gets a leading ``'``);
- numbers are Java ``DecimalFormat("0.000000000E0")`` with the chosen decimal mark
  (``-1.234567890E-1``); a column shorter than the longest is padded with ``NaN``;
- five CSV variants: comma / tab / semicolon with a decimal point, tab / semicolon with a
  decimal comma; lines end with ``\\n``;
- the ``.zip`` holds ``<set name>.csv`` for every export set (``Raw Data.csv`` for the sensor
  experiments) and ``meta/device.csv`` (``"property","value"``) and ``meta/time.csv``
  (``"event","experiment time","system time","system time text"``: START and PAUSE events).

Column names come from each experiment's definition, e.g. ``"Time (s)"``, ``"Gyroscope x
(rad/s)"`` (gyroscope) or ``"Rotation x (rad/s)"`` (pendulum): a gyroscope records an angular
velocity, read with ``[recording] velocity_column``.

What is read: the set's CSV through :mod:`~escfit.analysis.recordings.rawtable` (the shared
tokenizer), NaN padding dropped with a note.  From the zip: ``Raw Data.csv`` when it is there,
else the only set that has a time column; the device's model and the start time go to the
metadata, and a measurement paused and resumed (several START events in ``meta/time.csv``)
gets a note naming the instants: phyphox's experiment time skips the pause, so the record joins
two runs (set ``start``/``stop`` to keep one).
"""

from __future__ import annotations

import hashlib
import io
import zipfile
from pathlib import Path

from ...core.errors import DataError
from ...core.tabletext import decode_lenient, numbered_lines, parse_number, split_fields
from .columns import series_from_columns
from .packed import read_head, read_member
from .rawtable import scan_text, table_columns
from .recording_spec import RecordingSpec
from .series import TimeSeries

__all__ = ["read_phyphox", "sniff_phyphox_csv", "MAX_MEMBER_BYTES"]

MAX_MEMBER_BYTES = 200 << 20  # a phone records for hours at 500 Hz: some 100 MB of CSV; beyond is no export


def sniff_phyphox_csv(text: str) -> bool:
    """Whether text looks like a phyphox CSV: a quoted header, numbers written as ``0.000000000E0``."""
    lines = [s for _, s in numbered_lines(text[:4000]) if s.strip()]
    if len(lines) < 2 or not lines[0].startswith('"'):
        return False
    for delim in (",", "\t", ";"):
        head = split_fields(lines[0], delim)
        row = split_fields(lines[1], delim)
        if len(head) >= 2 and len(head) == len(row) and lines[0].count('"') == 2 * len(head):
            return all(c == "NaN" or ("E" in c and parse_number(c, delim != ",") is not None) for c in row)
    return False


META_BYTES = 1 << 20  # meta/device.csv and meta/time.csv: a few lines each


def _members(path: Path, where: str) -> tuple[str, dict[str, bytes]]:
    """The data set to read and the members read for it (the set, ``meta/device.csv``,
    ``meta/time.csv``): only these are unpacked, the set at most :data:`MAX_MEMBER_BYTES`, each
    other member at most :data:`META_BYTES`; the other sets' first bytes tell which set is the
    recording."""
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError):
        raise DataError("not a readable .zip file", where) from None
    with zf:
        names = [i.filename for i in zf.infolist() if not i.is_dir() and i.filename.lower().endswith(".csv")]
        sets = [n for n in names if not n.startswith("meta/")]
        heads = {n: read_head(zf, n, 200, where) for n in sets} if len(sets) > 1 and "Raw Data.csv" not in sets \
            else dict.fromkeys(sets, b"")
        name = _choose_set(heads, where)
        out = {name: read_member(zf, name, MAX_MEMBER_BYTES, where, "a phyphox data set")}
        for meta in ("meta/device.csv", "meta/time.csv"):
            if meta in names:
                out[meta] = read_member(zf, meta, META_BYTES, where, "phyphox's meta data")
    return name, out


def _meta_table(raw: bytes, where: str) -> list[list[str]]:
    notes: list[str] = []
    text = decode_lenient(raw, where, notes)
    rows = [s for _, s in numbered_lines(text) if s.strip()]
    if not rows:
        return []
    delim = max((",", "\t", ";"), key=rows[0].count)
    return [split_fields(r, delim) for r in rows[1:]]


def _time_notes(rows: list[list[str]], notes: list[str], meta: dict[str, str]) -> None:
    """Start time and pauses from meta/time.csv (event, experiment time, system time, text)."""
    starts = [r for r in rows if r and r[0].upper() == "START"]
    if starts and len(starts[0]) >= 4:
        meta["start_time"] = starts[0][3]
    pauses = [r for r in rows if r and r[0].upper() == "PAUSE"]
    if len(starts) > 1:
        at = ", ".join(f"t = {parse_number(r[1], ',' in r[1]) or 0.0:g} s" for r in pauses[:-1] or pauses)
        notes.append(f"the measurement was paused and resumed {len(starts) - 1} time(s) ({at}; meta/time.csv): phyphox's "
                     "time skips each pause, so the record joins separate runs; set [recording] start/stop to keep one")


def _choose_set(heads: dict[str, bytes], where: str) -> str:
    """The data set holding the recording, from the sets' first bytes."""
    sets = heads
    if not sets:
        raise DataError("no data set (<set name>.csv) in the zip: not a phyphox export", where)
    if "Raw Data.csv" in sets or len(sets) == 1:
        return "Raw Data.csv" if "Raw Data.csv" in sets else next(iter(sets))
    timed = [n for n, b in sets.items() if b[:200].lower().lstrip(b'\xef\xbb\xbf"').startswith(b"time")]
    if len(timed) == 1:
        return timed[0]
    raise DataError(f"several data sets in the zip ({', '.join(sorted(sets))}): cannot tell which holds the "
                    "recording; extract that set's CSV and read it", where)


def read_phyphox(path: str | Path, spec: RecordingSpec | None = None) -> TimeSeries:
    """Read a phyphox CSV or ``.zip`` export (see the module docstring).

    Raises
    ------
    DataError
        Not a phyphox export, several candidate sets, and all the column refusals of
        :func:`~escfit.analysis.recordings.columns.series_from_columns`.
    """
    p = Path(path)
    where = str(path)
    raw = p.read_bytes()
    notes: list[str] = []
    meta: dict[str, str] = {}
    if raw[:4] == b"PK\x03\x04":
        name, members = _members(p, where)
        body_raw = members[name]
        meta["phyphox_set"] = name[:-4]
        if "meta/device.csv" in members:
            device = {r[0]: r[1] for r in _meta_table(members["meta/device.csv"], where) if len(r) >= 2}
            for key in ("deviceModel", "deviceBrand", "version"):
                if device.get(key):
                    meta[f"phyphox_{key}"] = device[key]
        if "meta/time.csv" in members:
            _time_notes(_meta_table(members["meta/time.csv"], where), notes, meta)
        inner = f"{where}!{name}"
        describe = f"phyphox zip export, set {name!r}"
    else:
        body_raw, inner, describe = raw, where, "phyphox CSV export"
    text = decode_lenient(body_raw, inner, notes)
    _, _, body = scan_text(text, inner)
    cols = table_columns(body, inner, notes)
    cols.describe = f"{describe} ({cols.describe})"
    cols.meta.update(meta)
    cols.names = [n[1:] if n.startswith("'") and n[1:2] in "=+-@" else n for n in cols.names] if cols.names else None
    return series_from_columns(cols, spec, sha256=hashlib.sha256(raw).hexdigest())


def write_phyphox_csv(columns: dict[str, list[float]], *, separator: str = ",", decimal: str = ".") -> str:
    """A phyphox CSV as ``CsvFormat.export`` writes it (for tests and examples): quoted names,
    ``0.000000000E0`` numbers, shorter columns padded with NaN."""
    def fmt(v: float) -> str:
        if v != v:
            return "NaN"
        m, e = f"{v:.9E}".split("E")
        return f"{m}E{int(e)}".replace(".", decimal)

    names = list(columns)
    n = max(len(c) for c in columns.values())
    lines = [separator.join(f'"{k}"' for k in names)]
    for i in range(n):
        lines.append(separator.join(fmt(columns[k][i]) if i < len(columns[k]) else "NaN" for k in names))
    return "\n".join(lines) + "\n"


def write_phyphox_zip(path: str | Path, sets: dict[str, dict[str, list[float]]], *, time_events=(),
                      separator: str = ",", decimal: str = ".") -> None:
    """A phyphox ``.zip`` export: one CSV per set and ``meta/device.csv``, ``meta/time.csv``."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for name, cols in sets.items():
            zf.writestr(f"{name}.csv", write_phyphox_csv(cols, separator=separator, decimal=decimal))
        zf.writestr("meta/device.csv", f'"property"{separator}"value"\n"deviceModel"{separator}"test phone"\n')
        rows = [f'"event"{separator}"experiment time"{separator}"system time"{separator}"system time text"']
        rows += [f'"{ev}"{separator}{t:.9E}{separator}{st:.3f}{separator}"{txt}"' for ev, t, st, txt in time_events]
        zf.writestr("meta/time.csv", "\n".join(rows) + "\n")
    Path(path).write_bytes(buf.getvalue())
