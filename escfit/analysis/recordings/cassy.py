"""LD Didactic CASSY Lab 2: the ``.labx`` file (XML) and its text export.

Built from real files written by CASSY Lab 2 (GuenterQuast/PhyPraKit ``examples/Drehpendel.labx``,
``CassyExample.labx``, ``Cassy.txt``, 2016-2017; GPL files, read by the tests from
``../shared/realdata/gpl_tests_only/cassy_phyprakit``, never shipped).

``.labx``: UTF-8 with a byte-order mark, the whole XML on one line.  Root ``<cassylab>``;
``<allchannels>`` holds one ``<channels>`` element per measured or calculated quantity, and in
it one ``<channel>`` per run (``runs="true"``), each with ``<quantity>`` (the name, in the
program's language: ``Zeit``, ``Winkel``, ``Weg`` ...), ``<symbol>``, ``<unit>`` (empty for a
dimensionless quantity: CASSY's angles calculated as arc over radius are in rad) and
``<values count="N"><value>x</value>...``, decimal points, an empty ``<value />`` where a
calculated channel has no value (the first sample of a derivative).  A ``.labx`` saved
compressed is a zip whose member ``data.xml`` holds that XML (the layout another CASSY reader,
the ``cassy`` module of a lab-course package, opens; no compressed file was at hand).  Channels of another length
(the FFT axis ``Frequenz``) are left out.

Text export: UTF-8 with a byte-order mark, tab-separated, decimal commas, every line ended by
CR CR LF; header lines ``MIN=``, ``MAX=``, ``SCALE=``, ``DEC=`` (the display settings per
column) and ``DEF="Zeit" t / s<TAB>"Weg" s_A1 / m<TAB>...``: quantity in quotes, symbol, unit
after the slash.

Which column is the angle: the name (``Winkel``, ``angle``, ``phi``) or the unit (deg, rad); a
channel without a unit is read as rad with a note.  ``[recording] run`` picks a run (default 1).
"""

from __future__ import annotations

import hashlib
import re
import xml.etree.ElementTree as ET
from array import array
from pathlib import Path

import numpy as np

from ...core.errors import DataError
from ...core.tabletext import decode_lenient, numbered_lines, split_fields
from .columns import Columns, series_from_columns
from .foreign import cassy_member, zip_names
from .packed import XML_MAX_BYTES, feed_xml, member_chunks, read_capped
from .recording_spec import RecordingSpec
from .series import TimeSeries

__all__ = ["read_cassy_labx", "read_cassy_text", "sniff_cassy_text"]

_DEF = re.compile(r'^\s*"([^"]*)"\s*(\S*)\s*(?:/\s*(.*?))?\s*$')


class _CassyBuilder(ET.TreeBuilder):
    """A tree of the ``.labx`` without its ``<value>`` elements: each ``<values>`` element's numbers
    are gathered as they are parsed (8 bytes a sample, not an element each)."""

    def __init__(self) -> None:
        super().__init__()
        self.arrays: dict[ET.Element, array] = {}
        self._values: array | None = None
        self._text: list[str] | None = None

    def start(self, tag, attrs):  # type: ignore[override]
        if tag == "value" and self._values is not None:
            self._text = []
            return None
        elem = super().start(tag, attrs)
        if tag == "values":
            self._values = self.arrays.setdefault(elem, array("d"))
        return elem

    def data(self, data):  # type: ignore[override]
        if self._text is not None:
            self._text.append(data)
        else:
            super().data(data)

    def end(self, tag):  # type: ignore[override]
        if self._text is not None and tag == "value":
            self._values.append(_number("".join(self._text)))  # type: ignore[union-attr]
            self._text = None
            return None
        if tag == "values":
            self._values = None
        return super().end(tag)


def _number(cell: str) -> float:
    cell = cell.strip()
    try:
        return float(cell.replace(",", ".")) if cell else np.nan
    except ValueError:
        return np.nan


def _floats(values: ET.Element | None, arrays: dict[ET.Element, array]) -> np.ndarray:
    if values is None or values not in arrays:
        return np.zeros(0)
    return np.frombuffer(arrays[values], dtype=float).copy()


