"""Estimating pin-slot friction (and the spring torque) of a Geneva escapement.

Two kinds of data:

(a) :class:`SpeedTrace`, a measured driver-speed trace from release at rest;
(b) :class:`TerminalSpeeds`, terminal peak and minimum driver speeds at several spring
    torques (the form of Meyer's Appendix E tables).

Layers, each explicit:

* forward model: a pure function of the parameter vector (:meth:`GenevaProblem.predict`),
  built on :func:`escfit.geneva.simulate.forward`;
* observation model: the data equal the prediction plus independent Gaussian noise of
  known standard deviation ``sd`` (given with the data, or estimated once from the
  least-squares residuals and then held fixed, which is recorded);
* priors: one per free parameter, read from the scene (``prior = "..."`` in a parameter
  table, see :mod:`escfit.likelihood.priors`); a free parameter needs finite bounds or a
  proper prior;
* least squares with lmfit (start and Laplace covariance), then emcee with a fixed seed,
  returned as :class:`arviz.InferenceData` (``posterior`` with dims ``chain, draw``).

A forward run that fails (the pin locks, no terminal velocity) gives ``-inf`` log
probability and the reason is counted in :attr:`GenevaProblem.failures`.

Scaling used by (b): the equation of motion has one time scale ``sqrt(I_f/K)``, so every
terminal speed is exactly proportional to ``sqrt(K)``; one terminal cycle per parameter
point serves all torques.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import arviz as az
import emcee
import lmfit
import numpy as np

from ..core.errors import DataError, FitError
from ..likelihood.priors import Prior, prior_of
from ..core.params import Param, safe_name
from .engines import ENGINES
from .simulate import forward
from .terminal import terminal_cycle

__all__ = ["SpeedTrace", "TerminalSpeeds", "GenevaProblem", "LeastSquaresFit", "fit_least_squares",
           "sample_posterior", "synthetic_trace", "TORQUE_SCALE", "DEFAULT_SEED"]

DEFAULT_SEED = 1973
TORQUE_SCALE = "geneva.torque_scale"
FIT_OPTIONS = {"dt": 1e-3}  # rk4 step in units of sqrt(I_f/K): ~1e-7 relative error, 2x cheaper than simulate's


@dataclass(frozen=True)
class SpeedTrace:
    """A measured driver-speed trace, released at rest at ``t = 0``.

    Attributes
    ----------
    time
        Sample times, s (increasing, non-negative).
    speed
        Driver speed, rad/s.
    sd
        Measurement standard deviation, rad/s, or ``None`` to estimate it.
    source
        Where the data came from (for messages and provenance).
    """

    time: np.ndarray
    speed: np.ndarray
    sd: float | None = None
    source: str = "speed trace"

    def __post_init__(self) -> None:
        t, w = np.asarray(self.time, float), np.asarray(self.speed, float)
        if t.ndim != 1 or t.shape != w.shape or t.size < 3:
            raise DataError(f"time and speed must be 1-D of equal length >= 3, got {t.shape} and {w.shape}",
                            self.source)
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(w))):
            raise DataError("time or speed holds a non-finite value", self.source)
        if t[0] < 0 or np.any(np.diff(t) <= 0):
            raise DataError("times must be non-negative and strictly increasing", self.source)
        if self.sd is not None and not self.sd > 0:
            raise DataError(f"sd must be positive, got {self.sd!r}", self.source)


@dataclass(frozen=True)
class TerminalSpeeds:
    """Terminal peak and minimum driver speeds at several spring torques.

    Attributes
    ----------
    torque
        Nominal spring torque of each run, N*m.
    peak, minimum
        Terminal peak and minimum driver speed, rad/s.
    sd
        Standard deviation of every speed, rad/s, or ``None`` to estimate it.
    source
        Provenance.
    """

    torque: np.ndarray
    peak: np.ndarray
    minimum: np.ndarray
    sd: float | None = None
    source: str = "terminal speeds"

    def __post_init__(self) -> None:
        k, p, m = (np.asarray(v, float) for v in (self.torque, self.peak, self.minimum))
        if k.ndim != 1 or not (k.shape == p.shape == m.shape) or k.size < 1:
            raise DataError(f"torque, peak and minimum must be 1-D of equal length, got {k.shape}, {p.shape}, "
                            f"{m.shape}", self.source)
        if not (np.all(k > 0) and np.all(p > 0) and np.all(m >= 0) and np.all(np.isfinite(p + m))):
            raise DataError("torques and peak speeds must be positive, minimum speeds non-negative", self.source)
        if self.sd is not None and not self.sd > 0:
            raise DataError(f"sd must be positive, got {self.sd!r}", self.source)


@dataclass
class GenevaProblem:
    """Scene + data -> prediction, residuals and log posterior.

    Parameters
    ----------
    scene
        A Geneva scene; parameters with ``vary = true`` are estimated.
    data
        A :class:`SpeedTrace` or :class:`TerminalSpeeds`.
    torque_scale
        Terminal data only: ``None`` (the nominal torques are exact) or a prior string
        (e.g. ``"uniform(0.5, 2)"``) for a common factor ``geneva.torque_scale`` on all
        nominal torques, which is then estimated.

    Attributes
    ----------
    names
        Free parameter names, in vector order.
    priors
        Prior of each free parameter.
    failures
        Why evaluations returned ``-inf`` (``"locked"``, ``"no_terminal"`` ...), counted.
    """

    scene: Any
    data: SpeedTrace | TerminalSpeeds
    torque_scale: str | None = None
    names: list[str] = field(init=False)
    priors: dict[str, Prior] = field(init=False)
    failures: Counter = field(init=False, default_factory=Counter)

    def __post_init__(self) -> None:
        if getattr(self.scene, "model", None) != "geneva":
            raise FitError("a Geneva fit needs a geneva scene", getattr(self.scene, "where", "scene"))
        free = list(self.scene.params.free())
        if self.torque_scale is not None:
            if not isinstance(self.data, TerminalSpeeds):
                raise FitError("torque_scale applies to terminal-speed data only", self.scene.where)
            free.append(Param(TORQUE_SCALE, 1.0, "", "common factor on the nominal torques", True, 0.0, math.inf,
                              self.torque_scale))
        if isinstance(self.data, TerminalSpeeds) and "geneva.torque" in {p.name for p in free}:
            raise FitError("terminal-speed data give the torques; free geneva.torque_scale instead of "
                           "geneva.torque", self.scene.where)
        if not free:
            raise FitError("no free parameter: mark one with vary = true (e.g. mu = { value = 0.2, vary = true, "
                           "min = 0, max = 1 })", self.scene.where)
        self.names = [p.name for p in free]
        self.priors = {p.name: prior_of(p, f"{self.scene.where} [{p.name}]", allow_improper=True) for p in free}
        for n, pr in self.priors.items():
            if not pr.proper:
                raise FitError(f"{n} needs finite min and max or a proper prior (e.g. prior = 'uniform(0, 1)')",
                               self.scene.where)
        self.start = np.array([p.value for p in free])
        self.fixed = self.scene.params.values()

    # -------------------------------------------------------------- forward model
    @property
    def observed(self) -> np.ndarray:
        """The data vector the prediction is compared with, rad/s."""
        d = self.data
        return np.asarray(d.speed, float) if isinstance(d, SpeedTrace) else np.concatenate((d.peak, d.minimum))

    def values(self, theta: Sequence[float]) -> dict[str, float]:
        """Scene values with the free ones replaced (SI)."""
        out = dict(self.fixed)
        out.update({n: float(v) for n, v in zip(self.names, theta)})
        return out

    def predict(self, theta: Sequence[float]) -> np.ndarray | None:
        """Predicted data vector for a parameter vector, or ``None`` if the model fails (reason counted)."""
        vals = self.values(theta)
        geo = self.scene.geometry
        if isinstance(self.data, SpeedTrace):
            t = np.asarray(self.data.time, float)
            pred = forward(geo, vals, duration=float(t[-1]), sample_times=t, solver="rk4", options=FIT_OPTIONS,
                           with_terminal=False)
            tr = pred.trajectory
            if tr.end_reason != "duration" or tr.time.size != t.size:
                self.failures[tr.end_reason] += 1
                return None
            return tr.speed
        i_f = vals["geneva.follower_inertia"]
        rho = vals["geneva.driver_inertia"] / i_f
        term = terminal_cycle(geo, rho, vals["geneva.mu"], 1.0, ENGINES["rk4"], FIT_OPTIONS)
        if term.status != "ok":
            self.failures[term.status] += 1
            return None
        scale = np.sqrt(vals.get(TORQUE_SCALE, 1.0) * np.asarray(self.data.torque, float) / i_f)
        return np.concatenate((term.peak_speed * scale, term.min_speed * scale))

    # ---------------------------------------------------- observation model, priors
    def log_prior(self, theta: Sequence[float]) -> float:
        """Sum of the free parameters' log priors (``-inf`` outside the bounds)."""
        return float(sum(self.priors[n].logpdf(float(v)) for n, v in zip(self.names, theta)))

    def log_likelihood(self, theta: Sequence[float], sd: float) -> float:
        """Gaussian log likelihood with standard deviation ``sd`` (rad/s)."""
        pred = self.predict(theta)
        if pred is None:
            return -math.inf
        r = (self.observed - pred) / sd
        return float(-0.5 * r @ r - r.size * math.log(sd * math.sqrt(2 * math.pi)))

    def log_prob(self, theta: Sequence[float], sd: float) -> float:
        """Log posterior up to a constant."""
        lp = self.log_prior(theta)
        if not math.isfinite(lp):
            self.failures["outside prior"] += 1
            return -math.inf
        return lp + self.log_likelihood(theta, sd)


