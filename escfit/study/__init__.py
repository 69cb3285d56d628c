"""Fleet studies: batch fits of many units, population estimates and model comparison.

- :func:`fit_many` fits every unit of one or more recordings independently on
  dask.distributed (a local cluster by default, or a running one) and writes one results file
  per unit plus a combined summary with a ``unit`` dimension.
- :func:`collect_draws` and :func:`fit_population` estimate the log-normal population of
  C, R and X from the per-unit posteriors by hierarchical reweighting, and set unit-to-unit
  scatter against measurement noise.
- :func:`compare_models` compares Monday's phase model, the phase model with his damping
  drift and the angle model by PSIS-LOO per unit and over the fleet;
  :func:`decay_residuals` and :func:`chapter5_contrast` test his Chapter V remark.
- :func:`generate_fleet` draws synthetic fleets with known truth, recorded like his rig.
- :class:`StudySettings` and :func:`cross_fit` run the standard study (every shipped fleet
  fitted by every model) that the notebooks show.

Plotting lives in :mod:`escfit.study.plots` (matplotlib, imported there only).
"""

import importlib

# Names load their module on first use, so that reading a fleet summary (escfit summary) does not
# import dask, the population model and the fleet generator.
_HOME = {
    "batch": ("BatchResult", "LazyClient", "discover_units", "fit_fleet", "fit_many", "load_summary", "unit_seed"),
    "compare": ("ModelComparison", "chapter5_contrast", "compare_models", "decay_residuals"),
    "fleet": ("Fleet", "FleetSpec", "LogNormal", "generate_fleet", "load_fleet", "preset", "record_unit"),
    "population": ("PopulationResult", "UnitDraws", "collect_draws", "fit_population", "load_population"),
    "runs": ("StudySettings", "cross_fit", "results_dir"),
    "scenes": ("MODELS", "POPULATION_PARAMS", "Rig", "fit_scene", "generating_scene"),
}
_WHERE = {name: module for module, names in _HOME.items() for name in names}


def __getattr__(name: str):
    if name in _WHERE:
        value = getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_WHERE))


__all__ = [
    "fit_many", "fit_fleet", "BatchResult", "LazyClient", "discover_units", "load_summary", "unit_seed",
    "collect_draws", "fit_population", "UnitDraws", "PopulationResult", "load_population",
    "compare_models", "ModelComparison", "decay_residuals", "chapter5_contrast",
    "generate_fleet", "load_fleet", "preset", "record_unit", "Fleet", "FleetSpec", "LogNormal",
    "MODELS", "POPULATION_PARAMS", "Rig", "fit_scene", "generating_scene",
    "StudySettings", "cross_fit", "results_dir",
]
