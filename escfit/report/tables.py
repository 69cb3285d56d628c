"""The report's text: parameter table, fit statistics, sampler diagnostics and provenance.

Values are shown in display units (:mod:`escfit.core.display`): angles in degrees, torques per
inertia in rad/s^2; the results file keeps its canonical units.
"""

from __future__ import annotations

import json
import math

import numpy as np

from ..core.display import format_value, load_unit, to_display
from ..core.names import plain_name
from .params import estimate_kind, parameter_table

__all__ = ["parameter_table", "estimate_kind", "fit_statistics", "sampler_rows", "provenance_rows"]


def _loads_unit(res) -> str:
    return load_unit(json.loads(res.attrs.get("meanings", "{}") or "{}"))


def fit_statistics(res) -> str:
    """One paragraph on the fit: model, readings, parameters and the reading scatter.

    With a free noise scale the least-squares scatter is profiled from the residuals (a
    reduced chi-square would be 1 by construction and is not shown); with the scene's noise
    known, the reduced chi-square says how the residuals compare with it.  The scatter quoted
    here is the least-squares one; a posterior ``observation.sigma`` is in the parameter table.
    """
    a = res.attrs
    lsq = res.arrays("least_squares")
    la = lsq.attrs if lsq is not None else {}
    n = int(la.get("n_data", 0) or 0)
    npar = int(lsq.sizes.get("parameter", 0)) if lsq is not None else 0
    obs = res.arrays("observed_data")
    units = obs["reading"].attrs.get("units", "rad") if obs is not None else "rad"
    sigma_unit = "rad" if units == "notches" else units  # notch counts: the jitter is an angle
    noise = [name for name in res.parameter_names if name.startswith("observation.sigma")]
    profiled = [name for name in noise if lsq is None or name not in list(map(str, lsq["parameter"].values))]
    plural = lambda k, word: f"{k} {word}{'' if k == 1 else 's'}"  # noqa: E731
    sampled = str(a.get("method")) == "emcee"
    n_free = len([r for r in res.summary() if r in res.parameter_names]) if sampled else npar
    if sampled:
        fitted = (f"{plural(n_free, 'free parameter')}" + (f": {npar}" if n_free > 1 else ",") + " fitted by least squares"
                  + (" with the reading noise profiled from the residuals" if profiled else "")
                  + (", then sampled with emcee from there" if n_free == 1 else
                     f", then all {n_free} sampled with emcee from there"))
    else:
        fitted = (f"{plural(npar, 'parameter')} fitted by least squares (scipy, trust-region reflective)"
                  + (", the reading noise profiled from the residuals" if profiled else ""))
    kind = _kind_words(a.get('data_kind', 'readings'))
    if a.get("data_kind") == "timeseries" and units in SAMPLED:
        kind = SAMPLED[units]
    head = f"{_model_words(a)} fitted to {plural(n, 'reading')} ({kind}): {fitted}"
    if "redchi" not in la:
        return head + "."
    if n <= npar:
        return head + ": as many parameters as readings, the fit is exact and the readings give no scatter estimate."
    mixed = " and " in units

    def scatter(value) -> str:
        shown, label = to_display(float(value), sigma_unit, "observation.sigma")
        return f"{format_value(shown, 3)} {label}"

    posterior_sigma = res.arrays("posterior") is not None and "observation.sigma" in res.arrays("posterior")
    where = " (the posterior's reading noise is the reading-noise row of the table)" if posterior_sigma else ""
    tail = ". " + _criteria_text(la, obs)
    if mixed:
        per_series = _series_scatter(res, units)
        if per_series:
            tail = f". Residual scatter at the best fit: {per_series}" + tail
    if int(la.get("noise_profiled", 1) or 0):
        text = "" if mixed else (f". Least-squares reading scatter {scatter(la['sigma_hat'])}, profiled from the "
                                 f"residuals at the best fit{where}")
        return head + text + tail
    text = (f". Reduced chi-square {format_value(la['redchi'], 4)} against the scene's reading noise "
            f"{scatter(la['sigma_hat']) if not mixed else format_value(la['sigma_hat'])}")
    if not mixed:
        text += f" (least-squares residual scatter {scatter(float(la['sigma_hat']) * math.sqrt(float(la['redchi'])))})"
    return head + text + where + tail


