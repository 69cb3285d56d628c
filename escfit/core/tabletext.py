"""Text tables as programs write them: the one tokenizer under every text format escfit reads.

Every text reader (loggers' tables, phyphox, CASSY, LabVIEW, PicoScope, Vernier, PASCO, Tracker,
the timegrapher apps) goes through these functions, so a decimal comma, a quoted header, a UTF-16
file or a CR CR LF line end is handled once and the same way everywhere.

- **Bytes to text** (:func:`decode_lenient`): UTF-8 with or without a byte-order mark, UTF-16
  with its byte-order mark (Windows exports), else Latin-1 with a note; NUL bytes outside UTF-16
  make a binary file, refused.
- **Lines** (:func:`numbered_lines`): LF, CRLF, CR and CR CR LF (CASSY Lab's text export: a CR
  added before every CRLF) each end one line, so line numbers are the ones an editor shows.
- **Fields** (:func:`split_fields`): a delimiter (tab, semicolon, comma) with double quotes
  around a field that holds the delimiter, or runs of whitespace; a trailing delimiter adds no
  field.
- **Cells** (:func:`parse_number`, :func:`cell_kind`): numbers with a decimal point or comma,
  thousands separators (``1,234.5``, ``1.234,5``, ``1 234,5``, ``1'234.5``), E-notation
  (``1.234567890E-1`` as Java's DecimalFormat writes it), a Unicode minus, quotes; ``NaN``,
  ``NA``, ``---`` and empty cells are *missing* (nan); ``inf`` and ``∞`` are numbers that are
  not finite (the readers refuse them).  Times of day (``16:04:31.273``), ISO date-times
  (``2024-05-03T16:04:31.273+02:00``, a space for the ``T``) and dates (``2024-05-03``,
  ``03.05.2024``) are recognised and turned into seconds (:func:`time_seconds`); ``true`` /
  ``false`` are flags; anything else is text.
- **Dialect** (:func:`detect_dialect`): the delimiter and decimal mark that split the sample
  lines into one number of fields with numbers (and only the cell kinds above) in them.
"""

from __future__ import annotations

import csv
import datetime as _dt
import math
import re
from collections import Counter
from dataclasses import dataclass

import numpy as np

from .errors import DataError

__all__ = ["Dialect", "decode_lenient", "numbered_lines", "split_fields", "parse_number", "cell_kind",
           "time_seconds", "detect_dialect", "column_floats", "MISSING", "FLAGS"]

MISSING = frozenset({"", "nan", "-nan", "na", "n/a", "#n/a", "null", "none", "-", "--", "---", "—"})
FLAGS = {"true": True, "false": False, "yes": True, "no": False, "ok": True}
_DELIMITERS = (("tab", "\t"), ("semicolon", ";"), ("comma", ","), ("whitespace", None))
_CLOCK = re.compile(r"(\d{1,2}):(\d{2})(?::(\d{2})(?:[.,](\d+))?)?")
_ISO = re.compile(r"(\d{4})-(\d{2})-(\d{2})(?:[T ](\d{1,2}:\d{2}(?::\d{2}(?:[.,]\d+)?)?)\s*(Z|[+-]\d{2}:?\d{2})?)?")
_DOTTED_DATE = re.compile(r"(\d{1,2})\.(\d{1,2})\.(\d{4})(?:\s+(\d{1,2}:\d{2}(?::\d{2}(?:[.,]\d+)?)?))?")
# one grouping mark throughout a number (1,234,567.8 or 1 234 567,8; never 1 234,567 read as a grouping)
_GROUP_POINT = re.compile(r"[-+]?\d{1,3}(?P<g>[,' \u00a0\u202f])\d{3}(?:(?P=g)\d{3})*(?:\.\d*)?(?:[eE][-+]?\d+)?")
_GROUP_COMMA = re.compile(r"[-+]?\d{1,3}(?P<g>[.' \u00a0\u202f])\d{3}(?:(?P=g)\d{3})*(?:,\d*)?(?:[eE][-+]?\d+)?")
_PLAIN = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


@dataclass(frozen=True)
class Dialect:
    """How a table's lines split into cells.

    Attributes
    ----------
    name : str
        ``"tab"``, ``"semicolon"``, ``"comma"``, ``"whitespace"`` or ``"one column"``.
    delimiter : str or None
        The delimiter character; ``None`` for runs of whitespace (and one column).
    decimal_comma : bool
        Whether numbers use a decimal comma.
    trailing : bool
        Whether every line ends with the delimiter (which then closes the row, not opens a cell).
    """

    name: str
    delimiter: str | None
    decimal_comma: bool = False
    trailing: bool = False


