"""Model comparison by PSIS-LOO, per unit and over a fleet, and the Chapter V decay pattern.

Each model is fitted to the same recordings (one results directory per model, one file per
unit, from :func:`escfit.study.fit_many` with ``method = "emcee"``).  For every unit and model
``arviz.loo`` turns the stored pointwise log-likelihood (the ``log_likelihood`` group) into
the expected log predictive density ``elpd_loo``; fleet totals add the units, and the
standard error of a difference comes from the pointwise differences over all readings.

Monday's Chapter V remark -- measured curves decay more slowly than the computed ones over
the first cycles and faster as they approach constant amplitude -- is a statement about the
residuals of his phase model.  :func:`decay_residuals` collects observed minus fitted
amplitudes per reading, and :func:`chapter5_contrast` measures that residual after the first
cycles (positive: the recording decayed more slowly than the model) and its change over the
approach to steady state (negative: faster).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import xarray as xr

from ..core.errors import ResultsError
from ..inference.compare import K_GOOD as K_BAD
from ..results import clean_attrs, load_fit

__all__ = ["ModelComparison", "compare_models", "decay_residuals", "chapter5_contrast", "unit_files"]


def unit_files(results: str | Path, units: Sequence[str] | None = None) -> dict[str, Path]:
    """Results files of a directory by unit (file stem), optionally only ``units``."""
    p = Path(results)
    if not p.is_dir():
        raise ResultsError("results directory not found", str(p))
    files = {f.stem: f for f in sorted(p.glob("*.h5"))}
    if units is not None:
        missing = [u for u in units if u not in files]
        if missing:
            raise ResultsError(f"no results for unit(s) {missing}", str(p))
        files = {u: files[u] for u in units}
    return files


def _open_group(path: Path, group: str | None) -> xr.Dataset:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return xr.open_dataset(path, group=group, engine="h5netcdf").load()
    except Exception as exc:  # noqa: BLE001 - any unreadable file becomes one message
        raise ResultsError(f"cannot read group {group or '/'!r} ({type(exc).__name__}: {exc})", str(path)) from None


def _loo(path: Path):
    """PSIS-LOO of one results file (see :func:`escfit.inference.compare.psis_loo`)."""
    from ..inference.compare import psis_loo

    return psis_loo(load_fit(path))


@dataclass
class ModelComparison:
    """PSIS-LOO of several models on the same units.

    Attributes
    ----------
    models, units
        Model names (as given) and the units all of them fitted.
    elpd, se, p_loo, max_k, n_bad_k
        Per model and unit (arrays of shape (models, units)): expected log predictive
        density, its standard error, effective number of parameters, the largest Pareto k
        and the number of readings with k > 0.7.
    pointwise
        Per model, the pointwise elpd of every reading of every unit (concatenated in unit
        order), for the standard errors of differences.
    n_obs
        Readings per unit.
    """

    models: list[str]
    units: list[str]
    elpd: np.ndarray
    se: np.ndarray
    p_loo: np.ndarray
    max_k: np.ndarray
    n_bad_k: np.ndarray
    pointwise: dict[str, np.ndarray]
    n_obs: np.ndarray

    @property
    def best(self) -> str:
        """The model with the largest fleet elpd."""
        return self.models[int(np.argmax(self.elpd.sum(axis=1)))]

    @property
    def unit_best(self) -> list[str]:
        return [self.models[i] for i in np.argmax(self.elpd, axis=0)]

    def unit_diff(self, model: str, reference: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Per unit: elpd(model) - elpd(reference) and its standard error."""
        ref = reference or self.best
        a, b = self.pointwise[model], self.pointwise[ref]
        edges = np.concatenate([[0], np.cumsum(self.n_obs)])
        d = np.array([(a[s:e] - b[s:e]).sum() for s, e in zip(edges[:-1], edges[1:])])
        se = np.array([math.sqrt((e - s) * np.var(a[s:e] - b[s:e])) for s, e in zip(edges[:-1], edges[1:])])
        return d, se

    def fleet(self) -> list[dict]:
        """One row per model, best first: total elpd and se, difference to the best and its se,
        the number of units for which the model is best, and Pareto-k diagnostics."""
        best = self.best
        rows = []
        counts = {m: self.unit_best.count(m) for m in self.models}
        for i, m in enumerate(self.models):
            d = self.pointwise[m] - self.pointwise[best]
            rows.append({"model": m, "elpd": float(self.elpd[i].sum()),
                         "se": float(math.sqrt(d.size * np.var(self.pointwise[m]))),
                         "d_elpd": float(d.sum()), "d_se": float(math.sqrt(d.size * np.var(d))),
                         "units_best": counts[m], "p_loo": float(self.p_loo[i].sum()),
                         "max_k": float(self.max_k[i].max()), "readings_k_over_0.7": int(self.n_bad_k[i].sum())})
        return sorted(rows, key=lambda r: -r["elpd"])

    def table(self) -> str:
        """The fleet comparison as a Markdown table."""
        head = "| model | elpd_loo | se | elpd - best | se of difference | units best | max Pareto k | readings k > 0.7 |"
        lines = [head, "|---|---:|---:|---:|---:|---:|---:|---:|"]
        for r in self.fleet():
            lines.append(f"| {r['model']} | {r['elpd']:.1f} | {r['se']:.1f} | {r['d_elpd']:.1f} | {r['d_se']:.1f} | "
                         f"{r['units_best']}/{len(self.units)} | {r['max_k']:.2f} | {r['readings_k_over_0.7']} |")
        return "\n".join(lines)

    def to_dataset(self) -> xr.Dataset:
        ds = xr.Dataset(
            {"elpd_loo": (("model", "unit"), self.elpd), "se": (("model", "unit"), self.se),
             "p_loo": (("model", "unit"), self.p_loo), "max_pareto_k": (("model", "unit"), self.max_k),
             "n_pareto_k_over_0.7": (("model", "unit"), self.n_bad_k),
             "best": (("unit",), np.array(self.unit_best, dtype=object))},
            coords={"model": np.array(self.models, dtype=object), "unit": np.array(self.units, dtype=object)})
        ds.attrs = clean_attrs({"fleet": self.fleet(), "best": self.best})
        return ds