def _criteria_text(la, obs) -> str:
    """AICc and BIC at the best fit: the numbers ``escfit compare`` ranks by, from the same
    stored log-likelihood (:func:`escfit.inference.information.stored_criteria`)."""
    from ..inference.information import stored_criteria

    n = int(obs["reading"].size) if obs is not None else int(la.get("n_data", 0) or 0)
    ic = stored_criteria(la, n)
    if ic is None:
        return ("No log-likelihood is stored with this fit (written by an older escfit, or the model failed at the "
                "optimum): fit it again for AICc and BIC.")
    k = ic["n_params"]
    return (f"Information criteria at the best fit (log-likelihood {format_value(ic['loglike'], 6)} with its "
            f"normalising constants, {k} parameter{'' if k == 1 else 's'} counted, a profiled noise scale included; "
            f"n = {n}): AICc {format_value(ic['aicc'], 6)}, BIC {format_value(ic['bic'], 6)}, as escfit compare "
            "ranks fits of the same readings (lower is better; only differences between fits mean anything).")


_KIND_WORDS = {"rig-readings": "rig readings: the extra load dw of each setting",
               "terminal-speeds": "terminal speeds, peak and minimum of each run",
               "speed-trace": "a driver-speed trace", "turns-to-arm": "turns to arm","notches": "notch counts per half swing", "amplitude": "amplitudes per half swing",
               "timeseries": "a sampled angle", "timegrapher": "timegrapher readings", "pulses": "passage times",
               "terminal_speeds": "terminal speeds", "speed_trace": "a driver-speed trace"}


SAMPLED = {"rad/s": "a sampled angular velocity", "m": "a sampled displacement"}  # a time series by its units


def _kind_words(kind) -> str:
    return _KIND_WORDS.get(str(kind), str(kind).replace("_", " "))


def _model_words(a: dict) -> str:
    """The model in plain words, as its family says it (a family not registered here: its name)."""
    from ..core.errors import SceneError
    from ..core.family import get_family

    model = str(a.get("model", "balance"))
    try:
        return get_family(model).title(a)
    except SceneError:
        return f"{model} model"


# Why an evaluation gave no prediction, for the codes that are not sentences already
FAILURE_WORDS = {
    "locked": "the pin jams in the slot (no friction sign is consistent)",
    "no_terminal": "the driver keeps accelerating (no terminal speed)",
    "not_settled": "the run was too short for the speed to settle",
    "ambiguous": "both friction signs were consistent",
    "truncated": "the engagement budget ran out",
    "non-finite likelihood": "the likelihood was not a finite number",
    "non-physical parameters": "the parameters were outside the physical range",
}


def failures_text(res) -> str:
    """The evaluations that gave no prediction, counted and explained in words (empty when none)."""
    raw = res.attrs.get("failures", "")
    try:
        failures = json.loads(raw) if isinstance(raw, str) and raw else dict(raw or {})
    except (TypeError, ValueError):
        return ""
    failures = {k: int(v) for k, v in failures.items() if int(v) > 0}
    if not failures:
        return ""
    total = sum(failures.values())
    who = "the optimiser and the sampler" if res.attrs.get("method") == "emcee" else "the optimiser"
    parts = [f"{n} time{'s' if n != 1 else ''}: {FAILURE_WORDS.get(k, k)}" for k, n in failures.items()]
    return (f"{total} parameter set{'s' if total != 1 else ''} tried by {who} gave no prediction and "
            f"{'were' if total != 1 else 'was'} rejected ({'; '.join(parts)}). Such values lie outside where the "
            "mechanism works; rejecting them is part of the fit and does not bias it.")


