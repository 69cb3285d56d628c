"""Passage times: the time at which the balance crosses a known angle.

A photo-cell looking at a notched balance (Monday's recorder) or a timegrapher hearing the
escapement both report *when* the balance passes an angle that is known in advance: notch
``j`` of a wheel with notch angle ``n`` sits at ``theta = j*n``, the escapement sounds at the
edges of the lift.  Each reading is

    t_obs = t0 + t_cross(level) + noise,   noise ~ Normal(0, sigma)

with ``t_cross`` the crossing time read from the run's dense solution
(:meth:`escfit.balance.solution.DenseSolution.crossings`), whichever solver made it: with the
exact solver the crossing is root-found on the closed form to a few ulps, with an integrating
solver on its own steps.

Levels and frames
-----------------
Inside half swing ``m`` (1 = the half swing that starts at the release) the balance moves
monotonically in the swing frame ``x = s*theta`` from ``-A[m-1]`` to ``+A[m]``; a level is
given in that frame as ``x = x_base + s*offset`` so that a scale zero displaced by
``offset`` (rad, in theta) is handled without knowing the direction in advance.

A level the model does not reach is *clamped*: its predicted time is the turning point that
ends the half swing (or the one that starts it, for a level behind the start).  This is the
time of closest approach, so predictions stay continuous in the parameters when a model
amplitude sinks below a notch the data crossed: the two crossings of the outermost notch
merge at the turning point and then stay there.

Parameters: ``observation.sigma`` (s, timing noise: the reading noise of a passage-time
recording is a time), ``observation.t0`` (s, the release instant on the recording's clock)
and ``observation.offset`` (rad, zero offset of the notch scale relative to the rest
position).  All three are fixed unless the scene's ``[observation]`` table frees them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ...core.errors import SceneError
from ...core.params import Param, read_param
from ...core.scene import check_keys
from ...core.units import BARE_ANGLE_LIMIT

__all__ = ["PassageTimeObservation"]


@dataclass(frozen=True)
class PassageTimeObservation:
    """Gaussian timing noise on the crossing times of known levels.

    Attributes
    ----------
    params
        ``observation.sigma`` (s), ``observation.t0`` (s), ``observation.offset`` (rad).
    """

    params: tuple[Param, ...]
    kind = "passage_times"
    KEYS = {"model", "sigma", "t0", "offset"}

    @classmethod
    def from_table(cls, table: Mapping | None, where: str, *, release_s: float = 0.0,
                   default_sigma: float = 1e-4) -> "PassageTimeObservation":
        """Read an ``[observation]`` table with ``model = "passage_times"`` (or defaults).

        Parameters
        ----------
        table
            The table (``None``: all defaults).
        where
            ``"file [observation]"`` for messages.
        release_s
            Default release instant on the recording's clock, s (from the data file).
        default_sigma
            Default timing noise, s.
        """
        table = dict(table or {})
        model = table.get("model", "passage_times")
        if model != "passage_times":
            raise SceneError(f"a pulse recording needs model = \"passage_times\" in [observation], got {model!r}",
                             f"{where}.model")
        check_keys(table, cls.KEYS | {"model"}, where)
        sigma = read_param(table.get("sigma", {"value": default_sigma, "vary": True, "min": 1e-7, "max": 1.0,
                                               "prior": "loguniform(1e-7, 1)"}),
                           name="observation.sigma", kind="time", lower=0.0, lower_open=True,
                           meaning="timing noise of each passage time (s)", where=f"{where}.sigma")
        t0 = read_param(table.get("t0", release_s), name="observation.t0", kind="time",
                        meaning="release instant on the recording's clock (s); model times are added to it",
                        where=f"{where}.t0")
        offset = read_param(table.get("offset", 0.0), name="observation.offset", kind="angle", bare_limit=BARE_ANGLE_LIMIT,
                            meaning="zero offset of the notch scale (rad): notch j sits at theta = j*notch + offset",
                            where=f"{where}.offset")
        return cls((sigma, t0, offset))

    @staticmethod
    def expected(t_model: np.ndarray, values: Mapping[str, float]) -> np.ndarray:
        """Noise-free readings (s on the recording's clock) from model times since release."""
        return values["observation.t0"] + t_model

    def loglike_pointwise(self, t_model: np.ndarray, y: np.ndarray, values: Mapping[str, float]) -> np.ndarray:
        """Log-density of each passage time ``y`` (s)."""
        sigma = values["observation.sigma"]
        z = (y - self.expected(t_model, values)) / sigma
        return -0.5 * z * z - (math.log(sigma) + 0.5 * math.log(2 * math.pi))

    def loglike(self, t_model: np.ndarray, y: np.ndarray, values: Mapping[str, float]) -> float:
        return float(np.sum(self.loglike_pointwise(t_model, y, values)))

    def residuals(self, t_model: np.ndarray, y: np.ndarray, values: Mapping[str, float]) -> np.ndarray:
        """Standardised residuals."""
        return (y - self.expected(t_model, values)) / values["observation.sigma"]

    def sample(self, t_model: np.ndarray, values: Mapping[str, float], rng: np.random.Generator) -> np.ndarray:
        """Synthetic passage times, in time order (a recorder writes them as they come)."""
        return np.sort(self.expected(t_model, values) + values["observation.sigma"] * rng.standard_normal(t_model.size))