def compare_models(results: Mapping[str, str | Path], *, units: Sequence[str] | None = None) -> ModelComparison:
    """Compare models fitted to the same units by PSIS-LOO.

    Parameters
    ----------
    results
        Model name -> results directory (one ``<unit>.h5`` per unit, fitted with emcee).
    units
        Units to compare (default: those every directory holds).

    Raises
    ------
    ResultsError
        A directory is missing, no unit is common to all, a file lacks the
        ``log_likelihood`` group, or the readings differ between models.
    """
    models = list(results)
    if len(models) < 2:
        raise ResultsError(f"need at least two models to compare, got {models}")
    files = {m: unit_files(results[m]) for m in models}
    if units is None:
        common = set.intersection(*(set(f) for f in files.values()))
        units = [u for u in files[models[0]] if u in common]
    if not units:
        raise ResultsError("no unit has results for every model: " + ", ".join(f"{m}: {len(f)}" for m, f in files.items()))
    shape = (len(models), len(units))
    elpd, se, p_loo, max_k, n_bad = (np.full(shape, np.nan) for _ in range(5))
    pointwise = {m: [] for m in models}
    n_obs = np.zeros(len(units), int)
    for j, u in enumerate(units):
        for i, m in enumerate(models):
            if u not in files[m]:
                raise ResultsError(f"no results for unit {u!r}", str(results[m]))
            loo = _loo(files[m][u])
            k = np.asarray(loo.pareto_k)
            elpd[i, j], se[i, j], p_loo[i, j] = loo.elpd_loo, loo.se, loo.p_loo
            max_k[i, j], n_bad[i, j] = float(np.max(k)), int(np.sum(k > K_BAD))
            pw = np.asarray(loo.loo_i)
            if i and pw.size != n_obs[j]:
                raise ResultsError(f"unit {u!r} has {pw.size} readings here and {n_obs[j]} for model {models[0]!r}: "
                                   "models must be fitted to the same recordings", str(files[m][u]))
            n_obs[j] = pw.size
            pointwise[m].append(pw)
    return ModelComparison(models, list(units), elpd, se, p_loo, max_k, n_bad.astype(int),
                           {m: np.concatenate(v) for m, v in pointwise.items()}, n_obs)


