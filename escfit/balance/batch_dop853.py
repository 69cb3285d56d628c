"""theta(t) of many parameter sets at once: the compiled DOP853 integrator's dense solution, sampled in one call.

The counterpart of :mod:`escfit.balance.batch_dense` for scenes the exact solver cannot run
(a pendulum's ``sin(theta)``, air drag, a stiffening spring): for each set, the run that
:func:`escfit.balance.waveform.sample_state` makes with solver ``dop853`` -- the same kernel
(:func:`escfit.balance.dop853.run_dop853`) with the same options (``rtol``, ``atol`` and its
default from each set's release angle, the segment and step budgets that grow with the half
swings asked for, ``dense`` and ``t_end``), the half swings asked for grown as ``sample_state``
grows them, the rows enlarged as :func:`~escfit.balance.kernel_records.with_rows` enlarges them --
then the same row evaluation (:func:`escfit.balance.solution._states_at`: a DOP853 step of
the partial length from the stored step start).  Every set runs inside one compiled
``prange`` loop, so each set's samples are bit for bit those of the one-set path (the tests
check it).  It is not a second solver.

Angle switching only.  Each set has its own release instant: it is sampled at
``times - shift[i]`` (s since its release).
"""

from __future__ import annotations

import math

import numpy as np
from numba import from_dtype, prange

from ..core.errors import SolverError
from ..core.kernels import kernel
from ..core.status import Status
from .batch_dense import OMEGA, THETA, _first_swings, run_sampling, since_release
from .dop853 import run_dop853
from .kernel_records import HALF_SWING, ROWS_FULL, RUN
from .solution import ROW_DOP853, _states_at
from .solvers import capability
from .steps import N_STAGES
from .system import System
from .walker import Walk

__all__ = ["DOP853_SAMPLING", "sample_batch_dop853", "THETA", "OMEGA"]

#: What every set of a call shares: the quantity sampled (:data:`THETA` or :data:`OMEGA`), the
#: segment and step budgets (0: ``64*n + 1000`` and ``10_000*n + 100_000`` for ``n`` half
#: swings, as :func:`~escfit.balance.dop853.solve_dop853` sets them), the bound on the half
#: swings run, the relative tolerance and the absolute one of theta (rad; NaN: each set's
#: default ``1e-2 * rtol * |theta0|``, or 1e-12 rad when that is 0).
DOP853_SAMPLING = np.dtype([("which", "i8"), ("max_segments", "i8"), ("max_steps", "i8"), ("max_swings", "i8"),
                            ("rtol", "f8"), ("atol", "f8")])

_HALF_SWING = from_dtype(HALF_SWING)
_RUN = from_dtype(RUN)
_N_ROW = 9  # columns of a dop853 dense row (escfit.balance.solution)
_OK, _STOPPED, _BANKED, _REFUSED = int(Status.OK), int(Status.STOPPED), int(Status.BANKED), int(Status.REFUSED)


@kernel
def _tolerances(k, spec):
    """``(atol_x, atol_v)`` of one set as :func:`~escfit.balance.dop853.solve_dop853` derives
    them; ``(nan, nan)`` where that would raise (the one-set path then says why)."""
    atol = spec.atol
    if math.isnan(atol):
        atol = 1e-2 * spec.rtol * abs(k.theta0)
        if atol == 0.0:  # solve_dop853's ``... or 1e-12``
            atol = 1e-12
    if not (atol > 0.0 and math.isfinite(atol)):
        return math.nan, math.nan
    top = -math.inf
    for j in range(k.n_pieces):
        w2 = k.sp_w2[j]
        if not (w2 >= 0.0 and math.isfinite(w2)):  # NaN or a negative stiffness: not this path's to judge
            return math.nan, math.nan
        top = max(top, w2)
    return atol, atol * math.sqrt(top)


@kernel
def _run_dense(k, run, n):
    """:func:`run_dop853` with its dense rows, enlarged fourfold until they fit (as
    :func:`escfit.balance.kernel_records.with_rows` for :func:`~escfit.balance.dop853.solve_dop853`);
    returns the kernel's result and the rows."""
    out = np.empty(n, _HALF_SWING)
    n_rows = 64 * min(n, 10_000) + 256
    while True:
        rows = np.empty((n_rows, _N_ROW))
        res = run_dop853(k, run, out, rows)
        if res.status != ROWS_FULL:
            return res, rows
        n_rows *= 4


