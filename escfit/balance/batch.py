"""The exact solver for many parameter sets at once.

A sampler asks for the same scene at dozens of parameter vectors per step.  This module
stacks those parameter sets into arrays and runs the exact kernels of
:mod:`escfit.balance.exact` on them in a numba ``prange`` loop, one set per iteration, so
the sets share the machine's cores and pay one Python call between them.  It is not a
second solver: each set goes through the very same compiled :func:`run_angle` /
:func:`run_phase`, and its results are bit-for-bit those of
:func:`escfit.balance.solvers.solve_exact` (the tests check this).

What may differ between the sets is everything a fit can vary: release angle, C, R,
stiffness pieces, window magnitudes and the coefficient of restitution.  The structure --
window edges and directions, hairspring break angles, banking angle, damping drift -- is
shared, and a stack whose systems disagree on it is refused.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numba import config, get_num_threads, set_num_threads

from ..core.errors import SolverError
from .effects.base import SystemBuilder
from .exact import STATUS_NAMES, run_angle_many, run_phase_many
from .solvers import check_capability
from .trajectory import STATUS_MESSAGES, Trajectory

__all__ = ["SystemStack", "BatchTrajectory", "solve_batch"]

# OpenMP worker threads that spin between parallel regions take the core from the Python
# thread that prepares the next batch; on a busy machine that made a sampler ten times
# slower (docs/performance.md).  Sleeping workers cost a few microseconds per call instead.
# An explicit setting by the user wins; it must be in place before numba starts its threads.
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

REFUSED = len(STATUS_NAMES)  # status code of a set refused before any work
_STATUS = (*STATUS_NAMES, "failed")
_STATUS_ARRAY = np.array(_STATUS)


@dataclass(frozen=True)
class SystemStack:
    """Parameter sets of one structure, laid out as the kernels take them.

    Attributes
    ----------
    theta0, c, r, restitution, omega0 : ndarray, shape (n,)
        Release angle (rad), viscous C (1/s), Coulomb R (rad/s^2), coefficient of
        restitution and reference frequency (rad/s) of each set.
    sp_w2, sp_off : ndarray, shape (n, pieces)
        Hairspring stiffness per inertia (1/s^2) and offsets of each piece.
    w_x : ndarray, shape (n, windows)
        Signed window magnitudes (rad/s^2).
    sp_bp, w_lo, w_hi, w_dir, bank, drift_thresholds, drift_rates
        The shared structure (see :func:`escfit.balance.exact.run_angle`).
    """

    theta0: np.ndarray
    c: np.ndarray
    r: np.ndarray
    restitution: np.ndarray
    omega0: np.ndarray
    sp_w2: np.ndarray
    sp_off: np.ndarray
    w_x: np.ndarray
    sp_bp: np.ndarray
    w_lo: np.ndarray
    w_hi: np.ndarray
    w_dir: np.ndarray
    bank: float
    drift_thresholds: np.ndarray
    drift_rates: np.ndarray

    @property
    def size(self) -> int:
        return int(self.theta0.size)

    @classmethod
    def from_systems(cls, systems: Sequence[SystemBuilder]) -> "SystemStack":
        """Stack systems built from one scene (``scene.system(values)`` per set).

        Raises
        ------
        SolverError
            When the list is empty, two systems differ in structure or one is a pendulum (the
            exact kernels handle a spring only).
        """
        if not systems:
            raise SolverError("a batch needs at least one parameter set")
        first = systems[0]
        for restoring in {sys.restoring for sys in systems}:  # the batch runs the exact kernels
            check_capability("exact", "angle", restoring)
        key = _structure(first)
        for i, sys in enumerate(systems):
            if sys is not first and _structure(sys) != key:
                raise SolverError(f"parameter set {i} differs in structure (windows, hairspring breaks, banking or "
                                  "drift) from set 0; a batch shares one structure")
        bp, _, _ = first.spring_arrays()
        if first.spring_w2:
            pieces = [s.spring_arrays() for s in systems]
            sp_w2 = np.array([p[1] for p in pieces])
            sp_off = np.array([p[2] for p in pieces])
        else:  # the linear spring of spring_arrays(), without building it per set
            sp_w2 = np.array([[s.omega0**2] for s in systems])
            sp_off = np.zeros((len(systems), 1))
        w_x = np.array([s.w_x for s in systems], float).reshape(len(systems), len(first.w_lo))
        return cls(
            np.array([s.theta0 for s in systems], float), np.array([s.c for s in systems], float),
            np.array([s.r for s in systems], float), np.array([s.restitution for s in systems], float),
            np.array([s.omega0 for s in systems], float), sp_w2, sp_off, w_x, np.asarray(bp, float),
            np.asarray(first.w_lo, float), np.asarray(first.w_hi, float), np.asarray(first.w_dir, np.int64),
            float(first.bank), np.asarray(first.drift_thresholds, float), np.asarray(first.drift_rates, float),
        )

    def refusals(self, switching: str) -> list[str]:
        """Why each set would be refused by the single-set solver (``""`` when it is fine).

        Mirrors :func:`escfit.balance.solvers._check_system`, vectorised.
        """
        reasons = [""] * self.size
        with np.errstate(invalid="ignore"):
            fine = (np.isfinite(self.theta0) & np.isfinite(self.omega0) & (self.c >= 0) & (self.r >= 0)
                    & np.isfinite(self.c) & np.isfinite(self.r) & np.all(np.isfinite(self.w_x), axis=1))
            if switching == "phase":
                fine &= self.c < 2.0 * self.omega0
        if fine.all():  # the usual case: no message to build
            return reasons
        checks = [
            (~np.isfinite(self.c), "parameter C = {c!r} is not finite"),
            (~np.isfinite(self.r), "parameter R = {r!r} is not finite"),
            (~np.isfinite(self.theta0), "parameter theta0 = {theta0!r} is not finite"),
            (~np.isfinite(self.omega0), "parameter omega0 = {omega0!r} is not finite"),
            ((self.c < 0) | (self.r < 0), "C and R must be >= 0, got C={c!r}, R={r!r}"),
            (~np.all(np.isfinite(self.w_x), axis=1), "escapement magnitudes must be finite, got {w_x!r}"),
        ]
        if switching == "phase":
            checks.append((~(self.c < 2.0 * self.omega0), "phase switching needs an underdamped balance, C < 2*omega0; "
                           "got C={c:g}, omega0={omega0:g}"))
        for bad, template in checks:
            for i in np.flatnonzero(bad):
                if not reasons[i]:
                    reasons[i] = template.format(c=float(self.c[i]), r=float(self.r[i]), theta0=float(self.theta0[i]),
                                                 omega0=float(self.omega0[i]), w_x=list(map(float, self.w_x[i])))
        return reasons


def _structure(sys: SystemBuilder) -> tuple:
    """What a batch's systems must share."""
    return (tuple(sys.spring_breaks) if sys.spring_w2 else (), len(sys.spring_w2), tuple(sys.w_lo), tuple(sys.w_hi),
            tuple(sys.w_dir), sys.bank, tuple(sys.drift_thresholds), tuple(sys.drift_rates))