def decay_residuals(results: str | Path, *, units: Sequence[str] | None = None) -> xr.Dataset:
    """Observed minus fitted amplitude at every reading of every curve.

    Notch counts are read as the middle of their notch; the fit is the posterior-predictive
    mean (or the least-squares curve when the file has no posterior).

    Returns
    -------
    xarray.Dataset
        Dimensions (unit, curve, reading); variables ``observed``, ``fitted``, ``residual``
        (rad), ``swing`` and ``load``.  Curves with fewer readings are padded with NaN.
    """
    from ..results import check_results_file

    files = unit_files(results, units)
    rows = []
    for u, path in files.items():
        check_results_file(path)  # the layout, from its metadata, before any group is read
        obs = _open_group(path, "observed_data")
        root = _open_group(path, None)
        try:
            fitted = _open_group(path, "posterior_predictive")["expected"].mean(("chain", "draw")).values
        except ResultsError:
            fitted = _open_group(path, "least_squares")["expected"].values
        y = obs["reading"].values.astype(float)
        if root.attrs.get("data_kind") == "notches":
            notch = _notch_of(root.attrs.get("scene", ""))
            y = (y + 0.5) * notch
        curve = obs["curve"].values.astype(str)
        for c in dict.fromkeys(curve):
            k = curve == c
            rows.append((u, str(c), y[k], fitted[k], obs["swing"].values[k], float(obs["load"].values[k][0])))
    if not rows:
        raise ResultsError("no results files", str(results))
    unit_names = list(dict.fromkeys(r[0] for r in rows))
    per_unit = {u: [r for r in rows if r[0] == u] for u in unit_names}
    n_curve = max(len(v) for v in per_unit.values())
    n_read = max(r[2].size for r in rows)
    arr = {k: np.full((len(unit_names), n_curve, n_read), np.nan) for k in ("observed", "fitted", "swing")}
    load = np.full((len(unit_names), n_curve), np.nan)
    for i, u in enumerate(unit_names):
        for j, r in enumerate(per_unit[u]):
            n = r[2].size
            arr["observed"][i, j, :n], arr["fitted"][i, j, :n], arr["swing"][i, j, :n] = r[2], r[3], r[4]
            load[i, j] = r[5]
    dims = ("unit", "curve", "reading")
    ds = xr.Dataset({"observed": (dims, arr["observed"], {"units": "rad"}),
                     "fitted": (dims, arr["fitted"], {"units": "rad"}),
                     "residual": (dims, arr["observed"] - arr["fitted"], {"units": "rad",
                                                                          "long_name": "observed - fitted"}),
                     "swing": (dims, arr["swing"]), "load": (("unit", "curve"), load)},
                    coords={"unit": np.array(unit_names, dtype=object), "curve": np.arange(n_curve),
                            "reading": np.arange(n_read)})
    ds.attrs["results"] = str(results)
    return ds


def _notch_of(scene_text: str) -> float:
    import tomllib

    try:
        deg = float(tomllib.loads(scene_text).get("observation", {}).get("notch_deg", 6.0))
    except (tomllib.TOMLDecodeError, TypeError, ValueError):
        deg = 6.0
    return math.radians(deg)


def chapter5_contrast(residuals: xr.Dataset, *, first: int = 1, settled: int = 3) -> dict[str, float]:
    """Monday's Chapter V pattern in numbers.

    Model and unit start from the same release angle (the banking pin), so the residual at
    reading ``first`` (default: two cycles after release) is what the first cycles did: positive
    when the recording decayed more slowly than the model.  Its change from reading ``first``
    to ``settled`` (the approach to steady state) is negative when the recording then decays
    faster.  Each is averaged over a unit's curves, then over units, with the standard error
    between units.

    Returns
    -------
    dict
        ``early``, ``early_se``, ``approach``, ``approach_se`` (rad), ``units`` and
        ``pattern`` (1 when early > 2 se and approach < -2 se, i.e. Monday's remark holds).
    """
    r = residuals["residual"]

    def stat(x: xr.DataArray) -> tuple[float, float, int]:
        per_unit = x.mean("curve").values
        per_unit = per_unit[np.isfinite(per_unit)]
        return float(per_unit.mean()), float(per_unit.std(ddof=1) / math.sqrt(per_unit.size)), per_unit.size

    e, e_se, n = stat(r.isel(reading=first))
    a, a_se, _ = stat(r.isel(reading=settled) - r.isel(reading=first))
    return {"early": e, "early_se": e_se, "approach": a, "approach_se": a_se, "units": n,
            "pattern": int(e > 2 * e_se and a < -2 * a_se)}
