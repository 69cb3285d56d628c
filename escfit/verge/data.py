"""Turns-to-arm readings of a verge S&A mechanism: the data class and its file reader.

A reading is one arming test: the spin rate (rpm), the number of fuze revolutions the
mechanism needed to arm and, optionally, the standard deviation of that number
(measurement scatter, rounding of a published figure -- stated by whoever supplies it).

File format ``turns-to-arm``: a CSV table whose header holds the columns ``label``,
``spin_rpm``, ``turns`` and optionally ``sd``; other columns are ignored, lines starting
with ``#`` are comments::

    # M739 S&A, Lowen & Tepper (1982)
    label,spin_rpm,turns,sd
    mu=0.10,30000,25.8,0.26
"""

from __future__ import annotations

import csv
import hashlib
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from ..core.csvtable import refuses_unreadable
from ..core.errors import DataError

__all__ = ["TurnsData", "read_turns_csv", "detect_turns", "FORMAT", "REQUIRED_COLUMNS"]

#: the format name of a turns-to-arm table (:data:`escfit.verge.family.FAMILY` ``formats``)
FORMAT = "turns-to-arm"
REQUIRED_COLUMNS = ("label", "spin_rpm", "turns")


@dataclass(frozen=True)
class TurnsData:
    """Observed turns-to-arm.

    Attributes
    ----------
    spin_rpm, turns : numpy.ndarray
        Spin rate (rpm) and observed turns to arm of each reading (positive).
    sd : numpy.ndarray or None
        Standard deviation of each reading (turns, positive), or ``None`` when the data do
        not state it (the scene's ``[observation] sigma`` must then give the noise).
    labels : tuple of str
        One label per reading.
    source : str
        Where the numbers come from (the file name for data read from a file).
    sha256 : str
        SHA-256 of the file's bytes (``""`` for data made in memory).
    """

    spin_rpm: np.ndarray
    turns: np.ndarray
    sd: np.ndarray | None
    labels: tuple[str, ...]
    source: str = ""
    sha256: str = ""

    def __post_init__(self):
        labels = tuple(str(x) for x in self.labels)
        object.__setattr__(self, "labels", labels)
        n = len(labels)
        where = self.source or "TurnsData"
        if n == 0:
            raise DataError("no readings", where)
        for name in ("spin_rpm", "turns", "sd"):
            raw = getattr(self, name)
            if raw is None and name == "sd":
                continue
            arr = np.asarray(raw, dtype=float)
            if arr.shape != (n,):
                raise DataError(f"{name} has {arr.size} values for {n} labels", where)
            bad = ~(np.isfinite(arr) & (arr > 0))
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise DataError(f"{name} must be positive and finite, got {arr[i]!r} (reading {labels[i]!r})", where)
            object.__setattr__(self, name, arr)

    @property
    def n(self) -> int:
        """Number of readings."""
        return len(self.labels)

    @property
    def kind(self) -> str:
        return FORMAT

    def subset(self, index: Sequence[int]) -> "TurnsData":
        """The readings at the given positions (same source and checksum)."""
        idx = list(index)
        return TurnsData(self.spin_rpm[idx], self.turns[idx], None if self.sd is None else self.sd[idx],
                         tuple(self.labels[i] for i in idx), self.source, self.sha256)


def _table(path: Path) -> tuple[list[tuple[int, str]], bytes]:
    """(line number, text) of the non-comment, non-blank lines, and the file's bytes."""
    if not path.is_file():
        raise DataError("turns-to-arm file not found", str(path))
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DataError(f"not a UTF-8 text file ({exc.reason} at byte {exc.start})", str(path)) from None
    lines = [(i, ln) for i, ln in enumerate(text.splitlines(), start=1)
             if ln.strip() and not ln.lstrip().startswith("#")]
    return lines, raw


def _header(lines: list[tuple[int, str]], path: Path) -> list[str]:
    if not lines:
        raise DataError("empty: no header line (comments only)", str(path))
    return [c.strip() for c in next(csv.reader([lines[0][1]]))]


def detect_turns(path: str | Path) -> str:
    """``"turns-to-arm"`` when the file's header has the columns ``label, spin_rpm, turns``.

    Raises
    ------
    DataError
        Missing file, not text, or another header (the message names the file and the header).
    """
    path = Path(path)
    lines, _raw = _table(path)
    header = _header(lines, path)
    if set(REQUIRED_COLUMNS) <= set(header):
        return FORMAT
    raise DataError(f"not a turns-to-arm table: the header {header} lacks the columns "
                    f"{sorted(set(REQUIRED_COLUMNS) - set(header))} (a verge fit reads columns label, spin_rpm, turns "
                    "and optionally sd)", f"{path}:{lines[0][0]}")


@refuses_unreadable
def read_turns_csv(path: str | Path) -> TurnsData:
    """Read a turns-to-arm table (columns ``label, spin_rpm, turns`` and optionally ``sd``).

    Raises
    ------
    DataError
        Missing file or columns, a row with too few or too many fields, or a value that is
        not a positive number: the message names the file, the line and the column.
    """
    path = Path(path)
    lines, raw = _table(path)
    header = _header(lines, path)
    hline = lines[0][0]
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise DataError(f"missing column(s) {missing}; the header has {header}", f"{path}:{hline}")
    dup = sorted({c for c in header if header.count(c) > 1})
    if dup:
        raise DataError(f"column(s) {dup} appear more than once in the header", f"{path}:{hline}")
    numeric = [c for c in ("spin_rpm", "turns", "sd") if c in header]
    labels: list[str] = []
    cols: dict[str, list[float]] = {c: [] for c in numeric}
    for lineno, text in lines[1:]:
        fields = [f.strip() for f in next(csv.reader([text]))]
        if len(fields) != len(header):
            raise DataError(f"{len(fields)} fields, the header has {len(header)} ({', '.join(header)})",
                            f"{path}:{lineno}")
        row = dict(zip(header, fields))
        if not row["label"]:
            raise DataError("column 'label' is empty", f"{path}:{lineno}")
        labels.append(row["label"])
        for key in numeric:
            try:
                value = float(row[key])
            except ValueError:
                raise DataError(f"column {key!r}: {row[key]!r} is not a number", f"{path}:{lineno}") from None
            if not (np.isfinite(value) and value > 0):
                raise DataError(f"column {key!r}: {row[key]!r} must be a positive finite number", f"{path}:{lineno}")
            cols[key].append(value)
    if not labels:
        raise DataError("no readings below the header", str(path))
    sd = np.array(cols["sd"]) if "sd" in cols else None
    return TurnsData(np.array(cols["spin_rpm"]), np.array(cols["turns"]), sd, tuple(labels), str(path),
                     hashlib.sha256(raw).hexdigest())
