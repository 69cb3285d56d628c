"""Friction coefficients of a verge S&A mechanism from observed turns-to-arm.

Data model
----------
An observation is one arming test: the spin rate (rpm), the number of fuze revolutions the
mechanism needed to arm, and the standard deviation of that number (measurement scatter,
rounding of a published figure, model discrepancy -- stated by whoever supplies the data).
The likelihood is Gaussian in turns::

    turns_i ~ Normal(T(theta, spin_i), sd_i)

with ``T`` the simulated turns-to-arm (:func:`escfit.verge.forward`).  A parameter set for
which the simulation does not arm (stall, time limit) has likelihood zero; the sampler
records why (``sample_stats.forward_status``).

Parameters are ``verge.mu`` (gear train) and ``verge.mu1`` (escapement).  The report speaks
of one "system coefficient of friction": with ``tie_mu1=True`` (default) ``mu1 = mu`` and
only ``verge.mu`` is estimated.  Estimating both from turns-to-arm alone is possible but
they trade off against each other (a ridge in the posterior): turns-to-arm measures a
combination of the two.

Spin rate
---------
Every load in the model is proportional to ``omega**2``, so with a coefficient of
restitution of zero the turns-to-arm do not depend on the spin rate at all (the motion is
the same in terms of fuze revolutions).  The forward model then simulates once per
parameter set; several spin rates act as replicates.  With ``restitution > 0`` the fixed
capture speed after an impact breaks the invariance and each spin rate is simulated.

Fitting
-------
:func:`fit_least_squares` minimises the weighted residuals with lmfit (bounds from the
priors); its covariance is the Laplace approximation.  :func:`sample_posterior` samples the
posterior with emcee (explicit priors, fixed seed), started near the least-squares optimum,
and returns :class:`arviz.InferenceData`.
"""

from __future__ import annotations

import csv
import logging
import math
import warnings
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Mapping, Sequence

import arviz as az
import emcee
import lmfit
import numpy as np

from ..core.errors import DataError, FitError, SceneError
from ..likelihood.priors import Prior, prior_of
from ..core.params import Param, safe_name
from .scene import VergeScene
from .simulate import forward

__all__ = [
    "TurnsData", "TurnsProblem", "LeastSquaresFit", "read_turns_csv", "synthetic_turns", "fit_least_squares",
    "sample_posterior", "credible_interval", "DEFAULT_PRIORS", "DEFAULT_SEED", "FIT_STEP",
]

DEFAULT_SEED = 1982
#: explicit default priors: friction coefficients of lubricated steel/brass between 0 and 0.3
DEFAULT_PRIORS = {"verge.mu": "uniform(0, 0.3)", "verge.mu1": "uniform(0, 0.3)"}
#: RK4 step (rad of spin) used by fits: turns-to-arm within 1e-7 of the converged value
FIT_STEP = 0.04
_STATUS = {"armed": 0, "not_armed": 1, "failed": 2}


@dataclass(frozen=True)
class TurnsData:
    """Observed turns-to-arm.

    Attributes
    ----------
    spin_rpm, turns, sd : numpy.ndarray
        Spin rate (rpm), observed turns to arm and their standard deviation (turns).
    labels : tuple of str
        One label per observation.
    source : str
        Where the numbers come from.
    """

    spin_rpm: np.ndarray
    turns: np.ndarray
    sd: np.ndarray
    labels: tuple[str, ...]
    source: str = ""

    def __post_init__(self):
        n = len(self.labels)
        for name in ("spin_rpm", "turns", "sd"):
            arr = np.asarray(getattr(self, name), dtype=float)
            if arr.shape != (n,):
                raise DataError(f"{name} has {arr.size} values for {n} labels", self.source or "TurnsData")
            if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
                bad = arr[~(np.isfinite(arr) & (arr > 0))][0]
                raise DataError(f"{name} must be positive and finite, got {bad!r}", self.source or "TurnsData")
            object.__setattr__(self, name, arr)

    def subset(self, index: Sequence[int]) -> "TurnsData":
        """The observations at the given positions."""
        idx = list(index)
        return TurnsData(self.spin_rpm[idx], self.turns[idx], self.sd[idx], tuple(self.labels[i] for i in idx),
                         self.source)


