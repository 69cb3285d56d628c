"""The profiled noise scale of a fit with Gaussian priors, settled on the optimum's Jacobian.

With Gaussian priors the reading scatter cannot be profiled by rescaling the covariance (that
would inflate the priors' terms too): the scale ``s`` that divides the reading residuals must
equal the scatter the fit leaves, ``s**2 = |r(x)|**2 / dof`` (``r`` in the scene's noise units,
``dof`` the readings' degrees of freedom, :func:`~escfit.inference.lsq._data_dof`), and ``x``
must be the optimum at that ``s``.  That fixed point is the stationary point of the profiled
objective ``dof/2 * log|r(x)|**2 + |p(x)|**2/2`` (``p``: the priors' residuals).

Refitting at each new scale until the scale stops moving costs a trust-region run per round
(six to ten rounds, each at least one model run and one Jacobian).  Near an optimum the
residuals are linear in the parameters to second order, ``r(x0 + dx) = r0 + J dx``, so the
fixed point of the linearised problem is found with no model run at all
(:func:`settle_scale`): each round is a bounded linear least-squares step
(:func:`~escfit.inference.bounded_linear.bounded_lstsq`) and a new scale.  When that moves a parameter by more than
:data:`STEP_SE` of its standard error, one trust-region run from the linear solution confirms
it (the linear step's own error is second order in the step) and the settling is repeated
there; otherwise one model run gives the residuals at the settled point.  An optimiser that
returns no usable Jacobian gets the refits.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from ..core.errors import FitError
from .bounded_linear import bounded_lstsq
from .trf import Optimum, optimum

__all__ = ["settle_scale", "profiled_scale", "STEP_SE", "SCALE_RTOL", "MAX_POLISH"]

#: a linear step larger than this many standard errors (any parameter) is confirmed by a trust-region run
STEP_SE = 0.25

#: the scale is settled when a round changes it by less than this fraction
SCALE_RTOL = 1e-9

#: trust-region runs at most after the first optimum (then the linear solution is taken as it is)
MAX_POLISH = 3


def settle_scale(best: Optimum, scale: list[float], n: int, lower: np.ndarray, upper: np.ndarray, *,
                 dof: Callable[[Optimum], float], evaluate: Callable[[np.ndarray], np.ndarray],
                 polish: Callable[[np.ndarray], Optimum]) -> tuple[Optimum, int]:
    """The optimum at the profiled noise scale, starting from the optimum ``best`` at ``scale[0]``.

    Parameters
    ----------
    best
        The trust-region optimum at the current scale: stacked residuals (``n`` reading rows
        divided by ``scale[0]``, then the priors' rows) and their Jacobian.
    scale
        One-element list holding the divisor of the reading residuals (dimensionless, relative
        to the scene's noise); updated in place to the settled scale, which ``evaluate`` and
        ``polish`` read.
    n
        Number of reading rows.
    lower, upper
        The parameters' bounds.
    dof
        Degrees of freedom of the readings at an optimum.
    evaluate
        Stacked residuals at a parameter vector (one model run).
    polish
        Trust-region run from a parameter vector at the current scale.

    Returns
    -------
    best : Optimum
        At the settled scale: residuals evaluated there, Jacobian from the last trust-region
        run rescaled to that scale.
    polished : int
        Trust-region runs made.

    Raises
    ------
    FitError
        When the readings are fitted exactly (no scatter to estimate).
    """
    polished = 0
    while True:
        if not _has_jacobian(best, n):  # nothing to linearise: refit at each new scale until it settles
            return _refit_until_settled(best, scale, n, dof, polish, polished)
        x, dx, jac, s = _linear_fixed_point(best, scale[0], n, lower, upper, dof)
        scale[0] = s
        se = _stderr(jac)
        small = bool(np.all(np.abs(dx) <= STEP_SE * np.where(np.isfinite(se), se, np.inf)))
        if small or polished >= MAX_POLISH:
            x_new = np.clip(x + dx, lower, upper)
            return optimum(x_new, evaluate(x_new), jac, scale_covar=False, success=best.success,
                           message=best.message, nfev=best.nfev + 1), polished
        best = polish(np.clip(x + dx, lower, upper))
        polished += 1


def _has_jacobian(best: Optimum, n: int) -> bool:
    jac = getattr(best, "jac", None)
    if jac is None:
        return False
    jac = np.asarray(jac, float)
    return jac.ndim == 2 and jac.shape == (np.size(best.residual), np.size(best.x)) and jac.shape[0] >= n \
        and bool(np.all(np.isfinite(jac)))


def _refit_until_settled(best: Optimum, scale: list[float], n: int, dof, polish, polished: int) -> tuple[Optimum, int]:
    """The scale re-estimated from the reading residuals and the fit repeated, until it moves by
    less than :data:`SCALE_RTOL` (50 rounds at most)."""
    for _ in range(50):
        r = np.asarray(best.residual[:n], float) * scale[0]
        new = math.sqrt(float(r @ r) / dof(best))
        if not new > 0:
            raise FitError("the readings are fitted exactly: the noise scale cannot be estimated; fix "
                           "observation.sigma in the scene")
        done = abs(new - scale[0]) <= SCALE_RTOL * scale[0]
        scale[0] = new
        if done:
            break
        best = polish(best.x)
        polished += 1
    return best, polished


def _stderr(jac: np.ndarray) -> np.ndarray:
    try:
        cov = np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return np.full(jac.shape[1], np.nan)
    d = np.diag(cov)
    return np.where(d > 0, np.sqrt(np.abs(d)), np.nan)


def _linear_fixed_point(best: Optimum, s0: float, n: int, lower: np.ndarray, upper: np.ndarray,
                        dof: Callable[[Optimum], float]) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The scale and step at which the linearised residuals are optimal and their scatter is the scale.

    Returns ``x0``, the step ``dx``, the stacked Jacobian at the settled scale and that scale.
    """
    x0 = np.asarray(best.x, float)
    res, jac = np.asarray(best.residual, float), np.asarray(best.jac, float)
    r_data, j_data = res[:n] * s0, jac[:n] * s0  # the reading rows in the scene's noise units
    r_prior, j_prior = res[n:], jac[n:]
    s, dx = s0, np.zeros_like(x0)
    lo, hi = lower - x0, upper - x0
    for _ in range(100):
        a = np.vstack([j_data / s, j_prior])
        b = -np.r_[r_data / s, r_prior]
        if np.all(np.isfinite(a)) and np.all(np.isfinite(b)):
            dx = bounded_lstsq(a, b, np.minimum(lo, 0.0), np.maximum(hi, 0.0))
        rl = r_data + j_data @ dx
        step = optimum(x0 + dx, np.r_[rl / s, r_prior + j_prior @ dx], a, scale_covar=False, success=True,
                       message="", nfev=0)
        new = math.sqrt(float(rl @ rl) / dof(step))
        if not new > 0:
            raise FitError("the readings are fitted exactly: the noise scale cannot be estimated; fix "
                           "observation.sigma in the scene")
        done = abs(new - s) <= SCALE_RTOL * s
        s = new
        if done:
            break
    return x0, dx, np.vstack([j_data / s, j_prior]), s


def profiled_scale(problem, lsq) -> float | None:
    """The reading scale ``lsq`` profiled, relative to the scene's ``observation.sigma`` (the
    ``scale_start`` of a refit of the same readings), or ``None``."""
    sigma = problem.values({}).get("observation.sigma", math.nan)  # the scene's, not the profiled one
    if not (lsq.profiled and math.isfinite(lsq.sigma_hat) and math.isfinite(sigma) and sigma > 0):
        return None
    return float(lsq.sigma_hat / sigma)
