"""What a file holds, from its first bytes: the check every CSV reader makes before parsing.

Shared by the readers (:mod:`~escfit.analysis.recordings.timegrapher`,
:mod:`~escfit.analysis.recordings.pulses`, :mod:`~escfit.analysis.recordings.timeseries`,
:mod:`~escfit.analysis.recordings.tg_applog`) and by format detection
(:mod:`~escfit.analysis.recordings.detect`); it imports none of them.
"""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Iterable

from ...core.errors import DataError
from ...core.textfile import refuse_binary

__all__ = ["file_kind", "refuse_unless_csv", "match_header", "canonical_header", "did_you_mean", "release_from_meta",
           "KNOWN_COLUMNS", "KNOWN_PREFIXES"]

# Column names of the escfit CSV formats (unit curve, pulse train, timegrapher beats, time series)
KNOWN_COLUMNS = ("swing", "cycle", "amplitude_rad", "amplitude_deg", "notches", "time_s", "unit", "kind",
                 "rate_s_per_day", "beat_error_ms", "theta_rad", "theta_deg")
# Column families whose suffix is a unit (``load_mN``, ``time_ms``, ``theta_deg``)
KNOWN_PREFIXES = ("load_", "time_", "theta_")


def match_header(header: Iterable[str], known: Iterable[str] = KNOWN_COLUMNS,
                 prefixes: Iterable[str] = KNOWN_PREFIXES) -> list[str]:
    """Header names as the readers know them: spaces stripped, known names in lower case.

    ``Swing``, `` NOTCHES `` and ``Time_s`` are ``swing``, ``notches`` and ``time_s``.  For a
    column family (``load_``, ``time_``, ``theta_``) only the prefix is put in lower case: its
    suffix is a unit, where case matters (``mN`` is not ``MN``).  Other names are only stripped.
    """
    known = {k.lower() for k in known}
    prefixes = tuple(prefixes)
    out = []
    for name in header:
        stripped = name.strip().lstrip("\ufeff").strip()
        low = stripped.lower()
        if low in known:
            out.append(low)
            continue
        prefix = next((p for p in prefixes if low.startswith(p)), None)
        out.append(prefix + stripped[len(prefix):] if prefix else stripped)
    return out


def canonical_header(table, known: Iterable[str] = KNOWN_COLUMNS, prefixes: Iterable[str] = KNOWN_PREFIXES):
    """``table`` (a :class:`escfit.core.csvtable.Table`) with its header put through :func:`match_header`.

    Raises
    ------
    DataError
        Two columns of the file differ only in case or spaces (``swing`` and ``Swing``).
    """
    header = match_header(table.header, known, prefixes)
    seen: dict[str, str] = {}
    for raw, name in zip(table.header, header):
        if name in seen:
            raise DataError(f"columns {seen[name]!r} and {raw!r} are the same column {name!r} (names are matched "
                            "without regard to case and spaces)", table.path)
        seen[name] = raw
    table.header = header
    return table


def did_you_mean(columns: Iterable[str], known: Iterable[str] = KNOWN_COLUMNS) -> str:
    """``"; column 'notchez' is not known (did you mean 'notches'?)"`` for the columns close to a
    known name, or ``""`` when none is."""
    known = list(known)
    hints = []
    for c in columns:
        if c.lower() in known:
            continue
        close = difflib.get_close_matches(c.lower(), known, n=1, cutoff=0.7)
        if close:
            hints.append(f"column {c!r} is not known (did you mean {close[0]!r}?)")
    return "; " + "; ".join(hints) if hints else ""


def file_kind(path: str | Path) -> str:
    """``"json"``, ``"text"``, ``"binary"`` or ``"empty"`` from a file's first bytes.

    Raises
    ------
    DataError
        The file does not exist.
    """
    p = Path(path)
    if not p.is_file():
        raise DataError("data file not found", str(path))
    head = p.read_bytes()[:8192]
    if b"\x00" in head:
        return "binary"
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError as exc:
        if exc.start < len(head) - 4:  # not just a multi-byte character cut at the boundary
            # text in another encoding (Latin-1 from an old logger) is text: its reader names the encoding
            return "binary" if b"\x00" in head else "text"
        text = head[:exc.start].decode("utf-8")
    text = text.lstrip("\ufeff \t\r\n")
    if not text:
        return "empty"
    return "json" if text[0] in "{[" else "text"


def refuse_unless_csv(path: str | Path, what: str) -> None:
    """Refuse JSON, binary and empty files before a CSV reader tries them.

    Parameters
    ----------
    path
        The file.
    what
        What the caller reads, for the message (``"a pulse train"``).
    """
    kind = file_kind(path)
    if kind == "json":
        raise DataError(f"this is a JSON file, not the CSV table of {what} (a timegrapher dump? read it with "
                        "read_timegrapher or --format timegrapher)", str(path))
    if kind == "binary":
        refuse_binary(Path(path).read_bytes()[:512], str(path), f"the CSV text table of {what}")
    if kind == "empty":
        raise DataError("empty file (no header and no rows)", str(path))


def release_from_meta(meta: dict, where: str) -> float:
    """The ``# release_s:`` metadata line of an escfit CSV (s on the file's clock), ``nan`` when absent.

    Raises
    ------
    DataError
        When the value is not a finite number (naming the file and the key).
    """
    if "release_s" not in meta:
        return math.nan
    try:
        release = float(meta["release_s"])
    except ValueError:
        raise DataError(f"release_s must be a number, got {meta['release_s']!r}", f"{where} [release_s]") from None
    if not math.isfinite(release):
        raise DataError(f"release_s must be a finite time, got {meta['release_s']!r}", f"{where} [release_s]")
    return release
