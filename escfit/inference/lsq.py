"""Least squares through lmfit with a multistart, for every model family.

The optimiser sees :meth:`Problem.residuals` (the readings' standardised residuals) plus one
residual per Gaussian prior of a fitted parameter (see
:func:`~escfit.likelihood.problem.gaussian_prior_residuals`), so it finds the maximum of the
posterior where a prior pins what the data alone cannot.  Noise parameters
(:attr:`Problem.noise_names`, e.g. ``observation.sigma``) are not fitted:

* when one is free, the noise scale is *profiled*: without Gaussian priors lmfit rescales the
  covariance by the reduced chi-square; with them the scale is re-estimated from the reading
  residuals and the fit repeated until the two agree (degrees of freedom: readings minus the
  parameters no prior pins), because rescaling would also inflate the priors' terms;
* when none is free the scene's noise is known and the covariance is not rescaled.

``sigma_hat`` reports the profiled reading scatter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import lmfit
import numpy as np
from scipy.stats import qmc

from ..core.errors import FitError
from ..likelihood.problem import FAIL_RESIDUAL, Problem, gaussian_prior_residuals

__all__ = ["LeastSquaresResult", "least_squares"]

_GAUSSIAN = ("normal", "halfnormal", "lognormal")


@dataclass
class LeastSquaresResult:
    """Best fit of the structural parameters.

    Attributes
    ----------
    names : list[str]
        Fitted parameters (free parameters except the noise ones).
    value, stderr : ndarray
        Estimates and standard errors (nan when the covariance is singular or indefinite).
    correlation : ndarray
        Correlation matrix (nan when unavailable).
    chisqr, redchi : float
        Sum of squared standardised reading residuals (prior terms excluded) and its value
        per degree of freedom.
    sigma_hat : float
        Reading scatter implied by the fit, in the unit of ``observation.sigma``: profiled
        when the noise scale is free, else the scene's (nan when the family has none).
    n_data, n_starts : int
    success : bool
    message : str
    values : dict
        All parameter values at the optimum (by name, ties resolved, noise profiled).
    profiled : bool
        Whether the noise scale was profiled from the residuals.
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
    profiled: bool = True

    def loglike_gaussian(self) -> float:
        """Gaussian log-likelihood at the optimum with sigma profiled out (for AIC/BIC)."""
        n = self.n_data
        return -0.5 * n * (math.log(2 * math.pi * max(self.chisqr, 1e-300) / n) + 1.0)

    def aic(self) -> float:
        return 2 * (len(self.names) + 1) - 2 * self.loglike_gaussian()

    def bic(self) -> float:
        return (len(self.names) + 1) * math.log(self.n_data) - 2 * self.loglike_gaussian()


