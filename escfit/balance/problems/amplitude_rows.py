"""Rows that are already amplitude readings (``[recording] readings = "amplitudes"``).

Two kinds of record give them: a pointer read at every turning point (one row per half swing,
numbered by row order), and peak amplitudes read every few swings, for instance off a video
track every 5-10 swings (numbered by their times).  For the second the half period comes from
the scene's omega0, lengthened for a pendulum by its amplitude (the series of the complete
elliptic integral, ``1 + A^2/16 + 11 A^4/3072``), and omega0 is held there: amplitudes alone
depend on omega0 only through C/omega0 and R/omega0^2, so they cannot determine it.
"""

from __future__ import annotations

import math

import numpy as np

from ...core.errors import DataError
from ...analysis.recordings import UnitCurve

__all__ = ["amplitude_readings_curve", "UNEVEN"]

#: a gap between rows this far (relative) from the median makes the rows "every few swings"
UNEVEN = 0.4


def _half_period(omega0: float, amplitude: np.ndarray, restoring: str) -> np.ndarray:
    """Half period (s) at each amplitude (rad): pi/omega0, lengthened for a pendulum."""
    base = math.pi / omega0
    if restoring != "pendulum":
        return np.full(amplitude.shape, base)
    a2 = amplitude * amplitude
    return base * (1.0 + a2 / 16.0 + 11.0 * a2 * a2 / 3072.0)


def _numbered_by_time(t: np.ndarray, value: np.ndarray, omega0: float, restoring: str, source: str) -> np.ndarray:
    """Half-swing numbers of readings taken every few swings, from their times."""
    mid = 0.5 * (value[1:] + value[:-1])
    steps = np.diff(t) / _half_period(omega0, mid, restoring)
    swing = np.concatenate([[0], np.rint(np.cumsum(steps)).astype(np.int64)])
    close = np.flatnonzero(np.diff(swing) < 1)
    if close.size:
        i = int(close[0])
        raise DataError(f"readings {i + 1} and {i + 2} are {t[i + 1] - t[i]:.4g} s apart, less than a half swing at "
                        f"omega0 = {omega0:.5g} rad/s: amplitude rows must be distinct turning points", source)
    return swing


def amplitude_readings_curve(series, *, omega0: float | None = None, restoring: str = "spring"
                             ) -> tuple[UnitCurve, bool]:
    """The amplitude rows of ``series`` as a unit curve (reading 0: the release).

    Rows evenly spaced in time (within :data:`UNEVEN` of their median gap) and, where omega0 is
    known, about a half period apart are one per half swing in row order.  Other rows are
    numbered by their times at the half period of ``omega0`` (rad/s; refused without one).

    Returns
    -------
    curve, by_time
        The readings, and whether they were numbered by their times.
    """
    t = np.asarray(series.time, float)
    value = np.abs(np.asarray(series.theta, float))
    swing = np.arange(value.size, dtype=np.int64)
    how = "amplitude readings, one per half swing in row order"
    by_time = False
    if t.size >= 3:
        gaps = np.diff(t)
        med = float(np.median(gaps))
        bad = np.flatnonzero(np.abs(gaps - med) > UNEVEN * med)
        known = omega0 is not None and math.isfinite(omega0) and omega0 > 0.0
        apart = known and abs(med / float(np.median(_half_period(omega0, value, restoring))) - 1.0) > UNEVEN
        if bad.size or apart:
            if not known:
                raise DataError(f"readings {bad[0] + 1} and {bad[0] + 2} are {gaps[bad[0]]:.4g} s apart where the "
                                f"others are ~{med:.4g} s: rows one per half swing must be evenly spaced; for "
                                "readings taken every few swings give omega0 in the scene", series.source)
            swing = _numbered_by_time(t, value, omega0, restoring, series.source)
            by_time = True
            how = (f"amplitude readings every few swings, numbered by their times (half swings 0 to {swing[-1]} at "
                   f"omega0 = {omega0:.5g} rad/s)")
    meta = dict(series.meta)
    meta.update(derived_from=how)
    curve = UnitCurve(swing, value, "amplitude", unit=np.full(value.size, "", dtype=str), time=t - t[0],
                      source=series.source, sha256=series.sha256, meta=meta)
    return curve, by_time
