"""Scene -> simulated arming run -> :class:`xarray.Dataset`, plus the pure forward model.

Units in the results: time s, angles rad, speeds rad/s, forces lbf (the report's pound;
the contact-force maxima are compared with it), closing speeds in/s.  ``phi`` is the
escape-wheel angle in the active side's reference (it jumps at side changes);
``phi_total`` is the continuous cumulative angle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np
import xarray as xr

from ..core.errors import SolverError
from .hybrid import DEFAULT_STEP, IMPACT_FIELDS, RunResult, run_rk4
from .integrator import COLUMNS
from .scene import VergeScene

__all__ = ["simulate", "json_summary", "forward", "Prediction", "run", "SOLVERS", "SCHEMA_VERSION"]

SCHEMA_VERSION = "verge-1"
SOLVERS = ("rk4", "ivp")
DEFAULT_MAX_TURNS = 200.0
_OPTIONS = {"step", "h", "t_max", "max_turns", "record", "rtol", "atol"}


@dataclass(frozen=True)
class Prediction:
    """What the forward model predicts for one parameter set and spin rate.

    Attributes
    ----------
    status : str
        ``armed``, ``not_armed`` or ``failed``.
    time_to_arm : float
        Seconds from release to the cut-off angle (NaN unless armed).
    turns_to_arm : float
        Fuze revolutions in that time (NaN unless armed).
    maxima : dict
        Largest contact forces in lbf (``F23, F12, PN, FF23, FF12``).
    """

    status: str
    time_to_arm: float
    turns_to_arm: float
    maxima: Mapping[str, float]


def _check_options(solver: str | None, options: Mapping) -> str:
    solver = solver or "rk4"
    if solver not in SOLVERS:
        raise SolverError(f"the verge model has solvers {list(SOLVERS)}, not {solver!r}", "simulate(solver=...)")
    unknown = sorted(set(options) - _OPTIONS)
    if unknown:
        raise SolverError(f"unknown option(s) {unknown} for the verge model; allowed: {sorted(_OPTIONS)}",
                          "simulate(**options)")
    if solver == "rk4" and ({"rtol", "atol"} & set(options)):
        raise SolverError("rtol/atol apply to solver 'ivp' only", "simulate(**options)")
    if solver == "ivp" and ({"step", "h"} & set(options)):
        raise SolverError("step/h apply to solver 'rk4' only (ivp is adaptive)", "simulate(**options)")
    for key in ("step", "h", "t_max", "max_turns", "rtol", "atol"):
        if key in options:
            val = options[key]
            if isinstance(val, bool) or not isinstance(val, (int, float)) or not (val > 0 and math.isfinite(val)):
                raise SolverError(f"option {key} must be a positive number, got {val!r}", "simulate(**options)")
    return solver


def run(scene: VergeScene, values: Mapping[str, float] | None = None, *, solver: str | None = None,
        **options) -> RunResult:
    """Simulate one arming run of ``scene`` (optionally with some parameter values replaced).

    Parameters
    ----------
    scene : VergeScene
    values : mapping, optional
        Parameter values by dotted name, SI (``verge.spin`` in rad/s).
    solver : {"rk4", "ivp"}
        Compiled fixed-step RK4 with located events (default) or scipy's adaptive DOP853.
    step : float
        RK4 step as an angle of fuze spin (rad), default 0.005; or ``h`` in seconds.
    t_max : float
        Time limit (s); default ``max_turns`` fuze revolutions.
    max_turns : float
        Default time limit in fuze revolutions (200).
    record : bool
        Keep the trajectory (default True).
    rtol, atol : float
        Tolerances of the ``ivp`` solver.
    """
    solver = _check_options(solver, options)
    k = scene.constants(values)
    omega = k.omega
    t_max = options.get("t_max", 2 * math.pi * options.get("max_turns", DEFAULT_MAX_TURNS) / omega)
    record = bool(options.get("record", True))
    if solver == "rk4":
        step = options["h"] * omega if "h" in options else options.get("step", DEFAULT_STEP)
        return run_rk4(k, phi_start=scene.phi_start(), step=step, t_max=t_max, record=record)
    from .ivp import run_ivp

    return run_ivp(k, phi_start=scene.phi_start(), t_max=t_max, record=record, rtol=options.get("rtol", 1e-9),
                   atol=options.get("atol", 1e-12))


def forward(scene: VergeScene, values: Mapping[str, float] | None = None, *, solver: str | None = None,
            **options) -> Prediction:
    """Pure forward model: parameter values -> time and turns to arm and force maxima.

    Same arguments as :func:`run`; the trajectory is not kept.
    """
    options = dict(options, record=False)
    res = run(scene, values, solver=solver, **options)
    k_omega = abs((values or {}).get("verge.spin", scene.params["verge.spin"].value))
    turns = res.time_to_arm * k_omega / (2 * math.pi)
    return Prediction(res.status, res.time_to_arm, turns, dict(res.maxima))


def simulate(scene: VergeScene, solver: str | None = None, **options) -> xr.Dataset:
    """Simulate the scene's arming run and return the time history and results.

    Parameters
    ----------
    scene : VergeScene
    solver : {"rk4", "ivp"}, optional
        See :func:`run`.
    **options
        See :func:`run`.

    Returns
    -------
    xarray.Dataset
        Dimension ``sample`` (time history): ``time``, ``phi``, ``phi_total``, ``phidot``,
        ``phiddot``, ``psi``, ``psidot``, ``psiddot``, ``regime`` (``entrance_coupled``,
        ``exit_coupled``, ``free``), ``side``, ``F23``, ``F12`` (mesh forces, both regimes),
        ``PN`` (verge contact force, 0 in free motion), ``train_direction``.
        Dimension ``impact``: times, speeds before and after, closing speed.
        Scalars: ``time_to_arm``, ``turns_to_arm``, ``F23_max``, ``F12_max``, ``PN_max``
        (coupled motion), ``FF23_max``, ``FF12_max`` (free motion).
        Attributes: ``status`` (``armed``/``not_armed``/``failed``), ``reason``,
        ``message``, operating point, solver and provenance.
    """
    solver = _check_options(solver, options)
    res = run(scene, solver=solver, **options)
    return to_dataset(scene, res, solver, options)


def to_dataset(scene: VergeScene, res: RunResult, solver: str, options: Mapping) -> xr.Dataset:
    """Pack a :class:`RunResult` into the documented Dataset layout."""
    from ..core.version import __version__

    tr = res.trajectory if res.trajectory is not None else np.empty((0, len(COLUMNS)))
    col = {name: tr[:, i] for i, name in enumerate(COLUMNS)}
    coupled = col["regime"] == 0
    entrance = col["side"] > 0
    regime = np.where(coupled, np.where(entrance, "entrance_coupled", "exit_coupled"), "free")
    side = np.where(entrance, "entrance", "exit")
    omega = scene.params["verge.spin"].value
    turns = res.time_to_arm * omega / (2 * math.pi)

    def var(name, units, long):
        return (("sample",), col[name], {"units": units, "long_name": long})

    data = {
        "phi": var("phi", "rad", "escape-wheel angle in the active side's reference"),
        "phi_total": var("phi_total", "rad", "cumulative escape-wheel angle"),
        "phidot": var("phidot", "rad/s", "escape-wheel angular speed"),
        "phiddot": var("phiddot", "rad/s^2", "escape-wheel angular acceleration"),
        "psi": var("psi", "rad", "verge angle to the active face tip"),
        "psidot": var("psidot", "rad/s", "verge angular speed"),
        "psiddot": var("psiddot", "rad/s^2", "verge angular acceleration"),
        "F23": var("F23", "lbf", "normal tooth force gear 2 on pinion 3"),
        "F12": var("F12", "lbf", "normal tooth force rotor on pinion 2"),
        "PN": var("PN", "lbf", "normal contact force escape-wheel tooth on verge (0 in free motion)"),
        "regime": (("sample",), regime.astype(str), {"long_name": "motion regime"}),
        "side": (("sample",), side.astype(str), {"long_name": "active verge face"}),
        "train_direction": (("sample",), col["train_direction"].astype(np.int8),
                            {"long_name": "+1 gear train runs forward, -1 backwards (friction reversed)"}),
    }
    imp = res.impacts
    ic = {name: imp[:, i] for i, name in enumerate(IMPACT_FIELDS)}
    data.update({
        "impact_time": (("impact",), ic["time"], {"units": "s"}),
        "impact_side": (("impact",), np.where(ic["side"] > 0, "entrance", "exit").astype(str), {}),
        "phidot_before": (("impact",), ic["phidot_before"], {"units": "rad/s"}),
        "psidot_before": (("impact",), ic["psidot_before"], {"units": "rad/s"}),
        "phidot_after": (("impact",), ic["phidot_after"], {"units": "rad/s"}),
        "psidot_after": (("impact",), ic["psidot_after"], {"units": "rad/s"}),
        "closing_speed": (("impact",), ic["closing_speed"], {"units": "in/s",
                                                             "long_name": "normal approach speed before impact"}),
        "time_to_arm": ((), res.time_to_arm, {"units": "s", "long_name": "time to reach phi_cut (NaN unless armed)"}),
        "turns_to_arm": ((), turns, {"units": "1", "long_name": "fuze revolutions to arm"}),
    })
    labels = {"F23": "F23_max", "F12": "F12_max", "PN": "PN_max", "FF23": "FF23_max", "FF12": "FF12_max"}
    for key, name in labels.items():
        regime_name = "coupled" if key in ("F23", "F12", "PN") else "free"
        data[name] = ((), float(res.maxima[key]), {"units": "lbf", "long_name": f"largest {key} in {regime_name} motion "
                                                  "(impact forces excluded)"})
    p = scene.params.values()
    attrs = {
        "model": "verge",
        "status": res.status,
        "reason": res.reason,
        "message": res.message,
        "solver": solver,
        "solver_options": ", ".join(f"{k}={v}" for k, v in sorted(options.items())) or "defaults",
        "spin_rpm": scene.spin_rpm,
        "mu": p["verge.mu"],
        "mu1": p["verge.mu1"],
        "restitution": p["verge.restitution"],
        "phi_cut_deg": math.degrees(p["verge.phi_cut"]),
        "t_end": res.t_end,
        "phi_total_end_deg": math.degrees(res.phi_total_end),
        "n_impacts": int(imp.shape[0]),
        "n_phases": len(res.phases),
        "n_reversals": int(res.reversals),
        "scene_file": scene.where,
        "scene": scene.text,
        "title": scene.title,
        "schema_version": SCHEMA_VERSION,
        "escfit_version": __version__,
    }
    return xr.Dataset(data, coords={"time": (("sample",), col["time"], {"units": "s"})}, attrs=attrs)


def _num(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def json_summary(ds: xr.Dataset) -> dict:
    """Plain-JSON summary of a verge Dataset (``escfit simulate --json``).

    Keys: ``model``, ``status``, ``reason``, ``message``, ``time_to_arm`` (s, null unless
    armed), ``turns_to_arm`` (null unless armed), ``max_forces`` (lb: ``F23``, ``F12``,
    ``PN`` in coupled motion, ``FF23``, ``FF12`` in free motion), ``spin_rpm``, ``mu``,
    ``mu1``, ``restitution``, ``n_impacts``, ``n_reversals``, ``t_end`` (s) and
    ``phi_total_end_deg``.
    """
    a = ds.attrs
    return {
        "model": "verge",
        "status": a["status"],
        "reason": a["reason"],
        "message": a["message"],
        "time_to_arm": _num(ds["time_to_arm"]),
        "turns_to_arm": _num(ds["turns_to_arm"]),
        "max_forces": {key: _num(ds[f"{key}_max"]) for key in ("F23", "F12", "FF23", "FF12", "PN")},
        "spin_rpm": float(a["spin_rpm"]),
        "mu": float(a["mu"]),
        "mu1": float(a["mu1"]),
        "restitution": float(a["restitution"]),
        "n_impacts": int(a["n_impacts"]),
        "n_reversals": int(a["n_reversals"]),
        "t_end": float(a["t_end"]),
        "phi_total_end_deg": float(a["phi_total_end_deg"]),
        "solver": a["solver"],
    }