def least_squares(problem: Problem, *, n_starts: int = 8, n_refine: int | None = None, seed: int = 0,
                  fixed: dict[str, float] | None = None, start: dict[str, float] | None = None) -> LeastSquaresResult:
    """Minimise the standardised residuals over the structural free parameters.

    Parameters
    ----------
    problem
        Any family's fit problem (:class:`~escfit.likelihood.problem.Problem`).
    n_starts
        Start points: the scene's values (or ``start``) and ``n_starts - 1`` Latin-hypercube
        points spread over the priors (through their inverse cdf; over the bounds, or
        +-50 % around the start where a bound is infinite).
    n_refine
        Optimise from the ``n_refine`` starts of lowest cost (default: all of them).  Rugged
        costs (a speed trace whose period must be found) are cheap to rank and costly to
        optimise from everywhere.
    seed
        Seeds the Latin hypercube.
    fixed
        Parameters held at given values (profiles, the first stage of a correlated-noise fit).
    start
        Starting values by name, replacing the scene's.

    Raises
    ------
    FitError
        Nothing left to fit, fewer readings than fitted parameters, or no start converging.
    """
    noise = tuple(getattr(problem, "noise_names", ()))
    if "observation.rho" in problem.names and "observation.rho" not in (fixed or {}):
        return _two_stage_ar1(problem, n_starts=n_starts, n_refine=n_refine, seed=seed, fixed=fixed, start=start)
    fixed = dict(fixed or {})
    for n in fixed:
        if n not in problem.names:
            raise FitError(f"cannot hold {n!r} fixed: not a free parameter of the fit")
    names = [n for n in problem.names if n not in noise and n not in fixed]
    if not names:
        raise FitError("no structural parameter left to fit by least squares")
    idx = [problem.names.index(n) for n in names]
    priors = [problem.priors[i] for i in idx]
    lo, hi = (np.asarray(b, float)[idx] for b in problem.bounds)
    x0 = np.asarray(problem.initial, float)[idx]
    if start:
        x0 = np.array([start.get(n, v) for n, v in zip(names, x0)])
    pinned = sum(p.kind in _GAUSSIAN for p in priors)
    if problem.n_data + pinned < len(names):
        raise FitError(f"{problem.n_data} reading(s) cannot determine {len(names)} free parameters {names}: fix some "
                       "in the scene or give them informative priors")
    # the reading scatter is profiled when its scale observation.sigma is free; readings of several
    # kinds (timegrapher amplitudes and beat times) share the one covariance rescale instead
    profile_noise = "observation.sigma" in problem.names and "observation.sigma" in noise
    iterate_scale = profile_noise and pinned > 0 and not getattr(problem, "mixed_readings", False)
    starts = _starts(priors, x0, lo, hi, n_starts, seed)
    keys = [f"p{i}" for i in range(len(names))]  # lmfit needs identifiers; names carry dots and brackets
    n = problem.n_data
    options = dict(getattr(problem, "lsq_options", {}) or {})
    scale = [1.0]  # reading residuals are divided by this (the profiled noise over the scene's)

    def vector(params) -> np.ndarray:
        return np.array([params[k].value for k in keys])

    def residual(params: lmfit.Parameters) -> np.ndarray:
        x = vector(params)
        vals = problem.values({**fixed, **dict(zip(names, x))})
        r = np.asarray(problem.residuals(vals), float)[:n] / scale[0]
        out = np.concatenate([r, gaussian_prior_residuals(priors, x)])
        return np.where(np.isfinite(out), out, FAIL_RESIDUAL)

    def params_at(x) -> lmfit.Parameters:
        params = lmfit.Parameters()
        for k, v, a, b in zip(keys, x, lo, hi):
            params.add(k, value=float(np.clip(v, a, b)), min=float(a), max=float(b))
        return params

    if n_refine is not None and n_refine < len(starts):
        cost = [float(np.sum(residual(params_at(x)) ** 2)) for x in starts]
        starts = [starts[i] for i in np.argsort(cost)[:max(1, n_refine)]]
    best = None
    for x in starts:
        try:
            res = lmfit.minimize(residual, params_at(x), method="least_squares", scale_covar=not iterate_scale
                                 and profile_noise, **options)
        except (ValueError, FloatingPointError) as exc:  # lmfit refusing a start
            problem.failures[f"least squares start failed: {exc}"[:120]] += 1
            continue
        if best is None or res.chisqr < best.chisqr:
            best = res
    if best is None:
        raise FitError("least squares failed from every start point")
    free_dof = _data_dof(best, priors, n, len(names) - pinned)
    if iterate_scale:
        for _ in range(50):
            r = best.residual[:n] * scale[0]
            new = math.sqrt(float(r @ r) / free_dof)
            if not new > 0:
                raise FitError("the readings are fitted exactly: the noise scale cannot be estimated; fix "
                               "observation.sigma in the scene")
            done = abs(new - scale[0]) <= 1e-9 * scale[0]
            scale[0] = new
            if done:
                break
            best = lmfit.minimize(residual, best.params, method="least_squares", scale_covar=False, **options)
            free_dof = _data_dof(best, priors, n, len(names) - pinned)
    value = vector(best.params)
    stderr = np.array([np.nan if best.params[k].stderr is None else best.params[k].stderr for k in keys], float)
    corr = np.full((len(names), len(names)), np.nan)
    if best.covar is not None and best.covar.shape == (len(names), len(names)):
        diag = np.diag(best.covar)
        good = diag > 0  # an indefinite covariance (a flat or curved-away direction) has no standard error
        stderr[~good] = np.nan
        d = np.sqrt(np.where(good, diag, np.nan))
        with np.errstate(invalid="ignore"):
            corr = best.covar / np.outer(d, d)
        corr[np.abs(corr) > 1.0 + 1e-9] = np.nan  # not a covariance: no correlation to report
    vals = problem.values({**fixed, **dict(zip(names, value))})
    r = best.residual[:n] * scale[0]
    chisqr = float(r @ r)
    redchi = chisqr / free_dof
    sigma = vals.get("observation.sigma", math.nan)
    if profile_noise:
        sigma_hat = sigma * (scale[0] if iterate_scale else math.sqrt(redchi))
        if "observation.sigma" in problem.names and "observation.sigma" not in fixed and math.isfinite(sigma_hat):
            vals = problem.values({**fixed, **dict(zip(names, value)), "observation.sigma": sigma_hat})
    else:
        sigma_hat = sigma
    return LeastSquaresResult(names, value, stderr, corr, chisqr, float(redchi), float(sigma_hat), int(n),
                              len(starts), bool(best.success), str(best.message), vals, profile_noise)


