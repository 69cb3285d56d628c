"""theta(t) of many parameter sets at once: the exact solver's dense solution, sampled in one call.

A sampler fitting a waveform asks, for each of a few dozen parameter sets per step, for the
model's angle (or angular velocity) at every sample time.  One set at a time that is a run of
:func:`escfit.balance.exact.run_angle` with its segment log, a
:class:`~escfit.balance.solution.RowSolution` around the log and its compiled evaluation at the
times (:func:`escfit.balance.waveform.sample_state`), with Python between them.  Here the
same steps run for every set inside one compiled ``prange`` loop: the same kernel with the same
run options (the half swings asked for grow as :func:`~escfit.balance.waveform.sample_state`
grows them, the log is enlarged as :func:`~escfit.balance.kernel_records.with_rows` enlarges it), then
the same row evaluation (:func:`escfit.balance.solution._states_at`, the closed form of
:mod:`escfit.balance.segment`), so each set's samples are bit for bit those of the one-set path
(the tests check it).  It is not a second solver.

Angle switching only (a waveform is fitted with a physical escapement).  Each set has its own
release instant: it is sampled at ``times - shift[i]`` (s since its release).
"""

from __future__ import annotations

import math
import os

import numpy as np
from numba import config, from_dtype, get_num_threads, prange, set_num_threads

from ..core.errors import SolverError
from ..core.kernels import kernel
from ..core.status import Status
from .exact import N_LOG, run_angle
from .kernel_records import HALF_SWING, RUN, ROWS_FULL
from .solvers import capability
from .solution import ROW_EXACT, _states_at
from .steps import N_STAGES
from .system import System

__all__ = ["SAMPLING", "SAMPLED", "sample_batch", "THETA", "OMEGA"]

THETA, OMEGA = 0, 1
#: What every set of a call shares: the quantity sampled (:data:`THETA` or :data:`OMEGA`), the
#: segment budget (0: ``64*n + 1000`` for ``n`` half swings, as for one set) and the bound on
#: the half swings run.
SAMPLING = np.dtype([("which", "i8"), ("max_segments", "i8"), ("max_swings", "i8")])
#: What the kernel writes for each set: its run's status code, half swings, segments (rows),
#: final time (s), and ``usable`` (1: its samples are what :func:`sample_state` gives with a
#: status ``ok``, ``banked`` or ``stopped``; 0: anything else, for the one-set path to redo).
SAMPLED = np.dtype([("status", "i8"), ("n_done", "i8"), ("n_seg", "i8"), ("t", "f8"), ("usable", "i8")])

# sleeping OpenMP workers between parallel regions, as escfit.balance.batch sets them (the reason is there)
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

_HALF_SWING = from_dtype(HALF_SWING)
_RUN = from_dtype(RUN)
_OK, _STOPPED, _BANKED, _REFUSED = int(Status.OK), int(Status.STOPPED), int(Status.BANKED), int(Status.REFUSED)


@kernel
def _first_swings(t_end, omega0, max_swings):
    """Half swings first asked for (as :func:`escfit.balance.waveform._swings_for`); -1 when undefined."""
    guess = min(t_end * omega0 / math.pi * 1.1, 1e7)
    if not math.isfinite(guess):
        return -1
    return min(int(guess) + 2, max_swings)


@kernel
def since_release(times, shift):
    """The sample times (s, one clock) as seconds since a set's release at ``shift`` (that clock)."""
    t = np.empty(times.shape[0])
    for q in range(times.shape[0]):
        t[q] = times[q] - shift
    return t


@kernel
def _run_dense(k, run, n):
    """:func:`run_angle` with its segment log, the log enlarged fourfold until it fits (as
    :func:`escfit.balance.kernel_records.with_rows`); returns the kernel's result and the log."""
    out = np.empty(n, _HALF_SWING)
    rows = min(run.max_segments, 4 * n + 64)
    while True:
        log = np.empty((rows, N_LOG))
        res = run_angle(k, run, out, log)
        if res.status != ROWS_FULL:
            return res, log
        rows *= 4


