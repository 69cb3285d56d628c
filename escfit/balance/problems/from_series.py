"""Fit problems for sampled recordings: turning points or the whole waveform.

A sampled record (:class:`~escfit.analysis.recordings.timeseries.TimeSeries`) is first analysed once
(:func:`~escfit.analysis.recordings.turning_points.reduce_series`): turning points counted as
alternating extrema, the reference instant where the model is released at rest, the centre and
its drift, the end of motion.  Then, by the scene's ``[observation] model``:

- ``"amplitude"`` (default) or ``"notches"``: the turning points as a unit curve (reading 0 is
  the reference turning point itself, a reading of the release angle), fitted by
  :class:`~escfit.balance.problems.curves.FitProblem`;
- ``"waveform"``: every sample, fitted by :class:`~escfit.balance.problems.waveform.WaveformProblem`.

Notes speak of times after the file's first sample (an epoch clock's 1.407e9 s is 0 s there), as
``[recording] start``, ``stop`` and ``release`` do (the analysis counts time so: ``tp.after_first``);
those keys reach the analysis as the series' ``window``.  The fit itself keeps the file's clock.

Either way the release angle comes from the record (:func:`~escfit.balance.problems.release.release_from_record`)
and what was done is kept as plain-sentence ``notes``.

A record of what was measured other than an angle (the series' ``quantity``) is fitted sample
by sample: an angular velocity (a gyroscope, a velocity pickup) as theta'(t) of the scene's
oscillator, its turning points the rate's zeros (:func:`~escfit.analysis.recordings.rate.reduce_rate`),
its sensor zero the bias measured from the rate's extrema; a displacement as the x(t) of a linear
oscillator scene (``[oscillator] coordinate = "linear"``), analysed as an angle is, in m.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .. import BalanceScene
from ...core.params import ParamSet
from ...analysis.recordings import UnitCurve
from ...analysis.recordings.rawseries import notes_of
from .amplitude_rows import amplitude_readings_curve
from ...analysis.recordings.window import window_of
from .curves import FitProblem
from .facts import RecordFacts
from .nuisance import centre_priors
from .period import check_pendulum_period, check_scene_omega0, hold_omega0, measured_period, start_omega0
from .release import release_from_record, swing_unit_warnings, table_unit_warnings

__all__ = ["problem_from_series", "turning_point_curve", "amplitude_readings_curve"]


def turning_point_curve(series, tp) -> UnitCurve:
    """The turning points of ``series`` as amplitude readings about the estimated centre.

    The centre and its linear drift estimated from the turning points are removed; the fit's
    ``observation.offset`` and ``offset_rate`` are then small corrections to them.  Reading 0
    is the reference turning point (the model's release); times are since then.
    """
    swing = np.concatenate([[0], np.asarray(tp.swing, np.int64)])
    theta = np.concatenate([[tp.release_theta], np.asarray(tp.theta, float)])
    time = np.concatenate([[tp.release_time], np.asarray(tp.time, float)]) - tp.release_time
    off = float(tp.offset)
    amp = np.abs(theta - off - float(tp.offset_rate) * time)  # about the estimated (drifting) centre
    meta = dict(series.meta)
    meta.update(derived_from="time series: turning points counted as alternating extrema", period_s=repr(tp.period),
                offset_rad=repr(off), offset_rate_rad_per_s=repr(float(getattr(tp, "offset_rate", 0.0))),
                release_time_s=repr(float(tp.release_time)), release_theta_rad=repr(float(tp.release_theta)))
    return UnitCurve(swing, amp, "amplitude", unit=np.full(amp.size, "", dtype=str), time=time,
                     source=series.source, sha256=series.sha256, meta=meta)


def _free_centre(scene: BalanceScene, curve: UnitCurve, tp) -> BalanceScene:
    """Free the centre and its drift, within what the record measured, unless ``[observation]`` fixes them."""
    obs = dict(scene.extra.get("observation", {}))
    for key, table in centre_priors(tp, removed=True).items():
        obs.setdefault(key, table)
    return replace(scene, extra={**scene.extra, "observation": obs})


def problem_from_series(scene: BalanceScene, series, *, solver: str, solver_options: dict | None = None,
                        readings: str = "samples", turns=None, more: RecordFacts | None = None):
    """The fit problem of a sampled record (see the module docstring).

    Parameters
    ----------
    scene
        Balance scene.
    series
        The samples, rad, in the recording's clock.
    solver, solver_options
        Forward solver.
    readings
        ``"samples"``: theta sampled in time; ``"amplitudes"``: each row is already the
        amplitude of one half swing.
    turns
        The record's turning points when already found
        (:class:`~escfit.analysis.recordings.turning_points.TurningPoints` of an angle): they are
        then not looked for again.
    more
        Notes, warnings and trailing notes the caller adds (the reader's, the command line's),
        after the analysis's own.

    Returns
    -------
    FitProblem or WaveformProblem
        With ``notes`` saying what was done to the record.
    """
    scene = replace(scene, params=ParamSet(dict(scene.params.params)))  # the release is set on a copy
    given = replace(scene, params=ParamSet(dict(scene.params.params)))  # as the user wrote it: for the agreement check
    notes = notes_of(series.meta)
    quantity = getattr(series, "quantity", "angle")
    _check_quantity(scene, quantity, series.source)
    if quantity != "angle":
        return _sampled_problem(scene, series, notes, solver, solver_options, given, more)
    model = dict(scene.extra.get("observation", {})).get("model", "amplitude")
    if readings == "amplitudes":
        return _amplitude_rows_problem(scene, series, notes, solver, solver_options, more)
    from ...analysis.recordings.turning_points import reduce_series

    # a waveform fit uses the turning points only for its start (reference, period, centre): an
    # irregular interval late in the record is a note there, not a refusal
    tp = reduce_series(series, strict=model != "waveform", user_window=series.window) if turns is None else turns
    notes += list(getattr(tp, "notes", []))
    swing_warnings = swing_unit_warnings(series, tp, scene.restoring)  # the swing's size against the unit
    series = _without_steps(series, tp)
    _refuse_sustained(scene, tp, series.source)
    mp = measured_period(tp, series.source)
    check_pendulum_period(scene.restoring, mp)
    unit_notes, unit_warnings = _unit_from_period(scene, series, tp)
    notes += unit_notes
    unit_warnings = swing_warnings + unit_warnings
    check_scene_omega0(scene, mp)
    if model == "waveform":
        from .waveform import WaveformProblem

        notes += start_omega0(scene, mp)
        facts = RecordFacts(tuple(notes + [_count_note(tp)]), tuple(list(tp.warnings) + unit_warnings), mp,
                            turning_points=tp, record_window=_window(series, tp, waveform=True), given_scene=given)
        return WaveformProblem(scene, series, tp, solver, solver_options, facts=facts.plus(more))
    held = hold_omega0(scene, mp)
    curve = turning_point_curve(series, tp)
    notes.append(_count_note(tp))
    notes += held
    notes += release_from_record(scene.params, float(tp.release_theta - tp.offset), series.source, scene.restoring)
    facts = RecordFacts(tuple(notes), tuple(list(tp.warnings) + unit_warnings), mp,
                        ("oscillator.omega0",) if held else (), tp, _window(series, tp, waveform=False), given)
    return FitProblem(_free_centre(scene, curve, tp), curve, solver, dict(solver_options or {}), facts.plus(more))


def _window(series, tp, *, waveform: bool) -> tuple[float, float, float, float] | None:
    """The stretch of the record the fit uses against the whole record (``record_window``: first
    and last sample of the file, first and last instant fitted, s on the series' clock), for the
    plain summary; None for an empty series."""
    if not len(series.time):
        return None
    window = window_of(series)
    last = window.end if window.end is not None else float(series.time[-1])
    stop = float(tp.stop_time)
    end = stop if math.isfinite(stop) else (
        float(series.time[-1]) if waveform else float(np.max(tp.time, initial=tp.release_time)))
    return float(window.origin), float(last), float(tp.release_time), end


def _without_steps(series, tp):
    """The series without the glitches and with the offset steps the analysis found taken out
    (the record itself if none)."""
    from ...analysis.recordings.turning_points import drop_samples, remove_steps

    if getattr(tp, "dropped", ()):
        series = drop_samples(series, tp.dropped)
    if getattr(tp, "steps", ()):
        series = replace(series, theta=remove_steps(series.time, series.theta, tp.steps))
    return series


def _amplitude_rows_problem(scene: BalanceScene, series, notes: list[str], solver: str, solver_options,
                            more: RecordFacts | None):
    """Rows that are amplitude readings; omega0 held at the scene's value when the rows are
    numbered by their times (amplitudes alone cannot determine it)."""
    p = scene.params.params.get("oscillator.omega0")
    curve, by_time = amplitude_readings_curve(series, omega0=None if p is None else float(p.value),
                                              restoring=scene.restoring)
    held: tuple[str, ...] = ()
    if by_time:
        notes.append(curve.meta["derived_from"])
        if p.vary:
            scene.params.params[p.name] = replace(p, vary=False, prior=None)
            held = (p.name,)
            notes.append(f"omega0 held at the scene's {p.value:.5g} rad/s: amplitudes depend on it only through "
                         "C/omega0 and R/omega0^2 and their times were numbered with it")
    if p is not None and not p.vary and not by_time:
        small = " (small-swing)" if scene.restoring == "pendulum" else ""
        notes.append(f"omega0 held at the scene's {p.value:.5g} rad/s, period {2 * math.pi / p.value:.5g} s{small}: "
                     "amplitudes depend on it only through C/omega0 and R/omega0^2")
    notes += release_from_record(scene.params, float(curve.value[0]), series.source, scene.restoring)
    from ...analysis.recordings.row_kind import judge_rows

    centre = judge_rows(series.time, series.theta).centre
    unit_warnings = table_unit_warnings(series, float(np.max(np.abs(series.theta - centre))), scene.restoring)
    return FitProblem(scene, curve, solver, dict(solver_options or {}),
                      RecordFacts(tuple(notes), tuple(unit_warnings), held=held).plus(more))


def _count_note(tp, quantity: str = "angle") -> str:
    where = tp.release_theta - tp.offset
    shown = f"{where:+.4g} m" if quantity == "displacement" else f"{math.degrees(where):+.2f} deg"
    how = " (zeros of the angular velocity)" if quantity == "angular_velocity" else ""
    return (f"{tp.swing.size} turning points{how} after the reference one at t = {tp.after_first(tp.release_time):.4g} s "
            f"({shown} from the centre); period {tp.period:.5g} s")


WHAT = {"angular_velocity": "an angular velocity (rad/s)", "displacement": "a linear displacement (m)"}


def _check_quantity(scene: BalanceScene, quantity: str, source: str) -> None:
    """A displacement goes with a linear oscillator scene and an angle or a rate with a balance's: else refused."""
    from ...core.errors import FitError

    if scene.linear and quantity != "displacement":
        raise FitError(f"the scene is a linear oscillator (coordinate = 'linear', x in m) but the recording is "
                       f"{WHAT.get(quantity, 'an angle (rad)')}: record its displacement ([recording] "
                       "displacement_column), or write the scene for a balance or pendulum", source)
    if quantity == "displacement" and not scene.linear:
        raise FitError("the recording is a linear displacement (m), so the scene must be a linear oscillator: "
                       "[oscillator] coordinate = \"linear\", its release x0 in m, Coulomb friction R in m/s^2 "
                       "(or read an angle column with [recording] angle_column)", scene.where)
    model = dict(scene.extra.get("observation", {})).get("model", "waveform")
    if quantity != "angle" and model != "waveform":
        raise FitError(f"the recording is {WHAT[quantity]}: it is fitted sample by sample, as a waveform; set "
                       "[observation] model = \"waveform\" (or leave model out)", scene.where)


def _sampled_problem(scene: BalanceScene, series, notes: list, solver, solver_options, given: BalanceScene,
                     more: RecordFacts | None):
    """The waveform problem of an angular velocity or a displacement (see the module docstring)."""
    from .waveform import WaveformProblem

    obs = dict(scene.extra.get("observation", {}))
    if "model" not in obs:
        obs["model"] = "waveform"
        scene = replace(scene, extra={**scene.extra, "observation": obs})
    if series.quantity == "angular_velocity":
        from ...analysis.recordings.rate import reduce_rate

        rate = reduce_rate(series, user_window=series.window)
        tp, centre, noise = rate.turns, rate, rate.noise
        notes += rate.notes
    else:
        from ...analysis.recordings.turning_points import reduce_series

        tp = reduce_series(series, strict=False, user_window=series.window)
        centre, noise = tp, None
        notes += list(tp.notes)
        series = _without_steps(series, tp)
    _refuse_sustained(scene, tp, series.source)
    mp = measured_period(tp, series.source)
    check_scene_omega0(scene, mp)
    notes += start_omega0(scene, mp)
    facts = RecordFacts(tuple(notes + [_count_note(tp, series.quantity)]), tuple(getattr(tp, "warnings", [])), mp,
                        turning_points=tp, given_scene=given)
    return WaveformProblem(scene, series, tp, solver, solver_options, centre=centre, noise=noise,
                           facts=facts.plus(more))


def _refuse_sustained(scene: BalanceScene, tp, source: str) -> None:
    """A swing that stops decaying needs a drive in the model: refused when the scene has none."""
    when = float(getattr(tp, "sustained_from", math.nan))
    if not math.isfinite(when) or any(n.startswith("escapement") for n in scene.params.params):
        return
    from ...core.errors import DataError

    why = str(getattr(tp, "sustained_why", "")) or (f"from t = {tp.after_first(when):.4g} s the swing keeps its "
                                                      "amplitude where a free decay would go on losing")
    if when <= float(getattr(tp, "release_time", -math.inf)):  # no loss measured over the whole record
        raise DataError(f"{why}: something drives it (a motor, an escapement), or its losses are below what this "
                        "record resolves; the scene has no drive, so it cannot be fitted as a free decay: record a "
                        "longer stretch of the decay (or set [recording] start and stop around one), or model the "
                        "drive", source)
    raise DataError(f"{why}: something drives it (a motor, an escapement), and the scene has no drive, so it cannot be "
                    "fitted as a free decay; cut the record before that with [recording] stop, or model the drive",
                    source)


_DEGREE_WORDS = ("deg", "degree", "degrees", "°")
_RADIAN_WORDS = ("rad", "radian", "radians")


def _unit_from_period(scene: BalanceScene, series, tp) -> tuple[list[str], list[str]]:
    """A free pendulum's angles held against its period's amplitude dependence
    (:mod:`escfit.analysis.pendulum_unit`): ``(notes, warnings)``.  Radians read as degrees are
    refused naming ``angle_unit``; a period that keeps still where a pendulum's would change is a
    warning; a unit the periods confirm is a note."""
    unit = str(series.meta.get("angle_unit", "")).strip().lower()
    stiff = any(n.startswith("stiffening.") for n in scene.params.params)
    if scene.restoring != "pendulum" or stiff or unit not in _DEGREE_WORDS + _RADIAN_WORDS:
        return [], []
    from ...analysis.pendulum_unit import unit_from_period
    from ...core.errors import DataError

    # the free decay's samples, to its last turning point: not the noise after the swing faded
    last = float(tp.time[-1]) if len(tp.time) else math.inf
    after = (series.time >= tp.release_time) & (series.time <= last)
    centre = tp.offset + tp.offset_rate * (series.time[after] - tp.release_time)
    evidence = unit_from_period(series.time[after], series.theta[after] - centre)
    if evidence is None:
        return [], []
    if evidence.verdict == "radians read as degrees" and unit in _DEGREE_WORDS:
        raise DataError(f"{evidence.sentence()}: set [recording] angle_unit = \"rad\" (or --angle-unit rad)",
                        series.source)
    if evidence.verdict == "as read":
        return [evidence.sentence()], []
    if evidence.verdict == "unlike a pendulum":
        return [], [UNLIKE_PENDULUM + evidence.sentence() + ": the angles' scale ([recording] angle_unit, scale) or "
                    "the restoring law (a pendulum, --pendulum, or a spring) is not what the scene says"]
    return [], []


#: the start of the warning that the periods contradict a gravity pendulum's amplitude law: the
#: small-swing omega0 rests on that law, so the fit leaves it undetermined
UNLIKE_PENDULUM = "omega0 is not determined: "