@dataclass(frozen=True)
class LeastSquaresFit:
    """Result of :func:`fit_least_squares` (SI units).

    Attributes
    ----------
    names
        Free parameter names, in the order of ``covariance``.
    values, stderr
        Best-fit value and standard error of each free parameter.
    covariance
        Laplace covariance of the free parameters.
    sd, sd_estimated
        Noise sd used (rad/s) and whether it was estimated from the residuals.
    chisqr, ndata
        Sum of squared weighted residuals and number of data.
    success, message
        lmfit's verdict.
    """

    names: tuple[str, ...]
    values: dict[str, float]
    stderr: dict[str, float]
    covariance: np.ndarray
    sd: float
    sd_estimated: bool
    chisqr: float
    ndata: int
    success: bool
    message: str

    def interval(self, name: str, level: float = 0.95) -> tuple[float, float]:
        """Normal-approximation interval of a free parameter."""
        from scipy.stats import norm

        z = norm.ppf(0.5 + level / 2)
        return self.values[name] - z * self.stderr[name], self.values[name] + z * self.stderr[name]


def fit_least_squares(problem: GenevaProblem, *, n_starts: int = 24, n_refine: int = 3,
                      seed: int = DEFAULT_SEED) -> LeastSquaresFit:
    """Least-squares fit (lmfit, Levenberg-Marquardt within the prior bounds).

    A speed trace from rest has a rugged cost surface (a wrong period puts the speed
    oscillation out of phase), so the cost is first evaluated at the scene's values and at
    ``n_starts`` draws from the priors (seeded), and Levenberg-Marquardt is run from the
    ``n_refine`` best of them.

    When the data carry no ``sd`` the fit is done with unit weights and ``sd`` is set to
    the residual root mean square with ``ndata - nfree`` degrees of freedom.

    Raises
    ------
    FitError
        No valid start, too few data to estimate ``sd``, or no convergence.
    """
    names = problem.names
    params = lmfit.Parameters()
    for n, x0 in zip(names, problem.start):
        pr = problem.priors[n]
        params.add(safe_name(n), value=float(np.clip(x0, pr.lo, pr.hi)), min=pr.lo, max=pr.hi)
    obs = problem.observed
    sd_given = problem.data.sd

    def resid(p):
        pred = problem.predict([p[safe_name(n)].value for n in names])
        if pred is None:
            return np.full(obs.size, 1e6)
        return (obs - pred) / (sd_given or 1.0)

    # multi-start: the scene's values and prior draws, ranked by cost; LM from the best few
    rng = np.random.default_rng(seed)
    starts = [np.array([params[safe_name(n)].value for n in names])]
    draws = np.column_stack([problem.priors[n].sample(rng, n_starts) for n in names]) if n_starts else []
    starts.extend(draws)
    costs = []
    for x in starts:
        r = resid(_with(params, names, x))
        costs.append(float(r @ r))
    order = np.argsort(costs)
    if costs[order[0]] >= 1e12 * obs.size:
        raise FitError(f"the model fails at every start ({dict(problem.failures)})", problem.scene.where)
    res = None
    for i in order[:n_refine]:
        trial = lmfit.minimize(resid, _with(params, names, starts[i]), method="leastsq", scale_covar=False)
        if res is None or trial.chisqr < res.chisqr:
            res = trial
    dof = obs.size - len(names)
    if sd_given is None:
        if dof < 1:
            raise FitError(f"cannot estimate the noise sd from {obs.size} data with {len(names)} parameters",
                           problem.data.source)
        sd = float(math.sqrt(np.sum(res.residual ** 2) / dof))
        if not sd > 0:
            raise FitError("the data are fitted exactly; give sd", problem.data.source)
    else:
        sd = float(sd_given)
    factor = sd / (sd_given or 1.0)  # re-express the covariance for the final sd
    cov = (np.asarray(res.covar) * factor ** 2 if res.covar is not None
           else np.full((len(names), len(names)), np.nan))
    values = {n: float(res.params[safe_name(n)].value) for n in names}
    stderr = {n: float(math.sqrt(cov[i, i])) if np.isfinite(cov[i, i]) else math.nan for i, n in enumerate(names)}
    if not res.success:
        raise FitError(f"least squares did not converge: {res.message}", problem.scene.where)
    return LeastSquaresFit(tuple(names), values, stderr, cov, sd, sd_given is None,
                           float(np.sum((res.residual * (sd_given or 1.0) / sd) ** 2)), int(obs.size),
                           bool(res.success), str(res.message))


