"""Rank fits of the same readings by expected predictive accuracy.

Two criteria, one per kind of fit, never mixed:

* **posterior fits** (emcee): PSIS-LOO (ArviZ) from the pointwise log-likelihood stored with
  the posterior (the ``log_likelihood`` group): ``elpd_loo`` per fit (higher is better), its
  standard error, the difference to the best fit ``elpd_diff`` and the standard error of that
  difference ``dse`` from the pointwise differences (as :func:`arviz.compare` computes them),
  and the Pareto-k diagnostic of every reading;
* **least-squares fits**: AICc and BIC from the log-likelihood stored at the optimum
  (``least_squares`` attributes ``loglike``, ``n_params``, ``noise_model``; see
  :mod:`escfit.inference.information`), the differences to the best and Akaike weights.
  Information criteria are point values: they have no standard error.

A posterior's elpd and a least-squares AICc estimate predictive accuracy in different ways
(the first averages over the posterior and cross-validates, the second corrects a best fit's
likelihood by a parameter count), so fits of different methods are refused, as are fits of
different readings (data SHA-256, the readings themselves, how they were read).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from ..core.errors import ResultsError
from ..results import FitResult, load_fit
from .information import EXACT_KEY, akaike_weights, stored_criteria

__all__ = ["FitComparison", "compare_fits", "psis_loo", "verdict_choice", "K_GOOD"]

#: Pareto k above which a reading's PSIS-LOO estimate is unreliable (ArviZ lowers it for few draws)
K_GOOD = 0.7

LOO, IC = "loo", "aicc"


def psis_loo(result: FitResult):
    """PSIS-LOO of a posterior fit (ArviZ's ``ELPDData``, pointwise).

    Raises
    ------
    ResultsError
        The file holds no posterior or no pointwise log-likelihood.
    """
    import arviz as az

    post, ll = result.group("posterior"), result.group("log_likelihood")
    if post is None or ll is None:
        raise ResultsError("no posterior with pointwise log-likelihood (a least-squares fit?)", result.path or None)
    bad = sum(int(np.sum(~np.isfinite(ll[v].values))) for v in ll.data_vars)
    if bad:
        raise ResultsError(f"{bad} pointwise log-likelihood values are not finite (draws whose model failed): PSIS-LOO "
                           "needs every draw; refit, or fix what the failures count names", result.path or None)
    idata = az.InferenceData(posterior=post, log_likelihood=ll)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # high Pareto k is reported in words instead
        return az.loo(idata, pointwise=True)


@dataclass
class FitComparison:
    """Fits of one set of readings, best first.

    Attributes
    ----------
    criterion
        ``"loo"`` (posterior fits) or ``"aicc"`` (least-squares fits).
    rows
        One dict per fit, best first (keys in :meth:`table`'s columns and ``file``).
    data
        What the fits share: data file, SHA-256, kind, number of readings.
    notes
        Statements about the comparison as a whole (in words); the last is the verdict.
    choice
        The file the verdict names: the best, or among fits the criterion does not tell apart
        the one with the fewest parameters (see :func:`verdict_choice`).
    """

    criterion: str
    rows: list[dict]
    data: dict
    notes: list[str] = field(default_factory=list)
    choice: str = ""

    @property
    def best(self) -> str:
        """The file ranked first by the criterion."""
        return self.rows[0]["file"]

    def to_json(self) -> dict:
        return {"criterion": self.criterion, "data": self.data, "fits": self.rows, "notes": self.notes,
                "choice": self.choice}

    def table(self) -> str:
        """The comparison as aligned text, best first, followed by the notes."""
        if self.criterion == LOO:
            head = ["rank", "file", "k", "elpd_loo", "se", "p_loo", "elpd_diff", "dse", "Pareto k"]
            body = [[str(r["rank"]), r["label"], str(r["n_params"]), f"{r['elpd_loo']:.2f}", f"{r['se']:.2f}", f"{r['p_loo']:.2f}",
                     f"{r['elpd_diff']:.2f}", f"{r['dse']:.2f}", r["pareto_k_summary"]] for r in self.rows]
        else:
            head = ["rank", "file", "k", "log L", "AICc", "dAICc", "weight", "BIC", "dBIC", "noise model"]
            body = [[str(r["rank"]), r["label"], str(r["n_params"]), f"{r['loglike']:.2f}", f"{r['aicc']:.2f}",
                     f"{r['d_aicc']:.2f}", f"{r['akaike_weight']:.3f}", f"{r['bic']:.2f}", f"{r['d_bic']:.2f}",
                     r["noise_model"]] for r in self.rows]
        widths = [max(len(h), *(len(b[i]) for b in body)) for i, h in enumerate(head)]
        lines = ["  ".join(c.ljust(w) for c, w in zip(head, widths)).rstrip()]
        lines += ["  ".join(c.ljust(w) for c, w in zip(b, widths)).rstrip() for b in body]
        return "\n".join(lines)


def compare_fits(paths: Sequence[str | Path]) -> FitComparison:
    """Rank saved fits of the same readings (see the module docstring).

    Parameters
    ----------
    paths
        Two or more results files of ``escfit fit``.

    Raises
    ------
    ResultsError
        Fewer than two files, a file that cannot be read, fits of different readings or
        different observation models, fits of different methods, or a least-squares file
        without a stored log-likelihood (written by an older escfit).
    """
    paths = [str(p) for p in paths]
    if len(paths) < 2:
        raise ResultsError(f"need at least two results files to compare, got {len(paths)}")
    _refuse_repeats(paths)
    fits = [load_fit(p) for p in paths]
    data = _same_readings(fits)
    methods = {f.path: _method(f) for f in fits}
    if len(set(methods.values())) > 1:
        post = next(p for p, m in methods.items() if m == "emcee")
        lsq = next(p for p, m in methods.items() if m != "emcee")
        raise ResultsError(f"mixed methods: {post} is a posterior (emcee) fit, {lsq} a least-squares fit; PSIS-LOO "
                           "averages over a posterior and AICc/BIC correct a best fit's likelihood, so their numbers do "
                           "not compare: fit all with the same --method")
    labels = _labels(paths)
    if methods[paths[0]] == "emcee":
        return _compare_loo(fits, labels, data)
    return _compare_ic(fits, labels, data)


def _method(res: FitResult) -> str:
    return "emcee" if res.group("posterior") is not None else "leastsq"


def _labels(paths: list[str]) -> dict[str, str]:
    """Short names for the table: file names, or the whole paths when two names coincide."""
    names = [Path(p).name for p in paths]
    return {p: (n if names.count(n) == 1 else p) for p, n in zip(paths, names)}


# -- same readings ----------------------------------------------------------------------------
def _observation_signature(res: FitResult) -> dict:
    """How the readings were read: the family, the kind of readings, the observation model and
    the notch reading convention (noise laws may differ: the likelihood compares them)."""
    import tomllib

    a = res.attrs
    try:
        obs = tomllib.loads(a.get("scene", "") or "").get("observation", {})
    except tomllib.TOMLDecodeError as exc:
        raise ResultsError(f"the scene stored with this fit cannot be read ({exc})", res.path) from None
    return {"family": a.get("model", "balance"), "kind": a.get("data_kind", ""),
            "observation model": obs.get("model", "") if isinstance(obs, dict) else "",
            "notch angle": a.get("notch_deg", ""), "notch reading": a.get("notch_reading", "")}


def _refuse_repeats(paths: list[str]) -> None:
    """Refuse a file given twice, under one name or two (``r1.h5`` and ``./r1.h5``, a link)."""
    from ..core.atomic import same_file

    for i, p in enumerate(paths):
        for q in paths[:i]:
            if same_file(p, q):
                again = "" if p == q else f" (as {q!r} and {p!r})"
                raise ResultsError(f"the same results file is given twice{again}: a fit ranked against itself", p)


def _same_readings(fits: list[FitResult]) -> dict:
    first = fits[0]
    obs0 = first.group("observed_data")
    sig0 = _observation_signature(first)
    sha0 = first.attrs.get("data_sha256", "")
    for res in fits[1:]:
        sha = res.attrs.get("data_sha256", "")
        if sha != sha0:
            raise ResultsError(f"different data: {first.path} fitted data with SHA-256 {sha0[:12]}..., this file "
                               f"{sha[:12] or 'none'}...: only fits of the same readings compare", res.path)
        sig = _observation_signature(res)
        diff = [k for k in sig if sig[k] != sig0[k]]
        if diff:
            k = diff[0]
            raise ResultsError(f"different observation model: {k} {sig[k]!r} here, {sig0[k]!r} in {first.path}; "
                               "the same data read another way are different readings", res.path)
        why = _readings_differ(obs0, res.group("observed_data"))
        if why:
            raise ResultsError(f"different readings from the same data file ({why}) than {first.path}: the recording "
                               "was cut, thinned or reduced differently, so the likelihoods do not compare", res.path)
    return {"data_file": first.attrs.get("data_file", ""), "data_sha256": sha0, "data_kind": sig0["kind"],
            "model": sig0["family"], "n_readings": int(obs0["reading"].size)}


def _readings_differ(a, b) -> str:
    if a is None or b is None:
        return "a file has no observed_data group"
    if a["reading"].size != b["reading"].size:
        return f"{b['reading'].size} readings against {a['reading'].size}"
    for name in ("reading", "swing", "time"):
        if (name in a.variables) != (name in b.variables):
            return f"{name} given in one file only"
        if name in a.variables:
            x, y = np.asarray(a[name].values, float), np.asarray(b[name].values, float)
            if not np.array_equal(x, y, equal_nan=True):
                return f"the {name} values differ"
    return ""


# -- posterior fits: PSIS-LOO -------------------------------------------------------------------
def _compare_loo(fits: list[FitResult], labels: dict, data: dict) -> FitComparison:
    loos = {f.path: psis_loo(f) for f in fits}
    by_path = {f.path: f for f in fits}
    order = sorted(loos, key=lambda p: -float(loos[p].elpd_loo))
    best = np.asarray(loos[order[0]].loo_i)
    rows = []
    for rank, p in enumerate(order, 1):
        loo = loos[p]
        pw = np.asarray(loo.loo_i)
        d = best - pw
        k = np.asarray(loo.pareto_k)
        good_k = float(getattr(loo, "good_k", K_GOOD))
        rows.append({"rank": rank, "file": p, "label": labels[p], "n_params": len(by_path[p].parameter_names),
                     "elpd_loo": float(loo.elpd_loo),
                     "se": float(loo.se), "p_loo": float(loo.p_loo), "elpd_diff": float(d.sum()),
                     "dse": float(math.sqrt(d.size * np.var(d))), "n_draws": int(loo.n_samples),
                     "max_pareto_k": float(np.max(k)), "pareto_k_threshold": good_k,
                     "n_pareto_k_high": int(np.sum(k > good_k)), "n_pareto_k_very_high": int(np.sum(k > 1.0)),
                     "pareto_k_high_readings": [int(i) for i in np.flatnonzero(k > good_k)],
                     "pareto_k_high_swings": _swings(by_path[p], k > good_k),
                     "readings_are_samples": by_path[p].attrs.get("data_kind") == "timeseries",
                     "pareto_k_summary": _k_summary(k, good_k)})
    notes = ["PSIS-LOO: elpd_loo estimates how well a fit predicts new readings like these (the log predictive "
             "density summed over the readings, each left out in turn; higher is better); p_loo is the effective "
             "number of parameters; elpd_diff is the best fit's elpd minus this fit's, dse its standard error from "
             "the readings' pointwise differences. A difference smaller than about 4, or within 2 dse, does not "
             "tell the fits apart: prefer the simpler model."]
    notes += [_k_words(r) for r in rows if r["n_pareto_k_high"]]
    text, choice = _verdict_loo(rows)
    notes.append(text)
    return FitComparison(LOO, rows, data, notes, choice)


def _swings(res: FitResult, mask: np.ndarray) -> list[int]:
    """Half swings (or sample numbers) of the readings ``mask`` selects."""
    obs = res.group("observed_data")
    if obs is None or "swing" not in obs.variables:
        return []
    return [int(s) for s in np.asarray(obs["swing"].values)[mask]]


def _k_summary(k: np.ndarray, good: float) -> str:
    high = int(np.sum(k > good))
    if not high:
        return f"all <= {good:.2f}"
    return f"{high} of {k.size} > {good:.2f} (max {float(np.max(k)):.2f})"


def _k_words(row: dict) -> str:
    n, very = row["n_pareto_k_high"], row["n_pareto_k_very_high"]
    where = row["pareto_k_high_swings"]
    word = "sample" if row["readings_are_samples"] else "half swing"
    at = (f" ({word} {', '.join(map(str, where[:8]))}{', ...' if len(where) > 8 else ''})" if where else "")
    return (f"{row['label']}: {n} reading(s){at} have Pareto k above {row['pareto_k_threshold']:.2f}"
            + (f" ({very} above 1)" if very else "") + ": leaving them out changes the posterior so much that "
            "importance sampling cannot predict them reliably; this fit's elpd_loo may be too optimistic. Those "
            "readings are influential (outliers, or a model that fits them poorly): look at them, and for a "
            f"firmer number refit with more predictive draws (it used {row['n_draws']}) or cross-validate by refitting.")


def _verdict_loo(rows: list[dict]) -> tuple[str, str]:
    a, b = rows[0], rows[1]
    d, dse = b["elpd_diff"], b["dse"]
    close = [r for r in rows if r["elpd_diff"] < 4.0 or r["elpd_diff"] < 2.0 * r["dse"]]
    if len(close) > 1:
        return _undecided(close, "elpd_diff within 4 or 2 dse of the best")
    return f"verdict: {a['label']} predicts best; the next, {b['label']}, is {d:.2f} +- {dse:.2f} lower in elpd.", a["file"]


def verdict_choice(close: list[dict]) -> dict:
    """The fit to name among fits the criterion does not tell apart (``close``, best first).

    The one with the fewest parameters: a parameter that does not improve the expected
    predictive accuracy by more than the criterion's own noise is not supported by the
    readings (with a nesting model, whose extra coefficient sits at or near zero, the simpler
    law is the one the data show).  Among equally simple fits -- different laws with the same
    number of coefficients, e.g. viscous damping alone against Coulomb friction alone, which do
    not nest -- only the criterion can choose, so the best-ranked of them.
    """
    fewest = min(r["n_params"] for r in close)
    return next(r for r in close if r["n_params"] == fewest)


def _undecided(rows: list[dict], why: str) -> tuple[str, str]:
    pick = verdict_choice(rows)
    tied = [r for r in rows if r["n_params"] == pick["n_params"]]
    labels = ", ".join(r["label"] for r in rows)
    how = (f"prefer the simplest, {pick['label']} ({pick['n_params']} parameters)" if len(tied) == 1 else
           f"prefer the simplest; of those with {pick['n_params']} parameters, {pick['label']} ranks best")
    return f"verdict: {labels} are not told apart by these readings ({why}); {how}.", pick["file"]


# -- least-squares fits: AICc and BIC -----------------------------------------------------------
def _compare_ic(fits: list[FitResult], labels: dict, data: dict) -> FitComparison:
    stats = {f.path: _lsq_loglike(f) for f in fits}
    n = data["n_readings"]
    for p, (ll, k, _, _) in stats.items():
        if n - k - 1 <= 0:
            raise ResultsError(f"{n} readings and {k} free parameters: AICc needs more readings than parameters + 1", p)
    ic = {f.path: stored_criteria(f.group("least_squares").attrs, n) for f in fits}
    crit = {p: ic[p]["aicc"] for p in stats}
    order = sorted(crit, key=lambda p: crit[p])
    b = {p: ic[p]["bic"] for p in order}
    weights = akaike_weights(np.array([crit[p] for p in order]))
    rows = []
    for rank, (p, w) in enumerate(zip(order, weights), 1):
        ll, k, noise, exact = stats[p]
        rows.append({"rank": rank, "file": p, "label": labels[p], "n_params": k, "n_readings": n, "loglike": ll,
                     "aicc": crit[p], "d_aicc": crit[p] - crit[order[0]], "akaike_weight": float(w), "bic": b[p],
                     "d_bic": b[p] - min(b.values()), "noise_model": noise, "loglike_maximised": bool(exact)})
    notes = [f"AICc = -2 log L + 2k + 2k(k+1)/(n-k-1) and BIC = -2 log L + k ln n with n = {n} readings and k the "
             "parameters the least-squares fit varied (a profiled noise scale counts); lower is better. Information "
             "criteria are point values with no standard error: a dAICc below about 2 does not tell fits apart, "
             "above about 10 it does; BIC penalises extra parameters more for n > 7.",
             "Akaike weight: the relative likelihood exp(-dAICc/2) normalised over these fits."]
    if any(not r["loglike_maximised"] for r in rows):
        notes.append("for notch, whole-step or Student-t readings least squares maximises a Gaussian approximation, so "
                     "log L is the readings' own likelihood at that optimum, a lower bound of its maximum")
    if len({r["noise_model"] for r in rows}) > 1:
        notes.append("the fits use different noise models; the criteria compare them too")
    if rows[0]["d_bic"] > 0:
        notes.append(f"AICc and BIC disagree on the best fit: BIC prefers "
                     f"{next(r['label'] for r in rows if r['d_bic'] == 0)}")
    text, choice = _verdict_ic(rows)
    notes.append(text)
    return FitComparison(IC, rows, data, notes, choice)


def _lsq_loglike(res: FitResult) -> tuple[float, int, str, bool]:
    lsq = res.group("least_squares")
    a = {} if lsq is None else lsq.attrs
    if "loglike" not in a or "n_params" not in a:
        raise ResultsError("this least-squares fit has no stored log-likelihood (written by an older escfit): "
                           "fit it again to compare it", res.path)
    ll = float(a["loglike"])
    if not math.isfinite(ll):
        raise ResultsError("the model could not be evaluated at this fit's optimum, so it has no log-likelihood "
                           "to compare", res.path)
    return ll, int(a["n_params"]), str(a.get("noise_model", "")), bool(int(a.get(EXACT_KEY, 1)))


def _verdict_ic(rows: list[dict]) -> tuple[str, str]:
    a, b = rows[0], rows[1]
    close = [r for r in rows if r["d_aicc"] < 2.0]
    if len(close) > 1:
        return _undecided(close, "dAICc below 2")
    d = b["d_aicc"]
    strength = "strongly preferred" if d > 10.0 else "preferred"
    return f"verdict: {a['label']} is {strength} (dAICc {d:.2f} to {b['label']}).", a["file"]
