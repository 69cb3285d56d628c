"""The steps every raw-recording reader shares: checking, re-timing and windowing samples.

:mod:`~escfit.balance.recordings.rawtable` and :mod:`~escfit.balance.recordings.matfile` hand their
converted columns (time s, angle rad) to :func:`build_series`, which re-times stamps written in
bursts (:func:`regular_times`), applies the ``start``/``stop`` window and checks what is left.
The entry point that picks the reader is :func:`~escfit.balance.recordings.rawseries.read_raw_series`
(which re-exports these names); this module imports neither reader.

Metadata convention
-------------------
Readers fill :attr:`TimeSeries.meta` with strings only (so it survives
:func:`~escfit.balance.recordings.timeseries.write_timeseries` and HDF5 attributes):
``source_format``, ``time_column``, ``angle_column``, ``angle_unit``, ``window`` and ``notes``,
one string of sentences joined by ``"; "`` (:func:`notes_of` splits it), next to the file's own
``# key: value`` metadata (a file key that collides is kept as ``file_<key>``).
"""

from __future__ import annotations

import math
from typing import Callable, Mapping

import numpy as np

from ...core.errors import DataError, SceneError
from .recording_spec import RecordingSpec, parse_option, parse_seconds
from .series import TimeSeries
from .window import resolve_window

__all__ = ["build_series", "regular_times", "notes_of", "merge_file_meta", "file_options", "unwrap_angles",
           "FILE_OPTIONS", "MIN_SAMPLES"]

MIN_SAMPLES = 20
MIN_AMPLITUDE_ROWS = 4  # rows of amplitude readings: more than a viscous and Coulomb fit's parameters
FILE_OPTIONS = {"rate": "sample_rate", "sample_rate": "sample_rate", "samplerate": "sample_rate",
                "sampling_rate": "sample_rate", "sample_rate_hz": "sample_rate", "rate_hz": "sample_rate",
                "fs": "sample_rate", "dt": "dt", "dt_s": "dt", "sample_interval": "dt", "units": "angle_unit",
                "unit": "angle_unit", "angle_unit": "angle_unit", "counts_per_turn": "counts_per_turn",
                "scale": "scale"}


def notes_of(meta: Mapping) -> list[str]:
    """The reader's notes of a series' ``meta`` as a list of sentences."""
    text = meta.get("notes", "")
    return [s for s in text.split("; ") if s] if isinstance(text, str) else list(text)


def regular_times(time: np.ndarray, where_of_row: Callable[[int], str], notes: list[str]) -> np.ndarray:
    """Check that ``time`` (s) increases; re-time stamps written in bursts.

    A logger may stamp rows in bursts: the same stamp repeated over many rows while the
    sensor samples uniformly.  When at least half the steps are zero, none negative and
    there are at least three distinct stamps, the times are replaced by a least-squares line
    of stamp on row number, accepted when no stamp is further from it than the longest burst
    spans (plus one sample).  A note gives the burst length and the fitted rate.

    Raises
    ------
    DataError
        Decreasing stamps (naming the row and both values), a repeated stamp that is not a
        burst pattern, or bursts that do not follow a line.
    """
    step = np.diff(time)
    back = np.flatnonzero(step < 0)
    if back.size:
        i = int(back[0]) + 1
        raise DataError(f"time goes backwards: {float(time[i - 1])!r} then {float(time[i])!r}", where_of_row(i))
    same = step == 0
    if not same.any():
        return time
    starts = np.flatnonzero(np.r_[True, ~same])
    runs = np.diff(np.r_[starts, time.size])
    if same.mean() < 0.5 or starts.size < 3:
        i = int(np.flatnonzero(same)[0]) + 1
        tail = i > 1 and bool(np.all(time[i:] == time[i]))
        hint = (f" (the time stops there for the last {time.size - i + 1} rows: a logger's stalled clock? set "
                f"[recording] stop = \"{float(time[i - 2] - time[0]):g} s\" to read the rows before it)") if tail else ""
        raise DataError(f"time {float(time[i])!r} repeats the previous row's; times must increase{hint}",
                        where_of_row(i))
    rows = np.arange(time.size, dtype=float)
    slope, intercept = np.polyfit(rows, time, 1)
    fitted = intercept + slope * rows
    worst = int(np.argmax(np.abs(time - fitted)))
    if not slope > 0 or abs(time[worst] - fitted[worst]) > (runs.max() + 1) * slope:
        raise DataError(f"time stamps repeat in bursts but do not follow a straight line (stamp {float(time[worst])!r} "
                        f"is {abs(time[worst] - fitted[worst]):.3g} s from it)", where_of_row(worst))
    notes.append(f"time stamps repeat in bursts of ~{np.median(runs):.0f} rows, re-timed by a line fit of stamp "
                 f"on row number: {1.0 / slope:.6g} Hz")
    return fitted


