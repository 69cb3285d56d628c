"""The steps every raw-recording reader shares: checking, re-timing and windowing samples.

:mod:`~escfit.analysis.recordings.rawtable` and :mod:`~escfit.analysis.recordings.matfile` hand their
converted columns (time s, angle rad) to :func:`build_series`, which passes the stamps through the
time-base stage (:func:`repaired_times`, :mod:`escfit.analysis.timebase`: rows out of order,
repeated rows, a stalled clock, stamps in bursts), applies the ``start``/``stop`` window and
checks what is left.
The entry point that picks the reader is :func:`~escfit.analysis.recordings.rawseries.read_raw_series`
(which re-exports these names); this module imports neither reader.

Metadata convention
-------------------
Readers fill :attr:`TimeSeries.meta` with strings only (so it survives
:func:`~escfit.analysis.recordings.timeseries.write_timeseries` and HDF5 attributes):
``source_format``, ``time_column``, ``angle_column``, ``angle_unit``, ``window``, ``notes`` and
``warnings`` (large repairs of the time base), each one string of sentences joined by ``"; "``
(:func:`notes_of` and :func:`warnings_of` split them), next to the file's own
``# key: value`` metadata (a file key that collides is kept as ``file_<key>``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Callable, Mapping

import numpy as np

from ...analysis.timebase import time_base
from ...core.errors import DataError, SceneError
from .recording_spec import RecordingSpec, parse_option, parse_seconds
from .series import TimeSeries
from .window import resolve_window

if TYPE_CHECKING:
    from ..switch_off import SwitchOff

__all__ = ["build_series", "repaired_times", "notes_of", "warnings_of", "merge_file_meta", "file_options", "unwrap_angles",
           "FILE_OPTIONS", "MIN_SAMPLES"]

MIN_SAMPLES = 20
MIN_AMPLITUDE_ROWS = 4  # rows of amplitude readings: more than a viscous and Coulomb fit's parameters
FILE_OPTIONS = {"rate": "sample_rate", "sample_rate": "sample_rate", "samplerate": "sample_rate",
                "sampling_rate": "sample_rate", "sample_rate_hz": "sample_rate", "rate_hz": "sample_rate",
                "fs": "sample_rate", "dt": "dt", "dt_s": "dt", "sample_interval": "dt", "units": "angle_unit",
                "unit": "angle_unit", "angle_unit": "angle_unit", "counts_per_turn": "counts_per_turn",
                "scale": "scale"}


def notes_of(meta: Mapping, key: str = "notes") -> list[str]:
    """The reader's notes (or, with ``key="warnings"``, warnings) of a series' ``meta`` as a list of sentences."""
    text = meta.get(key, "")
    return [s for s in text.split("; ") if s] if isinstance(text, str) else list(text)


def warnings_of(meta: Mapping) -> list[str]:
    """The reader's warnings of a series' ``meta`` (large repairs of its time base) as a list of sentences."""
    return notes_of(meta, "warnings")


def repaired_times(time: np.ndarray, theta: np.ndarray, where_of_row: Callable[[int], str], notes: list[str],
                   warnings: list[str], source: str) -> tuple[np.ndarray, np.ndarray]:
    """``(time, theta)`` of the rows the time base keeps, repaired (:func:`~escfit.analysis.timebase.time_base`).

    Its notes are appended to ``notes``, its warnings (repairs of more than 5 % of the rows) to
    ``warnings``.

    Raises
    ------
    DataError
        Stamps that cannot be repaired, naming the row and ``[recording] sample_rate``.
    """
    tb = time_base(time, theta, where_of_row=where_of_row, source=source)
    notes += tb.notes
    warnings += tb.warnings
    return tb.time, np.asarray(theta, dtype=float)[tb.rows]


def _joined(sentences: list[str]) -> str:
    return "; ".join(n.replace(";", ",") for n in sentences)


def build_series(time: np.ndarray, theta: np.ndarray, spec: RecordingSpec, *, source: str, sha256: str,
                 meta: dict[str, str], notes: list[str], where_of_row: Callable[[int], str],
                 release_s: float = math.nan, label: str = "", unit_from: str = "file",
                 not_before: SwitchOff | None = None) -> TimeSeries:
    """Check and window converted samples (time s, theta rad) and wrap them in a TimeSeries.

    Non-finite values are refused; the stamps are repaired by the time-base stage (see
    :func:`repaired_times`), which refuses what it cannot repair; the window
    ``start <= t <= stop`` is applied and must keep :data:`MIN_SAMPLES` samples.  The samples'
    shape is held against the quantity and unit they are read as
    (:func:`~escfit.analysis.quantity.check_quantity`, for the column ``label`` whose unit came
    from ``unit_from``: ``"file"``, ``"option"`` or ``"assumed"``): a refusal is a DataError
    naming the key to set, a suspicion a note.  ``meta`` gets ``window``, ``notes`` and ``warnings``.
    The ``start``, ``stop`` and ``release`` keys are read on the file's clock from its first row
    (the clock rule of :mod:`~escfit.analysis.recordings.window`); the series carries them
    (``window``) for the analysis.  ``not_before``, a
    :class:`~escfit.analysis.switch_off.SwitchOff` found in another column, moves the start of a
    window the user did not start to the drive's switch-off, with a note saying why (a warning
    when it leaves out more than a quarter of the record).
    """
    for name, values in (("time", time), ("angle", theta)):
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise DataError(f"{name} value {float(values[bad[0]])!r} is not a finite number", where_of_row(int(bad[0])))
    if np.size(time) < 2:
        raise DataError(f"only {np.size(time)} samples; a decay needs at least {MIN_SAMPLES}", source)
    time, theta = np.asarray(time, dtype=float), np.asarray(theta, dtype=float)
    rows = np.arange(time.size)
    if spec.readings == "amplitudes" and np.any(np.diff(time) < 0.0):  # a table's rows need not be in time order
        rows = np.argsort(time, kind="stable")
        time, theta = time[rows], theta[rows]
        notes.append(f"the {time.size} amplitudes are not in time order in the file (sorted by another column?): "
                     "read in the order of their times")
    # the keys are read on the clock as the file gives it (its first row the origin), before any re-timing
    window, clock_notes = resolve_window(spec, time, source)
    notes += clock_notes
    lo = -math.inf if window.start is None else window.start
    hi = math.inf if window.stop is None else window.stop
    warnings: list[str] = []
    if not_before is not None and not window.given and time[0] < not_before.time < hi:
        lo = not_before.time
        dropped = (lo - time[0]) / (min(hi, time[-1]) - time[0])
        (warnings if dropped > 0.25 else notes).append(
            not_before.evidence(label or "the signal", window.origin)
            + f": the first {lo - time[0]:.4g} s ({100 * dropped:.0f} % of the record) are left out as not a free "
              "decay ([recording] start keeps them)")
        meta["drive_off"], meta["drive_column"] = f"{lo:.10g}", not_before.column
    cut = math.isfinite(lo) or window.stop is not None
    if cut and np.any(np.diff(time) <= 0.0):
        # rows stamped outside the window go before the stamps are checked (a logger's clock that
        # stalls after the decay is cut by `stop`); the window is applied again to the times read
        inside = (time >= lo) & (time <= hi)
        if inside.sum() >= 2:
            time, theta, rows = time[inside], theta[inside], rows[inside]
    time, theta = repaired_times(time, theta, lambda i: where_of_row(int(rows[i])), notes, warnings, source)
    if meta.get("angle_unit_assumed") and np.ptp(theta) > 2.0 * math.pi:
        raise DataError(f"the angles span {np.ptp(theta):.4g} with no unit given (rad assumed): more than a turn, so "
                        "not radians of a swinging balance; if they are degrees set [recording] angle_unit = \"deg\" "
                        "(or --angle-unit deg)", source)
    if spec.readings == "samples":
        _check_quantity(time, theta, (lo, hi), spec, meta, notes, source, label, unit_from)
    if spec.readings == "samples" and spec.quantity == "angle":
        theta = unwrap_angles(theta, notes)
    if cut:
        keep = (time >= lo) & (time <= hi)
        shown = f"{'' if not math.isfinite(lo) else f'{window.after_first(lo):g} s <= '}t" \
                f"{'' if window.stop is None else f' <= {window.after_first(hi):g} s'}"
        if keep.sum() < MIN_SAMPLES:
            raise DataError(f"the window {shown} (after the first sample) keeps {int(keep.sum())} of {time.size} "
                            f"samples (the record spans 0 to {time[-1] - window.origin:g} s after its first sample); "
                            f"at least {MIN_SAMPLES} are needed", f"{source} [recording].start/stop")
        time, theta = time[keep], theta[keep]
        meta["window"] = shown
    if spec.mode is not None and spec.readings == "samples":
        from ..mode_filter import isolate_mode

        time, theta, split = isolate_mode(time, theta, spec.mode, f"{source} [recording].mode")
        (warnings if split.warns else notes).append(split.sentence())
        meta["mode"] = str(spec.mode)
    need = MIN_SAMPLES if spec.readings == "samples" else MIN_AMPLITUDE_ROWS
    if time.size < need:
        what = "samples" if spec.readings == "samples" else "amplitude readings"
        raise DataError(f"only {time.size} {what}; a decay needs at least {need}", source)
    if notes:
        meta["notes"] = _joined(notes)
    if warnings:
        meta["warnings"] = _joined(warnings)
    return TimeSeries(time=time, theta=np.asarray(theta, dtype=float), release_s=release_s, source=source,
                      sha256=sha256, meta=meta, window=window)


def _check_quantity(time: np.ndarray, values: np.ndarray, bounds: tuple[float, float], spec: RecordingSpec,
                    meta: dict, notes: list[str], source: str, label: str, unit_from: str) -> None:
    """Hold the samples' shape against what they are read as (within the window); refuse or note."""
    from ...analysis.quantity import check_quantity

    keep = (time >= bounds[0]) & (time <= bounds[1])
    if keep.sum() < MIN_SAMPLES:
        return  # the window's own refusal says it
    unit_key = {"angle": "angle_unit", "angular_velocity": "velocity_unit", "displacement": "displacement_unit"}
    unit = str(meta.get(unit_key[spec.quantity], "")).split(" (")[0]
    scale = float(meta.get("scale", "1") or 1)
    check = check_quantity(time[keep], values[keep], claimed=spec.quantity, unit=unit, name=label,
                           given_by="assumed" if meta.get("angle_unit_assumed") else unit_from, scale=scale)
    if check.verdict == "refuse":
        raise DataError(check.sentence(label), source)
    if check.verdict == "suspect":
        said = check.sentence(label)
        notes.append(said.replace(";", ","))
        meta["analysis"] = "; ".join(filter(None, [meta.get("analysis", ""), said.replace(";", ",")]))


def unwrap_angles(theta: np.ndarray, notes: list[str]) -> np.ndarray:
    """Undo the wrap of angles written modulo one turn (an ``atan2`` of tracker coordinates).

    A step of more than 1.5*pi rad between neighbouring samples is a wrap, not motion (the
    motion itself moves far less between samples of any usable record); the wraps are undone
    with a note counting them.  Only angles that stay within one turn (a span of at most 2 pi, 5 %
    allowed for noise) can have been written modulo one turn: jumps in a signal spanning more are
    left for the checks that follow (counts or another unit read as an angle).
    """
    steps = np.diff(theta)
    jumps = int(np.count_nonzero(np.abs(steps) > 1.5 * math.pi))
    if not jumps or np.ptp(theta) > 2.1 * math.pi:
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
