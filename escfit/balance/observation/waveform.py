"""Waveform readings: every sample of a time series is a reading of theta(t), theta'(t) or x(t).

A sample taken at time ``t`` (the recording's clock, s) reads

    y = theta(t - t_release) - offset - offset_rate * (t - t_ref) + noise

for an angle (``quantity = "angle"``, rad), and the same with the model's angular velocity
theta'(t) in place of theta for a gyroscope or a velocity pickup (``"angular_velocity"``,
rad/s: ``offset`` is then minus the sensor's bias, rad/s, and ``offset_rate`` its drift,
rad/s^2), or with a linear oscillator's displacement x(t) (``"displacement"``, m: offset in m,
offset_rate in m/s).  The model is the same solution either way (its dense output gives theta
and theta' at any time); the readings are compared as measured, never differentiated or
integrated.  In words, for an angle:

(the sensor's zero sits at ``offset`` in the oscillator's frame, as for amplitude readings: an
encoder reading pi at the hanging position of a pendulum has ``offset = -pi``), where ``theta``
is the model's motion released at rest at ``oscillator.theta0`` at the instant
``t_release`` (a turning point of the record, so the release at rest is exact physics, not an
approximation), ``t_ref`` the fixed reference instant of the drift (the detected release) and
the noise Gaussian with scale ``sigma``: independent from sample to sample (``noise = "white"``,
the default) or, with ``noise = "ar1"``, correlated as a first-order autoregression in sample
order, ``e_i = rho*e_(i-1) + innovation`` with marginal scale ``sigma``.  Video trackers and
filtered sensors give correlated errors, and a model that misses a small effect (air drag
growing with the speed, a marker off the axis) leaves residuals that look the same; white noise
then makes the intervals too narrow by about ``sqrt((1 + rho)/(1 - rho))``.  A sensor that reports whole steps (an encoder count, a
pixel) is described by ``quantum``: the reading is the step containing the true value plus
jitter, and the likelihood of a sample is the probability mass of its step, as for notch
counts.

A scene may also name ``gain``: the readings are then ``gain * theta(t - t_release) - offset - ...``,
a scale error of the sensor (a video tracker whose pivot marker sits off the true pivot, a
camera not square to the swing, an encoder's wrong counts per turn).  For a linear oscillator
it is indistinguishable from the release angle; for a pendulum the period's growth with the
amplitude (``sin theta``) fixes the true angle scale, so a free gain is identifiable there.
Without the key there is no gain parameter (readings are the model's quantity as it is).

Parameters: ``observation.sigma`` (rad; rad/s; m), ``observation.offset`` (rad; rad/s; m),
``observation.offset_rate`` (rad/s; rad/s^2; m/s), ``observation.t_release`` (s, recording clock),
``observation.rho`` (AR(1) noise only), ``observation.gain`` (dimensionless, only when the scene
names it).  ``quantum`` (a step of the readings' unit) and ``thin``
(use every n-th sample) are settings, not parameters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from ...core.errors import SceneError
from ...core.params import Param, read_param
from ...core.scene import check_keys
from ...core.units import BARE_ANGLE_LIMIT, to_canonical
from .notches import log_interval_mass

__all__ = ["WaveformObservation", "READINGS"]


@dataclass(frozen=True)
class Readings:
    """What the samples are: the unit kinds of a reading and of its drift, for :func:`read_param`."""

    unit: str  # the readings' unit
    kind: str  # unit kind of a reading (escfit.core.units.CANONICAL)
    rate_unit: str  # unit of the offset's drift
    rate_kind: str
    words: str  # "angle", "angular velocity", "displacement"
    bare_limit: float | None = None


READINGS = {
    "angle": Readings("rad", "angle", "rad/s", "angular_frequency", "angle", BARE_ANGLE_LIMIT),
    "angular_velocity": Readings("rad/s", "angular_frequency", "rad/s**2", "angular_acceleration", "angular velocity"),
    "displacement": Readings("m", "length", "m/s", "speed", "displacement"),
}


@dataclass(frozen=True)
class WaveformObservation:
    """Samples of theta(t) with Gaussian noise and an optional quantisation step.

    Attributes
    ----------
    quantum
        Step of the sensor's readings (rad); 0 for continuous readings.
    thin
        Use every ``thin``-th sample (0: choose so that at most :attr:`MAX_SAMPLES` remain).
    t_ref
        Reference instant of the offset drift (s, recording clock).
    params
        ``observation.sigma``, ``offset``, ``offset_rate``, ``t_release``.
    """

    quantum: float
    thin: int
    t_ref: float
    params: tuple[Param, ...]
    noise: str = "white"
    quantity: str = "angle"
    #: per sample read, whether it starts a new AR(1) chain (a block of a thinned long record,
    #: :mod:`escfit.balance.problems.thinning`); None: the first sample only
    fresh: np.ndarray | None = field(default=None, compare=False, repr=False)
    kind = "waveform"
    KEYS = {"model", "sigma", "offset", "offset_rate", "t_release", "quantum", "thin", "noise", "rho", "gain"}
    MAX_SAMPLES = 4000

    @classmethod
    def from_table(cls, table: Mapping, where: str, *, t_release: float, period: float, offset: float,
                   offset_rate: float, sigma: float, quantity: str = "angle") -> "WaveformObservation":
        """Read ``[observation]`` with ``model = "waveform"``.

        Parameters
        ----------
        table
            The scene's table (keys :attr:`KEYS`).
        where
            ``"file [observation]"`` for messages.
        t_release, period, offset, offset_rate, sigma
            Estimates from the record's turning points (s, s, and the readings' units: rad, rad/s,
            rad; the offsets in this module's convention, i.e. minus the centre on the sensor's
            scale): the defaults of parameters the table does not give.  ``t_release`` is free
            within a tenth of a period either side, the offsets and sigma are free.
        quantity
            What the samples are: ``"angle"``, ``"angular_velocity"`` or ``"displacement"``
            (the units of sigma, offset, offset_rate and quantum follow).
        """
        r = READINGS[quantity]
        check_keys(table, cls.KEYS | {"model"}, where)
        quantum = to_canonical(table.get("quantum", 0.0), r.kind, f"{where}.quantum", bare_limit=r.bare_limit)
        if not (math.isfinite(quantum) and quantum >= 0.0):
            raise SceneError(f"quantum must be a step of the readings ({r.unit}) >= 0, got {table.get('quantum')!r}",
                             f"{where}.quantum")
        noise = table.get("noise", "white")
        if noise not in ("white", "ar1"):
            raise SceneError(f"noise must be 'white' or 'ar1', got {noise!r}", f"{where}.noise")
        if noise == "ar1" and quantum > 0.0:
            raise SceneError("quantum (whole-step readings) goes with white noise; with correlated noise leave it out",
                             f"{where}.quantum")
        if noise == "white" and "rho" in table:
            raise SceneError("rho is the correlation of AR(1) noise: it needs noise = 'ar1'", f"{where}.rho")
        thin = table.get("thin", 0)
        if isinstance(thin, bool) or not isinstance(thin, int) or not 0 <= thin <= 1_000_000:
            raise SceneError(f"thin must be a whole number >= 1 (or 0 for automatic), got {thin!r}", f"{where}.thin")
        guess = dict(table)
        floor = max(quantum / 10.0, 1e-9)
        top = max(1.0, 100.0 * sigma) if math.isfinite(sigma) else 1.0  # a rate in rad/s may be noisier than 1
        guess.setdefault("sigma", {"value": max(sigma, 2 * floor), "vary": True, "min": floor, "max": top,
                                   "prior": f"loguniform({floor!r}, {top!r})"})
        span = abs(offset) + 1.0
        guess.setdefault("offset", {"value": offset, "vary": True, "min": offset - span, "max": offset + span})
        rate_span = abs(offset_rate) + 0.1
        guess.setdefault("offset_rate", {"value": offset_rate, "vary": True, "min": offset_rate - rate_span,
                                         "max": offset_rate + rate_span})
        params = _reading_params(guess, where, r)
        half = 0.1 * period
        t_rel = read_param(table.get("t_release", {"value": t_release, "vary": True, "min": t_release - half,
                                                   "max": t_release + half}),
                           name="observation.t_release", kind="time",
                           meaning="instant the model is released at rest (s, the recording's clock)",
                           where=f"{where}.t_release")
        if noise == "ar1":
            params.append(read_param(table.get("rho", {"value": 0.5, "vary": True, "min": 0.0, "max": 0.99}),
                                     name="observation.rho", kind="dimensionless", lower=-0.999, upper=0.999,
                                     meaning="lag-1 correlation of the reading noise (AR(1), in sample order)",
                                     where=f"{where}.rho"))
        if "gain" in table:
            params.append(read_param(table["gain"], name="observation.gain", kind="dimensionless", lower=0.0,
                                     lower_open=True, meaning="scale of the readings: a reading is gain times "
                                     "the model's quantity (1: the sensor is calibrated)", where=f"{where}.gain"))
        return cls(quantum, thin, t_release, tuple(params) + (t_rel,), noise, quantity)

    def expected(self, theta: np.ndarray, t: np.ndarray, values: Mapping[str, float]) -> np.ndarray:
        """Noise-free readings at sample times ``t`` (s) for the model's ``theta`` (its angle, angular
        velocity or displacement, as :attr:`quantity` says; the readings' unit), times ``gain`` if any."""
        gain = values.get("observation.gain", 1.0)
        return gain * theta - values["observation.offset"] - values["observation.offset_rate"] * (t - self.t_ref)

    def loglike_pointwise(self, theta: np.ndarray, t: np.ndarray, y: np.ndarray,
                          values: Mapping[str, float]) -> np.ndarray:
        """Log-likelihood of each sample ``y`` (rad)."""
        mu = self.expected(theta, t, values)
        sigma = values["observation.sigma"]
        if self.quantum > 0.0:
            h = 0.5 * self.quantum
            return log_interval_mass((y - h - mu) / sigma, (y + h - mu) / sigma)
        z, scale = self._innovations(y - mu, sigma, values)
        return -0.5 * z * z - (np.log(scale) + 0.5 * math.log(2 * math.pi))

    def _innovations(self, r: np.ndarray, sigma: float, values: Mapping[str, float]):
        """Standardised innovations of the residuals ``r`` and the scale of each (rad)."""
        if self.noise == "white":
            return r / sigma, np.full(r.size, sigma)
        rho = values["observation.rho"]
        scale = np.full(r.size, sigma * math.sqrt(max(1.0 - rho * rho, 1e-300)))
        scale[0] = sigma
        e = r.copy()
        e[1:] -= rho * r[:-1]
        if self.fresh is not None:  # each block of a thinned record starts its own chain
            e[self.fresh] = r[self.fresh]
            scale[self.fresh] = sigma
        return e / scale, scale

    def residuals(self, theta: np.ndarray, t: np.ndarray, y: np.ndarray, values: Mapping[str, float]) -> np.ndarray:
        """Residuals scaled by the total reading spread (noise and rounding), for least squares."""
        if self.noise == "ar1":
            return self._innovations(y - self.expected(theta, t, values), values["observation.sigma"], values)[0]
        spread = math.sqrt(values["observation.sigma"] ** 2 + self.quantum**2 / 12.0)
        return (y - self.expected(theta, t, values)) / spread

    def sample(self, theta: np.ndarray, t: np.ndarray, values: Mapping[str, float],
               rng: np.random.Generator) -> np.ndarray:
        """Synthetic readings (rad), rounded to the step when there is one."""
        e = rng.standard_normal(theta.size)
        if self.noise == "ar1":
            rho = values["observation.rho"]
            s = math.sqrt(1.0 - rho * rho)
            for i in range(1, e.size):
                if self.fresh is None or not self.fresh[i]:
                    e[i] = rho * e[i - 1] + s * e[i]
        y = self.expected(theta, t, values) + values["observation.sigma"] * e
        return np.round(y / self.quantum) * self.quantum if self.quantum > 0.0 else y


def _reading_params(table: Mapping, where: str, r: Readings) -> list[Param]:
    """``observation.sigma``, ``offset`` and ``offset_rate`` in the readings' units."""
    if r.unit == "rad":
        from .amplitude import drift_param, noise_params

        return noise_params(table, where, math.nan) + [drift_param(table, where)]
    sigma = read_param(table["sigma"], name="observation.sigma", kind=r.kind, lower=0.0, lower_open=True,
                       bare_limit=r.bare_limit, unit=r.unit, meaning=f"reading noise scale ({r.unit})",
                       where=f"{where}.sigma")
    offset = read_param(table["offset"], name="observation.offset", kind=r.kind, bare_limit=r.bare_limit, unit=r.unit,
                        meaning=(f"zero offset of the sensor ({r.unit}): a reading is the {r.words} less it"
                                 + (" (minus the sensor's bias)" if r.unit == "rad/s" else "")),
                        where=f"{where}.offset")
    rate = read_param(table["offset_rate"], name="observation.offset_rate", kind=r.rate_kind, unit=r.rate_unit,
                      meaning=f"drift of the zero offset ({r.rate_unit})", where=f"{where}.offset_rate")
    return [sigma, offset, rate]
