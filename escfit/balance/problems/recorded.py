"""Fit problems for sampled recordings: turning points or the whole waveform.

A sampled record (:class:`~escfit.balance.recordings.timeseries.TimeSeries`) is first analysed once
(:func:`~escfit.balance.recordings.turning_points.reduce_series`): turning points counted as
alternating extrema, the reference instant where the model is released at rest, the centre and
its drift, the end of motion.  Then, by the scene's ``[observation] model``:

- ``"amplitude"`` (default) or ``"notches"``: the turning points as a unit curve (reading 0 is
  the reference turning point itself, a reading of the release angle), fitted by
  :class:`~escfit.balance.problems.curves.FitProblem`;
- ``"waveform"``: every sample, fitted by :class:`~escfit.balance.problems.waveform.WaveformProblem`.

Either way the release angle comes from the record (:func:`~escfit.balance.problems.release.release_from_record`)
and what was done is kept as plain-sentence ``notes``.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .. import BalanceScene
from ...core.params import ParamSet
from ..recordings import UnitCurve
from ..recordings.rawseries import notes_of
from .curves import FitProblem
from .release import release_from_record

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


def amplitude_readings_curve(series) -> UnitCurve:
    """Rows that are already amplitude readings, one per half swing (reading 0: the release).

    For records such as a pointer read at every turning point: the angle column holds
    amplitudes, the time column the reading times.  Swings are numbered by row order; the
    spacing of the times is checked to be even within 40 % of its median.
    """
    from ...core.errors import DataError

    t = np.asarray(series.time, float)
    if t.size >= 3:
        gaps = np.diff(t)
        med = float(np.median(gaps))
        bad = np.flatnonzero(np.abs(gaps - med) > 0.4 * med)
        if bad.size:
            raise DataError(f"readings {bad[0] + 1} and {bad[0] + 2} are {gaps[bad[0]]:.4g} s apart where the others are "
                            f"~{med:.4g} s: a half swing missed or repeated; amplitude rows must follow one per half swing",
                            series.source)
    value = np.abs(np.asarray(series.theta, float))
    meta = dict(series.meta)
    meta.update(derived_from="amplitude readings, one per half swing in row order")
    return UnitCurve(np.arange(value.size, dtype=np.int64), value, "amplitude", unit=np.full(value.size, "", dtype=str),
                     time=t - t[0], source=series.source, sha256=series.sha256, meta=meta)


def _free_centre(scene: BalanceScene, curve: UnitCurve, tp) -> BalanceScene:
    """Free the centre and its drift unless the scene's ``[observation]`` fixes them."""
    obs = dict(scene.extra.get("observation", {}))
    amp = float(np.max(curve.value))
    span_t = float(max(curve.time[-1], 1e-9))
    rate0 = float(getattr(tp, "offset_rate", 0.0))
    obs.setdefault("offset", {"value": 0.0, "vary": True, "min": -0.25 * amp, "max": 0.25 * amp})
    obs.setdefault("offset_rate", {"value": 0.0, "vary": True, "min": -(abs(rate0) + amp / span_t),
                                   "max": abs(rate0) + amp / span_t})
    return replace(scene, extra={**scene.extra, "observation": obs})


def omega0_from_period(scene: BalanceScene, tp) -> float:
    """Natural frequency (rad/s) implied by the record's measured period.

    A spring's period does not depend on the amplitude: ``omega0 = 2 pi / P``.  A pendulum's
    grows with it: ``P = 4 K(sin^2(A/2)) / omega0`` with ``A`` the median turning-point amplitude
    (light damping shifts either by a fraction ``(C/2 omega0)^2``, negligible here).
    """
    if getattr(scene, "restoring", "spring") != "pendulum":
        return 2.0 * math.pi / tp.period
    from scipy.special import ellipk

    amp = float(np.median(np.abs(np.asarray(tp.theta) - tp.offset)))
    return 4.0 * float(ellipk(math.sin(0.5 * amp) ** 2)) / tp.period


def _start_omega0(scene: BalanceScene, tp) -> list[str]:
    """Start a free ``oscillator.omega0`` at the measured period's value, in place; notes."""
    if "oscillator.omega0" not in scene.params or not scene.params["oscillator.omega0"].vary:
        return []
    p = scene.params["oscillator.omega0"]
    w = omega0_from_period(scene, tp)
    if not p.min <= w <= p.max:
        return [f"the measured period {tp.period:.4g} s implies omega0 = {w:.4g} rad/s, outside the scene's range "
                f"[{p.min:.4g}, {p.max:.4g}]: is the range right?"]
    scene.params.params[p.name] = replace(p, value=w)
    return [f"omega0 started at {w:.4g} rad/s from the measured period {tp.period:.4g} s"]


def problem_from_series(scene: BalanceScene, series, *, solver: str, solver_options: dict | None = None,
                        readings: str = "samples"):
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

    Returns
    -------
    FitProblem or WaveformProblem
        With ``notes`` saying what was done to the record.
    """
    scene = replace(scene, params=ParamSet(dict(scene.params.params)))  # the release is set on a copy
    notes = notes_of(series.meta)
    model = dict(scene.extra.get("observation", {})).get("model", "amplitude")
    if readings == "amplitudes":
        curve = amplitude_readings_curve(series)
        notes += release_from_record(scene.params, float(curve.value[0]), series.source, scene.restoring)
        problem = FitProblem(scene, curve, solver, dict(solver_options or {}))
        problem.notes = notes
        return problem
    from ..recordings.turning_points import reduce_series

    # a waveform fit uses the turning points only for its start (reference, period, centre): an
    # irregular interval late in the record is a note there, not a refusal
    tp = reduce_series(series, strict=model != "waveform")
    notes += list(getattr(tp, "notes", [])) + _start_omega0(scene, tp)
    if model == "waveform":
        from .waveform import WaveformProblem

        problem = WaveformProblem(scene, series, tp, solver, solver_options)
        problem.notes = notes + problem.notes
        return problem
    curve = turning_point_curve(series, tp)
    notes.append(f"{curve.value.size - 1} turning points after the reference one at t = {tp.release_time:.4g} s "
                 f"({math.degrees(tp.release_theta - tp.offset):+.2f} deg from the centre); period {tp.period:.4g} s")
    notes += release_from_record(scene.params, float(tp.release_theta - tp.offset), series.source, scene.restoring)
    problem = FitProblem(_free_centre(scene, curve, tp), curve, solver, dict(solver_options or {}))
    problem.notes = notes
    if "oscillator.omega0" in problem.names:
        problem.data_warnings = [
            "turning-point amplitudes fix omega0 only through the damping per swing: fit the whole waveform "
            f"([observation] model = \"waveform\") or fix omega0 near {omega0_from_period(scene, tp):.4g} rad/s "
            f"(from the measured period {tp.period:.4g} s)"]
    return problem
