"""The waveform log-likelihood of many parameter sets in one compiled call.

What :meth:`WaveformObservation.loglike_pointwise
<escfit.balance.observation.waveform.WaveformObservation.loglike_pointwise>` computes sample by
sample, summed, for every row of a (sets, samples) array of the model's quantity (theta,
theta' or x at the sample times, from :func:`escfit.balance.batch_dense.sample_batch`): the
expected reading ``gain*model - offset - offset_rate*(t - t_ref)``, then white Gaussian
noise, AR(1) noise (the first sample with the marginal scale ``sigma``, the others through their
innovations ``r_i - rho*r_(i-1)`` with scale ``sigma*sqrt(1 - rho^2)``) or whole-step readings
(the probability mass of the step, white jitter).  The numpy version stays the reference
(the tests compare the two); only the order of the final sum differs, so the two agree to
rounding.

Samples are described once per fit by :data:`SAMPLE` records (the reading and its time since
the drift's reference instant), the parameters of each set by :data:`WAVE_SET` records.
"""

from __future__ import annotations

import math

import numpy as np

from ...core.kernels import kernel
from .compiled import log_interval_mass

__all__ = ["SAMPLE", "WAVE_SET", "WHITE", "AR1", "QUANTISED", "waveform_loglike_sets"]

#: one sample: the reading ``y`` (the readings' unit) and ``dt = t - t_ref`` (s)
SAMPLE = np.dtype([("y", "f8"), ("dt", "f8"), ("fresh", "u1")])
#: one parameter set: observation.sigma, offset, offset_rate, gain (1 without one), rho (0 for white noise)
WAVE_SET = np.dtype([("sigma", "f8"), ("offset", "f8"), ("rate", "f8"), ("gain", "f8"), ("rho", "f8")])
#: noise models: independent Gaussian, first-order autoregression, whole steps of ``quantum``
WHITE, AR1, QUANTISED = 0, 1, 2

_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)


@kernel
def waveform_loglike_sets(model, samples, sets, noise, out):
    """Log-likelihood of every set, written to ``out`` (shape (sets,)).

    Parameters
    ----------
    model : ndarray, shape (sets, samples)
        The model's quantity at the sample times.
    samples : ndarray of :data:`SAMPLE`
    sets : ndarray of :data:`WAVE_SET`, shape (sets,)
    noise : tuple
        ``(code, quantum)``: :data:`WHITE`, :data:`AR1` or :data:`QUANTISED`, and the step of
        whole-step readings (their unit; unused otherwise).
    """
    code, quantum = noise
    n = samples.shape[0]
    half = 0.5 * quantum
    for s in range(sets.shape[0]):
        st = sets[s]
        sigma = st.sigma
        offset = st.offset
        rate = st.rate
        gain = st.gain
        total = 0.0
        if code == QUANTISED:
            for j in range(n):
                mu = gain * model[s, j] - offset - rate * samples[j].dt
                y = samples[j].y
                total += log_interval_mass((y - half - mu) / sigma, (y + half - mu) / sigma)
        elif code == AR1:
            rho = st.rho
            scale = sigma * math.sqrt(max(1.0 - rho * rho, 1e-300))
            log_first = math.log(sigma) + _LOG_SQRT_2PI
            log_rest = math.log(scale) + _LOG_SQRT_2PI
            previous = 0.0
            for j in range(n):
                r = samples[j].y - (gain * model[s, j] - offset - rate * samples[j].dt)
                if j == 0 or samples[j].fresh:  # a chain's first sample: its marginal scale
                    z = r / sigma
                    total += -0.5 * z * z - log_first
                else:
                    z = (r - rho * previous) / scale
                    total += -0.5 * z * z - log_rest
                previous = r
        else:
            log_norm = math.log(sigma) + _LOG_SQRT_2PI
            for j in range(n):
                z = (samples[j].y - (gain * model[s, j] - offset - rate * samples[j].dt)) / sigma
                total += -0.5 * z * z - log_norm
        out[s] = total
