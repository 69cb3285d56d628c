"""The result every balance solver returns, and its conversion to xarray.

A :class:`Trajectory` holds the per-half-swing results every solver computes, the run's
:class:`~escfit.core.status.Status` and, when the run was asked for it (``dense=True``), its
dense solution (:class:`escfit.balance.solution.DenseSolution`): theta(t), theta'(t), level
crossings and turning points, from whichever solver ran.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.status import Status

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["Trajectory"]


@dataclass
class Trajectory:
    """Per-half-swing results of one run.

    Attributes
    ----------
    amplitude : ndarray
        |theta| at the turning point (or banking impact) ending each half swing, rad.
    theta_turn : ndarray
        Signed theta there, rad.
    half_period : ndarray
        Duration of each half swing, s.
    time : ndarray
        Time at the end of each half swing since release, s.
    banked : ndarray of bool
        Whether the half swing ended on the banking pins.
    code : Status
        How the run ended; :attr:`status` is its label (``"ok"``, ``"stopped"`` ...).
    omega0 : float
        Reference natural frequency (rad/s) for the rate.
    solver, options : str, dict
        Which solver produced it and with which settings.
    n_segments, n_steps : int
        Closed-form segments (exact) or integration steps (rk4, ivp) used.
    final : tuple
        ``(t, theta, omega)`` where the run ended.
    dense : DenseSolution or None
        The dense solution, when the run was asked for one (``dense=True``).
    detail : str
        Why the run ended, when more is known than the status's own message (a refusal);
        :attr:`message` gives it, else the status's message.
    """

    amplitude: np.ndarray
    theta_turn: np.ndarray
    half_period: np.ndarray
    time: np.ndarray
    banked: np.ndarray
    code: Status
    omega0: float
    solver: str
    options: dict[str, Any] = field(default_factory=dict)
    n_segments: int = 0
    n_steps: int = 0
    final: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    dense: Any = None
    detail: str = ""

    @property
    def message(self) -> str:
        """Why the run ended, in one sentence."""
        return self.detail or Status(self.code).message

    @property
    def status(self) -> str:
        """The status label: ``"ok"``, ``"stopped"``, ``"banked"``, ``"max_segments"``,
        ``"phase_breakdown"`` or ``"failed"``."""
        return Status(self.code).label

    @property
    def rate(self) -> np.ndarray:
        """Rate error of each half swing, s/day: ``86400*((pi/omega0)/half_period - 1)``."""
        return 86400.0 * ((math.pi / self.omega0) / self.half_period - 1.0)

    def to_dataset(self, attrs: dict[str, Any] | None = None) -> xr.Dataset:
        """Dataset with dimension ``swing`` (1-based) and the run's status in attributes."""
        import xarray as xr  # imported here: a fit never builds a Dataset of a trajectory

        n = len(self.amplitude)
        swing = np.arange(1, n + 1)
        ds = xr.Dataset(
            {
                "amplitude": ("swing", self.amplitude, {"units": "rad", "long_name": "|theta| at the end of the half swing"}),
                "theta_turn": ("swing", self.theta_turn, {"units": "rad", "long_name": "signed theta at the end of the half swing"}),
                "half_period": ("swing", self.half_period, {"units": "s", "long_name": "duration of the half swing"}),
                "time": ("swing", self.time, {"units": "s", "long_name": "time at the end of the half swing"}),
                "rate": ("swing", self.rate, {"units": "s/day", "long_name": "rate error 86400*((pi/omega0)/half_period - 1)"}),
                "banked": ("swing", self.banked.astype(bool), {"long_name": "half swing ended on the banking pins"}),
            },
            coords={"swing": ("swing", swing, {"long_name": "half swing from release (1 ends at the first turning point)"})},
        )
        ds.attrs.update(
            status=self.status,
            status_message=self.message,
            solver=self.solver,
            solver_options=repr(self.options),
            n_segments=int(self.n_segments),
            n_steps=int(self.n_steps),
            omega0=float(self.omega0),
            final_time=float(self.final[0]),
            final_theta=float(self.final[1]),
            final_omega=float(self.final[2]),
        )
        if attrs:
            ds.attrs.update(attrs)
        return ds