@kernel
def dense_run(k, spec, t):
    """The dense run of one set long enough to pass its last time ``t[-1]`` (s since its release).

    Returns ``(ran, res, rows, reached)``: whether the set was run at all (not when the one-set
    path would refuse its tolerances or its first time precedes the release), the walk's
    :class:`~escfit.balance.walker.Walk`, its dense rows and whether the run reached the last time.  Shared by :func:`_sample_one` and the sensitivities (:mod:`escfit.balance.sensitivity`).
    """
    n_t = t.shape[0]
    t_end = t[n_t - 1]
    max_swings = spec.max_swings
    n = _first_swings(t_end, k.omega0, max_swings)
    atol_x, atol_v = _tolerances(k, spec)
    if n < 1 or not (t[0] >= 0.0) or math.isnan(atol_x):
        return False, Walk(0, _REFUSED, 0, 0, math.nan, math.nan, math.nan, 0), np.empty((0, _N_ROW)), False
    runs = np.empty(1, _RUN)
    run = runs[0]
    run.t_end = t_end
    run.dense = 1
    run.rtol = spec.rtol
    run.atol_x = atol_x
    run.atol_v = atol_v
    run.h = 0.0
    run.mode = 0
    while True:
        run.n_swings = n
        run.max_segments = spec.max_segments if spec.max_segments > 0 else 64 * n + 1000
        run.max_steps = spec.max_steps if spec.max_steps > 0 else 10_000 * n + 100_000
        res, rows = _run_dense(k, run, n)
        reached = res.t >= t_end
        if reached or res.n_done < n or n >= max_swings:
            break
        # the half swings were longer than pi/omega0: scale by the time covered (as sample_state)
        n = min(max_swings, max(2 * n, int(n * t_end / max(res.t, 1e-300) * 1.1) + 2))
    return True, res, rows[:res.rows], reached


@kernel
def _sample_one(ks, i, spec, times, shift, value, row):
    """Set ``i``: run long enough to pass the last time, then its state at every time (see the module)."""
    k = ks[i]
    t = since_release(times, shift)
    n_t = t.shape[0]
    ran, res, rows, reached = dense_run(k, spec, t)
    if not ran:
        row.status = _REFUSED
        return
    status = res.status
    beyond = (res.theta, 0.0) if status == _STOPPED else (math.nan, math.nan)
    stages = (np.empty(N_STAGES + 1), np.empty(N_STAGES + 1))
    other = np.empty(n_t)
    sol = (rows, ROW_DOP853, ks[i:i + 1], stages)
    if spec.which == THETA:
        _states_at(sol, t, beyond, value, other)
    else:
        _states_at(sol, t, beyond, other, value)
    row.status = status
    row.n_done = res.n_done
    row.n_seg = res.n_seg
    row.t = res.t
    row.usable = 1 if status == _STOPPED or ((status == _OK or status == _BANKED) and reached) else 0


@kernel(parallel=True)
def sample_many_dop853(ks, spec, samples, active, values, summary):
    """:func:`_sample_one` for every active set ``i``, in parallel.

    ``samples = (times, shift)``: sample times (s, ascending) and each set's release instant
    (s); ``spec`` holds one :data:`DOP853_SAMPLING` record; ``values`` has shape (sets, times);
    ``summary`` holds :data:`~escfit.balance.batch_dense.SAMPLED` records.
    """
    times, shift = samples
    for i in prange(ks.shape[0]):
        if active[i]:
            _sample_one(ks, i, spec[0], times, shift[i], values[i], summary[i])


def sample_batch_dop853(system: System, times: np.ndarray, shift: np.ndarray, *, which: int = THETA,
                        rtol: float = 1e-10, atol: float | None = None, max_segments: int | None = None,
                        max_steps: int | None = None, max_swings: int = 10_000_000,
                        threads: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """theta (rad) or theta' (rad/s) of every set at its own sample times, by solver ``dop853``, in one call.

    Parameters
    ----------
    system
        Parameter sets with angle switching (``scene.system(values, n)``).
    times
        Sample times (s, ascending, one clock for all sets).
    shift
        Release instant of each set (s, that clock): set ``i`` is sampled at ``times - shift[i]``
        s after its release at rest.
    which
        :data:`THETA` or :data:`OMEGA`.
    rtol, atol, max_segments, max_steps
        :func:`~escfit.balance.dop853.solve_dop853`'s options, with its defaults.
    max_swings
        As :func:`escfit.balance.waveform.sample_state` takes it.
    threads
        numba threads to use (default: numba's current setting, all cores).

    Returns
    -------
    values : ndarray, shape (sets, times)
        The samples (NaN for a set not run).
    summary : ndarray of :data:`~escfit.balance.batch_dense.SAMPLED`
        Each set's run; a set the one-set path would refuse (its parameters, its tolerances), or
        whose first time precedes its release, gets status ``REFUSED`` and ``usable`` 0.

    Raises
    ------
    SolverError
        Phase switching, a need dop853 does not handle, tolerances it refuses, bad times.
    """
    if system.switching != "angle":
        raise SolverError("sample_batch_dop853 runs angle switching only")
    capability(system, "dop853")
    if not 1e-15 <= rtol < 1.0 or (atol is not None and not (atol > 0.0 and math.isfinite(atol))):
        raise SolverError(f"dop853 needs 1e-15 <= rtol < 1 and atol > 0, got rtol={rtol!r}, atol={atol!r}")
    spec = np.zeros(1, DOP853_SAMPLING)
    spec[0] = (which, int(max_segments or 0), int(max_steps or 0), int(max_swings), float(rtol),
               math.nan if atol is None else float(atol))
    return run_sampling(sample_many_dop853, system, spec, times, shift, threads)