def sample_posterior(problem: GenevaProblem, *, start: LeastSquaresFit | None = None, nwalkers: int = 16,
                     nsteps: int = 400, burn: int = 100, seed: int = DEFAULT_SEED) -> az.InferenceData:
    """Sample the posterior with emcee (affine-invariant ensemble, fixed seed).

    Parameters
    ----------
    problem
        The fit problem.
    start
        A least-squares fit to start near and take ``sd`` from (computed when omitted).
    nwalkers, nsteps, burn
        Ensemble size, steps run, and initial steps discarded.
    seed
        Seed of the initial scatter and of emcee's generator: equal seeds, equal draws.

    Returns
    -------
    arviz.InferenceData
        ``posterior``: one variable per free parameter, dims ``(chain, draw)`` (a chain is
        a walker), SI units in ``attrs``; ``observed_data``; ``sample_stats`` with
        ``lp``; provenance (priors, sd, seed, failures, scene text) in ``posterior.attrs``.
    """
    ndim = len(problem.names)
    if nwalkers < 2 * ndim:
        raise FitError(f"nwalkers = {nwalkers} is too small for {ndim} parameters; use at least {2 * ndim}",
                       problem.scene.where)
    if not 0 <= burn < nsteps:
        raise FitError(f"burn = {burn} must lie in [0, nsteps = {nsteps})", problem.scene.where)
    fit = start if start is not None else fit_least_squares(problem)
    rng = np.random.default_rng(seed)
    centre = np.array([fit.values[n] for n in problem.names])
    scale = np.array([fit.stderr[n] for n in problem.names])
    scale = np.where(np.isfinite(scale) & (scale > 0), scale, np.abs(centre) * 1e-3 + 1e-12)
    p0 = np.empty((nwalkers, ndim))
    for i in range(nwalkers):
        for _ in range(200):
            trial = centre + 0.5 * scale * rng.standard_normal(ndim)
            if math.isfinite(problem.log_prob(trial, fit.sd)):
                p0[i] = trial
                break
        else:
            raise FitError("no valid starting point near the least-squares optimum", problem.scene.where)
    sampler = emcee.EnsembleSampler(nwalkers, ndim, problem.log_prob, args=(fit.sd,))
    sampler.random_state = np.random.RandomState(seed).get_state()
    sampler.run_mcmc(p0, nsteps, progress=False)
    chain = np.transpose(sampler.get_chain(discard=burn), (1, 0, 2))  # (chain, draw, dim)
    lp = sampler.get_log_prob(discard=burn).T
    units = {p.name: p.unit for p in problem.scene.params}
    posterior = {n: chain[:, :, j] for j, n in enumerate(problem.names)}
    obs_dim = "sample" if isinstance(problem.data, SpeedTrace) else "point"
    idata = az.from_dict(posterior=posterior, sample_stats={"lp": lp},
                         observed_data={"speed": problem.observed}, dims={"speed": [obs_dim]})
    for n in problem.names:
        idata.posterior[n].attrs.update(units=units.get(n, ""), prior=_describe(problem.priors[n]))
    idata.posterior.attrs.update(
        model="geneva", kind="posterior", data=problem.data.source, scene=problem.scene.text,
        where=problem.scene.where, noise_sd=fit.sd, noise_sd_estimated=int(fit.sd_estimated), seed=seed,
        nwalkers=nwalkers, nsteps=nsteps, burn=burn,
        acceptance_fraction=float(np.mean(sampler.acceptance_fraction)),
        failures=repr(dict(problem.failures)), escfit_version=_version(),
    )
    return idata


