"""Solver front-ends: one function per solver, all returning a :class:`Trajectory`.

Each solver declares the options it takes and the switching laws it can handle; anything
else is refused with :class:`~escfit.errors.SolverError` before any work is done.
"""

from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from ..errors import SolverError
from .effects.base import SystemBuilder
from .exact import STATUS_NAMES, run_angle, run_phase
from .trajectory import Trajectory

__all__ = ["SOLVERS", "solve_system", "kernel_args", "static_args"]


def kernel_args(sys: SystemBuilder) -> tuple:
    """Arrays in the order the compiled kernels take them (angle switching)."""
    bp, w2, off = sys.spring_arrays()
    return (
        float(sys.theta0), 0.0, float(sys.c), float(sys.r), bp, w2, off,
        np.asarray(sys.w_lo, float), np.asarray(sys.w_hi, float), np.asarray(sys.w_x, float),
        np.asarray(sys.w_dir, np.int64), float(sys.bank), float(sys.restitution),
        np.asarray(sys.drift_thresholds, float), np.asarray(sys.drift_rates, float),
    )


def static_args(sys: SystemBuilder, solver: str) -> tuple:
    """Kernel arguments without the damping drift, which only the exact solver models."""
    if any(rate != 0.0 for rate in sys.drift_rates):
        raise SolverError(f"solver {solver!r} does not model viscous_drift; use the exact solver")
    return kernel_args(sys)[:13]


def _outputs(n: int):
    return np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.zeros(n, np.int8)


def _check_system(sys: SystemBuilder, switching: str) -> None:
    values = {"C": sys.c, "R": sys.r, "theta0": sys.theta0, "omega0": sys.omega0}
    for name, v in values.items():
        if not math.isfinite(v):
            raise SolverError(f"parameter {name} = {v!r} is not finite")
    if sys.c < 0 or sys.r < 0:
        raise SolverError(f"C and R must be >= 0, got C={sys.c!r}, R={sys.r!r}")
    if any(not (math.isfinite(x)) for x in sys.w_x):
        raise SolverError(f"escapement magnitudes must be finite, got {sys.w_x!r}")
    if switching == "phase" and not sys.c < 2.0 * sys.omega0:
        raise SolverError(
            f"phase switching needs an underdamped balance, C < 2*omega0; got C={sys.c:g}, omega0={sys.omega0:g}"
        )


def solve_exact(sys: SystemBuilder, n_swings: int, switching: str, *, log: bool = False,
                max_segments: int | None = None) -> Trajectory:
    """Piecewise closed-form solution (see :mod:`escfit.balance.exact`).

    Parameters
    ----------
    log
        Keep the segment log (needed for dense output and energy checks).
    max_segments
        Segment budget; default ``64*n_swings + 1000``.
    """
    _check_system(sys, switching)
    nseg = int(max_segments or 64 * n_swings + 1000)
    out = _outputs(n_swings)
    logarr = np.zeros((nseg if log else 0, 9))
    if switching == "phase":
        w2 = sys.omega0**2
        res = run_phase(float(sys.theta0), float(sys.c), float(sys.r), w2, np.asarray(sys.w_lo, float),
                        np.asarray(sys.w_hi, float), np.asarray(sys.w_x, float), np.asarray(sys.w_dir, np.int64),
                        np.asarray(sys.drift_thresholds, float), np.asarray(sys.drift_rates, float), n_swings,
                        *out, logarr)
    else:
        res = run_angle(*kernel_args(sys), n_swings, nseg, *out, logarr)
    n_done, status, n_seg, t, theta, omega = res
    return Trajectory(
        *(a[:n_done].copy() for a in out[:4]), out[4][:n_done].astype(bool), STATUS_NAMES[status], sys.omega0,
        "exact", {"log": log, "max_segments": nseg}, n_seg, 0, (t, theta, omega),
        logarr[:n_seg].copy() if log else None,
    )


def _lazy(module: str, name: str) -> Callable[..., Trajectory]:
    def call(*args, **kwargs):
        import importlib

        return getattr(importlib.import_module(module, __package__), name)(*args, **kwargs)

    return call


# name -> (function, options it accepts, switching laws it handles)
SOLVERS: dict[str, tuple[Callable[..., Trajectory], set[str], set[str]]] = {
    "exact": (solve_exact, {"log", "max_segments"}, {"angle", "phase"}),
    "rk4": (_lazy(".rk4", "solve_rk4"), {"h", "locate_events", "max_steps"}, {"angle"}),
    "ivp": (_lazy(".ivp", "solve_ivp_events"), {"method", "rtol", "atol", "max_segments"}, {"angle"}),
}


def solve_system(sys: SystemBuilder, n_swings: int, switching: str, solver: str = "exact", **options: Any) -> Trajectory:
    """Dispatch to a solver after checking it can handle the request."""
    if solver not in SOLVERS:
        raise SolverError(f"unknown solver {solver!r}; choose one of {sorted(SOLVERS)}")
    fn, allowed, laws = SOLVERS[solver]
    bad = sorted(set(options) - allowed)
    if bad:
        raise SolverError(f"solver {solver!r} takes options {sorted(allowed)}, not {bad}")
    if switching not in laws:
        raise SolverError(f"solver {solver!r} handles switching {sorted(laws)}, not {switching!r}")
    return fn(sys, n_swings, switching, **options)
