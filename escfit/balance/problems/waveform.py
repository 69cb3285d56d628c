"""Fit problem on a whole waveform: every sample of a time series is a reading.

Turning points keep one number per half swing; a short or noisy record has few of them.  The
waveform fit compares the model's theta(t) with every sample (see
:mod:`escfit.balance.observation.waveform`), through the solvers' dense output
(:func:`escfit.balance.waveform.sample_theta`): parameter vector -> values -> balance system ->
theta at the sample times -> observation model -> log-likelihood.

Samples used: from a tenth of a period after the record's reference turning point (so that
every admissible release instant ``t_release`` precedes them) up to the end of motion, thinned
to at most :attr:`~escfit.balance.observation.waveform.WaveformObservation.MAX_SAMPLES` unless the scene's
``thin`` says otherwise.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Mapping

import numpy as np

from .. import BalanceScene
from ...core.errors import FitError
from ..observation.waveform import WaveformObservation
from ...core.params import ParamSet
from .curves import Curve
from .pulses import RecordingProblem
from .nuisance import centre_priors
from .release import release_from_record

__all__ = ["WaveformProblem", "noise_from_samples"]


def noise_from_samples(theta: np.ndarray) -> float:
    """Reading noise (rad) from the second differences of a densely sampled smooth signal.

    For white noise of scale ``s`` the second difference has scale ``s*sqrt(6)``; the motion's
    own curvature adds little when there are many samples per period.  A robust (MAD) scale.
    """
    d2 = np.diff(theta, 2)
    if d2.size < 3:
        return math.nan
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / math.sqrt(6.0))


class WaveformProblem(RecordingProblem):
    """Fit a balance scene to every sample of a free-decay time series.

    Parameters
    ----------
    scene
        Balance scene (angle switching); its ``[observation]`` says ``model = "waveform"``.
    series
        The samples (:class:`~escfit.balance.recordings.timeseries.TimeSeries`).
    reference
        The record's turning-point analysis (:class:`~escfit.balance.recordings.timeseries.TurningPoints`):
        reference instant and angle, period, offset and drift estimates, end of motion.
    solver, solver_options
        Any solver (default: the scene's) and its options.
    """

    reading_units = "rad"

    def __init__(self, scene: BalanceScene, series, reference, solver: str | None = None,
                 solver_options: dict | None = None):
        scene = replace(scene, params=ParamSet(dict(scene.params.params)))  # the release is set on a copy
        super().__init__(scene, series, solver, solver_options)
        where = f"{scene.where} [observation]"
        table = {k: v for k, v in dict(scene.extra.get("observation", {})).items() if k != "model"}
        for key, value in centre_priors(reference, sign=-1.0).items():
            table.setdefault(key, value)
        t_ref = float(reference.release_time)
        period = float(reference.period)
        stop = float(getattr(reference, "stop_time", math.nan))
        end = stop if math.isfinite(stop) else float(series.time[-1])
        keep = (series.time >= t_ref + 0.1 * period) & (series.time <= end)
        idx = np.flatnonzero(keep)
        if idx.size < 20:
            raise FitError(f"only {idx.size} samples between the reference turning point at {t_ref:.4g} s and the end "
                           f"of motion at {end:.4g} s; a waveform fit needs a longer record", series.source)
        sigma0 = noise_from_samples(series.theta[idx])
        if math.isfinite(sigma0) and sigma0 > 0.3:
            raise FitError(f"the samples scatter by {sigma0:.3g} rad about a smooth curve: are they angles in rad? set "
                           "[recording] angle_unit (and scale) for another unit", series.source)
        self.observation = WaveformObservation.from_table(
            table, where, t_release=t_ref, period=period, offset=-float(reference.offset),
            offset_rate=-float(getattr(reference, "offset_rate", 0.0)),
            sigma=sigma0 if math.isfinite(sigma0) and sigma0 > 0 else 1e-3)
        thin = self.observation.thin or max(1, math.ceil(idx.size / WaveformObservation.MAX_SAMPLES))
        idx = idx[::thin]
        self.thin = thin
        self.period = period
        self.sample_time = series.time[idx]
        self.notes = release_from_record(self.scene.params, float(reference.release_theta) - float(reference.offset),
                                         series.source, scene.restoring)
        self._setup_params()
        if thin > 1:
            self.notes.append(f"waveform: one sample in {thin} used ({idx.size} of {np.count_nonzero(keep)})")
        self.curves = [Curve("waveform", math.nan, np.arange(idx.size), series.theta[idx], self.sample_time)]

    def _predict(self, vals: Mapping[str, float]) -> np.ndarray:
        """Model angle (rad, about the centre) at every sample used."""
        from ..waveform import sample_theta

        t = self.sample_time - vals["observation.t_release"]
        if t[0] < 0.0:
            raise FitError("the release instant falls after the first sample used")
        theta, status = sample_theta(self.scene.system(vals), t, self.solver, **self.solver_options)
        if status in ("max_segments", "failed"):
            raise FitError(f"solver status {status}")
        return theta

    def _pointwise(self, pred, vals):
        return self.observation.loglike_pointwise(pred, self.sample_time, self.curves[0].y, vals)

    def _residuals(self, pred, vals):
        return self.observation.residuals(pred, self.sample_time, self.curves[0].y, vals)

    def _expected(self, pred, vals):
        return self.observation.expected(pred, self.sample_time, vals)
