"""The fit held against the record: the model's turning points against the measured ones.

Residual statistics (runs, lag-1 correlation) say *that* a fit misses something, not *what*,
and a waveform fit of a long record can drift out of phase with it while every one of them
only grumbles.  This last check compares what the fitted model does with what the record
itself measured, independently of the likelihood:

1. **Turning points.**  The model is run once from the fitted release to the record's last
   turning point; each of its turning points is compared with the record's (the turning-point
   analysis, :mod:`escfit.balance.recordings.turning_points`): the time difference as a phase,
   ``2 pi (t_record - t_model) / period`` (rad, positive: the record turns later), and the
   amplitude difference (the record's amplitude minus the model's, in the readings' unit).
   Each is measured in units of the record's own point-to-point scatter of that difference
   (robust, from differences of turning points two apart, so that a smooth drift and an
   alternating side bias do not count as scatter).  A **drift** is the smooth part: a
   polynomial of degree 2 in the turning-point number (a frequency that drifts linearly moves
   the phase quadratically), plus an alternating term; it is a warning when its largest value
   along the record exceeds :data:`DRIFT_SIGMAS` of that scatter, and a finding when it is also
   gross: the phase more than :data:`PHASE_GROSS` off (a quarter period: the model turns where
   the record is mid-swing) or the envelope off by more than :data:`GROSS_SHARE` of the amplitude
   lost by then (at least a fifth of the first amplitude).
2. **Start.**  The first :data:`START_TURNS` turning points (the release included when the record
   holds it whole): a finding when the record's amplitude grows among them (a free decay never
   does) and at least two of them leave the trend of the rest of the record by more than
   :data:`START_SIGMAS` of the scatter, as when a hand-guided start is fitted as a free decay.
3. **Two fits of one record.**  For a waveform fit, the turning-point fit of the same scene and
   record (``[observation] model = "amplitude"``, fitted by least squares from the waveform's
   values) and the estimates they share (omega0, the damping, the friction) compared: a
   difference beyond :data:`PARAMETER_SIGMAS` combined standard errors is a finding when it is
   also material (:data:`MATERIAL`: 0.5 % of omega0, 10 % of a damping parameter, enough to
   change what a user concludes), else a warning that the intervals are too narrow.

Findings make the fit's status "not determined" (the command line exits with status 3) with a
first warning saying what disagrees, by how much, and what to change; agreement is a note.
For a turning-point fit a drift of the *times* is a warning only: that fit does not use them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Mapping

import numpy as np

__all__ = ["Agreement", "TurnDifferences", "ParameterDifference", "check_agreement", "turn_scatter",
           "smooth_trend", "DRIFT_SIGMAS", "START_SIGMAS", "PARAMETER_SIGMAS"]

DRIFT_SIGMAS = 5.0  # a smooth drift larger than this many point scatters is a finding
START_SIGMAS = 5.0  # ... as are two of the first START_TURNS turning points beyond this many
START_TURNS = 3
START_RATIO = 2.0
PARAMETER_SIGMAS = 3.0  # waveform and turning-point estimates further apart than this (combined) disagree
GROSS_SHARE = 0.3  # a model's amplitudes this far from the record's (a share of them) describe another motion
MIN_DRIFT_TURNS = 20  # below this the scatter is too uncertain for a drift to decide the status (a warning then)
MIN_TURNS = 8  # fewer turning points measure no scatter and no drift
COMPARED = ("oscillator.omega0", "viscous.C", "coulomb.R", "drag.D")  # what both fits estimate
MATERIAL = {"oscillator.omega0": 0.005, "damping": 0.10}  # differences that change what a user concludes
PHASE_GROSS = math.pi / 2  # rad: a model a quarter period out of phase describes another motion


def _materiality() -> str:
    return (f"{100 * MATERIAL['oscillator.omega0']:g} % of omega0, {100 * MATERIAL['damping']:g} % of a damping "
            "parameter")


@dataclass(frozen=True)
class TurnDifferences:
    """Record minus model at each turning point, for one quantity.

    Attributes
    ----------
    what : str
        ``"phase"`` (rad: ``2 pi dt / period``, positive when the record turns later) or
        ``"amplitude"`` (the readings' unit, positive when the record swings further).
    swing : ndarray of int
        Turning-point numbers (0 the release).
    time : ndarray
        The record's turning times, s (its clock).
    difference : ndarray
        Record minus model.
    scatter : float
        The record's point-to-point scatter of ``difference`` (its unit): a turning point's
        standard error.
    trend : ndarray
        The smooth part of ``difference`` (:func:`smooth_trend`).
    """

    what: str
    swing: np.ndarray
    time: np.ndarray
    difference: np.ndarray
    scatter: float
    trend: np.ndarray
    size: np.ndarray | None = None  # amplitudes: the record's own at each turning point

    @property
    def gross(self) -> bool:
        """Amplitudes: whether the smooth misfit exceeds :data:`GROSS_SHARE` of the amplitude the
        record has lost by then (at least a fifth of its first amplitude) somewhere, beyond
        :data:`DRIFT_SIGMAS` scatters: the model describes another motion, not the same decay
        with a slightly different law (whose misfit grows with what was lost and stays a share of it)."""
        if self.size is None or self.drift_sigmas <= DRIFT_SIGMAS:
            return False
        size = np.abs(self.size)
        first = float(np.max(size[:3]))
        lost = np.maximum(first - size, 0.2 * first)
        return bool(np.any(np.abs(self.trend) > GROSS_SHARE * lost))

    @property
    def start_growth(self) -> float:
        """Amplitudes: the largest growth of the record's amplitude from one turning point to the
        next on the same side among the first :data:`START_TURNS` + 2, in scatters (a free decay
        never grows)."""
        if self.size is None or self.size.size < 3:
            return 0.0
        amp = np.abs(self.size[:START_TURNS + 2])
        return float(np.max(amp[2:] - amp[:-2])) / (math.sqrt(2.0) * self.scatter)  # one side: no centre error

    @property
    def sigmas(self) -> np.ndarray:
        """Each difference in units of :attr:`scatter`."""
        return np.abs(self.difference) / self.scatter

    @property
    def drift_index(self) -> int:
        """Where the trend is largest."""
        return int(np.argmax(np.abs(self.trend)))

    @property
    def drift(self) -> float:
        """The trend's largest value (signed, the difference's unit)."""
        return float(self.trend[self.drift_index])

    @property
    def drift_sigmas(self) -> float:
        """:attr:`drift` in units of :attr:`scatter`."""
        return abs(self.drift) / self.scatter

    @property
    def start_excess(self) -> np.ndarray:
        """The first :data:`START_TURNS` differences less the smooth trend of the others
        extrapolated to them (the difference's unit)."""
        rest = slice(START_TURNS, None)
        at = self.swing[:START_TURNS]
        return self.difference[:START_TURNS] - smooth_trend(self.swing[rest], self.difference[rest], at=at)

    @property
    def start_sigmas(self) -> np.ndarray:
        """:attr:`start_excess` in units of :attr:`scatter`."""
        return np.abs(self.start_excess) / self.scatter

    @property
    def start_stands_out(self) -> bool:
        """Whether the record's start departs from the model as the rest of it does not: two of
        the first :data:`START_TURNS` turning points off the trend of the others by more than
        :data:`START_SIGMAS` scatters and more than :data:`START_RATIO` times the 95th percentile
        of the others' departures from it (a misfit of the whole record, such as a damping law
        that the model lacks, is not a wrong start)."""
        rest = slice(START_TURNS, None)
        if self.swing.size < START_TURNS + MIN_TURNS:
            return False
        others = self.difference[rest] - smooth_trend(self.swing[rest], self.difference[rest])
        level = START_RATIO * float(np.quantile(np.abs(others), 0.95))
        excess = np.abs(self.start_excess)
        return int(np.sum((excess > START_SIGMAS * self.scatter) & (excess > level))) >= 2


@dataclass(frozen=True)
class ParameterDifference:
    """One estimate of the waveform fit against the turning-point fit of the same record."""

    name: str
    waveform: float
    waveform_stderr: float
    turning_points: float
    turning_points_stderr: float

    @property
    def relative(self) -> float:
        """The difference as a share of the larger of the two estimates' sizes."""
        size = max(abs(self.waveform), abs(self.turning_points))
        return abs(self.waveform - self.turning_points) / size if size > 0 else 0.0

    @property
    def material(self) -> bool:
        """Whether the difference is one a user would act on: above :data:`MATERIAL` for this estimate."""
        return self.relative > MATERIAL.get(self.name, MATERIAL["damping"])

    @property
    def sigmas(self) -> float:
        """The difference in combined standard errors (nan when either has none)."""
        se = math.hypot(self.waveform_stderr, self.turning_points_stderr)
        return abs(self.waveform - self.turning_points) / se if se > 0 else math.nan


@dataclass(frozen=True)
class Agreement:
    """What the agreement check found (see the module docstring).

    Attributes
    ----------
    fit : str
        ``"waveform"`` or ``"amplitude"``: what was fitted.
    periods : float
        Periods the compared turning points span.
    phase, amplitude : TurnDifferences or None
        The turning points compared (``None`` when too few, or not measured).
    parameters : tuple of ParameterDifference
        Waveform fits: the shared estimates against the turning-point fit.
    findings : tuple of str
        What disagrees beyond its uncertainty, as clauses; empty when everything agrees.
    cautions : tuple of str
        Disagreements that do not concern what was fitted (warnings only).
    advice : str
        What the user can change, when there are findings.
    comments : tuple of str
        What could not be compared, and why.
    """

    fit: str
    periods: float
    phase: TurnDifferences | None
    amplitude: TurnDifferences | None
    parameters: tuple = ()
    findings: tuple = ()
    cautions: tuple = ()
    advice: str = ""
    comments: tuple = field(default_factory=tuple)

    @property
    def agrees(self) -> bool:
        return not self.findings

    def statement(self) -> str:
        """The first warning of a fit that disagrees ('' when it agrees)."""
        if self.agrees:
            return ""
        return (f"the parameters are NOT determined: {'; '.join(self.findings)}: {self.advice}")

    def note(self) -> str:
        """One sentence on what agrees, for the notes."""
        parts = []
        steady = [d for d in (self.phase, self.amplitude) if d is not None and d.drift_sigmas <= DRIFT_SIGMAS]
        if steady:
            what = " and ".join("times" if d.what == "phase" else "amplitudes" for d in steady)
            z = max(d.drift_sigmas for d in steady)
            parts.append(f"the model's turning {what} follow the record's to within {z:.2g} standard errors over "
                         f"{self.periods:.0f} periods")
        if self.parameters:
            z = np.nanmax([p.sigmas for p in self.parameters] + [0.0])
            parts.append(f"the turning-point fit of the same record agrees to within {z:.2g} combined standard "
                         "errors")
        return "; ".join(parts + list(self.comments))


# -- the record's turning points against the model's -------------------------------------------

def turn_scatter(difference: np.ndarray, floor: float) -> float:
    """Robust point-to-point scatter of a sequence of turning-point differences.

    From differences of points two apart (the same side of the swing), so that an alternating
    side bias and a smooth drift do not count: ``1.4826 MAD / sqrt(2)``; at least ``floor``.
    """
    d2 = difference[2:] - difference[:-2]
    if d2.size < 3:
        return math.nan
    s = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(2.0)
    return max(s, floor)


def smooth_trend(swing: np.ndarray, difference: np.ndarray, at: np.ndarray | None = None) -> np.ndarray:
    """The smooth part of ``difference`` along the record: a quadratic in the turning-point
    number fitted with an alternating term (a side bias), the alternating term left out;
    evaluated at the turning points ``at`` (default ``swing``)."""
    at = swing if at is None else np.asarray(at)
    scale = max(float(swing[-1] - swing[0]), 1.0)

    def design(k):
        u = (k - swing[0]) / scale
        return np.column_stack([np.ones_like(u, dtype=float), u, u * u, np.where(k % 2 == 0, 1.0, -1.0)])

    coef, *_ = np.linalg.lstsq(design(swing), difference, rcond=None)
    return design(at)[:, :3] @ coef[:3]


def _model_turns(problem, values: Mapping[str, float], swings: np.ndarray):
    """The model's turning points at ``swings``: times on the record's clock (s) and signed
    readings about the model's centre (the readings' unit; amplitudes for a turning-point fit)."""
    from ..balance.solvers import solve_system

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

def turning_point_refit(problem, lsq, *, seed: int = 0):
    """The turning-point (``model = "amplitude"``) fit of a waveform problem's scene and record.

    Least squares from the waveform fit's values, checked against the measured period and with
    the held omega0's uncertainty, as ``escfit fit`` does.  Returns the least-squares result and
    the turning-point problem or, when the record's turning points cannot be fitted so, the
    reason (str).
    """
    from ..balance.problems.recorded import problem_from_series
    from ..core.errors import EscfitError
    from ..inference.lsq import least_squares
    from ..inference.reconcile import reconcile, with_held_uncertainty

    scene = problem.given_scene
    obs = {k: v for k, v in dict(scene.extra.get("observation", {})).items() if k in ("offset", "offset_rate")}
    scene = replace(scene, extra={**scene.extra, "observation": {**obs, "model": "amplitude"}})
    try:
        turns = problem_from_series(scene, problem.data, solver=problem.solver,
                                    solver_options=dict(problem.solver_options or {}), turns=problem.turning_points)
        start = {n: float(lsq.values[n]) for n in turns.names if n in lsq.values and not n.startswith("observation.")}
        fit = least_squares(turns, n_starts=1, seed=seed, start=start)
        fit, _, unresolved = reconcile(turns, fit, seed=seed)
        fit, _ = with_held_uncertainty(turns, fit)
    except (EscfitError, ValueError, ArithmeticError) as exc:
        return f"no turning-point fit to compare with ({str(exc).splitlines()[0][:160]})"
    if unresolved:
        return "the turning-point fit of this record contradicts its measured period: not compared"
    return fit, turns


def _compare_parameters(wave, turns, held_by) -> list[ParameterDifference]:
    out = []
    for name in COMPARED:
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


# -- the decision -------------------------------------------------------------------------------

def check_agreement(problem, lsq, *, seed: int = 0) -> Agreement | None:
    """Hold a fit of a sampled record against the record (see the module docstring).

    Parameters
    ----------
    problem
        A fit problem of a sampled record (:func:`escfit.balance.problems.recorded.problem_from_series`
        keeps its ``turning_points`` and ``given_scene``); ``None`` is returned for any other.
    lsq
        Its least-squares result (:class:`~escfit.inference.lsq.LeastSquaresResult`).
    seed
        For the turning-point refit of a waveform fit.

    Returns
    -------
    Agreement or None
    """
    from ..core.errors import EscfitError

    if getattr(problem, "turning_points", None) is None:
        return None
    waveform = hasattr(problem, "sample_time")
    try:
        phase, amplitude, comments = _compare_turns(problem, lsq.values)
    except (EscfitError, ValueError, ArithmeticError) as exc:
        phase, amplitude, comments = None, None, [f"the model's turning points could not be computed ({exc})"]
    findings, cautions = [], []
    unit = getattr(problem, "reading_units", "rad")
    driven = amplitude is not None and amplitude.start_growth > START_SIGMAS
    for d in (phase, amplitude):
        if d is None:
            continue
        clause = _drift_clause(d, unit)
        if driven and d.start_stands_out:
            findings.append(_start_clause(d, unit))
        elif d.drift_sigmas > DRIFT_SIGMAS:
            # the phase of a waveform fit is what it fits; an envelope or the times of a turning-point
            # fit that drift say the model misses something, without making its estimates another record's
            decisive = d.swing.size >= MIN_DRIFT_TURNS
            if decisive and ((waveform and d.what == "phase" and abs(d.drift) > PHASE_GROSS) or d.gross):
                findings.append(clause)
            else:
                cautions.append(clause + _remedy(problem, d))
    parameters: list[ParameterDifference] = []
    if waveform and getattr(problem, "given_scene", None) is not None and \
            getattr(problem, "quantity", "angle") == "angle":
        turns = turning_point_refit(problem, lsq, seed=seed)
        if isinstance(turns, str):
            comments.append(turns)
        else:
            parameters = _compare_parameters(lsq, *turns)
            bad = [p for p in parameters if p.sigmas > PARAMETER_SIGMAS]
            said = ", ".join(f"{_short(p.name)} by {p.sigmas:.2g} standard errors ({p.waveform:.4g} against "
                             f"{p.turning_points:.4g}, {100 * p.relative:.2g} %)" for p in bad)
            if any(p.material for p in bad):
                findings.append("the waveform and turning-point fits disagree on " + said)
            elif bad:
                cautions.append("the waveform and turning-point fits differ on " + said + ", beyond their "
                                "standard errors but by less than matters (" + _materiality() + "): the intervals "
                                "are too narrow for this record")
    tp = problem.turning_points
    span = float(phase.time[-1] - phase.time[0]) if phase is not None else math.nan
    periods = span / float(tp.period) if math.isfinite(span) else float(tp.swing.size) / 2.0
    advice = _advice(problem, phase, amplitude, waveform) if findings else ""
    return Agreement("waveform" if waveform else "amplitude", periods, phase, amplitude, tuple(parameters),
                     tuple(findings), tuple(cautions), advice, tuple(comments))


def _short(name: str) -> str:
    return {"oscillator.omega0": "omega0", "viscous.C": "C", "coulomb.R": "R", "drag.D": "D"}.get(name, name)


def _shown(x: float, unit: str) -> str:
    return f"{math.degrees(x):.2g} deg" if unit == "rad" else f"{x:.2g} {unit}"


def _drift_clause(d: TurnDifferences, unit: str) -> str:
    i = d.drift_index
    if d.what == "phase":
        how = "run ahead of" if d.drift > 0 else "lag behind"  # the record turning later: the model runs ahead
        return (f"the model's turning points drift out of phase with the record's (they {how} them): "
                f"{abs(d.drift):.2g} rad ({d.drift_sigmas:.0f} standard errors) by t = {d.time[i]:.4g} s")
    more = "more" if d.drift > 0 else "less"
    return (f"the record swings {_shown(abs(d.drift), unit)} {more} than the model at t = {d.time[i]:.4g} s "
            f"({d.drift_sigmas:.0f} standard errors of a turning point)")


def _remedy(problem, d: TurnDifferences) -> str:
    """What a drift of the envelope or of the times of a turning-point fit suggests."""
    names = {n.split(".")[0] for n in problem.scene.params.params}
    if d.what == "amplitude":
        missing = [f"[effects.{k}]" for k in ("drag", "coulomb") if k not in names]
        law = f" (add {' or '.join(missing)})" if missing else ""
        return f": the model's damping law does not follow the record's decay{law}; the estimates are a compromise"
    return (": the record's period changes along it (an amplitude-dependent restoring torque, a temperature drift); "
            "the turning-point fit does not use the times")


def _start_clause(d: TurnDifferences, unit: str) -> str:
    z = d.start_sigmas
    k = int(np.argmax(z))
    diff = d.start_excess[k]
    what = f"{abs(diff):.2g} rad of phase" if d.what == "phase" else _shown(abs(diff), unit)
    return (f"the record's first turning points do not follow a free decay from the release (its amplitude grows: "
            f"something drives it): turning point "
            f"{int(d.swing[k])} at t = {d.time[k]:.4g} s lies {what} ({z[k]:.0f} standard errors) from the model's")


def _advice(problem, phase, amplitude, waveform: bool) -> str:
    start = amplitude is not None and amplitude.start_growth > START_SIGMAS and any(
        d is not None and d.start_stands_out for d in (phase, amplitude))
    if start:
        return ("start the fit where the free decay starts: [recording] start (or release_s) after the last push, "
                "or leave them out so that escfit finds it")
    names = {n.split(".")[0] for n in problem.scene.params.params}
    steps = []
    if waveform:
        steps.append('fit the turning points ([observation] model = "amplitude"), which a drifting phase does '
                     "not bias")
    if problem.scene.restoring != "pendulum" and "stiffening" not in names:
        steps.append("add an amplitude-dependent restoring torque ([effects.stiffening] k3) if the period changes "
                     "with the amplitude")
    steps.append('or fit a shorter window ([recording] stop = "...")')
    return "; ".join(steps)
