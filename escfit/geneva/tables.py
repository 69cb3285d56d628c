"""Reading digitised tables (CSV with units in the headers) such as Meyer's Appendix E.

Format: lines starting with ``#`` are comments (the first one names the source); the first
other line is the header, each column written ``name [unit]`` with a pint unit (``[1]`` for
dimensionless); every later line is a row of numbers.  Values are converted to SI.
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import numpy as np

from ..core.errors import DataError
from ..core.units import registry

__all__ = ["read_table", "MEYER_TABLES", "meyer_table"]

_HEADER = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*\[([^\]]*)\]\s*$")

DATA_DIR = Path(__file__).resolve().parents[2] / "datasets" / "geneva"

# Appendix E mechanism -> (file, slots, driver and follower inertia in lbf*inch*s^2 as used, compat)
MEYER_TABLES = {
    "four_pin": ("meyer1973_four_pin.csv", 4, 3e-6, 50e-6, "none"),
    "three_pin": ("meyer1973_three_pin.csv", 6, 3e-6, 40e-6, "meyer1973"),
    "six_pin": ("meyer1973_six_pin.csv", 3, 6e-6, 10e-6, "meyer1973"),
}


def read_table(path: str | Path) -> dict[str, np.ndarray]:
    """Read a units-in-header CSV into SI column arrays.

    Parameters
    ----------
    path
        The CSV file.

    Returns
    -------
    dict
        Column name -> float array in SI units; key ``"_source"`` holds the comment lines.

    Raises
    ------
    DataError
        Missing file, header without units, unknown unit, non-numeric cell or a row of the
        wrong length; the message names the file, line and value.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError("table file not found", str(path))
    comments: list[str] = []
    header: list[tuple[str, float]] | None = None
    rows: list[list[float]] = []
    with path.open(encoding="utf-8", newline="") as fh:
        for lineno, row in enumerate(csv.reader(fh), start=1):
            where = f"{path}:{lineno}"
            if not row or not "".join(row).strip():
                continue
            if row[0].lstrip().startswith("#"):
                comments.append(",".join(row).lstrip("# ").rstrip())
                continue
            if header is None:
                header = [_column(cell, where) for cell in row]
                continue
            if len(row) != len(header):
                raise DataError(f"row has {len(row)} values, header has {len(header)}", where)
            vals = []
            for cell, (name, _) in zip(row, header):
                try:
                    v = float(cell)
                except ValueError:
                    raise DataError(f"column {name!r}: {cell!r} is not a number", where) from None
                if not math.isfinite(v):
                    raise DataError(f"column {name!r}: {cell!r} is not finite", where)
                vals.append(v)
            rows.append(vals)
    if header is None:
        raise DataError("no header line", str(path))
    data = np.array(rows, dtype=float).reshape(-1, len(header))
    out: dict = {name: data[:, i] * factor for i, (name, factor) in enumerate(header)}
    out["_source"] = comments
    return out


def _column(cell: str, where: str) -> tuple[str, float]:
    m = _HEADER.match(cell)
    if not m:
        raise DataError(f"header cell {cell!r} must read 'name [unit]'", where)
    name, unit = m.group(1), m.group(2).strip()
    if unit in ("", "1"):
        return name, 1.0
    try:
        q = registry().Quantity(1.0, unit)
        return name, float(q.to_base_units().magnitude)
    except Exception as exc:  # pint raises several types
        raise DataError(f"header cell {cell!r}: unknown unit {unit!r} ({exc})", where) from None


def meyer_table(name: str) -> dict[str, np.ndarray]:
    """One of Meyer's Appendix E tables (``"four_pin"``, ``"three_pin"``, ``"six_pin"``), SI."""
    if name not in MEYER_TABLES:
        raise DataError(f"unknown table {name!r}; known: {sorted(MEYER_TABLES)}", "meyer_table")
    return read_table(DATA_DIR / MEYER_TABLES[name][0])
