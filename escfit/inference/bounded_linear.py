"""Bounded linear least squares of a few parameters: ``min |a x - b|`` with ``lower <= x <= upper``.

The profiled noise scale (:mod:`escfit.inference.noise_scale`) and lmfit's path to a bound
(:mod:`escfit.inference.lmfit_path`) solve small bounded linear problems, thousands of rows
and a handful of columns, several times per fit.  scipy's :func:`~scipy.optimize.lsq_linear`
solves them with an interior trust-region iteration that costs about 5 ms each; most of them
have their optimum inside the box, or with a parameter or two held on a bound, where one
dense least squares per guess of the bound parameters finds it in tens of microseconds.

:func:`bounded_lstsq` guesses the set of parameters held on a bound (an active set: start
with none, hold every variable that leaves its box, free the one whose gradient points most
into the box) and returns a solution only when it satisfies the optimality conditions of
the bounded problem (Karush-Kuhn-Tucker: inside its bounds; the gradient of ``|a x - b|**2``
zero along the free parameters, pointing into the box on the held ones).  The problem is
convex, so that point is the minimum (the unique one when ``a`` has full column rank).  When
the guesses do not settle within a few rounds, or ``a`` is rank-deficient, or anything is
not finite, scipy's :func:`~scipy.optimize.lsq_linear` solves it instead.
"""

from __future__ import annotations

import numpy as np

__all__ = ["bounded_lstsq", "GRADIENT_RTOL"]

#: a held parameter's gradient counts as zero below this fraction of ``|a_i| |a x - b|`` (and ``|a_i| |b|``)
GRADIENT_RTOL = 1e-10


def bounded_lstsq(a: np.ndarray, b: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The ``x`` within ``[lower, upper]`` minimising ``|a @ x - b|``.

    Parameters
    ----------
    a
        Design matrix, shape ``(m, p)``.
    b
        Right-hand side, shape ``(m,)``.
    lower, upper
        Bounds of ``x``, shape ``(p,)`` (``-inf``/``inf`` for none), ``lower <= upper``.

    Returns
    -------
    numpy.ndarray
        The minimiser, shape ``(p,)``: from the active-set rounds when they satisfy the
        optimality conditions, from :func:`scipy.optimize.lsq_linear` otherwise.
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    x = _active_set(a, b, lower, upper)
    if x is not None:
        return x
    from scipy.optimize import lsq_linear

    return lsq_linear(a, b, bounds=(lower, upper)).x


def _active_set(a: np.ndarray, b: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray | None:
    """The active-set solution verified by the optimality conditions, or ``None``."""
    m, p = a.shape
    if m < p or not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))) or np.any(lower > upper):
        return None
    norms = np.sqrt(np.einsum("ij,ij->j", a, a))
    if not np.all(norms > 0):
        return None
    held = np.zeros(p, np.int8)  # -1: on its lower bound, +1: on its upper bound, 0: free
    for _ in range(2 * p + 2):
        x = _solve_free(a, b, lower, upper, held)
        if x is None:
            return None
        low, high = (held == 0) & (x < lower), (held == 0) & (x > upper)
        if low.any() or high.any():
            held[low], held[high] = -1, 1
            continue
        residual = a @ x - b
        gradient = a.T @ residual
        tol = GRADIENT_RTOL * norms * max(float(np.linalg.norm(residual)), float(np.linalg.norm(b)), 1e-300)
        wrong = ((held < 0) & (gradient < -tol)) | ((held > 0) & (gradient > tol))
        if not wrong.any():
            return x
        held[int(np.argmax(np.where(wrong, np.abs(gradient) / norms, -1.0)))] = 0
    return None


def _solve_free(a: np.ndarray, b: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                held: np.ndarray) -> np.ndarray | None:
    """``x`` with the held parameters on their bounds and the free ones by least squares;
    ``None`` when the free columns are rank-deficient (no unique minimum to verify)."""
    x = np.where(held < 0, lower, np.where(held > 0, upper, 0.0))
    free = held == 0
    if not free.any():
        return x
    cols = a[:, free]
    rhs = b - a[:, ~free] @ x[~free] if (~free).any() else b
    scale = np.sqrt(np.einsum("ij,ij->j", cols, cols))
    sol, _, rank, _ = np.linalg.lstsq(cols / scale, rhs, rcond=None)
    if rank < cols.shape[1]:
        return None
    x[free] = sol / scale
    return x
