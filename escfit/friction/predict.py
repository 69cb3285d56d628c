"""Forward predictions of a rig scene and JSON summaries of rig results."""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
import xarray as xr

from ..core.errors import SolverError
from ..core.units import registry
from .rig import lever_ratio, mu_law, predicted_dw
from .scene import SIGMA, RigScene

__all__ = ["simulate", "json_summary"]

_GF = float(registry().Quantity(1.0, "gf").to("N").magnitude)
_FT_S = float(registry().Quantity(1.0, "ft/s").to("m/s").magnitude)


def simulate(scene: RigScene, solver: str | None = None, *, loads: Sequence[float] | None = None,
             speeds: Sequence[float] | None = None) -> xr.Dataset:
    """Predicted rig readings for the scene's nominal geometry and friction law.

    The rig is static, so there is no time integration: ``solver`` must be ``None`` or
    ``"closed_form"``.

    Parameters
    ----------
    scene
        A parsed ``friction_rig`` scene.
    solver
        ``None`` or ``"closed_form"``; anything else is refused.
    loads
        Loads ``w`` in N (default: 0.5 to 5 gram-force in 10 steps).
    speeds
        Sliding speeds in m/s (default: the reference speed, or 3 to 10 ft/s when the scene
        has a speed law).

    Returns
    -------
    xarray.Dataset
        Dims ``(load, speed)``; variables ``dw`` (N), ``mu`` (1), ``friction_force`` (N)
        and ``calibration_load`` (N, the load that gives the same beam position with the
        disc at rest), with units in ``attrs``.

    Raises
    ------
    SolverError
        A solver other than the closed form was requested.
    """
    if solver not in (None, "closed_form"):
        raise SolverError(f"the friction rig is solved in closed form; solver {solver!r} does not apply",
                          scene.where)
    values = scene.params.values()
    w = np.asarray(loads if loads is not None else np.linspace(0.5, 5.0, 10) * _GF, dtype=float)
    if speeds is None:
        speeds = (np.array([3.0, 5.0, 7.5, 10.0]) * _FT_S if "speed" in scene.laws else [scene.speed_ref])
    v = np.asarray(speeds, dtype=float)
    W, V = np.meshgrid(w, v, indexing="ij")
    mu = mu_law(values["friction.mu"], W, V, mu_w=values.get("friction.mu_w", 0.0),
                mu_v=values.get("friction.mu_v", 0.0), load_ref=scene.load_ref, speed_ref=scene.speed_ref)
    k, d = values["rig.k"], values["rig.d"]
    dw = predicted_dw(W, mu, k, d, scene.load_at)
    normal = W if scene.load_at == "reading" else W + dw
    cal = W - dw if scene.load_at == "reading" else W
    ds = xr.Dataset(
        {
            "dw": (("load", "speed"), dw, {"units": "N", "meaning": "extra load to reach the calibration deflection"}),
            "mu": (("load", "speed"), mu, {"units": "", "meaning": "friction coefficient"}),
            "friction_force": (("load", "speed"), mu * normal, {"units": "N"}),
            "calibration_load": (("load", "speed"), cal, {"units": "N"}),
        },
        coords={"load": ("load", w, {"units": "N"}), "speed": ("speed", v, {"units": "m/s"})},
        attrs={
            "model": "friction_rig", "kind": "prediction", "solver": "closed_form", "status": "ok",
            "scene_file": scene.where, "scene": scene.text, "load_at": scene.load_at,
            "k_m": k, "d_m": d, "lever_ratio": float(lever_ratio(k, d)),
            "observation_sigma_N": values[SIGMA], "schema_version": 1,
        },
    )
    return ds


def json_summary(ds: Any) -> dict:
    """A JSON-serialisable summary of a rig prediction or fit.

    Parameters
    ----------
    ds
        The Dataset from :func:`simulate`; a :class:`~escfit.results.FitResult` of a rig fit
        (:func:`escfit.inference.fit`); its ``posterior`` Dataset (dims ``chain, draw``); or its
        ``least_squares`` Dataset (``value``, ``stderr`` by ``parameter``).

    Returns
    -------
    dict
        For predictions: geometry and the ``dw`` grid in gram-force.  For fits: per parameter
        the posterior mean, sd, median and 95 % interval, or the least-squares value, standard
        error and normal 95 % interval, in canonical units.
    """
    if hasattr(ds, "tree") and hasattr(ds, "group"):  # a FitResult
        import json as _json

        attrs = dict(ds.attrs)
        units = _json.loads(attrs.get("units", "{}") or "{}")
        post = ds.group("posterior")
        body = (_posterior_params(post, units) if post is not None
                else _lsq_params(ds.group("least_squares"), units))
        return {"model": attrs.get("model"), "kind": "posterior" if post is not None else "least_squares",
                "method": attrs.get("method"), "scene_file": attrs.get("scene_file"),
                "data_file": attrs.get("data_file"), "seed": attrs.get("seed"), **body}
    attrs = dict(ds.attrs)
    if "chain" in ds.dims and "draw" in ds.dims:
        return {"model": "friction_rig", "kind": "posterior", **_posterior_params(ds, {})}
    if "value" in ds and "parameter" in ds.dims:
        return {"model": "friction_rig", "kind": "least_squares", "chisqr": attrs.get("chisqr"),
                "n_data": attrs.get("n_data"), **_lsq_params(ds, {})}
    return {
        "model": "friction_rig", "kind": "prediction", "status": attrs.get("status"),
        "solver": attrs.get("solver"), "load_at": attrs.get("load_at"),
        "k_m": attrs.get("k_m"), "d_m": attrs.get("d_m"), "lever_ratio": attrs.get("lever_ratio"),
        "load_gf": [round(x / _GF, 6) for x in ds["load"].values.tolist()],
        "speed_m_s": ds["speed"].values.tolist(),
        "dw_gf": (ds["dw"].values / _GF).round(6).tolist(),
        "mu": ds["mu"].values.round(6).tolist(),
    }


def _posterior_params(post: xr.Dataset, units: dict) -> dict:
    params = {}
    for name, var in post.data_vars.items():
        x = np.asarray(var.values, float).ravel()
        lo, med, hi = np.quantile(x, [0.025, 0.5, 0.975])
        params[name] = {"mean": float(np.mean(x)), "sd": float(np.std(x)), "median": float(med),
                        "ci95": [float(lo), float(hi)], "units": var.attrs.get("units", units.get(name, ""))}
    return {"params": params}


def _lsq_params(lsq: xr.Dataset, units: dict) -> dict:
    params = {}
    for name in lsq["parameter"].values.tolist():
        sel = lsq.sel(parameter=name)
        val, se = float(sel["value"]), float(sel["stderr"])
        params[name] = {"value": val, "stderr": _clean(se), "units": units.get(name, ""),
                        "ci95": [_clean(val - 1.959964 * se), _clean(val + 1.959964 * se)]}
    return {"chisqr": lsq.attrs.get("chisqr"), "n_data": lsq.attrs.get("n_data"), "params": params}


def _clean(x: float):
    return None if not math.isfinite(x) else float(x)
