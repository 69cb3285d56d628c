"""Fitting a rig session: penalised least squares (lmfit) and the posterior (emcee).

Both use the same explicit model (:mod:`escfit.friction.likelihood`):

* the least-squares objective is the negative log posterior of its Gaussian parts (reading
  residuals plus one residual per normal prior, e.g. ``(k - k_measured) / sd_k``); flat
  priors become lmfit bounds.  Its covariance is the Laplace approximation of the posterior.
  When the reading sd is not given it is re-estimated from the residual scatter until it is
  consistent with it (degrees of freedom: readings minus friction-law parameters; the
  geometry is pinned by its priors).
* the posterior is sampled with emcee's affine-invariant ensemble, started near the
  least-squares optimum with a fixed seed, and returned as :class:`arviz.InferenceData`
  with ``posterior`` (dims chain, draw), ``log_likelihood`` (per reading),
  ``observed_data``, ``constant_data`` and ``sample_stats``.
"""

from __future__ import annotations

import json
import logging
import math
import warnings
from dataclasses import dataclass, field
from importlib import metadata

import arviz as az
import emcee
import lmfit
import numpy as np
import xarray as xr

from ..core.errors import FitError
from ..core.params import safe_name
from .likelihood import SessionModel, build_model
from .readers import Readings
from .rig import lever_ratio
from .scene import RigScene

__all__ = ["LeastSquaresFit", "fit_least_squares", "sample_posterior", "DEFAULT_SEED"]

DEFAULT_SEED = 19650601
_LAW = ("friction.mu", "friction.mu_w", "friction.mu_v")


@dataclass(frozen=True)
class LeastSquaresFit:
    """Result of :func:`fit_least_squares`.

    Attributes
    ----------
    names
        Free parameter names, in the order of ``covariance``.
    values
        Best-fit value of every parameter (free and fixed), canonical units.
    stderr
        Standard error of each free parameter (and of ``reading.sd`` when estimated).
    covariance
        Covariance of the free parameters (Laplace approximation of the posterior).
    reading_sd
        Reading standard deviation used in the final weights, N.
    sd_estimated
        Whether ``reading_sd`` was estimated from the residuals.
    chisqr
        Sum of squared, weighted reading residuals (prior terms excluded).
    ndata, nlaw
        Number of readings and of friction-law parameters fitted.
    success, message
        lmfit's status.
    where
        ``scene :: data`` provenance.
    """

    names: tuple[str, ...]
    values: dict[str, float]
    stderr: dict[str, float]
    covariance: np.ndarray
    reading_sd: float
    sd_estimated: bool
    chisqr: float
    ndata: int
    nlaw: int
    success: bool
    message: str
    where: str
    units: dict[str, str] = field(default_factory=dict)

    def interval(self, name: str, level: float = 0.95) -> tuple[float, float]:
        """Normal-approximation interval of a free parameter."""
        from scipy.stats import norm

        z = norm.ppf(0.5 + level / 2)
        return (self.values[name] - z * self.stderr[name], self.values[name] + z * self.stderr[name])

    def to_dataset(self) -> xr.Dataset:
        """The fit as an xarray Dataset (one variable per parameter, stderr in attrs)."""
        ds = xr.Dataset(attrs={
            "model": "friction_rig", "kind": "least_squares", "where": self.where,
            "chisqr": self.chisqr, "ndata": self.ndata, "reading_sd": self.reading_sd,
            "sd_estimated": int(self.sd_estimated), "success": int(self.success), "message": self.message,
        })
        for n, v in self.values.items():
            ds[n] = xr.DataArray(v, attrs={"units": self.units.get(n, ""), "stderr": self.stderr.get(n, np.nan),
                                           "free": int(n in self.names)})
        return ds