def read_turns_csv(path: str | Path) -> TurnsData:
    """Read a CSV with columns ``label, spin_rpm, turns, sd`` (``#`` lines are comments).

    Other columns are allowed and ignored.

    Raises
    ------
    DataError
        Missing file or columns, or a value that is not a positive number (message names
        the file, line and column).
    """
    path = Path(path)
    if not path.is_file():
        raise DataError("turns-to-arm file not found", str(path))
    lines = [ln for ln in path.read_text(encoding="utf-8").splitlines() if ln.strip() and not ln.startswith("#")]
    reader = csv.DictReader(lines)
    need = {"label", "spin_rpm", "turns", "sd"}
    if reader.fieldnames is None or not need <= set(reader.fieldnames):
        raise DataError(f"needs columns {sorted(need)}, has {reader.fieldnames}", str(path))
    labels, cols = [], {k: [] for k in ("spin_rpm", "turns", "sd")}
    for i, row in enumerate(reader, start=2):
        labels.append(row["label"])
        for key in cols:
            try:
                cols[key].append(float(row[key]))
            except (TypeError, ValueError):
                raise DataError(f"column {key!r}: {row[key]!r} is not a number", f"{path}:{i}") from None
    if not labels:
        raise DataError("no observations", str(path))
    return TurnsData(np.array(cols["spin_rpm"]), np.array(cols["turns"]), np.array(cols["sd"]), tuple(labels),
                     str(path))


def _free_params(scene: VergeScene, free: Sequence[str], tie_mu1: bool, priors: Mapping[str, str]):
    if not free:
        raise FitError("nothing to fit: give at least one free parameter", "free")
    for name in free:
        if name not in scene.params:
            raise FitError(f"unknown parameter {name!r}; the scene has {sorted(p.name for p in scene.params)}",
                           "free")
    if tie_mu1 and "verge.mu1" in free:
        raise FitError("verge.mu1 cannot be free while tied to verge.mu (tie_mu1=True)", "free")
    out = []
    for name in free:
        p = scene.params[name]
        spec = priors.get(name)
        if spec is None:
            raise FitError(f"no prior for {name!r}: give one explicitly (e.g. 'uniform(0, 0.3)')", "priors")
        out.append(prior_of(Param(name, p.value, p.unit, p.meaning, True, p.min, p.max, spec), f"priors[{name}]"))
    return out


