"""The exact solver for many parameter sets at once.

A sampler asks for the same scene at dozens of parameter vectors per step.  The scene builds
all of them in one pass as one :class:`~escfit.balance.system.System` of many coefficient
records (``scene.system(values, n)``: the same effect code that fills one record fills them
all, so no field can be left behind on this path), and this module runs the exact kernels of
:mod:`escfit.balance.exact` over the records in a numba ``prange`` loop, one set per iteration,
so the sets share the machine's cores and pay one Python call between them.  It is not a
second solver: each set goes through the very same compiled :func:`run_angle` /
:func:`run_phase` with its own record, and its results are bit-for-bit those of
:func:`escfit.balance.solvers.solve_system` (the tests check this).  Sets may differ in
anything, structure included.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numba import config, get_num_threads, set_num_threads

from ..core.errors import SolverError
from ..core.status import LABELS, Status
from .exact import run_angle_many, run_phase_many
from .kernel_records import half_swings, run_options
from .solvers import SOLVERS, capability
from .system import System
from .trajectory import Trajectory

__all__ = ["BatchTrajectory", "solve_batch", "SUMMARY"]

# OpenMP worker threads that spin between parallel regions take the core from the Python
# thread that prepares the next batch; on a busy machine that made a sampler ten times
# slower (docs/performance.md).  Sleeping workers cost a few microseconds per call instead.
# An explicit setting by the user wins; it must be in place before numba starts its threads.
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

#: What the batch kernels write for each set besides its half swings.
SUMMARY = np.dtype([("n_done", "i8"), ("status", "i8"), ("n_seg", "i8"), ("t", "f8"), ("theta", "f8"),
                    ("omega", "f8")])
_LABELS = np.array([LABELS[Status(i)][0] for i in range(len(Status))])


@dataclass
class BatchTrajectory:
    """Per-half-swing results of many parameter sets.

    Arrays have shape ``(sets, swings)``; entries after a set's ``n_done`` are NaN (and
    ``banked`` False).  ``code`` holds each set's :class:`~escfit.core.status.Status` and
    ``status`` its label; ``message`` why a set was refused (``""`` otherwise).
    """

    amplitude: np.ndarray
    theta_turn: np.ndarray
    half_period: np.ndarray
    time: np.ndarray
    banked: np.ndarray
    n_done: np.ndarray
    code: np.ndarray
    n_segments: np.ndarray
    final: np.ndarray
    omega0: np.ndarray
    message: list[str]
    options: dict

    @property
    def status(self) -> np.ndarray:
        """The status label of each set."""
        return _LABELS[self.code]

    def __len__(self) -> int:
        return int(self.n_done.size)

    def __getitem__(self, i: int) -> Trajectory:
        """Set ``i`` as the :class:`Trajectory` the single-set exact solver returns."""
        n = int(self.n_done[i])
        return Trajectory(self.amplitude[i, :n].copy(), self.theta_turn[i, :n].copy(), self.half_period[i, :n].copy(),
                          self.time[i, :n].copy(), self.banked[i, :n].copy(), Status(int(self.code[i])),
                          float(self.omega0[i]), "exact", dict(self.options), int(self.n_segments[i]), 0,
                          tuple(map(float, self.final[i])), detail=self.message[i])


def solve_batch(system: System | Sequence[System], n_swings: int, *, max_segments: int | None = None,
                threads: int | None = None, throw: bool = True) -> BatchTrajectory:
    """Run the exact solver on many parameter sets.

    Parameters
    ----------
    system
        A :class:`~escfit.balance.system.System` of many sets (``scene.system(values, n)``), or
        systems to stack.
    n_swings
        Half swings wanted of every set.
    max_segments
        Segment budget per set; default ``64*n_swings + 1000`` as for one set.
    threads
        numba threads to use.  Default: one thread when the batch is small (``sets *
        n_swings`` below 512 half swings with angle switching, 8192 with phase switching,
        where waking the worker threads costs more than they save), else numba's current
        setting (all cores).
    throw
        Raise :class:`~escfit.core.errors.SolverError` for a set the single-set solver would
        refuse; with ``False`` such sets are skipped and get status ``REFUSED`` (label
        ``"failed"``) and the refusal as their ``message``.
    """
    system = system if isinstance(system, System) else System.stack(list(system))
    if not len(system):
        raise SolverError("a batch needs at least one parameter set")
    batch_solvers = [name for name, spec in SOLVERS.items() if spec.batch]
    capability(system, batch_solvers[0])
    if isinstance(n_swings, bool) or int(n_swings) != n_swings or n_swings < 1:
        raise SolverError(f"n_swings must be a positive whole number, got {n_swings!r}")
    n_swings = int(n_swings)
    reasons = system.refusals()
    if throw and any(reasons):
        i = next(j for j, m in enumerate(reasons) if m)
        raise SolverError(f"parameter set {i}: {reasons[i]}")
    active = np.array([not m for m in reasons], np.bool_)
    n = len(system)
    nseg = int(max_segments or 64 * n_swings + 1000)
    out = half_swings(n, n_swings, nan=True)
    summary = np.zeros(n, SUMMARY)
    summary["status"] = int(Status.REFUSED)
    summary["t"] = summary["theta"] = summary["omega"] = np.nan
    phase = system.switching == "phase"
    previous = get_num_threads()
    if threads is None and n * n_swings < (8192 if phase else 512):
        # Measured with run_angle_many on the Monday-like unit (2 shared cores): a parallel
        # region costs ~18 us to wake its workers, the work ~0.7 us per half swing, and 2
        # threads lost to 1 up to 240 half swings and won from 480 on; below 512 the serial
        # loop is no slower and leaves the other core free.  A phase-convention half swing is
        # one affine map (~0.06 us), so its break-even batch is about ten times larger.
        threads = 1
    if threads is not None:
        set_num_threads(max(1, min(int(threads), config.NUMBA_NUM_THREADS)))
    try:
        kernel = run_phase_many if phase else run_angle_many
        kernel(system.k, run_options(n_swings, max_segments=nseg), active, out, summary)
    finally:
        set_num_threads(previous)
    # rows were written only up to n_done; the rest keep their NaN fill (half_swings(nan=True))
    final = np.stack([summary["t"], summary["theta"], summary["omega"]], axis=1)
    return BatchTrajectory(out["amplitude"].copy(), out["theta_turn"].copy(), out["half_period"].copy(),
                           out["time"].copy(), out["banked"].astype(bool), summary["n_done"].copy(),
                           summary["status"].copy(), summary["n_seg"].copy(), final, system.k["omega0"].copy(),
                           reasons, {"max_segments": nseg, "switching": system.switching})
