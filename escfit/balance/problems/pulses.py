"""Fit problems on passage times: photo-cell pulse trains (and the shared plumbing).

:class:`RecordingProblem` offers the interface :func:`~escfit.inference.lsq.least_squares`,
:func:`~escfit.inference.mcmc.run_emcee` and the results writer use (``names``, ``priors``,
``bounds``, ``initial``, ``values``, ``log_prob``, ``residuals``, ``loglike_pointwise``,
``expected``, ``observed``, ``n_data``, ``curves``, ``failures`` ...) for recordings whose
readings are not turning-point amplitudes: the data flow is parameter vector -> values ->
balance system -> solver *with its dense solution* -> predicted readings -> observation
model -> log-likelihood.  Any solver serves (the exact one by default, dop853 where the scene
has a smooth torque): readings come from the dense solution's crossings and samples.  A failed solve or a non-finite number becomes ``-inf`` (or large
residuals) with the reason counted in ``failures``.

Least squares (:mod:`escfit.inference.lsq`) adds a residual per Gaussian prior, so a
nuisance the data alone cannot pin (a timegrapher's true lift angle) is held by its prior
as it is in the posterior.

:class:`PulseFitProblem` fits a :class:`~escfit.analysis.recordings.pulses.PulseTrain`: every pulse is
a notch at a known angle crossed at a measured time (see
:mod:`escfit.balance.observation.passage_times`).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections import Counter
from typing import Mapping

import numpy as np

from .. import BalanceScene
from ..solvers import check_scene, default_solver, solve_system
from ..trajectory import Trajectory
from ...core.errors import DataError, EscfitError, FitError
from ..observation.passage_times import PassageTimeObservation
from ...core.params import ParamSet
from ...analysis.recordings.pulses import PulseTrain, assign_pulses
from ...likelihood.freeparams import FreeParameters
from .common import BalanceProblem
from .curves import FAIL_RESIDUAL, Curve

__all__ = ["RecordingProblem", "PulseFitProblem"]


class RecordingProblem(FreeParameters, BalanceProblem, ABC):
    """Parameter handling, solving and failure accounting shared by recording fits.

    Subclasses set ``self.observation`` and ``self.curves`` and implement
    :meth:`_predict`, :meth:`_pointwise`, :meth:`_residuals` and :meth:`_expected`.

    Parameters
    ----------
    scene
        Balance scene with angle switching; its ``vary = true`` parameters are estimated.
    data
        The recording.
    solver, solver_options
        Any solver and its options (checked against the scene here, before any work).
    """

    reading_units = "s"

    def __init__(self, scene: BalanceScene, data, solver: str | None = None, solver_options: dict | None = None):
        if getattr(scene, "model", None) != "balance":
            raise FitError(f"fitting recordings needs a balance scene, got model {getattr(scene, 'model', None)!r}",
                           getattr(scene, "where", None))
        if scene.switching != "angle":
            raise FitError("passage times need angle switching (a physical escapement): with phase switching the "
                           "balance is not tied to angles", scene.where)
        options = dict(solver_options or {})
        solver = solver or default_solver(scene)
        check_scene(scene, solver, {**options, "dense": True})
        self.scene, self.data, self.solver, self.solver_options = scene, data, solver, options
        self.failures: Counter = Counter()

    def _setup_params(self) -> None:
        params = ParamSet(dict(self.scene.params.params))
        for p in self.observation.params:
            params.add(p)
        self._set_free(params, self.scene.where)

    # -- forward model -----------------------------------------------------------------------
    def trajectory(self, vals: Mapping[str, float], n_swings: int) -> Trajectory:
        """The solution of ``n_swings`` half swings with its dense solution.

        Raises
        ------
        EscfitError
            When the solver refuses the parameters, runs out of its budget or fails.
        """
        tr = solve_system(self.scene.system(vals), n_swings, self.solver, dense=True, **self.solver_options)
        if tr.status in ("max_segments", "failed"):
            raise FitError("solver ran out of segments" if tr.status == "max_segments" else
                           f"solver failed: {tr.message}")
        return tr

    def predict(self, vals: Mapping[str, float]):
        """The model's side of every reading (see the subclass)."""
        return self._predict(vals)

    # -- likelihood --------------------------------------------------------------------------
    def log_likelihood(self, vals: Mapping[str, float]) -> float:
        try:
            pred = self._predict(vals)
        except (EscfitError, ValueError, ArithmeticError) as exc:
            self.failures[f"solve failed: {exc}"[:120]] += 1
            return -math.inf
        ll = float(np.sum(self._pointwise(pred, vals)))
        if not math.isfinite(ll):
            self.failures["non-finite likelihood"] += 1
            return -math.inf
        return ll

    def residuals(self, vals: Mapping[str, float]) -> np.ndarray:
        """Standardised residuals of all readings (large values on failure)."""
        try:
            pred = self._predict(vals)
            r = self._residuals(pred, vals)
        except (EscfitError, ValueError, ArithmeticError) as exc:
            self.failures[f"solve failed: {exc}"[:120]] += 1
            return np.full(self.n_data, FAIL_RESIDUAL)
        return np.where(np.isfinite(r), r, FAIL_RESIDUAL)

    def loglike_pointwise(self, vals: Mapping[str, float]) -> np.ndarray:
        """Log-likelihood of each reading (for PSIS-LOO); raises when the solve fails."""
        return self._pointwise(self._predict(vals), vals)

    def expected(self, vals: Mapping[str, float]) -> np.ndarray:
        """Noise-free expected readings of all data points, concatenated."""
        return self._expected(self._predict(vals), vals)

    def noise_loglike(self, vals: Mapping[str, float]):
        """The summed log-likelihood as a function of the noise parameters alone (a mapping of
        ``observation.sigma``, ``observation.rho``, ...), the model run once at ``vals``: the
        noise parameters change the observation model, never the prediction."""
        pred = self._predict(vals)
        return lambda noise: float(np.sum(self._pointwise(pred, {**vals, **noise})))

    # -- what each recording defines ------------------------------------------------------------
    @abstractmethod
    def _predict(self, vals):
        """The model's side of the readings for parameter values ``vals``."""

    @abstractmethod
    def _pointwise(self, pred, vals) -> np.ndarray:
        """Log-likelihood of each reading."""

    @abstractmethod
    def _residuals(self, pred, vals) -> np.ndarray:
        """Standardised residual of each reading."""

    @abstractmethod
    def _expected(self, pred, vals) -> np.ndarray:
        """Noise-free expected value of each reading."""


