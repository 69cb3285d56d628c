"""What a file holds, from its first bytes: the check every CSV reader makes before parsing.

Shared by the readers (:mod:`~escfit.balance.recordings.timegrapher`,
:mod:`~escfit.balance.recordings.pulses`, :mod:`~escfit.balance.recordings.timeseries`,
:mod:`~escfit.balance.recordings.tg_applog`) and by format detection
(:mod:`~escfit.balance.recordings.detect`); it imports none of them.
"""

from __future__ import annotations

from pathlib import Path

from ...core.errors import DataError

__all__ = ["file_kind", "refuse_unless_csv"]


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
            return "binary"
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
        raise DataError(f"binary file, not the CSV text table of {what}", str(path))
    if kind == "empty":
        raise DataError("empty file (no header and no rows)", str(path))