@kernel
def _sample_one(ks, i, spec, times, shift, value, row):
    """Set ``i``: run long enough to pass the last time, then its state at every time (see the module)."""
    k = ks[i]
    t = since_release(times, shift)
    n_t = t.shape[0]
    t_end = t[n_t - 1]
    max_swings = spec.max_swings
    n = _first_swings(t_end, k.omega0, max_swings)
    if n < 1 or not (t[0] >= 0.0):
        row.status = _REFUSED
        return
    runs = np.empty(1, _RUN)
    run = runs[0]
    run.max_steps = 0
    run.t_end = t_end
    run.dense = 1
    run.rtol = 0.0
    run.atol_x = 0.0
    run.atol_v = 0.0
    run.h = 0.0
    run.mode = 0
    while True:
        run.n_swings = n
        run.max_segments = spec.max_segments if spec.max_segments > 0 else 64 * n + 1000
        res, log = _run_dense(k, run, n)
        n_done, status, n_seg, t_fin = res.n_done, res.status, res.n_seg, res.t
        reached = t_fin >= t_end
        if reached or n_done < n or n >= max_swings:
            break
        # the half swings were longer than pi/omega0: scale by the time covered (as sample_state)
        n = min(max_swings, max(2 * n, int(n * t_end / max(t_fin, 1e-300) * 1.1) + 2))
    beyond = (res.theta, 0.0) if status == _STOPPED else (math.nan, math.nan)
    stages = (np.empty(N_STAGES + 1), np.empty(N_STAGES + 1))
    other = np.empty(n_t)
    sol = (log[:res.rows], ROW_EXACT, ks[i:i + 1], stages)
    if spec.which == THETA:
        _states_at(sol, t, beyond, value, other)
    else:
        _states_at(sol, t, beyond, other, value)
    row.status = status
    row.n_done = n_done
    row.n_seg = n_seg
    row.t = t_fin
    row.usable = 1 if status == _STOPPED or ((status == _OK or status == _BANKED) and reached) else 0


@kernel(parallel=True)
def sample_many(ks, spec, samples, active, values, summary):
    """:func:`_sample_one` for every active set ``i``, in parallel.

    ``samples = (times, shift)``: sample times (s, ascending) and each set's release instant
    (s); ``values`` has shape (sets, times); ``summary`` holds :data:`SAMPLED` records.
    """
    times, shift = samples
    # (records are indexed inside the parallel loop: numba cannot pass one into it)
    for i in prange(ks.shape[0]):
        if active[i]:
            _sample_one(ks, i, spec[0], times, shift[i], values[i], summary[i])


def sample_batch(system: System, times: np.ndarray, shift: np.ndarray, *, which: int = THETA,
                 max_segments: int | None = None, max_swings: int = 10_000_000,
                 threads: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """theta (rad) or theta' (rad/s) of every set at its own sample times, in one call.

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
    max_segments, max_swings
        As :func:`escfit.balance.waveform.sample_state` takes them.
    threads
        numba threads to use (default: numba's current setting, all cores).  Each set is tens of
        microseconds of work or more (the 120-swing benchmark record: ~100 us for 3000 samples),
        far above the ~20 us of waking the workers: measured on the 2-core machine with the
        other core idle, 16 such sets took 57 us a set in wall time on 2 threads against 105 on
        one, at the same CPU time.

    Returns
    -------
    values : ndarray, shape (sets, times)
        The samples (NaN for a set not run).
    summary : ndarray of :data:`SAMPLED`
        Each set's run; a set the single-set solver would refuse, or whose first time precedes
        its release, gets status ``REFUSED`` and ``usable`` 0.
    """
    if system.switching != "angle":
        raise SolverError("sample_batch runs angle switching only")
    capability(system, "exact")  # a pendulum or drag needs an integrator: refused, never approximated
    spec = np.zeros(1, SAMPLING)
    spec[0] = (which, int(max_segments or 0), int(max_swings))
    return run_sampling(sample_many, system, spec, times, shift, threads)


def run_sampling(many, system: System, spec: np.ndarray, times: np.ndarray, shift, threads: int | None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Check the times, prepare the outputs and run the compiled loop ``many`` over every set.

    Shared by :func:`sample_batch` and :func:`escfit.balance.batch_dop853.sample_batch_dop853`:
    ``many(ks, spec, (times, shift), active, values, summary)`` fills ``values`` (sets, times)
    and ``summary`` (:data:`SAMPLED`); sets the one-set solver would refuse stay ``REFUSED``.
    """
    times = np.ascontiguousarray(times, float)
    n = len(system)
    if not (isinstance(shift, np.ndarray) and shift.dtype == np.float64 and shift.shape == (n,)
            and shift.flags.c_contiguous):
        shift = np.ascontiguousarray(np.broadcast_to(np.asarray(shift, float), (n,)))
    if times.ndim != 1 or not times.size or not (times[1:] >= times[:-1]).all():
        raise SolverError("sample times must be a non-empty ascending 1-d array")
    active = np.array([not m for m in system.refusals()], np.bool_)
    values = np.full((n, times.size), np.nan)
    summary = np.zeros(n, SAMPLED)
    summary["status"] = _REFUSED
    summary["t"] = math.nan
    if threads is None:
        many(system.k, spec, (times, shift), active, values, summary)
        return values, summary
    previous = get_num_threads()
    set_num_threads(max(1, min(int(threads), config.NUMBA_NUM_THREADS)))
    try:
        many(system.k, spec, (times, shift), active, values, summary)
    finally:
        set_num_threads(previous)
    return values, summary
