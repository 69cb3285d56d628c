"""The smooth part of a record-minus-model sequence of turning-point differences, and its scatter.

Shared by the agreement check's drift, start and end rules (:mod:`escfit.analysis.agreement`):
a point-to-point scatter that a side bias and a smooth drift do not inflate, a quadratic trend
along the turning-point number with an alternating side term, and the spread of that trend where
it is extrapolated.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["turn_scatter", "smooth_trend", "trend_spread"]


def turn_scatter(difference: np.ndarray, floor: float) -> float:
    """Robust point-to-point scatter of a sequence of turning-point differences.

    From differences of points two apart (the same side of the swing), so that an alternating
    side bias and a smooth drift do not count: ``1.4826 MAD / sqrt(2)``; at least ``floor``.
    """
    d2 = difference[2:] - difference[:-2]
    if d2.size < 3:
        return math.nan
    s = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(2.0)
    return max(s, floor)


def _trend_design(swing: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Columns of :func:`smooth_trend`'s fit at the turning points ``at``: 1, u, u**2 (u the
    turning-point number scaled to the span of ``swing``) and the alternating side term."""
    scale = max(float(swing[-1] - swing[0]), 1.0)
    u = (at - swing[0]) / scale
    return np.column_stack([np.ones_like(u, dtype=float), u, u * u, np.where(at % 2 == 0, 1.0, -1.0)])


def smooth_trend(swing: np.ndarray, difference: np.ndarray, at: np.ndarray | None = None) -> np.ndarray:
    """The smooth part of ``difference`` along the record: a quadratic in the turning-point
    number fitted with an alternating term (a side bias), the alternating term left out;
    evaluated at the turning points ``at`` (default ``swing``)."""
    at = swing if at is None else np.asarray(at)
    coef, *_ = np.linalg.lstsq(_trend_design(swing, swing), difference, rcond=None)
    return _trend_design(swing, at)[:, :3] @ coef[:3]


def trend_spread(swing: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Standard error of :func:`smooth_trend` fitted at ``swing`` and evaluated at ``at``, in units
    of one difference's scatter (it grows where the trend is extrapolated)."""
    x = _trend_design(swing, swing)
    cov = np.linalg.pinv(x.T @ x)[:3, :3]
    y = _trend_design(swing, np.asarray(at))[:, :3]
    return np.sqrt(np.einsum("ij,jk,ik->i", y, cov, y))
