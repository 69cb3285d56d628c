"""Turning points of a recorded free decay, numbered from a reference at rest.

:func:`reduce_series` is the one entry point: it takes a
:class:`~escfit.analysis.recordings.timeseries.TimeSeries` and returns :class:`TurningPoints`.

Steps
-----
1. **Period** from the periodogram peak of the detrended series
   (:func:`~escfit.analysis.recordings.extrema.spectral_period`): robust to noise, quantisation, a
   drifting centre and a resting tail.  Below :data:`MIN_SAMPLES_PER_PERIOD` samples per
   period the turning points are placed by sinusoid arcs, with a note saying what that costs;
   below :data:`COARSE_SAMPLES_PER_PERIOD` the record is refused.
2. **Resolution**: the noise scale about a smoothing (a tenth of a period) and the
   quantisation step of an encoder; they set the hysteresis of the extremum search and the
   band within which the balance counts as at rest.
3. **Resting tail**: where the smoothed angle stays within that band of its final value for
   at least a period and the swing measured over whole periods
   (:func:`~escfit.analysis.recordings.extrema.local_amplitude`) has sunk into the noise,
   motion has stopped; the rest is cut and reported (``stop_time``, ``rest_theta``).  A
   record that never rests (a sensor's bias that steps or wanders) is cut where the swing has
   sunk to a few times its noise floor (:mod:`~escfit.analysis.recordings.noise_end`:
   ``stop_time`` and ``noise_floor``), unless the user set ``[recording] stop``.  With
   dry friction the balance stops at a turning point short of the centre, so when the last
   half swing runs into the rest that stop is the last turning point.
4. **Reference** (``release_time``, ``release_theta``, the instant the model is released at
   rest): where the user set it (``[recording] release`` or ``start``, passed as ``user_window``:
   :mod:`~escfit.analysis.recordings.given_start`); else the series' ``release_s`` when given; else the start of the record's **last** free
   decay (:mod:`escfit.analysis.recordings.motion`): after the last push, pull, hold or drive,
   the release from a hold (the angle flat for a tenth of a period or more, then moving
   freely: the release is where motion starts and its angle the held one) or a turning point
   (a turning point at the first sample, the first one of a record that starts mid-swing, or
   the one a hand's pull ends in: releasing the model at rest at a turning point is exact, the
   velocity being zero there).  Either sign.  At least three turning points (the reference
   included) must stand above the noise.
5. **Extrema** by hysteresis on the smoothed series
   (:func:`~escfit.analysis.recordings.extrema.alternating_extrema`): maxima and minima alternate and
   a plateau of equal samples is one extremum at its centre.  Turning points are numbered by
   **counting** them: swing ``k`` ends at the ``k``-th turning point after the reference.
   Times serve as a check only: every interval between consecutive turning points must lie
   within 0.6 to 1.6 local half periods, else an extremum is missing (or spurious) and the
   record is refused (``strict=True``) or the result carries a note.
6. **Values and times** by the local kinked polynomial fit
   (:func:`~escfit.analysis.recordings.extrema.kinked_vertex`) to the raw samples within
   ``+-window*period``: the velocity vanishes at the turn but the curvature jumps there as
   Coulomb friction reverses.  Unless given, the window is a fifth of a period when the noise
   or the quantisation step exceeds 2e-4 of the amplitude, or an eighth would hold fewer
   than 6 samples a side; else an eighth.  A quartic over an eighth of a period is biased by
   some 1e-6 of the amplitude, over a fifth by some 5e-5, below such noise, while the
   wider window averages more of it (on an encoder's staircase the narrow one can misplace
   a turn by a sample).  A quarter period would reach the escapement near the centre.  When
   the resolution exceeds 2e-3 of the amplitude, only the curvature is kinked (the cubic and
   quartic terms are common to both sides): fewer parameters, less scatter, and a bias (up
   to some 2e-4 of the amplitude) well below that resolution.
7. **Centre** and its drift, with their standard errors
   (:func:`~escfit.analysis.recordings.centre.measure_centre`): the centre is
   ``offset + offset_rate*(t - release_time)``.

Sign convention: angles are the series' own (signed, the sensor's zero offset still in
them); ``release_theta - offset`` is the signed release angle about the centre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ...core.errors import DataError
from .centre import measure_centre
from .extrema import (alternating_extrema, drop_wiggles, extrema_period, power_near, resolution, smooth,
                      smoothing_share, smoothing_window, spectral_period, vertex_at)
from ..amplitude_trend import sustained
from .motion import INTERVAL_RANGE, Turn, faded_end, reference
from .given_start import user_reference
from .modes import MIN_PROMINENCE, check_other_modes
from .noise_end import noise_tail, resting_tail
from .sampled import MIN_SAMPLES_PER_PERIOD, SampledRecord
from .series import TimeSeries, quantity_words, show_value
from .swing_numbers import GAP_INTERVALS, period_of, swing_numbers
from .window import window_of

__all__ = ["TurningPoints", "reduce_series", "turning_points", "period_of", "MIN_SAMPLES_PER_PERIOD", "MIN_TURNS"]

COARSE_SAMPLES_PER_PERIOD = 8  # from here to 16: sinusoid arcs through the few samples at each turn, with a note
MIN_TURNS = 3  # turning points (the reference included) a decay needs: one whole period


@dataclass(frozen=True)
class TurningPoints:
    """Turning points of a decay, numbered from the reference at rest.

    Attributes
    ----------
    swing : ndarray of int
        Half swing each one ends: 1, 2, ... counted from the reference.
    time : ndarray
        Time of each, s (the series' clock).
    theta : ndarray
        Signed angle of each, rad, the zero offset not removed.
    period : float
        Mean period, s: twice the slope of the turning times after the reference against their
        number, weighted by the squared amplitude (:func:`period_of`).
    offset : float
        Centre of oscillation at ``release_time``, rad.
    offset_rate : float
        Linear drift of the centre, rad/s (0 unless significant).
    release_time, release_theta : float
        Reference instant (s) and signed angle (rad, offset not removed) at which the
        balance is at rest: the release, or the first turning point of a record that starts
        mid-swing.
    stop_time, rest_theta : float
        Where motion stopped (s) and the angle it rests at (rad, offset not removed);
        ``nan`` when the record ends in motion.
    notes : list of str
        What the analysis found or assumed, as plain sentences.
    period_stderr : float
        Standard error of ``period``, s.
    offset_stderr, offset_rate_stderr : float
        Standard errors of the centre and of the measured drift (rad, rad/s); the drift's
        is given even when the drift is not significant (``offset_rate`` 0).
    offset_rate_measured : float
        The drift as measured, significant or not, rad/s.
    noise : float
        Robust scale of the samples about a smoothing, rad (the reading noise).
    sustained_from : float
        Instant (s) from which the swing stops decaying while a free decay could not (a
        drive or an escapement keeps it going); ``nan`` when it decays to the end
        (:func:`escfit.analysis.amplitude_trend.sustained`).
    sustained_why : str
        The evidence for ``sustained_from`` with its numbers (empty when it is ``nan``).
    warnings : list of str
        What the user must know before trusting a fit (a large part of the record left out).
    steps : tuple of (float, float, str)
        Offset steps of the centre removed from the samples: the time of the first sample
        moved (s), the jump (the samples' unit) and the note; apply them to the series with
        :func:`remove_steps` before comparing a model with the samples.
    origin : float
        The file's first sample on the series' clock, s: the zero of the times in ``notes``
        (and of ``[recording] start``, ``stop``, ``release``).
    noise_floor : float
        The noise floor the swing sank into where the record was cut before it came to rest
        (:mod:`~escfit.analysis.recordings.noise_end`; the unit of the samples it was measured
        on: for a rate, the rate's or its running integral's), ``nan`` otherwise: ``stop_time``
        is then that end of motion.
    dropped : tuple of (float, float, str)
        Runs of samples left out as a tracking glitch (:mod:`escfit.analysis.glitches`): first
        and last time (s, the series' clock) and the note; :func:`drop_samples` leaves them out
        of the series too.
    pushed_after : bool
        ``stop_time`` ends the free decay chosen before a push (the record goes on, pushed
        again): :func:`escfit.analysis.recordings.motion.find_start` chose the longest free
        stretch between pushes.
    other_modes : tuple of (float, float)
        Weak oscillations besides the swing, ``(period s, share of the swing's power)``
        (:func:`escfit.analysis.recordings.modes.check_other_modes`); the fit follows the swing.
    """

    swing: np.ndarray
    time: np.ndarray
    theta: np.ndarray
    period: float
    offset: float
    offset_rate: float = 0.0
    release_time: float = math.nan
    release_theta: float = math.nan
    stop_time: float = math.nan
    rest_theta: float = math.nan
    notes: list = field(default_factory=list)
    period_stderr: float = math.nan
    offset_stderr: float = math.nan
    offset_rate_stderr: float = math.nan
    offset_rate_measured: float = 0.0
    noise: float = math.nan
    sustained_from: float = math.nan
    sustained_why: str = ""
    warnings: list = field(default_factory=list)
    steps: tuple = ()
    origin: float = 0.0
    dropped: tuple = ()
    noise_floor: float = math.nan
    pushed_after: bool = False
    other_modes: tuple = ()

    def after_first(self, t: float) -> float:
        """``t`` (s, the series' clock) as a time after the file's first sample, as notes show times."""
        return t - self.origin

    @property
    def count(self) -> int:
        """Turning points after the reference."""
        return int(self.swing.size)

    def centre(self, t: np.ndarray | float) -> np.ndarray | float:
        """Centre of oscillation (rad) at times ``t`` (s)."""
        return self.offset + self.offset_rate * (np.asarray(t) - self.release_time)


def reduce_series(series: TimeSeries, *, window: float | None = None, degree: int = 4,
                  strict: bool = True, min_noise: float = 0.0, user_window=None) -> TurningPoints:
    """Turning points of a sampled free decay (see the module docstring for the method).

    Parameters
    ----------
    series
        The samples; an explicit ``series.release_s`` fixes the reference instant.
    window
        Half width of the local vertex fits, in periods (widened to at least 4.5 samples);
        ``None``: 1/8 or 1/5 by the record's resolution (module docstring, step 6).
    degree
        Degree of the polynomial each side of a turning point (2 to 6).
    strict
        Refuse a record whose turning points are irregularly spaced (a missed or spurious
        extremum); with ``False`` the result carries a note instead.
    min_noise
        A floor for the noise scale the rest band and the hysteresis are set from (rad): for a
        series whose slow wander the scatter about a smoothing does not show (the running
        integral of a rate, :mod:`escfit.analysis.recordings.rate`).
    user_window
        The user's ``[recording]`` window on the series' clock
        (:class:`~escfit.analysis.recordings.window.RecordWindow`, usually ``series.window``): a
        ``release`` or ``start`` in it fixes where the free decay starts, over the series' own
        ``release_s`` and the automatic search (:mod:`~escfit.analysis.recordings.given_start`).

    Returns
    -------
    TurningPoints

    Raises
    ------
    DataError
        Not a free decay: no oscillation, too few samples per period (the message gives the
        rate needed), a growing amplitude, wrapped angles, too few turning points, or
        (``strict``) irregularly spaced turning points.
    """
    try:
        first = _reduce(series, window, degree, strict, min_noise, user_window, find_steps=True)
    except DataError:  # a glitch's spurious turning points break the strict count: look for one first
        if not strict:
            raise
        dropped = _glitches(series, _reduce(series, window, degree, False, min_noise, user_window, find_steps=False))
        if not dropped:
            raise
        first = _reduce(series, window, degree, False, min_noise, user_window, find_steps=False)
    dropped = _glitches(series, first)
    if dropped:  # a tracker's jump of a few frames: the same analysis without those samples
        series = drop_samples(series, dropped)
        first = _reduce(series, window, degree, strict, min_noise, user_window, find_steps=True)
        first = replace(first, notes=[note for *_, note in dropped] + first.notes, dropped=dropped)
    if not first.steps:
        return first
    # the centre jumped (a moved origin): the same analysis of the samples with the jumps taken back
    fixed = replace(series, theta=remove_steps(series.time, series.theta, first.steps))
    found = _reduce(fixed, window, degree, strict, min_noise, user_window, find_steps=False)
    return replace(found, notes=[note for *_, note in first.steps] + found.notes, steps=first.steps,
                   dropped=first.dropped)


def _glitches(series: TimeSeries, tp: TurningPoints) -> tuple:
    """``(first time, last time, note)`` of each run of samples off the swing (a tracking glitch)."""
    from ...analysis.glitches import find_glitches

    t, x = np.asarray(series.time, float), np.asarray(series.theta, float)
    if t.size < 20 or not math.isfinite(tp.period):
        return ()
    xs = smooth(x, tp.period / float(np.median(np.diff(t))))
    out = []
    for g in find_glitches(t, x, tp.period, xs):
        n = g.last - g.first + 1
        out.append((float(t[g.first]), float(t[g.last]),
                    f"{n} sample(s) at t = {t[g.first] - tp.origin:.4g} s lie {show_value(abs(g.size), series.quantity, 2)} "
                    "off the swing the samples around them follow (a tracking glitch): left out"))
    return tuple(out)


def drop_samples(series: TimeSeries, dropped) -> TimeSeries:
    """The series without the samples of each ``(first time, last time, ...)`` run."""
    t = np.asarray(series.time, float)
    keep = np.ones(t.size, bool)
    for first, last, *_ in dropped:
        keep &= ~((t >= first) & (t <= last))
    return replace(series, time=t[keep], theta=np.asarray(series.theta, float)[keep])


def _reduce(series: TimeSeries, window: float | None, degree: int, strict: bool, min_noise: float, user_window, *,
            find_steps: bool) -> TurningPoints:
    """:func:`reduce_series`; with ``find_steps`` False no offset step is looked for."""
    where = series.source
    if not 2 <= degree <= 6:
        raise DataError(f"degree must be 2 to 6, got {degree!r}", where)
    # the analysis, and so its notes, count time from the file's first sample: shifted back at the end
    origin = window_of(series).origin
    t = np.asarray(series.time, dtype=float) - origin
    x = np.asarray(series.theta, dtype=float)
    rec = prepare(t, x, window, degree, where, series.quantity, min_noise)
    rec.find_steps = find_steps
    rec.moving_at_start = "drive_off" in series.meta and not (user_window is not None and user_window.given)
    if origin != 0.0:
        rec.notes.insert(0, f"times in these notes are counted from the record's first sample (t = 0 s there, "
                            f"{origin:.10g} s on the file's clock; the fitted observation.t_release is on the "
                            "file's clock)")
    i_rest, rest_theta = resting_tail(rec)
    sunk = None
    if user_window is None or user_window.stop is None:  # the user's stop wins
        rec, sunk = noise_tail(rec, i_rest)
        if sunk is not None:  # sunk into the noise before any rest: motion ends there
            t, x = rec.t, rec.x
            i_rest, rest_theta = t.size, math.nan
    if i_rest < t.size:
        period, prominence = _working_period(t[:i_rest], x[:i_rest], min_cycles=1.5)
        if math.isfinite(period) and prominence > MIN_PROMINENCE:
            rec.period = period
            rec.xs = smooth(x, period / rec.dt)
    t_end = t[i_rest] if i_rest < t.size else math.inf
    given = user_window is not None and user_window.given
    if math.isfinite(series.release_s) and not given:
        t_ref, theta_ref, cands = _given_release(rec, series.release_s - origin)
        turns = _refine_all(rec, cands, t_end)
    else:
        cands = drop_wiggles(rec.notes, alternating_extrema(rec.xs, rec.step, 0), rec.t, rec.xs, rec.period)
        turns = _refine_all(rec, cands, t_end)
        if given:  # the user's start or release wins over the search for the free decay
            t_ref, theta_ref, turns = user_reference(rec, turns, user_window.shifted(-origin))
        else:
            t_ref, theta_ref, turns = reference(rec, turns)
    times = [u.time for u in turns]
    values = [u.value for u in turns]
    stop_time = math.nan
    cut = math.isfinite(rec.cut_end)  # a push after the free decay chosen: it ends at its last turning point
    if cut:
        stop_time, rest_theta = rec.cut_end, math.nan
    elif i_rest < t.size:
        stop_time = _final_turn(rec, i_rest, rest_theta, t_ref, theta_ref, times, values)
    all_t = np.r_[t_ref, times]
    all_v = np.r_[theta_ref, values]
    keep = faded_end(rec, all_t, all_v)
    if keep < all_t.size:
        all_t, all_v = all_t[:keep], all_v[:keep]
        times, values = times[:keep - 1], values[:keep - 1]
        # the turning points of the noise are gone; the motion still ended where the record rests
        stop_time = float(t[i_rest]) if i_rest < t.size and not cut else stop_time
    if sunk is not None and not cut:
        stop_time = sunk.time
    if all_t.size < MIN_TURNS:
        raise DataError(f"only {all_t.size} turning point(s) from the reference at t = {t_ref:.4g} s on stand above "
                        f"the noise ({rec.show(rec.band, 2)}); a decay needs at least {MIN_TURNS} (one whole "
                        "period)", where)
    ratio = _local_ratios(np.diff(all_t))[0] if all_t.size > 1 else np.zeros(0)
    numbers = swing_numbers(rec.t, rec.dt, all_t, all_v, ratio, INTERVAL_RANGE[1])
    _check_intervals(rec, all_t, all_v, strict, numbers)
    centre = measure_centre(all_t, all_v, rec.band, rec.quantity)
    if centre.note:
        rec.notes.append(centre.note)
    # the reference is left out: a release from a hold or a hand is not a free turning point on
    # its left, and a stop is none on its right
    n_moving = all_t.size - 1 if math.isfinite(stop_time) and stop_time == all_t[-1] else all_t.size
    amps = all_v - centre.offset - centre.rate * (all_t - t_ref)
    period, period_se = period_of(all_t[1:n_moving], amps[1:n_moving], numbers[1:n_moving]) if n_moving > 3 \
        else period_of(all_t[:n_moving], amps[:n_moving], numbers[:n_moving])
    if math.isfinite(stop_time) and sunk is None and not cut:
        level = centre.offset + centre.rate * (stop_time - t_ref)
        rec.notes.append(f"motion stopped at t = {stop_time:.4g} s (resting {rec.show(rest_theta - level, signed=True)} "
                         "from the centre)")
    kept = sustained(all_t[:n_moving], all_v[:n_moving], show=lambda v: rec.show(v, 3))
    held_from, why = (kept.time, kept.sentence) if kept is not None else (math.nan, "")
    if kept is not None:
        rec.notes.append(f"the swing no longer decays as a free oscillator's would (it keeps its amplitude): {why}")
    swing = numbers[1:len(times) + 1].astype(np.int64)
    return TurningPoints(swing, np.array(times, dtype=float) + origin, np.array(values, dtype=float), float(period),
                         float(centre.offset), float(centre.rate), float(t_ref) + origin, float(theta_ref),
                         float(stop_time) + origin, float(rest_theta) if math.isfinite(stop_time) and not cut else math.nan,
                         rec.notes, period_stderr=period_se, offset_stderr=centre.offset_stderr,
                         offset_rate_stderr=centre.rate_stderr, offset_rate_measured=centre.measured_rate,
                         noise=rec.sigma, sustained_from=held_from + origin, sustained_why=why, origin=origin,
                         noise_floor=sunk.floor if sunk is not None else math.nan,
                         warnings=rec.warnings, steps=tuple((at + origin, size, note) for at, size, note in rec.steps),
                         pushed_after=cut, other_modes=rec.other_modes)


def remove_steps(time: np.ndarray, values: np.ndarray, steps) -> np.ndarray:
    """``values`` with each offset step ``(t_jump, size)`` taken back from ``t_jump`` on."""
    out = np.asarray(values, float).copy()
    for t_jump, size, *_ in steps:
        out[np.asarray(time) >= t_jump] -= size
    return out


def _refine_all(rec: "SampledRecord", cands: list, t_end: float) -> list[Turn]:
    """The candidates before ``t_end`` refined on the raw samples; stops at one too close to the end."""
    t = rec.t
    late = [c for c in cands if t[c[0]] > t_end]
    if late:
        rec.notes.append(f"{len(late)} extrema after motion stopped (disturbances) left out")
    # the last sample before a gap of the samples a quarter period long and the first after it are
    # extrema of the indices, not turning points of the swing (it moved on, unseen)
    gaps = [(t[g] - 0.1 * rec.period, t[g + 1] + 0.1 * rec.period)
            for g in np.flatnonzero(np.diff(t) > max(GAP_INTERVALS * rec.dt, 0.25 * rec.period))]
    if gaps:
        cands = [c for c in cands if not any(lo <= t[c[0]] <= hi or lo <= t[c[1]] <= hi for lo, hi in gaps)]
    out: list[Turn] = []
    for k, (a, b, is_max) in enumerate(c for c in cands if t[c[0]] <= t_end):
        got = rec.refine(a, b, is_max=is_max)
        if got is None and k > 0 and t[a] > t[0] + rec.period:
            rec.notes.append(f"the turning point near t = {t[a]:.4g} s is too close to the end of the record for a "
                             "local fit; left out")
            break
        out.append(Turn(a, b, is_max, None if got is None else float(got[0]), None if got is None else float(got[1])))
    return out


def _given_release(rec: "SampledRecord", release_s: float) -> tuple[float, float, list]:
    """The series' own release instant, its angle from the samples after it, and the extrema after it."""
    t, x = rec.t, rec.x
    i0 = int(np.searchsorted(t, release_s))
    if i0 >= t.size - 10:
        raise DataError(f"release_s = {release_s!r} s leaves no samples after it", rec.where)
    right = (t >= release_s) & (t <= release_s + rec.half_width())
    theta = vertex_at(t[right] - release_s, x[right], rec.degree)[1]
    cands = [c for c in alternating_extrema(rec.xs, rec.step, i0) if t[c[0]] > release_s + 0.25 * rec.period]
    return float(release_s), theta, cands


turning_points = reduce_series  # the earlier name


def prepare(t: np.ndarray, x: np.ndarray, window: float | None, degree: int, where: str,
            quantity: str = "angle", min_noise: float = 0.0) -> SampledRecord:
    """Check the samples; period, smoothing and resolution (steps 1 and 2).

    ``quantity`` is what the samples are (:data:`~escfit.analysis.recordings.series.QUANTITIES`):
    only an angle can be wrapped, and the notes speak in its unit.
    """
    if t.size < 20:
        raise DataError(f"only {t.size} samples; a decay needs many samples per period", where)
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(x))):
        raise DataError(f"times and {quantity_words(quantity)}s must be finite numbers", where)
    dts = np.diff(t)
    if np.any(dts <= 0):
        i = int(np.flatnonzero(dts <= 0)[0])
        raise DataError(f"times must increase: {t[i]!r} then {t[i + 1]!r}", where)
    steps = np.diff(x)
    if np.ptp(x) > 0 and (np.all(steps >= 0) or np.all(steps <= 0)):
        raise DataError(f"the {quantity_words(quantity)} only {'rises' if steps.sum() > 0 else 'falls'} over all "
                        f"{x.size} samples and never turns: a clock, a running count "
                        "or a list of event times (a light gate's passes?), or a motion that creeps to rest without "
                        "a swing; escfit needs the sampled swing's turning points", where)
    jump = np.abs(steps) if quantity == "angle" else np.zeros(0)
    if np.any(jump > 1.5 * math.pi):  # no motion sampled 16 times a period moves that far
        i = int(np.argmax(jump))
        within_turn = np.ptp(x) <= 2.1 * math.pi
        why = ("a wrapped angle? unwrap it (numpy.unwrap) before the analysis" if within_turn else
               "further than any swing moves between two samples, so the column is not an angle in the unit it "
               "was read in: set [recording] angle_unit (and scale), or displacement_column with its unit")
        raise DataError(f"the angle jumps by {math.degrees(jump[i]):.0f} deg between t = {t[i]:.4g} s and "
                        f"{t[i + 1]:.4g} s: {why}", where)
    notes: list[str] = []
    dt = float(np.median(dts))
    gaps = np.flatnonzero(dts > 3 * dt)
    if gaps.size:
        notes.append(f"{gaps.size} gap(s) in the sampling, the first from t = {t[gaps[0]]:.4g} s to "
                     f"{t[gaps[0] + 1]:.4g} s")
    period, prominence = _working_period(t, x)
    if not math.isfinite(period) or prominence < MIN_PROMINENCE:
        raise DataError(f"no oscillation found: the spectrum has no clear peak (peak {prominence:.3g} times the median "
                        f"power, a decay gives over {MIN_PROMINENCE:g}); is this a free decay?", where)
    mode_notes, weak_modes = check_other_modes(t, x, period, where)
    notes += mode_notes
    spp = period / dt
    if spp < COARSE_SAMPLES_PER_PERIOD:
        raise DataError(f"the period of {period:.4g} s spans only {spp:.1f} samples; the turning-point fits need at "
                        f"least {COARSE_SAMPLES_PER_PERIOD}: sample at {MIN_SAMPLES_PER_PERIOD / period:.3g} Hz or "
                        "faster", where)
    if spp < MIN_SAMPLES_PER_PERIOD:  # a coarse record: sinusoid arcs through the few samples at each turn
        notes.append(f"the period of {period:.4g} s spans only {spp:.1f} samples: each turning point is placed by an "
                     "arc of a sinusoid through the few samples around it, so turning times and amplitudes are less precise "
                     f"than at {MIN_SAMPLES_PER_PERIOD} samples a period or more (a waveform fit, [observation] model "
                     "= \"waveform\", uses every sample)")
    xs = smooth(x, spp)
    sigma, quantum = resolution(x, xs)
    if xs.size >= smoothing_window(spp):  # the scatter about the smoothing understates white noise
        sigma /= math.sqrt(1.0 - smoothing_share(spp))
    sigma = max(sigma, min_noise)
    amplitude = 0.5 * float(np.ptp(xs))
    band = max(1.5 * quantum, 4.0 * sigma, 1e-3 * amplitude)
    step = max(3.0 * quantum, 5.0 * sigma, 2e-3 * amplitude)
    resolution_ratio = max(quantum, sigma) / amplitude
    if window is None:
        window = 0.2 if resolution_ratio > 2e-4 or 0.125 * spp < 6 else 0.125
    shared = resolution_ratio > 2e-3
    return SampledRecord(t, x, xs, period, dt, band, step, window, degree, where, notes, shared, sigma, quantum, quantity,
                         other_modes=tuple(weak_modes))


def _working_period(t: np.ndarray, x: np.ndarray, min_cycles: float = 2.0) -> tuple[float, float]:
    """Period (s) and periodogram prominence; the spacing of the extrema decides when they disagree.

    A hold or a step puts the periodogram's largest peak at a low frequency when the decay is
    short (a strongly damped one): the spacing of the larger extrema is then the better working
    period (the turning times give the final one), provided the spectrum has a real peak there
    too (a weak faster ripple on the main swing makes extrema of its own; it holds under a
    thousandth of the power, a strongly damped swing next to a step a third).
    """
    period, prominence = spectral_period(t, x, min_cycles=min_cycles)
    check = extrema_period(t, x)
    if math.isfinite(check) and math.isfinite(period) and not 0.7 <= check / period <= 1.4:
        there, here = power_near(t, x, [check, period])
        if there >= 0.05 * here:
            period = check
    return period, prominence


def _final_turn(rec: SampledRecord, i_rest: int, rest: float, t_ref: float, theta_ref: float, times: list,
                values: list) -> float:
    """Stop instant; appends the stop as the last turning point when a half swing runs into it."""
    t = rec.t
    t_last, v_last = (times[-1], values[-1]) if times else (t_ref, theta_ref)
    if abs(rest - v_last) >= rec.step:
        # the swing into a stop is the record's smallest and its end the flattest: a parabola
        # times it best (higher terms trade off with the vertex time against the flat rest)
        got = rec.refine(i_rest, i_rest, flat="right", degree=2)
        if got is not None:
            d = (got[0] - t_last) / (0.5 * rec.period)
            if INTERVAL_RANGE[0] <= d <= INTERVAL_RANGE[1]:
                times.append(got[0])
                values.append(got[1])
                return got[0]
    rec.notes.append(f"the swing faded below the resolution ({rec.show(rec.band, 2)}) rather than "
                     "stopping at a turning point")
    return float(t[i_rest])


def _local_ratios(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each interval over the median of its neighbours (three each side), and that median."""
    half = 3
    local = np.empty(d.size)
    edge = list(range(min(half, d.size))) + list(range(max(half, d.size - half), d.size))
    for i in edge:
        local[i] = np.median(d[max(0, i - half):i + half + 1])
    if d.size > 2 * half:
        local[half:d.size - half] = np.median(np.lib.stride_tricks.sliding_window_view(d, 2 * half + 1), axis=1)
    return d / local, local


def _pendulum_stretch(values: np.ndarray) -> np.ndarray:
    """How much longer a pendulum's half swing between these turning points is than a small
    one's: K(sin^2(A/2)) / (pi/2), A half the swing between them (rad, below pi)."""
    from scipy.special import ellipk

    amp = np.minimum(0.5 * np.abs(np.diff(values)), math.pi - 1e-6)
    return ellipk(np.sin(0.5 * amp) ** 2) / (0.5 * math.pi)


def _check_intervals(rec: SampledRecord, times: np.ndarray, values: np.ndarray, strict: bool,
                     numbers: np.ndarray) -> None:
    """Each interval between turning points within :data:`INTERVAL_RANGE` local half periods.

    An angle record's interval also passes when it is regular once each half swing is scaled by
    a pendulum's lengthening at its amplitude: a pendulum let fall from near the top swings its
    first half swings far slower than the next (a spring's or balance's neighbours have like
    amplitudes, so the scaling excuses nothing there).
    """
    d = np.diff(times)
    ratio, local = _local_ratios(d)
    out = (ratio < INTERVAL_RANGE[0]) | (ratio > INTERVAL_RANGE[1])
    if out.any() and rec.quantity == "angle":
        scaled, _ = _local_ratios(d / _pendulum_stretch(np.asarray(values, float)))
        out &= (scaled < INTERVAL_RANGE[0]) | (scaled > INTERVAL_RANGE[1])
    hid = np.diff(numbers) - 1  # turning points a gap of the samples hid: counted across it
    if hid.any():
        rec.notes.append(f"{int(hid.sum())} turning point(s) fall in gaps of the samples (the first after t = "
                         f"{times[int(np.flatnonzero(hid)[0])]:.4g} s): the half swings after them are counted across")
    bad = np.flatnonzero(out & (hid == 0))
    if not bad.size:
        return
    i = int(bad[0])
    what = "an extremum was missed or samples are missing" if ratio[i] > 1 else "a spurious extremum (noise?)"
    message = (f"{bad.size} irregular interval(s) between turning points; the first, from t = {times[i]:.4g} s to "
               f"{times[i + 1]:.4g} s, is {ratio[i]:.2f} local half periods ({local[i]:.4g} s): {what}; the swing "
               "numbers after it would be wrong")
    if strict:
        raise DataError(message + " (cut the record there, or pass strict=False to keep it with a note)", rec.where)
    rec.notes.append(message)
