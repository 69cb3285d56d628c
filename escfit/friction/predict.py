"""Forward predictions of a rig scene and JSON summaries of rig results."""

from __future__ import annotations

import json
import math
from typing import Any, Sequence

import numpy as np
import xarray as xr

from ..core.errors import SolverError
from ..core.units import ureg
from .rig import lever_ratio, mu_law, predicted_dw
from .scene import RigScene

__all__ = ["simulate", "json_summary"]

_GF = float(ureg.Quantity(1.0, "gf").to("N").magnitude)
_FT_S = float(ureg.Quantity(1.0, "ft/s").to("m/s").magnitude)


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
            "reading_sd_N": values["reading.sd"], "schema_version": 1,
        },
    )
    return ds


def json_summary(ds: Any) -> dict:
    """A JSON-serialisable summary of a rig prediction, fit or posterior.

    Parameters
    ----------
    ds
        The Dataset from :func:`simulate`, a least-squares Dataset
        (:meth:`~escfit.friction.inference.LeastSquaresFit.to_dataset`), or an
        :class:`arviz.InferenceData` / posterior Dataset from
        :func:`~escfit.friction.inference.sample_posterior`.

    Returns
    -------
    dict
        For predictions: geometry and the ``dw`` grid in gram-force.  For fits: value,
        standard error / sd and 95% interval of every parameter, in canonical units.
    """
    if hasattr(ds, "posterior"):
        attrs = dict(ds.attrs)
        post = ds.posterior
        kind = "posterior"
    else:
        attrs = dict(ds.attrs)
        post = ds
        kind = attrs.get("kind", "prediction")
    if kind == "prediction":
        return {
            "model": "friction_rig", "kind": "prediction", "status": attrs.get("status"),
            "solver": attrs.get("solver"), "load_at": attrs.get("load_at"),
            "k_m": attrs.get("k_m"), "d_m": attrs.get("d_m"), "lever_ratio": attrs.get("lever_ratio"),
            "load_gf": [round(x / _GF, 6) for x in ds["load"].values.tolist()],
            "speed_m_s": ds["speed"].values.tolist(),
            "dw_gf": (ds["dw"].values / _GF).round(6).tolist(),
            "mu": ds["mu"].values.round(6).tolist(),
        }
    if kind == "least_squares":
        params = {}
        for name, var in post.data_vars.items():
            se = float(var.attrs.get("stderr", math.nan))
            val = float(var.values)
            params[name] = {"value": val, "stderr": _clean(se), "units": var.attrs.get("units", ""),
                            "free": bool(var.attrs.get("free", 0)),
                            "ci95": [_clean(val - 1.959964 * se), _clean(val + 1.959964 * se)]}
        return {"model": "friction_rig", "kind": kind, "where": attrs.get("where"),
                "chisqr": attrs.get("chisqr"), "ndata": attrs.get("ndata"), "params": params}
    params = {}
    for name, var in post.data_vars.items():
        x = np.asarray(var.values).ravel()
        lo, med, hi = np.quantile(x, [0.025, 0.5, 0.975])
        params[name] = {"mean": float(np.mean(x)), "sd": float(np.std(x)), "median": float(med),
                        "ci95": [float(lo), float(hi)], "units": var.attrs.get("units", "")}
    return {"model": "friction_rig", "kind": "posterior", "scene_file": attrs.get("scene_file"),
            "data_file": attrs.get("data_file"), "seed": attrs.get("seed"),
            "acceptance_fraction": attrs.get("acceptance_fraction"),
            "autocorr_time": json.loads(attrs.get("autocorr_time", "[]")), "params": params}


def _clean(x: float):
    return None if not math.isfinite(x) else float(x)
