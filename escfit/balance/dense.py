"""Dense output for plots: theta(t) and omega(t) between the turning points, from any solver.

The values come from the run's dense solution (:mod:`escfit.balance.solution`), sampled at
evenly spaced times inside each of its pieces (the exact solver's closed-form segments, an
integrator's steps), so every turning point and switch is a sample.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..core.errors import SolverError
from .trajectory import Trajectory

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["dense_output"]


def dense_output(traj: Trajectory, *, points_per_segment: int = 24) -> xr.Dataset:
    """theta(t) (rad) and omega(t) (rad/s) from a run made with ``dense=True``.

    Parameters
    ----------
    traj
        Result of ``solve(scene, ..., dense=True)``.
    points_per_segment
        Samples per piece of the dense solution (its ends included).

    Returns
    -------
    xarray.Dataset
        Variables ``theta`` and ``omega`` and the ``swing`` each sample belongs to (1 ends at the
        first turning point), on a dimension ``t`` (s).
    """
    if traj.dense is None:
        raise SolverError("dense output needs the dense solution: solve(..., dense=True)")
    knots = traj.dense.knots()
    if not np.isfinite(knots[-1]):
        # only the exact solver's last segment creeps to rest without end: show a few time constants
        h, w2 = traj.dense.segments[-1, 7], traj.dense.segments[-1, 6]
        knots = np.append(knots[:-1], knots[-2] + 5.0 / max(h, np.sqrt(w2) * 1e-3))
    u = np.linspace(0.0, 1.0, points_per_segment)
    t = (knots[:-1, None] + (knots[1:] - knots[:-1])[:, None] * u[None, :]).ravel()
    t = np.maximum.accumulate(t)  # rounding of the ends must not step back
    theta, omega = traj.dense.state(t)
    swing = np.searchsorted(traj.time, t, side="left") + 1
    import xarray as xr  # imported here: a fit never builds a Dataset of a trajectory

    return xr.Dataset(
        {"theta": ("t", theta, {"units": "rad"}), "omega": ("t", omega, {"units": "rad/s"}),
         "swing": ("t", swing, {"long_name": "half swing the sample belongs to"})},
        coords={"t": ("t", t, {"units": "s"})})