# -- bytes and lines ------------------------------------------------------------------------------
def decode_lenient(raw: bytes, where: str, notes: list[str], *, what: str = "a text table") -> str:
    """A file's text: UTF-8 (byte-order mark dropped), UTF-16 with a byte-order mark, else Latin-1.

    Raises
    ------
    DataError
        An empty or binary file.
    """
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        try:
            return raw.decode("utf-16")
        except UnicodeDecodeError:
            raise DataError("starts with a UTF-16 byte-order mark but is not UTF-16 text", where) from None
    if not raw.strip():
        raise DataError("empty file", where)
    if b"\x00" in raw[:8192]:
        raise DataError(f"a binary file, not {what}", where)
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
        if sum(not (c.isprintable() or c.isspace()) for c in text[:8192]) > 0.01 * min(len(text), 8192):
            raise DataError(f"a binary file, not {what}", where) from None
        notes.append("not UTF-8, decoded as Latin-1")
        return text


def numbered_lines(text: str) -> list[tuple[int, str]]:
    """``(line number, text)`` of every line; CR CR LF, CRLF, CR and LF each end one line."""
    text = text.replace("\r\r\n", "\n").replace("\r\n", "\n").replace("\r", "\n")
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    return list(enumerate(lines, start=1))


# -- fields and cells -----------------------------------------------------------------------------
def split_fields(line: str, delimiter: str | None) -> list[str]:
    """The cells of ``line``: quoted fields unquoted, spaces stripped.  A delimiter at the end of the
    line makes an empty last cell (a table whose every row ends so loses that column in its reader)."""
    if delimiter is None:
        return line.split()
    s = line.strip(" \r\n") if delimiter == "\t" else line.strip()
    if '"' not in s:
        return [f.strip() for f in s.split(delimiter)]
    return [f.strip() for f in next(csv.reader([s], delimiter=delimiter, skipinitialspace=True))]


def _unquote(cell: str) -> str:
    c = cell.strip()
    if len(c) >= 2 and c[0] == c[-1] and c[0] in "\"'":
        c = c[1:-1].strip()
    return c


def parse_number(cell: str, decimal_comma: bool = False) -> float | None:
    """The number a cell holds (nan for a missing value), or None when it is not a number."""
    c = _unquote(cell).replace("\u2212", "-")
    low = c.lower()
    if low in MISSING:
        return math.nan
    if low in ("inf", "+inf", "infinity", "∞", "+∞"):
        return math.inf
    if low in ("-inf", "-infinity", "-∞"):
        return -math.inf
    if decimal_comma:
        if _GROUP_COMMA.fullmatch(c) and not c.lstrip("+-").startswith("0"):
            c = re.sub(r"[.' \u00a0\u202f]", "", c)
        c = c.replace(",", ".") if c.count(",") == 1 else c
    elif "," in c or "'" in c or " " in c or "\u00a0" in c or "\u202f" in c:
        # a grouping mark after a leading 0 groups nothing ("0,020" is 0.020 with a decimal comma)
        if not _GROUP_POINT.fullmatch(c) or c.lstrip("+-").startswith("0"):
            return None
        c = re.sub(r"[,' \u00a0\u202f]", "", c)
    if not _PLAIN.fullmatch(c):
        return None
    return float(c)


def time_seconds(cell: str) -> tuple[str, float] | None:
    """``(kind, seconds)`` of a time of day (``"clock"``: s since midnight), an ISO or dotted
    date-time (``"datetime"``: s since 1970, UTC when an offset is given) or a date (``"date"``),
    or None."""
    c = _unquote(cell)
    m = _CLOCK.fullmatch(c)
    if m:
        h, mi, s, frac = m.groups()
        if int(mi) >= 60 or (s is not None and int(s) >= 60) or int(h) > 24:
            return None
        sec = 3600 * int(h) + 60 * int(mi) + (int(s) if s else 0) + (float("0." + frac) if frac else 0.0)
        return "clock", float(sec)
    m = _ISO.fullmatch(c) or _DOTTED_DATE.fullmatch(c)
    if not m:
        return None
    try:
        if m.re is _ISO:
            y, mo, d, clock, zone = m.groups()
        else:
            d, mo, y, clock = m.groups()
            zone = None
        day = _dt.datetime(int(y), int(mo), int(d), tzinfo=_dt.timezone.utc)
    except ValueError:
        return None
    sec = day.timestamp()
    if clock:
        part = time_seconds(clock)
        if part is None:
            return None
        sec += part[1]
    if zone and zone != "Z":
        sign = -1.0 if zone[0] == "+" else 1.0
        digits = zone[1:].replace(":", "")
        sec += sign * (3600 * int(digits[:2]) + 60 * int(digits[2:]))
    return ("datetime" if clock else "date"), sec