@dataclass(frozen=True)
class TurnsProblem:
    """Scene + data + free parameters + priors: the pieces of the posterior.

    Parameters
    ----------
    scene : VergeScene
        Everything not estimated is taken from here.
    data : TurnsData
    free : sequence of str
        Estimated parameters, default ``("verge.mu",)``.
    tie_mu1 : bool
        Keep ``verge.mu1`` equal to ``verge.mu`` (the report's system coefficient).
    priors : mapping
        Prior string per free parameter (see :mod:`escfit.likelihood.priors`); defaults to
        :data:`DEFAULT_PRIORS`.
    step : float
        RK4 step of the forward model (rad of spin).
    """

    scene: VergeScene
    data: TurnsData
    free: tuple[str, ...] = ("verge.mu",)
    tie_mu1: bool = True
    priors: Mapping[str, str] = field(default_factory=lambda: dict(DEFAULT_PRIORS))
    step: float = FIT_STEP

    def __post_init__(self):
        object.__setattr__(self, "free", tuple(self.free))
        object.__setattr__(self, "_priors", _free_params(self.scene, self.free, self.tie_mu1, self.priors))

    @property
    def prior_objects(self) -> list[Prior]:
        """Parsed priors, in the order of :attr:`free`."""
        return self._priors  # type: ignore[attr-defined]

    def values(self, theta: Sequence[float]) -> dict[str, float]:
        """Parameter values (SI) for a vector of free parameters."""
        vals = {name: float(x) for name, x in zip(self.free, theta)}
        if self.tie_mu1:
            vals["verge.mu1"] = vals.get("verge.mu", self.scene.params["verge.mu"].value)
        return vals

    def predict(self, theta: Sequence[float]) -> tuple[np.ndarray, int]:
        """Simulated turns-to-arm per observation and a status code (0 armed, 1 not, 2 failed).

        Not-armed predictions, and parameter values outside their physical range, are NaN.
        """
        vals = self.values(theta)
        restitution = vals.get("verge.restitution", self.scene.params["verge.restitution"].value)
        spins = np.unique(self.data.spin_rpm) if restitution > 0 else self.data.spin_rpm[:1]
        out: dict[float, float] = {}
        status = 0
        for rpm in spins:
            try:
                p = forward(self.scene, dict(vals, **{"verge.spin": rpm * math.pi / 30}), step=self.step)
            except SceneError:
                # a prior reaching outside the physical range: no prediction, zero likelihood
                status = _STATUS["failed"]
                out[float(rpm)] = math.nan
                continue
            status = max(status, _STATUS[p.status])
            out[float(rpm)] = p.turns_to_arm if p.status == "armed" else math.nan
        if restitution > 0:
            return np.array([out[float(r)] for r in self.data.spin_rpm]), status
        return np.full(self.data.turns.shape, out[float(spins[0])]), status

    def log_prior(self, theta: Sequence[float]) -> float:
        return float(sum(pr.logpdf(float(x)) for pr, x in zip(self.prior_objects, theta)))

    def log_likelihood(self, prediction: np.ndarray) -> np.ndarray:
        """Pointwise Gaussian log-likelihood of the observations given a prediction."""
        d = self.data
        z = (d.turns - prediction) / d.sd
        ll = -0.5 * z * z - np.log(d.sd * math.sqrt(2 * math.pi))
        return np.where(np.isfinite(prediction), ll, -np.inf)


def synthetic_turns(scene: VergeScene, truth: Mapping[str, float], spins_rpm: Sequence[float], sd: float, *,
                    seed: int = DEFAULT_SEED, tie_mu1: bool = True) -> TurnsData:
    """Simulated observations with Gaussian noise, for recovery tests.

    ``truth`` gives parameter values (``verge.mu``, optionally ``verge.mu1``); each spin rate
    yields one observation ``turns + Normal(0, sd)``.
    """
    vals = dict(truth)
    if tie_mu1 and "verge.mu1" not in vals and "verge.mu" in vals:
        vals["verge.mu1"] = vals["verge.mu"]
    rng = np.random.default_rng(seed)
    turns = []
    for rpm in spins_rpm:
        p = forward(scene, dict(vals, **{"verge.spin": rpm * math.pi / 30}), step=FIT_STEP)
        if p.status != "armed":
            raise FitError(f"the true parameters {dict(truth)} do not arm at {rpm} rpm ({p.status})", "truth")
        turns.append(p.turns_to_arm + rng.normal(0.0, sd))
    n = len(turns)
    return TurnsData(np.asarray(spins_rpm, float), np.array(turns), np.full(n, float(sd)),
                     tuple(f"synthetic {i + 1}" for i in range(n)),
                     f"synthetic: truth {dict(truth)}, sd {sd}, seed {seed}")


@dataclass(frozen=True)
class LeastSquaresFit:
    """Result of :func:`fit_least_squares`.

    Attributes
    ----------
    names : tuple of str
        Free parameters.
    best : numpy.ndarray
        Best-fit values.
    stderr : numpy.ndarray
        Standard errors from the covariance (NaN when lmfit could not estimate it).
    covariance : numpy.ndarray
        Covariance (Laplace approximation of the posterior under flat priors).
    chisqr : float
        Sum of squared weighted residuals.
    prediction : numpy.ndarray
        Simulated turns at the optimum, per observation.
    """

    names: tuple[str, ...]
    best: np.ndarray
    stderr: np.ndarray
    covariance: np.ndarray
    chisqr: float
    prediction: np.ndarray


