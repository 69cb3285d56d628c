"""Fit problem on a whole waveform: every sample of a time series is a reading.

Turning points keep one number per half swing; a short or noisy record has few of them.  The
waveform fit compares the model's theta(t) with every sample (see
:mod:`escfit.balance.observation.waveform`), through the solvers' dense output
(:func:`escfit.balance.waveform.sample_state`): parameter vector -> values -> balance system ->
theta (or theta') at the sample times -> observation model -> log-likelihood.  What was measured
is the series' ``quantity``: an angle (rad) is compared with theta(t), an angular velocity
(rad/s: a gyroscope, a velocity pickup) with theta'(t), a displacement (m) with the x(t) of a
linear oscillator scene (``[oscillator] coordinate = "linear"``).

Samples used: from a tenth of a period after the record's reference turning point (so that
every admissible release instant ``t_release`` precedes them) up to the end of motion, thinned
to at most :attr:`~escfit.balance.observation.waveform.WaveformObservation.MAX_SAMPLES` unless the scene's
``thin`` says otherwise.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import replace
from typing import Mapping

import numpy as np

from .. import BalanceScene
from ...core.errors import EscfitError, FitError
from .thinning import thin_samples
from ..observation.waveform import READINGS, WaveformObservation
from ...core.params import ParamSet
from .curves import FAIL_RESIDUAL, Curve, _column
from .pulses import RecordingProblem
from .nuisance import centre_priors
from .release import release_from_record
from .tolerance import noise_rtol
from .start_spans import start_spans

__all__ = ["WaveformProblem", "noise_from_samples"]

#: solvers whose dense solution log_prob_many samples for a whole ensemble, and the options it passes on
_BATCH_OPTIONS = {"exact": {"max_segments"}, "dop853": {"rtol", "atol", "max_segments", "max_steps"}}


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
        The samples (:class:`~escfit.analysis.recordings.timeseries.TimeSeries`).
    reference
        The record's turning-point analysis (:class:`~escfit.analysis.recordings.timeseries.TurningPoints`):
        reference instant and angle (or displacement), period, offset and drift estimates, end of
        motion; for an angular velocity, the angle's turning points (the rate's zeros).
    solver, solver_options
        Any solver (default: the scene's) and its options.
    centre
        Where the sensor's zero and its drift were measured, with standard errors (attributes
        ``offset``, ``offset_stderr``, ``offset_rate``, ``offset_rate_measured``,
        ``offset_rate_stderr``, in the readings' units): for an angular velocity the rate's bias
        (:class:`~escfit.analysis.recordings.rate.RateAnalysis`); default ``reference``.
    noise
        The readings' noise scale (their unit), a start for ``observation.sigma``; default: from
        the samples' second differences.
    facts
        What the analysis of the record found (:class:`~escfit.balance.problems.facts.RecordFacts`):
        its notes come before the problem's own.
    """

    def __init__(self, scene: BalanceScene, series, reference, solver: str | None = None,
                 solver_options: dict | None = None, *, centre=None, noise: float | None = None, facts=None):
        scene = replace(scene, params=ParamSet(dict(scene.params.params)))  # the release is set on a copy
        super().__init__(scene, series, solver, solver_options)
        self.quantity = getattr(series, "quantity", "angle")
        where = f"{scene.where} [observation]"
        table = {k: v for k, v in dict(scene.extra.get("observation", {})).items() if k != "model"}
        centre = reference if centre is None else centre
        for key, value in centre_priors(centre, sign=-1.0).items():
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
        sigma0 = noise_from_samples(series.theta[idx]) if noise is None else float(noise)
        if self.quantity == "angle" and math.isfinite(sigma0) and sigma0 > 0.3:
            raise FitError(f"the samples scatter by {sigma0:.3g} rad about a smooth curve: are they angles in rad? set "
                           "[recording] angle_unit (and scale) for another unit", series.source)
        if not (math.isfinite(sigma0) and sigma0 > 0):
            sigma0 = 1e-3 * max(float(np.ptp(series.theta[idx])), 1e-6)
        self.observation = WaveformObservation.from_table(
            table, where, t_release=t_ref, period=period, offset=-float(centre.offset),
            offset_rate=-float(getattr(centre, "offset_rate", 0.0)), sigma=sigma0, quantity=self.quantity)
        kept = thin_samples(series.time, idx, period, WaveformObservation.MAX_SAMPLES, self.observation.thin)
        idx = kept.index
        if kept.fresh is not None:
            self.observation = replace(self.observation, fresh=kept.fresh)
        self.period = period
        self.sample_time = series.time[idx]
        self.notes = release_from_record(self.scene.params, float(reference.release_theta) - float(reference.offset),
                                         series.source, scene.restoring, "m" if scene.linear else "rad")
        self._setup_params()
        if kept.note:
            self.notes.append(f"waveform: {kept.note}")
        self.curves = [Curve("waveform", math.nan, np.arange(idx.size), series.theta[idx], self.sample_time)]
        # the exact or dop853 dense solution is sampled for a whole ensemble in one call (log_prob_many)
        self.tolerance_basis = ""
        #: least squares differentiates by the integrator's sensitivities (else by forward differences)
        self.has_sensitivities = self.solver == "dop853" and self._sensitivities_apply()
        if self.solver == "dop853" and not {"rtol", "atol"} & set(self.solver_options):
            # the tolerance from the readings' noise and the Jacobian's steps, stated in the results
            span = float(self.sample_time[-1] - t_ref)
            rtol, self.tolerance_basis = noise_rtol(sigma0, 0.5 * float(np.ptp(series.theta[idx])), idx.size,
                                                    span / period if period > 0 else math.nan,
                                                    sensitivities=self.has_sensitivities)
            self.solver_options = {**self.solver_options, "rtol": rtol}
        #: where the multistart draws omega0 and the losses: what the record's period and decay allow
        self.start_spans = start_spans(self.scene, getattr(facts, "measured_period", None), reference,
                                       float(self.sample_time[-1] - t_ref)) if self.quantity == "angle" else {}
        self.jacobians = Counter()  # least squares' Jacobians by how they were made
        self.vectorized = self.solver in _BATCH_OPTIONS and set(self.solver_options) <= _BATCH_OPTIONS[self.solver]
        if facts is not None:
            facts.give(self)

    def _sensitivities_apply(self) -> bool:
        """Whether least squares will differentiate this scene by the integrator's sensitivities
        (:mod:`escfit.balance.sensitivity`: dop853, no switch but turning points)."""
        from ..sensitivity import covers

        try:
            return covers(self.scene.system(self.values(self.initial)))
        except (EscfitError, ValueError, ArithmeticError, KeyError):
            return False

    def provenance(self) -> dict:
        """As every recording problem's, and how the integrator's tolerance was chosen (``solver_tolerance``)."""
        out = super().provenance()
        if self.tolerance_basis:
            out["solver_tolerance"] = self.tolerance_basis
        if self.jacobians:
            out["jacobian"] = ", ".join(f"{n} by {how}" for how, n in self.jacobians.most_common())
        return out

    @property
    def sampler_coordinates(self):
        """With AR(1) noise whose scale and correlation are both free, emcee samples the log
        innovation scale and atanh(rho) in their place
        (:class:`~escfit.likelihood.coordinates.AR1Coordinates`): the data fix those two almost
        independently, while (sigma, rho) lie on a curved ridge that mixes slowly.  None otherwise."""
        names = list(self.names)
        if self.observation.noise != "ar1" or not {"observation.sigma", "observation.rho"} <= set(names):
            return None
        from ...likelihood.coordinates import AR1Coordinates

        return AR1Coordinates(names.index("observation.sigma"), names.index("observation.rho"))

    @property
    def reading_units(self) -> str:
        """The readings' unit: rad, rad/s or m."""
        return READINGS[self.quantity].unit

    def _predict(self, vals: Mapping[str, float]) -> np.ndarray:
        """The model's angle (rad), angular velocity (rad/s) or displacement (m) at every sample used."""
        from ..waveform import sample_state

        t = self.sample_time - vals["observation.t_release"]
        if t[0] < 0.0:
            raise FitError("the release instant falls after the first sample used")
        theta, omega, status = sample_state(self.scene.system(vals), t, self.solver, **self.solver_options)
        if status in ("max_segments", "failed"):
            raise FitError(f"solver status {status}")
        return omega if self.quantity == "angular_velocity" else theta

    def _pointwise(self, pred, vals):
        return self.observation.loglike_pointwise(pred, self.sample_time, self.curves[0].y, vals)

    def _residuals(self, pred, vals):
        return self.observation.residuals(pred, self.sample_time, self.curves[0].y, vals)

    def _expected(self, pred, vals):
        return self.observation.expected(pred, self.sample_time, vals)

    # -- many parameter vectors at once ------------------------------------------------------
    def _log_likelihood_many(self, vecs: np.ndarray) -> np.ndarray:
        """Log-likelihood of every row (inside the priors) as one array computation.

        Every set's run and its dense solution at the sample times in one compiled call
        (:func:`escfit.balance.batch_dense.sample_batch`,
        :func:`escfit.balance.batch_dop853.sample_batch_dop853`), the observation model of every
        set in another (:func:`escfit.balance.observation.waveform_compiled.waveform_loglike_sets`);
        sets the batch refuses or does not finish (a release after the first sample, a run out of
        segments, a non-finite likelihood) go through :meth:`log_likelihood` one at a time, which
        records why.
        """
        from ..observation.waveform_compiled import WAVE_SET, waveform_loglike_sets

        n_sets = vecs.shape[0]
        vals = self.values_many(vecs)
        ll = np.full(n_sets, math.nan)
        model, usable = self._model_many(vals, n_sets)
        if model is not None:
            sets = np.empty(n_sets, WAVE_SET)
            sets["sigma"] = vals["observation.sigma"]
            sets["offset"] = vals["observation.offset"]
            sets["rate"] = vals["observation.offset_rate"]
            sets["gain"] = vals.get("observation.gain", 1.0)
            sets["rho"] = vals.get("observation.rho", 0.0)
            with np.errstate(all="ignore"):
                waveform_loglike_sets(model, self._samples(), sets, self._noise(), ll)
        for i in np.flatnonzero(~(usable & np.isfinite(ll))):
            ll[i] = self.log_likelihood(self.values(vecs[i]))  # counts the failure as log_prob would
        return ll

    def _model_many(self, vals: Mapping, n_sets: int) -> tuple[np.ndarray | None, np.ndarray]:
        """The model's quantity at the sample times for every set, shape (sets, samples), and which
        sets the batch finished (the others are for the one-set path); ``(None, all False)`` when
        the batch refuses the whole ensemble."""
        from ..batch_dense import OMEGA, THETA, sample_batch

        if self.solver == "dop853":
            from ..batch_dop853 import sample_batch_dop853 as sample_batch
        try:
            model, summary = sample_batch(self.scene.system(vals, n_sets), self.sample_time,
                                          _column(vals["observation.t_release"], n_sets),
                                          which=OMEGA if self.quantity == "angular_velocity" else THETA,
                                          **self.solver_options)
        except (EscfitError, ValueError, ArithmeticError):
            return None, np.zeros(n_sets, bool)  # every set the one-at-a-time way, which records why
        return model, summary["usable"] == 1

    def residuals_many(self, vecs: np.ndarray) -> np.ndarray:
        """:meth:`residuals` of every row of ``vecs`` (sets, ndim), shape (sets, readings).

        Row by row the numbers of :meth:`residuals` (the same sampled model, bit for bit, and the
        same element-wise arithmetic of :meth:`WaveformObservation.residuals
        <escfit.balance.observation.waveform.WaveformObservation.residuals>`: gain, offsets, white
        or AR(1)-whitened residuals over the noise and rounding spread).  With the exact or the
        dop853 solver every set's model comes from one batch call; sets it does not finish, and
        every set with another solver, go through :meth:`residuals` one at a time, which counts
        the failure and returns its large residuals.
        """
        vecs = np.atleast_2d(np.asarray(vecs, float))
        n_sets = vecs.shape[0]
        if not self.vectorized:
            return np.array([self.residuals(self.values(v)) for v in vecs]).reshape(n_sets, self.n_data)
        vals = self.values_many(vecs)
        model, usable = self._model_many(vals, n_sets)
        out = np.empty((n_sets, self.n_data))
        if model is not None and usable.any():
            with np.errstate(all="ignore"):
                out[usable] = self._residual_rows(model[usable], {k: (v[usable] if isinstance(v, np.ndarray) else v)
                                                                  for k, v in vals.items()})
        for i in np.flatnonzero(~usable):
            out[i] = self.residuals(self.values(vecs[i]))
        return np.where(np.isfinite(out), out, FAIL_RESIDUAL)

    def residual_jacobian(self, vals: Mapping, names: list[str]) -> np.ndarray | None:
        """The standardised residuals' derivatives by ``names`` at ``vals``, shape (readings, names),
        from the integrator's sensitivities (:mod:`escfit.balance.problems.waveform_jacobian`);
        None where they do not apply (then forward differences are the way)."""
        from .waveform_jacobian import residual_jacobian

        return residual_jacobian(self, vals, names)

    def _residual_rows(self, model: np.ndarray, vals: Mapping) -> np.ndarray:
        """:meth:`WaveformObservation.residuals` of rows of ``model`` with per-row parameters."""
        obs = self.observation

        def col(name, default=None):
            v = vals.get(name, default)
            return np.asarray(v, float)[:, None] if np.ndim(v) else v

        gain = col("observation.gain", 1.0)
        mu = gain * model - col("observation.offset") - col("observation.offset_rate") * (self.sample_time - obs.t_ref)
        return self.standardise(self.curves[0].y - mu, vals)

    def standardise(self, r: np.ndarray, vals: Mapping) -> np.ndarray:
        """Rows of raw residuals (readings minus the mean, shape (sets, readings)) over the noise:
        white or AR(1)-whitened (each thinned block its own chain) or over the rounding spread,
        with each row's ``observation.sigma`` and ``observation.rho`` (scalars or one per row).
        Linear in ``r``, so it also carries a residual's derivatives."""
        obs = self.observation
        sigma = np.asarray(vals["observation.sigma"], float)
        if obs.noise == "ar1":
            rho = np.broadcast_to(np.asarray(vals["observation.rho"], float), (r.shape[0],))
            sigma = np.broadcast_to(sigma, (r.shape[0],))
            scale = np.array([s * math.sqrt(max(1.0 - p * p, 1e-300)) for s, p in zip(sigma, rho)])
            e = r.copy()
            e[:, 1:] -= rho[:, None] * r[:, :-1]
            e[:, 0] /= sigma
            e[:, 1:] /= scale[:, None]
            if obs.fresh is not None:  # each block of a thinned record starts its own chain
                e[:, obs.fresh] = r[:, obs.fresh] / sigma[:, None]
            return e
        spread = np.array([math.sqrt(s**2 + obs.quantum**2 / 12.0)
                           for s in np.broadcast_to(sigma, (r.shape[0],))])
        return r / spread[:, None]

    def _samples(self) -> np.ndarray:
        """The samples as :data:`~escfit.balance.observation.waveform_compiled.SAMPLE` records (computed once)."""
        rec = self.__dict__.get("_samples_cache")
        if rec is None:
            from ..observation.waveform_compiled import SAMPLE

            rec = np.empty(self.sample_time.size, SAMPLE)
            rec["y"] = self.curves[0].y
            rec["dt"] = self.sample_time - self.observation.t_ref
            fresh = self.observation.fresh
            rec["fresh"] = fresh if fresh is not None else np.arange(rec.size) == 0
            self.__dict__["_samples_cache"] = rec
        return rec

    def _noise(self) -> tuple[int, float]:
        noise = self.__dict__.get("_noise_cache")
        if noise is None:
            self.__dict__["_noise_cache"] = noise = self._noise_code()
        return noise

    def _noise_code(self) -> tuple[int, float]:
        from ..observation.waveform_compiled import AR1, QUANTISED, WHITE

        obs = self.observation
        code = QUANTISED if obs.quantum > 0.0 else AR1 if obs.noise == "ar1" else WHITE
        return code, float(obs.quantum)
