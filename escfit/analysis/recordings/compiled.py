"""The loops of the record analysis that run per sample or per trial vertex, compiled.

**Extremum scan** (:func:`extremum_scan`): the hysteresis search of
:func:`~escfit.analysis.recordings.extrema.alternating_extrema`, one pass over the samples
(a second per million samples in Python).

**Kinked vertex**: :func:`~escfit.analysis.recordings.extrema.kinked_vertex` fits, for each trial vertex time, a
polynomial each side of the vertex without a linear term, and searches the time that leaves the
smallest residual: some 30 small least-squares problems (a few dozen samples, at most 11
columns) per turning point.  Through numpy each costs some 100 us of call overhead, which at
the 10^4 turning points of a long record is most of a minute; here one costs a few us.

The problem is solved by Householder QR of the design matrix with the samples appended as one
more column (backward stable, as the SVD numpy's ``lstsq`` uses; the residual sum of squares
is the norm of the part of the transformed samples outside the columns' span).  A design
matrix of deficient rank (samples too few or coincident for a side's degree) is not solved
here: the caller then falls back to numpy's minimum-norm solution.
"""

from __future__ import annotations

import math

import numpy as np

from ...core.kernels import kernel

__all__ = ["extremum_scan", "kinked_design", "kinked_lstsq", "kinked_grid"]

# a column whose part outside the earlier columns' span is below this share of its norm makes
# the problem rank deficient for the purpose here (numpy's lstsq would drop a direction)
_RANK_TOL = 1e-11


@kernel
def extremum_scan(xs: np.ndarray, threshold: float, start: int, stop: int, seek: int,
                  eps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First and last sample of each extremum's plateau and whether it is a maximum, for
    :func:`~escfit.analysis.recordings.extrema.alternating_extrema` (which documents the rule)."""
    first = np.empty(stop - start, np.int64)
    last = np.empty(stop - start, np.int64)
    is_max = np.empty(stop - start, np.bool_)
    n = 0
    hi = lo = xs[start]
    hi_a = hi_b = lo_a = lo_b = start
    for i in range(start + 1, stop):
        v = xs[i]
        if seek >= 0:
            if v > hi + eps:
                hi, hi_a, hi_b = v, i, i
            elif v >= hi - eps:
                hi_b = i
            elif v < hi - threshold:
                first[n], last[n], is_max[n] = hi_a, hi_b, True
                n += 1
                seek, lo, lo_a, lo_b = -1, v, i, i
                continue
        if seek <= 0:
            if v < lo - eps:
                lo, lo_a, lo_b = v, i, i
            elif v <= lo + eps:
                lo_b = i
            elif v > lo + threshold:
                first[n], last[n], is_max[n] = lo_a, lo_b, False
                n += 1
                seek, hi, hi_a, hi_b = 1, v, i, i
    return first[:n], last[:n], is_max[:n]


@kernel
def _columns(u: np.ndarray, uc: float, deg_left: int, deg_right: int, shared: bool, extra: int) -> np.ndarray:
    """The design matrix transposed (columns, samples), with ``extra`` zero rows after it."""
    m = u.size
    top = max(deg_left, deg_right)
    k = 1
    for p in range(2, top + 1):
        if shared and p > 2:
            k += 1
        else:
            k += (p <= deg_left) + (p <= deg_right)
    a = np.zeros((k + extra, m))
    for i in range(m):
        s = u[i] - uc
        left = s < 0.0
        a[0, i] = 1.0
        col = 1
        sp = s
        for p in range(2, top + 1):
            sp *= s
            if shared and p > 2:
                a[col, i] = sp
                col += 1
                continue
            if p <= deg_left:
                if left:
                    a[col, i] = sp
                col += 1
            if p <= deg_right:
                if not left:
                    a[col, i] = sp
                col += 1
    return a


@kernel
def kinked_design(u: np.ndarray, uc: float, deg_left: int, deg_right: int, shared: bool) -> np.ndarray:
    """Design matrix (samples, columns) of the fit with vertex at ``uc``: the vertex value, then
    per power ``p >= 2`` of ``s = u - uc`` the left side's and the right side's column (one
    common column for ``p > 2`` when ``shared``); ``s < 0`` is the left side."""
    return _columns(u, uc, deg_left, deg_right, shared, 0).T.copy()


@kernel
def kinked_lstsq(u: np.ndarray, x: np.ndarray, uc: float, deg_left: int, deg_right: int,
                 shared: bool) -> tuple[float, float, bool]:
    """``(residual sum of squares, vertex value, solved)`` of the fit with vertex at ``uc``.

    ``solved`` is False (and the first two nan) when the design matrix is rank deficient.
    """
    w = _columns(u, uc, deg_left, deg_right, shared, 1)  # row c: column c; the last row: the samples
    k = w.shape[0] - 1
    m = u.size
    if m < k:
        return math.nan, math.nan, False
    w[k, :] = x
    v = np.empty(m)
    for j in range(k):
        full = 0.0
        for i in range(m):
            full += w[j, i] * w[j, i]
        norm2 = 0.0
        for i in range(j, m):
            norm2 += w[j, i] * w[j, i]
        if norm2 <= (_RANK_TOL * _RANK_TOL) * full or norm2 == 0.0:
            return math.nan, math.nan, False
        norm = math.sqrt(norm2)
        alpha = -norm if w[j, j] > 0.0 else norm
        vnorm2 = 0.0
        for i in range(j, m):
            v[i] = w[j, i]
        v[j] -= alpha
        for i in range(j, m):
            vnorm2 += v[i] * v[i]
        for c in range(j + 1, k + 1):
            dot = 0.0
            for i in range(j, m):
                dot += v[i] * w[c, i]
            f = 2.0 * dot / vnorm2
            for i in range(j, m):
                w[c, i] -= f * v[i]
        w[j, j] = alpha
    rss = 0.0
    for i in range(k, m):
        rss += w[k, i] * w[k, i]
    coef = np.empty(k)
    for j in range(k - 1, -1, -1):
        acc = w[k, j]
        for c in range(j + 1, k):
            acc -= w[c, j] * coef[c]
        coef[j] = acc / w[j, j]
    return rss, coef[0], True


@kernel
def kinked_grid(u: np.ndarray, x: np.ndarray, grid: np.ndarray, deg_left: int, deg_right: int,
                shared: bool) -> np.ndarray:
    """Residual sum of squares of the fit with its vertex at each of ``grid`` (nan where the
    design matrix is rank deficient)."""
    out = np.empty(grid.size)
    for g in range(grid.size):
        rss, _, solved = kinked_lstsq(u, x, grid[g], deg_left, deg_right, shared)
        out[g] = rss if solved else math.nan
    return out