def synthetic_trace(scene, *, duration: float, interval: float, sd: float, seed: int = 0,
                    values: Mapping[str, float] | None = None) -> SpeedTrace:
    """A driver-speed trace simulated from a scene with Gaussian noise (for tests and studies).

    Parameters
    ----------
    scene
        Geneva scene giving the true values (overridden by ``values``).
    duration, interval
        Trace length and sample spacing, s.
    sd
        Noise standard deviation, rad/s.
    seed
        Noise seed.
    """
    vals = dict(scene.params.values())
    vals.update(values or {})
    t = np.arange(int(math.floor(duration / interval + 1e-9)) + 1) * interval
    pred = forward(scene.geometry, vals, duration=float(t[-1]), sample_times=t, solver="dop853", with_terminal=False)
    if pred.trajectory.time.size != t.size:
        raise FitError(f"the true parameters give a run that ends early ({pred.trajectory.end_reason})",
                       scene.where)
    noise = np.random.default_rng(seed).normal(0.0, sd, t.size)
    return SpeedTrace(t, pred.trajectory.speed + noise, sd, f"synthetic trace of {scene.where} (seed {seed})")


def _with(params: lmfit.Parameters, names: Sequence[str], x: Sequence[float]) -> lmfit.Parameters:
    out = params.copy()
    for n, v in zip(names, x):
        par = out[safe_name(n)]
        par.set(value=float(np.clip(v, par.min, par.max)))
    return out


def _describe(p: Prior) -> str:
    return f"{p.kind}({', '.join(f'{a:g}' for a in p.args)}) on [{p.lo:g}, {p.hi:g}]"


def _version() -> str:
    from .. import __version__

    return __version__
