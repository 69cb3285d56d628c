"""escfit: identify the physical parameters of mechanical timekeeping oscillators.

The public API is small:

- :func:`load_scene` reads a TOML scene (``model = "balance" | "geneva" | "verge" | "friction_rig"``);
- :func:`simulate` runs it and returns an :class:`xarray.Dataset`.
"""

from __future__ import annotations

from typing import Any

from .core.version import __version__

from .core.errors import DataError, EscfitError, FitError, ResultsError, SceneError, SolverError, UnitError
from .core.scene import load_scene

__all__ = [
    "__version__", "load_scene", "simulate", "load_fit",
    "EscfitError", "SceneError", "UnitError", "DataError", "SolverError", "FitError", "ResultsError",
]


def simulate(scene, solver: str | None = None, **options: Any):
    """Simulate a scene (object or path to a TOML file).

    Parameters
    ----------
    scene
        A scene object from :func:`load_scene`, or a path.
    solver
        Model-specific solver name (balance: ``"exact"``, the default for springs, ``"dop853"``, the
        default for pendulums, ``"rk4"``, ``"ivp"``).
    **options
        Solver options; unknown ones are refused before any work.

    Returns
    -------
    xarray.Dataset
        Per-swing (balance) or time-history (other models) results with the run's
        ``status`` in ``attrs``.
    """
    from .core.scene import model_module

    if not hasattr(scene, "model"):
        scene = load_scene(scene)
    module = model_module(scene.model)
    if solver is None:
        return module.simulate(scene, **options)
    return module.simulate(scene, solver, **options)


def load_fit(path):
    """Read a results file written by ``escfit fit`` (see :func:`escfit.results.load_fit`)."""
    from .results import load_fit as _load

    return _load(path)
