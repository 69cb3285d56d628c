"""theta(t) at given times, for fits to a sampled waveform (an angle recorded against time).

Two routes, both compiled, with O(1) Python work per call:

- ``"exact"``: one closed-form run with the segment log, long enough to pass the last time,
  evaluated per segment (:func:`escfit.balance.dense.log_theta_at`); no integration error.
- ``"dop853"``: the compiled adaptive integrator of :mod:`escfit.balance.dop853`, its steps
  clipped to land on the requested times; needed for a pendulum.

Times are seconds since the release at rest from ``theta0``; theta is in rad, positive in the
sense of ``theta0`` (the scene's frame).  Once friction holds the balance, theta stays at the
rest angle; past a failed run the values are NaN.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from ..core.errors import SolverError
from ..core.kernels import kernel
from .dense import log_theta_at
from .effects.base import SystemBuilder
from .solvers import check_capability, default_solver, solve_system, status_of

__all__ = ["sample_theta", "sample_scene"]

# options each sampling route accepts
SAMPLE_OPTIONS = {"exact": frozenset({"max_swings", "max_segments"}),
                  "dop853": frozenset({"rtol", "atol", "max_segments", "max_steps"})}
_EMPTY = np.zeros(0)
_EMPTY_FLAGS = np.zeros(0, np.int8)


def _swings_for(sys: SystemBuilder, t_end: float) -> int:
    """Half swings that probably cover ``t_end`` s (each lasts about pi/omega0)."""
    return int(min(t_end * sys.omega0 / math.pi * 1.1, 1e7)) + 2


@kernel
def _ascending(t):
    for i in range(1, t.shape[0]):
        if not t[i] >= t[i - 1]:
            return False
    return True


def _times(times: Any) -> np.ndarray:
    t = np.ascontiguousarray(times, dtype=float)
    if t.ndim != 1:
        raise SolverError(f"sample times must be a 1-d array, got shape {t.shape}")
    if t.size and not (t[0] >= 0.0 and math.isfinite(t[-1]) and _ascending(t)):
        raise SolverError("sample times must be finite, >= 0 and sorted ascending (s since release)")
    return t


def sample_theta(sys: SystemBuilder, times: np.ndarray, switching: str = "angle", solver: str = "exact",
                 **options: Any) -> tuple[np.ndarray, str]:
    """theta (rad) at the given times (s since release, sorted ascending, >= 0); status string.

    Parameters
    ----------
    sys
        The numeric system (``scene.system(values)`` or ``scene.build(values)``).
    times
        Sample times, s since the release at rest.
    switching
        ``"angle"`` or ``"phase"`` (phase: exact solver only).
    solver
        ``"exact"`` (closed form; spring only) or ``"dop853"`` (spring or pendulum).
    **options
        ``exact``: ``max_swings`` (bound on the half swings run to reach the last time,
        default 1e7) and ``max_segments`` (segment budget of a run, default from the half
        swings needed).  ``dop853``: ``rtol``, ``atol``, ``max_segments``, ``max_steps``
        (see :func:`escfit.balance.dop853.solve_dop853`).

    Returns
    -------
    theta : ndarray
        Angle at each time (rad); the rest angle after a stop, NaN after a failure or
        beyond the budget.
    status : str
        As :attr:`escfit.balance.trajectory.Trajectory.status`; ``"max_segments"`` also when
        ``max_swings`` ended the run before the last time.

    Raises
    ------
    SolverError
        For a solver that cannot sample or cannot handle the system, unknown options, bad
        times or parameters.
    """
    if solver not in SAMPLE_OPTIONS:
        raise SolverError(f"sample_theta runs solvers {sorted(SAMPLE_OPTIONS)}, not {solver!r}")
    check_capability(solver, switching, sys.restoring)
    bad = sorted(set(options) - SAMPLE_OPTIONS[solver])
    if bad:
        raise SolverError(f"sample_theta with solver {solver!r} takes options {sorted(SAMPLE_OPTIONS[solver])}, "
                          f"not {bad}")
    t = _times(times)
    theta = np.empty(t.size)
    if not t.size:
        return theta, "ok"
    if solver == "exact":
        return theta, _sample_exact(sys, t, switching, theta, int(options.get("max_swings", 10_000_000)),
                                    options.get("max_segments"))
    return theta, _sample_dop853(sys, t, switching, theta, **options)


def _sample_exact(sys: SystemBuilder, t: np.ndarray, switching: str, theta: np.ndarray, max_swings: int,
                  max_segments: int | None) -> str:
    t_end = float(t[-1])
    n = min(_swings_for(sys, t_end), max_swings)
    # segments per half swing: one per region between switch points, one more for a grazing turn
    per_swing = 2 * len(sys.w_lo) + len(sys.spring_breaks) + 3
    while True:
        tr = solve_system(sys, n, switching, "exact", log=True, max_segments=max_segments or per_swing * n + 1000)
        reached = tr.final[0] >= t_end
        if reached or len(tr.amplitude) < n or n >= max_swings:  # done, or ended for another reason
            break
        # the half swings were longer than pi/omega0: scale by the time covered
        n = min(max_swings, max(2 * n, int(n * t_end / max(tr.final[0], 1e-300) * 1.1) + 2))
    status = tr.status
    beyond = tr.final[1] if status == "stopped" else math.nan
    log_theta_at(tr.log, t, beyond, theta)
    if not reached and status not in ("stopped", "max_segments"):
        return "max_segments"
    # a creep to rest (final time inf) counts as stopped from the start of its segment
    t_stop = tr.final[0] if math.isfinite(tr.final[0]) or not len(tr.log) else tr.log[-1, 0]
    if status in ("ok", "banked") or (status == "stopped" and t_stop > t_end):
        # the run went past the last time: report what happened up to it, as dop853 does
        return "banked" if tr.banked.any() and tr.time[tr.banked.argmax()] <= t_end else "ok"
    return status


def _sample_dop853(sys: SystemBuilder, t: np.ndarray, switching: str, theta: np.ndarray, **options: Any) -> str:
    from .dop853 import kernel_inputs, run_dop853

    # no swing limit: the run ends at the last sample
    args, _ = kernel_inputs(sys, switching, 2**62, budget_swings=_swings_for(sys, float(t[-1])), **options)
    res = run_dop853(*args, t, theta, _EMPTY, _EMPTY, _EMPTY, _EMPTY, _EMPTY_FLAGS)
    return status_of(res[1])[0]


def sample_scene(scene: Any, times: np.ndarray, values: Mapping[str, float] | None = None,
                 solver: str | None = None, **options: Any) -> tuple[np.ndarray, str]:
    """theta (rad) of a whole scene at the given times; see :func:`sample_theta`.

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
    sys = scene.build(values)
    return sample_theta(sys, times, scene.switching, solver or default_solver(scene), **options)