def read_cassy_labx(path: str | Path, spec: RecordingSpec | None = None) -> TimeSeries:
    """Read a CASSY Lab 2 ``.labx`` file (see the module docstring).

    Raises
    ------
    DataError
        Not a CASSY Lab file, no time channel, a run that is not there, and the column
        refusals of :func:`~escfit.analysis.recordings.columns.series_from_columns`.
    """
    spec = spec or RecordingSpec()
    where = str(path)
    raw = read_capped(path, XML_MAX_BYTES, "a CASSY Lab file")
    builder = _CassyBuilder()
    packed = ""
    if raw.startswith(b"PK\x03\x04"):  # saved compressed: a zip whose data.xml is the file's XML
        root, packed = _unzipped(path, builder)
    else:
        root = feed_xml([raw], where, builder)
    if root.tag != "cassylab":
        raise DataError(f"XML root <{root.tag}>, not <cassylab>: not a CASSY Lab file", where)
    run = (spec.run or 1) - 1
    found = []
    for group in root.iter("channels"):
        runs = group.findall("channel")
        if not runs:
            continue
        if run >= len(runs):
            raise DataError(f"[recording] run = {run + 1}, but channel {runs[0].findtext('quantity')!r} has "
                            f"{len(runs)} run(s)", where)
        ch = runs[run]
        found.append(((ch.findtext("quantity") or "").strip(), (ch.findtext("symbol") or "").strip(),
                      (ch.findtext("unit") or "").strip(), _floats(ch.find("values"), builder.arrays)))
    times = [i for i, (q, s, u, v) in enumerate(found) if u == "s" and v.size]
    if not times:
        raise DataError(f"no time channel (unit s) among {[q for q, *_ in found]}", where)
    n = found[times[0]][3].size
    kept = [(q, s, u, v) for q, s, u, v in found if v.size in (n, n - 1) and q.lower() not in ("index", "n")]
    dropped = [q for q, s, u, v in found if (q, s, u, v) not in kept and q.lower() not in ("index", "n")]
    notes = [f"channel(s) of another length left out: {', '.join(dropped)}"] if dropped else []
    names = [q if q else s for q, s, u, v in kept]
    units: list[str | None] = [u or None for q, s, u, v in kept]
    values = {i: np.concatenate([v, np.full(n - v.size, np.nan)]) for i, (q, s, u, v) in enumerate(kept)}
    angles = [i for i, (q, s, u, v) in enumerate(kept) if not u and (q.lower() in ("winkel", "angle", "phi")
                                                                     or s.lower() in ("phi", "alpha", "φ", "α"))]
    for i in angles:
        units[i] = "rad"
        notes.append(f"channel {names[i]!r} ({kept[i][1]}) has no unit: CASSY's angle from arc over radius, read as rad")
    stamp = next((c.get("datetime") for c in root.iter("channel") if c.get("datetime")), None)
    cols = Columns(where, names, [], [], units=units, values=values,
                   describe=f"CASSY Lab 2 .labx{packed}, run {run + 1}, channels {names}", notes=notes,
                   meta={"recorded": stamp} if stamp else {})
    return series_from_columns(cols, spec, sha256=hashlib.sha256(raw).hexdigest())


def _unzipped(path, builder: _CassyBuilder) -> tuple[ET.Element, str]:
    """The parsed XML of a compressed ``.labx`` and how it was found (for the description): the
    member is unpacked and parsed chunk by chunk, at most :data:`XML_MAX_BYTES` of it."""
    import zipfile

    where = str(path)
    member = cassy_member(zip_names(path), Path(path).suffix.lower())
    if member is None:
        raise DataError("a zip archive holding no single CASSY Lab data file: extract the .labx from it and read "
                        "that", where)
    with zipfile.ZipFile(path) as zf:
        root = feed_xml(member_chunks(zf, member, XML_MAX_BYTES, where, "a CASSY Lab file"), where, builder)
    return root, f" (compressed, {member})"


def sniff_cassy_text(text: str) -> bool:
    """Whether text is a CASSY Lab text export (``MIN=``/``DEF=`` lines)."""
    head = text[:3000].lstrip("\ufeff")
    return head.startswith(("MIN=", "MAX=", "SCALE=", "DEC=", "DEF=")) and "DEF=" in head


def read_cassy_text(path: str | Path, spec: RecordingSpec | None = None) -> TimeSeries:
    """Read a CASSY Lab text export (see the module docstring)."""
    where = str(path)
    raw = Path(path).read_bytes()
    notes: list[str] = []
    lines = [(n, s) for n, s in numbered_lines(decode_lenient(raw, where, notes)) if s.strip()]
    defs = [(n, s) for n, s in lines if s.startswith("DEF=")]
    if not defs:
        raise DataError("no DEF= line naming the columns: not a CASSY Lab text export", where)
    head_line, head = defs[0]
    fields = [f.strip() for f in head[4:].strip().split("\t")]
    names, units = [], []
    for f in fields:
        m = _DEF.match(f)
        if not m:
            raise DataError(f"cannot read the column definition {f!r} (expected '\"name\" symbol / unit')",
                            f"{where}:{head_line}")
        names.append(m.group(1) or m.group(2))
        units.append(m.group(3) or None)
    settings = {s.split("=", 1)[0]: s.split("=", 1)[1] for n, s in lines if re.match(r"^[A-Z]+=", s)}
    body = [(n, s) for n, s in lines if n > head_line and not re.match(r"^[A-Z]+=", s)]
    rows = [split_fields(s, "\t") for _, s in body]
    if rows and len(rows[-1]) < len(names) and (len(rows) < 2 or len(rows[-1]) < len(rows[-2])):
        notes.append(f"the last row (line {body[-1][0]}) has {len(rows[-1])} of {len(names)} fields and was dropped as "
                     "truncated")
        rows, body = rows[:-1], body[:-1]
    # a channel shorter than the time (an FFT's axis and spectrum, a derivative) ends in empty cells,
    # or, last in the row, in no cells at all
    rows = [r + [""] * (len(names) - len(r)) if len(r) < len(names) else r for r in rows]
    for r, (n, _) in zip(rows, body):
        if len(r) != len(names):
            raise DataError(f"expected {len(names)} fields ({', '.join(names)}), found {len(r)}", f"{where}:{n}")
    if not rows:
        raise DataError("no data rows under the DEF= line", where)
    decimal_comma = any("," in c for r in rows[:20] for c in r)
    for i, (name, unit) in enumerate(zip(names, units)):
        if unit is None and name.lower() in ("winkel", "angle"):
            units[i] = "rad"
            notes.append(f"column {name!r} has no unit: CASSY's angle from arc over radius, read as rad")
    cols = Columns(where, names, [[r[j] for r in rows] for j in range(len(names))], [n for n, _ in body],
                   decimal_comma, head_line, units, describe="CASSY Lab text export (tab-separated"
                   f"{', decimal comma' if decimal_comma else ''}, DEF= header on line {head_line})", notes=notes,
                   meta={f"cassy_{k.lower()}": v.replace("\t", " | ") for k, v in settings.items() if k != "DEF"})
    return series_from_columns(cols, spec, sha256=hashlib.sha256(raw).hexdigest())
