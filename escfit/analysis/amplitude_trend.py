"""Whether a record's swing loses energy as a free oscillator's must: trends with standard errors.

A free oscillator loses amplitude at every swing; a drive (a motor, an escapement, a hand)
makes up what it loses.  Told apart on neighbouring turning points, a slow decay (a high Q:
a few per cent per hundred periods) looks driven, because between two neighbours it loses
less than the reading noise of a turning point.  The evidence here is taken over whole
stretches of the record instead:

- the **trend** of a stretch is the slope of the logarithm of the swing (half the
  peak-to-peak swing ``p_k = |v_(k+1) - v_k|`` of turning points ``v_k``, at the middle of its
  half swing) on time, a weighted least-squares line (weights ``p_k^2``: constant reading
  noise in ``p`` is a relative noise ``1/p`` in ``log p``).  Its standard error comes from the
  scatter of the swings about the line, not from neighbouring pairs, and is widened for the
  correlation of neighbouring residuals (two swings share a turning point; a weak second mode
  or a wobble moves several in a row): the long-run variance with Bartlett weights
  (Newey-West) of the residuals of the whole record about its running mean;
- a record **decays** when the fall of its whole trend stands :data:`Z_DECAY` standard errors
  above zero (that trend with Tukey's biweights, so that one turning point out of line does not
  hide a short record's decay).  A record that does not (a swing constant within its noise, or one that grows)
  shows no loss at all: a free oscillator with any positive damping would show one, so the
  record is driven, or too short or too noisy for its losses to be measured;
- a **tail** that stops decaying: a free oscillator's decay rate (of ``log p``, 1/s) cannot
  fall faster than the square of its amplitude (air drag; viscous damping keeps it, Coulomb
  friction raises it as the swing shrinks).  For each split of the record, the rate the head
  (the turning points before the split) measured at its largest fitted swing is carried to
  the tail's smallest fitted swing by that square: the least any free law lets the tail lose.
  A tail whose measured rate falls short of that least rate by :data:`Z_SUSTAIN` combined
  standard errors (and whose head's rate stands that far above zero) is kept going.

All trends of all splits come from running sums, so the test costs ``O(n)`` for ``n``
turning points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Trend", "SustainEvidence", "swing_trend", "sustained", "Z_DECAY", "Z_SUSTAIN", "MIN_SWINGS"]

Z_DECAY = 3.0  # standard errors a record's fall needs to count as a measured loss
Z_SUSTAIN = 5.0  # standard errors a tail must lose less than any free law allows (many splits are tried)
MIN_SWINGS = 12  # half swings a stretch needs for a trend (and a scatter) of its own
BISQUARE = 4.685  # robust scales at which a swing's weight in the whole record's trend reaches zero


@dataclass(frozen=True)
class Trend:
    """The trend of the logarithm of the swing over a stretch of the record.

    Attributes
    ----------
    rate : float
        Decay rate of the swing, 1/s: ``-d log p / dt`` (positive when the swing falls).
    stderr : float
        Its standard error, 1/s.
    first, last : float
        Times (s) of the stretch's first and last swings.
    start_swing, end_swing : float
        Fitted swing (half the peak-to-peak, the record's unit) at ``first`` and ``last``.
    count : int
        Half swings in the stretch.
    """

    rate: float
    stderr: float
    first: float
    last: float
    start_swing: float
    end_swing: float
    count: int

    @property
    def fall(self) -> float:
        """Relative fall of the fitted swing over the stretch (``1 - p_last / p_first``)."""
        return -math.expm1(-self.rate * (self.last - self.first))

    @property
    def fall_stderr(self) -> float:
        """Standard error of :attr:`fall`."""
        return math.exp(-self.rate * (self.last - self.first)) * self.stderr * (self.last - self.first)


@dataclass(frozen=True)
class SustainEvidence:
    """Where a record stops losing as a free oscillator must, and why.

    Attributes
    ----------
    index : int
        Turning point (index into the values given) from which the swing is kept going.
    time : float
        Its time, s.
    sentence : str
        The evidence with its numbers.
    """

    index: int
    time: float
    sentence: str


def _swings(times: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mid times (s) and half peak-to-peak swings of consecutive turning points (positive ones only)."""
    t = np.asarray(times, float)
    v = np.asarray(values, float)
    p = 0.5 * np.abs(np.diff(v))
    mid = 0.5 * (t[1:] + t[:-1])
    ok = np.isfinite(p) & np.isfinite(mid) & (p > 0)
    return mid[ok], p[ok]


def _long_run_factor(resid: np.ndarray, weights: np.ndarray) -> float:
    """Variance of a weighted mean of ``resid`` over the variance for independent residuals.

    Bartlett-weighted sum of the autocorrelations of the weighted residuals up to lag
    ``n^(1/3)`` (Newey-West), never below 1: correlated residuals carry less information.
    """
    e = resid * np.sqrt(weights)
    n = e.size
    c0 = float(e @ e) / n
    if n < 8 or c0 <= 0:
        return 1.0
    lags = max(1, int(math.ceil(n ** (1.0 / 3.0))))
    total = 1.0
    for lag in range(1, min(lags, n - 1) + 1):
        rho = float(e[:-lag] @ e[lag:]) / (n * c0)
        total += 2.0 * (1.0 - lag / (lags + 1.0)) * rho
    return max(total, 1.0)


def _inflation(logp: np.ndarray, w: np.ndarray) -> float:
    """:func:`_long_run_factor` of the residuals of ``log p`` about its running mean.

    The running mean spans a twentieth of the record (at least :data:`MIN_SWINGS` half swings):
    it follows any decay law and a drive's change of level, so that what is left is the noise and
    whatever moves neighbouring swings together.  A record under three such spans is too short
    for it: its residuals are taken about its own weighted line instead.
    """
    n = logp.size
    if n < 8:
        return 1.0
    width = max(MIN_SWINGS, n // 20) | 1
    if n < 3 * width:  # too short for a running mean: the residuals about the record's line
        k = np.arange(n, dtype=float)
        sw = np.sqrt(w)
        design = np.stack([np.ones(n), k], axis=1)
        coef, *_ = np.linalg.lstsq(design * sw[:, None], logp * sw, rcond=None)
        return _long_run_factor(logp - design @ coef, w)
    padded = np.pad(logp, width // 2, mode="reflect")
    run = np.concatenate([[0.0], np.cumsum(padded)])
    mean = (run[width:] - run[:-width]) / width
    return _long_run_factor(logp - mean, w)


class _Sums:
    """Running weighted sums of a regression of ``y`` on ``x``, for the line of any run ``[i, j)``."""

    def __init__(self, x: np.ndarray, y: np.ndarray, w: np.ndarray) -> None:
        def run(a: np.ndarray) -> np.ndarray:
            return np.concatenate([[0.0], np.cumsum(a)])

        self.x, self.y, self.w = x, y, w
        self.s, self.sx, self.sy = run(w), run(w * x), run(w * y)
        self.sxx, self.sxy, self.syy = run(w * x * x), run(w * x * y), run(w * y * y)

    def line(self, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, ...]:
        """Slope, its standard error (scale from the residuals) and the fitted ``y`` at ``x[i]``
        and ``x[j-1]``, for runs ``[i, j)`` (arrays of equal shape, ``j - i >= 3``)."""
        s = self.s[j] - self.s[i]
        mx = (self.sx[j] - self.sx[i]) / s
        my = (self.sy[j] - self.sy[i]) / s
        sxx = np.maximum((self.sxx[j] - self.sxx[i]) - s * mx * mx, 1e-300)
        sxy = (self.sxy[j] - self.sxy[i]) - s * mx * my
        syy = (self.syy[j] - self.syy[i]) - s * my * my
        slope = sxy / sxx
        rss = np.maximum(syy - slope * sxy, 0.0)
        # weights are relative: the scale comes from the residuals, as n / sum(w) per point
        var = rss / np.maximum(j - i - 2, 1)
        se = np.sqrt(var / sxx)
        y_first = my + slope * (self.x[i] - mx)
        y_last = my + slope * (self.x[j - 1] - mx)
        return slope, se, y_first, y_last


def _robust_line(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> tuple[float, float, float, float]:
    """Weighted line through ``(x, y)`` with Tukey's biweights: slope, its standard error and
    the fitted ``y`` at the first and last ``x``.

    A turning point out of line (a tracker that slipped at the end of a short record) would set
    the whole record's trend and scatter; its weight falls to zero at :data:`BISQUARE` robust
    scales of residual (three reweightings from the least-squares line, the scale the median
    absolute residual; 95 % of the least-squares efficiency on normal noise).
    """
    h = np.ones_like(w)
    for _ in range(4):
        sums = _Sums(x, y, w * h)
        slope, se, y0, y1 = (float(a[0]) for a in sums.line(np.array([0]), np.array([x.size])))
        resid = (y - (y0 + slope * (x - x[0]))) * np.sqrt(w)
        scale = 1.4826 * float(np.median(np.abs(resid)))
        if scale <= 0:
            break
        u = resid / (BISQUARE * scale)
        h = np.where(np.abs(u) < 1.0, (1.0 - u * u) ** 2, 0.0)
    return slope, se, y0, y1


def _prepared(times: np.ndarray, values: np.ndarray):
    mid, p = _swings(times, values)
    if mid.size < MIN_SWINGS:
        return None
    origin = float(mid[0])
    x = mid - origin
    y = np.log(p)
    w = (p / float(np.max(p))) ** 2
    return mid, x, y, w, _inflation(y, w)


def swing_trend(times: np.ndarray, values: np.ndarray) -> Trend | None:
    """The :class:`Trend` of the whole record of turning points ``values`` (s, any unit) at
    ``times``; ``None`` with fewer than :data:`MIN_SWINGS` half swings."""
    prep = _prepared(times, values)
    if prep is None:
        return None
    mid, x, y, w, inflate = prep
    slope, se, y0, y1 = _robust_line(x, y, w)
    return Trend(-slope, se * math.sqrt(inflate), float(mid[0]), float(mid[-1]), math.exp(y0), math.exp(y1),
                 int(x.size))


def sustained(times: np.ndarray, values: np.ndarray, *, show=lambda v: f"{v:.3g}") -> SustainEvidence | None:
    """Where the record's swing stops losing as a free oscillator's must, or ``None`` (see the module docstring).

    Parameters
    ----------
    times, values
        The free decay's turning points (s; rad or the record's unit), the reference first.
    show
        Writes a swing in the record's unit for the sentence.

    Returns
    -------
    SustainEvidence or None
        From the first turning point when the whole record shows no measured loss; else from
        the split whose tail falls short of the least any free law allows by the most standard
        errors, when that is significant; else ``None``.
    """
    prep = _prepared(times, values)
    if prep is None:
        return None
    mid, x, y, w, inflate = prep
    t = np.asarray(times, float)
    sums = _Sums(x, y, w)
    n = x.size
    root = math.sqrt(inflate)
    slope, se, y0, y1 = _robust_line(x, y, w)
    rate, err = -slope, se * root
    periods = 0.5 * n
    if rate < Z_DECAY * err:
        what = "grows" if rate < -Z_DECAY * err else "keeps its amplitude within its noise"
        fall = -math.expm1(-rate * (mid[-1] - mid[0]))
        fall_se = math.exp(-rate * (mid[-1] - mid[0])) * err * (mid[-1] - mid[0])
        return SustainEvidence(0, float(t[0]), (
            f"over {periods:.0f} periods (t = {t[0]:.4g} to {t[-1]:.4g} s) the swing {what}: it falls by "
            f"{100 * fall:.2g} % +- {100 * fall_se:.2g} % (one standard error, from the scatter of all {n} swings "
            f"about their trend), less than {Z_DECAY:g} standard errors, where a free decay with any damping loses "
            "a measurable share (unless the record is too short or too noisy for its losses)"))
    splits = np.arange(MIN_SWINGS, n - MIN_SWINGS + 1)
    if not splits.size:
        return None
    zeros, ends = np.zeros_like(splits), np.full_like(splits, n)
    h_slope, h_se, h_first, _ = sums.line(zeros, splits)
    t_slope, t_se, _, t_last = sums.line(splits, ends)
    head_rate, tail_rate = -h_slope, -t_slope
    head_se, tail_se = h_se * root, t_se * root
    # the least a free law lets the tail lose: the head's rate scaled by the square of the swing,
    # from the head's largest fitted swing down to the tail's smallest
    scale = np.exp(2.0 * (np.minimum(t_last, h_first) - h_first))
    least, least_se = head_rate * scale, head_se * scale
    spread = np.hypot(least_se, tail_se)
    # a record without noise (a simulation) has no scale to judge by: no evidence either way
    short = np.divide(least - tail_rate, spread, out=np.zeros_like(spread), where=spread > 0)
    found = np.flatnonzero((least > Z_SUSTAIN * least_se) & (short > Z_SUSTAIN))
    if not found.size:
        return None
    k = int(found[np.argmax(short[found])])  # the split the evidence points to most: the knee
    split = int(splits[k])
    when = float(t[split])  # swing `split` runs from turning point `split` on
    return SustainEvidence(split, when, (
        f"from t = {when:.4g} s the swing keeps its amplitude where a free decay would go on losing: it loses "
        f"{_per_period(tail_rate[k], mid):.2g} +- "
        f"{_per_period(tail_se[k], mid):.2g} % a period, where any free law (drag, viscous, Coulomb) continuing the "
        f"{_per_period(head_rate[k], mid):.2g} % a period at {show(math.exp(h_first[k]))} before it loses at least "
        f"{_per_period(least[k], mid):.2g} % at {show(math.exp(min(t_last[k], h_first[k])))} "
        f"({short[k]:.0f} standard errors more)"))


def _per_period(rate: float, mid: np.ndarray) -> float:
    """A decay rate (1/s) as the percentage of the swing lost per period (two half swings)."""
    period = 2.0 * float(mid[-1] - mid[0]) / max(mid.size - 1, 1)
    return 100.0 * float(rate) * period
