"""Turning points of an oscillator recorded by its angular velocity (a gyroscope, a velocity pickup).

A zero of the angular velocity is a turning point of the angle, and the velocity's extrema lie
between them, where the oscillator passes its centre.  What a fit of the rate needs from the
record is what a fit of the angle needs (:mod:`escfit.analysis.recordings.turning_points`): where
the free decay starts (after the last hold, pull or push), where it ends in the noise, the
period, the release angle, and the sensor's zero (a gyro's bias) with its uncertainty.

Method
------
1. **The rate's own analysis** (:func:`~escfit.analysis.recordings.turning_points.prepare`): its
   period, smoothing, noise in rad/s, and the end of motion where the rate has sunk into that
   noise for a period (:func:`~escfit.analysis.recordings.noise_end.resting_tail`); a first
   bias estimate is the rate at rest there (else the median of the moving part).
2. **The angle's turning points** are the zeros of the rate less its bias.  They are found, with
   the record's hysteresis and the same motion finding as a recorded angle (a hold is a rate flat
   at zero, a hand's pull a hump before the free swing, a second push a swing that grows), on the
   running integral of the rate less the first bias estimate (where the smoothed rate rests within
   its noise of that bias, nothing is counted: a hold stays flat), cut at the end of motion: the
   extrema of that integral are the rate's zero crossings, and its excursion between two of them
   is the angle swept in that half swing (the release angle).  The integral serves this analysis
   only; the fit compares the model's theta'(t) with every rate sample
   (:mod:`escfit.balance.problems.waveform`).
3. **The bias** (the sensor's zero, rad/s) and its drift (rad/s^2) are measured from the rate's
   extrema after the reference, as a recorded angle's centre is from its turning points
   (:func:`~escfit.analysis.recordings.centre.measure_centre`): the midpoints of the two sides'
   envelopes.  A rate's bias is also what a drifting centre of the angle would leave, so one
   constant covers both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ...core.errors import DataError
from .centre import Centre, centre_estimates, measure_centre
from .extrema import alternating_extrema
from .noise_end import describe, sunk_end_before
from .series import TimeSeries
from .turning_points import TurningPoints, prepare, reduce_series, resting_tail
from .window import window_of

__all__ = ["RateAnalysis", "reduce_rate"]


@dataclass(frozen=True)
class RateAnalysis:
    """What a recorded angular velocity says about its oscillator.

    Attributes
    ----------
    turns : TurningPoints
        The angle's turning points (the rate's zeros), numbered from the reference at rest;
        angles in rad on the rate's running integral (zero arbitrary: use them about
        ``turns.offset``), ``stop_time`` where the rate sank into its noise.
    offset, offset_stderr : float
        The rate's zero (bias) at ``turns.release_time`` and its standard error, rad/s.
    offset_rate, offset_rate_stderr, offset_rate_measured : float
        Its drift, rad/s^2: kept (0 unless significant), the standard error, and as measured.
    noise : float
        Robust scale of the rate samples about a smoothing, rad/s.
    notes : list of str
        What was found, as plain sentences.
    """

    turns: TurningPoints
    offset: float
    offset_stderr: float
    offset_rate: float
    offset_rate_stderr: float
    offset_rate_measured: float
    noise: float
    notes: list

    @property
    def release_time(self) -> float:
        return self.turns.release_time


def reduce_rate(series: TimeSeries, *, user_window=None) -> RateAnalysis:
    """The analysis of a sampled angular velocity (see the module docstring).

    ``user_window``: the user's ``[recording]`` window, as for
    :func:`~escfit.analysis.recordings.turning_points.reduce_series` (the swept angle's reference).

    Raises
    ------
    DataError
        What the turning-point analysis refuses (no oscillation, too few samples per period,
        too few turning points above the noise, a swing that grows), in the rate's terms.
    """
    where = series.source
    t = np.asarray(series.time, float)
    v = np.asarray(series.theta, float)
    rec = prepare(t, v, None, 4, where, "angular_velocity")
    i_rest, rest = resting_tail(rec)
    sunk = None
    if user_window is None or user_window.stop is None:  # the user's stop wins
        # the rate may sink into its noise before it rests, if ever (a phone's gyroscope: a bias step later)
        sunk = sunk_end_before(rec.t, rec.x, rec.period, i_rest)
        i_rest = sunk.index if sunk is not None else i_rest
    moving = slice(0, i_rest)
    bias0 = rest if i_rest < t.size and sunk is None else _extrema_centre(rec, i_rest)
    # where the smoothed rate rests within its noise of the bias (a hold, the end), nothing moves:
    # counting only motion keeps a held oscillator's angle flat instead of a random walk of the noise
    at_rest = np.abs(rec.xs[moving] - bias0) <= rec.band
    angle = _running_integral(t[moving], np.where(at_rest, 0.0, v[moving] - bias0))
    # the integral of the rate's white noise wanders as a random walk, which the scatter about a
    # smoothing does not show: over a period it strays by noise * sqrt(dt * period)
    wander = 0.5 * rec.sigma * math.sqrt(rec.dt * rec.period)
    try:
        first = reduce_series(_path(series, t[moving], angle), strict=False, min_noise=wander, user_window=user_window)
        # again about the centre found, so that the angles in the notes are the swing's (the
        # offset only: removing a drift too would tilt a hold)
        turns = reduce_series(_path(series, t[moving], angle - first.offset), strict=False, min_noise=wander,
                              user_window=user_window)
    except DataError as exc:
        raise DataError(f"{getattr(exc, 'message', exc)} (the angle's turning points are the zeros of the "
                        "angular velocity, found on its running integral)", exc.where) from None
    stop = float(t[i_rest]) if i_rest < t.size else math.nan
    floor = math.nan
    warnings = list(turns.warnings)
    if sunk is not None:
        said, warning = describe(sunk, lambda value: f"{value:.2g} rad/s", window_of(series).origin)
        warnings += [warning] if warning else []
        floor = sunk.floor
    elif math.isfinite(turns.noise_floor) and not math.isfinite(stop):
        # the rate's swing stands above its noise to the end, but the swept angle's sinks into
        # its own (the integral's random walk): motion ends there
        stop, floor = float(turns.stop_time), float(turns.noise_floor)
    turns = replace(turns, stop_time=stop, rest_theta=math.nan, notes=list(turns.notes), warnings=warnings,
                    noise_floor=floor)
    centre = _bias(rec, turns.release_time, i_rest, bias0)
    at_ref = centre.offset  # measure_centre counts from the first extremum; the drift is carried to the reference
    notes = [f"angular velocity: the angle's turning points are the rate's zeros, found on its running integral (for "
             f"this analysis only: the fit reads every rate sample); the rate's zero (the sensor's bias), measured "
             f"from its extrema: {at_ref:+.4g} +- {centre.offset_stderr:.2g} rad/s"]
    if sunk is not None:
        notes.append(said)
    elif math.isfinite(stop):
        notes.append(f"motion stopped at t = {stop:.4g} s (the rate stays within its noise, "
                     f"{rec.sigma:.2g} rad/s, for a period and more)")
    notes += [n for n in rec.notes if n not in turns.notes]
    if centre.note:
        notes.append(centre.note.replace("the centre", "the rate's zero"))
    # the integral's own end of motion is superseded by the rate's, its drifting centre by the rate's zero
    notes += [n for n in turns.notes
              if not n.startswith(("motion stopped at", "the swing faded below", "the centre drifts"))]
    return RateAnalysis(turns, at_ref, centre.offset_stderr, centre.rate, centre.rate_stderr, centre.measured_rate,
                        rec.sigma, notes)


def _extrema_centre(rec, stop: int) -> float:
    """A first estimate of the rate's zero: the median midpoint of its smoothed extrema (the median of
    the samples when it has fewer than three).  The samples' own median or mean is off by a good part
    of the swing when the record holds a few periods of a decay."""
    ext = alternating_extrema(rec.xs, rec.step, 0, stop)
    if len(ext) < 3:
        return float(np.median(rec.x[:stop]))
    return float(np.median(centre_estimates(np.array([rec.xs[a] for a, _, _ in ext]))))


def _path(series: TimeSeries, t: np.ndarray, angle: np.ndarray) -> TimeSeries:
    """The running integral as an angle series (the analysis' input), with the record's release and name."""
    return TimeSeries(t, angle, series.release_s, series.source, series.sha256, dict(series.meta), "angle",
                      series.window)


def _running_integral(t: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The trapezoid running integral of ``v`` over ``t``, 0 at the first sample."""
    out = np.zeros(t.size)
    out[1:] = np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))
    return out