def fit_least_squares(scene: RigScene, readings: Readings, *, max_iter: int = 50) -> LeastSquaresFit:
    """Penalised least-squares fit of one session.

    Parameters
    ----------
    scene
        Parsed ``friction_rig`` scene (geometry priors, friction law, reading sd).
    readings
        One session (one material, one set-up).
    max_iter
        Maximum number of re-weighting passes when the reading sd is estimated.

    Returns
    -------
    LeastSquaresFit

    Raises
    ------
    FitError
        Inconsistent scene and data, too few readings to estimate the reading sd, or an
        optimiser failure.
    """
    model = build_model(scene, readings)
    names = [n for n in model.names if n != "reading.sd"]
    estimate_sd = "reading.sd" in model.names
    nlaw = sum(n in names for n in _LAW)
    n = len(readings)
    if not names:
        raise FitError("only the reading sd varies; free friction.mu or give k and d an sd", scene.where)
    if estimate_sd and n - nlaw < 1:
        raise FitError(
            f"cannot estimate the reading sd from {n} reading(s) with {nlaw} friction-law parameter(s); "
            f"give [reading] sd or resolution in the scene", scene.where)
    sd = _initial_sd(model) if estimate_sd else model.fixed["reading.sd"]
    params = lmfit.Parameters()
    start = _initial_values(model)
    for name in names:
        lo, hi = scene.priors[name].lo, scene.priors[name].hi
        params.add(safe_name(name), value=float(np.clip(start[name], lo, hi)), min=lo, max=hi)
    result = None
    for _ in range(max_iter if estimate_sd else 1):
        result = lmfit.minimize(_residual, params, args=(model, names, sd), scale_covar=False,
                                nan_policy="raise")
        params = result.params
        if not estimate_sd:
            break
        data_resid = _residual(params, model, names, 1.0)[:n]
        new_sd = float(math.sqrt(np.sum(data_resid**2) / (n - nlaw)))
        if not new_sd > 0:
            raise FitError("the readings are fitted exactly; the reading sd cannot be estimated", readings.where)
        done = abs(new_sd - sd) <= 1e-9 * sd
        sd = new_sd
        if done:
            break
    if not result.success:
        raise FitError(f"least squares did not converge: {result.message}", f"{scene.where} :: {readings.where}")
    values = dict(model.fixed)
    stderr: dict[str, float] = {}
    for name in names:
        par = result.params[safe_name(name)]
        values[name] = float(par.value)
        stderr[name] = float(par.stderr) if par.stderr is not None else math.nan
    values["reading.sd"] = sd
    if estimate_sd:
        stderr["reading.sd"] = sd / math.sqrt(2.0 * (n - nlaw))
    cov = np.asarray(result.covar) if result.covar is not None else np.full((len(names), len(names)), np.nan)
    data_resid = _residual(result.params, model, names, sd)[:n]
    return LeastSquaresFit(
        names=tuple(names), values=values, stderr=stderr, covariance=cov, reading_sd=sd,
        sd_estimated=estimate_sd, chisqr=float(np.sum(data_resid**2)), ndata=n, nlaw=nlaw,
        success=bool(result.success) and result.covar is not None, message=str(result.message),
        where=f"{scene.where} :: {readings.where}", units={p.name: p.unit for p in scene.params},
    )


def _residual(params: lmfit.Parameters, model: SessionModel, names: list[str], sd: float) -> np.ndarray:
    theta = _theta(model, {n: params[safe_name(n)].value for n in names}, sd)
    pred = model.predict(theta)[0]
    resid = [(model.readings.dw - pred) / sd]
    for name in names:
        prior = model.scene.priors[name]
        x = params[safe_name(name)].value
        if prior.kind == "normal":
            resid.append(np.array([(x - prior.args[0]) / prior.args[1]]))
        elif prior.kind == "halfnormal":
            resid.append(np.array([x / prior.args[0]]))
    out = np.concatenate(resid)
    # an impossible point (negative mu, friction out-levering the load) is far from the data
    return np.where(np.isfinite(out), out, 1e6)


def _theta(model: SessionModel, values: dict[str, float], sd: float) -> np.ndarray:
    row = [values[n] if n != "reading.sd" else sd for n in model.names]
    return np.array([row])


def _initial_values(model: SessionModel) -> dict[str, float]:
    """Scene values, with mu started from the readings at the nominal geometry."""
    from .rig import mu_from_reading

    start = dict(model.fixed)
    r = model.readings
    mu_each = mu_from_reading(r.load, r.dw, model.fixed["rig.k"], model.fixed["rig.d"], model.scene.load_at)
    if "friction.mu" in model.names:
        start["friction.mu"] = float(np.median(mu_each))
    return start


def _initial_sd(model: SessionModel) -> float:
    spread = float(np.std(model.readings.dw))
    return spread if spread > 0 else max(float(np.mean(model.readings.dw)) * 1e-3, 1e-9)


def sample_posterior(
    scene: RigScene,
    readings: Readings,
    *,
    nwalkers: int = 32,
    nsteps: int = 3000,
    burn: int = 1000,
    thin: int = 1,
    seed: int = DEFAULT_SEED,
    start: LeastSquaresFit | None = None,
) -> az.InferenceData:
    """Sample the posterior of one session with emcee.

    Parameters
    ----------
    scene, readings
        As for :func:`fit_least_squares`.
    nwalkers
        Ensemble size (at least twice the number of free parameters).
    nsteps, burn, thin
        Steps run, initial steps discarded, and thinning of the kept steps.
    seed
        Seed of the initial scatter and of emcee's generator; equal seeds give equal draws.
    start
        A least-squares fit to start from (computed when omitted).

    Returns
    -------
    arviz.InferenceData
        ``posterior`` holds one variable per free parameter (canonical units in ``attrs``)
        and the derived ``rig.lever_ratio`` (a/d); dims ``(chain, draw)`` where a chain is
        one walker.  ``log_likelihood["dw"]`` has dims ``(chain, draw, reading)``.

    Raises
    ------
    FitError
        Inconsistent inputs, too few walkers, ``burn >= nsteps``, or no valid start.
    """
    model = build_model(scene, readings)
    ndim = model.ndim
    if nwalkers < 2 * ndim:
        raise FitError(f"nwalkers = {nwalkers} is too small for {ndim} parameters; use at least {2 * ndim}", scene.where)
    if not 0 <= burn < nsteps:
        raise FitError(f"burn = {burn} must lie in [0, nsteps = {nsteps})", scene.where)
    fit = start if start is not None else fit_least_squares(scene, readings)
    rng = np.random.default_rng(seed)
    p0 = _initial_ensemble(model, fit, nwalkers, rng)
    sampler = emcee.EnsembleSampler(nwalkers, ndim, model.log_prob, vectorize=True)
    sampler.random_state = np.random.RandomState(seed).get_state()
    sampler.run_mcmc(p0, nsteps, progress=False)
    chain = sampler.get_chain(discard=burn, thin=thin)  # (draw, walker, dim)
    lp = sampler.get_log_prob(discard=burn, thin=thin)
    samples = np.transpose(chain, (1, 0, 2))  # (chain, draw, dim)
    flat = samples.reshape(-1, ndim)
    tau = _autocorr_time(sampler, burn)
    return _to_inference_data(model, samples, flat, lp.T, tau, sampler, dict(
        seed=seed, nwalkers=nwalkers, nsteps=nsteps, burn=burn, thin=thin))


