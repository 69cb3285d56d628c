"""The log-likelihood of turning-point readings for many parameter sets in one compiled call.

A sampler step asks for the log-likelihood of a few dozen parameter sets.  The batch solver
(:mod:`escfit.balance.batch`) gives their turning points in one call; this kernel reads every
recorded swing of every curve out of them and sums the observation model's log-probabilities,
so no numpy array of (sets, readings) is built and no ufunc is dispatched per step.  It
computes what :meth:`NotchObservation.loglike_pointwise
<escfit.balance.observation.notches.NotchObservation.loglike_pointwise>` and the Gaussian
:meth:`AmplitudeObservation.loglike_pointwise
<escfit.balance.observation.amplitude.AmplitudeObservation.loglike_pointwise>` compute (those
numpy versions stay the reference: ``tests/test_compiled_loglike.py`` checks the two agree
to rounding), summed curve after curve in reading order.

Readings are described once per fit by a :data:`READING` record each (curve, swing, nominal
side, time since release, and the reading: the interval edges of a notch count in rad, or the
amplitude in rad), the parameters of each set by a :data:`SET` record.
"""

from __future__ import annotations

import math

import numpy as np

from ...core.kernels import kernel

__all__ = ["READING", "SET", "NOTCHES", "GAUSSIAN", "loglike_sets", "log_ndtr", "log_interval_mass"]

#: one reading: which curve and swing it reads, its nominal side (0: none, read |theta - offset|),
#: time since release (s), and ``lo``/``hi`` (notch interval edges, rad) or ``lo`` = the amplitude (rad)
READING = np.dtype([("curve", "i8"), ("swing", "i8"), ("side", "f8"), ("time", "f8"), ("lo", "f8"), ("hi", "f8")])
#: one parameter set: observation.sigma, observation.offset, observation.offset_rate
SET = np.dtype([("sigma", "f8"), ("offset", "f8"), ("rate", "f8")])
NOTCHES, GAUSSIAN = 0, 1

_SQRT1_2 = 1.0 / math.sqrt(2.0)
_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)


@kernel
def log_ndtr(x: float) -> float:
    """log of the standard normal cdf, accurate in both tails (as scipy.special.log_ndtr)."""
    if x > 0.0:  # the upper tail's small complement, kept to full relative precision
        return math.log1p(-0.5 * math.erfc(x * _SQRT1_2))
    if x > -20.0:
        return math.log(0.5 * math.erfc(-x * _SQRT1_2))
    # asymptotic series of the lower tail: the terms fall below rounding by the 12th at x <= -20
    r = 1.0 / (x * x)
    term, total = 1.0, 1.0
    for k in range(1, 13):
        term *= -(2.0 * k - 1.0) * r
        total += term
    return -0.5 * x * x - math.log(-x) - _LOG_SQRT_2PI + math.log(total)


@kernel
def log_interval_mass(a: float, b: float) -> float:
    """log(Phi(b) - Phi(a)) for a < b, the upper tail mirrored (as notches.log_interval_mass)."""
    if a > 0.0:
        lo, hi = -b, -a
    else:
        lo, hi = a, b
    lhi = log_ndtr(hi)
    return lhi + math.log1p(-math.exp(log_ndtr(lo) - lhi))


@kernel
def loglike_sets(turns: np.ndarray, n_done: np.ndarray, readings: np.ndarray, sets: np.ndarray, model: int,
                 out: np.ndarray) -> None:
    """Log-likelihood of every parameter set, written to ``out`` (shape (sets,)).

    Parameters
    ----------
    turns : ndarray, shape (curves, sets, 1 + swings)
        Release angle, then the signed turning points of each set at each curve's load (rad).
    n_done : ndarray of int, shape (curves, sets)
        Half swings each run completed: a swing after them reads the rest position 0.
    readings : ndarray of :data:`READING`
        Every reading, curve after curve.
    sets : ndarray of :data:`SET`, shape (sets,)
    model
        :data:`NOTCHES` (interval mass of each count) or :data:`GAUSSIAN` (density of each amplitude).
    """
    n_sets = sets.shape[0]
    n_read = readings.shape[0]
    for s in range(n_sets):
        sigma = sets[s]["sigma"]
        offset = sets[s]["offset"]
        rate = sets[s]["rate"]
        log_norm = math.log(sigma) + _LOG_SQRT_2PI
        total = 0.0
        part = 0.0
        current = readings[0]["curve"] if n_read else 0
        for j in range(n_read):
            rd = readings[j]
            c = rd["curve"]
            if c != current:  # each curve's sum first, then the curves' sums in order
                total += part
                part = 0.0
                current = c
            k = rd["swing"]
            theta = turns[c, s, k] if k <= n_done[c, s] else 0.0
            off = offset + rate * rd["time"] if rate != 0.0 else offset
            side = rd["side"]
            if side == 0.0:
                mu = abs(theta - off)
            else:
                mu = side * theta - side * off
            if model == NOTCHES:
                part += log_interval_mass((rd["lo"] - mu) / sigma, (rd["hi"] - mu) / sigma)
            else:
                z = (rd["lo"] - mu) / sigma
                part += -0.5 * z * z - log_norm
        out[s] = total + part
