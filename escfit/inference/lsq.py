"""Bounded least squares with a multistart, for every model family.

Each start runs scipy's trust-region reflective method (:mod:`escfit.inference.trf`, the
algorithm lmfit's ``least_squares`` method wraps, called directly).  Its Jacobian is the
problem's own (the integrator's sensitivities of a waveform fit) where it has one,
else forward differences run as one batch call when the problem offers ``residuals_many`` (many
parameter sets at once, :mod:`escfit.inference.fdjac`: the same steps, hence the same fit); see
:mod:`escfit.inference.lsq_jacobian`.

The optimiser sees :meth:`Problem.residuals` (the readings' standardised residuals) plus one
residual per Gaussian prior of a fitted parameter (see
:func:`~escfit.likelihood.problem.gaussian_prior_residuals`), so it finds the maximum of the
posterior where a prior pins what the data alone cannot.  Noise parameters
(:attr:`Problem.noise_names`, e.g. ``observation.sigma``) are not fitted:

* when one is free, the noise scale is *profiled*: without Gaussian priors the fit rescales the
  covariance by the reduced chi-square; with them the scale must equal the scatter the reading
  residuals leave at the optimum found with it (degrees of freedom: readings minus the
  parameters no prior pins), because rescaling would also inflate the priors' terms; that fixed
  point is settled on the optimum's Jacobian (:func:`~escfit.inference.noise_scale.settle_scale`:
  linear steps, a trust-region run only to confirm a step of more than a quarter of a
  standard error);
* when none is free the scene's noise is known and the covariance is not rescaled.

``sigma_hat`` reports the profiled reading scatter.

Uncertainties come from the curvature ``J^T J`` of the stacked residuals at the optimum, in
the parameters' own units.  A singular curvature (a direction the readings do not fix) leaves
the standard errors of the parameters it involves undefined (nan) instead of round-off
numbers, and correlations outside [-1, 1] are never reported.  Intervals respect the scene's
bounds (:func:`bounded_interval`); a parameter on a bound is flagged (``at_bound``) and given a
one-sided interval.  A fit's final stage looks for a second optimum (:mod:`.neighbours`).
"""

from __future__ import annotations

import math
import warnings
from collections import Counter
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import EscfitError, FitError
from ..likelihood.problem import Problem, stacked_residuals
from .lsq_jacobian import LeastSquaresJacobian
from .neighbours import MAX_READINGS, look_nearby
from .noise_scale import profiled_scale, settle_scale
from .starts import multistart_points
from .trf import minimize, single_blas_thread

__all__ = ["LeastSquaresResult", "least_squares", "profiled_scale", "bounded_interval", "bound_flags", "stacked_residuals", "INTERVAL_Z"]

_GAUSSIAN = ("normal", "halfnormal", "lognormal")

#: standard-normal quantiles of the stored two-sided intervals, by level in percent
INTERVAL_Z = {68: 1.0, 95: 1.959963984540054}

#: a parameter within this fraction of its range (or of max(|value|, 1) for an open range) of a bound is on it
BOUND_RTOL = 1e-6

#: starts optimised by default, the cheapest by their cost at the start point
N_REFINE = 3

#: eigenvalues of the standardised curvature below this fraction of the largest count as zero (no information)
SINGULAR_RTOL = 1e-10


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
    lower, upper : ndarray
        The scene's bounds of each fitted parameter (-inf/inf when open).
    at_bound : ndarray of int
        -1 when the estimate sits on its lower bound, +1 on its upper bound, else 0
        (see :func:`bound_flags`).
    intervals : dict
        ``lo68``, ``hi68``, ``lo95``, ``hi95``: approximate 68 % and 95 % intervals inside the
        bounds (see :func:`bounded_interval`), in the parameters' units.
    warnings : list[str]
        What makes the covariance unusable (a singular curvature), in words.
    other_optimum : dict
        Another optimum nearly as good (:mod:`~escfit.inference.neighbours`), by name; or empty.
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
    lower: np.ndarray | None = None
    upper: np.ndarray | None = None
    at_bound: np.ndarray | None = None
    intervals: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    other_optimum: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        k = len(self.names)
        if self.lower is None:
            self.lower = np.full(k, -np.inf)
        if self.upper is None:
            self.upper = np.full(k, np.inf)
        if self.at_bound is None:
            self.at_bound = bound_flags(self.value, self.lower, self.upper, self.stderr)
        if not self.intervals:
            self.intervals = interval_table(self.value, self.stderr, self.lower, self.upper, self.at_bound)