def _autocorr_time(sampler, burn: int) -> np.ndarray:
    """Integrated autocorrelation time per parameter, in steps (recorded, not printed)."""
    log = logging.getLogger("emcee")
    level = log.level
    log.setLevel(logging.ERROR)  # a short-chain caveat is recorded in attrs instead
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return np.asarray(sampler.get_autocorr_time(discard=burn, quiet=True), dtype=float)
    finally:
        log.setLevel(level)


def _initial_ensemble(model: SessionModel, fit: LeastSquaresFit, nwalkers: int, rng) -> np.ndarray:
    centre = np.array([fit.values[n] for n in model.names])
    scale = np.array([fit.stderr.get(n, math.nan) for n in model.names])
    scale = np.where(np.isfinite(scale) & (scale > 0), scale, np.abs(centre) * 1e-3 + 1e-12)
    out = np.empty((nwalkers, model.ndim))
    for i in range(nwalkers):
        for _ in range(1000):
            trial = centre + 0.1 * scale * rng.standard_normal(model.ndim)
            if np.isfinite(model.log_prob(trial)[0]):
                out[i] = trial
                break
        else:
            raise FitError("no valid starting point near the least-squares optimum", model.scene.where)
    return out


def _to_inference_data(model: SessionModel, samples, flat, lp, tau, sampler, run: dict) -> az.InferenceData:
    nchain, ndraw, _ = samples.shape
    units = {p.name: p.unit for p in model.scene.params}
    posterior = {n: samples[:, :, j] for j, n in enumerate(model.names)}
    values = model.unpack(flat)
    posterior["rig.lever_ratio"] = np.asarray(lever_ratio(values["rig.k"], values["rig.d"])).reshape(nchain, ndraw)
    loglik = model.pointwise_loglik(flat).reshape(nchain, ndraw, -1)
    r = model.readings
    constant = {"load": r.load}
    if r.speed is not None:
        constant["speed"] = r.speed
    reading = np.arange(len(r))
    priors = {n: model.scene.priors[n].describe() for n in model.names}
    attrs = {
        "model": "friction_rig",
        "kind": "posterior",
        "scene_file": model.scene.where,
        "scene": model.scene.text,
        "data_file": r.where,
        "load_at": model.scene.load_at,
        "load_ref_N": model.scene.load_ref,
        "speed_ref_m_s": model.scene.speed_ref,
        "reading_note": model.scene.reading_note,
        "priors": json.dumps(priors),
        "free": json.dumps(list(model.names)),
        "sampler": "emcee.EnsembleSampler (stretch move, vectorised)",
        "acceptance_fraction": float(np.mean(sampler.acceptance_fraction)),
        "autocorr_time": json.dumps([float(t) for t in tau]),
        "draws_per_autocorr_time": float(samples.shape[1] * run["thin"] / np.max(tau)),
        "versions": json.dumps(_versions()),
        "schema_version": 1,
        **run,
    }
    idata = az.from_dict(
        posterior=posterior,
        log_likelihood={"dw": loglik},
        observed_data={"dw": r.dw},
        constant_data=constant,
        sample_stats={"lp": lp},
        coords={"reading": reading},
        dims={"dw": ["reading"], "load": ["reading"], "speed": ["reading"]},
        attrs=attrs,
    )
    for n in model.names:
        idata.posterior[n].attrs["units"] = units.get(n, "")
        idata.posterior[n].attrs["prior"] = priors[n]
    idata.posterior["rig.lever_ratio"].attrs["units"] = ""
    for group in ("observed_data", "constant_data"):
        ds = getattr(idata, group)
        for v in ds.data_vars:
            ds[v].attrs["units"] = "m/s" if v == "speed" else "N"
    return idata


def _versions() -> dict[str, str]:
    out = {}
    for pkg in ("escfit", "numpy", "emcee", "lmfit", "arviz"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "unknown"
    return out
