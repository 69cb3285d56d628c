"""Read friction-rig readings from CSV.

One row per friction reading; every numeric column carries its unit in the header, after
the quantity name and an underscore (``_`` inside the unit stands for ``/``)::

    # source: synthetic session, see docs/friction.md
    # material: 1095 steel (hard)
    load_g,dw_g,speed_ft_s,material
    2.2,0.127,5.0,1095 steel

Columns
-------
``load_<unit>`` (required)
    Load ``w`` of the reading (see ``rig.load_at`` for whether it is the normal force
    during the reading or the calibration load).  A force unit, or a mass unit read as the
    weight of that mass under standard gravity (``load_g`` = grams on the pan).
``dw_<unit>`` (required)
    Extra load needed to bring the light spot back to the calibration deflection, >= 0.
``speed_<unit>`` (optional)
    Sliding speed of the disc under the pallet, e.g. ``speed_ft_s``.
``material`` (optional)
    Free text naming the disc material.

Lines starting with ``#`` are comments; those of the form ``# key: value`` are also kept as
metadata.  Blank lines are ignored.
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np
import pint

from ..core.csvtable import refuses_unreadable
from ..core.errors import DataError
from ..core.units import registry

__all__ = ["Readings", "read_readings", "parse_readings", "write_readings"]

_META = re.compile(r"^#\s*([A-Za-z][\w .-]*?)\s*:\s*(.*?)\s*$")
_QUANTITIES = {
    # name: (canonical unit, accepted dimension words)
    "load": "N",
    "dw": "N",
    "speed": "m/s",
}


@dataclass(frozen=True, eq=False)
class Readings:
    """One rig session: readings that share one stylus set-up (one k, one d).

    Attributes
    ----------
    load
        Load ``w`` of each reading, N.
    dw
        Extra load of each reading, N (>= 0).
    speed
        Sliding speed of each reading, m/s, or ``None`` when the file has no speed column.
    material
        Material of each reading, or ``None``.
    lines
        Line number (1-based) of each reading in the source, for messages.
    metadata
        ``# key: value`` comment lines, in file order (a repeated key continues the value).
    where
        Source file name.
    """

    load: np.ndarray
    dw: np.ndarray
    speed: np.ndarray | None = None
    material: tuple[str, ...] | None = None
    lines: tuple[int, ...] = ()
    metadata: dict[str, str] = field(default_factory=dict)
    where: str = "<readings>"

    def __len__(self) -> int:
        return int(self.load.size)

    def materials(self) -> list[str]:
        """Distinct materials in file order (empty when the column is absent)."""
        if self.material is None:
            return []
        return list(dict.fromkeys(self.material))

    def only(self, material: str) -> "Readings":
        """The readings of one material (a session of its own)."""
        if self.material is None or material not in self.material:
            raise DataError(f"no readings of material {material!r}; present: {self.materials()}", self.where)
        keep = np.array([m == material for m in self.material])
        return Readings(
            load=self.load[keep],
            dw=self.dw[keep],
            speed=None if self.speed is None else self.speed[keep],
            material=tuple(m for m, k in zip(self.material, keep) if k),
            lines=tuple(n for n, k in zip(self.lines, keep) if k),
            metadata=dict(self.metadata),
            where=self.where,
        )


@refuses_unreadable
def read_readings(path: str | Path) -> Readings:
    """Read a rig readings CSV file.

    Parameters
    ----------
    path
        File to read (UTF-8).

    Returns
    -------
    Readings
        Values converted to N and m/s.

    Raises
    ------
    DataError
        Missing or unreadable file, no header or no readings, missing or duplicated
        column, unknown column or unit, wrong number of fields, text or non-finite values in
        a numeric column, non-positive load, negative ``dw`` or speed.  The message names
        ``file:line [column]`` and the offending value.
    """
    where = str(path)
    p = Path(path)
    if not p.is_file():
        raise DataError("readings file not found", where)
    try:
        text = p.read_text(encoding="utf-8-sig")  # tolerate a spreadsheet's byte-order mark
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f"cannot read readings file ({exc})", where) from None
    return parse_readings(text, where=where)


def parse_readings(text: str, *, where: str = "<readings>") -> Readings:
    """Parse the text of a readings CSV (see :func:`read_readings`)."""
    metadata: dict[str, str] = {}
    rows: list[tuple[int, list[str]]] = []
    for lineno, raw in enumerate(io.StringIO(text), start=1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            m = _META.match(line)
            if m:  # a repeated key continues its value
                key = m.group(1)
                metadata[key] = f"{metadata[key]} {m.group(2)}" if key in metadata else m.group(2)
            continue
        fields = next(csv.reader([line]))
        rows.append((lineno, [f.strip() for f in fields]))
    if not rows:
        raise DataError("empty file: no header and no readings", where)
    header_line, header = rows[0]
    columns = _parse_header(header, f"{where}:{header_line}")
    if len(rows) == 1:
        raise DataError("no readings after the header", f"{where}:{header_line}")

    values: dict[str, list[float]] = {name: [] for name, _ in columns.values() if name != "material"}
    material: list[str] = []
    lines: list[int] = []
    for lineno, fields in rows[1:]:
        if len(fields) != len(header):
            raise DataError(
                f"expected {len(header)} fields ({', '.join(header)}), got {len(fields)}: {','.join(fields)!r}",
                f"{where}:{lineno}",
            )
        for (name, factor), text_value, col in zip(columns.values(), fields, header):
            loc = f"{where}:{lineno} [{col}]"
            if name == "material":
                material.append(text_value)
                continue
            values[name].append(_number(text_value, factor, name, loc))
        lines.append(lineno)
    load = np.array(values["load"])
    dw = np.array(values["dw"])
    speed = np.array(values["speed"]) if "speed" in values else None
    return Readings(
        load=load,
        dw=dw,
        speed=speed,
        material=tuple(material) if "material" in columns else None,
        lines=tuple(lines),
        metadata=metadata,
        where=where,
    )


def _parse_header(header: list[str], where: str) -> dict[str, tuple[str, float]]:
    """Map each header cell to (quantity, factor to canonical); keyed by the cell text."""
    out: dict[str, tuple[str, float]] = {}
    seen: dict[str, str] = {}
    for cell in header:
        if not cell:
            raise DataError("empty column name in header", where)
        if cell == "material":
            name, factor = "material", 1.0
        else:
            name, _, unit_token = cell.partition("_")
            if name not in _QUANTITIES:
                raise DataError(
                    f"unknown column {cell!r}; expected load_<unit>, dw_<unit>, speed_<unit> or material",
                    f"{where} [{cell}]",
                )
            if not unit_token:
                example = {"load": "load_g", "dw": "dw_g", "speed": "speed_ft_s"}[name]
                raise DataError(f"column {cell!r} has no unit; write e.g. {example!r}", f"{where} [{cell}]")
            factor = _unit_factor(name, unit_token, f"{where} [{cell}]")
        if name in seen:
            raise DataError(f"quantity {name!r} appears twice (columns {seen[name]!r} and {cell!r})", where)
        seen[name] = cell
        out[cell] = (name, factor)
    for required in ("load", "dw"):
        if required not in seen:
            raise DataError(
                f"missing column {required}_<unit> (e.g. {required}_g); header has {header}", where
            )
    return out


def _unit_factor(name: str, token: str, where: str) -> float:
    """Factor converting one header unit to the canonical unit of quantity ``name``."""
    unit_text = token.replace("_", "/")
    try:
        q = registry().Quantity(1.0, unit_text)
    except (pint.errors.UndefinedUnitError, pint.errors.DefinitionSyntaxError, AttributeError,
            TypeError, ValueError, AssertionError):
        raise DataError(f"unknown unit {token!r}", where) from None
    target = _QUANTITIES[name]
    if name in ("load", "dw") and q.check("[mass]"):
        # grams on the pan: their weight under standard gravity
        q = q * registry().Quantity(1.0, "g_0")
    try:
        return float(q.to(target).magnitude)
    except pint.DimensionalityError:
        kind = "a force or a mass" if target == "N" else "a speed"
        raise DataError(f"unit {token!r} is not {kind} (dimension {q.dimensionality})", where) from None


def _number(text_value: str, factor: float, name: str, where: str) -> float:
    try:
        x = float(text_value)
    except ValueError:
        shown = text_value if text_value else "(empty)"
        raise DataError(f"value {shown!r} is not a number", where) from None
    if not math.isfinite(x):
        raise DataError(f"value {text_value!r} is not finite", where)
    if name == "load" and x <= 0:
        raise DataError(f"load must be positive, got {text_value!r}", where)
    if name == "dw" and x < 0:
        raise DataError(
            f"dw must be zero or positive (friction opposing the load's moment), got {text_value!r}", where
        )
    if name == "speed" and x < 0:
        raise DataError(f"speed must be zero or positive, got {text_value!r}", where)
    return x * factor


def write_readings(readings: Readings, path: str | Path, *, comments: Sequence[str] = (), unit: str = "g",
                   speed_unit: str = "ft_s", digits: int = 4) -> None:
    """Write readings as CSV with loads in ``unit`` (mass read as weight) and speeds in ``speed_unit``.

    ``comments`` are written first as ``#`` lines (use ``"key: value"`` for metadata).
    """
    load_f = 1.0 / _unit_factor("load", unit, "write_readings")
    speed_f = 1.0 / _unit_factor("speed", speed_unit, "write_readings")
    header = [f"load_{unit}", f"dw_{unit}"]
    if readings.speed is not None:
        header.append(f"speed_{speed_unit}")
    if readings.material is not None:
        header.append("material")
    out = io.StringIO()
    for c in comments:
        out.write(f"# {c}\n" if c else "#\n")
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header)
    for i in range(len(readings)):
        row = [f"{readings.load[i] * load_f:.{digits}f}", f"{readings.dw[i] * load_f:.{digits}f}"]
        if readings.speed is not None:
            row.append(f"{readings.speed[i] * speed_f:g}")
        if readings.material is not None:
            row.append(readings.material[i])
        writer.writerow(row)
    Path(path).write_text(out.getvalue(), encoding="utf-8")
