"""Least squares through lmfit, with a small Latin-hypercube multistart.

The noise scale ``observation.sigma`` (and ``observation.nu``) are not fitted here: the
residuals are standardised by the scene's sigma and lmfit rescales the covariance by the
reduced chi-square, so standard errors reflect the actual scatter; ``sigma_hat`` reports the
scatter itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import lmfit
import numpy as np
from scipy.stats import qmc

from ..errors import FitError
from .problem import FitProblem

__all__ = ["LeastSquaresResult", "least_squares", "NOISE_PARAMS"]

NOISE_PARAMS = ("observation.sigma", "observation.nu", "observation.sigma_t", "observation.rho")


@dataclass
class LeastSquaresResult:
    """Best fit of the structural parameters.

    Attributes
    ----------
    names : list[str]
        Fitted parameters (free parameters except the noise ones).
    value, stderr : ndarray
        Estimates and standard errors (nan when the covariance is singular).
    correlation : ndarray
        Correlation matrix (nan when unavailable).
    chisqr, redchi : float
        Sum of squared standardised residuals and its reduced value.
    sigma_hat : float
        Reading scatter implied by the fit: the scene's sigma times sqrt(redchi) (rad).
    n_data, n_starts : int
    success : bool
    message : str
    values : dict
        All parameter values at the optimum (by name, ties resolved).
    """

    names: list[str]
    value: np.ndarray
    stderr: np.ndarray
    correlation: np.ndarray
    chisqr: float
    redchi: float
    sigma_hat: float
    n_data: int
    n_starts: int
    success: bool
    message: str
    values: dict

    def loglike_gaussian(self) -> float:
        """Gaussian log-likelihood at the optimum with sigma profiled out (for AIC/BIC)."""
        n = self.n_data
        return -0.5 * n * (math.log(2 * math.pi * self.chisqr / n) + 1.0)

    def aic(self) -> float:
        return 2 * (len(self.names) + 1) - 2 * self.loglike_gaussian()

    def bic(self) -> float:
        return (len(self.names) + 1) * math.log(self.n_data) - 2 * self.loglike_gaussian()


def least_squares(problem: FitProblem, *, n_starts: int = 8, seed: int = 0,
                  fixed: dict[str, float] | None = None, start: dict[str, float] | None = None) -> LeastSquaresResult:
    """Minimise the standardised residuals over the structural free parameters.

    Parameters
    ----------
    problem
        The fit problem.
    n_starts
        Start points: the scene's values plus ``n_starts - 1`` Latin-hypercube points in the
        prior bounds (infinite bounds: +-50 % around the scene value).
    seed
        Seed of the Latin hypercube.
    fixed
        Parameters held at given values (used by profile likelihoods).
    start
        Values replacing the scene's in the first start point.

    Notes
    -----
    With correlated reading noise (``observation.rho``, AR(1)) the residuals are the noise's
    innovations at a given rho.  rho is then estimated from the lag-1 autocorrelation of the
    readings' residuals at the optimum and the fit repeated once at that rho, from the optimum.
    """
    if "observation.rho" in problem.names and "observation.rho" not in (fixed or {}):
        first = least_squares(problem, n_starts=n_starts, seed=seed,
                              fixed={**(fixed or {}), "observation.rho": 0.0}, start=start)
        r = problem.observed - problem.expected(first.values)
        r = r - r.mean()
        rho = float(np.clip((r[1:] @ r[:-1]) / (r @ r), 0.0, 0.99))
        return least_squares(problem, n_starts=1, seed=seed, fixed={**(fixed or {}), "observation.rho": rho},
                             start={n: first.values[n] for n in first.names})
    fixed = dict(fixed or {})
    names = [n for n in problem.names if n not in NOISE_PARAMS and n not in fixed]
    if not names:
        raise FitError("no structural parameter left to fit by least squares")
    idx = [problem.names.index(n) for n in names]
    lo, hi = (b[idx] for b in problem.bounds)
    x0 = problem.initial[idx]
    if start:
        x0 = np.array([start.get(n, v) for n, v in zip(names, x0)])
    for n, v in fixed.items():
        if n not in problem.names:
            raise FitError(f"cannot hold {n!r} fixed: not a free parameter of the fit")
    span_lo = np.where(np.isfinite(lo), lo, x0 - 0.5 * np.abs(x0) - 1e-12)
    span_hi = np.where(np.isfinite(hi), hi, x0 + 0.5 * np.abs(x0) + 1e-12)
    starts = [x0]
    if n_starts > 1:
        u = qmc.LatinHypercube(d=len(names), seed=seed).random(n_starts - 1)
        starts += list(qmc.scale(u, span_lo, span_hi))

    keys = [f"p{i}" for i in range(len(names))]  # lmfit needs identifiers; names carry brackets and dots

    def residual(params: lmfit.Parameters) -> np.ndarray:
        vals = problem.values({**fixed, **{n: params[k].value for n, k in zip(names, keys)}})
        return problem.residuals(vals)

    best = None
    for start in starts:
        params = lmfit.Parameters()
        for k, v, a, b in zip(keys, start, lo, hi):
            params.add(k, value=float(np.clip(v, a, b)), min=float(a), max=float(b))
        try:
            res = lmfit.minimize(residual, params, method="least_squares", scale_covar=True)
        except (ValueError, FloatingPointError) as exc:  # pragma: no cover - lmfit refusing a start
            problem.failures[f"least squares start failed: {exc}"[:120]] += 1
            continue
        if best is None or res.chisqr < best.chisqr:
            best = res
    if best is None:
        raise FitError("least squares failed from every start point")
    value = np.array([best.params[k].value for k in keys])
    stderr = np.array([np.nan if best.params[k].stderr is None else best.params[k].stderr for k in keys], float)
    corr = np.full((len(names), len(names)), np.nan)
    if best.covar is not None and best.covar.shape == (len(names), len(names)):
        diag = np.diag(best.covar)
        good = diag > 0  # an indefinite covariance (a flat or curved-away direction) has no standard error
        stderr[~good] = np.nan
        d = np.sqrt(np.where(good, diag, np.nan))
        with np.errstate(invalid="ignore"):
            corr = best.covar / np.outer(d, d)
    vals = problem.values({**fixed, **dict(zip(names, value))})
    ndof = max(best.ndata - best.nvarys, 1)
    redchi = best.chisqr / ndof
    sigma = vals.get("observation.sigma", math.nan)
    return LeastSquaresResult(names, value, stderr, corr, float(best.chisqr), float(redchi),
                              float(sigma * math.sqrt(redchi)), int(best.ndata), len(starts), bool(best.success),
                              str(best.message), vals)
