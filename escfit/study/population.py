"""The population a fleet is drawn from, estimated from the per-unit posteriors.

Each unit i was fitted on its own with prior pi(theta).  If the units come from a
population p(theta | phi) -- here log-normal, independent in C, R and X with log-medians
``mu`` and log-sds ``tau`` -- the marginal likelihood of the hyperparameters is, up to a
constant, the product over units of

    L_i(phi) = E_{theta ~ posterior_i} [ p(theta | phi) / pi(theta) ],

estimated by averaging over the stored draws (hierarchical reweighting: Hogg, Myers & Bovy
2010).  The hyperparameters are sampled with emcee under flat priors on ``mu`` (within the
per-unit prior's support) and half-normal priors on ``tau``.  The estimate is good when each
unit's draws cover where the population puts the unit: the effective number of draws per unit
is reported and a warning given when it is small.

Unit-to-unit scatter ``tau`` is set against measurement noise ``s`` (the typical posterior
sd of log theta of one unit): the intraclass fraction ``tau^2 / (tau^2 + s^2)`` says how much
of the spread one sees between units' estimates is real.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np
import xarray as xr
from scipy.special import logsumexp

from ..core.errors import FitError, ResultsError
from ..inference.mcmc import run_emcee
from ..likelihood.problem import ProblemBase
from ..results import FitResult, clean_attrs
from .scenes import POPULATION_PARAMS

__all__ = ["UnitDraws", "collect_draws", "PopulationResult", "fit_population", "POPULATION_SCHEMA",
           "load_population"]

POPULATION_SCHEMA = "escfit-population/1"


@dataclass
class UnitDraws:
    """Per-unit posterior draws of the population parameters and their prior density.

    Attributes
    ----------
    units
        Unit names.
    names
        Parameter names (e.g. ``viscous.C``).
    theta
        Draws, shape (units, draws, names); canonical units, all positive.
    log_prior
        Log density of the per-unit fit prior at each draw, shape (units, draws).
    bounds
        Prior support (lo, hi) of each parameter.
    sigma
        Posterior median of the reading jitter ``observation.sigma`` per unit (rad), or nan.
    """

    units: list[str]
    names: list[str]
    theta: np.ndarray
    log_prior: np.ndarray
    bounds: list[tuple[float, float]]
    sigma: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def log_theta(self) -> np.ndarray:
        return np.log(self.theta)

    def measurement_sd(self) -> np.ndarray:
        """Per unit and parameter: posterior sd of log theta, shape (units, names)."""
        return self.log_theta.std(axis=1, ddof=1)


def _result_files(results) -> list:
    if isinstance(results, (str, Path)) and Path(results).is_dir():
        files = sorted(p for p in Path(results).glob("*.h5"))
        if not files:
            raise ResultsError("no results files (*.h5) in the directory", str(results))
        return files
    if isinstance(results, (str, Path, FitResult)):
        return [results]
    return list(results)


def collect_draws(results: str | Path | Iterable[str | Path | FitResult], *,
                  names: Sequence[str] = POPULATION_PARAMS, max_draws: int = 500,
                  units: Sequence[str] | None = None) -> UnitDraws:
    """Read the posterior draws of ``names`` from per-unit results files.

    Parameters
    ----------
    results
        A results directory (every ``*.h5``), or files / :class:`FitResult` objects; each
        must hold a posterior (``method = "emcee"``).
    names
        Parameters the population describes; each must be free in every fit.
    max_draws
        Draws kept per unit (evenly thinned over walkers and steps).
    units
        Keep only these units (by file stem), in this order.

    Raises
    ------
    ResultsError
        A file has no posterior, misses a parameter or holds non-positive draws.
    """
    from ..likelihood.priors import prior_of
    from ..core.scene import load_scene

    items = _result_files(results)
    labels = [Path(r.path).stem if isinstance(r, FitResult) else Path(r).stem for r in items]
    if units is not None:
        by = dict(zip(labels, items))
        missing = [u for u in units if u not in by]
        if missing:
            raise ResultsError(f"no results for unit(s) {missing}")
        labels, items = list(units), [by[u] for u in units]
    thetas, lps, sig = [], [], []
    bounds = None
    for label, item in zip(labels, items):
        f = item if isinstance(item, FitResult) else _PosteriorOnly.read(item)
        post = f.group("posterior")
        if post is None:
            raise ResultsError("no posterior draws (fit with method = 'emcee')", f.path or label)
        missing = [n for n in names if n not in post]
        if missing:
            raise ResultsError(f"posterior lacks {missing}; it has {list(post.data_vars)}", f.path or label)
        flat = np.stack([post[n].values.reshape(-1) for n in names], axis=1)
        idx = np.unique(np.linspace(0, flat.shape[0] - 1, min(max_draws, flat.shape[0])).astype(int))
        if idx.size < max_draws:  # keep every unit's array the same length
            idx = np.resize(idx, max_draws)
        flat = flat[idx]
        if not np.all(flat > 0):
            raise ResultsError("population parameters must be positive in every draw", f.path or label)
        scene = load_scene(f.attrs.get("scene_file") or label, text=f.attrs["scene"])
        priors = [prior_of(scene.params[n], allow_improper=True) for n in names]
        lp = np.array([[p.logpdf(float(v)) for p, v in zip(priors, row)] for row in flat]).sum(axis=1)
        if not np.all(np.isfinite(lp)):
            raise ResultsError("draws outside the fit's prior support", f.path or label)
        b = [(p.lo, p.hi) for p in priors]
        bounds = b if bounds is None else [(max(a[0], c[0]), min(a[1], c[1])) for a, c in zip(bounds, b)]
        thetas.append(flat)
        lps.append(lp)
        sig.append(float(np.median(post["observation.sigma"].values)) if "observation.sigma" in post else math.nan)
    return UnitDraws(labels, list(names), np.stack(thetas), np.stack(lps), bounds, np.array(sig))


@dataclass
class _PosteriorOnly:
    """The root attributes and posterior group of a results file (reading every group is slow)."""

    attrs: dict
    posterior: xr.Dataset | None
    path: str

    def group(self, name: str) -> xr.Dataset | None:
        return self.posterior if name == "posterior" else None

    @classmethod
    def read(cls, path: str | Path) -> "_PosteriorOnly":
        from ..results import SCHEMA_VERSION

        from ..results import check_results_file

        p = Path(path)
        if not p.is_file():
            raise ResultsError("results file not found", str(p))
        check_results_file(p)  # the layout, from its metadata, before any array is read
        attrs: dict = {}
        try:
            with xr.open_dataset(p, engine="h5netcdf") as root:
                attrs = dict(root.attrs)
            with xr.open_dataset(p, group="posterior", engine="h5netcdf") as post:
                posterior = post.load()
        except OSError as exc:
            if "posterior" in str(exc) and attrs.get("schema_version") == SCHEMA_VERSION:
                return cls(attrs, None, str(p))
            raise ResultsError(f"cannot read as an HDF5 results file ({type(exc).__name__}: {exc})", str(p)) from None
        except Exception as exc:  # noqa: BLE001 - any unreadable file becomes one message
            raise ResultsError(f"cannot read as an HDF5 results file ({type(exc).__name__}: {exc})", str(p)) from None
        if attrs.get("schema_version") != SCHEMA_VERSION:
            raise ResultsError(f"not an escfit fit file of schema {SCHEMA_VERSION!r}", str(p))
        return cls(attrs, posterior, str(p))


def _half_normal_logpdf(x: np.ndarray, scale: float) -> np.ndarray:
    return np.where(x > 0, -0.5 * (x / scale) ** 2, -np.inf)


class _Posterior:
    """log p(mu, tau | all units), vectorised over walkers.

    The Gaussian exponent sum_j ((y_j - mu_j) / tau_j)^2 is linear in (y_j^2, y_j, 1), so one
    matrix product evaluates it for every draw and walker at once.
    """

    def __init__(self, draws: UnitDraws, tau_scale: float):
        self.y = draws.log_theta  # (n, S, d)
        # constant part of each draw's weight: the Jacobian of log and the fit prior
        self.w0 = -self.y.sum(axis=2) - draws.log_prior  # (n, S)
        self.n, self.s, self.d = self.y.shape
        self.features = np.concatenate([self.y**2, self.y], axis=2).reshape(-1, 2 * self.d)  # (n*S, 2d)
        lo = np.array([max(b[0], 1e-300) for b in draws.bounds])
        self.mu_lo, self.mu_hi = np.log(lo), np.log(np.array([b[1] for b in draws.bounds]))
        self.tau_scale = tau_scale

    def log_weights(self, mu: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """log [p_pop(theta_is) / pi(theta_is)] for each walker, unit and draw, shape (W, n, S)."""
        prec = 1.0 / tau**2  # (W, d)
        coef = np.concatenate([-0.5 * prec, mu * prec], axis=1)  # (W, 2d)
        const = -0.5 * (mu**2 * prec).sum(axis=1) - np.log(tau).sum(axis=1) - 0.5 * self.d * math.log(2 * math.pi)
        # einsum without BLAS: multithreaded BLAS on a busy machine is slower than one core here
        quad = np.einsum("nk,wk->wn", self.features, coef).reshape(-1, self.n, self.s)  # (W, n, S)
        quad += const[:, None, None]
        quad += self.w0[None]
        return quad

    def unit_terms(self, mu: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """log L_i for each walker and unit, shape (W, n)."""
        lw = self.log_weights(mu, tau)
        top = lw.max(axis=2, keepdims=True)
        lw -= top
        np.exp(lw, out=lw)
        return np.log(lw.sum(axis=2)) + top[..., 0] - math.log(self.s)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        x = np.atleast_2d(x)
        mu, tau = x[:, : self.d], x[:, self.d:]
        ok = np.all((mu > self.mu_lo) & (mu < self.mu_hi) & (tau > 0), axis=1)
        out = np.full(x.shape[0], -np.inf)
        if ok.any():
            lp = _half_normal_logpdf(tau[ok], self.tau_scale).sum(axis=1)
            out[ok] = lp + self.unit_terms(mu[ok], tau[ok]).sum(axis=1)
        return out


class _HyperProblem(ProblemBase):
    """The hyperparameters (mu, tau) as a fit problem of the one emcee driver.

    mu is the population mean of log theta (bounded by the units' prior ranges), tau its
    sd (half-normal prior); :class:`_Posterior` evaluates every walker in one call.
    """

    family = "population"
    vectorized = True

    def __init__(self, post: _Posterior, names: Sequence[str], start: np.ndarray):
        self.post = post
        self.names = [f"mu[{n}]" for n in names] + [f"tau[{n}]" for n in names]
        self.initial = np.asarray(start, float)
        d = len(names)
        self.bounds = (np.concatenate([post.mu_lo, np.zeros(d)]), np.concatenate([post.mu_hi, np.full(d, np.inf)]))
        self.failures: Counter = Counter()

    def log_prob(self, vec: np.ndarray) -> float:
        return float(self.post(np.asarray(vec, float)[None])[0])

    def log_prob_many(self, vecs: np.ndarray) -> np.ndarray:
        return self.post(np.asarray(vecs, float))


@dataclass
class PopulationResult:
    """Posterior of the population's log-medians ``mu`` and log-sds ``tau``.

    Attributes
    ----------
    draws
        The per-unit draws it was estimated from.
    mu, tau
        Hyperparameter draws, shape (samples, names).
    ess
        Effective number of each unit's draws under the population (at the posterior
        median hyperparameters).
    warnings
        Reasons to distrust the estimate.
    """

    draws: UnitDraws
    mu: np.ndarray
    tau: np.ndarray
    ess: np.ndarray
    acceptance: float
    settings: dict
    warnings: list[str] = field(default_factory=list)

    @property
    def names(self) -> list[str]:
        return self.draws.names

    def measurement_sd(self) -> np.ndarray:
        """Typical per-unit measurement uncertainty of log theta (median over units)."""
        return np.median(self.draws.measurement_sd(), axis=0)

    def summary(self, level: float = 0.95) -> dict[str, dict[str, float]]:
        """Per parameter: population median and log-sd with intervals, against measurement noise.

        Keys: ``median`` (exp mu; ``median_lo``/``median_hi`` its interval), ``tau``
        (``tau_lo``/``tau_hi``), ``measurement_sd`` (typical per-unit posterior sd of
        log theta), ``naive_sd`` (sd of the units' posterior medians of log theta, what a
        table like Monday's shows), ``fraction_real`` (tau^2/(tau^2 + s^2), with interval),
        ``p_scatter_exceeds_noise`` (posterior probability that tau > s), ``new_unit_lo`` /
        ``new_unit_hi`` (interval for a new unit drawn from the population).
        """
        a = (1 - level) / 2
        s = self.measurement_sd()
        med_units = np.median(self.draws.log_theta, axis=1)
        rng = np.random.default_rng(0)
        new = np.exp(self.mu + self.tau * rng.standard_normal(self.mu.shape))
        out = {}
        for j, n in enumerate(self.names):
            mu, tau = self.mu[:, j], self.tau[:, j]
            frac = tau**2 / (tau**2 + s[j] ** 2)
            q = lambda x: np.quantile(x, [a, 0.5, 1 - a])  # noqa: E731
            m, t, f, nu = q(np.exp(mu)), q(tau), q(frac), q(new[:, j])
            out[n] = {"median": float(m[1]), "median_lo": float(m[0]), "median_hi": float(m[2]),
                      "tau": float(t[1]), "tau_lo": float(t[0]), "tau_hi": float(t[2]),
                      "measurement_sd": float(s[j]), "naive_sd": float(np.std(med_units[:, j], ddof=1)),
                      "fraction_real": float(f[1]), "fraction_real_lo": float(f[0]), "fraction_real_hi": float(f[2]),
                      "p_scatter_exceeds_noise": float(np.mean(tau > s[j])),
                      "new_unit_lo": float(nu[0]), "new_unit_hi": float(nu[2])}
        return out

    def shrunk(self, *, n_hyper: int = 200, level: float = 0.95, seed: int = 0) -> dict[str, np.ndarray]:
        """Each unit's parameters under the population (partial pooling).

        Returns
        -------
        dict
            ``median``, ``lo``, ``hi`` arrays of shape (units, names).
        """
        rng = np.random.default_rng(seed)
        pick = rng.choice(self.mu.shape[0], size=min(n_hyper, self.mu.shape[0]), replace=False)
        post = _Posterior(self.draws, 1.0)
        y = self.draws.log_theta
        lw = post.log_weights(self.mu[pick], self.tau[pick])
        lw -= logsumexp(lw, axis=2, keepdims=True)  # normalise per hyper draw and unit
        w = np.exp(lw).mean(axis=0)  # (n, S): mixture over hyper draws
        a = (1 - level) / 2
        out = {k: np.empty(y.shape[0:1] + y.shape[2:]) for k in ("median", "lo", "hi")}
        for i in range(y.shape[0]):
            for j in range(y.shape[2]):
                out["lo"][i, j], out["median"][i, j], out["hi"][i, j] = np.exp(
                    _weighted_quantile(y[i, :, j], w[i], [a, 0.5, 1 - a]))
        return out

    def to_dataset(self) -> xr.Dataset:
        """The result as an xarray Dataset (sample, parameter) with the summary in attributes."""
        summ = self.summary()
        ds = xr.Dataset(
            {"mu": (("sample", "parameter"), self.mu, {"long_name": "population mean of log theta"}),
             "tau": (("sample", "parameter"), self.tau, {"long_name": "population sd of log theta (unit-to-unit)"}),
             "unit_ess": (("unit",), self.ess, {"long_name": "effective draws per unit under the population"}),
             "measurement_sd": (("parameter",), self.measurement_sd(),
                                {"long_name": "median per-unit posterior sd of log theta"}),
             "unit_median": (("unit", "parameter"), np.median(self.draws.theta, axis=1)),
             "unit_sigma": (("unit",), self.draws.sigma, {"units": "rad"})},
            coords={"parameter": np.array(self.names, dtype=object), "unit": np.array(self.draws.units, dtype=object)})
        ds.attrs = clean_attrs({"schema_version": POPULATION_SCHEMA, "summary": summ, "warnings": self.warnings,
                                "acceptance": self.acceptance, "settings": self.settings})
        return ds

    def write(self, path: str | Path, *, force: bool = False) -> None:
        from ..core.atomic import atomic_path

        with atomic_path(path, force=force) as tmp:
            self.to_dataset().to_netcdf(tmp, engine="h5netcdf")


def _weighted_quantile(x: np.ndarray, w: np.ndarray, q: Sequence[float]) -> np.ndarray:
    order = np.argsort(x)
    cw = np.cumsum(w[order])
    cw /= cw[-1]
    return np.interp(q, cw - 0.5 * w[order] / w.sum(), x[order])


def fit_population(draws: UnitDraws, *, walkers: int = 32, steps: int = 2000, burn: int | None = None,
                   seed: int = 0, tau_scale: float = 1.0, min_ess: float = 20.0) -> PopulationResult:
    """Sample the population hyperparameters by hierarchical reweighting of the unit draws.

    Parameters
    ----------
    draws
        From :func:`collect_draws`.
    walkers, steps, burn, seed
        emcee settings (``burn`` defaults to half the steps: the walkers do not start at a least-squares optimum).
    tau_scale
        Scale of the half-normal prior of each log-sd (1.0: a factor e between units is
        plausible, a factor e^3 is not).
    min_ess
        Warn when a unit keeps fewer effective draws under the population than this.
    """
    if len(draws.units) < 2:
        raise FitError(f"a population needs at least two units, got {len(draws.units)}")
    d = len(draws.names)
    if walkers < 4 * d:
        raise FitError(f"use at least {4 * d} walkers for {2 * d} hyperparameters, got {walkers}")
    post = _Posterior(draws, tau_scale)
    med = np.median(draws.log_theta, axis=1)  # (n, d)
    problem = _HyperProblem(post, draws.names, np.concatenate([med.mean(axis=0),
                                                               np.maximum(med.std(axis=0, ddof=1), 0.05)]))
    mc = run_emcee(problem, None, walkers=walkers, steps=steps, burn=burn, seed=seed, moves="de")
    burn = mc.burn
    chain = mc.chain.reshape(-1, 2 * d)
    mu, tau = chain[:, :d], chain[:, d:]
    mid = np.median(chain, axis=0)
    lw = post.log_weights(mid[None, :d], mid[None, d:])[0]
    w = np.exp(lw - lw.max(axis=1, keepdims=True))
    ess = w.sum(axis=1) ** 2 / (w**2).sum(axis=1)
    warnings = []
    low = [u for u, e in zip(draws.units, ess) if e < min_ess]
    if low:
        warnings.append(f"units {low} keep fewer than {min_ess:g} effective draws under the population: "
                        "their posteriors are too narrow or too far out for reweighting; sample them longer")
    acc = float(np.mean(mc.acceptance))
    if not mc.tau_reliable:
        warnings.append("the hyperparameter run is shorter than 50 autocorrelation times: intervals are approximate")
    if acc < 0.1:
        warnings.append(f"hyperparameter sampler acceptance {acc:.2f} is low")
    settings = {"walkers": walkers, "steps": steps, "burn": burn, "seed": seed, "tau_scale": tau_scale,
                "draws_per_unit": int(draws.theta.shape[1]), "units": len(draws.units)}
    return PopulationResult(draws, mu, tau, ess, acc, settings, warnings)


def load_population(path: str | Path) -> xr.Dataset:
    """Read a population result written by :meth:`PopulationResult.write`."""
    from ..core.h5layout import check_file

    p = Path(path)
    if not p.is_file():
        raise ResultsError("population file not found", str(p))
    if check_file(p, "population file").attrs.get("schema_version") != POPULATION_SCHEMA:
        raise ResultsError(f"not a population file of schema {POPULATION_SCHEMA!r}", str(p))
    ds = xr.open_dataset(p, engine="h5netcdf").load()
    ds.attrs["summary"] = json.loads(ds.attrs["summary"])
    return ds