@dataclass
class BatchTrajectory:
    """Per-half-swing results of many parameter sets.

    Arrays have shape ``(sets, swings)``; entries after a set's ``n_done`` are NaN (and
    ``banked`` False).  ``status`` holds the status name of each set, ``message`` why a set
    was refused (``""`` otherwise).
    """

    amplitude: np.ndarray
    theta_turn: np.ndarray
    half_period: np.ndarray
    time: np.ndarray
    banked: np.ndarray
    n_done: np.ndarray
    status: np.ndarray
    n_segments: np.ndarray
    final: np.ndarray
    omega0: np.ndarray
    message: list[str]
    options: dict

    def __len__(self) -> int:
        return int(self.n_done.size)

    def __getitem__(self, i: int) -> Trajectory:
        """Set ``i`` as the :class:`Trajectory` the single-set exact solver returns."""
        n = int(self.n_done[i])
        status = str(self.status[i])
        return Trajectory(self.amplitude[i, :n].copy(), self.theta_turn[i, :n].copy(), self.half_period[i, :n].copy(),
                          self.time[i, :n].copy(), self.banked[i, :n].copy(), status, float(self.omega0[i]), "exact",
                          dict(self.options), int(self.n_segments[i]), 0, tuple(map(float, self.final[i])),
                          message=self.message[i] or ("" if status in STATUS_MESSAGES else status))


