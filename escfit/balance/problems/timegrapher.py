"""Fit problem on timegrapher recordings: amplitude readings and beat times.

The readings are modelled as the instrument makes them (see
:mod:`escfit.balance.observation.timegrapher`): the pulse duration through the true lift angle (a
nuisance parameter with a prior), the harmonic formula with the lift angle set on the
instrument, averaging over the window, rounding to the display resolution and rejection
outside 135-360 deg.  Beat times are passage times of the rest position.

Which amplitude readings are used
---------------------------------
Readings whose windows overlap share most of their beats and cannot be independent; a
per-beat CSV repeats the window ending at every beat.  The problem therefore keeps readings
whose windows lie inside the recorded beats and do not overlap (greedily from the first),
and says so in ``used_readings``.  tg's dump, written back to back, loses nothing.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Mapping

import numpy as np

from .. import BalanceScene
from ...core.errors import DataError, FitError
from ..observation.timegrapher import TimegrapherObservation, beat_events, window_readings
from ...analysis.recordings.timegrapher import TimegrapherRecording, beat_swings
from .curves import Curve
from .pulses import RecordingProblem

__all__ = ["TimegrapherFitProblem"]


class TimegrapherFitProblem(RecordingProblem):
    """Fit a balance scene to a timegrapher recording.

    The scene's ``[observation]`` table, if any, must say ``model = "timegrapher"``; keys
    ``sigma`` (rad, amplitude noise), ``lift_angle`` (rad, true lift angle; default free with
    prior ``normal(set, 2 deg)``), ``sigma_t`` (s, beat noise; fixed by default), ``t0`` (s,
    release instant; default the file's) and ``beats`` (``false`` to fit the amplitudes
    alone).

    Parameters
    ----------
    scene
        Balance scene (angle switching).
    data
        The recording (needs its release instant).
    solver, solver_options
        Any solver (default exact) and its options.

    Raises
    ------
    DataError
        No release instant, or a beat rate the scene's oscillator cannot produce.
    """

    reading_units = "deg (amplitude) and s (beats)"
    mixed_readings = True  # amplitudes and beat times: one covariance rescale, not one profiled scale

    def __init__(self, scene: BalanceScene, data: TimegrapherRecording, solver: str | None = None,
                 solver_options: dict | None = None):
        if not isinstance(data, TimegrapherRecording):
            raise FitError(f"TimegrapherFitProblem needs a TimegrapherRecording, got {type(data).__name__}",
                           getattr(data, "source", None))
        super().__init__(scene, data, solver, solver_options)
        self.beat_swing = beat_swings(data)  # refuses a recording without a release instant
        self.observation = TimegrapherObservation.from_table(scene.extra.get("observation"),
                                                             f"{scene.where} [observation]",
                                                             lift_set=data.lift_angle, release_s=data.release_s)
        self.notes = [n.strip() for n in str(data.meta.get("notes", "") or "").split(";") if n.strip()]
        from ...analysis.recordings.tg_applog import STEADY_STATE_WARNING, is_steady_state

        steady = is_steady_state(data.amp_deg, data.amp_time, resolution_deg=data.resolution_deg)
        self.data_warnings = [STEADY_STATE_WARNING] if steady else []
        if getattr(data, "format", "") == "tg-applog" and self.observation.use_beats:
            # an app log's row times are display updates, not heard beats: fit the amplitudes alone
            self.observation = replace(self.observation, use_beats=False)
            self.notes.append("app log: row times are display updates, not beats; amplitudes fitted alone")
        self._setup_params()
        self._check_rate()
        start, end = data.amp_window
        self.used_readings = self._independent(start, end)
        self._start, self._end = start[self.used_readings], end[self.used_readings]
        y = data.amp_deg[self.used_readings]
        last_beat = np.searchsorted(data.beat_time, self._end, side="right") - 1
        self.curves = [Curve("amplitude", math.nan, self.beat_swing[np.clip(last_beat, 0, None)], y)]
        if self.observation.use_beats:
            self.curves.append(Curve("beats", math.nan, self.beat_swing, data.beat_time))
        self.n_swings = int(self.beat_swing.max()) + 2
        self._lift_set_deg = math.degrees(data.lift_angle)

    def _independent(self, start: np.ndarray, end: np.ndarray) -> np.ndarray:
        t = self.data.beat_time
        inside = (start >= t[0]) & (end <= t[-1])
        keep: list[int] = []
        for i in np.flatnonzero(inside):
            if not keep or start[i] >= end[keep[-1]]:
                keep.append(int(i))
        if not keep:
            raise DataError(f"no amplitude reading has its whole {self.data.window:g} s window inside the recorded "
                            "beats", self.data.source)
        return np.array(keep, dtype=np.int64)

    def _check_rate(self) -> None:
        if "oscillator.omega0" not in self.params:
            return
        beat = float(np.median(np.diff(self.data.beat_time)))
        model = math.pi / self.params["oscillator.omega0"].value
        if abs(beat / model - 1.0) > 0.1:
            raise DataError(f"the recording beats every {1e3 * beat:.4g} ms ({3600 / beat:.0f} beats/hour) but the "
                            f"scene's omega0 = {self.params['oscillator.omega0'].value:g} rad/s beats every "
                            f"{1e3 * model:.4g} ms: another scene's data", self.data.source)

    # -- model -----------------------------------------------------------------------------
    def _predict(self, vals: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """Expected amplitude readings (deg) and model beat times (s since release)."""
        tr = self.trajectory(vals, self.n_swings)
        tz, pulse = beat_events(tr.dense, self.n_swings, vals["observation.lift_angle"])
        t0 = vals["observation.t0"]
        mu = self._lift_set_deg * window_readings(t0 + tz, pulse, self._start, self._end)
        beats = tz[self.beat_swing - 1]
        if self.observation.use_beats and not np.all(np.isfinite(beats)):
            raise FitError(f"the model balance stops before half swing {int(self.beat_swing.max())}, the last beat")
        return mu, beats

    def _sigma_deg(self, vals) -> float:
        return math.degrees(vals["observation.sigma"])

    def _pointwise(self, pred, vals) -> np.ndarray:
        mu, beats = pred
        d = self.data
        ll = self.observation.amp_loglike_pointwise(mu, self.curves[0].y, self._sigma_deg(vals), d.resolution_deg,
                                                    d.amp_range_deg, d.rejected_shown)
        if self.observation.use_beats:
            ll = np.concatenate([ll, self.observation.beat_loglike_pointwise(beats, self.curves[1].y, vals)])
        return ll

    def _residuals(self, pred, vals) -> np.ndarray:
        mu, beats = pred
        d = self.data
        r = self.observation.amp_residuals(mu, self.curves[0].y, self._sigma_deg(vals), d.resolution_deg,
                                           d.amp_range_deg)
        if self.observation.use_beats:
            # standardised by the scene's timing noise: least squares must not trade it for fit
            sigma_t = self._base["observation.sigma_t"]
            r = np.concatenate([r, (self.curves[1].y - vals["observation.t0"] - beats) / sigma_t])
        return r

    def _expected(self, pred, vals) -> np.ndarray:
        mu, beats = pred
        if self.observation.use_beats:
            return np.concatenate([mu, vals["observation.t0"] + beats])
        return mu
