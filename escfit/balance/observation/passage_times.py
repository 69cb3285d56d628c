"""Passage times: the time at which the balance crosses a known angle.

A photo-cell looking at a notched balance (Monday's recorder) or a timegrapher hearing the
escapement both report *when* the balance passes an angle that is known in advance: notch
``j`` of a wheel with notch angle ``n`` sits at ``theta = j*n``, the escapement sounds at the
edges of the lift.  Each reading is

    t_obs = t0 + t_cross(level) + noise,   noise ~ Normal(0, sigma)

with ``t_cross`` the exact crossing time computed from the exact solver's segment log: the
row holding the level is found from the rows' end states (:func:`escfit.balance.dense.row_state`,
the one evaluation of a log row) and the crossing inside it is root-found on the closed form
to a few ulps (:func:`escfit.balance.segment.cross_time`).

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
from ...core.kernels import kernel
from ...core.params import Param, read_param
from ...core.units import BARE_ANGLE_LIMIT
from ..dense import row_state
from ..segment import cross_time

__all__ = ["PassageTimeObservation", "level_times", "swing_starts"]


def swing_starts(log: np.ndarray, n_swings: int) -> np.ndarray:
    """Index of the first segment-log row of each half swing (length ``n_swings + 1``).

    Parameters
    ----------
    log
        Segment log of the exact solver (rows t0, tau, s, x0, v0, xc, w2, h, swing).
    n_swings
        Number of half swings wanted; half swings the run did not reach get empty ranges.
    """
    return np.searchsorted(log[:, 8], np.arange(n_swings + 1, dtype=float), side="left").astype(np.int64)


@kernel
def _level_times(log, starts, swing, x_base, offset, out):
    n_avail = starts.shape[0] - 1
    for q in range(swing.shape[0]):
        m = swing[q]
        if m < 1 or m > n_avail or starts[m - 1] >= starts[m]:
            out[q] = math.nan
            continue
        r0 = starts[m - 1]
        r1 = starts[m]
        s = log[r0, 2]
        x = x_base[q] + s * offset
        if x <= log[r0, 3]:
            out[q] = log[r0, 0]  # behind the start of the half swing: its first turning point
            continue
        found = False
        for r in range(r0, r1):
            t0 = log[r, 0]
            tau = log[r, 1]
            x0 = log[r, 3]
            v0 = log[r, 4]
            xc = log[r, 5]
            w2 = log[r, 6]
            h = log[r, 7]
            if not math.isfinite(tau):
                # creeps towards the centre xc without turning: crosses only levels below it
                if x < xc:
                    out[q] = t0 + cross_time(x0 - xc, v0, h, w2, x - xc, math.inf)[0]
                else:
                    out[q] = math.inf
                found = True
                break
            theta_end, _ = row_state(log, r, tau)
            if x <= log[r, 2] * theta_end:  # the row's end in the swing frame (exact: s = +-1)
                if tau == 0.0 or x <= x0:
                    out[q] = t0
                else:
                    out[q] = t0 + cross_time(x0 - xc, v0, h, w2, x - xc, tau)[0]
                found = True
                break
        if not found:
            out[q] = log[r1 - 1, 0] + log[r1 - 1, 1]  # beyond the turning point: clamp to it


def level_times(log: np.ndarray, swing: np.ndarray, x_base: np.ndarray, offset: float = 0.0,
                starts: np.ndarray | None = None) -> np.ndarray:
    """Times (s since release) at which the balance crosses given levels.

    Parameters
    ----------
    log
        Segment log of the exact solver.
    swing
        Half swing of each query, 1-based (1 starts at the release).
    x_base
        Level in the swing frame of that half swing, rad (the balance runs from ``-A`` to
        ``+A`` there).
    offset
        Zero offset in theta, rad: the level actually used is ``x_base + s*offset``.
    starts
        Output of :func:`swing_starts` (computed when omitted).

    Returns
    -------
    ndarray
        Crossing times; a level not reached is clamped to the nearest turning point of its
        half swing; ``nan`` for half swings the run never reached; ``inf`` for a level the
        balance only approaches asymptotically.
    """
    swing = np.ascontiguousarray(swing, dtype=np.int64)
    x_base = np.ascontiguousarray(x_base, dtype=float)
    if starts is None:
        starts = swing_starts(log, int(swing.max()) if swing.size else 0)
    out = np.empty(swing.size)
    _level_times(np.ascontiguousarray(log), starts, swing, x_base, float(offset), out)
    return out


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
        unknown = sorted(set(table) - cls.KEYS)
        if unknown:
            raise SceneError(f"unknown key(s) {unknown}; allowed: {sorted(cls.KEYS)}", where)
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