def solve_batch(systems: SystemStack | Sequence[SystemBuilder], n_swings: int, switching: str = "angle", *,
                max_segments: int | None = None, threads: int | None = None, throw: bool = True) -> BatchTrajectory:
    """Run the exact solver on many parameter sets of one structure.

    Parameters
    ----------
    systems
        A :class:`SystemStack` or the systems themselves (``scene.system(values)``).
    n_swings
        Half swings wanted of every set.
    switching
        ``"angle"`` or ``"phase"``.
    max_segments
        Segment budget per set; default ``64*n_swings + 1000`` as for one set.
    threads
        numba threads to use.  Default: one thread when the batch is small (``sets *
        n_swings`` below 512 half swings with angle switching, 8192 with phase switching,
        where waking the worker threads costs more than they save), else numba's current
        setting (all cores).
    throw
        Raise :class:`~escfit.core.errors.SolverError` for a set the single-set solver would
        refuse; with ``False`` such sets are skipped and get status ``"failed"`` and the
        refusal as their ``message``.
    """
    stack = systems if isinstance(systems, SystemStack) else SystemStack.from_systems(list(systems))
    if switching not in ("angle", "phase"):
        raise SolverError(f"switching must be 'angle' or 'phase', got {switching!r}")
    if isinstance(n_swings, bool) or int(n_swings) != n_swings or n_swings < 1:
        raise SolverError(f"n_swings must be a positive whole number, got {n_swings!r}")
    n_swings = int(n_swings)
    if switching == "phase" and (stack.sp_bp.size or math.isfinite(stack.bank)):
        raise SolverError("phase switching handles neither a piecewise hairspring nor banking")
    reasons = stack.refusals(switching)
    if throw and any(reasons):
        i = next(k for k, m in enumerate(reasons) if m)
        raise SolverError(f"parameter set {i}: {reasons[i]}")
    active = np.array([not m for m in reasons], np.bool_)
    n = stack.size
    nseg = int(max_segments or 64 * n_swings + 1000)
    amp, turn, half, tm = (np.full((n, n_swings), np.nan) for _ in range(4))
    banked = np.zeros((n, n_swings), np.int8)
    n_done = np.zeros(n, np.int64)
    status = np.full(n, REFUSED, np.int64)
    n_seg = np.zeros(n, np.int64)
    final = np.full((n, 3), np.nan)
    previous = get_num_threads()
    if threads is None and n * n_swings < (512 if switching == "angle" else 8192):
        # Measured with run_angle_many on the Monday-like unit (2 shared cores): a parallel
        # region costs ~18 us to wake its workers, the work ~0.7 us per half swing, and 2
        # threads lost to 1 up to 240 half swings and won from 480 on; below 512 the serial
        # loop is no slower and leaves the other core free.  A phase-convention half swing is
        # one affine map (~0.06 us), so its break-even batch is about ten times larger.
        threads = 1
    if threads is not None:
        set_num_threads(max(1, min(int(threads), config.NUMBA_NUM_THREADS)))
    try:
        if switching == "phase":
            run_phase_many(stack.theta0, stack.c, stack.r, stack.sp_w2[:, 0].copy(), stack.w_lo, stack.w_hi,
                           stack.w_x, stack.w_dir, stack.drift_thresholds, stack.drift_rates, active, n_swings,
                           amp, turn, half, tm, banked, n_done, status, n_seg, final)
        else:
            run_angle_many(stack.theta0, stack.c, stack.r, stack.sp_bp, stack.sp_w2, stack.sp_off, stack.w_lo,
                           stack.w_hi, stack.w_x, stack.w_dir, stack.bank, stack.restitution, stack.drift_thresholds,
                           stack.drift_rates, active, n_swings, nseg, amp, turn, half, tm, banked, n_done, status,
                           n_seg, final)
    finally:
        set_num_threads(previous)
    # rows were written only up to n_done; the rest keep their NaN fill (np.full above)
    names = _STATUS_ARRAY[status]
    return BatchTrajectory(amp, turn, half, tm, banked.astype(bool), n_done, names, n_seg, final, stack.omega0.copy(),
                           reasons, {"max_segments": nseg, "switching": switching})
