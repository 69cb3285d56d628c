"""Quantised readings: whole notches of a notched balance counted by a photo-cell.

Monday's balance had 60 notches (6 deg each).  Two reading conventions turn an amplitude ``A``
into a whole number ``n`` of notches of angle ``d``, chosen by ``notch_reading`` in the scene's
``[observation]`` table:

- ``"counted"`` (default): the marks passed from the rest position to the turning point are
  counted, ``n = floor(A/d)``; a reading ``n`` means ``A`` lies in ``[n*d, (n+1)*d)``.
- ``"nearest"``: the turning point is read at the nearest mark, ``n = floor(A/d + 1/2)``; a
  reading ``n`` means ``A`` lies in ``[(n-1/2)*d, (n+1/2)*d)``.

The two differ by half a notch for every reading, so fitting readings under the wrong one
shifts every model amplitude by ``d/2`` and biases the damping parameters; the misfit
diagnostics look for it (:func:`escfit.balance.observation.notch_convention.notch_reading_report`).
With a small timing/reading jitter ``sigma`` the probability of reading ``n`` is the mass of
the reading's interval under a normal distribution centred on the true amplitude, not a
Gaussian density at its centre.  Parameters: ``observation.sigma`` (rad, jitter),
``observation.offset`` (rad) and its drift ``observation.offset_rate`` (rad/s, see
:mod:`escfit.balance.observation.amplitude`).
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

__all__ = ["NotchObservation", "log_interval_mass", "NOTCH_READINGS", "notch_count"]

# lower edge of the interval a reading n stands for, in notches above n
NOTCH_READINGS = {"counted": 0.0, "nearest": -0.5}


def notch_count(amplitude: np.ndarray, notch: float, reading: str = "counted") -> np.ndarray:
    """Whole notches read for amplitudes ``amplitude`` (rad) on a scale of ``notch`` rad.

    ``"counted"``: ``floor(A/notch)``; ``"nearest"``: ``floor(A/notch + 1/2)`` (half-way
    amplitudes read up).  Negative amplitudes read 0.
    """
    lower = NOTCH_READINGS[reading]
    return np.maximum(np.floor(np.asarray(amplitude, float) / notch - lower), 0.0)


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
    """Integer notch readings.

    Attributes
    ----------
    notch
        Notch angle (rad, > 0).
    params
        ``observation.sigma``, ``observation.offset``, ``observation.offset_rate``.
    reading
        ``"counted"`` (marks passed, ``[n, n+1)`` notches) or ``"nearest"`` (nearest mark,
        ``[n-1/2, n+1/2)`` notches); see the module docstring.
    """

    notch: float
    params: tuple[Param, ...]
    reading: str = "counted"
    kind = "notches"
    KEYS = {"sigma", "offset", "offset_rate", "notch_deg", "notch_reading"}

    def __post_init__(self) -> None:
        if self.reading not in NOTCH_READINGS:
            raise SceneError(f"notch_reading must be one of {', '.join(map(repr, NOTCH_READINGS))}, "
                             f"got {self.reading!r}")

    @classmethod
    def from_table(cls, table: Mapping, where: str, notch: float | None = None) -> "NotchObservation":
        reading = table.get("notch_reading", "counted")
        if reading not in NOTCH_READINGS:
            raise SceneError(f"notch_reading must be one of {', '.join(map(repr, NOTCH_READINGS))} (marks passed, or "
                             f"the mark nearest the turning point), got {reading!r}", f"{where}.notch_reading")
        if "notch_deg" in table:
            n = _notch_angle(table["notch_deg"], f"{where}.notch_deg")
            if notch is not None and not math.isnan(notch) and abs(n - notch) > 1e-12:
                raise SceneError(f"notch_deg {table['notch_deg']!r} disagrees with the data's notch angle "
                                 f"{math.degrees(notch):g} deg", f"{where}.notch_deg")
            notch = n
        if notch is None or not notch > 0:
            raise SceneError("notch readings need a notch angle (notch_deg)", where)
        return cls(notch, tuple(noise_params(table, where, 0.25 * notch) + [drift_param(table, where)]), reading)

    def interval(self, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Edges (rad) of the amplitude interval ``[lower, upper)`` a reading ``n`` stands for."""
        lower = (np.asarray(n, float) + NOTCH_READINGS[self.reading]) * self.notch
        return lower, lower + self.notch

    def interval_position(self, mu: np.ndarray, n: np.ndarray) -> np.ndarray:
        """Position of expected amplitudes ``mu`` (rad) inside their readings' intervals.

        0 at the lower edge, 1 at the upper edge; outside ``[0, 1)`` when the model amplitude
        lies outside the reading's interval.  Under the right convention and a model that fits,
        positions spread over the interval; piled against one edge they say the readings
        follow the other convention.
        """
        lower, _ = self.interval(n)
        return (np.asarray(mu, float) - lower) / self.notch

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
        lower, upper = self.interval(n)
        return log_interval_mass((lower - mu) / sigma, (upper - mu) / sigma)

    def loglike(self, theta_turn: np.ndarray, n: np.ndarray, values: Mapping[str, float],
                side: np.ndarray | None = None, time: np.ndarray | None = None) -> float:
        """Log-probability of the counts ``n``."""
        return float(np.sum(self.loglike_pointwise(theta_turn, n, values, side, time)))

    def residuals(self, theta_turn: np.ndarray, n: np.ndarray, values: Mapping[str, float],
                  side: np.ndarray | None = None, time: np.ndarray | None = None) -> np.ndarray:
        """Interval mid-point residuals scaled by the total reading spread (for least squares)."""
        mu = self.expected(theta_turn, values, side, time)
        spread = math.sqrt(values["observation.sigma"] ** 2 + self.notch**2 / 12.0)
        lower, upper = self.interval(n)
        return (0.5 * (lower + upper) - mu) / spread

    def sample(self, theta_turn: np.ndarray, values: Mapping[str, float], rng: np.random.Generator) -> np.ndarray:
        """Synthetic readings: the jittered amplitude read in this model's convention."""
        mu = self.expected(theta_turn, values)
        return notch_count(mu + values["observation.sigma"] * rng.standard_normal(mu.size), self.notch, self.reading)


def _notch_angle(raw, where: str) -> float:
    """``notch_deg``: a bare number is in degrees; a string carries its own unit (``"6 deg"``)."""
    if isinstance(raw, str):
        return to_canonical(raw, "angle", where)
    if isinstance(raw, bool) or not isinstance(raw, (int, float)) or not math.isfinite(raw):
        raise SceneError(f"notch_deg must be a finite number of degrees, got {raw!r}", where)
    return math.radians(raw)
