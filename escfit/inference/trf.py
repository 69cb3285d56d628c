"""Bounded least squares from one start: scipy's trust-region reflective method, called directly.

This is the optimiser :func:`~escfit.inference.lsq.least_squares` runs from each start.  It is
the algorithm lmfit's ``least_squares`` method wraps (``scipy.optimize.least_squares`` with
``method="trf"``, two-point finite-difference Jacobian, ``ftol = xtol = gtol = 1e-8``, the
scene's bounds passed natively, covariance ``(J^T J)^-1`` at the optimum, optionally scaled
by the reduced chi-square), with two costs removed:

* no lmfit ``Parameters`` round trip per evaluation (a few hundred microseconds each);
* the trust-region step factorises the Jacobian (an SVD of a readings-by-parameters matrix
  per iteration).  For the thin matrices of a fit (thousands of rows, a handful of columns)
  OpenBLAS's threads cost a hundred times the arithmetic (measured: 46 ms per SVD of a
  2334 x 7 matrix on two loaded cores, 0.4 ms on one thread), so BLAS runs on one thread
  for the duration of a fit (``threadpoolctl``; without it the run is only slower).
"""

from __future__ import annotations

import math
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass
from typing import Callable

import numpy as np

__all__ = ["Optimum", "minimize", "optimum", "single_blas_thread", "DEFAULT_TOL"]

#: a start this many times its bounds' width from zero is optimised as its offset from the start
OFFSET_RANGES = 1e4

#: ftol, xtol and gtol of every run (lmfit's defaults for this method)
DEFAULT_TOL = 1e-8


@dataclass
class Optimum:
    """Result of one bounded least-squares run.

    Attributes
    ----------
    x : ndarray
        Parameters at the optimum, in their own units.
    residual : ndarray
        The stacked residual vector there.
    jac : ndarray
        Its Jacobian (rows: residuals, columns: parameters), as the last trust-region step saw it.
    covar : ndarray or None
        ``(J^T J)^-1`` times ``redchi`` when ``scale_covar``; None when ``J^T J`` is singular.
    chisqr, redchi : float
        Sum of squared residuals and its value per ``len(residual) - len(x)``.
    success : bool
    message : str
    nfev : int
        Residual evaluations outside the finite-difference Jacobians.
    """

    x: np.ndarray
    residual: np.ndarray
    jac: np.ndarray
    covar: np.ndarray | None
    chisqr: float
    redchi: float
    success: bool
    message: str
    nfev: int


@contextmanager
def single_blas_thread():
    """Hold BLAS/LAPACK to one thread (small dense factorisations run faster that way)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # an optional speed-up: without it the results are the same
        limiter = nullcontext()
    else:
        limiter = threadpool_limits(limits=1, user_api="blas")
    with limiter:
        yield


def minimize(fun: Callable[[np.ndarray], np.ndarray], x0: np.ndarray, lower: np.ndarray, upper: np.ndarray, *,
             scale_covar: bool = False, names: list[str] | None = None, **options) -> Optimum:
    """Minimise ``sum(fun(x)**2)`` inside ``lower <= x <= upper`` from ``x0``.

    Parameters
    ----------
    fun
        Residual vector of a parameter vector (finite values; a failed model gives large ones).
    x0
        Start, clipped into the bounds.
    lower, upper
        Bounds (``-inf``/``inf`` when open).
    scale_covar
        Multiply the covariance by the reduced chi-square (the noise scale is profiled).
    names
        The parameters' names (unused here; optimisers that report by name take them).
    **options
        Passed on to ``scipy.optimize.least_squares`` (``diff_step``, tolerances, ``max_nfev``).
    """
    from scipy.optimize import least_squares as scipy_least_squares

    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    x0 = np.clip(np.asarray(x0, float), lower, upper)
    k = x0.size
    kws = dict(jac="2-point", method="trf", ftol=DEFAULT_TOL, xtol=DEFAULT_TOL, gtol=DEFAULT_TOL, x_scale=1.0,
               max_nfev=4000 * (k + 1))
    kws.update(options)
    # scipy's trust region sizes its first step by the norm of the start: a release instant on an
    # epoch clock (1e9 s) made it a billion, and the first steps threw the losses far off.  A
    # parameter far from zero against its range is optimised as its offset from the start.
    width = np.where(np.isfinite(upper - lower), upper - lower, np.abs(x0))
    # (to the start less its range: an offset of exactly 0 gets no finite-difference step from scipy)
    far = np.abs(x0) > OFFSET_RANGES * np.maximum(width, 1e-300)
    shift = np.where(far, x0 - np.maximum(width, 1.0), 0.0)
    if np.any(shift):
        fun, kws = _shifted(fun, kws, shift, x0)
        x0, lower, upper = x0 - shift, lower - shift, upper - shift
    ret = scipy_least_squares(fun, x0, bounds=(lower, upper), **kws)
    return optimum(ret.x + shift, ret.fun, ret.jac, scale_covar=scale_covar, success=bool(ret.success),
                   message=str(ret.message), nfev=int(ret.nfev))


def _shifted(fun, kws: dict, shift: np.ndarray, x0: np.ndarray):
    """``fun`` and a callable ``jac`` of ``kws`` taking offsets ``u`` from ``shift`` (the same derivatives).

    scipy's finite differences step an offset of about 1 by about 1e-8, below what ``shift + u``
    resolves (1e9 s holds 1e-7 s): a shifted parameter's step is a thousand times its rounding
    instead (2e-4 s at 1e9 s), the others' scipy's own.
    """
    jac = kws.get("jac")
    if callable(jac):
        kws = {**kws, "jac": lambda u, *a: jac(u + shift, *a)}
    elif kws.get("diff_step") is None:
        eps = np.finfo(float).eps
        own = eps ** (1 / 3 if jac == "3-point" else 1 / 2)  # scipy's relative step
        kws = {**kws, "diff_step": np.where(shift != 0, np.maximum(own, 1e3 * eps * np.abs(shift) / np.maximum(
            np.abs(x0 - shift), 1.0)), own)}
    return (lambda u, *a: fun(u + shift, *a)), kws


def optimum(x, residual, jac, *, scale_covar: bool, success: bool, message: str, nfev: int) -> Optimum:
    """The :class:`Optimum` at ``x`` from its residual vector and Jacobian: chi-square, reduced
    chi-square and covariance ``(J^T J)^-1`` (times the reduced chi-square when ``scale_covar``;
    None when singular or not finite)."""
    x, r, jac = np.asarray(x, float), np.asarray(residual, float), np.asarray(jac, float)
    k = x.size
    chisqr = float(r @ r)
    redchi = chisqr / max(1, r.size - k)
    try:
        covar = np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        covar = None
    if covar is not None and scale_covar:
        covar = covar * redchi
    if covar is not None and not np.all(np.isfinite(covar)):
        covar = None
    return Optimum(x, r, jac, covar, chisqr, redchi if math.isfinite(redchi) else math.nan, success, message, nfev)
