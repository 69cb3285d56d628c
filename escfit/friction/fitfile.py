"""Rig fits as escfit results files (the same layout as balance fits).

Wraps :func:`~escfit.friction.inference.fit_least_squares` and
:func:`~escfit.friction.inference.sample_posterior` so ``escfit fit rig.csv --scene rig.toml``
writes a file ``escfit summary`` and ``escfit report`` read like any other fit.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
from pathlib import Path

import numpy as np
import xarray as xr

from ..core.atomic import refuse_existing
from ..results import SCHEMA_VERSION, FitResult, clean_attrs, dependency_versions, write_fit
from .inference import fit_least_squares, sample_posterior
from .readers import read_readings
from .scene import RigScene

__all__ = ["fit_rig"]


def fit_rig(scene: RigScene, data: str | Path, *, method: str = "leastsq", out: str | Path | None = None,
            force: bool = False, seed: int = 0, walkers: int = 32, steps: int = 3000, burn: int | None = None
            ) -> FitResult:
    """Fit a friction-rig session and return (and optionally write) an escfit results file.

    Parameters
    ----------
    scene
        A ``friction_rig`` scene.
    data
        Rig readings CSV (see :mod:`escfit.friction.readers`).
    method
        ``"leastsq"`` or ``"emcee"``.
    """
    if out is not None:
        refuse_existing(out, force)
    readings = read_readings(data)
    started = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    lsq = fit_least_squares(scene, readings)
    names = list(lsq.names)
    cov = np.asarray(lsq.covariance, float)
    if cov.shape == (len(names), len(names)):
        d = np.sqrt(np.diag(cov))
        corr = cov / np.outer(d, d)
    else:
        corr = np.full((len(names), len(names)), np.nan)
    groups = {"least_squares": xr.Dataset(
        {"value": ("parameter", [lsq.values[n] for n in names]),
         "stderr": ("parameter", [lsq.stderr.get(n, np.nan) for n in names]),
         "correlation": (("parameter", "parameter_b"), corr)},
        coords={"parameter": names, "parameter_b": names},
        attrs=clean_attrs({"chisqr": lsq.chisqr, "n_data": lsq.ndata, "reading_sd": lsq.reading_sd,
                           "success": lsq.success, "message": lsq.message}))}
    groups["observed_data"] = xr.Dataset({"dw": ("obs", readings.dw, {"units": "N"}),
                                          "load": ("obs", readings.load, {"units": "N"})},
                                         coords={"obs": np.arange(len(readings))})
    attrs = {"walkers": None, "steps": None, "burn": None}
    if method == "emcee":
        burn = steps // 3 if burn is None else burn
        idata = sample_posterior(scene, readings, nwalkers=walkers, nsteps=steps, burn=burn, seed=seed, start=lsq)
        post = idata.posterior
        groups["posterior"] = xr.Dataset({n: post[n] for n in post.data_vars}).drop_vars(
            [c for c in post.coords if c not in ("chain", "draw")], errors="ignore")
        groups["sample_stats"] = idata.sample_stats.to_dataset() if hasattr(idata.sample_stats, "to_dataset") else idata.sample_stats
        groups["log_likelihood"] = idata.log_likelihood
        groups["diagnostics"] = _diagnostics(groups["posterior"], names, idata)
        attrs = {"walkers": walkers, "steps": steps, "burn": burn}
    units = {p.name: p.unit for p in scene.params}
    units["rig.lever_ratio"] = ""
    param_names = names + (["rig.lever_ratio"] if method == "emcee" else [])
    root_attrs = {
        "schema_version": SCHEMA_VERSION, "model": "friction_rig", "method": method, "seed": seed,
        "parameters": param_names, "units": units, "scene": scene.text, "scene_file": scene.where,
        "data_file": str(data), "data_sha256": hashlib.sha256(Path(data).read_bytes()).hexdigest(),
        "data_kind": "rig_readings", "solver": "closed_form", "solver_options": {}, "versions": dependency_versions(),
        "started": started, "finished": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "warnings": [], "failures": {}, **attrs,
    }
    tree = xr.DataTree(dataset=xr.Dataset(attrs=clean_attrs(root_attrs)))
    for name, ds in groups.items():
        tree[name] = xr.DataTree(dataset=xr.Dataset(ds.data_vars, coords=ds.coords, attrs=clean_attrs(dict(ds.attrs))))
    result = FitResult(tree)
    if out is not None:
        write_fit(result, out, force=force)
    return result


def _diagnostics(post: xr.Dataset, names: list[str], idata) -> xr.Dataset:
    import json

    import arviz as az

    sub = post[names]
    rhat, ess_b, ess_t = az.rhat(sub), az.ess(sub, method="bulk"), az.ess(sub, method="tail")
    tau = json.loads(idata.posterior.attrs.get("autocorr_time", "[]")) or [np.nan] * len(names)
    return xr.Dataset({"rhat": ("parameter", [float(rhat[n]) for n in names]),
                       "ess_bulk": ("parameter", [float(ess_b[n]) for n in names]),
                       "ess_tail": ("parameter", [float(ess_t[n]) for n in names]),
                       "tau": ("parameter", np.asarray(tau, float)[: len(names)])},
                      coords={"parameter": names})