def fit_least_squares(problem: TurnsProblem, start: Mapping[str, float] | None = None) -> LeastSquaresFit:
    """Weighted least squares with lmfit; bounds are the priors' supports.

    A parameter set that does not arm gets a residual of 1e3 standard deviations per
    observation (so the optimiser turns back) -- not a NaN, which lmfit cannot handle.
    """
    params = lmfit.Parameters()
    for name, pr in zip(problem.free, problem.prior_objects):
        x0 = (start or {}).get(name, problem.scene.params[name].value)
        lo, hi = pr.lo, pr.hi
        x0 = min(max(x0, lo + 1e-6 * (hi - lo)), hi - 1e-6 * (hi - lo)) if math.isfinite(hi - lo) else x0
        params.add(safe_name(name), value=x0, min=lo, max=hi)

    def residual(p):
        theta = [p[safe_name(n)].value for n in problem.free]
        pred, _ = problem.predict(theta)
        r = (pred - problem.data.turns) / problem.data.sd
        return np.where(np.isfinite(r), r, 1e3)

    # the standard deviations are given, so the covariance is not rescaled by the residuals
    res = lmfit.minimize(residual, params, method="leastsq", epsfcn=1e-8, scale_covar=False)
    names = problem.free
    best = np.array([res.params[safe_name(n)].value for n in names])
    stderr = np.array([res.params[safe_name(n)].stderr or math.nan for n in names], dtype=float)
    cov = res.covar if res.covar is not None else np.full((len(names), len(names)), math.nan)
    pred, _ = problem.predict(best)
    return LeastSquaresFit(names, best, stderr, np.asarray(cov), float(res.chisqr), pred)


def sample_posterior(problem: TurnsProblem, *, walkers: int = 16, steps: int = 400, burn: int | None = None,
                     seed: int = DEFAULT_SEED, lsq: LeastSquaresFit | None = None) -> az.InferenceData:
    """Sample the posterior of the free parameters with emcee.

    Parameters
    ----------
    problem : TurnsProblem
    walkers, steps : int
        Ensemble size and chain length.
    burn : int, optional
        Steps discarded at the start (default: a quarter of ``steps``).
    seed : int
        Seeds the initial scatter and emcee's generator; equal seeds give equal draws.
    lsq : LeastSquaresFit, optional
        Starting point (computed when not given).

    Returns
    -------
    arviz.InferenceData
        ``posterior``: the free parameters (dotted names) and ``turns_model`` (simulated
        turns per observation); ``log_likelihood``: ``turns`` per observation;
        ``observed_data``: ``turns``; ``constant_data``: ``sd`` and ``spin_rpm``;
        ``sample_stats``: ``lp`` and ``forward_status`` (0 armed, 1 not armed, 2 failed);
        attributes record priors, tie, seed, sampler settings and package versions.
    """
    ndim = len(problem.free)
    if walkers < 2 * ndim or walkers % 2:
        raise FitError(f"walkers must be even and at least {2 * ndim}, got {walkers}", "sample_posterior(walkers=...)")
    if steps < 2:
        raise FitError(f"steps must be at least 2, got {steps}", "sample_posterior(steps=...)")
    burn = steps // 4 if burn is None else burn
    if not 0 <= burn < steps:
        raise FitError(f"burn must lie in [0, {steps}), got {burn}", "sample_posterior(burn=...)")
    lsq = lsq or fit_least_squares(problem)
    rng = np.random.default_rng(seed)
    p0 = _start(problem, lsq, walkers, rng)
    nobs = problem.data.turns.size

    def log_prob(theta):
        lp = problem.log_prior(theta)
        if not math.isfinite(lp):
            return -math.inf, np.full(nobs, math.nan), np.full(nobs, -math.inf), -1
        pred, status = problem.predict(theta)
        ll = problem.log_likelihood(pred)
        total = lp + float(ll.sum())
        return (total if math.isfinite(total) else -math.inf), pred, ll, status

    sampler = emcee.EnsembleSampler(walkers, ndim, log_prob,
                                    blobs_dtype=[("pred", float, (nobs,)), ("ll", float, (nobs,)), ("status", int)])
    sampler.random_state = np.random.RandomState(seed).get_state()
    sampler.run_mcmc(p0, steps, progress=False)
    chain = sampler.get_chain(discard=burn)  # (draw, walker, ndim)
    blobs = sampler.get_blobs(discard=burn)
    lp = sampler.get_log_prob(discard=burn)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        logging.getLogger("emcee").setLevel(logging.ERROR)
        tau = sampler.get_autocorr_time(quiet=True, discard=burn) if steps - burn > 10 else np.full(ndim, np.nan)
    return _inference_data(problem, chain, blobs, lp, sampler, tau, dict(
        seed=seed, walkers=walkers, steps=steps, burn=burn))