def _data_dof(best, priors, n: int, unpinned: int) -> float:
    """Degrees of freedom of the readings' residuals: readings minus the effective number of
    parameters they determine, ``n - tr(H_d)``.

    ``H_d = J_d (J^T J)^-1 J_d^T`` is the readings' block of the hat matrix of the stacked
    residuals (readings and Gaussian priors); since ``J^T J = J_d^T J_d + J_p^T J_p``,
    ``tr(H_d) = p - tr(C J_p^T J_p)`` with the unscaled covariance ``C``, and ``J_p`` is
    diagonal (the priors' residual slopes).  A parameter its prior pins counts ~0, one the
    readings determine despite a weak prior counts ~1.  Without a covariance: readings minus
    the parameters without a Gaussian prior.
    """
    p = len(priors)
    cov = getattr(best, "covar", None)
    if cov is None or np.shape(cov) != (p, p) or not np.all(np.isfinite(np.diag(cov))):
        return float(max(n - unpinned, 1))
    x = np.array([best.params[k].value for k in best.var_names])
    tr_prior = 0.0
    for i, pr in enumerate(priors):
        if pr.kind in ("normal", "halfnormal"):
            slope = 1.0 / pr.args[-1]
        elif pr.kind == "lognormal" and x[i] > 0:
            slope = 1.0 / (x[i] * pr.args[1])
        else:
            continue
        tr_prior += float(cov[i, i]) * slope * slope
    return float(max(n - (p - tr_prior), 1.0))


def _two_stage_ar1(problem, *, n_starts, n_refine, seed, fixed, start) -> LeastSquaresResult:
    """Correlated noise: fit with white noise, estimate rho from the residuals, refit."""
    first = least_squares(problem, n_starts=n_starts, n_refine=n_refine, seed=seed,
                          fixed={**(fixed or {}), "observation.rho": 0.0}, start=start)
    r = problem.observed - problem.expected(first.values)
    r = r - r.mean()
    i = problem.names.index("observation.rho")
    lo, hi = (float(np.asarray(b)[i]) for b in problem.bounds)
    rho = float(np.clip((r[1:] @ r[:-1]) / (r @ r), max(lo, -0.99), min(hi, 0.99)))
    return least_squares(problem, n_starts=1, seed=seed, fixed={**(fixed or {}), "observation.rho": rho},
                         start={n: first.values[n] for n in first.names})


def _starts(priors, x0: np.ndarray, lo: np.ndarray, hi: np.ndarray, n_starts: int, seed: int) -> list[np.ndarray]:
    """The start point and a Latin hypercube over the priors (or the bounds)."""
    starts = [x0]
    if n_starts <= 1:
        return starts
    u = qmc.LatinHypercube(d=x0.size, seed=seed).random(n_starts - 1)
    span_lo = np.where(np.isfinite(lo), lo, x0 - 0.5 * np.abs(x0) - 1e-12)
    span_hi = np.where(np.isfinite(hi), hi, x0 + 0.5 * np.abs(x0) + 1e-12)
    pts = qmc.scale(u, span_lo, span_hi)
    for j, pr in enumerate(priors):
        ppf = getattr(pr, "ppf", None)
        if ppf is not None and pr.kind != "uniform" and getattr(pr, "proper", True):
            try:
                x = np.asarray(ppf(u[:, j]), float)
            except (ValueError, ArithmeticError):  # SceneError is a ValueError
                continue
            if np.all(np.isfinite(x)):
                pts[:, j] = x
    return starts + list(pts)
