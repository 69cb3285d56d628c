"""The report's text: parameter table, fit statistics, sampler diagnostics and provenance.

Values are shown in display units (:mod:`escfit.core.display`): angles in degrees, torques per
inertia in rad/s^2; the results file keeps its canonical units.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from ..core.display import display_name, format_value, load_unit, to_display

__all__ = ["parameter_table", "estimate_kind", "fit_statistics", "sampler_rows", "provenance_rows"]

_BOUND_FLAG = {"min": "at lower bound", "max": "at upper bound"}


def estimate_kind(row: dict[str, Any]) -> str:
    """``"median"`` (posterior row) or ``"best fit"`` (least-squares row) of a summary row.

    Rows written before ``estimate_kind`` existed tell by their keys: posterior rows carry
    ``mean``, least-squares rows ``stderr``.
    """
    if row.get("estimate_kind"):
        return str(row["estimate_kind"])
    return "median" if "mean" in row else "best fit"


def _estimate(row: dict[str, Any]) -> float | None:
    for key in ("estimate", "median", "best_fit"):
        if row.get(key) is not None:
            return row[key]
    return None


def _loads_unit(res) -> str:
    return load_unit(json.loads(res.attrs.get("meanings", "{}") or "{}"))


def parameter_table(res) -> tuple[list[str], list[list[str]]]:
    """Header and rows of the parameter table, in display units.

    Parameters
    ----------
    res
        A saved fit (:class:`escfit.results.FitResult`).

    Returns
    -------
    tuple
        ``(head, rows)``, all strings.  The estimate column is headed ``"median"`` for a
        posterior, ``"best fit"`` for least squares (``"estimate"`` if the rows mix both, each
        row then saying which in the note column), ``"value (NOT determined)"`` when the fit
        determines nothing (:attr:`escfit.results.FitResult.verdict`); a parameter the fit does
        not determine says so in the note column.  Angles are in deg, R and X in rad/s^2,
        omega0 in rad/s; intervals convert with their values.  R-hat and ESS columns appear
        for posteriors only; a ``note`` column appears when a row needs one: an estimate on a
        bound of the scene's range (``at lower bound``), or which reading noise a posterior
        ``observation.sigma`` is.
    """
    summary = res.summary()
    loads_in = _loads_unit(res)
    kinds = {estimate_kind(r) for r in summary.values()}
    column = kinds.pop() if len(kinds) == 1 else "estimate"
    verdict = getattr(res, "verdict", "")
    undetermined = set(getattr(res, "undetermined", []) or [])
    if verdict == "not determined":
        column = "value (NOT determined)"
    posterior = any(estimate_kind(r) == "median" for r in summary.values())
    notes: list[list[str]] = []
    rows = []
    for name, r in summary.items():
        value, unit = to_display(_estimate(r), r.get("unit"), name)
        ends = [to_display(r.get(k), r.get("unit"), name)[0] for k in ("lo68", "hi68", "lo95", "hi95")]
        bound = {"min": ends[2], "max": ends[3]}.get(r.get("at_bound"))
        if bound is not None and value is not None and abs(value - bound) <= 1e-9 * max(abs(ends[3] - ends[2]), 1e-300):
            value = bound  # on the bound to rounding (5.8e-17 against 0): show the bound
        row = [display_name(name, loads_in), unit, format_value(value),
               f"[{format_value(ends[0])}, {format_value(ends[1])}]", f"[{format_value(ends[2])}, {format_value(ends[3])}]"]
        if posterior:
            row += [format_value(r.get("rhat"), 4), _count(r.get("ess_bulk"))]
        note = []
        if column == "estimate":
            note.append(estimate_kind(r))
        if name in undetermined and verdict != "not determined":
            note.append("not determined")
        if r.get("at_bound") in _BOUND_FLAG:
            note.append(_BOUND_FLAG[r["at_bound"]])
        if name == "observation.sigma" and estimate_kind(r) == "median":
            note.append("reading noise, posterior")
        rhat = r.get("rhat")
        if rhat is not None and rhat > 1.01:
            note.append("not converged (R-hat above 1.01)")
        notes.append(note)
        rows.append(row)
    head = ["parameter", "unit", column, "68% interval", "95% interval"]
    if posterior:
        head += ["R-hat", "ESS (bulk)"]
    if any(notes):
        head.append("note")
        rows = [row + ["; ".join(note)] for row, note in zip(rows, notes)]
    return head, rows


def fit_statistics(res) -> str:
    """One paragraph on the fit: model, readings, parameters and the reading scatter.

    With a free noise scale the least-squares scatter is profiled from the residuals (a
    reduced chi-square would be 1 by construction and is not shown); with the scene's noise
    known, the reduced chi-square says how the residuals compare with it.  The scatter quoted
    here is the least-squares one; a posterior ``observation.sigma`` is in the parameter table.
    """
    a = res.attrs
    lsq = res.group("least_squares")
    la = lsq.attrs if lsq is not None else {}
    n = int(la.get("n_data", 0) or 0)
    npar = int(lsq.sizes.get("parameter", 0)) if lsq is not None else 0
    obs = res.group("observed_data")
    units = obs["reading"].attrs.get("units", "rad") if obs is not None else "rad"
    sigma_unit = "rad" if units == "notches" else units  # notch counts: the jitter is an angle
    method = {"emcee": "posterior sampled with emcee, started from a least-squares fit",
              "leastsq": "least squares (lmfit)"}.get(str(a.get("method")), str(a.get("method", "")))
    noise = [name for name in res.parameter_names if name.startswith("observation.sigma")]
    profiled = [name for name in noise if lsq is None or name not in list(map(str, lsq["parameter"].values))]
    plural = lambda k, word: f"{k} {word}{'' if k == 1 else 's'}"  # noqa: E731
    fitted = plural(npar, "parameter") + (" fitted by least squares and the reading noise profiled from the "
                                          "residuals" if profiled else "")
    model = {"balance": "Balance wheel or pendulum", "friction_rig": "Friction rig", "geneva": "Geneva escapement",
             "verge": "Verge escapement"}.get(str(a.get("model", "balance")), str(a.get("model")))
    head = (f"{model} model fitted to {plural(n, 'reading')} ({a.get('data_kind', 'readings')}): {fitted}; "
            f"{method}")
    if "redchi" not in la:
        return head + "."
    if n <= npar:
        return head + ": as many parameters as readings, the fit is exact and the readings give no scatter estimate."
    mixed = " and " in units

    def scatter(value) -> str:
        shown, label = to_display(float(value), sigma_unit, "observation.sigma")
        return f"{format_value(shown, 3)} {label}"

    posterior_sigma = res.group("posterior") is not None and "observation.sigma" in res.group("posterior")
    where = " (the posterior's reading noise is the observation.sigma row of the table)" if posterior_sigma else ""
    tail = f". Information criteria at the best fit: AIC {format_value(la['aic'], 5)}, BIC {format_value(la['bic'], 5)}."
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


def _series_scatter(res, units: str) -> str:
    """RMS of reading - best fit per reading series, for recordings that mix units
    (``"deg (amplitude) and s (beats)"``); times in ms."""
    import re

    obs, lsq = res.group("observed_data"), res.group("least_squares")
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
    diag = res.group("diagnostics")
    if res.group("posterior") is None:
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
    head = ["parameter", "split R-hat", "ESS (bulk)", "ESS (tail)", "autocorrelation time (steps)"]
    rows = []
    for name in map(str, diag["parameter"].values):
        sel = diag.sel(parameter=name)
        rows.append([display_name(name, loads_in), format_value(float(sel["rhat"]), 4),
                     _count(float(sel["ess_bulk"])), _count(float(sel["ess_tail"])),
                     format_value(float(sel["tau"]), 3) if "tau" in sel else "-"])
    return sentence, head, rows


def provenance_rows(res, path) -> list[tuple[str, str]]:
    """Where the fit came from: files, their hash, solver, seed, run length, times, versions."""
    a = res.attrs
    rows = [("results file", str(path)), ("method", a.get("method")), ("scene file", a.get("scene_file")),
            ("switching", a.get("switching")), ("data file", a.get("data_file")), ("data SHA-256", a.get("data_sha256")),
            ("solver", f"{a.get('solver', '')} {a.get('solver_options', '')}".strip()), ("seed", a.get("seed")),
            ("walkers x steps (burn)", f"{a.get('walkers', '-')} x {a.get('steps', '-')} ({a.get('burn', '-')})"
             if "walkers" in a else None),
            ("started / finished", f"{a.get('started')} / {a.get('finished')}"), ("schema", a.get("schema_version")),
            ("versions", a.get("versions")), ("failed evaluations", a.get("failures"))]
    return [(k, str(v)) for k, v in rows if v not in (None, "", "None None", "None / None")]


def _count(value) -> str:
    """An effective sample size: a whole number of draws (``-`` when undefined)."""
    import math

    try:
        v = float(value)
    except (TypeError, ValueError):
        return "-"
    return f"{v:.0f}" if math.isfinite(v) else "-"