def build_series(time: np.ndarray, theta: np.ndarray, spec: RecordingSpec, *, source: str, sha256: str,
                 meta: dict[str, str], notes: list[str], where_of_row: Callable[[int], str],
                 release_s: float = math.nan) -> TimeSeries:
    """Check and window converted samples (time s, theta rad) and wrap them in a TimeSeries.

    Non-finite values, decreasing or repeated times are refused (burst stamps re-timed, see
    :func:`regular_times`); the window ``start <= t <= stop`` is applied and must keep
    :data:`MIN_SAMPLES` samples.  ``meta`` gets ``window`` and ``notes``.  The ``start``, ``stop`` and
    ``release`` keys are read on the file's clock from its first row (the clock rule of
    :mod:`~escfit.balance.recordings.window`); the series carries them (``window``) for the analysis.
    """
    for name, values in (("time", time), ("angle", theta)):
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise DataError(f"{name} value {float(values[bad[0]])!r} is not a finite number", where_of_row(int(bad[0])))
    if np.size(time) < 2:
        raise DataError(f"only {np.size(time)} samples; a decay needs at least {MIN_SAMPLES}", source)
    time, theta = np.asarray(time, dtype=float), np.asarray(theta, dtype=float)
    rows = np.arange(time.size)
    # the keys are read on the clock as the file gives it (its first row the origin), before any re-timing
    window, clock_notes = resolve_window(spec, time, source)
    notes += clock_notes
    lo = -math.inf if window.start is None else window.start
    hi = math.inf if window.stop is None else window.stop
    cut = window.start is not None or window.stop is not None
    if cut and np.any(np.diff(time) <= 0.0):
        # rows stamped outside the window go before the stamps are checked (a logger's clock that
        # stalls after the decay is cut by `stop`); the window is applied again to the times read
        inside = (time >= lo) & (time <= hi)
        if inside.sum() >= 2:
            time, theta, rows = time[inside], theta[inside], rows[inside]
    time, theta, rows = _drop_repeated_rows(time, theta, rows, notes, where_of_row)
    time = regular_times(time, lambda i: where_of_row(int(rows[i])), notes)
    if meta.get("angle_unit_assumed") and np.ptp(theta) > 2.0 * math.pi:
        raise DataError(f"the angles span {np.ptp(theta):.4g} with no unit given (rad assumed): more than a turn, so "
                        "not radians of a swinging balance; if they are degrees set [recording] angle_unit = \"deg\" "
                        "(or --angle-unit deg)", source)
    if spec.readings == "samples" and spec.quantity == "angle":
        theta = unwrap_angles(theta, notes)
    if cut:
        keep = (time >= lo) & (time <= hi)
        shown = f"{'' if window.start is None else f'{window.after_first(lo):g} s <= '}t" \
                f"{'' if window.stop is None else f' <= {window.after_first(hi):g} s'}"
        if keep.sum() < MIN_SAMPLES:
            raise DataError(f"the window {shown} (after the first sample) keeps {int(keep.sum())} of {time.size} "
                            f"samples (the record spans 0 to {time[-1] - window.origin:g} s after its first sample); "
                            f"at least {MIN_SAMPLES} are needed", f"{source} [recording].start/stop")
        time, theta = time[keep], theta[keep]
        meta["window"] = shown
    need = MIN_SAMPLES if spec.readings == "samples" else MIN_AMPLITUDE_ROWS
    if time.size < need:
        what = "samples" if spec.readings == "samples" else "amplitude readings"
        raise DataError(f"only {time.size} {what}; a decay needs at least {need}", source)
    if notes:
        meta["notes"] = "; ".join(n.replace(";", ",") for n in notes)
    return TimeSeries(time=time, theta=np.asarray(theta, dtype=float), release_s=release_s, source=source,
                      sha256=sha256, meta=meta, window=window)


def _drop_repeated_rows(time: np.ndarray, theta: np.ndarray, rows: np.ndarray, notes: list[str],
                        where_of_row: Callable[[int], str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows that repeat the previous row exactly (time and reading: a spreadsheet's pasted copy)
    left out, with a note; a repeated time with another reading stays (and is refused).
    ``rows`` are the samples' row numbers in the file (for messages)."""
    if time.size < 2:
        return time, theta, rows
    same = np.r_[False, (np.diff(time) == 0.0) & (np.diff(theta) == 0.0)]
    if not same.any():
        return time, theta, rows
    first = int(rows[np.flatnonzero(same)[0]])
    notes.append(f"{int(same.sum())} row(s) repeating the previous row exactly left out, the first at "
                 f"{where_of_row(first)}")
    return time[~same], theta[~same], rows[~same]


def unwrap_angles(theta: np.ndarray, notes: list[str]) -> np.ndarray:
    """Undo the wrap of angles written modulo one turn (an ``atan2`` of tracker coordinates).

    A step of more than 1.5*pi rad between neighbouring samples is a wrap, not motion (the
    motion itself moves far less between samples of any usable record); the wraps are undone
    with a note counting them.
    """
    steps = np.diff(theta)
    jumps = int(np.count_nonzero(np.abs(steps) > 1.5 * math.pi))
    if not jumps:
        return theta
    notes.append(f"angles written modulo one turn: {jumps} wraps at +-180 deg undone")
    return np.unwrap(theta, discont=1.5 * math.pi)


def merge_file_meta(file_meta: Mapping[str, str], reader_meta: Mapping[str, str]) -> dict[str, str]:
    """The file's ``# key: value`` metadata with the reader's keys; a clash keeps the file's as ``file_<key>``."""
    out = {(f"file_{k}" if k in reader_meta else k): v for k, v in file_meta.items()}
    out.update(reader_meta)
    return out


def file_options(given: Mapping[str, tuple[str, str]]) -> dict:
    """Options a file gives itself (a metadata header, ``# key: value`` comments), validated.

    Parameters
    ----------
    given
        ``{name: (value text, "file:line [name]")}``; names outside :data:`FILE_OPTIONS` are
        ignored, ``dt`` (s) becomes ``sample_rate``.

    Raises
    ------
    DataError
        A value the ``[recording]`` key would refuse.
    """
    out: dict = {}
    for key, (value, where) in given.items():
        target = FILE_OPTIONS.get(key)
        if target is None:
            continue
        try:
            if target == "dt":
                dt = parse_seconds(value, where)
                if not dt > 0:
                    raise SceneError(f"the sample interval must be positive, got {value!r}", where)
                out["sample_rate"] = 1.0 / dt
            else:
                out[target] = parse_option(target, value, where)
        except SceneError as exc:
            raise DataError(exc.message, where) from None
    return out