class PulseFitProblem(RecordingProblem):
    """Fit a balance scene to the passage times of a photo-cell pulse train.

    Each pulse used (see :func:`~escfit.analysis.recordings.pulses.assign_pulses`) is the crossing of
    notch ``tooth * notch`` in the swing frame of its half swing, observed at its time with
    Gaussian timing noise ``observation.sigma`` (s).  The scene's ``[observation]`` table, if
    any, must say ``model = "passage_times"`` (keys ``sigma``, ``t0``, ``offset``); ``t0``
    defaults to the file's ``release_s`` (0 when it has none) and is fixed unless freed.

    Parameters
    ----------
    scene
        Balance scene (angle switching).
    data
        The pulse train.
    solver, solver_options
        Any solver (default exact) and its options.

    Raises
    ------
    DataError
        When the train's release count contradicts the scene's (fixed) release angle.
    """

    reading_units = "s"

    def __init__(self, scene: BalanceScene, data: PulseTrain, solver: str | None = None,
                 solver_options: dict | None = None):
        if not isinstance(data, PulseTrain):
            raise FitError(f"PulseFitProblem needs a PulseTrain, got {type(data).__name__}",
                           getattr(data, "source", None))
        super().__init__(scene, data, solver, solver_options)
        release = data.release_s if math.isfinite(data.release_s) else 0.0
        self.observation = PassageTimeObservation.from_table(scene.extra.get("observation"),
                                                             f"{scene.where} [observation]", release_s=release)
        self._setup_params()
        self.assignment = a = assign_pulses(data)
        self._check_release(a.counts[0])
        self.notes = self._unused_tail(data, a)
        self.notch = data.notch
        self.curves = [Curve("pulses", math.nan, a.swing, data.time[a.index])]
        self._x = a.tooth * data.notch
        self.n_swings = int(a.swing.max())

    @staticmethod
    def _unused_tail(data: PulseTrain, a) -> list[str]:
        """Say which pulses after the last zero pulse (an unfinished half swing) are not fitted.

        Refuses a tail that reaches far beyond the fitted pulses (more than the whole fitted
        record again): a stray time stamp, not the end of a swing.
        """
        last = int(a.index.max())
        tail = data.time[last + 1:]
        if not tail.size:
            return []
        used = data.time[last] - data.time[0]
        if tail[-1] - data.time[last] > max(used, 1e-9):
            raise FitError(f"pulse at {tail[-1]:.6g} s comes {tail[-1] - data.time[last]:.3g} s after the last zero "
                           f"pulse, longer than the whole fitted record ({used:.3g} s): a stray time stamp? "
                           "check the file's last rows", data.where(last + tail.size))
        return [f"{tail.size} notch pulse(s) after the last zero pulse (an unfinished half swing, up to "
                f"{tail[-1]:.6g} s) are not fitted"]

    def _check_release(self, n0: int) -> None:
        p = self.params["oscillator.theta0"]
        if p.vary:
            return
        offset = self.params["observation.offset"]
        if offset.vary:
            return
        implied = math.floor(abs(p.value - offset.value) / self.data.notch + 1e-9)
        if implied != n0:
            lo, hi = n0 * self.data.notch, (n0 + 1) * self.data.notch
            raise DataError(f"the train has {n0} notch pulses before the first zero pulse (a release between "
                            f"{lo:.4g} and {hi:.4g} rad) but the scene releases the balance at theta0 = {p.value:.4g} "
                            f"rad ({implied} notches): another scene's data, or a chart started after the release",
                            self.data.source)

    def _predict(self, vals: Mapping[str, float]) -> np.ndarray:
        """Model passage times since release (s) of the used pulses."""
        tr = self.trajectory(vals, self.n_swings)
        if tr.amplitude.size < self.n_swings:
            raise FitError(f"the model balance stops after {tr.amplitude.size} half swings; the pulses run to half "
                           f"swing {self.n_swings}")
        t = tr.dense.crossings(self.assignment.swing, self._x, vals["observation.offset"])
        if not np.all(np.isfinite(t)):
            raise FitError("a notch the data crossed is only approached asymptotically by the model")
        return t

    def _pointwise(self, pred, vals):
        return self.observation.loglike_pointwise(pred, self.curves[0].y, vals)

    def _residuals(self, pred, vals):
        return self.observation.residuals(pred, self.curves[0].y, vals)

    def _expected(self, pred, vals):
        return self.observation.expected(pred, vals)
