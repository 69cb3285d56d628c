"""Solver registry: what each solver handles, the one check before any work, and the dispatch.

Each solver declares (:class:`SolverSpec`) the options it takes and the needs it handles
(:data:`escfit.balance.effects.base.NEEDS`); a scene's :class:`~escfit.balance.system.System`
knows what its effects need.  :func:`check` compares the two before any work and refuses a
mismatch naming what asks for it and the solvers that handle everything the scene needs;
:func:`default_solver` picks the first of those (``"exact"`` when a closed form exists, else
``"dop853"``).  Every solver returns a :class:`~escfit.balance.trajectory.Trajectory` with a
:class:`~escfit.core.status.Status`, and with ``dense=True`` its dense solution.

==========  ===================================================  ==================================
solver      method                                               handles
==========  ===================================================  ==================================
``exact``   closed form per segment of constant coefficients      linear, windows, stop rule,
                                                                  impacts, drift, phase switching
``dop853``  compiled adaptive Dormand-Prince 8(5,3), events       linear, windows, smooth, stop
            located on the step map                               rule, impacts
``rk4``     fixed-step classical Runge-Kutta                      as dop853
``ivp``     scipy ``solve_ivp`` per segment, events               as dop853
==========  ===================================================  ==================================
"""

from __future__ import annotations

import functools
import importlib
import math
from typing import Any, Callable, NamedTuple

import numpy as np

from ..core.errors import SolverError
from ..core.status import Status
from .effects.base import NEEDS
from .exact import run_one, run_phase_one
from .kernel_records import COEFFICIENTS, columns, half_swings, run_options, with_rows
from .solution import ROW_EXACT, RowSolution
from .system import Structure, System
from .trajectory import Trajectory

__all__ = ["SOLVERS", "SolverSpec", "solve_system", "default_solver", "check", "capability", "check_scene",
           "solve_exact"]

_CLOSED_FORM = frozenset({"linear", "windows", "stop_rule", "impacts", "drift", "phase_switching"})
_INTEGRATED = frozenset({"linear", "windows", "smooth", "stop_rule", "impacts"})


def solve_exact(system: System, n_swings: int, *, max_segments: int | None = None, dense: bool = False,
                t_end: float = math.inf) -> Trajectory:
    """Piecewise closed-form solution (see :mod:`escfit.balance.exact`).

    Parameters
    ----------
    system
        One parameter set, already checked (:func:`solve_system` checks).
    n_swings
        Half swings wanted.
    max_segments
        Segment budget; default ``64*n_swings + 1000``.
    dense
        Keep the closed-form segments as the dense solution (:attr:`Trajectory.dense`).
    t_end
        End the run with the first half swing ending at or after this time (s), if it comes first.
    """
    nseg = int(max_segments or 64 * n_swings + 1000)
    out = half_swings(n_swings)
    run = run_options(n_swings, max_segments=nseg, t_end=t_end, dense=dense)
    kernel = run_phase_one if system.switching == "phase" else run_one
    # room for the segments of ~4 regions per half swing; more is made when a run needs it
    res, log = with_rows(lambda rows: kernel(system.k, run, out, rows), min(nseg, 4 * n_swings + 64), 9, dense)
    traj = Trajectory(*columns(out, res.n_done), Status(res.status), system.omega0, "exact",
                      {"max_segments": nseg}, res.n_seg, 0, (res.t, res.theta, res.omega))
    if dense:
        traj.dense = RowSolution(log[:res.rows].copy(), ROW_EXACT, system.k, traj)
    return traj


def _lazy(module: str, name: str) -> Callable[..., Trajectory]:
    def call(*args, **kwargs):
        return getattr(importlib.import_module(module, __package__), name)(*args, **kwargs)

    return call


class SolverSpec(NamedTuple):
    """What a solver is and what it can do.

    Attributes
    ----------
    function
        ``function(system, n_swings, **options) -> Trajectory``.
    options
        Keyword options it accepts (every solver takes ``dense`` and ``t_end``).
    handles
        The needs (:data:`escfit.balance.effects.base.NEEDS`) it can meet.
    batch
        Whether :func:`escfit.balance.batch.solve_batch` runs it on many parameter sets at once.
    sampler
        ``sampler(system, times, shift, which=THETA)``: theta (or theta') of many parameter sets
        at sample times in one compiled call, each set's samples those of its one-set dense
        solution; ``None`` when the solver has none.
    """

    function: Callable[..., Trajectory]
    options: frozenset[str]
    handles: frozenset[str]
    batch: bool = False
    sampler: Callable[..., tuple] | None = None


def _spec(function, options, handles, batch=False, sampler=None) -> SolverSpec:
    return SolverSpec(function, frozenset(options) | {"dense", "t_end"}, frozenset(handles), batch, sampler)


