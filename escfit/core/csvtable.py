"""A small, strict CSV reader shared by escfit's own recording formats (unit curves, pulse trains,
time series, per-beat timegrapher CSVs).

``#`` lines are comments; ``# key: value`` comments are metadata.  Every error names the
file, the line and the column.  Lines and fields come from the tokenizer every text format
shares (:func:`~escfit.core.tabletext.numbered_lines`: LF, CRLF, CR and CR CR LF each end one
line; :func:`~escfit.core.tabletext.split_fields`: comma-separated, double quotes around a field);
the text must be UTF-8 (:func:`~escfit.core.textfile.decode_text`) and the numbers plain
(``float``): these formats are escfit's, written by escfit or by hand to its documentation, so
no decimal commas or thousands marks are guessed.
"""

from __future__ import annotations

import csv
import hashlib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from .errors import DataError
from .tabletext import numbered_lines, split_fields
from .textfile import BOM, decode_text

__all__ = ["refuses_unreadable", "Table", "NumericTable", "read_table", "read_numbers"]


def refuses_unreadable(reader):
    """Decorate a reader ``reader(path, ...)``: failures of the text machinery become one DataError.

    A CSV field beyond the csv module's limit (131072 characters) or JSON nested beyond the
    interpreter's recursion limit are properties of the file, not of escfit: they are reported
    as one line naming the file, like any other malformed input.
    """
    import functools

    @functools.wraps(reader)
    def wrapped(path, *args, **kwargs):
        try:
            return reader(path, *args, **kwargs)
        except csv.Error as exc:
            raise DataError(f"cannot read as a table ({exc})", str(path)) from None
        except RecursionError:
            raise DataError("nested too deeply to read", str(path)) from None

    return wrapped


@dataclass
class Table:
    """Columns as lists of strings, with the file line of each row."""

    path: str
    header: list[str]
    rows: list[list[str]]
    lines: list[int]
    meta: dict[str, str] = field(default_factory=dict)
    sha256: str = ""

    def column(self, name: str) -> list[str]:
        i = self.header.index(name)
        return [r[i] for r in self.rows]

    def floats(self, name: str, *, allow_nan: bool = False, positive: bool = False, nonneg: bool = False) -> list[float]:
        """Parse a numeric column, naming file:line [column] and the value on error."""
        out = []
        for line, text in zip(self.lines, self.column(name)):
            where = f"{self.path}:{line} [{name}]"
            try:
                v = float(text)
            except ValueError:
                raise DataError(f"expected a number, got {text!r}", where) from None
            if not allow_nan and not math.isfinite(v):
                raise DataError(f"value {text!r} is not a finite number", where)
            if positive and not v > 0:
                raise DataError(f"value {text!r} must be positive", where)
            if nonneg and v < 0:
                raise DataError(f"value {text!r} must not be negative", where)
            out.append(v)
        return out


def _comment_or_blank(line: str, meta: dict[str, str]) -> bool:
    """Whether ``line`` is blank or a ``#`` comment; a ``# key: value`` comment goes into ``meta``."""
    s = line.strip()
    if s.startswith("#"):
        key, sep, value = s[1:].partition(":")
        if sep and key.strip() and " " not in key.strip():
            meta[key.strip().lower()] = value.strip()
        return True
    return not s


def read_table(path: str | Path) -> Table:
    """Read a CSV file with comment and metadata lines."""
    p = Path(path)
    where = str(path)
    if not p.is_file():
        raise DataError("data file not found", where)
    raw = p.read_bytes()
    text = decode_text(raw, where, what="a CSV table")
    meta: dict[str, str] = {}
    body: list[tuple[int, str]] = []
    for n, line in numbered_lines(text):
        if _comment_or_blank(line, meta):
            continue
        body.append((n, line))
    if not body:
        raise DataError("empty file (no header and no rows)", where)
    try:
        rows = [split_fields(b, ",") for _, b in body]
    except csv.Error as exc:
        raise DataError(f"cannot read as a table ({exc})", where) from None
    header = [h.strip() for h in rows[0]]
    if len(set(header)) != len(header):
        raise DataError(f"duplicate column names in header {header}", f"{where}:{body[0][0]}")
    data, lines = [], []
    for (n, _), r in zip(body[1:], rows[1:]):
        if len(r) != len(header):
            raise DataError(f"expected {len(header)} fields ({', '.join(header)}), found {len(r)}", f"{where}:{n}")
        data.append([c.strip() for c in r])
        lines.append(n)
    if not data:
        raise DataError("header only, no data rows", where)
    return Table(where, header, data, lines, meta, hashlib.sha256(raw).hexdigest())


@dataclass
class NumericTable:
    """A table whose every data row is plain numbers: its header, its metadata and one float array.

    ``values`` has one row per data row and one column per header name.
    """

    path: str
    header: list[str]
    values: "np.ndarray"
    meta: dict[str, str] = field(default_factory=dict)
    sha256: str = ""

    def column(self, name: str) -> "np.ndarray":
        return self.values[:, self.header.index(name)]


# what a data row of plain numbers is made of: digits, signs, points, exponents, commas, spaces
_PLAIN_NUMBERS = re.compile(rb"[0-9eE+\-.,\s]*")
_DIGIT = re.compile(rb"[0-9]")


def read_numbers(path: str | Path) -> NumericTable | None:
    """The table of :func:`read_table` as numbers, read in one pass by numpy; ``None`` unless
    every line after the header is comma-separated plain numbers (no comment, quote or text).

    :func:`read_table` keeps every cell as a string with its line (some 30 times the file's
    size in memory, a few seconds per million rows); a long record of plain numbers needs
    neither: its lines are checked as bytes and parsed by :func:`numpy.loadtxt` from the file
    (the file's size once in memory, for its checksum, then the array).  ``None`` means: read it
    with :func:`read_table`, whose messages name the line and the cell of any problem.  The
    numbers are parsed as :func:`float` parses them.
    """
    import numpy as np

    p = Path(path)
    where = str(path)
    if not p.is_file():
        return None
    raw = p.read_bytes()
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        return None
    pos = len(BOM) if raw.startswith(BOM) else 0
    meta: dict[str, str] = {}
    header_line = None
    head_lines = 0
    while pos < len(raw):  # the comments and metadata before the header, and the header
        end = raw.find(b"\n", pos)
        if end < 0:
            return None  # no data row
        chunk = raw[pos:end]
        pos = end + 1
        head_lines += 1
        if b"\r" in (chunk[:-1] if chunk.endswith(b"\r") else chunk):  # other line ends: left to read_table
            return None
        try:
            line = chunk.decode("utf-8")
        except UnicodeDecodeError:
            return None
        if _comment_or_blank(line, meta):
            continue
        header_line = line
        break
    if header_line is None or '"' in header_line:
        return None
    body = memoryview(raw)[pos:]
    if _PLAIN_NUMBERS.fullmatch(body) is None or _DIGIT.search(body) is None:
        return None
    del body
    sha256 = hashlib.sha256(raw).hexdigest()
    del raw
    header = [h.strip() for h in header_line.split(",")]
    if len(set(header)) != len(header):
        return None
    try:
        with open(p, encoding="utf-8-sig", newline=None) as f:  # CRLF and CR CR LF end lines as in read_table
            for _ in range(head_lines):
                f.readline()
            values = np.loadtxt(f, delimiter=",", ndmin=2, dtype=float, comments=None)
    except ValueError:
        return None
    if values.shape[1] != len(header) or not values.shape[0]:
        return None
    return NumericTable(where, header, values, meta, sha256)
