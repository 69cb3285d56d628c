"""Dense solutions: theta(t), theta'(t), level crossings and turning points, from any solver.

Every solver asked for ``dense=True`` attaches a :class:`DenseSolution` to its trajectory, and
observation models read the motion only through it: sampled angles and angular velocities
(waveform fits, sampled recordings), the times at which the balance passes known angles
(photo-cell pulses, timegrapher beats and lift) and the turning points.

:class:`RowSolution` serves the compiled solvers.  A run is kept as rows, each a stretch of one
half swing in one region of constant coefficients (:mod:`escfit.balance.regions`) starting at
time ``t0`` from a state ``(x0, v0)`` in the swing frame ``x = s*theta``, and lasting ``tau``:

======  =========================================  ==============================================
kind    rows                                        motion inside a row
======  =========================================  ==============================================
exact   one per closed-form segment                 the closed form (:mod:`escfit.balance.segment`)
dop853  one per accepted step (or step to an event) a DOP853 step of the partial length
rk4     one per 64 steps, or fewer before an event  the RK4 steps from the row start, then a
                                                    partial one
======  =========================================  ==============================================

so the motion between stored states carries the solver's own accuracy (the closed form's
rounding, or the integrator's local error).  Columns: ``t0, tau, s, x0, v0, xc, w2, extra,
swing`` (and, for rk4, the number of whole steps), ``extra`` being ``C/2`` (exact), the
acceleration at the row start (dop853) or the step (rk4); ``swing`` counts half swings from 0.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod

import numpy as np

from ..core.kernels import kernel
from ..core.status import Status
from .segment import cross_time, propagate
from .steps import N_EXTENDED, N_STAGES, dop853_extension, dop853_step, extension_at, rk4_step

__all__ = ["DenseSolution", "RowSolution", "ROW_EXACT", "ROW_DOP853", "ROW_RK4", "swing_starts", "write_row"]

ROW_EXACT, ROW_DOP853, ROW_RK4 = 0, 1, 2


@kernel(inline="always")
def write_row(rows, n, start, region, extra, swing):
    """Row ``n`` of a dense solution: ``start = (t0, tau, s, x0, v0)``, ``region = (xc, w2)``, the
    solver's ``extra`` and the half swing (the columns of the module docstring)."""
    t0, tau, s, x0, v0 = start
    xc, w2 = region
    rows[n, 0] = t0
    rows[n, 1] = tau
    rows[n, 2] = s
    rows[n, 3] = x0
    rows[n, 4] = v0
    rows[n, 5] = xc
    rows[n, 6] = w2
    rows[n, 7] = extra
    rows[n, 8] = swing


class DenseSolution(ABC):
    """The motion of one run between and at its turning points.

    Times are seconds since the release; angles (rad) and angular velocities (rad/s) are in the
    scene's frame (positive in the sense of a positive ``theta0``).
    """

    trajectory = None  # the per-half-swing results of the run (escfit.balance.trajectory.Trajectory)

    @abstractmethod
    def state(self, t) -> tuple[np.ndarray, np.ndarray]:
        """theta (rad) and theta' (rad/s) at times ``t`` (s since release, >= 0).

        After a stop the balance stays at its rest angle with zero velocity; beyond the end of a
        run that ended otherwise (the half swings asked for, a failure) the values are NaN.
        """

    def theta(self, t) -> np.ndarray:
        """Angle (rad) at times ``t``; see :meth:`state`."""
        return self.state(t)[0]

    def omega(self, t) -> np.ndarray:
        """Angular velocity (rad/s) at times ``t``; see :meth:`state`."""
        return self.state(t)[1]

    @abstractmethod
    def crossings(self, swing, level, offset: float = 0.0) -> np.ndarray:
        """Times (s since release) at which half swings pass given levels.

        Parameters
        ----------
        swing : array of int
            Half swing of each query, 1-based (1 starts at the release).
        level : array
            Level in the swing frame of that half swing, rad: the balance runs from ``-A`` to
            ``+A`` there.
        offset
            Zero offset in theta, rad: the level actually used is ``level + s*offset``.

        Returns
        -------
        ndarray
            Crossing times.  A level the half swing does not reach is clamped to its nearest
            turning point (the time of closest approach), one behind its start to its start;
            NaN for half swings the run never reached; ``inf`` for a level only approached
            asymptotically.
        """

    @abstractmethod
    def knots(self) -> np.ndarray:
        """Start times (s) of the solution's pieces, and the end of the last (for plots)."""

    def turning_points(self) -> tuple[np.ndarray, np.ndarray]:
        """Time (s) and signed angle (rad) at the end of each half swing: its turning point or
        banking impact (the release itself, at rest from ``theta0`` at ``t = 0``, is not listed)."""
        return self.trajectory.time.copy(), self.trajectory.theta_turn.copy()

    def _beyond(self) -> tuple[float, float]:
        """State after the last piece: at rest after a stop, else unknown."""
        tr = self.trajectory
        if tr.code == Status.STOPPED:
            return float(tr.final[1]), 0.0
        return math.nan, math.nan


