"""Time stamps written with a few significant digits, and the even clock they round.

A logger or a video tool that prints its clock to three significant digits (``4.33E-02``,
``12.3``, ``101``) keeps a stamp to 0.1 ms below 0.1 s, 10 ms below 10 s, 0.1 s below 100 s and
1 s beyond: at 30 frames a second thirty rows then share each stamp past 100 s, which reads as
a stalled clock, and a tenth of the rows or fewer step forward at all.  The rows were taken
evenly when a straight line of time on row number lies within half a rounding step (and
:data:`JITTER` of an interval) of every stamp.  The line is fitted through the instants the
stamp changes (:func:`_crossings_line`), which a coarse stamp dates as well as a fine one.  A clock that stalls, drops rows or runs unevenly fails that test and is
left to :mod:`escfit.analysis.timebase`'s other repairs or refusals.
"""

from __future__ import annotations

import numpy as np

__all__ = ["significant_digits", "rounded_clock", "MAX_DIGITS", "JITTER"]

MAX_DIGITS = 4  # stamps written with more significant digits than this are not re-timed here
JITTER = 0.25  # of an interval: how far from the line a stamp may be besides its rounding
REPEATED = 0.2  # share of the rows repeating the stamp before them, at least


def _quantum(t: np.ndarray, digits: int) -> np.ndarray:
    """The rounding step (s) of each stamp written with ``digits`` significant digits."""
    mag = np.floor(np.log10(np.abs(np.where(t == 0.0, 1.0, t))))
    return 10.0 ** (mag - digits + 1)


def significant_digits(t) -> int | None:
    """The fewest significant digits (1 to :data:`MAX_DIGITS`) that write every stamp of ``t``
    exactly, or None when more are needed (or no stamp is nonzero)."""
    t = np.asarray(t, dtype=float)
    t = t[np.isfinite(t) & (t != 0.0)]
    if not t.size:
        return None
    for digits in range(1, MAX_DIGITS + 1):
        k = t / _quantum(t, digits)
        if np.all(np.abs(k - np.round(k)) < 1e-6):
            return digits
    return None


def _crossings_line(t: np.ndarray, rows: np.ndarray) -> np.ndarray | None:
    """The least-squares line through the instants the stamp changes.

    A clock rounded to the nearest step changes its stamp when the time passes the midpoint of
    the two stamps, somewhere between the last row of one and the first of the next: the points
    ``(first row - 1/2, midpoint)`` lie on the even clock's line to within half an interval,
    however coarse the stamps (a stamp repeated over thirty rows still changes at a known time)."""
    starts = np.flatnonzero(np.diff(t) != 0) + 1
    if starts.size < 3:
        return None
    slope, intercept = np.polyfit(starts - 0.5, 0.5 * (t[starts - 1] + t[starts]), 1)
    return intercept + slope * rows if slope > 0 else None


def rounded_clock(t) -> tuple[np.ndarray, str] | None:
    """Even times for stamps that round an even clock to a few significant digits, and the
    sentence that says so; None when the stamps are not such a clock (see the module docstring).

    Parameters
    ----------
    t : array_like
        The stamps (s), in row order, never falling.
    """
    t = np.asarray(t, dtype=float)
    if t.size < 20 or not np.all(np.isfinite(t)):
        return None
    steps = np.diff(t)
    if np.any(steps < 0) or np.mean(steps == 0) < REPEATED:
        return None
    digits = significant_digits(t)
    if digits is None:
        return None
    rows = np.arange(t.size, dtype=float)
    step = _quantum(t, digits)
    slope = (t[-1] - t[0]) / (t.size - 1)
    if not slope > 0:
        return None
    line = _crossings_line(t, rows)
    if line is None or np.max(np.abs(t - line) / (0.5 * step + JITTER * slope)) > 1.0:
        return None
    slope = (line[-1] - line[0]) / (t.size - 1)
    return line, (f"time stamps written to {digits} significant digits ({100 * np.mean(steps == 0):.0f} % of the "
                  f"rows repeat the stamp before them, up to a {float(step.max()):g} s step): all {t.size} rows "
                  f"re-timed by a straight line of stamp on row number, {1.0 / slope:.6g} Hz, which stays within half "
                  f"a rounding step and {JITTER:g} of an interval of every stamp")