def cell_kind(cell: str, decimal_comma: bool = False) -> str:
    """``"number"``, ``"missing"``, ``"clock"``, ``"datetime"``, ``"date"``, ``"flag"`` or ``"text"``."""
    v = parse_number(cell, decimal_comma)
    if v is not None:
        return "missing" if math.isnan(v) else "number"
    c = _unquote(cell).lower()
    if c in FLAGS:
        return "flag"
    t = time_seconds(cell)
    return t[0] if t else "text"


def column_floats(cells: list[str], decimal_comma: bool) -> tuple[np.ndarray, int | None]:
    """A column as floats (nan where missing) and the index of the first cell that is no number
    (None when every cell is one)."""
    try:
        if not decimal_comma:
            return np.array(cells, dtype=float), None
    except ValueError:
        pass
    out = np.empty(len(cells))
    for i, c in enumerate(cells):
        v = parse_number(c, decimal_comma)
        if v is None:
            return out[:i], i
        out[i] = v
    return out, None


# -- dialect ----------------------------------------------------------------------------------------
def _all_numbers(fields: list[str], dc: bool) -> bool:
    return all(parse_number(f, dc) is not None for f in fields)


def _split_decimals(rows: list[list[str]]) -> bool:
    """Whether two comma-separated "columns" are one column written with a decimal comma: every
    cell of both a plain integer, the second always of one width of 2 digits or more and led by
    a zero in some rows (``38,0169``; a count or a time in whole units has no leading zeros)."""
    pairs = [r for r in rows if len(r) == 2]
    whole = re.compile(r"[-+]?\d+")
    if not pairs or not all(whole.fullmatch(a.strip()) and b.strip().isdigit() for a, b in pairs):
        return False
    widths = {len(b.strip()) for _, b in pairs}
    return len(widths) == 1 and widths.pop() >= 2 and any(b.strip().startswith("0") for _, b in pairs)


def _kinds_agree(rows: list[list[str]], n: int, dc: bool, need: float) -> bool:
    """Rows of mixed cells: some column numeric in nearly every row, every column of one kind."""
    full = [r for r in rows if len(r) == n]
    numeric = 0
    for j in range(n):
        kinds = Counter(cell_kind(r[j], dc) for r in full)
        kinds.pop("missing", None)
        if not kinds:
            continue
        kind, count = kinds.most_common(1)[0]
        if count < need * sum(kinds.values()):
            return False
        numeric += kind == "number" and count >= need * len(full)
    return numeric >= 1


def detect_dialect(sample: list[str], where: str) -> tuple[Dialect, int]:
    """The dialect and the number of columns of a table whose body lines are ``sample``.

    Tried in order: tab, semicolon, comma, runs of whitespace, each with a decimal point and then
    (but for the comma) a decimal comma; first with every cell a number, then with columns of
    times, dates, flags or names beside the numbers; last, a single column of numbers.

    Raises
    ------
    DataError
        No dialect splits 90 % of the lines alike.
    """
    need = 0.9 * len(sample)
    candidates = []
    for name, delim in _DELIMITERS:
        rows = [split_fields(s, delim) for s in sample]
        n, count = Counter(len(r) for r in rows).most_common(1)[0]
        if n >= 2 and count >= need:
            candidates.append((name, delim, rows, n))
    for mixed in (False, True):
        for name, delim, rows, n in candidates:
            for dc in (False, True) if delim != "," else (False,):
                if mixed:
                    if _kinds_agree(rows, n, dc, 0.9):
                        return Dialect(name, delim, dc), n
                elif sum(len(r) == n and _all_numbers(r, dc) for r in rows) >= need:
                    if delim == "," and n == 2 and _split_decimals(rows):
                        return Dialect("one column", None, True), 1
                    return Dialect(name, delim, dc), n
    for dc in (False, True):
        if sum(parse_number(s.strip(), dc) is not None for s in sample) >= need:
            return Dialect("one column", None, dc), 1
    raise DataError("cannot find a table of numbers: the last lines do not split into numeric columns at tabs, "
                    "semicolons, commas or spaces", where)