# -- compiled evaluation of rows ---------------------------------------------------------------

@kernel
def _row_motion(sol, i, u):
    """Swing-frame state ``(x, v)`` a time ``u`` into row ``i`` of ``sol = (rows, kind, ks, stages)``
    (``ks``: the coefficient record, an array of one; ``stages``: DOP853 scratch arrays)."""
    rows, kind, ks, stages = sol
    tau = rows[i, 1]
    if u > tau:
        u = tau
    if u < 0.0:
        u = 0.0
    x0 = rows[i, 3]
    v0 = rows[i, 4]
    xc = rows[i, 5]
    w2 = rows[i, 6]
    if kind == ROW_EXACT:
        y, v = propagate(x0 - xc, v0, u, rows[i, 7], w2)
        return xc + y, v
    if u == 0.0:
        return x0, v0
    regime = (w2, xc, ks[0])
    if kind == ROW_DOP853:
        x, v, _ = dop853_step((x0, v0, rows[i, 7]), u, regime, stages)
        return x, v
    h = rows[i, 7]
    n = min(int(u / h), int(rows[i, 9]))
    x = x0
    v = v0
    for _ in range(n):
        x, v = rk4_step(x, v, h, regime)
    rest = u - n * h
    if rest > 0.0:
        x, v = rk4_step(x, v, rest, regime)
    return x, v


@kernel
def _states_at(sol, times, beyond, theta, omega):
    """theta, omega at ascending ``times``: each time in the last row starting at or before it.

    Times after the end of the last row (all times when there are no rows) get ``beyond``.  A
    dop853 row is evaluated by its step's continuous extension
    (:func:`~escfit.balance.steps.dop853_extension`: the step and three more stages once, then a
    polynomial per time) instead of a step of the partial length per time: samples a few per
    step apart cost a fraction, and the motion is one smooth function of the parameters
    whichever way the samples fall among the steps.
    """
    rows, kind, ks, _ = sol
    n = rows.shape[0]
    i = 0
    end = rows[n - 1, 0] + rows[n - 1, 1] if n > 0 else -math.inf
    dop853 = kind == ROW_DOP853
    kx = np.empty(N_EXTENDED)
    kv = np.empty(N_EXTENDED)
    coef = np.empty((7, 2))
    extended = -1  # the row whose continuous extension coef holds
    for q in range(times.shape[0]):
        t = times[q]
        if not t <= end:
            theta[q], omega[q] = beyond
            continue
        while i + 1 < n and rows[i + 1, 0] <= t:
            i += 1
        if extended != i and dop853 and rows[i, 1] > 0.0:
            # the step's continuous extension, made once, serves every time inside it
            dop853_extension((rows[i, 3], rows[i, 4], rows[i, 7]), rows[i, 1], (rows[i, 6], rows[i, 5], ks[0]),
                             (kx, kv), coef)
            extended = i
        if extended == i:
            x, v = extension_at(coef, rows[i, 3], rows[i, 4], min(max((t - rows[i, 0]) / rows[i, 1], 0.0), 1.0))
        else:
            x, v = _row_motion(sol, i, t - rows[i, 0])
        s = rows[i, 2]
        theta[q] = s * x
        omega[q] = s * v


@kernel
def _cross_in_row(sol, r, level):
    """Time into row ``r`` at which its swing-frame angle rises to ``level`` (between its ends)."""
    rows = sol[0]
    tau = rows[r, 1]
    if sol[1] == ROW_EXACT:
        xc = rows[r, 5]
        return cross_time(rows[r, 3] - xc, rows[r, 4], rows[r, 7], rows[r, 6], level - xc, tau)[0]
    lo = 0.0
    hi = tau
    v0 = rows[r, 4]
    u = (level - rows[r, 3]) / v0 if v0 > 0.0 else 0.5 * tau
    if not (lo < u < hi):
        u = 0.5 * (lo + hi)
    noise = 4.5e-16 * (abs(rows[r, 3]) + abs(level))
    for _ in range(200):
        x, v = _row_motion(sol, r, u)
        f = x - level
        if f == 0.0 or abs(f) <= noise:
            return u
        if f > 0.0:
            hi = u
        else:
            lo = u
        new = 0.5 * (lo + hi)
        if v > 0.0 and lo < u - f / v < hi:
            new = u - f / v
        if hi - lo <= 4e-16 * hi or new == u:
            return new
        u = new
    return u


