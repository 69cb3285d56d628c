"""Energy gained beyond a record's own free-decay law: pushes that a short record hides.

A free swing loses, in each half swing, an amount that depends on its size only: Coulomb
friction the same at every size, viscous damping in proportion to it, air drag in proportion
to its square.  So the losses of a record's peak-to-peak swings ``p_k``,
``l_k = p_k - p_(k+1)``, lie on one smooth curve of the mean swing
``(p_k + p_(k+1)) / 2``, the record's **free law**, here a quadratic fitted with Huber weights
(a push or a glitch is an outlier of it, not a part of it).  Summing each half swing's loss
short of that law gives ``G_k``, the energy gained beyond the law up to turning point ``k``
(in peak-to-peak units); for a free decay it is flat within the reading noise of one swing:

- a **push** raises it for good: a step up;
- a **glitch** (one turning point out of line) moves one or two of its values and not the rest;
- an **offset step** moves one value (one peak-to-peak swing spans the jump);
- a **wobble** makes it rise and fall by the wobble's depth, both ways.

The step at each half swing is the median of ``G`` over :data:`SIDE` values after it less the
median over as many before it, the two values in between left out.  Compared with the level
test of :mod:`escfit.analysis.segments`, nothing is carried across the gap but the law, which
the whole record fixes: in a record of a few tens of swings with several pushes this test
still sees a push of a tenth of the swing, where a local slope carried across the gap blurs it.

A push here is a step up that is (1) :data:`Z` times its reading noise, (2) :data:`MIRROR`
times the deepest step down anywhere in the record (a wobble or a misfitting law steps both
ways; a free decay never loses energy in a step), and (3) at least :data:`MIN_GAIN` of the
swing before it.  Over 1000 wobbling decays (1-3 % depth, 10-30 swings, 20-100 periods; the
set of ``tests/test_segments.py``) the largest step up was 2.4 times the deepest step down of
its record, and none is claimed with these numbers.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["robust_scale", "free_law_gains", "law_steps", "law_pushes", "SIDE", "Z", "MIRROR", "MIN_GAIN"]

SIDE = 6  # values of G on each side of a step
MIN_SIDE = 3  # fewer on either side: no verdict there
MIN_SWINGS = 12  # fewer peak-to-peak swings: the law is not fixed well enough to test against
Z = 5.0  # a step up this many times its reading noise
MIRROR = 3.0  # and this many times the deepest step down in the record
MIN_GAIN = 0.02  # and this share of the swing before it
HUBER = 1.5  # Huber's threshold, in robust standard deviations of the law's residuals
MAD = 1.4826
MEDIAN_SE = math.sqrt(math.pi / 2.0)


def robust_scale(values: np.ndarray) -> float:
    """Standard deviation of the finite ``values`` from their median absolute deviation (nan: none)."""
    v = values[np.isfinite(values)]
    return float(MAD * np.median(np.abs(v - np.median(v)))) if v.size else math.nan


def free_law_gains(p: np.ndarray, iterations: int = 20) -> np.ndarray:
    """Gain beyond the free law in each half swing: the law's loss less the loss measured.

    Parameters
    ----------
    p : ndarray
        Peak-to-peak swings in order (the record's unit, positive).

    Returns
    -------
    ndarray
        ``e_k`` for ``k = 0 .. p.size - 2``, same unit: positive where the swing ``p_(k+1)`` is
        larger than the law makes it from ``p_k`` (energy gained).
    """
    p = np.asarray(p, float)
    loss = p[:-1] - p[1:]
    mean = 0.5 * (p[:-1] + p[1:])
    x = mean / max(float(np.median(mean)), 1e-300)  # the quadratic on a scale of order one
    design = np.stack([np.ones_like(x), x, x * x], axis=1)
    weight = np.ones_like(loss)
    law = np.zeros_like(loss)
    for _ in range(iterations):  # iteratively reweighted least squares, Huber's weights
        root = np.sqrt(weight)
        coef, *_ = np.linalg.lstsq(design * root[:, None], loss * root, rcond=None)
        law = design @ coef
        scale = robust_scale(loss - law)
        if not (math.isfinite(scale) and scale > 0):
            break
        u = np.abs(loss - law) / (HUBER * scale)
        weight = np.where(u <= 1.0, 1.0, 1.0 / np.maximum(u, 1e-300))
    return law - loss


def window_medians(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``median(x[lo[j]:hi[j]])`` for every ``j`` (bounds clipped to ``x``; ``nan`` for an empty window).

    The windows of one width are taken as rows of one strided view and their medians found in
    one call: the same numbers as a median per window, in linear time instead of a Python call
    per half swing.
    """
    x = np.asarray(x, float)
    lo = np.clip(np.asarray(lo), 0, x.size)
    hi = np.clip(np.asarray(hi), 0, x.size)
    width = hi - lo
    out = np.full(lo.size, np.nan)
    for w in np.unique(width[width > 0]):
        rows = np.flatnonzero(width == w)
        out[rows] = np.median(np.lib.stride_tricks.sliding_window_view(x, int(w))[lo[rows]], axis=1)
    return out


def law_steps(p: np.ndarray, side: int = SIDE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Step of the gained energy ``G`` at each half swing, its reading noise and the swing before it.

    Returns ``(step, stderr, level)``, one value per element of ``p`` (``nan`` where a side holds
    fewer than :data:`MIN_SIDE` values): ``step[j]`` is the median of ``G[j+2 : j+2+side]`` less
    that of ``G[j-side : j]`` (a push in half swing ``j``, or over ``j - 1`` and ``j``, falls
    between them), ``level[j]`` the median swing ``p`` before it.  The reading noise: ``G_k``
    carries that of ``p_k`` (``s_p``, from the second differences of ``p`` as in
    :func:`escfit.analysis.segments.find_events`), and neighbouring swings share a turning point
    (correlation one half, which doubles the variance of a median of neighbours).
    """
    p = np.asarray(p, float)
    n = p.size
    step, err, level = (np.full(n, np.nan) for _ in range(3))
    if n < MIN_SWINGS or not np.all(np.isfinite(p)) or np.ptp(p) <= 0:
        return step, err, level
    try:
        g = np.r_[0.0, np.cumsum(free_law_gains(p))]
    except np.linalg.LinAlgError:  # no law to test against
        return step, err, level
    s_p = robust_scale(np.diff(p, 2)) / math.sqrt(2.0)
    j = np.arange(n)
    n_before = np.minimum(j, side)
    n_after = np.clip(g.size - (j + 2), 0, side)
    ok = (n_before >= MIN_SIDE) & (n_after >= MIN_SIDE)
    step[ok] = (window_medians(g, j + 2, j + 2 + side) - window_medians(g, j - side, j))[ok]
    err[ok] = MEDIAN_SE * math.sqrt(2.0) * s_p * np.sqrt(1.0 / n_before[ok] + 1.0 / n_after[ok])
    level[ok] = window_medians(p, j - side, j)[ok]
    return step, err, level


def law_pushes(p: np.ndarray, floor: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Where the swings ``p`` gain energy beyond their free law (see the module docstring).

    Parameters
    ----------
    p : ndarray
        Peak-to-peak swings in order (positive, the record's unit).
    floor : float
        Smallest gain the record resolves (same unit).

    Returns
    -------
    flags : ndarray of bool
        One per element of ``p``: a push falls in that half swing's test.
    step, stderr : ndarray
        The steps of ``G`` and their reading noise (:func:`law_steps`).
    deepest : float
        The deepest step down in the record (positive, same unit): what a push must stand above.
    """
    step, err, level = law_steps(p)
    finite = np.isfinite(step)
    deepest = max(0.0, -float(np.min(step[finite]))) if finite.any() else 0.0
    flags = finite & (np.nan_to_num(step) > Z * np.nan_to_num(err)) & (np.nan_to_num(step) > MIRROR * deepest) \
        & (np.nan_to_num(step) > MIN_GAIN * np.nan_to_num(level)) & (np.nan_to_num(step) > floor)
    return flags, step, err, deepest