def least_squares(problem: Problem, *, n_starts: int = 8, n_refine: int | None = None, seed: int = 0,
                  fixed: dict[str, float] | None = None, start: dict[str, float] | None = None,
                  priors_count: bool = False, optimizer=minimize, scale_start: float | None = None,
                  nearby: bool = False) -> LeastSquaresResult:
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
        Optimise from the ``n_refine`` starts of lowest cost (default :data:`N_REFINE`; the
        costs are one model evaluation each).  Most Latin-hypercube points start far from any
        record's optimum (a random frequency against seventy periods of a decay), cost a
        full trust-region run each, and end in worse minima or in the one a cheaper start
        reaches; ranking keeps the starts that can win.
    seed
        Seeds the Latin hypercube.
    fixed
        Parameters held at given values (profiles, the first stage of a correlated-noise fit).
    priors_count
        Let Gaussian priors make up for missing readings (the start of a posterior run, where
        informative priors may pin what the data cannot); a least-squares result alone refuses
        fewer readings than parameters.
    start
        Starting values by name, replacing the scene's.
    optimizer
        The run from one start: :func:`~escfit.inference.trf.minimize` (scipy's trust region) or
        any callable of its signature returning an :class:`~escfit.inference.trf.Optimum`
        (:func:`~escfit.inference.lmfit_path.lmfit_optimizer`: an lmfit minimiser).
    scale_start
        Where the profiled noise scale starts when Gaussian priors make it a fixed point, relative
        to the scene's ``observation.sigma`` (default 1): a second noise stage starts at the first
        one's scale, so that settling it hardly moves the optimum.
    nearby
        Look for another optimum near the best (:mod:`escfit.inference.neighbours`): a fit's
        final stage.

    Raises
    ------
    FitError
        Nothing left to fit, fewer readings than fitted parameters (refused before any
        evaluation; Gaussian priors' residual rows are not readings), or no start converging.
    """
    noise = tuple(getattr(problem, "noise_names", ()))
    failures_before = Counter(problem.failures)
    fixed = dict(fixed or {})
    for n in fixed:
        if n not in problem.names:
            raise FitError(f"cannot hold {n!r} fixed: not a free parameter of the fit")
    names = [n for n in problem.names if n not in noise and n not in fixed]
    if not names:
        raise FitError("no structural parameter left to fit by least squares")
    pinned_by_priors = sum(problem.priors[problem.names.index(n)].kind in _GAUSSIAN for n in names)
    refuse_underdetermined(problem, names, pinned_by_priors if priors_count else 0)
    if "observation.rho" in problem.names and "observation.rho" not in fixed:
        return _two_stage_ar1(problem, n_starts=n_starts, n_refine=n_refine, seed=seed, fixed=fixed, start=start,
                              optimizer=optimizer, nearby=nearby)
    idx = [problem.names.index(n) for n in names]
    priors = [problem.priors[i] for i in idx]
    lo, hi = (np.asarray(b, float)[idx] for b in problem.bounds)
    x0 = np.asarray(problem.initial, float)[idx]
    if start:
        x0 = np.array([start.get(n, v) for n, v in zip(names, x0)])
    pinned = sum(p.kind in _GAUSSIAN for p in priors)
    # the reading scatter is profiled when its scale observation.sigma is free; readings of several
    # kinds (timegrapher amplitudes and beat times) share the one covariance rescale instead
    profile_noise = "observation.sigma" in problem.names and "observation.sigma" in noise
    iterate_scale = profile_noise and pinned > 0 and not getattr(problem, "mixed_readings", False)
    spans = {names.index(n): span for n, span in (getattr(problem, "start_spans", None) or {}).items() if n in names}
    starts = multistart_points(priors, x0, lo, hi, n_starts, seed, spans)
    n = problem.n_data
    options = dict(getattr(problem, "lsq_options", {}) or {})
    # reading residuals are divided by this (the profiled noise over the scene's)
    scale = [float(scale_start) if iterate_scale and scale_start and scale_start > 0 else 1.0]

    last = {}  # the latest residual evaluation, which scipy differentiates at next

    def residual(x: np.ndarray) -> np.ndarray:
        vals = problem.values({**fixed, **dict(zip(names, (float(v) for v in x)))})
        r = np.asarray(problem.residuals(vals), float)[:n] / scale[0]
        out = stacked_residuals(r, priors, x)
        last.update(x=np.array(x, float), scale=scale[0], out=out)
        return out

    # the problem's sensitivities, else forward differences in one batch call (same steps, same fit)
    if callable(getattr(problem, "residuals_many", None)) and getattr(problem, "vectorized", True) \
            and "jac" not in options:
        options["jac"] = LeastSquaresJacobian(problem, names, fixed, priors, scale, last, (lo, hi),
                                              options.get("diff_step"))

    with single_blas_thread(), _quiet():
        starts = _ranked(starts, residual, lo, hi, N_REFINE if n_refine is None else n_refine)
        best = None
        for x in starts:
            try:
                res = optimizer(residual, x, lo, hi, scale_covar=not iterate_scale and profile_noise, names=names,
                                **options)
            except (ValueError, FloatingPointError) as exc:  # scipy refusing a start
                problem.failures[f"least squares start failed: {exc}"[:120]] += 1
                continue
            if best is None or res.chisqr < best.chisqr:
                best = res
        if best is None:
            raise FitError("least squares failed from every start point")
        free_dof = _data_dof(best, priors, n, len(names) - pinned)
        if iterate_scale:  # the scale and the optimum settled together on the optimum's Jacobian
            best, _ = settle_scale(
                best, scale, n, lo, hi, dof=lambda b: _data_dof(b, priors, n, len(names) - pinned), evaluate=residual,
                polish=lambda x: optimizer(residual, x, lo, hi, scale_covar=False, names=names, **options))
            free_dof = _data_dof(best, priors, n, len(names) - pinned)
        scaled = profile_noise and not iterate_scale
        cov, undetermined = _covariance(best, len(names), float(best.redchi) if scaled else 1.0)
        cov_warnings, other = [], {}
        if nearby and n <= MAX_READINGS and not undetermined.any() and not getattr(optimizer, "global_search", 0):
            best, cov_warnings, other = look_nearby(
                lambda x: optimizer(residual, x, lo, hi, scale_covar=scaled, names=names, **options),
                lambda x: float(np.sum(residual(x) ** 2)), best, cov, (lo, hi), float(best.redchi) if scaled else 1.0, names)
            cov, undetermined = _covariance(best, len(names), float(best.redchi) if scaled else 1.0)
            free_dof = _data_dof(best, priors, n, len(names) - pinned)  # (a better optimum may have been adopted)
    value = best.x.copy()
    stderr, corr = _errors_and_correlations(cov)
    if undetermined.any():
        which = [nm for nm, u in zip(names, undetermined) if u]
        cov_warnings.append(f"the least-squares curvature is singular: the readings do not fix {which} locally "
                            "(standard errors undefined, no interval); fix some of them in the scene, give them "
                            "informative priors or use --method emcee")
    vals = problem.values({**fixed, **dict(zip(names, value))})
    _refuse_failed_optimum(problem, vals, n)
    searched = _failures_since(problem, failures_before)
    if searched:
        count, reason = searched
        cov_warnings.append(f"{count} model evaluation(s) failed while least squares searched ({reason}): the search "
                            "met parameters where the model cannot be computed, and an interval reaching towards "
                            "them is not to be trusted")
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
                              len(starts), bool(best.success), best.message, vals, profile_noise,
                              lower=lo.copy(), upper=hi.copy(), warnings=cov_warnings, other_optimum=other)


def _failures_since(problem: Problem, before: Counter) -> tuple[int, str] | None:
    """Failed evaluations counted since ``before``: their number and the commonest reason, or ``None``."""
    new = Counter(problem.failures)
    new.subtract(before)
    new = +new
    if not new:
        return None
    reason, count = new.most_common(1)[0]
    return sum(new.values()), f"{reason!r} x {count}" + (f" and {len(new) - 1} other reason(s)" if len(new) > 1 else "")


def _refuse_failed_optimum(problem: Problem, vals: dict, n: int) -> None:
    """Refuse a least-squares optimum at which the model itself cannot be computed.

    A failed evaluation is counted in ``problem.failures`` and gets a large constant residual
    (:data:`~escfit.likelihood.problem.FAIL_RESIDUAL`), so a search over a region where the
    solver fails everywhere (runs out of segments, is refused) ends somewhere in it with
    meaningless numbers and NaN intervals; it is reported as a failed fit instead.

    Raises
    ------
    FitError
        Naming the reason the model failed there.
    """
    before = Counter(problem.failures)
    try:
        r = np.asarray(problem.residuals(vals), float)[:n]
        reason = _failures_since(problem, before)  # a failed solve is counted (its residuals are large, finite)
        if reason is None and np.all(np.isfinite(r)):
            return
        why = reason[1] if reason else f"{int(np.count_nonzero(~np.isfinite(r)))} reading(s) not computed"
    except (EscfitError, ValueError, ArithmeticError) as exc:
        why = str(exc)
    shown = ", ".join(f"{k} = {v:.6g}" for k, v in vals.items() if k in problem.names)
    raise FitError(f"the model cannot be computed at the best fit least squares found ({shown}): {why}; no estimate "
                   "is given (for a solver that runs out of segments: fewer hairspring pieces or swings, or a solver "
                   "option max_segments)")


def refuse_underdetermined(problem: Problem, names: list[str], pinned: int = 0) -> None:
    """Refuse a fit with fewer readings than structural parameters, before any evaluation.

    Readings are counted as the problem counts them (:attr:`Problem.n_data`); the residual rows
    Gaussian priors add are not readings, so for a least-squares result a prior does not make an
    underdetermined fit determined (the optimum would only restate the priors).  A posterior run
    passes ``pinned``, the parameters with informative (Gaussian) priors, which then count.

    Raises
    ------
    FitError
        Naming both counts, the parameters and the data file when the problem knows it.
    """
    n = int(problem.n_data)
    if n + pinned >= len(names):
        return
    where = None
    try:
        where = problem.provenance().get("data_file") or None
    except Exception:  # noqa: BLE001 - provenance is only used to name the file
        where = None
    raise FitError(f"{n} reading(s) cannot determine {len(names)} free parameters {names}: record more readings, "
                   "fix some parameters in the scene, or give them informative priors and use --method emcee",
                   None if where is None else str(where))


@contextmanager
def _quiet():
    """Keep the arithmetic warnings (``sqrt`` of a negative variance of a
    singular curvature) off the console: :func:`_covariance` turns that case into our own warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        yield


def _covariance(best, k: int, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Covariance of the fitted parameters and which of them the readings leave undetermined.

    The curvature ``H = J^T J`` (the Jacobian of the stacked residuals, in the parameters'
    units) is standardised by its diagonal; eigenvalues below :data:`SINGULAR_RTOL` times the
    largest are directions the readings do not fix.  Parameters with a weight in such a
    direction get a nan variance and covariance; the others take the pseudo-inverse on the
    determined subspace.  A regular curvature keeps the optimiser's covariance (the same numbers).
    """
    cov = np.full((k, k), np.nan)
    undetermined = np.ones(k, bool)
    jac = getattr(best, "jac", None)
    jac = None if jac is None else np.asarray(jac, float)
    if jac is None or jac.ndim != 2 or jac.shape[1] != k or not np.all(np.isfinite(jac)):
        return cov, undetermined
    h = jac.T @ jac
    d = np.sqrt(np.diag(h))
    live = d > 0
    if live.any():
        hs = h[np.ix_(live, live)] / np.outer(d[live], d[live])
        w, v = np.linalg.eigh(0.5 * (hs + hs.T))
        null = w <= SINGULAR_RTOL * max(float(w[-1]), 0.0)
        sub = np.zeros(int(live.sum()), bool)
        if null.any():
            sub = np.max(np.abs(v[:, null]), axis=1) > 1e-6
        undetermined[np.flatnonzero(live)] = sub
        keep = ~null
        inv = (v[:, keep] / w[keep]) @ v[:, keep].T / np.outer(d[live], d[live])
        full = np.full((k, k), np.nan)
        full[np.ix_(live, live)] = inv
        cov = full * scale
    covar = getattr(best, "covar", None)
    if not undetermined.any() and covar is not None and np.shape(covar) == (k, k) and np.all(np.diag(covar) > 0):
        cov = np.array(covar, float)  # the optimiser's own (already scaled) covariance: identical numbers
    cov[undetermined, :] = np.nan
    cov[:, undetermined] = np.nan
    return cov, undetermined


def _errors_and_correlations(cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Standard errors and correlations of a covariance; nan where undefined, never |r| > 1."""
    diag = np.diag(cov)
    good = np.isfinite(diag) & (diag > 0)
    stderr = np.where(good, np.sqrt(np.where(good, diag, 1.0)), np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(stderr, stderr)
    corr[~np.isfinite(corr) | (np.abs(corr) > 1.0 + 1e-9)] = np.nan  # not a covariance: no correlation to report
    corr = np.clip(corr, -1.0, 1.0)
    idx = np.flatnonzero(good)
    corr[idx, idx] = 1.0
    return stderr, corr


def bound_flags(value: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                stderr: np.ndarray | None = None) -> np.ndarray:
    """-1 for an estimate on its lower bound, +1 on its upper bound, 0 inside.

    On a bound means within :data:`BOUND_RTOL` of the range ``upper - lower`` when both bounds
    are finite.  With one bound open there is no scale in the parameter's unit (an inertia of
    3e-7 kg m^2 is not "near 0"), so the distance is measured in standard errors: within
    1e-3 of one; without a finite standard error, within 1e-12 of the magnitudes involved.
    """
    value, lower, upper = (np.asarray(a, float) for a in (value, lower, upper))
    se = np.full(value.shape, np.nan) if stderr is None else np.asarray(stderr, float)
    closed = np.isfinite(upper - lower)
    scale = np.where(np.isfinite(se) & (se > 0), 1e-3 * se,
                     1e-12 * np.maximum(np.abs(value), np.abs(np.where(np.isfinite(lower), lower, 0.0))))
    tol = np.where(closed, BOUND_RTOL * np.where(closed, upper - lower, 0.0), scale)
    flags = np.zeros(value.shape, int)
    flags[np.isfinite(lower) & (np.abs(value - lower) <= tol)] = -1
    flags[np.isfinite(upper) & (np.abs(value - upper) <= tol) & (flags == 0)] = 1
    return flags


def bounded_interval(value: float, stderr: float, lower: float, upper: float, z: float,
                     at_bound: int = 0) -> tuple[float, float]:
    """Approximate interval of one parameter that never leaves its bounds.

    The delta method is applied in a coordinate in which the bounds are at infinity,
    ``u = log(x - lower)`` (lower bound only), ``u = -log(upper - x)`` (upper bound only),
    ``u = logit((x - lower)/(upper - lower))`` (both) or ``u = x`` (none):
    ``u +- z * |du/dx| * stderr`` is mapped back to ``x``.  This costs no further fit (a
    profile likelihood costs two root searches of refits per parameter, minutes for a
    balance fit), keeps the interval inside the bounds by construction, reduces to
    ``x +- z * stderr`` where the bounds are many standard errors away, and is exact when the
    readings depend linearly on ``u`` (e.g. on ``log R``), the usual case for positive scale
    parameters.  Near a bound the interval is asymmetric, longer away from the bound.

    A parameter on a bound (``at_bound`` -1 or +1) has no two-sided interval: it gets the
    one-sided ``[lower, lower + z * stderr]`` (or ``[upper - z * stderr, upper]``), clipped to
    the other bound.  ``stderr`` there is the curvature's, and the cost rising through the
    bound only shortens the profile interval, so this is conservative.

    Parameters
    ----------
    value, stderr
        Estimate and standard error, in the parameter's unit.
    lower, upper
        Bounds (``-inf``/``inf`` when open).
    z
        Standard-normal quantile of the two-sided level (1 for 68 %, 1.96 for 95 %).
    at_bound
        -1, 0 or +1 (see :func:`bound_flags`).

    Returns
    -------
    (lo, hi) : tuple of float
        In the parameter's unit; nan where the standard error is undefined.
    """
    x, se, a, b = float(value), float(stderr), float(lower), float(upper)
    if at_bound < 0 and math.isfinite(a):
        return a, (min(b, a + z * se) if math.isfinite(se) else math.nan)
    if at_bound > 0 and math.isfinite(b):
        return (max(a, b - z * se) if math.isfinite(se) else math.nan), b
    if not (math.isfinite(se) and math.isfinite(x)):
        return math.nan, math.nan
    lo_open, hi_open = not math.isfinite(a), not math.isfinite(b)
    if lo_open and hi_open:
        return x - z * se, x + z * se
    if hi_open:
        d = max(x - a, 1e-300)
        s = z * se / d
        return a + d * math.exp(-min(s, 700.0)), a + d * math.exp(min(s, 700.0))
    if lo_open:
        d = max(b - x, 1e-300)
        s = z * se / d
        return b - d * math.exp(min(s, 700.0)), b - d * math.exp(-min(s, 700.0))
    w = b - a
    p = min(max((x - a) / w, 1e-300), 1.0 - 1e-16)
    u = math.log(p) - math.log1p(-p)
    s = z * se / (w * p * (1.0 - p))
    return a + w * _expit(u - s), a + w * _expit(u + s)


def _expit(u: float) -> float:
    return 1.0 / (1.0 + math.exp(-u)) if u >= 0 else math.exp(u) / (1.0 + math.exp(u))


def interval_table(value, stderr, lower, upper, at_bound) -> dict[str, np.ndarray]:
    """``lo68``, ``hi68``, ``lo95``, ``hi95`` of every parameter (:func:`bounded_interval`)."""
    out = {}
    for level, z in INTERVAL_Z.items():
        pairs = [bounded_interval(v, e, a, b, z, int(f))
                 for v, e, a, b, f in zip(value, stderr, lower, upper, at_bound)]
        out[f"lo{level}"] = np.array([p[0] for p in pairs], float)
        out[f"hi{level}"] = np.array([p[1] for p in pairs], float)
    return out


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
    x = best.x
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


def _two_stage_ar1(problem, *, n_starts, n_refine, seed, fixed, start, optimizer, nearby) -> LeastSquaresResult:
    """Correlated noise: fit with white noise, estimate rho from the residuals, refit."""
    first = least_squares(problem, n_starts=n_starts, n_refine=n_refine, seed=seed,
                          fixed={**(fixed or {}), "observation.rho": 0.0}, start=start, optimizer=optimizer)
    r = problem.observed - problem.expected(first.values)
    r = r - r.mean()
    i = problem.names.index("observation.rho")
    lo, hi = (float(np.asarray(b)[i]) for b in problem.bounds)
    rho = float(np.clip((r[1:] @ r[:-1]) / (r @ r), max(lo, -0.99), min(hi, 0.99)))
    return least_squares(problem, n_starts=1, seed=seed, fixed={**(fixed or {}), "observation.rho": rho},
                         start={n: first.values[n] for n in first.names}, optimizer=optimizer,
                         scale_start=profiled_scale(problem, first), nearby=nearby)


def _ranked(starts: list[np.ndarray], residual, lo: np.ndarray, hi: np.ndarray,
            n_refine: int | None) -> list[np.ndarray]:
    """The ``n_refine`` starts of lowest cost (one evaluation each), best first."""
    if n_refine >= len(starts):
        return starts
    cost = [float(np.sum(residual(np.clip(x, lo, hi)) ** 2)) for x in starts]
    return [starts[i] for i in np.argsort(cost, kind="stable")[:max(1, n_refine)]]
