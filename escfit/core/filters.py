"""A Tukey window and Savitzky-Golay smoothing in plain numpy.

The record analysis needs one window function and one polynomial smoother; importing
``scipy.signal`` for them costs a second or more of every command's start-up (it pulls in
``scipy.stats`` too).  These follow ``scipy.signal``'s definitions (``windows.tukey`` with
``sym=True``; ``savgol_coeffs`` and ``savgol_filter`` with ``deriv=0`` and ``mode="interp"``);
``tests/test_filters.py`` checks them against scipy.
"""

from __future__ import annotations

import numpy as np

__all__ = ["tukey", "savgol_coeffs", "savgol_filter"]


def tukey(n: int, alpha: float = 0.5) -> np.ndarray:
    """Tukey (tapered cosine) window of ``n`` points, symmetric.

    Parameters
    ----------
    n
        Number of points (0 gives an empty window).
    alpha
        Fraction of the window inside the two cosine tapers: 0 is a rectangle, 1 a Hann window.

    Returns
    -------
    numpy.ndarray
        The window, maximum 1 in the flat middle, ends 0 (for ``alpha > 0``).
    """
    if n < 0:
        raise ValueError(f"a window needs a length of 0 or more points, got {n}")
    if n <= 1 or alpha <= 0:
        return np.ones(n)
    alpha = min(float(alpha), 1.0)
    k = np.arange(n, dtype=float)
    width = int(np.floor(alpha * (n - 1) / 2.0))
    w = np.ones(n)
    head = k[:width + 1]
    tail = k[n - width - 1:]
    w[:width + 1] = 0.5 * (1.0 + np.cos(np.pi * (-1.0 + 2.0 * head / alpha / (n - 1))))
    w[n - width - 1:] = 0.5 * (1.0 + np.cos(np.pi * (-2.0 / alpha + 1.0 + 2.0 * tail / alpha / (n - 1))))
    return w


def _vandermonde(positions: np.ndarray, order: int) -> np.ndarray:
    """Rows ``positions[i] ** j`` for ``j = 0 .. order``."""
    return positions[:, None] ** np.arange(order + 1)


def savgol_coeffs(window: int, order: int) -> np.ndarray:
    """Weights of the Savitzky-Golay smoother: a polynomial of degree ``order`` fitted by least
    squares to ``window`` samples (odd), evaluated at the middle one.

    Returns
    -------
    numpy.ndarray
        ``window`` weights summing to 1, symmetric (so in the order of a convolution and of a
        correlation alike).
    """
    if window % 2 != 1 or window < 1:
        raise ValueError(f"the smoothing window must be an odd number of samples, got {window}")
    if order >= window:
        raise ValueError(f"the polynomial degree ({order}) must be below the window ({window})")
    half = window // 2
    a = _vandermonde(np.arange(-half, half + 1, dtype=float), order)
    # the fitted polynomial's value at 0 is its constant term: the first row of the pseudo-inverse
    return np.linalg.pinv(a)[0]


def savgol_filter(x: np.ndarray, window: int, order: int) -> np.ndarray:
    """Savitzky-Golay smoothing of a 1-d series; the ends from the polynomial of the first and last
    ``window`` samples (scipy's ``mode="interp"``).

    Parameters
    ----------
    x
        Samples, at least ``window`` of them.
    window, order
        See :func:`savgol_coeffs`.

    Returns
    -------
    numpy.ndarray
        Smoothed samples (float), as many as ``x``.
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise ValueError(f"savgol_filter smooths a 1-d series, got {x.ndim} dimensions")
    if window > x.size:
        raise ValueError(f"the smoothing window ({window}) is longer than the series ({x.size})")
    half = window // 2
    out = np.empty_like(x)
    out[half:x.size - half] = np.convolve(x, savgol_coeffs(window, order), mode="valid")
    if half:
        # the polynomial through each end's window, evaluated at that end's first half samples
        a = _vandermonde(np.arange(window, dtype=float) - half, order)  # centred: well conditioned
        fit = np.linalg.pinv(a)
        ends = a[:half] @ fit @ x[:window], a[window - half:] @ fit @ x[x.size - window:]
        out[:half], out[x.size - half:] = ends
    return out
