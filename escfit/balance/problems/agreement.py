"""The fit of a sampled balance or pendulum record held against the record itself.

The balance family's side of :mod:`escfit.analysis.agreement`: the fitted model run from its
release to the record's last turning point (:func:`escfit.balance.solvers.solve_system`), its
turning points compared with the record's (phase and amplitude), and, for a waveform fit, the
turning-point fit of the same scene and record compared with it; the decision is the analysis
layer's (:func:`escfit.analysis.agreement.judge`).  The refit's least squares is handed in by the
inference layer (``refit``), which sits above the families.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable, Mapping

import numpy as np

from ...analysis.agreement import (MIN_TURNS, Agreement, ModelFacts, ParameterDifference,
                                   TurnDifferences, judge, smooth_trend, turn_scatter)

from ..decrement import loss_symbols

__all__ = ["check_agreement", "turning_point_refit", "later_start_refit"]


def _model_turns(problem, values: Mapping[str, float], swings: np.ndarray):
    """The model's turning points at ``swings``: times on the record's clock (s) and signed
    readings about the model's centre (the readings' unit; amplitudes for a turning-point fit)."""
    from ..solvers import solve_system

    sys = problem.scene.system(values)
    n = int(swings.max())
    tr = solve_system(sys, n, problem.solver, **dict(problem.solver_options or {}))
    times = np.r_[0.0, np.asarray(tr.time, float)]
    theta = np.r_[float(sys.theta0), np.asarray(tr.theta_turn, float)]
    ok = swings < times.size  # the model may come to rest first
    swings = swings[ok]
    gain = float(values.get("observation.gain", 1.0))
    return ok, times[swings], gain * theta[swings]


def _compare_turns(problem, values: Mapping[str, float]) -> tuple[TurnDifferences | None, TurnDifferences | None,
                                                                  list[str]]:
    tp = problem.turning_points
    period = float(tp.period)
    waveform = hasattr(problem, "sample_time")
    swing = np.r_[0, np.asarray(tp.swing, np.int64)]
    t_rec = np.r_[float(tp.release_time), np.asarray(tp.time, float)]
    y_rec = np.r_[float(tp.release_theta), np.asarray(tp.theta, float)]
    comments = []
    keep = np.ones(swing.size, bool)
    first = float(problem.data.time[0])
    if t_rec[0] <= first + 0.05 * period:  # a reference at the record's edge: extrapolated, not measured whole
        keep[0] = False
    if math.isfinite(float(getattr(tp, "stop_time", math.nan))) and tp.stop_time == t_rec[-1]:
        keep[-1] = False  # a stop is no turning point of the free motion
    swing, t_rec, y_rec = swing[keep], t_rec[keep], y_rec[keep]
    if swing.size < MIN_TURNS:
        return None, None, [f"only {swing.size} turning points to hold the model against"]
    ok, t_mod, y_mod = _model_turns(problem, values, swing)
    if not ok.all():
        comments.append(f"the model comes to rest after {int(ok.sum())} of the record's {ok.size} turning points")
    swing, t_rec, y_rec = swing[ok], t_rec[ok], y_rec[ok]
    if swing.size < MIN_TURNS:
        return None, None, comments
    if waveform:
        t_mod = t_mod + float(values["observation.t_release"])
        centre = -float(values["observation.offset"]) - float(values["observation.offset_rate"]) * (
            t_mod - problem.observation.t_ref)
        side = np.sign(y_mod)
        amp_rec, amp_mod = side * (y_rec - centre), np.abs(y_mod)
    else:  # a turning-point fit: its readings are amplitudes about the estimated centre, times since release
        t_mod = t_mod + float(tp.release_time)
        curve = problem.curves[0]
        rows = np.searchsorted(curve.swing, swing)
        amp_rec, amp_mod = curve.y[rows], problem.expected(values)[rows]
    phase = 2.0 * math.pi * (t_rec - t_mod) / period
    d_amp = amp_rec - amp_mod
    t_rec = t_rec - float(getattr(tp, "origin", 0.0))  # shown as the notes show times: after the first sample
    out = []
    for what, d, floor in (("phase", phase, 1e-6), ("amplitude", d_amp, 1e-6 * float(np.max(np.abs(amp_rec))))):
        if what == "amplitude" and getattr(problem, "quantity", "angle") == "angular_velocity":
            out.append(None)  # the rate's zeros carry no measured angle
            continue
        s = turn_scatter(d, floor)
        size = amp_rec if what == "amplitude" else None
        out.append(TurnDifferences(what, swing, t_rec, d, s, smooth_trend(swing, d), size) if math.isfinite(s)
                   else None)
    return out[0], out[1], comments


# -- the waveform fit against the turning-point fit of the same record -----------------------------

def turning_point_refit(problem, lsq, refit, *, seed: int = 0):
    """The turning-point (``model = "amplitude"``) fit of a waveform problem's scene and record.

    ``refit(problem, start, seed)`` is the inference layer's least squares (checked against the
    measured period, with the held omega0's uncertainty, as ``escfit fit`` does), returning the
    result and whether the period was left unresolved.  Returns the least-squares result and the
    turning-point problem or, when the record's turning points cannot be fitted so, the reason (str).
    """
    scene = problem.given_scene
    obs = {k: v for k, v in dict(scene.extra.get("observation", {})).items() if k in ("offset", "offset_rate")}
    scene = replace(scene, extra={**scene.extra, "observation": {**obs, "model": "amplitude"}})
    return _second_fit(problem, scene, problem.data, lsq, refit, seed, "turning-point fit", turns=problem.turning_points)


def _second_fit(problem, scene, series, lsq, refit, seed: int, what: str, *, keep=lambda name: True, **options):
    """Least squares of another problem of the same record (``problem_from_series(scene, series,
    **options)`` with the problem's solver), started from the fit's physical values whose names
    ``keep`` accepts.  Returns the result and that problem, or why there is none (str)."""
    from ...core.errors import EscfitError
    from .from_series import problem_from_series

    try:
        other = problem_from_series(scene, series, solver=problem.solver,
                                    solver_options=dict(problem.solver_options or {}), **options)
        begin = {n: float(lsq.values[n]) for n in other.names
                 if n in lsq.values and not n.startswith("observation.") and keep(n)}
        fit, unresolved = refit(other, begin, seed)
    except (EscfitError, ValueError, ArithmeticError) as exc:
        said = str(exc).splitlines()[0]
        return f"no {what} to compare with ({said if len(said) <= 240 else said[:240].rsplit(' ', 1)[0] + ' ...'})"
    if unresolved:
        return f"the {what} contradicts the record's measured period: not compared"
    return fit, other


def _compare_parameters(wave, turns, held_by) -> list[ParameterDifference]:
    out = []
    for name in ("oscillator.omega0", *(p for p, _ in loss_symbols(effects_of(wave.names)))):
        if name not in wave.names:
            continue
        i = wave.names.index(name)
        if name in turns.names:
            j = turns.names.index(name)
            b, b_se = float(turns.value[j]), float(turns.stderr[j])
        elif name == "oscillator.omega0" and name in turns.values:  # held at the measured period's value
            mp = getattr(held_by, "measured_period", None)
            b = float(turns.values[name])
            b_se = b * mp.stderr / mp.period if mp is not None and math.isfinite(mp.stderr) else 0.0
        else:
            continue
        a, a_se = float(wave.value[i]), float(wave.stderr[i])
        if math.isfinite(a_se) and math.isfinite(b_se):
            out.append(ParameterDifference(name, a, a_se, b, b_se))
    return out


def check_agreement(problem, lsq, refit: Callable, *, seed: int = 0) -> Agreement | None:
    """Hold a fit of a sampled record against the record (see :mod:`escfit.analysis.agreement`).

    Parameters
    ----------
    problem
        A fit problem of a sampled record (:func:`escfit.balance.problems.from_series.problem_from_series`
        keeps its ``turning_points`` and ``given_scene``); ``None`` is returned for any other.
    lsq
        Its least-squares result (:class:`~escfit.inference.lsq.LeastSquaresResult`).
    refit
        ``refit(problem, start, seed) -> (result, unresolved)``: least squares of another problem.
    seed
        For the turning-point refit of a waveform fit.

    Returns
    -------
    Agreement or None
    """
    from ...core.errors import EscfitError

    if getattr(problem, "turning_points", None) is None:
        return None
    waveform = hasattr(problem, "sample_time")
    try:
        phase, amplitude, comments = _compare_turns(problem, lsq.values)
    except (EscfitError, ValueError, ArithmeticError) as exc:
        phase, amplitude, comments = None, None, [f"the model's turning points could not be computed ({exc})"]
    parameters: list[ParameterDifference] = []
    if waveform and getattr(problem, "given_scene", None) is not None and \
            getattr(problem, "quantity", "angle") == "angle":
        turns = turning_point_refit(problem, lsq, refit, seed=seed)
        if isinstance(turns, str):
            comments.append(turns)
        else:
            parameters = _compare_parameters(lsq, *turns)
    tp = problem.turning_points
    span = float(phase.time[-1] - phase.time[0]) if phase is not None else math.nan
    periods = span / float(tp.period) if math.isfinite(span) else float(tp.swing.size) / 2.0
    effects = effects_of(problem.scene.params.params)
    model = ModelFacts(waveform, getattr(problem, "reading_units", "rad"), effects, problem.scene.restoring,
                       loss_symbols(effects))
    agreement = _pendulum_law(problem, judge(phase, amplitude, parameters, model, periods=periods, comments=comments))
    if parameters and agreement.agrees:  # a waveform fit of an angle that the turning-point fit could check
        agreement = _start_dependence(problem, lsq, refit, seed, agreement, model)
    return agreement


# -- the fit against the fit of the same record from one period later -----------------------------

def later_start_refit(problem, lsq, refit, *, seed: int = 0):
    """The fit of a waveform problem's scene and record from one period after its reference turning point.

    The record is the same series with ``[recording] start`` set three quarters of a period after
    the reference (the first turning point from there is one period after it; a ``release`` the
    user set gives way to it); ``refit`` is as for :func:`turning_point_refit`, started from the
    fit's physical values.  Returns the least-squares result and the later problem or, when
    there is no such fit, the reason (str).
    """
    from ...analysis.recordings.window import window_of
    from ...analysis.start_dependence import LATER_PERIODS, MIN_PERIODS

    tp, series = problem.turning_points, problem.data
    period = float(tp.period)
    start = float(tp.release_time) + (LATER_PERIODS - 0.25) * period
    stop = float(getattr(tp, "stop_time", math.nan))
    end = stop if math.isfinite(stop) else float(series.time[-1])
    if not end - start >= MIN_PERIODS * period:
        return f"the record is too short to be fitted again from one period later (under {MIN_PERIODS:g} periods after it)"
    used = np.isin(series.time, problem.sample_time)  # a thinned record: the same samples, nested
    tries = [replace(series, time=series.time[used], theta=series.theta[used]), series] if not used.all() \
        else [series]
    for each in tries:  # the whole record when the analysis of the thinned one fails (its blocks can alias)
        later = replace(each, window=replace(window_of(each), start=start, release=None), release_s=math.nan)
        got = _second_fit(problem, problem.given_scene, later, lsq, refit, seed, "fit from one period later",
                          keep=lambda name: name != "oscillator.theta0")
        if not (isinstance(got, str) and got.startswith("no fit")):
            return got
    return got


def _start_dependence(problem, lsq, refit, seed: int, agreement: Agreement, model: ModelFacts) -> Agreement:
    """The agreement with the loss coefficients that move when the first period is left out
    marked not determined (:mod:`escfit.analysis.start_dependence`), or a note that none do."""
    from ...analysis.start_dependence import StartDifference, start_dependence

    got = later_start_refit(problem, lsq, refit, seed=seed)
    if isinstance(got, str):
        return replace(agreement, comments=agreement.comments + (got,))
    later, again = got
    differences = []
    for name, _ in model.losses:
        if name in lsq.names and name in later.names:
            i, j = lsq.names.index(name), later.names.index(name)
            differences.append(StartDifference(name, float(lsq.value[i]), float(lsq.stderr[i]),
                                               float(later.value[j]), float(later.stderr[j])))
    found = start_dependence(differences, float(again.turning_points.release_time),
                             _losses_at(problem.scene.restoring, lsq.values, later.values))
    if not found.moved:
        return replace(agreement, comments=agreement.comments + (found.note(),))
    return replace(agreement, undetermined=tuple(dict.fromkeys(tuple(agreement.undetermined) + found.moved)),
                   cautions=(found.clause(model.short),) + tuple(agreement.cautions))


def _losses_at(restoring: str, values: Mapping, later: Mapping) -> tuple[float, float, float] | None:
    """``(A, fit's, later fit's)``: the swing's loss per period (a fraction of ``A``) by each fit's
    coefficients at ``A``, the later fit's first amplitude (rad); None without the parameters."""
    from ..decrement import losses, swing_of

    if not {"oscillator.omega0", "oscillator.theta0"} <= set(later) or "oscillator.omega0" not in values:
        return None
    amplitude = abs(float(later["oscillator.theta0"]))

    def per_period(v: Mapping) -> float:
        swing = swing_of(np.array([amplitude]), float(v["oscillator.omega0"]), k3=float(v.get("stiffening.k3", 0.0)),
                         restoring=restoring)
        parts = [cls.decrement(float(v[cls.LOSS.parameter]), swing) for cls in losses().values()
                 if cls.LOSS.parameter in v]
        return 2.0 * float(np.sum(parts)) / amplitude if parts and amplitude > 0 else math.nan

    return amplitude, per_period(values), per_period(later)


def _pendulum_law(problem, agreement: Agreement) -> Agreement:
    """A record whose periods do not change with the amplitude as a gravity pendulum's do leaves
    the small-swing omega0 undetermined: it is the measured period shortened by that law, at the
    amplitudes as read, which the record contradicts (the angles' scale or the restoring law is
    not the scene's; the warning says which keys).  The period itself and the losses stand."""
    from .from_series import UNLIKE_PENDULUM

    said = [w for w in getattr(problem, "data_warnings", []) if w.startswith(UNLIKE_PENDULUM)]
    if not said or "oscillator.omega0" in agreement.undetermined:
        return agreement
    return replace(agreement, undetermined=("oscillator.omega0",) + tuple(agreement.undetermined))


def effects_of(names) -> frozenset:
    """The effects (``"viscous"``, ``"coulomb"`` ...) of parameter names (``"viscous.C"``)."""
    return frozenset(n.split(".")[0].split("[")[0] for n in names)
