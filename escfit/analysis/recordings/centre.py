"""The centre of oscillation and its drift, measured from the turning points of a decay.

A free decay swings about a centre that the sensor's zero seldom marks, and the centre may
creep (a sensor warming up, a suspension taking a set).  Both are kinematic facts of the
record, independent of the damping law, so they are measured here once, with their
uncertainties, and the fits then hold them within what was measured instead of fitting them
freely against the decay (a free drift can trade off with the damping).

Method
------
At each inner turning point ``e_k`` the other side's envelope is interpolated at the same
swing number from its neighbours ``e_(k-1), e_(k+1)`` (and ``e_(k-3), e_(k+3)`` where they
exist: a cubic, so that a decay whose per-swing loss changes along the record, as air drag
makes it, leaves no alternating bias), and the centre estimate is the mean of the two sides.
The drift is the Theil-Sen slope of these estimates against time (:func:`theil_sen`: the
median of the pairwise slopes, exact up to :data:`MAX_PAIRS` pairs, over that many pairs drawn
at random with a fixed seed beyond), kept when its 95 % interval excludes zero and it moves
the centre by more than a quarter of the rest band over the record; the centre is the median of the estimates carried back to the reference instant.
Standard errors come from the scatter of the estimates about that line, with the sample
counted at half its size because neighbouring estimates share turning points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from .series import QUANTITIES, show_value

__all__ = ["Centre", "measure_centre", "theil_sen", "MAX_PAIRS"]

# pairwise slopes the drift's estimate uses at most: 8 MB of slopes, some 0.1 s; every pair of
# up to 1414 turning points (scipy.stats.theilslopes' result to rounding), a sample beyond
MAX_PAIRS = 1_000_000
PAIRS_SEED = 20260401  # fixed: the same record gives the same drift, run after run


@dataclass(frozen=True)
class Centre:
    """Centre of oscillation ``offset + rate * (t - t_ref)`` (rad, rad/s) and its uncertainty.

    Attributes
    ----------
    offset, offset_stderr : float
        Centre at the reference instant and its standard error, rad.
    rate, rate_stderr : float
        Drift (0 unless significant) and the standard error of the measured slope, rad/s
        (given even when the drift is not significant: it bounds what a fit may add).
    measured_rate : float
        The slope as measured, significant or not, rad/s.
    note : str
        A sentence on a significant drift, else empty.
    """

    offset: float
    offset_stderr: float
    rate: float = 0.0
    rate_stderr: float = 0.0
    measured_rate: float = 0.0
    note: str = ""


def centre_estimates(values: np.ndarray) -> np.ndarray:
    """Centre estimate at each inner turning point (index 1 .. n-2) of alternating extrema.

    The other side's envelope at swing ``k``: the two-point mean of its neighbours, or the
    cubic interpolation ``(-e[k-3] + 9 e[k-1] + 9 e[k+1] - e[k+3]) / 16`` where both outer
    neighbours exist.
    """
    e = np.asarray(values, float)
    n = e.size
    other = 0.5 * (e[:-2] + e[2:])
    k = np.arange(1, n - 1)
    inner = (k >= 3) & (k <= n - 4)
    if inner.any():
        kk = k[inner]
        other[inner] = (-e[kk - 3] + 9.0 * e[kk - 1] + 9.0 * e[kk + 1] - e[kk + 3]) / 16.0
    return 0.5 * (other + e[1:-1])


def theil_sen(y: np.ndarray, x: np.ndarray, confidence: float = 0.95, *,
              max_pairs: int = MAX_PAIRS) -> tuple[float, float, float]:
    """Theil-Sen slope of ``y`` against ``x`` and its ``confidence`` interval (Sen 1968), in
    bounded memory: ``(slope, low, high)`` in units of ``y`` per unit of ``x``.

    The slope is the median of the slopes ``(y_j - y_i) / (x_j - x_i)`` over pairs with
    ``x_j > x_i``; the interval's ends are the order statistics of those slopes at the ranks of
    Sen's equation 2.6 (the variance of Kendall's statistic, ties in ``x`` and ``y`` counted),
    as :func:`scipy.stats.theilslopes` takes them.  With at most ``max_pairs`` pairs all are
    used and the result is scipy's.  Beyond, ``max_pairs`` pairs drawn uniformly at random (a
    fixed seed) stand for all of them: the slope and the interval's ends are the same
    quantiles of the sample's slopes.  The median of a sample of ``M`` slopes lies within
    ``1/sqrt(M)`` in rank (0.1 % of the pairs for ``M = 10^6``) of the median of all of them,
    while the 95 % interval spans ``+-1.3/sqrt(n)`` in rank for ``n`` points (1 % at
    ``n = 18000``, a watch balance logged for an hour): the sampled slope moves by a tenth of
    the interval at most, and keeps the estimator's robustness (a breakdown point of 29 %: a
    sample of pairs is as likely as all of them to hold a pair of outliers).  The memory is
    ``O(max_pairs)``, the time ``O(n log n + max_pairs log max_pairs)``, where the all-pairs
    method needs ``O(n^2)`` of both (6.6 GB at ``n = 18000``).

    Parameters
    ----------
    y, x
        The values and their abscissae (equal length, at least 2 distinct ``x``).
    confidence
        Two-sided confidence of the interval (0.95: 95 %).
    max_pairs
        The most pairs to use.
    """
    y = np.asarray(y, float)
    x = np.asarray(x, float)
    n = y.size
    all_pairs = n * (n - 1) // 2
    if all_pairs <= max_pairs:
        i, j = np.triu_indices(n, 1)
    else:
        rng = np.random.default_rng(PAIRS_SEED)
        i = rng.integers(0, n, max_pairs)
        j = rng.integers(0, n - 1, max_pairs)
        j += j >= i  # uniform over the other n - 1 points: a uniform unordered pair
    dx = x[j] - x[i]
    dy = y[j] - y[i]
    del i, j
    ok = dx != 0  # either order: a pair's slope is the same both ways
    slopes = np.sort(dy[ok] / dx[ok])
    del dx, dy, ok
    m = slopes.size
    if m == 0:
        return math.nan, math.nan, math.nan
    slope = float(np.median(slopes))
    # Sen (1968) equation 2.6: variance of Kendall's S with ties in x and in y
    x_counts = np.unique(x, return_counts=True)[1].astype(float)
    y_counts = np.unique(y, return_counts=True)[1].astype(float)
    ties = sum(float(np.sum(k * (k - 1.0) * (2.0 * k + 5.0))) for k in (x_counts, y_counts))
    sigma = math.sqrt(max((n * (n - 1.0) * (2.0 * n + 5.0) - ties) / 18.0, 0.0))
    z = -NormalDist().inv_cdf(0.5 * (1.0 - confidence))
    # ranks among all pairs with distinct x (as scipy counts them), then the same quantiles of the sample
    nt = all_pairs - int(np.sum(x_counts * (x_counts - 1.0)) // 2)
    upper = min(int(np.round((nt + z * sigma) / 2.0)), nt - 1)
    lower = max(int(np.round((nt - z * sigma) / 2.0)) - 1, 0)
    if m != nt:
        lower, upper = (min(int(np.round(r / max(nt - 1, 1) * (m - 1))), m - 1) for r in (lower, upper))
    return slope, float(slopes[lower]), float(slopes[upper])


def measure_centre(times: np.ndarray, values: np.ndarray, band: float, quantity: str = "angle") -> Centre:
    """Centre and drift of alternating turning points ``values`` (rad) at ``times`` (s).

    Parameters
    ----------
    times, values
        The reference turning point first, then the turning points in order.
    band
        Half width of the rest band (rad): a drift smaller than a quarter of it over the
        record is not kept.
    quantity
        What the values are (:data:`~escfit.analysis.recordings.series.QUANTITIES`; the units
        above are then rad/s or m), for the note.
    """
    t = np.asarray(times, float)
    v = np.asarray(values, float)
    if v.size < 3:
        mid = float(0.5 * (v[0] + v[-1]))
        return Centre(mid, 0.5 * abs(float(v[-1] - v[0])) if v.size > 1 else math.inf)
    c = centre_estimates(v)
    tc = t[1:-1] - t[0]
    if c.size < 4:
        scatter = float(np.std(c, ddof=1)) if c.size > 1 else 0.5 * float(np.ptp(v[-2:]))
        return Centre(float(np.median(c)), scatter / math.sqrt(max(0.5 * c.size, 1.0)) if scatter > 0 else band)
    rate, low, high = theil_sen(c, tc)
    n_eff = max(0.5 * c.size, 2.0)
    sxx = float(np.sum((tc - tc.mean()) ** 2))
    span = abs(rate) * (tc[-1] - tc[0])
    significant = (low > 0 or high < 0) and span > 0.25 * band
    kept = float(rate) if significant else 0.0
    resid = c - kept * tc
    offset = float(np.median(resid))
    scatter = float(1.4826 * np.median(np.abs(resid - offset)))
    if scatter == 0.0:  # exact records: the estimates agree to rounding
        scatter = float(np.std(resid, ddof=1)) or 1e-12 * max(float(np.max(np.abs(v))), 1e-300)
    # standard errors of a line through n_eff independent points of that scatter
    rate_se = scatter / math.sqrt(sxx * n_eff / c.size) if sxx > 0 else math.inf
    offset_se = scatter / math.sqrt(n_eff)
    if significant and sxx > 0:  # the intercept of a fitted line, carried back to the reference
        offset_se = scatter * math.sqrt(1.0 / n_eff + (tc.mean() ** 2) * c.size / (n_eff * sxx))
    note = ""
    if significant:
        per_s = "deg/s" if quantity == "angle" else f"{QUANTITIES[quantity]}/s"
        k = math.degrees(1.0) if quantity == "angle" else 1.0
        note = (f"the centre drifts by {show_value(rate * (tc[-1] - tc[0]), quantity, signed=True)} over the record "
                f"({k * rate:+.3g} +- {k * rate_se:.2g} {per_s})")
    return Centre(offset, float(offset_se), kept, float(rate_se), float(rate), note)