def _start(problem: TurnsProblem, lsq: LeastSquaresFit, walkers: int, rng: np.random.Generator) -> np.ndarray:
    out = np.empty((walkers, len(problem.free)))
    for j, pr in enumerate(problem.prior_objects):
        centre = lsq.best[j]
        spread = lsq.stderr[j] if np.isfinite(lsq.stderr[j]) and lsq.stderr[j] > 0 else 0.01 * (pr.hi - pr.lo)
        x = centre + spread * rng.standard_normal(walkers)
        out[:, j] = np.clip(x, pr.lo + 1e-9 * (pr.hi - pr.lo), pr.hi - 1e-9 * (pr.hi - pr.lo))
    return out


def _inference_data(problem, chain, blobs, lp, sampler, tau, run) -> az.InferenceData:
    d = problem.data
    # arviz wants (chain, draw, ...): emcee walkers are the chains
    posterior = {name: chain[:, :, j].T for j, name in enumerate(problem.free)}
    posterior["turns_model"] = np.transpose(blobs["pred"], (1, 0, 2))
    coords = {"obs": list(d.labels)}
    dims = {"turns_model": ["obs"], "turns": ["obs"], "sd": ["obs"], "spin_rpm": ["obs"]}
    versions = {}
    for pkg in ("escfit", "numpy", "emcee", "lmfit", "arviz"):
        try:
            versions[f"version_{pkg}"] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[f"version_{pkg}"] = "unknown"
    attrs = {
        "model": "verge",
        "likelihood": "turns_i ~ Normal(simulated turns-to-arm at spin_i, sd_i); not armed -> zero likelihood",
        "free": ", ".join(problem.free),
        "tie_mu1": int(problem.tie_mu1),
        "priors": "; ".join(f"{n}: {problem.priors[n]}" for n in problem.free),
        "forward_step": problem.step,
        "scene_file": problem.scene.where,
        "data_source": d.source,
        "sampler": "emcee.EnsembleSampler (stretch move)",
        "acceptance_fraction": float(np.mean(sampler.acceptance_fraction)),
        "autocorr_time": ", ".join(f"{t:.3g}" for t in np.atleast_1d(tau)),
        **run,
        **versions,
    }
    idata = az.from_dict(
        posterior=posterior,
        log_likelihood={"turns": np.transpose(blobs["ll"], (1, 0, 2))},
        observed_data={"turns": d.turns},
        constant_data={"sd": d.sd, "spin_rpm": d.spin_rpm},
        sample_stats={"lp": lp.T, "forward_status": blobs["status"].T},
        coords=coords,
        dims=dims,
        attrs=attrs,
    )
    return idata


def credible_interval(idata: az.InferenceData, name: str, prob: float = 0.95) -> tuple[float, float]:
    """Equal-tailed credible interval of a posterior variable."""
    x = idata.posterior[name].values.ravel()
    a = (1.0 - prob) / 2
    lo, hi = np.quantile(x, [a, 1.0 - a])
    return float(lo), float(hi)
