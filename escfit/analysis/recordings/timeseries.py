"""Free-decay time series: the balance angle sampled in time, reduced to turning points.

CSV format
----------
Columns ``time_s`` and one angle column ``theta_rad``, ``theta_deg`` or ``theta_<unit>`` (any
angle unit pint knows), sampled at increasing times (a logger's faulty stamps are repaired by
the time-base stage, :mod:`escfit.analysis.timebase`, with notes).  The record may start with the balance
held and then released, at a turning point or mid-swing, and may end at rest; the analysis
finds which.  A ``# release_s: <t>`` metadata line fixes the release instant instead.  The
samples may carry noise, quantisation (an encoder's steps), a zero offset and its drift.

Reduction
---------
The analysis of a decay lives in :mod:`escfit.analysis.recordings.turning_points`:
:func:`~escfit.analysis.recordings.turning_points.reduce_series` is the entry point other code uses
(re-exported here, as is its earlier name ``turning_points``).  :func:`timeseries_to_unit_curve`
turns its result into amplitude readings per half swing for the unit-curve fit.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ...core.errors import DataError
from ...core.units import common_factor, registry
from ...core.csvtable import read_numbers, read_table
from .rawsteps import notes_of, repaired_times, warnings_of
from .series import TimeSeries
from .sniff import canonical_header, did_you_mean, refuse_unless_csv, release_from_meta
from .turning_points import TurningPoints, reduce_series, turning_points
from .unit_curve import UnitCurve

__all__ = ["TimeSeries", "TurningPoints", "read_timeseries", "write_timeseries", "reduce_series", "turning_points",
           "timeseries_to_unit_curve"]


def read_timeseries(path: str | Path) -> TimeSeries:
    """Read a time-series CSV (see the module docstring).

    Raises
    ------
    DataError
        JSON, binary or empty files, missing or ambiguous columns, unknown or non-angle
        units, text or non-finite numbers, times the time-base stage cannot repair.
    """
    refuse_unless_csv(path, "a time series")
    numbers = read_numbers(path)  # a long record of plain numbers: one numpy pass
    t = canonical_header(numbers if numbers is not None else read_table(path))
    where = t.path
    angle = [c for c in t.header if c.startswith("theta_")]
    if "time_s" not in t.header or len(angle) != 1:
        raise DataError(f"need columns time_s and one angle column theta_rad or theta_deg, header has {t.header}"
                        f"{did_you_mean(t.header)}", where)
    unknown = [c for c in t.header if c not in ("time_s", angle[0])]
    if unknown:
        raise DataError(f"unknown column(s) {unknown}{did_you_mean(unknown)}; a time series has time_s and "
                        "theta_rad|theta_deg", where)
    unit = angle[0][len("theta_"):]
    factor = common_factor(unit, "angle")
    if factor is None:
        try:
            q = registry().Quantity(1.0, unit)
        except Exception:
            raise DataError(f"unknown angle unit {unit!r} in column {angle[0]!r}", where) from None
        if not q.dimensionless:
            raise DataError(f"column {angle[0]!r}: {unit!r} is not an angle unit", where)
        factor = float(q.to("rad").magnitude)
    if numbers is not None:
        time, theta = t.column("time_s"), t.column(angle[0])
        if time.size >= 20 and np.all(np.isfinite(theta)) and np.all(np.diff(time) > 0) \
                and np.isfinite(time[0]) and np.isfinite(time[-1]):
            got = _timed(time.copy(), theta * factor, dict(t.meta), lambda i: f"{where} row {i + 1}", where)
            if got is not None:
                return TimeSeries(*got[:2], release_from_meta(t.meta, where), where, t.sha256, got[2])
        t = canonical_header(read_table(path))  # its messages name the line and the cell
    time = np.array(t.floats("time_s"))
    theta = np.array(t.floats(angle[0])) * factor
    time, theta, meta = _timed(time, theta, dict(t.meta), lambda i: f"{where}:{t.lines[i]} [time_s]", where,
                               refuse=True)
    release = release_from_meta(t.meta, where)
    if time.size < 20:
        raise DataError(f"only {time.size} samples; a decay needs many samples per period", where)
    return TimeSeries(time, theta, release, where, t.sha256, meta)


def _timed(time: np.ndarray, theta: np.ndarray, meta: dict, where_of_row, where: str, *, refuse: bool = False):
    """``(time, theta, meta)`` through the time-base stage, its notes and warnings in ``meta``;
    ``None`` where the stage refuses and ``refuse`` is off (the strict reader then says why)."""
    notes, warnings = notes_of(meta), warnings_of(meta)
    try:
        time, theta = repaired_times(time, theta, where_of_row, notes, warnings, where)
    except DataError:
        if refuse:
            raise
        return None
    for key, sentences in (("notes", notes), ("warnings", warnings)):
        if sentences:
            meta[key] = "; ".join(n.replace(";", ",") for n in sentences)
    return time, theta, meta


def write_timeseries(path: str | Path, series: TimeSeries, *, unit: str = "rad", decimals: int = 6,
                     comments: list[str] | None = None) -> None:
    """Write ``series`` in the CSV format :func:`read_timeseries` reads.

    Parameters
    ----------
    unit
        ``"rad"`` or ``"deg"`` for the angle column.
    decimals
        Decimals of the angle (times are written to 1 us).
    comments
        Comment lines; the series' metadata follows as ``# key: value`` lines.
    """
    if unit not in ("rad", "deg"):
        raise DataError(f"unit must be 'rad' or 'deg', got {unit!r}", str(path))
    values = series.theta if unit == "rad" else np.degrees(series.theta)
    lines = [f"# {c}" for c in (comments or [])]
    lines += [f"# {k}: {v}" for k, v in series.meta.items() if " " not in k and k != "release_s"]
    if math.isfinite(series.release_s):
        lines.append(f"# release_s: {series.release_s!r}")
    lines.append(f"time_s,theta_{unit}")
    lines += [f"{t:.6f},{v:.{decimals}f}" for t, v in zip(series.time, values)]
    Path(path).write_text("\n".join(lines) + "\n")


def timeseries_to_unit_curve(series: "TimeSeries", *, window: float | None = None, degree: int = 4,
                             remove_offset: bool = True, release_theta: float | None = None,
                             tolerance: float = 0.05, strict: bool = True) -> UnitCurve:
    """Amplitudes of the turning points of a decay, as a unit curve.

    Parameters
    ----------
    series
        The samples.
    window, degree, strict
        See :func:`~escfit.analysis.recordings.turning_points.reduce_series`.
    remove_offset
        Subtract the estimated centre ``offset + offset_rate*(t - release_time)`` before
        taking ``|theta|``.
    release_theta
        The scene's release angle (rad); when given, a record whose reference angle (the
        release, or the first turning point; centre removed) differs in magnitude by more
        than ``tolerance`` (relative) is refused as belonging to another scene.  Only
        magnitudes are compared: a scene may release at ``+theta0`` while the record's
        reference turning point is negative; the signed value from the record is then the
        one that matters (``release_theta_rad`` in the metadata, and a note).
    tolerance
        Relative tolerance of that check.

    Returns
    -------
    UnitCurve
        ``kind = "amplitude"`` readings (rad) per half swing (1, 2, ... after the reference)
        with their times (s, the series' clock).  ``meta`` (strings) adds ``period_s``,
        ``offset_rad``, ``offset_rate_rad_per_s``, ``offset_removed``, ``release_time_s``,
        ``release_theta_rad`` (signed, offset not removed), ``stop_time_s`` and
        ``rest_theta_rad`` (``nan`` when the record ends in motion) and ``notes`` (joined by
        ``"; "``).

    Raises
    ------
    DataError
        When the record does not match ``release_theta`` or
        :func:`~escfit.analysis.recordings.turning_points.reduce_series` refuses it.
    """
    tp = reduce_series(series, window=window, degree=degree, strict=strict)
    notes = list(tp.notes)
    start = tp.release_theta - tp.offset
    if release_theta is not None:
        if abs(abs(start) - abs(release_theta)) > tolerance * abs(release_theta) + 1e-9:
            raise DataError(f"the series starts at {start:.4g} rad but the scene releases the balance at "
                            f"{release_theta:.4g} rad (theta0); the start is the release or the first turning point, "
                            "centre removed", series.source)
        if start * release_theta < 0:
            notes.append(f"the record's reference angle {start:+.4g} rad is on the other side of the centre than the "
                         f"scene's theta0 = {release_theta:+.4g} rad; amplitudes are compared")
    meta = dict(series.meta)
    meta.update(derived_from="time series (local kinked quartic fits at the turning points)",
                period_s=repr(tp.period), offset_rad=repr(tp.offset), offset_rate_rad_per_s=repr(tp.offset_rate),
                offset_removed=str(bool(remove_offset)), release_time_s=repr(tp.release_time),
                release_theta_rad=repr(tp.release_theta), stop_time_s=repr(tp.stop_time),
                rest_theta_rad=repr(tp.rest_theta), notes="; ".join(notes))
    centre = tp.centre(tp.time) if remove_offset else 0.0
    amp = np.abs(tp.theta - centre)
    return UnitCurve(tp.swing, amp, "amplitude", unit=np.full(amp.size, "", dtype=str), time=tp.time,
                     source=series.source, sha256=series.sha256, meta=meta)
