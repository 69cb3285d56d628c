"""Dense output of the exact solver: theta(t) and omega(t) on a time grid, for plots.

Inside each logged segment the motion is the closed form of :mod:`escfit.balance.segment`, so
dense values are exact, not interpolated.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from .segment import propagate
from .trajectory import Trajectory

__all__ = ["dense_output"]


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
        raise ValueError("dense output needs the segment log: solve(..., solver='exact', log=True)")
    t_all, th_all, om_all, sw_all = [], [], [], []
    for t0, tau, s, x0, v0, xc, w2, h, swing in traj.log:
        if not math.isfinite(tau):
            tau = 5.0 / max(h, math.sqrt(w2) * 1e-3)  # creeping to rest: show a few time constants
        for u in np.linspace(0.0, tau, points_per_segment):
            y, v = propagate(x0 - xc, v0, u, h, w2)
            t_all.append(t0 + u)
            th_all.append(s * (xc + y))
            om_all.append(s * v)
            sw_all.append(int(swing) + 1)
    return xr.Dataset(
        {"theta": ("t", np.array(th_all), {"units": "rad"}), "omega": ("t", np.array(om_all), {"units": "rad/s"}),
         "swing": ("t", np.array(sw_all), {"long_name": "half swing the sample belongs to"})},
        coords={"t": ("t", np.array(t_all), {"units": "s"})})
