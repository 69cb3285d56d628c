"""Start points of a multistart least-squares fit: the scene's values and a Latin hypercube.

The hypercube is scipy's (``scipy.stats.qmc.LatinHypercube``, scrambled, strength 1) written
out in numpy, drawing the same numbers from the same seed: importing ``scipy.stats`` for it
cost a second of every fit's start-up.  ``tests/test_starts.py`` checks it against scipy.
"""

from __future__ import annotations

import numpy as np

__all__ = ["latin_hypercube", "multistart_points"]


def latin_hypercube(n: int, d: int, seed: int | None) -> np.ndarray:
    """``n`` points in the unit cube ``[0, 1)^d``, one in each of ``n`` equal strata of every axis.

    Each axis is cut into ``n`` slices; a random permutation assigns the points to slices and
    each point lies uniformly within its slice (``numpy.random.default_rng(seed)`` draws the
    offsets first, then the permutations axis by axis).

    Returns
    -------
    numpy.ndarray
        Shape ``(n, d)``.
    """
    rng = np.random.default_rng(seed)
    offsets = rng.uniform(size=(n, d))
    slices = np.tile(np.arange(1, n + 1), (d, 1))
    for axis in range(d):
        rng.shuffle(slices[axis, :])
    return (slices.T - offsets) / n


def multistart_points(priors, x0: np.ndarray, lo: np.ndarray, hi: np.ndarray, n_starts: int,
                      seed: int, spans: dict[int, tuple[float, float]] | None = None) -> list[np.ndarray]:
    """The start point ``x0`` and ``n_starts - 1`` points of a Latin hypercube over the priors.

    A proper non-uniform prior places its axis's points at its quantiles; other axes span the
    bounds ``lo``, ``hi`` (or ``x0`` +- 50 % where a bound is infinite).  ``spans`` (axis ->
    ``(low, high)``) narrows an axis to the range a measurement allows, within the bounds, in
    place of its prior: the hypercube's numbers stay the same, so the other axes do not move.
    """
    starts = [x0]
    if n_starts <= 1:
        return starts
    u = latin_hypercube(n_starts - 1, x0.size, seed)
    span_lo = np.where(np.isfinite(lo), lo, x0 - 0.5 * np.abs(x0) - 1e-12)
    span_hi = np.where(np.isfinite(hi), hi, x0 + 0.5 * np.abs(x0) + 1e-12)
    pts = span_lo + u * (span_hi - span_lo)
    for j, pr in enumerate(priors):
        ppf = getattr(pr, "ppf", None)
        if ppf is not None and pr.kind != "uniform" and getattr(pr, "proper", True):
            try:
                x = np.asarray(ppf(u[:, j]), float)
            except (ValueError, ArithmeticError):  # SceneError is a ValueError
                continue
            if np.all(np.isfinite(x)):
                pts[:, j] = x
    for j, (a, b) in (spans or {}).items():
        a, b = max(float(a), float(span_lo[j])), min(float(b), float(span_hi[j]))
        if a < b:
            pts[:, j] = a + u[:, j] * (b - a)
    return starts + list(pts)
