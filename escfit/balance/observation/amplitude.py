"""Amplitude readings with Gaussian or Student-t noise and an unknown scale zero.

A reading of half swing k is ``|theta_turn[k] - offset(t_k)| + noise``: with the scale's zero
displaced by ``offset`` the readings on alternate sides differ by twice the offset.

The centre of oscillation may drift: ``offset(t) = offset + offset_rate * t`` with ``t`` the
reading's time since release (s).  Physical causes: a sensor zero that creeps as its
electronics warm up (linear over minutes), a hairspring or suspension that takes a set (the
rest position moves slowly in one direction), a support that tilts or settles, and, for a
torsion wheel, the spring's stud creeping in its clamp.  A linear drift is the first term of
any of them over a record; a constant offset leaves two alternating residual branches that
open or close along the record, which the misfit diagnostics report.

Every method takes the model's turning points either as signed angles ``theta`` or, with
``side`` given, as amplitudes measured towards the nominal side ``side`` (+1/-1) of each
swing; the latter may be negative (Monday's phase convention can end a half cycle on the
wrong side) and then keeps the expected reading smooth instead of folding it at zero.
Parameters: ``observation.sigma`` (rad, noise scale), ``observation.offset`` (rad, zero
offset; fixed at 0 unless the scene says otherwise), ``observation.offset_rate`` (rad/s, its
linear drift; fixed at 0 unless the scene says otherwise), ``observation.nu`` (Student-t degrees
of freedom).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np
from scipy import special

from ...core.errors import SceneError
from ...core.params import Param, read_param
from ...core.units import BARE_ANGLE_LIMIT

__all__ = ["AmplitudeObservation", "noise_params", "expected_reading"]


def expected_reading(theta: np.ndarray, offset, side: np.ndarray | None = None) -> np.ndarray:
    """Noise-free amplitude reading of a scale whose zero is displaced by ``offset``.

    Without ``side``: ``|theta - offset|``.  With ``side``: ``theta`` is the amplitude towards
    the nominal side ``side`` and the reading is ``theta - side*offset`` (may be negative).
    ``offset`` (rad) is a number or one value per reading (a drifting centre).
    """
    if side is None:
        return np.abs(theta - offset)
    return theta - side * offset


def noise_params(table: Mapping, where: str, default_sigma: float) -> list[Param]:
    """The sigma and offset parameters shared by the amplitude-like models."""
    sigma = read_param(table.get("sigma", {"value": default_sigma, "vary": True, "min": 1e-6, "max": 10.0,
                                           "prior": "loguniform(1e-6, 10)"}),
                       name="observation.sigma", kind="angle", lower=0.0, lower_open=True, bare_limit=BARE_ANGLE_LIMIT,
                       meaning="reading noise scale (rad)", where=f"{where}.sigma")
    offset = read_param(table.get("offset", 0.0), name="observation.offset", kind="angle", bare_limit=BARE_ANGLE_LIMIT,
                        meaning="zero offset of the scale (rad); readings on alternate sides differ by twice it",
                        where=f"{where}.offset")
    return [sigma, offset]


def drift_param(table: Mapping, where: str) -> Param:
    """``observation.offset_rate``: linear drift of the scale's zero (rad/s), fixed at 0 by default."""
    return read_param(table.get("offset_rate", 0.0), name="observation.offset_rate", kind="angular_frequency",
                      meaning="drift of the zero offset (rad/s, positive: the centre moves towards +theta)",
                      where=f"{where}.offset_rate", unit="rad/s")


def offset_at(values: Mapping[str, float], time: np.ndarray | None):
    """Zero offset (rad) at the readings' times since release (s); a number when there is no drift."""
    rate = values.get("observation.offset_rate", 0.0)
    if np.ndim(rate) == 0 and rate == 0.0:  # (values may hold one column per parameter set)
        return values["observation.offset"]
    if time is None:
        raise SceneError("observation.offset_rate needs the time of every reading; the data have no times")
    return values["observation.offset"] + rate * time


@dataclass(frozen=True)
class AmplitudeObservation:
    """Continuous amplitude readings (rad)."""

    noise: str
    params: tuple[Param, ...]
    kind = "amplitude"
    KEYS = {"noise", "sigma", "offset", "offset_rate", "nu"}

    @classmethod
    def from_table(cls, table: Mapping, where: str, notch: float | None = None) -> "AmplitudeObservation":
        noise = table.get("noise", "gaussian")
        if noise not in ("gaussian", "student_t"):
            raise SceneError(f"noise must be 'gaussian' or 'student_t', got {noise!r}", f"{where}.noise")
        params = noise_params(table, where, 0.05) + [drift_param(table, where)]
        if noise == "student_t":
            params.append(read_param(table.get("nu", 4.0), name="observation.nu", kind="dimensionless", lower=0.0,
                                     lower_open=True, meaning="Student-t degrees of freedom", where=f"{where}.nu"))
        return cls(noise, tuple(params))

    @staticmethod
    def expected(theta_turn: np.ndarray, values: Mapping[str, float], side: np.ndarray | None = None,
                 time: np.ndarray | None = None) -> np.ndarray:
        """Noise-free readings, rad; ``time`` (s since release) is needed with a drifting offset."""
        return expected_reading(theta_turn, offset_at(values, time), side)

    def loglike_pointwise(self, theta_turn: np.ndarray, y: np.ndarray, values: Mapping[str, float],
                          side: np.ndarray | None = None, time: np.ndarray | None = None) -> np.ndarray:
        """Log-likelihood of each reading ``y`` (rad)."""
        sigma = values["observation.sigma"]
        z = (y - self.expected(theta_turn, values, side, time)) / sigma
        if self.noise == "gaussian":
            return -0.5 * z * z - (np.log(sigma) + 0.5 * math.log(2 * math.pi))
        nu = values["observation.nu"]
        c = special.gammaln((nu + 1) / 2) - special.gammaln(nu / 2) - 0.5 * np.log(nu * math.pi) - np.log(sigma)
        return c - (nu + 1) / 2 * np.log1p(z * z / nu)

    def loglike(self, theta_turn: np.ndarray, y: np.ndarray, values: Mapping[str, float],
                side: np.ndarray | None = None, time: np.ndarray | None = None) -> float:
        """Log-likelihood of readings ``y`` (rad)."""
        return float(np.sum(self.loglike_pointwise(theta_turn, y, values, side, time)))

    def residuals(self, theta_turn: np.ndarray, y: np.ndarray, values: Mapping[str, float],
                  side: np.ndarray | None = None, time: np.ndarray | None = None) -> np.ndarray:
        """Standardised residuals for least squares (Gaussian approximation)."""
        return (y - self.expected(theta_turn, values, side, time)) / values["observation.sigma"]

    def sample(self, theta_turn: np.ndarray, values: Mapping[str, float], rng: np.random.Generator,
               time: np.ndarray | None = None) -> np.ndarray:
        """Synthetic readings (rad, clipped at 0)."""
        e = self.expected(theta_turn, values, None, time)
        sigma = values["observation.sigma"]
        noise = rng.standard_t(values["observation.nu"], e.size) if self.noise == "student_t" else rng.standard_normal(e.size)
        return np.maximum(e + sigma * noise, 0.0)