@kernel
def _level_times(sol, starts, queries, offset, out):
    """Crossing times of ``queries = (swing, level)``; see :meth:`DenseSolution.crossings`."""
    rows = sol[0]
    swing, x_base = queries
    n_avail = starts.shape[0] - 1
    for q in range(swing.shape[0]):
        m = swing[q]
        if m < 1 or m > n_avail or starts[m - 1] >= starts[m]:
            out[q] = math.nan
            continue
        r0 = starts[m - 1]
        r1 = starts[m]
        s = rows[r0, 2]
        x = x_base[q] + s * offset
        if x <= rows[r0, 3]:
            out[q] = rows[r0, 0]  # behind the start of the half swing: its first turning point
            continue
        found = False
        for r in range(r0, r1):
            t0 = rows[r, 0]
            tau = rows[r, 1]
            if not math.isfinite(tau):
                # creeps towards the centre xc without turning: crosses only levels below it
                xc = rows[r, 5]
                if x < xc:
                    out[q] = t0 + cross_time(rows[r, 3] - xc, rows[r, 4], rows[r, 7], rows[r, 6], x - xc,
                                             math.inf)[0]
                else:
                    out[q] = math.inf
                found = True
                break
            if sol[1] != ROW_EXACT and r + 1 < r1:
                x_end = rows[r + 1, 3]  # the next row starts where this one ends
            else:
                x_end, _ = _row_motion(sol, r, tau)
            if x <= x_end:
                if tau == 0.0 or x <= rows[r, 3]:
                    out[q] = t0
                else:
                    out[q] = t0 + _cross_in_row(sol, r, x)
                found = True
                break
        if not found:
            out[q] = rows[r1 - 1, 0] + rows[r1 - 1, 1]  # beyond the turning point: clamp to it


@kernel
def _ascending(t):
    for i in range(1, t.shape[0]):
        if not t[i] >= t[i - 1]:
            return False
    return True


def swing_starts(rows: np.ndarray, n_swings: int) -> np.ndarray:
    """Index of the first row of each half swing (length ``n_swings + 1``; empty ranges for half
    swings the run did not reach)."""
    return np.searchsorted(rows[:, 8], np.arange(n_swings + 1, dtype=float), side="left").astype(np.int64)


class RowSolution(DenseSolution):
    """The dense solution of a compiled solver: its rows (see the module docstring).

    Parameters
    ----------
    rows
        The rows, in time order.
    kind
        ``ROW_EXACT``, ``ROW_DOP853`` or ``ROW_RK4``.
    k
        The run's coefficient record (an array of one), for the integrators' steps.
    trajectory
        The run's per-half-swing results.
    """

    def __init__(self, rows: np.ndarray, kind: int, k: np.ndarray, trajectory):
        self.rows = np.ascontiguousarray(rows, float)
        self.kind = int(kind)
        self.k = k
        self.trajectory = trajectory

    @property
    def segments(self) -> np.ndarray:
        """The rows themselves (for the exact solver: its closed-form segments, columns ``t0, tau, s,
        x0, v0, xc, w2, h, swing`` with ``h = C/2``)."""
        return self.rows

    def _sol(self) -> tuple:
        return (self.rows, self.kind, self.k, (np.empty(N_STAGES + 1), np.empty(N_STAGES + 1)))

    def state(self, t) -> tuple[np.ndarray, np.ndarray]:
        times = np.ascontiguousarray(t, dtype=float)
        scalar = times.ndim == 0
        times = times.reshape(-1)
        theta, omega = np.empty(times.size), np.empty(times.size)
        if _ascending(times):
            _states_at(self._sol(), times, self._beyond(), theta, omega)
        else:
            order = np.argsort(times, kind="stable")
            th, om = np.empty(times.size), np.empty(times.size)
            _states_at(self._sol(), np.ascontiguousarray(times[order]), self._beyond(), th, om)
            theta[order], omega[order] = th, om
        return (theta[0], omega[0]) if scalar else (theta, omega)

    def crossings(self, swing, level, offset: float = 0.0) -> np.ndarray:
        swing = np.ascontiguousarray(swing, dtype=np.int64)
        level = np.ascontiguousarray(np.broadcast_to(np.asarray(level, float), swing.shape))
        n = int(swing.max()) if swing.size else 0
        out = np.empty(swing.size)
        _level_times(self._sol(), swing_starts(self.rows, n), (swing, level), float(offset), out)
        return out

    def knots(self) -> np.ndarray:
        rows = self.rows
        if not rows.shape[0]:
            return np.zeros(1)
        return np.append(rows[:, 0], rows[-1, 0] + rows[-1, 1])
