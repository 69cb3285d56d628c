"""escfit: identify the physical parameters of mechanical timekeeping oscillators.

What a notebook needs is here, imported on first use so that ``import escfit`` (and the
command line's ``--help``) stays quick:

- :func:`load_scene` reads a TOML scene (its ``model =`` names the family: ``"balance"``,
  ``"geneva"``, ``"verge"``, ``"friction_rig"`` or one added with
  :func:`escfit.core.family.register_family`) into a :class:`Scene`;
- :func:`read_recording` reads a recording file of a family's formats;
- :func:`simulate` runs a scene of any family and returns an :class:`xarray.Dataset`;
  :func:`solve` runs a balance or pendulum scene and returns its per-swing trajectory;
- :func:`fit` fits a scene's free parameters to a recording (:func:`escfit.inference.fit`);
- :func:`load_results` reads a saved fit, or a ``fit-many`` fleet summary, back;
- :func:`to_lmfit` hands a scene and a recording to lmfit (``Parameters`` and a ``Minimizer``),
  :func:`lmfit_parameters` a results file (best fit and standard errors).

The subpackages (``escfit.balance``, ``escfit.inference``, ``escfit.study`` ...) are reachable as
attributes too; docs/architecture.md shows how they are layered.
"""

from __future__ import annotations

import importlib
from typing import Any

from .core.errors import DataError, EscfitError, FitError, ResultsError, SceneError, SolverError, UnitError
from .core.version import __version__

__all__ = [
    "__version__", "Scene", "load_scene", "read_recording", "simulate", "solve", "fit", "load_results", "load_fit",
    "to_lmfit", "lmfit_parameters",
    "EscfitError", "SceneError", "UnitError", "DataError", "SolverError", "FitError", "ResultsError",
]

# Public names defined in submodules, imported when first read: name -> (module, attribute)
_LAZY = {
    "Scene": ("escfit.core.scene", "Scene"),
    "load_scene": ("escfit.core.scene", "load_scene"),
    "fit": ("escfit.inference", "fit"),
    "solve": ("escfit.balance", "solve"),
    "load_fit": ("escfit.results", "load_fit"),
    "to_lmfit": ("escfit.inference.lmfit_params", "to_lmfit"),
    "lmfit_parameters": ("escfit.inference.lmfit_params", "parameters_from_results"),
}
# Subpackages reachable as attributes (``escfit.inference.fit(...)`` after ``import escfit``)
_SUBPACKAGES = frozenset({"analysis", "balance", "core", "friction", "geneva", "inference", "likelihood", "report",
                          "results", "study", "verge", "cli"})


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
        ``"ivp"``); ``None``: the family's default.
    **options
        Solver options; unknown ones are refused before any work.

    Returns
    -------
    xarray.Dataset
        Per-swing (balance) or time-history (other models) results with the run's
        ``status`` in ``attrs``.
    """
    from .core.family import get_family
    from .core.scene import load_scene

    if not hasattr(scene, "model"):
        scene = load_scene(scene)
    return get_family(scene.model).simulate(scene, solver, **options)


def read_recording(path, *, model: str = "balance", fmt: str | None = None, **options: Any):
    """Read a recording file as ``escfit fit`` does for a scene of family ``model``.

    Parameters
    ----------
    path
        The recording file.
    model
        The family whose formats to read (a scene's ``model =`` value).
    fmt
        One of the family's formats; detected from the file's content when ``None``.
    **options
        The family's reading options (balance: ``recording``, the ``[recording]`` table of a raw
        table or ``.mat`` file, and ``notch_deg``).

    Returns
    -------
    object
        The family's recording (balance: a unit curve, passage times, timegrapher readings or a
        time series; see :meth:`escfit.core.family.Family.read`).
    """
    from .core.family import get_family

    return get_family(model).read(path, fmt=fmt, **options)


def load_results(path):
    """Read a results file of ``escfit fit`` (or :func:`fit`), or the fleet summary of ``escfit fit-many``.

    Parameters
    ----------
    path
        A fit's results file (HDF5), or a ``fit-many`` results directory or its ``summary.nc``.

    Returns
    -------
    escfit.results.FitResult or xarray.Dataset
        The fit (:func:`escfit.results.load_fit`), or the fleet summary with a ``unit`` dimension
        (:func:`escfit.study.load_summary`).
    """
    from .study.fleet_table import is_fleet_summary, read_fleet_summary

    if is_fleet_summary(path):
        return read_fleet_summary(path)
    from .results import load_fit as _load

    return _load(path)
