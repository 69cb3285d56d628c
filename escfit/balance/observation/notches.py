"""Quantised readings: whole notches of a notched balance counted by a photo-cell.

Monday's balance had 60 notches (6 deg each); counting notches from the rest position to the
turning point gives ``n = floor(A/notch)``.  With a small timing/reading jitter ``sigma`` the
probability of reading ``n`` is the mass of the interval ``[n, n+1) * notch`` under a normal
distribution centred on the true amplitude, not a Gaussian density at its centre.
Parameters: ``observation.sigma`` (rad, jitter), ``observation.offset`` (rad) and its drift
``observation.offset_rate`` (rad/s, see :mod:`escfit.balance.observation.amplitude`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np
from scipy import special

from ...core.errors import SceneError
from ...core.params import Param
from ...core.units import to_canonical
from .amplitude import drift_param, expected_reading, noise_params, offset_at

__all__ = ["NotchObservation", "log_interval_mass"]


def log_interval_mass(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """log(Phi(b) - Phi(a)) for a < b, accurate in both tails."""
    a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
    upper = a > 0  # use the mirrored interval in the upper tail
    lo = np.where(upper, -b, a)
    hi = np.where(upper, -a, b)
    lhi, llo = special.log_ndtr(hi), special.log_ndtr(lo)
    with np.errstate(divide="ignore"):
        return lhi + np.log1p(-np.exp(llo - lhi))


@dataclass(frozen=True)
class NotchObservation:
    """Integer notch counts; ``notch`` is the notch angle (rad)."""

    notch: float
    params: tuple[Param, ...]
    kind = "notches"
    KEYS = {"sigma", "offset", "offset_rate", "notch_deg"}

    @classmethod
    def from_table(cls, table: Mapping, where: str, notch: float | None = None) -> "NotchObservation":
        if "notch_deg" in table:
            n = to_canonical(f"{table['notch_deg']} deg", "angle", f"{where}.notch_deg")
            if notch is not None and not math.isnan(notch) and abs(n - notch) > 1e-12:
                raise SceneError(f"notch_deg {table['notch_deg']!r} disagrees with the data's notch angle "
                                 f"{math.degrees(notch):g} deg", f"{where}.notch_deg")
            notch = n
        if notch is None or not notch > 0:
            raise SceneError("notch readings need a notch angle (notch_deg)", where)
        return cls(notch, tuple(noise_params(table, where, 0.25 * notch) + [drift_param(table, where)]))

    @staticmethod
    def expected(theta_turn: np.ndarray, values: Mapping[str, float], side: np.ndarray | None = None,
                 time: np.ndarray | None = None) -> np.ndarray:
        """Noise-free amplitude (rad) before counting; see :func:`expected_reading`."""
        return expected_reading(theta_turn, offset_at(values, time), side)

    def loglike_pointwise(self, theta_turn: np.ndarray, n: np.ndarray, values: Mapping[str, float],
                          side: np.ndarray | None = None, time: np.ndarray | None = None) -> np.ndarray:
        """Log-probability of each count ``n``."""
        mu = self.expected(theta_turn, values, side, time)
        sigma = values["observation.sigma"]
        return log_interval_mass((n * self.notch - mu) / sigma, ((n + 1) * self.notch - mu) / sigma)

    def loglike(self, theta_turn: np.ndarray, n: np.ndarray, values: Mapping[str, float],
                side: np.ndarray | None = None, time: np.ndarray | None = None) -> float:
        """Log-probability of the counts ``n``."""
        return float(np.sum(self.loglike_pointwise(theta_turn, n, values, side, time)))

    def residuals(self, theta_turn: np.ndarray, n: np.ndarray, values: Mapping[str, float],
                  side: np.ndarray | None = None, time: np.ndarray | None = None) -> np.ndarray:
        """Interval mid-point residuals scaled by the total reading spread (for least squares)."""
        mu = self.expected(theta_turn, values, side, time)
        spread = math.sqrt(values["observation.sigma"] ** 2 + self.notch**2 / 12.0)
        return ((n + 0.5) * self.notch - mu) / spread

    def sample(self, theta_turn: np.ndarray, values: Mapping[str, float], rng: np.random.Generator) -> np.ndarray:
        mu = self.expected(theta_turn, values)
        return np.maximum(np.floor((mu + values["observation.sigma"] * rng.standard_normal(mu.size)) / self.notch), 0.0)