SOLVERS: dict[str, SolverSpec] = {
    "exact": _spec(solve_exact, {"max_segments"}, _CLOSED_FORM, batch=True,
                   sampler=_lazy(".batch_dense", "sample_batch")),
    "dop853": _spec(_lazy(".dop853", "solve_dop853"), {"rtol", "atol", "max_segments", "max_steps"}, _INTEGRATED,
                    sampler=_lazy(".batch_dop853", "sample_batch_dop853")),
    "rk4": _spec(_lazy(".rk4", "solve_rk4"), {"h", "locate_events", "max_steps"}, _INTEGRATED),
    "ivp": _spec(_lazy(".ivp", "solve_ivp_events"), {"method", "rtol", "atol", "max_segments"}, _INTEGRATED),
}

#: Preference when the caller names no solver: no integration error first.
_PREFERENCE = ("exact", "dop853", "ivp", "rk4")


def default_solver(scene_or_system: Any) -> str:
    """The solver used when the caller names none: the first of ``exact``, ``dop853`` that
    handles everything the scene needs (``exact`` whenever a closed form exists).

    Parameters
    ----------
    scene_or_system
        A :class:`~escfit.balance.scene.BalanceScene` or a :class:`~escfit.balance.system.System`.
    """
    return _default_for(_needs_of(scene_or_system))


@functools.lru_cache(maxsize=64)
def _default_for(needs: frozenset[str]) -> str:
    return next((name for name in _PREFERENCE if needs <= SOLVERS[name].handles), "dop853")


def _structure(scene: Any) -> System:
    """A system with the scene's structure and no parameter sets (what capability checks read)."""
    structure = getattr(scene, "structure", None)
    if not isinstance(structure, Structure):
        structure = Structure(tuple(getattr(scene, "effects", ())), getattr(scene, "restoring", "spring"),
                              getattr(scene, "switching", "angle"))
    return System(np.zeros(0, COEFFICIENTS), structure)


def _needs_of(obj: Any) -> frozenset[str]:
    return (obj if isinstance(obj, System) else _structure(obj)).needs


def check_scene(scene: Any, solver: str, options: Any = ()) -> SolverSpec:
    """:func:`capability` for a whole scene, before any parameter set exists (a fit's set-up)."""
    return capability(_structure(scene), solver, options)


def check(system: System, solver: str, options: Any = ()) -> SolverSpec:
    """The solver's :class:`SolverSpec`, after refusing what it cannot do; then the parameters.

    Raises
    ------
    SolverError
        Unknown solver, an option it does not take, a need of the scene it does not handle (the
        message names what asks for it and the solvers that handle the whole scene), or parameter
        values no solver can run (:meth:`~escfit.balance.system.System.check`).
    """
    spec = capability(system, solver, options)
    system.check()
    return spec


def capability(system: System, solver: str, options: Any = ()) -> SolverSpec:
    """:func:`check` without the parameter values: whether ``solver`` can run this structure at all."""
    if solver not in SOLVERS:
        raise SolverError(f"unknown solver {solver!r}; choose one of {sorted(SOLVERS)}")
    spec = SOLVERS[solver]
    bad = sorted(set(options) - spec.options)
    if bad:
        raise SolverError(f"solver {solver!r} takes options {sorted(spec.options)}, not {bad}")
    missing = _missing(system.structure, spec.handles)
    if missing:
        need, who = missing[0]
        what = "has no closed form for" if need == "smooth" else "does not handle"
        others = [name for name in _PREFERENCE if system.needs <= SOLVERS[name].handles]
        use = ("use solver " + ", ".join(f"{name!r}" for name in others)) if others else \
            "no solver handles this combination"
        raise SolverError(f"solver {solver!r} {what} {who} ({NEEDS[need]}); {use}")
    return spec


@functools.lru_cache(maxsize=256)
def _missing(structure: Structure, handles: frozenset[str]) -> tuple:
    return tuple((need, who) for need, who in structure.demands if need not in handles)


def solve_system(system: System, n_swings: int, solver: str | None = None, **options: Any) -> Trajectory:
    """Run one parameter set with a solver (default :func:`default_solver`) after :func:`check`.

    Parameters
    ----------
    system
        One parameter set (``scene.system(values)``).
    n_swings
        Half swings wanted.
    solver
        ``"exact"``, ``"dop853"``, ``"rk4"`` or ``"ivp"``.
    **options
        The solver's options (:attr:`SolverSpec.options`); every solver takes ``dense`` (keep the
        dense solution) and ``t_end`` (s: end with the first half swing ending at or after it).
    """
    if len(system) != 1:
        raise SolverError(f"solve_system runs one parameter set, got {len(system)}; use solve_batch for many")
    solver = solver or default_solver(system)
    spec = check(system, solver, options)
    return spec.function(system, n_swings, **options)
