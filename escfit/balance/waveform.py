"""theta(t) at given times, for fits to a sampled waveform (an angle recorded against time).

One run of any solver with its dense solution (:mod:`escfit.balance.solution`), long enough to
pass the last time, then the dense solution at every time: the closed form of the exact solver
(no integration error), or a step of the compiled integrator from its stored steps (dop853; a
pendulum or a smooth torque needs one).  Times are seconds since the release at rest from
``theta0``; theta is in rad, positive in the sense of ``theta0`` (the scene's frame).  Once
friction holds the balance, theta stays at the rest angle; past a failed run the values are NaN.
:func:`sample_state` also gives theta'(t).
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from ..core.errors import SolverError
from .solvers import default_solver, solve_system
from .system import System

__all__ = ["sample_theta", "sample_state", "sample_scene"]


def _swings_for(system: System, t_end: float) -> int:
    """Half swings that probably cover ``t_end`` s (each lasts about pi/omega0)."""
    return int(min(t_end * system.omega0 / math.pi * 1.1, 1e7)) + 2


def _times(times: Any) -> np.ndarray:
    t = np.ascontiguousarray(times, dtype=float)
    if t.ndim != 1:
        raise SolverError(f"sample times must be a 1-d array, got shape {t.shape}")
    if t.size and not (t[0] >= 0.0 and math.isfinite(t[-1]) and np.all(np.diff(t) >= 0.0)):
        raise SolverError("sample times must be finite, >= 0 and sorted ascending (s since release)")
    return t


def sample_state(system: System, times: np.ndarray, solver: str | None = None, *, max_swings: int = 10_000_000,
                 **options: Any) -> tuple[np.ndarray, np.ndarray, str]:
    """theta (rad) and theta' (rad/s) at the given times (s since release, ascending, >= 0), and a status.

    Parameters
    ----------
    system
        One parameter set (``scene.system(values)`` or ``scene.build(values)``).
    times
        Sample times, s since the release at rest.
    solver
        Any solver (default :func:`~escfit.balance.solvers.default_solver`).
    max_swings
        Bound on the half swings run to reach the last time.
    **options
        The solver's options (``dense`` and ``t_end`` are set here).

    Returns
    -------
    theta, omega : ndarray
        State at each time; the rest angle (and 0) after a stop, NaN after a failure or beyond
        the budget.
    status : str
        The run's status label up to the last time; ``"max_segments"`` also when ``max_swings``
        ended the run before the last time.

    Raises
    ------
    SolverError
        For a solver that cannot handle the system, unknown options, bad times or parameters.
    """
    solver = solver or default_solver(system)
    bad = sorted({"dense", "t_end"} & set(options))
    if bad:
        raise SolverError(f"sampling sets {bad} itself")
    t = _times(times)
    if not t.size:
        return np.empty(0), np.empty(0), "ok"
    t_end = float(t[-1])
    n = min(_swings_for(system, t_end), max_swings)
    while True:
        tr = solve_system(system, n, solver, dense=True, t_end=t_end, **options)
        reached = tr.final[0] >= t_end
        if reached or len(tr.amplitude) < n or n >= max_swings:  # done, or ended for another reason
            break
        # the half swings were longer than pi/omega0: scale by the time covered
        n = min(max_swings, max(2 * n, int(n * t_end / max(tr.final[0], 1e-300) * 1.1) + 2))
    theta, omega = tr.dense.state(t)
    status = tr.status
    if not reached and status not in ("stopped", "max_segments", "failed"):
        return theta, omega, "max_segments"
    # a creep to rest (final time inf) counts as stopped from the start of its last piece
    knots = tr.dense.knots()
    t_stop = tr.final[0] if math.isfinite(tr.final[0]) or knots.size < 2 else float(knots[-2])
    if status in ("ok", "banked") or (status == "stopped" and t_stop > t_end):
        # the run went past the last time: report what happened up to it
        return theta, omega, "banked" if tr.banked.any() and tr.time[tr.banked.argmax()] <= t_end else "ok"
    return theta, omega, status


def sample_theta(system: System, times: np.ndarray, solver: str | None = None, **options: Any) -> tuple[np.ndarray, str]:
    """theta (rad) at the given times and the run's status; see :func:`sample_state`."""
    theta, _, status = sample_state(system, times, solver, **options)
    return theta, status


def sample_scene(scene: Any, times: np.ndarray, values: Mapping[str, float] | None = None,
                 solver: str | None = None, **options: Any) -> tuple[np.ndarray, str]:
    """theta (rad) of a whole scene at the given times; see :func:`sample_state`.

    Parameters
    ----------
    scene
        A :class:`~escfit.balance.scene.BalanceScene`.
    times
        Sample times (s since release, ascending, >= 0).
    values
        Parameter values by name overriding the scene's.
    solver
        Default :func:`~escfit.balance.solvers.default_solver` (exact, dop853 for a pendulum).
    """
    return sample_theta(scene.build(values), times, solver or default_solver(scene), **options)