def _series_scatter(res, units: str) -> str:
    """RMS of reading - best fit per reading series, for recordings that mix units
    (``"deg (amplitude) and s (beats)"``); times in ms."""
    import re

    obs, lsq = res.arrays("observed_data"), res.arrays("least_squares")
    if obs is None or lsq is None or "expected" not in lsq or "curve" not in obs.coords:
        return ""
    unit_of = {series: unit for unit, series in re.findall(r"(\S+) \(([^)]+)\)", units)}
    curves = obs["curve"].values.astype(str)
    resid = obs["reading"].values.astype(float) - lsq["expected"].values.astype(float)
    parts = []
    for series in dict.fromkeys(curves):
        rms = float(np.sqrt(np.mean(resid[curves == series] ** 2)))
        unit = unit_of.get(series, "")
        if unit == "s":
            rms, unit = rms * 1e3, "ms"
        parts.append(f"{series} {format_value(rms, 3)} {unit}".rstrip())
    return ", ".join(parts)


def sampler_rows(res) -> tuple[str, list[str], list[list[str]]]:
    """The sampler's run in one sentence, and a per-parameter table of its diagnostics.

    Returns
    -------
    tuple
        ``(sentence, head, rows)``; empty strings and lists for a least-squares fit.
    """
    a = res.attrs
    diag = res.arrays("diagnostics")
    if res.arrays("posterior") is None:
        return "", [], []
    how = "fixed length"
    if a.get("steps_mode") == "auto":
        how = ("stopped when converged" if int(a.get("converged", 0) or 0) else "stopped at the cap, NOT converged")
    sentence = (f"emcee ({a.get('moves', 'stretch')} moves): {a.get('walkers', '-')} walkers x {a.get('steps', '-')} "
                f"steps, the first {a.get('burn', '-')} discarded as burn-in ({how})")
    if diag is not None and "acceptance" in diag:
        acc = diag["acceptance"].values.astype(float)
        sentence += f"; acceptance fraction {np.median(acc):.2f} (median over walkers, {acc.min():.2f} to {acc.max():.2f})"
    sentence += (". Converged chains have split R-hat at most 1.01 and bulk and tail ESS of a few hundred; "
                 "in the trace plots the walkers overlap with no trend.")
    if diag is None or "rhat" not in diag:
        return sentence, [], []
    loads_in = _loads_unit(res)
    meanings = json.loads(res.attrs.get("meanings", "{}") or "{}")
    head = ["parameter", "split R-hat", "ESS (bulk)", "ESS (tail)", "autocorrelation time (steps)"]
    rows = []
    for i, name in enumerate(map(str, diag["parameter"].values)):
        sel = {k: float(diag[k].values[i]) for k in ("rhat", "ess_bulk", "ess_tail", "tau") if k in diag}
        rows.append([plain_name(name, meanings.get(name, ""), loads_in), f"{sel['rhat']:.3f}",
                     _count(sel["ess_bulk"]), _count(sel["ess_tail"]),
                     format_value(sel["tau"], 3) if "tau" in sel else "-"])
    return sentence, head, rows


def provenance_rows(res, path) -> list[tuple[str, str]]:
    """Where the fit came from: files, their hash, solver (and why its tolerance, how least squares
    differentiated the model), seed, run length, times, versions."""
    a = res.attrs
    rows = [("results file", str(path)), ("method", a.get("method")), ("scene file", a.get("scene_file")),
            ("switching", a.get("switching")), ("data file", a.get("data_file")), ("data SHA-256", a.get("data_sha256")),
            ("solver", f"{a.get('solver', '')} {a.get('solver_options', '')}".strip()),
            ("solver tolerance", a.get("solver_tolerance")), ("least-squares Jacobians", a.get("jacobian")),
            ("seed", a.get("seed")),
            ("walkers x steps (burn)", f"{a.get('walkers', '-')} x {a.get('steps', '-')} ({a.get('burn', '-')})"
             if "walkers" in a else None),
            ("started / finished", f"{a.get('started')} / {a.get('finished')}"), ("schema", a.get("schema_version")),
            ("versions", a.get("versions"))]
    return [(k, str(v)) for k, v in rows if v not in (None, "", "None None", "None / None")]


def _count(value) -> str:
    """An effective sample size: a whole number of draws (``-`` when undefined)."""
    import math

    try:
        v = float(value)
    except (TypeError, ValueError):
        return "-"
    return f"{v:.0f}" if math.isfinite(v) else "-"
