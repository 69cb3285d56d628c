"""Starter scenes from a recording: what the record says, for ``escfit init``.

:func:`read_with_help` reads a file as a fit does (:func:`escfit.balance.family.read_data`) and,
when the reader cannot decide alone, tries the few ``[recording]`` options its message names
(the column that swings, degrees instead of radians); :func:`survey` measures what a starter
scene needs from the record: the period, the amplitude of every half swing about the centre,
starts and bounds of the viscous and Coulomb terms, and whether the samples' noise is
correlated.  :mod:`escfit.balance.starter_text` writes the scene from a :class:`Survey`.

Estimates (all from the record, none from a fit)
-----------------------------------------------
For a linear oscillator with viscous rate ``C`` and Coulomb term ``R`` (torque per inertia), the
amplitude after a half swing is exactly ``A' = r A - (1 + r) R / omega0**2`` with
``r = exp(-pi C / (2 omega_d))``, ``omega_d = sqrt(omega0**2 - C**2/4)``.  A straight-line fit of
``A'`` on ``A`` over successive half swings gives ``r`` and ``R``: the starts.  The bounds are
what the record allows: a viscous term alone explaining the whole decay is
``C_all = 2 ln(A_first / A_last) / (t_last - t_first)``, a Coulomb term alone
``R_all = omega0**2 (A_first - A_last) / (2 n)`` over ``n`` half swings; each upper bound is
three times that (neither can explain more than the decay seen, noise aside).  A gravity
pendulum's decay differs from the linear one by terms of order ``A**2 / 16``: enough for starts.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.errors import DataError
from .family import read_data
from ..analysis.recordings import UnitCurve
from ..analysis.recordings.timegrapher import TimegrapherRecording
from ..analysis.recordings.timeseries import TimeSeries
from ..analysis.recordings.still_column import TRACK_HINT

from .starter_decay import BOUND_FACTOR, decay_estimates

__all__ = ["Survey", "read_with_help", "survey", "decay_estimates", "BOUND_FACTOR"]

MAX_COLUMNS = 12  # columns tried when the reader cannot tell which one swings
AR1_EXCESS = 0.3  # lag-1 correlation above white noise's (after smoothing) that calls for AR(1) noise


_PAST_LAST = re.compile(r"has (only )?\d+ columns?|out of range|only \d+ columns?")


@dataclass
class Survey:
    """What a record says, for a starter scene.

    Attributes
    ----------
    kind : str
        The observation the scene will use: ``"waveform"`` (samples in time), ``"amplitude"``
        or ``"notches"`` (one reading per half swing), ``"timegrapher"``.
    path : str
        The file.
    format_words, columns_words : str
        How the file was read, in words.
    recording : dict
        ``[recording]`` options needed to read it (empty when detection sufficed), and why.
    period : float
        Measured period, s (``nan`` when the record has no times).
    amplitudes : ndarray
        Amplitude of each half swing about the centre, rad (readings' units for amplitude rows),
        the release first.
    times : ndarray or None
        Time of each of those, s.
    counts : dict
        Numbers to quote: samples, duration, turning points, rate, loads, units...
    noise_ar1 : bool
        Whether the samples' noise looks correlated from sample to sample.
    lag1 : float
        The lag-1 correlation of the samples about a smoothing, minus white noise's.
    notes : list of str
        What was found or assumed.
    data : object
        The recording object as read.
    """

    kind: str
    path: str
    format_words: str = ""
    columns_words: str = ""
    recording: dict = field(default_factory=dict)
    why: dict = field(default_factory=dict)
    period: float = math.nan
    amplitudes: np.ndarray = field(default_factory=lambda: np.zeros(0))
    times: np.ndarray | None = None
    counts: dict = field(default_factory=dict)
    noise_ar1: bool = False
    lag1: float = math.nan
    notes: list = field(default_factory=list)
    data: object = None
    tp: object = None
    quantity: str = "angle"  # what a sampled record measured: angle, angular_velocity, displacement
    counts_extra: dict = field(default_factory=dict)
    checks: list = field(default_factory=list)  # what the reader judged of the column and its unit (said aloud)
    window: dict = field(default_factory=dict)  # where the analysis took the free decay (:func:`window_found`)


# -- reading -------------------------------------------------------------------------------------
def read_with_help(path: str | Path, recording: dict | None = None, *, fmt: str | None = None,
                   notch_deg: float | None = None, reduced: dict | None = None) -> tuple[object, dict, dict]:
    """Read ``path`` as a fit does; where the reader cannot decide, try what its message names.

    Parameters
    ----------
    path
        The recording.
    recording
        ``[recording]`` options given by the user (scene-table keys), kept as given.
    fmt, notch_deg
        As :func:`escfit.balance.family.read_data`.
    reduced
        A dict that receives ``{"series": data, "turns": TurningPoints}`` when the record's
        turning points were found on the way (a sampled angle): the caller need not find them
        again.

    Returns
    -------
    tuple
        ``(data, table, why)``: the recording, the ``[recording]`` options that read it (the
        user's and those found here; empty when detection sufficed) and, per key found here,
        why it was needed.

    Raises
    ------
    DataError
        The reader's own message when nothing found here helps (it names the option to give).
    """
    table = {k: v for k, v in (recording or {}).items() if v is not None}
    why: dict[str, str] = {}
    for _ in range(4):
        try:
            data = read_data(path, recording=table or None, fmt=fmt, notch_deg=notch_deg)
        except DataError as exc:
            step = _help(path, table, exc, fmt)
            if step is None:
                raise
            key, value, reason = step
            table[key] = value
            why[key] = reason
            continue
        if isinstance(data, TimeSeries):
            data = _amplitude_rows(path, data, table, why, fmt, reduced)
            if data.meta.get("angle_unit_assumed") and "angle_unit" not in table:
                table["angle_unit"] = data.meta["angle_unit_assumed"]
                why["angle_unit"] = (f"the file names no unit for the angle: {data.meta['angle_unit_assumed']} "
                                     "assumed; CHECK it (deg, rad, or counts with counts_per_turn)")
        return data, table, why
    raise DataError("cannot read the record with any options tried; give [recording] options (escfit init -h)",
                    str(path))


_OTHER_QUANTITY = re.compile(r"column '([^']+)' looks like (angular velocity|displacement): set \[recording\] "
                             r"(velocity_column|displacement_column)(?:; (.*)\)\s*$)?")


def _help(path, table: dict, exc: DataError, fmt) -> tuple[str, object, str] | None:
    """One ``[recording]`` option the reader's message asks for and the record can settle."""
    message = str(exc)
    length = getattr(exc, "other_quantity", None)
    if length is not None and length[0] not in table:
        return length[0], length[1], (f"column {length[1]!r} holds a length ({length[2]}), not an angle: read as a "
                                      "displacement and fitted as measured")
    other = _OTHER_QUANTITY.search(message)
    if other and other.group(3) not in table:
        return other.group(3), other.group(1), (f"column {other.group(1)!r} holds the {other.group(2)}, not an angle: "
                                                "it is fitted as measured"
                                                + (f" ({other.group(4)})" if other.group(4) else ""))
    if "gives no unit: set [recording] velocity_unit" in message and "velocity_unit" not in table:
        return "velocity_unit", "rad/s", ("the file names no unit for the rate: rad/s assumed; CHECK it (deg/s, "
                                          "rpm, or V with scale)")
    if "gives no unit: set [recording] displacement_unit" in message and "displacement_unit" not in table:
        return "displacement_unit", "m", "the file names no unit for the displacement: m assumed; CHECK it (cm, mm)"
    if TRACK_HINT in message and "format" not in table and fmt is None:
        return "format", "tracker", (f"{message.split(';')[0]}, while x and y move: read as a track, the angle "
                                     "about the arc they trace")
    if "angle_column" in message and "angle_column" not in table:
        choice = getattr(exc, "channel_choice", None)
        if choice is not None and choice.chosen is not None:
            value = choice.positions.get(choice.chosen, choice.chosen) if choice.chosen.startswith("column ") \
                else choice.chosen
            key = choice.key_of(choice.chosen)
            if key in table:
                return None
            return key, value, (f"the file does not say which column is the signal: column {value} swings; "
                                f"{choice.note()}")
        if choice is not None and max(choice.scores.values(), default=0.0) > 0.0:
            raise DataError(choice.refusal(), exc.where) from None  # oscillating columns, none clearly the decay
        found = _swinging_column(path, table, fmt, amplitudes_only=choice is not None)
        if found is not None:
            return "angle_column", found[0], found[1]
    if (_TOO_FEW.search(message) or _SORTED_TABLE.search(message)) and "readings" not in table:
        return _few_rows(path, table, fmt, exc)
    if "angle_unit" in message and '"deg"' in message and "no unit given" in message and "angle_unit" not in table:
        return "angle_unit", "deg", ("the readings span more than a turn if read as radians; degrees, as the reader "
                                     "suggested")
    return None


_TOO_FEW = re.compile(r"only \d+ samples; a decay needs")
_SORTED_TABLE = re.compile(r"sorted by the reading, a table of amplitudes\?")
READINGS_HINT = "--readings amplitudes ([recording] readings = \"amplitudes\")"


def _few_rows(path, table: dict, fmt, exc: DataError) -> tuple[str, object, str]:
    """Too few rows for samples in time (or rows the reader found sorted by their readings):
    turning points if the rows are (:func:`_table_reading`), else refused in one line naming the
    option that reads them as turning points."""
    try:
        data = read_data(path, recording={**table, "readings": "amplitudes"}, fmt=fmt)
    except DataError:
        data = None
    if isinstance(data, TimeSeries):
        try:
            key, value, reason = _table_reading(data, exc)
        except DataError as err:
            if err is not exc:
                raise
        else:
            return key, value, f"{reason}: read as amplitudes, as {READINGS_HINT} asks"
    raise DataError(f"{exc.message}; if each row is one amplitude (a peak per period or per half swing) give "
                    f"{READINGS_HINT}", exc.where) from None


def _table_reading(series: TimeSeries, exc: DataError) -> tuple[str, object, str]:
    """``("readings", "amplitudes", why)`` when the rows are turning points
    (:func:`escfit.analysis.recordings.row_kind.judge_rows`); else ``exc`` raised again, in one
    line naming both readings when the rows could be either, or what a table of one sign cannot say."""
    from ..analysis.recordings.row_kind import judge_rows

    kind = judge_rows(series.time, series.theta)
    if kind.verdict == "turning points" and kind.per_half_swing:
        how = ("magnitudes read on each side, one per half swing (alternate rows differ: the scale's zero is off the "
               "centre)" if kind.one_sided else "turning points, one per half swing on alternate sides")
        return "readings", "amplitudes", f"each row is one of the swing's {how}: {kind.evidence()}"
    if kind.verdict == "turning points":
        step = kind.step
        measured, small = _row_periods(series.time, np.abs(series.theta))
        pendulum = (f" ({4 * math.pi / small:.5g} for a gravity pendulum: its small-swing value at these amplitudes)"
                    if series.quantity == "angle" and math.isfinite(small) else "")
        raise DataError(f"the rows look like turning points of one sign ({kind.evidence()}), but they cannot say "
                        f"whether each is a half swing (magnitudes read each side: period {2 * step:.4g} s) or a "
                        f"period (the peaks of one side: period {step:.4g} s): give {READINGS_HINT} and, for peaks "
                        f"a period apart, set omega0 = {4 * math.pi / measured:.5g}{pendulum} in the scene",
                        exc.where) from None
    if kind.verdict == "ambiguous":
        raise DataError(f"{exc.message}; the rows could be turning points ({'; '.join(kind.reasons)}; "
                        f"{kind.evidence()}): give {READINGS_HINT} if each row is one, or --readings samples "
                        "([recording] readings = \"samples\") if they are samples in time", exc.where) from None
    raise exc


def _swinging_column(path, table: dict, fmt, *, amplitudes_only: bool = False) -> tuple[int, str] | None:
    """The 1-based column that holds a decaying swing (or amplitude readings), and why.

    Tried column by column where the reader could not score the columns' shapes (a MATLAB file);
    ``amplitudes_only`` where it did and found no free decay: only a column of amplitude readings
    (one per half swing) is looked for then."""
    best = None
    for col in range(1, MAX_COLUMNS + 1):
        if table.get("time_column") == col:
            continue
        trial = {**table, "angle_column": col}
        data = None
        for extra in ({}, {"angle_unit": "deg"}):
            try:
                data = read_data(path, recording={**trial, **extra}, fmt=fmt)
                break
            except DataError as exc:
                if _PAST_LAST.search(str(exc)):
                    data = "end"
                    break
                if "not an angle unit" in str(exc) or "labelled" in str(exc):
                    break  # a column whose label says another quantity is not read as degrees
        if data == "end":
            break
        if not isinstance(data, TimeSeries):
            continue
        score, what = _swing_score(data)
        if amplitudes_only and score != 0.5:
            continue
        if score > 0 and (best is None or score > best[0]):
            best = (score, col, what)
    if best is None:
        return None
    return best[1], f"the file does not say which column is the angle: column {best[1]} {best[2]}"


def _swing_score(series: TimeSeries) -> tuple[float, str]:
    """How much a column looks like a recorded free decay: turning points found, else amplitude rows."""
    from ..analysis.recordings.row_kind import judge_rows
    from ..analysis.recordings.turning_points import reduce_series

    try:
        tp = reduce_series(series, strict=False, user_window=series.window)
    except DataError:
        kind = judge_rows(series.time, series.theta)
        return (0.5, "holds one turning point per row") if kind.verdict == "turning points" else (0.0, "")
    return 1.0 + len(tp.theta), f"swings ({len(tp.theta)} turning points)"


def _amplitude_rows(path, series: TimeSeries, table: dict, why: dict, fmt, reduced: dict | None = None) -> TimeSeries:
    """Switch to ``readings = "amplitudes"`` when the rows are turning points, one per half swing
    (:func:`_table_reading`); samples whose turning points are found are kept as samples."""
    from ..analysis.recordings.turning_points import reduce_series

    if "readings" in table:
        return series
    try:
        tp = reduce_series(series, strict=False, user_window=series.window)
        if reduced is not None:
            reduced.update(series=series, turns=tp)
        return series
    except DataError as exc:
        from ..analysis.recordings.modes import TwoModes

        if isinstance(exc, TwoModes) and "mode" not in table:  # two modes: the lowest is fitted unless the user says
            modes = exc.modes
            table["mode"] = 1
            why["mode"] = (f"the record rings in two modes (periods {modes[0]:.4g} s and {modes[1]:.4g} s): the "
                           "slower, the lowest, is fitted and the other filtered out; mode = 2 fits the faster")
            return _amplitude_rows(path, read_data(path, recording=table, fmt=fmt), table, why, fmt, reduced)
        key, value, reason = _table_reading(series, exc)
    table[key] = value
    why[key] = f"{reason}: read as amplitudes, as {READINGS_HINT} asks"
    return series


# -- what the record says -------------------------------------------------------------------------
def survey(path: str | Path, *, restoring: str = "spring", recording: dict | None = None, fmt: str | None = None,
           notch_deg: float | None = None) -> Survey:
    """Read ``path`` and measure what a starter scene needs (see the module docstring).

    Raises
    ------
    DataError
        An unreadable record (the reader's message), a record with no swing in it, or a kind
        of recording a starter scene is not written for (pulse trains).
    """
    reduced: dict = {}
    data, table, why = read_with_help(path, recording, fmt=fmt, notch_deg=notch_deg, reduced=reduced)
    s = Survey(kind="", path=str(path), recording=table, why=why, data=data)
    if isinstance(data, TimeSeries):
        if table.get("readings") == "amplitudes":
            _survey_amplitude_rows(s, data, restoring)
        else:
            _survey_samples(s, data, restoring, reduced.get("turns") if reduced.get("series") is data else None)
    elif isinstance(data, UnitCurve):
        _survey_unit_curve(s, data)
    elif isinstance(data, TimegrapherRecording):
        _survey_timegrapher(s, data)
    else:
        raise DataError(f"escfit init writes starter scenes for sampled angles, amplitude tables and timegrapher "
                        f"logs; this file is a {type(data).__name__} (photo-cell pulses): start from "
                        "datasets/recordings/pulses_scene.toml (escfit examples DIR copies it)", str(path))
    return s


def _survey_samples(s: Survey, series: TimeSeries, restoring: str, turns=None) -> None:
    """The survey of a sampled record; ``turns``: its turning points when already found."""
    from .problems.period import check_pendulum_period, implied_omega0, measured_period
    from .problems.release import swing_unit_warnings
    from ..analysis.recordings.turning_points import reduce_series

    if series.quantity == "angular_velocity":  # the angle's turning points are the rate's zeros
        from ..analysis.recordings.rate import reduce_rate

        rate = reduce_rate(series, user_window=series.window)
        tp = rate.turns
        s.counts_extra = {"rate zero": rate.offset, "rate zero se": rate.offset_stderr}
        notes = [f"warning: {w}" for w in tp.warnings if w not in rate.notes] + rate.notes
    else:
        tp = turns if turns is not None else reduce_series(series, strict=False, user_window=series.window)
        notes = [f"warning: {w}" for w in tp.warnings] + list(tp.notes)
    s.quantity = series.quantity
    s.checks = [n for n in str(series.meta.get("analysis", "")).split("; ") if n]  # column and unit judged
    s.checks += [f"warning: {w}" for w in swing_unit_warnings(series, tp, restoring)]  # as the fit will judge it
    s.kind, s.tp = "waveform", tp
    check_pendulum_period("spring" if series.quantity == "displacement" else restoring, measured_period(tp, series.source))
    s.period = float(tp.period)
    times = np.concatenate([[tp.release_time], np.asarray(tp.time, float)])
    theta = np.concatenate([[tp.release_theta], np.asarray(tp.theta, float)])
    s.amplitudes = np.abs(theta - tp.centre(times))
    s.times = times
    t = np.asarray(series.time, float)
    s.counts = {"samples": int(t.size), "duration": float(t[-1] - t[0]), "turning points": int(len(tp.theta)),
                "rate": float((t.size - 1) / (t[-1] - t[0])) if t.size > 1 and t[-1] > t[0] else math.nan,
                "centre": float(tp.offset), "centre rate": float(tp.offset_rate),
                # a displacement is fitted as a linear oscillator (the scene written has no pendulum law)
                "omega0": implied_omega0("spring" if series.quantity == "displacement" else restoring,
                                         measured_period(tp, series.source))}
    s.counts.update(s.counts_extra)
    s.notes = notes
    s.format_words = series.meta.get("source_format", "escfit time series (time_s, theta)")
    s.columns_words = _columns_words(series.meta)
    s.lag1 = _excess_lag1(np.asarray(series.theta, float), s.period / np.median(np.diff(t)))
    s.noise_ar1 = bool(s.lag1 > AR1_EXCESS)
    s.window = window_found(series, tp)


def window_found(series: TimeSeries, tp) -> dict:
    """Where the analysis took the free decay, in s after the file's first sample.

    Keys: ``first`` and ``last`` (the record's first and last sample), ``reference`` (the
    reference instant), ``held`` (the held angle, rad, when the record is flat over the quarter
    of a period before the reference: a release from a hold; else ``None``), ``left_out`` (whether
    more than a period before the reference was not taken as free), ``stop`` (where motion
    stopped or faded, ``nan`` when the record ends in motion), ``sunk`` (whether that stop is where
    the swing sank into a noise floor before it came to rest: the record after it is noise) and
    ``last_turn``.
    """
    t, x = np.asarray(series.time, float), np.asarray(series.theta, float)
    ref, period = float(tp.release_time), float(tp.period)
    # a quarter period: over it a swinging oscillator moves by its whole amplitude, a held one not at
    # all (over a tenth of a period a noisy swing, moving a fifth of its amplitude, looked held)
    before = (t >= ref - 0.25 * period) & (t <= ref)
    amplitude = float(np.max(np.abs(np.asarray(tp.theta, float) - tp.offset), initial=0.0))
    band = max(4.0 * float(tp.noise) if math.isfinite(tp.noise) else 0.0, 1e-3 * amplitude)
    held = None
    if np.count_nonzero(before) >= 3 and t[0] <= ref - 0.25 * period:
        level = float(np.median(x[before]))
        if np.all(np.abs(x[before] - level) <= band):
            held = float(tp.release_theta)
    zero = float(getattr(tp, "origin", 0.0))  # the keys count from the file's first sample
    return {"first": float(t[0]) - zero, "last": float(t[-1]) - zero, "reference": ref - zero, "held": held,
            "left_out": bool(ref - t[0] > period), "stop": float(tp.stop_time) - zero, "period": period,
            "sunk": bool(math.isfinite(float(getattr(tp, "noise_floor", math.nan)))),
            "pushed": bool(getattr(tp, "pushed_after", False)),
            "last_turn": (float(tp.time[-1]) if len(tp.time) else ref) - zero,
            "drive_off": _drive_off(series, zero)}


def _drive_off(series, zero: float) -> tuple[float, str] | None:
    """Where a drive logged beside the signal was switched off (s after the first sample) and its
    column, when the reader cut the record there (:mod:`escfit.analysis.switch_off`); else None."""
    at = series.meta.get("drive_off")
    return None if at is None else (float(at) - zero, str(series.meta.get("drive_column", "")))


def _survey_amplitude_rows(s: Survey, series: TimeSeries, restoring: str = "spring") -> None:
    """The survey of rows that are turning points: the period from their times (a straight line of
    time on the half-swing count, a missing row counted), omega0 from it (for a pendulum the
    small-swing value: each half swing's time lengthened by its amplitude, exactly), the
    amplitudes about the centre the rows alternate about."""
    from ..analysis.recordings.row_kind import judge_rows

    t = np.asarray(series.time, float)
    v = np.asarray(series.theta, float)
    kind = judge_rows(t, v)
    s.kind = "amplitude"
    s.amplitudes = np.abs(v - kind.centre)
    s.times = t - t[0]
    s.period, omega0 = math.nan, math.nan
    if t.size > 2:
        s.period, small = _row_periods(t, s.amplitudes)
        omega0 = 2 * math.pi / s.period
        if restoring == "pendulum" and series.quantity == "angle" and math.isfinite(small) and small > 0:
            omega0 = 2 * math.pi / small
            s.notes.append(f"small-swing period {small:.5g} s: the measured {s.period:.5g} s with each half "
                           "swing shortened by its amplitude as a gravity pendulum's is (complete elliptic "
                           "integral)")
    s.counts = {"readings": int(t.size), "duration": float(t[-1] - t[0]), "omega0": omega0}
    s.format_words = series.meta.get("source_format", "table")
    s.columns_words = _columns_words(series.meta)
    if math.isfinite(s.period) and kind.one_sided and kind.per_half_swing is None:
        # magnitudes read each side, or the peaks of one side: the rows cannot say which
        s.notes.append(f"the readings have one sign: taken as one per half swing (period {s.period:.4g} s, twice their "
                       f"spacing); if they are one per period (the peaks on one side), the period is "
                       f"{s.period / 2:.4g} s: set omega0 = {2 * omega0:.5g}")
    _check_table_angle(s, series, restoring)


def _row_periods(time: np.ndarray, amplitudes: np.ndarray) -> tuple[float, float]:
    """Period (s) of rows one per half swing, measured (a straight line of row time on the half-swing
    count, a missing row counted) and a gravity pendulum's small-swing value (each half swing's time
    divided by :func:`~escfit.analysis.pendulum_unit.pendulum_period_factor` of its amplitude, rad)."""
    from ..analysis.pendulum_unit import pendulum_period_factor
    from ..analysis.recordings.row_kind import row_steps

    t = np.asarray(time, float)
    a = np.asarray(amplitudes, float)
    if t.size < 3:
        return math.nan, math.nan
    whole = row_steps(t)
    measured = 2.0 * float(np.polyfit(np.concatenate([[0], np.cumsum(whole)]), t, 1)[0])
    factor = pendulum_period_factor(0.5 * (a[1:] + a[:-1]))
    if not np.all(np.isfinite(factor)):
        return measured, math.nan
    small = 2.0 * float(np.polyfit(np.concatenate([[0.0], np.cumsum(whole * factor)]), t, 1)[0])
    return measured, small


def _check_table_angle(s: Survey, series: TimeSeries, restoring: str) -> None:
    """A table's largest amplitude held against its angle unit, as for samples
    (:func:`escfit.analysis.quantity.swing_unit_check`)."""
    from .problems.release import table_unit_warnings

    s.checks += [f"warning: {w}" for w in table_unit_warnings(series, float(np.max(s.amplitudes)), restoring)]


def _survey_unit_curve(s: Survey, curve: UnitCurve) -> None:
    groups = curve.groups()
    (unit, load), rows = groups[0]
    s.kind = curve.kind
    amp = curve.amplitude_rad if curve.kind == "amplitude" else (curve.value + 0.5) * curve.notch
    s.amplitudes = np.asarray(amp, float)[rows]
    s.counts = {"readings": int(curve.swing.size), "curves": len(groups), "first swing": int(curve.swing[rows][0]),
                "swing step": int(np.median(np.diff(curve.swing[rows]))) if rows.size > 1 else 1,
                "units": sorted(set(map(str, curve.unit)) - {""}),
                "loads": [] if curve.load is None else sorted({float(x) for x in curve.load if math.isfinite(x)}),
                "load unit": curve.load_unit, "notch": float(curve.notch)}
    if curve.time is not None and rows.size > 2:
        ts, sw = np.asarray(curve.time, float)[rows], np.asarray(curve.swing, float)[rows]
        half = float(np.polyfit(sw, ts, 1)[0])
        s.period, s.times = 2.0 * half, ts - ts[0]
    s.counts["omega0"] = 2 * math.pi / s.period if math.isfinite(s.period) else math.nan
    s.format_words = "escfit unit curve (one reading per half swing)"
    s.columns_words = ("notch counts" if curve.kind == "notches" else "amplitudes") + \
        (", times" if curve.time is not None else ", no times") + (", loads" if curve.load is not None else "")


def _survey_timegrapher(s: Survey, rec: TimegrapherRecording) -> None:
    s.kind = "timegrapher"
    beats = np.asarray(rec.beat_time, float)
    if beats.size > 3:
        s.period = float(2.0 * np.median(np.diff(beats)))
        how = "beat times"
    else:
        rate = np.asarray(rec.rate, float) if rec.rate is not None else np.zeros(0)
        rate = rate[np.isfinite(rate)]
        nominal = 7200.0 / rec.bph
        s.period = nominal / (1.0 + float(np.median(rate)) / 86400.0) if rate.size else nominal
        how = "the rate shown" if rate.size else "the nominal beat rate"
    amp = np.asarray(rec.amp_deg, float)
    s.amplitudes = np.radians(amp[np.isfinite(amp)])
    s.times = np.asarray(rec.amp_time, float)[np.isfinite(amp)]
    s.counts = {"beats": int(beats.size), "amplitude readings": int(s.amplitudes.size), "bph": int(rec.bph),
                "lift angle": float(rec.lift_angle), "period from": how, "omega0": 2 * math.pi / s.period,
                "format": rec.format}
    s.format_words = {"tg-json": "tg-timer JSON dump", "csv": "timegrapher per-beat CSV",
                      "tg-applog": "timegrapher app log"}.get(rec.format, rec.format)
    s.columns_words = f"{beats.size} beats, {s.amplitudes.size} amplitude readings, {rec.bph} bph, lift angle " \
                      f"{math.degrees(rec.lift_angle):.4g} deg"


def _columns_words(meta: dict) -> str:
    parts = []
    if meta.get("time_column"):
        parts.append(f"time: {meta['time_column']}")
    if meta.get("angle_column"):
        unit = meta.get("angle_unit", "")
        assumed = " (assumed)" if meta.get("angle_unit_assumed") else ""
        parts.append(f"angle: {meta['angle_column']}" + (f" in {unit}{assumed}" if unit else ""))
    for key, what in (("velocity", "angular velocity"), ("displacement", "displacement")):
        if meta.get(f"{key}_column"):
            unit = meta.get(f"{key}_unit", "")
            parts.append(f"{what}: {meta[f'{key}_column']}" + (f" in {unit}" if unit else ""))
    return "; ".join(parts) or "time_s and theta columns"


# -- estimates -----------------------------------------------------------------------------------
def _excess_lag1(x: np.ndarray, period_samples: float) -> float:
    """Lag-1 correlation of the samples about their smoothing, minus what white noise would give."""
    from ..core.filters import savgol_coeffs
    from ..analysis.recordings.extrema import smooth

    if x.size < 50 or not math.isfinite(period_samples):
        return math.nan
    r = x - smooth(x, period_samples)
    r = r - r.mean()
    den = float(np.dot(r, r))
    if den <= 0:
        return math.nan
    measured = float(np.dot(r[1:], r[:-1]) / den)
    n = max(5, int(round(0.1 * period_samples)) | 1)  # the smoothing's window (as extrema.smooth)
    if n > x.size:
        return measured
    g = -savgol_coeffs(n, 2)
    g[n // 2] += 1.0  # residual filter: identity minus the smoother
    white = float(np.dot(g[1:], g[:-1]) / np.dot(g, g))
    return measured - white

