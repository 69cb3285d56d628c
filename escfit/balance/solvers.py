"""Solver front-ends: one function per solver, all returning a :class:`Trajectory`.

Each solver declares the options it takes, the switching laws and the restoring torques it
can handle (:class:`SolverSpec`); anything else is refused with
:class:`~escfit.core.errors.SolverError` before any work is done.  :func:`default_solver` picks the
solver used when the caller names none: ``"exact"`` for a spring, ``"dop853"`` for a pendulum.
"""

from __future__ import annotations

import math
from typing import Any, Callable, NamedTuple

import numpy as np

from ..core.errors import SolverError
from .effects.base import SystemBuilder
from .exact import STATUS_NAMES, run_angle, run_phase
from .trajectory import Trajectory

__all__ = ["SOLVERS", "SolverSpec", "solve_system", "default_solver", "check_capability", "kernel_args",
           "static_args", "status_of"]

# Status codes of the compiled kernels beyond exact.STATUS_NAMES (shared by rk4 and dop853).
OVER_THE_TOP = 5
STEP_UNDERFLOW = 6
STEP_BUDGET = 7
_EXTRA_STATUS = {
    OVER_THE_TOP: ("failed", "the pendulum went over the top (|theta| reached pi) and has no further turning point"),
    STEP_UNDERFLOW: ("failed", "the step size fell below the rounding of the time (the equation is too stiff or "
                               "the tolerances too tight)"),
    STEP_BUDGET: ("max_segments", "step budget exhausted before the requested swings (stiff or pathological input, "
                                  "e.g. an overdamped creep to rest: use the exact solver)"),
}


def status_of(code: int) -> tuple[str, str]:
    """Status name and message (``""``: the standard one) of a kernel status code."""
    if code in _EXTRA_STATUS:
        return _EXTRA_STATUS[code]
    return STATUS_NAMES[code], ""


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
    if math.isnan(sys.theta0):
        raise SolverError("theta0 is not given: the scene takes its release from a recording; give "
                          "[oscillator] theta0 to simulate it")
    values = {"C": sys.c, "R": sys.r, "theta0": sys.theta0, "omega0": sys.omega0}
    for name, v in values.items():
        if not math.isfinite(v):
            raise SolverError(f"parameter {name} = {v!r} is not finite")
    if sys.restoring == "pendulum" and not abs(sys.theta0) < math.pi:
        raise SolverError(f"a pendulum needs |theta0| < pi, got theta0 = {sys.theta0!r} rad")
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


class SolverSpec(NamedTuple):
    """What a solver is and what it can do.

    Attributes
    ----------
    function
        ``function(sys, n_swings, switching, **options) -> Trajectory``.
    options
        Keyword options it accepts.
    switching
        Switching laws it handles (``"angle"``, ``"phase"``).
    restoring
        Restoring torques it handles (``"spring"``: linear or piecewise-linear hairspring;
        ``"pendulum"``: ``omega0**2 * sin(theta)``).
    """

    function: Callable[..., Trajectory]
    options: frozenset[str]
    switching: frozenset[str]
    restoring: frozenset[str]


def _spec(function, options, switching, restoring) -> SolverSpec:
    return SolverSpec(function, frozenset(options), frozenset(switching), frozenset(restoring))


SOLVERS: dict[str, SolverSpec] = {
    "exact": _spec(solve_exact, {"log", "max_segments"}, {"angle", "phase"}, {"spring"}),
    "rk4": _spec(_lazy(".rk4", "solve_rk4"), {"h", "locate_events", "max_steps"}, {"angle"}, {"spring", "pendulum"}),
    "ivp": _spec(_lazy(".ivp", "solve_ivp_events"), {"method", "rtol", "atol", "max_segments"}, {"angle"},
                 {"spring", "pendulum"}),
    "dop853": _spec(_lazy(".dop853", "solve_dop853"), {"rtol", "atol", "max_segments", "max_steps"}, {"angle"},
                    {"spring", "pendulum"}),
}

_RESTORING_WORDS = {"spring": "a linear or piecewise-linear spring", "pendulum": "a pendulum (omega0**2 * sin(theta))"}


def default_solver(scene_or_system: Any) -> str:
    """The solver used when the caller names none.

    ``"exact"`` (closed form, no integration error) for a spring; ``"dop853"`` (compiled
    adaptive Runge-Kutta, the closed form not existing) for ``restoring = "pendulum"``.

    Parameters
    ----------
    scene_or_system
        A :class:`~escfit.balance.scene.BalanceScene` or a
        :class:`~escfit.balance.effects.base.SystemBuilder` (anything with ``restoring``).
    """
    return "dop853" if getattr(scene_or_system, "restoring", "spring") == "pendulum" else "exact"


def check_capability(solver: str, switching: str, restoring: str, options: Any = ()) -> SolverSpec:
    """The solver's :class:`SolverSpec`, after refusing what it cannot do.

    Raises
    ------
    SolverError
        Unknown solver, an option it does not take, or a switching law or restoring torque
        it does not handle (the message names the solvers that do).
    """
    if solver not in SOLVERS:
        raise SolverError(f"unknown solver {solver!r}; choose one of {sorted(SOLVERS)}")
    spec = SOLVERS[solver]
    bad = sorted(set(options) - spec.options)
    if bad:
        raise SolverError(f"solver {solver!r} takes options {sorted(spec.options)}, not {bad}")
    if switching not in spec.switching:
        raise SolverError(f"solver {solver!r} handles switching {sorted(spec.switching)}, not {switching!r}")
    if restoring not in spec.restoring:
        handles = " or ".join(_RESTORING_WORDS[k] for k in sorted(spec.restoring))
        others = sorted(k for k, s in SOLVERS.items() if restoring in s.restoring and switching in s.switching)
        default = default_solver(SystemBuilder(restoring=restoring))
        alternatives = " or ".join(f"{k!r}" + (f" (default for {restoring} scenes)" if k == default else "")
                                   for k in sorted(others, key=lambda k: k != default))
        raise SolverError(f"solver {solver!r} handles {handles}; restoring = {restoring!r} needs solver "
                          f"{alternatives}")
    return spec


def solve_system(sys: SystemBuilder, n_swings: int, switching: str, solver: str | None = None,
                 **options: Any) -> Trajectory:
    """Dispatch to a solver (default :func:`default_solver`) after checking it can handle the request."""
    solver = solver or default_solver(sys)
    spec = check_capability(solver, switching, sys.restoring, options)
    return spec.function(sys, n_swings, switching, **options)
