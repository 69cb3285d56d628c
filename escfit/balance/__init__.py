"""The balance wheel under an escapement (Monday 1965; Theory of Horology 3-2).

Per unit inertia::

    theta'' + C theta' + g(theta) + R sgn(theta') + F_esc + F_smooth = 0

with ``g`` the hairspring (``omega0**2 * theta`` unless a piecewise hairspring is named) or,
with ``[oscillator] restoring = "pendulum"``, gravity (``omega0**2 * sin(theta)``), ``C``
viscous, ``R`` Coulomb, ``F_esc`` the escapement windows and ``F_smooth`` the smooth torques
without a closed form (air drag, a stiffening spring).  Only the effects a scene names are
simulated.  A scene with a closed form is solved in closed form by default, any other by the
compiled adaptive solver ``"dop853"`` (:func:`default_solver`); see docs/physics.md.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .dense import dense_output
from .scene import BalanceScene, parse
from .solvers import SOLVERS, default_solver, solve_system
from .system import System
from .trajectory import Trajectory
from .waveform import sample_scene, sample_state, sample_theta

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["BalanceScene", "parse", "simulate", "solve", "json_summary", "dense_output", "Trajectory", "SOLVERS",
           "default_solver", "sample_theta", "sample_state", "sample_scene", "System"]


def solve(scene: BalanceScene, solver: str | None = None, *, values: dict[str, float] | None = None,
          swings: int | None = None, **options: Any) -> Trajectory:
    """Run a balance scene and return the per-swing :class:`Trajectory`.

    Parameters
    ----------
    scene
        A balance scene.
    solver
        ``"exact"``, ``"dop853"``, ``"rk4"`` or ``"ivp"``; default :func:`default_solver`
        (``"exact"``, or ``"dop853"`` where the scene has no closed form: a pendulum, air drag, a
        stiffening spring).
    values
        Parameter values by name overriding the scene's (used by fits).
    swings
        Number of half swings (default: the scene's ``[run] swings``).
    **options
        Solver options (see :data:`SOLVERS`); ``dense=True`` keeps the dense solution
        (:attr:`Trajectory.dense`: theta(t), theta'(t), level crossings, turning points).
    """
    return solve_system(scene.build(values), swings or scene.swings, solver or default_solver(scene), **options)


def simulate(scene: BalanceScene, solver: str | None = None, *, swings: int | None = None,
             **options: Any) -> xr.Dataset:
    """Simulate a balance scene; see :func:`escfit.simulate` (solver default: :func:`default_solver`)."""
    from ..core.version import __version__

    traj = solve(scene, solver, swings=swings, **options)
    return traj.to_dataset({
        "model": "balance",
        "switching": scene.switching,
        "restoring": scene.restoring,
        "scene": scene.text,
        "scene_file": scene.where,
        "escfit_version": __version__,
    })


def json_summary(ds: xr.Dataset) -> dict[str, Any]:
    """The JSON object ``escfit simulate --json`` prints for a balance run."""
    def arr(name: str) -> list:
        return [None if not np.isfinite(v) else float(v) for v in ds[name].values]

    return {
        "amplitude": arr("amplitude"),
        "half_period": arr("half_period"),
        "time": arr("time"),
        "rate": arr("rate"),
        "status": ds.attrs["status"],
        "solver": ds.attrs["solver"],
        "switching": ds.attrs["switching"],
    }
