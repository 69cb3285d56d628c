"""A drive recorded beside the oscillator, and the instant it stopped.

A driven pendulum or torsion wheel (Pohl's wheel, a motor-driven torsion pendulum) is often
logged with its drive in a column of its own: the motor's angle or voltage, a sine while the
drive runs, flat once it is switched off.  The oscillator is free only after that instant, and
the column says where that is more plainly than the oscillator's swing can (a drive off
resonance makes the swing rise and fall before it settles; its switch-off changes the swing
little).

:func:`drive_stop` takes the record's other numeric columns and returns the one that drove it
and the instant it stopped: a column that swings at the oscillator's frequency (within
:data:`FREQUENCY_TOLERANCE`) over an active stretch of :data:`MIN_ACTIVE` periods or more, and is
then still, below :data:`STILL` of its active swing, for :data:`MIN_AFTER` periods or more to the
end of the record.  A column that never stops, or does not swing at that frequency (a second
sensor of another motion, a temperature, a counter), is not a drive; nor is a column that stops
with less than :data:`MIN_AFTER` periods after it.  None when no column is such a drive, or when
two are (the choice is then the user's: ``[recording] start``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["DriveStop", "drive_stop", "drive_window", "FREQUENCY_TOLERANCE", "STILL", "MIN_ACTIVE", "MIN_AFTER"]

FREQUENCY_TOLERANCE = 0.25  # the drive's frequency within this share of the oscillator's
STILL = 0.05  # a window whose swing is under this share of the active swing is still
ACTIVE = 0.3  # a window whose swing is over this share of the column's largest is active
MIN_ACTIVE = 5.0  # periods of drive at least
MIN_AFTER = 3.0  # periods of stillness after it at least


@dataclass(frozen=True)
class DriveStop:
    """A drive column and where it stopped.

    Attributes
    ----------
    column : str
        The column's label.
    time : float
        The end of its last active period, s on the record's clock (the oscillator is free
        from there on).
    frequency_ratio : float
        The drive's frequency over the oscillator's.
    """

    column: str
    time: float
    frequency_ratio: float


def _window_swing(t: np.ndarray, x: np.ndarray, period: float) -> tuple[np.ndarray, np.ndarray]:
    """Ends (s) and swings (max - min) of consecutive windows of one period."""
    edges = np.arange(t[0], t[-1] + period, period)
    idx = np.searchsorted(t, edges)
    ends, swings = [], []
    for a, b in zip(idx[:-1], idx[1:]):
        if b - a >= 2:
            ends.append(float(t[b - 1]))
            swings.append(float(np.ptp(x[a:b])))
    return np.array(ends), np.array(swings)


def _crossings(x: np.ndarray) -> int:
    """Crossings of the median by ``x`` (hysteresis of a tenth of its swing: noise does not count)."""
    centre = float(np.median(x))
    band = 0.1 * float(np.ptp(x))
    state, count = 0, 0
    for v in x:
        s = 1 if v > centre + band else (-1 if v < centre - band else 0)
        if s and s != state:
            count += state != 0
            state = s
    return count


def _stop_of(t: np.ndarray, x: np.ndarray, period: float) -> tuple[float, float] | None:
    """(stop instant, frequency ratio) of one column as a drive, or None."""
    ok = np.isfinite(x)
    if ok.sum() < 10:
        return None
    t, x = t[ok], x[ok]
    ends, swings = _window_swing(t, x, period)
    if swings.size < MIN_ACTIVE + MIN_AFTER or float(np.max(swings)) <= 0:
        return None
    active = np.flatnonzero(swings > ACTIVE * float(np.max(swings)))
    last = int(active[-1])
    level = float(np.median(swings[active]))
    after = swings[last + 1:]
    if active.size < MIN_ACTIVE or after.size < MIN_AFTER or np.any(after > STILL * level):
        return None
    first = int(active[0])
    span = (t >= ends[first] - period) & (t <= ends[last])
    duration = float(ends[last] - ends[first] + period)
    ratio = _crossings(x[span]) * period / (2.0 * duration)
    if abs(ratio - 1.0) > FREQUENCY_TOLERANCE:
        return None
    return float(ends[last]), ratio


def drive_stop(time: np.ndarray, others: dict[str, np.ndarray], period: float) -> DriveStop | None:
    """The column of ``others`` that drove the oscillator, and where it stopped (see the module docstring).

    Parameters
    ----------
    time
        The record's times (s), increasing.
    others
        The record's other numeric columns by label (not the time, not the oscillator's), on
        the same rows.
    period
        The oscillator's period (s).
    """
    if not math.isfinite(period) or period <= 0:
        return None
    t = np.asarray(time, float)
    found = []
    for label, values in others.items():
        got = _stop_of(t, np.asarray(values, float), period)
        if got is not None:
            found.append(DriveStop(str(label), got[0], got[1]))
    return found[0] if len(found) == 1 else None



def drive_window(meta: dict, origin: float):
    """``(window, what)``: a :class:`~escfit.analysis.recordings.window.RecordWindow` whose start
    is where a drive recorded in another column stopped (``meta["drive_stop_s"]``, on the
    series' clock whose first sample is ``origin``; the window on the clock from that sample),
    and the words for the note; None when there is none."""
    from .recordings.window import RecordWindow

    stop = float(meta.get("drive_stop_s", "nan") or "nan") - origin
    if not math.isfinite(stop):
        return None
    what = (f"the drive recorded in {meta.get('drive_column')}, which swings at the oscillator's frequency and "
            f"stops at t = {stop:.4g} s (the oscillator is free only after it; [recording] start sets another)")
    return RecordWindow(start=stop), what
