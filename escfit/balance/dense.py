"""Dense output of the exact solver: theta(t) and omega(t) between the turning points.

Inside each logged segment the motion is the closed form of :mod:`escfit.balance.segment`, so
dense values are exact, not interpolated.  :func:`row_state` is the one evaluation of a
segment-log row; :func:`log_states` (hence :func:`dense_output`, for plots), :func:`log_theta_at`
(waveform fits, see :mod:`escfit.balance.waveform`) and the level crossings of
:mod:`escfit.balance.observation.passage_times` all use it.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from ..core.kernels import kernel
from .segment import propagate
from .trajectory import Trajectory

__all__ = ["dense_output", "log_states", "log_theta_at", "row_state"]


@kernel(inline="always")
def row_state(log, i, u):
    """State a time ``u`` into row ``i`` of a segment log (compiled; inlined into callers).

    Parameters
    ----------
    log : ndarray, shape (rows, 9)
        Segment log of the exact solver (t0, tau, s, x0, v0, xc, w2, h, swing).
    i : int
        Row.
    u : float
        Time into the row (s), clipped to ``[0, tau]``.

    Returns
    -------
    theta, omega : float
        Angle (rad) and angular velocity (rad/s), signed in the balance frame: ``log[i, 2]``
        times the swing-frame values, so ``log[i, 2] * theta`` is the swing-frame angle exactly.
    """
    tau = log[i, 1]
    if u > tau:
        u = tau
    if u < 0.0:
        u = 0.0
    s = log[i, 2]
    xc = log[i, 5]
    y, v = propagate(log[i, 3] - xc, log[i, 4], u, log[i, 7], log[i, 6])
    return s * (xc + y), s * v


@kernel
def log_states(log, seg, u, theta, omega):
    """Fill ``theta[k], omega[k]`` with the state ``u[k]`` seconds into log row ``seg[k]``.

    Parameters
    ----------
    log : ndarray, shape (rows, 9)
        Segment log of the exact solver (t0, tau, s, x0, v0, xc, w2, h, swing).
    seg : ndarray of int
        Row of each sample.
    u : ndarray
        Time into that row (s), clipped to ``[0, tau]``.
    theta, omega : ndarray
        Outputs: angle (rad) and angular velocity (rad/s), signed in the balance frame.
    """
    for k in range(seg.shape[0]):
        theta[k], omega[k] = row_state(log, seg[k], u[k])


@kernel
def log_theta_at(log, times, beyond, theta):
    """theta (rad) at ascending ``times`` (s) from a segment log.

    Each time falls in the last row starting at or before it (a merge of the sorted times with
    the rows' start times); times after the end of the last row, or all times when the log is
    empty, get ``beyond`` (the rest angle after a stop, or NaN).
    """
    n = log.shape[0]
    i = 0
    end = log[n - 1, 0] + log[n - 1, 1] if n > 0 else -math.inf
    for k in range(times.shape[0]):
        t = times[k]
        if not t <= end:
            theta[k] = beyond
            continue
        while i + 1 < n and log[i + 1, 0] <= t:
            i += 1
        theta[k], _ = row_state(log, i, t - log[i, 0])


def dense_output(traj: Trajectory, *, points_per_segment: int = 24) -> xr.Dataset:
    """theta(t) (rad) and omega(t) (rad/s) from an exact run made with ``log=True``.

    Parameters
    ----------
    traj
        Result of ``solve(scene, "exact", log=True)``.
    points_per_segment
        Samples per closed-form segment (segment ends included).

    Returns
    -------
    xarray.Dataset
        Variables ``theta`` and ``omega`` and the ``swing`` each sample belongs to, on a
        dimension ``t`` (s).
    """
    if traj.log is None:
        from ..core.errors import SolverError
        raise SolverError("dense output needs the segment log, got traj.log = None: "
                          "solve(..., solver='exact', log=True)")
    log = np.ascontiguousarray(traj.log, float)
    tau = log[:, 1].copy()
    creep = ~np.isfinite(tau)
    # creeping to rest: show a few time constants
    tau[creep] = 5.0 / np.maximum(log[creep, 7], np.sqrt(log[creep, 6]) * 1e-3)
    u = (tau[:, None] * np.linspace(0.0, 1.0, points_per_segment)[None, :]).ravel()
    seg = np.repeat(np.arange(log.shape[0]), points_per_segment)
    theta, omega = np.empty(u.size), np.empty(u.size)
    log_states(log, seg, u, theta, omega)
    t = log[seg, 0] + u
    swing = log[seg, 8].astype(int) + 1
    return xr.Dataset(
        {"theta": ("t", theta, {"units": "rad"}), "omega": ("t", omega, {"units": "rad/s"}),
         "swing": ("t", swing, {"long_name": "half swing the sample belongs to"})},
        coords={"t": ("t", t, {"units": "s"})})
