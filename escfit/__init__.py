"""escfit: identify the physical parameters of mechanical timekeeping oscillators.

The public API is small:

- :func:`load_scene` reads a TOML scene (``model = "balance" | "geneva" | "verge" | "friction_rig"``);
- :func:`simulate` runs it and returns an :class:`xarray.Dataset`;
- :func:`fit` fits a scene's free parameters to a recording (:func:`escfit.inference.fit`);
- :func:`load_fit` reads a results file back;
- :func:`to_lmfit` hands a scene and a recording to lmfit (``Parameters`` and a ``Minimizer``),
  :func:`lmfit_parameters` a results file (best fit and standard errors).

Everything but the version and the error classes is imported on first use, so that
``import escfit`` (and the command line's ``--help``) stays quick.
"""

from __future__ import annotations

import importlib
from typing import Any

from .core.errors import DataError, EscfitError, FitError, ResultsError, SceneError, SolverError, UnitError
from .core.version import __version__

__all__ = [
    "__version__", "load_scene", "simulate", "fit", "load_fit", "to_lmfit", "lmfit_parameters",
    "EscfitError", "SceneError", "UnitError", "DataError", "SolverError", "FitError", "ResultsError",
]

# Public names defined in submodules, imported when first read: name -> (module, attribute)
_LAZY = {
    "load_scene": ("escfit.core.scene", "load_scene"),
    "fit": ("escfit.inference", "fit"),
    "load_fit": ("escfit.results", "load_fit"),
    "to_lmfit": ("escfit.inference.lmfit_params", "to_lmfit"),
    "lmfit_parameters": ("escfit.inference.lmfit_params", "parameters_from_results"),
}
# Subpackages reachable as attributes (``escfit.inference.fit(...)`` after ``import escfit``)
_SUBPACKAGES = frozenset({"analysis", "balance", "core", "fitting", "friction", "geneva", "inference", "likelihood",
                          "observation", "recordings", "report", "results", "study", "verge", "cli"})


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        module, attr = _LAZY[name]
        value = getattr(importlib.import_module(module), attr)
        globals()[name] = value
        return value
    if name in _SUBPACKAGES:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY, *_SUBPACKAGES})


def simulate(scene, solver: str | None = None, **options: Any):
    """Simulate a scene (object or path to a TOML file).

    Parameters
    ----------
    scene
        A scene object from :func:`load_scene`, or a path.
    solver
        Model-specific solver name (balance: ``"exact"``, the default where a closed form exists,
        ``"dop853"``, the default otherwise -- pendulums, air drag, stiffening springs --, ``"rk4"``,
        ``"ivp"``).
    **options
        Solver options; unknown ones are refused before any work.

    Returns
    -------
    xarray.Dataset
        Per-swing (balance) or time-history (other models) results with the run's
        ``status`` in ``attrs``.
    """
    from .core.scene import load_scene, model_module

    if not hasattr(scene, "model"):
        scene = load_scene(scene)
    module = model_module(scene.model)
    if solver is None:
        return module.simulate(scene, **options)
    return module.simulate(scene, solver, **options)


def load_fit(path):
    """Read a results file written by ``escfit fit`` or :func:`fit`.

    Parameters
    ----------
    path
        The results file (HDF5).

    Returns
    -------
    escfit.results.FitResult
        See :func:`escfit.results.load_fit`.
    """
    from .results import load_fit as _load

    return _load(path)
