"""Which half swing each turning point ends, and the period the turning times give.

Turning points are counted from the record's reference (half swing 0): each ends the half
swing after the one before, except across a gap in the samples (a logger that dropped rows,
a tracker that lost the bob).  There the interval holds as many local half periods as the gap
hid, and counting it as one would shift every later number, and with them the period, the
model's turning points held against the record's and the turning-point fit.  Across a gap of
the samples (:func:`spans_gap`) an interval beyond :data:`~escfit.analysis.recordings.motion.INTERVAL_RANGE`
counts the nearest whole number of local half periods whose parity the sides give (turning
points on opposite sides of the centre are an odd number of half swings apart).  Without a gap
in the samples an irregular interval is a missed or spurious extremum, counted as one, and
the analysis says so.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["spans_gap", "swing_numbers", "period_of", "GAP_INTERVALS"]

GAP_INTERVALS = 3.0  # a step between samples over this many median steps is a gap in the sampling


def spans_gap(t: np.ndarray, dt: float, t0: float, t1: float) -> bool:
    """Whether the sample times ``t`` (median step ``dt``) have a gap between ``t0`` and ``t1``."""
    i, j = np.searchsorted(t, [t0, t1], side="left")
    seg = t[max(i - 1, 0):min(j + 1, t.size)]
    return bool(seg.size > 1 and np.max(np.diff(seg)) > GAP_INTERVALS * dt)


def swing_numbers(t: np.ndarray, dt: float, times: np.ndarray, values: np.ndarray, ratio: np.ndarray,
                  upper: float) -> np.ndarray:
    """The half swing (0 for ``times[0]``, the reference) each turning point ends.

    ``ratio`` is each interval over its local half period; one beyond ``upper`` that spans a
    gap of the samples ``t`` counts the whole number of half periods it holds, of the parity the
    turning points' sides (``values``) give.
    """
    steps = np.ones(max(times.size - 1, 0), np.int64)
    if steps.size:
        swing = np.abs(np.diff(values))
        typical = float(np.median(swing))
        for i in np.flatnonzero(ratio > upper):
            if not spans_gap(t, dt, float(times[i]), float(times[i + 1])):
                continue
            odd = swing[i] > 0.5 * typical  # opposite sides of the centre
            k = max(1, int(round(ratio[i])))
            if (k % 2 == 1) != odd:
                k = k + 1 if ratio[i] > k or k == 1 else k - 1
            steps[i] = k
    return np.r_[0, np.cumsum(steps)]


def period_of(times: np.ndarray, amplitudes: np.ndarray, numbers: np.ndarray | None = None) -> tuple[float, float]:
    """Period (s) and its standard error from turning times and the amplitudes there.

    Twice the slope of the turning times on their half-swing numbers (``numbers``, default
    0, 1, 2 ...), weighted by the squared amplitude: a turning point's time is fixed by its
    curvature, so its error grows as the swing fades (the last turning points of a strongly
    damped record scatter by a good part of a second).  The same rule applied to a model's
    turning points gives the model's period.
    """
    times = np.asarray(times, float)
    k = np.arange(times.size, dtype=float) if numbers is None else np.asarray(numbers, float)
    if times.size < 3:
        return 2.0 * float(times[-1] - times[0]) / max(float(k[-1] - k[0]), 1.0), math.inf
    a = np.abs(np.asarray(amplitudes, float))
    w = np.maximum((a / max(float(np.max(a)), 1e-300)) ** 2, 1e-4)
    design = np.stack([k, np.ones_like(k)], axis=1)
    normal = design.T @ (design * w[:, None])
    coef = np.linalg.solve(normal, design.T @ (w * times))
    resid = times - design @ coef
    s2 = float(w @ resid**2) / (times.size - 2)
    cov = np.linalg.inv(normal) * s2
    return 2.0 * float(coef[0]), 2.0 * math.sqrt(max(float(cov[0, 0]), 0.0))
