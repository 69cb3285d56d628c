"""Unit curves: amplitude per half swing or per cycle, as Monday plotted them.

CSV format
----------
One of the index columns

- ``swing``: half swing from release (swing 1 ends at the first turning point; swing 0 is a
  reading of the release amplitude itself), or
- ``cycle``: cycle k ends at swing 2k;

and one amplitude column

- ``amplitude_rad`` or ``amplitude_deg``: the amplitude reading, or
- ``notches``: whole notches counted from the rest position to the turning point (notch
  angle from a ``# notch_deg: 6`` comment line or the reader's ``notch_deg`` argument);

optional ``time_s``, ``load_<unit>`` (e.g. ``load_g``: the fixture load, any mass or force
unit pint knows) and ``unit`` (an identifier, so one file can hold several units or loads).
Lines starting with ``#`` are comments; ``# key: value`` comments are metadata.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...core.errors import DataError
from ...core.units import COMMON_UNITS, registry
from ...core.csvtable import read_table
from .sniff import canonical_header, did_you_mean

__all__ = ["UnitCurve", "read_unit_curve", "write_unit_curve"]

AMPLITUDE_COLUMNS = ("amplitude_rad", "amplitude_deg", "notches")

#: Largest swing index a unit curve may name: a balance beating at 10 Hz makes 10^6 half swings in
#: 14 hours; the model is solved up to the last recorded swing, so the index bounds the work.
MAX_SWING = 1_000_000


@dataclass
class UnitCurve:
    """Amplitude readings of one or more decay curves.

    Attributes
    ----------
    swing : ndarray of int
        Half-swing index of each reading (0 = the release amplitude).
    value : ndarray
        Amplitude in rad (``kind == "amplitude"``) or notch counts (``kind == "notches"``).
    kind : str
        ``"amplitude"`` or ``"notches"``.
    notch : float
        Notch angle, rad (``nan`` for amplitude readings).
    load : ndarray or None
        Fixture load of each reading in ``load_unit`` (None when the file has none).
    unit : ndarray of str
        Unit identifier of each reading (``""`` when absent).
    time : ndarray or None
        Time of each reading, s.
    source, sha256, meta
        File name, content hash and ``# key: value`` metadata.
    """

    swing: np.ndarray
    value: np.ndarray
    kind: str
    notch: float = math.nan
    load: np.ndarray | None = None
    load_unit: str = ""
    unit: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=str))
    time: np.ndarray | None = None
    source: str = ""
    sha256: str = ""
    meta: dict = field(default_factory=dict)

    def groups(self) -> list[tuple[tuple[str, float], np.ndarray]]:
        """Row indices of each (unit, load) curve, in order of appearance."""
        loads = self.load if self.load is not None else np.full(self.swing.size, math.nan)
        keys: list[tuple[str, float]] = []
        seen: set[tuple[str, float | None]] = set()
        for u, ld in zip(self.unit, loads):
            tag = (str(u), None if math.isnan(ld) else float(ld))  # NaN never equals itself
            if tag not in seen:
                seen.add(tag)
                keys.append((str(u), float(ld)))
        return [(k, np.flatnonzero((self.unit == k[0]) & ((loads == k[1]) | (np.isnan(loads) & math.isnan(k[1])))))
                for k in keys]

    def select(self, rows: np.ndarray) -> "UnitCurve":
        """The readings at ``rows``."""
        pick = lambda a: None if a is None else a[rows]  # noqa: E731
        return UnitCurve(self.swing[rows], self.value[rows], self.kind, self.notch, pick(self.load), self.load_unit,
                         self.unit[rows], pick(self.time), self.source, self.sha256, self.meta)

    @property
    def amplitude_rad(self) -> np.ndarray:
        """Readings as angles (notch counts times the notch angle)."""
        return self.value * self.notch if self.kind == "notches" else self.value


def read_unit_curve(path: str | Path, *, notch_deg: float | None = None,
                    default_notch_deg: float | None = None) -> UnitCurve:
    """Read a unit-curve CSV (see the module docstring for the format).

    ``notch_deg`` (deg) overrides the file's ``# notch_deg:`` line; ``default_notch_deg`` (the
    scene's ``[observation] notch_deg``) is used only when the file has none.

    Raises
    ------
    DataError
        Missing or ambiguous columns, non-numeric or non-finite values, negative
        amplitudes, swing indices that are not whole, positive and strictly increasing
        within a curve, unknown load units, or notches without a notch angle.
    """
    t = canonical_header(read_table(path))
    where = t.path
    idx = [c for c in ("swing", "cycle") if c in t.header]
    if len(idx) != 1:
        raise DataError(f"need exactly one index column 'swing' or 'cycle', header has {t.header}"
                        f"{did_you_mean(t.header)}", where)
    amp = [c for c in AMPLITUDE_COLUMNS if c in t.header]
    if len(amp) != 1:
        raise DataError(f"need exactly one amplitude column of {list(AMPLITUDE_COLUMNS)}, header has {t.header}"
                        f"{did_you_mean(t.header)}", where)
    loads = [c for c in t.header if c.startswith("load_")]
    known = {"swing", "cycle", *AMPLITUDE_COLUMNS, "time_s", "unit", *loads}
    unknown = [c for c in t.header if c not in known]
    if unknown:
        raise DataError(f"unknown column(s) {unknown}{did_you_mean(unknown)}; known: swing|cycle, "
                        f"{'|'.join(AMPLITUDE_COLUMNS)}, time_s, load_<unit>, unit", where)
    index = t.floats(idx[0], nonneg=True)
    for line, v in zip(t.lines, index):
        if v != int(v):
            raise DataError(f"{idx[0]} index must be a whole number >= 0, got {v!r}", f"{where}:{line} [{idx[0]}]")
        if v * (2 if idx[0] == "cycle" else 1) > MAX_SWING:
            # the model is run to the last recorded swing: an index this large would take hours and gigabytes
            raise DataError(f"{idx[0]} index {v:.17g} is beyond {MAX_SWING:,} half swings (a unit curve is a decay "
                            "of minutes); check the column", f"{where}:{line} [{idx[0]}]")
    swing = np.array(index, dtype=np.int64) * (2 if idx[0] == "cycle" else 1)
    value = np.array(t.floats(amp[0], nonneg=True))
    kind, notch = "amplitude", math.nan
    if amp[0] == "amplitude_deg":
        value = np.radians(value)
    elif amp[0] == "notches":
        kind = "notches"
        nd = notch_deg if notch_deg is not None else t.meta.get("notch_deg", default_notch_deg)
        if nd is None:
            raise DataError("notch counts need the notch angle: a '# notch_deg: 6' line, --notch-deg or the scene's "
                            "[observation] notch_deg", where)
        try:
            notch = math.radians(float(nd))
        except ValueError:
            raise DataError(f"notch_deg must be a number, got {nd!r}", where) from None
        if not (notch > 0 and math.isfinite(notch)) or notch > math.pi:
            raise DataError(f"notch_deg must be a positive number of degrees up to 180, got {nd!r}", where)
        for line, v in zip(t.lines, value):
            if v != int(v):
                raise DataError(f"notch counts must be whole numbers, got {v!r}", f"{where}:{line} [notches]")
    load, load_unit = None, ""
    if len(loads) > 1:
        raise DataError(f"more than one load column {loads}", where)
    if loads:
        load_unit = loads[0][len("load_"):]
        if COMMON_UNITS.get(load_unit, ("",))[0] not in ("mass", "force"):  # not g, kg or N: pint reads it
            try:
                dim = registry().Unit(load_unit).dimensionality
            except Exception:
                raise DataError(f"unknown load unit {load_unit!r} in column {loads[0]!r}", where) from None
            mass_or_force = dim in (registry().Unit("g").dimensionality, registry().Unit("N").dimensionality)
        else:
            mass_or_force = True
        if not mass_or_force:
            raise DataError(f"load unit {load_unit!r} in column {loads[0]!r} is not a mass or a force", where)
        load = np.array(t.floats(loads[0], nonneg=True))
    unit = np.array(t.column("unit"), dtype=str) if "unit" in t.header else np.full(swing.size, "", dtype=str)
    time = np.array(t.floats("time_s", nonneg=True)) if "time_s" in t.header else None
    curve = UnitCurve(swing, value, kind, notch, load, load_unit, unit, time, where, t.sha256, t.meta)
    for (u, ld), rows in curve.groups():
        s = swing[rows]
        bad = np.flatnonzero(np.diff(s) <= 0)
        if bad.size:
            line = t.lines[rows[bad[0] + 1]]
            label = f" (unit {u!r}, load {ld:g})" if u or not math.isnan(ld) else ""
            raise DataError(f"{idx[0]} index must increase within a curve{label}: {s[bad[0]]} then {s[bad[0] + 1]}",
                            f"{where}:{line} [{idx[0]}]")
    return curve


def write_unit_curve(path: str | Path, curve: UnitCurve, *, comments: list[str] | None = None) -> None:
    """Write ``curve`` in the CSV format ``read_unit_curve`` reads (swing index)."""
    cols = ["swing", "notches" if curve.kind == "notches" else "amplitude_rad"]
    if curve.load is not None:
        cols.append(f"load_{curve.load_unit or 'g'}")
    if curve.unit.size and any(curve.unit):
        cols.append("unit")
    lines = [f"# {c}" for c in (comments or [])]
    if curve.kind == "notches":
        lines.append(f"# notch_deg: {math.degrees(curve.notch):.12g}")
    lines.append(",".join(cols))
    for i in range(curve.swing.size):
        row = [str(int(curve.swing[i])), str(int(curve.value[i])) if curve.kind == "notches" else repr(float(curve.value[i]))]
        if curve.load is not None:
            row.append(repr(float(curve.load[i])))
        if "unit" in cols:
            row.append(str(curve.unit[i]))
        lines.append(",".join(row))
    Path(path).write_text("\n".join(lines) + "\n")