def _bias(rec, t_ref: float, i_rest: int, fallback: float) -> Centre:
    """The rate's zero from its extrema after ``t_ref`` (up to the end of motion), carried back to ``t_ref``."""
    i0 = int(np.searchsorted(rec.t, t_ref))
    times, values = [], []
    for a, b, is_max in alternating_extrema(rec.xs, rec.step, i0, i_rest):
        got = rec.refine(a, b, is_max=is_max)
        if got is not None:
            times.append(got[0])
            values.append(got[1])
    tail = _resting_level(rec, i_rest)
    if len(values) < 3:  # too few swings to measure it: the level the rate rests at, within its noise
        return tail or Centre(fallback, rec.sigma if rec.sigma > 0 else abs(fallback) + 1e-9)
    centre = measure_centre(np.array(times), np.array(values), rec.band, "angular_velocity")
    centre = replace(centre, offset=centre.offset + centre.rate * (t_ref - times[0]))
    if tail is None or centre.rate != 0.0:  # a drifting zero: the level at rest belongs to the record's end
        return centre
    # two measurements of one constant: weighted by their variances
    w1, w2 = centre.offset_stderr ** -2, tail.offset_stderr ** -2
    return replace(centre, offset=(w1 * centre.offset + w2 * tail.offset) / (w1 + w2), offset_stderr=(w1 + w2) ** -0.5)


def _resting_level(rec, i_rest: int) -> Centre | None:
    """The rate at rest after the end of motion and its standard error (``None`` without such a tail).

    The error comes from the scatter of means over blocks of a tenth of a period, so noise that
    is correlated from sample to sample is not counted as independent.
    """
    t, v = rec.t[i_rest:], rec.x[i_rest:]
    if t.size < 2:
        return None
    blocks = np.floor((t - t[0]) / (0.1 * rec.period)).astype(int)
    means = np.array([v[blocks == b].mean() for b in np.unique(blocks)])
    if means.size < 8:
        return None
    return Centre(float(np.mean(means)), float(np.std(means, ddof=1) / math.sqrt(means.size)))
