"""Recording formats: detection from a file's content and the format -> reader dispatch.

This module sits above the readers: it imports them, none of them imports it.  The readers
share only :mod:`~escfit.balance.recordings.sniff` (and :mod:`escfit.core.csvtable`).
"""

from __future__ import annotations

from pathlib import Path

from ...core.csvtable import refuses_unreadable
from ...core.errors import DataError
from .pulses import read_pulses
from .sniff import did_you_mean, file_kind, match_header, refuse_unless_csv
from .tg_applog import read_tg_applog, sniff_tg_applog
from .timegrapher import TimegrapherRecording, read_tg_json, read_timegrapher_csv
from .timeseries import read_timeseries
from .unit_curve import read_unit_curve

__all__ = ["FORMATS", "detect_format", "read_recording", "read_timegrapher"]

FORMATS = ("unit-curve", "pulses", "timegrapher", "timeseries", "tg-applog")


@refuses_unreadable
def detect_format(path: str | Path) -> str:
    """Which of :data:`FORMATS` a recording file holds, from its content.

    Column names are matched without regard to case and surrounding spaces.

    Raises
    ------
    DataError
        Binary or empty files, and headers matching no format (naming the columns close to
        a known one).
    """
    kind = file_kind(path)
    where = str(path)
    if kind == "json":
        return "timegrapher"
    if kind in ("binary", "empty"):
        raise DataError("binary file, not a recording" if kind == "binary" else "empty file (no header and no rows)",
                        where)
    header: list[str] = []
    for line in Path(path).read_text(encoding="utf-8", errors="replace").splitlines():
        s = line.strip().lstrip("\ufeff")
        if s and not s.startswith("#"):
            header = [h.strip() for h in s.split(",")]
            break
    cols = set(match_header(header))  # Swing, NOTCHES, ' time_s ' are swing, notches, time_s
    if "kind" in cols and any(c.startswith("time_") for c in cols):
        return "pulses"
    if cols & {"swing", "cycle"}:
        return "unit-curve"
    if "amplitude_deg" in cols and cols & {"rate_s_per_day", "beat_error_ms"}:
        return "timegrapher"
    if any(c.startswith("theta_") for c in cols):
        return "timeseries"
    if sniff_tg_applog(path):  # a timegrapher app's log: settings lines first, one row per display update
        return "tg-applog"
    raise DataError(f"cannot tell the recording format from the header {header}{did_you_mean(header)}; give "
                    f"the format explicitly (one of {', '.join(FORMATS)})", where)


def read_timegrapher(path: str | Path) -> TimegrapherRecording:
    """Read a tg JSON dump, a per-beat CSV or an app's log (told apart by content)."""
    if file_kind(path) == "json":
        return read_tg_json(path)
    return read_tg_applog(path) if sniff_tg_applog(path) else read_timegrapher_csv(path)


@refuses_unreadable
def read_recording(path: str | Path, fmt: str | None = None, **options):
    """Read any recording format (detected unless ``fmt`` is given).

    Parameters
    ----------
    path
        The file.
    fmt
        One of :data:`FORMATS`, or ``None`` to detect it.
    **options
        Passed to the format's reader (e.g. ``notch_deg`` for unit curves).

    Returns
    -------
    UnitCurve, PulseTrain, TimegrapherRecording or TimeSeries
        (a ``"tg-applog"`` file, see :mod:`escfit.balance.recordings.tg_applog`, is a TimegrapherRecording)
    """
    fmt = fmt or detect_format(path)
    if fmt == "unit-curve":
        refuse_unless_csv(path, "a unit curve")
        return read_unit_curve(path, **options)
    if fmt == "pulses":
        return read_pulses(path, **options)
    if fmt == "timegrapher":
        return read_timegrapher(path, **options)
    if fmt == "timeseries":
        return read_timeseries(path, **options)
    if fmt == "tg-applog":
        return read_tg_applog(path, **options)
    raise DataError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}", str(path))
