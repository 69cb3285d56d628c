"""The fit held against the record: the model's turning points against the measured ones.

Residual statistics (runs, lag-1 correlation) say *that* a fit misses something, not *what*,
and a waveform fit of a long record can drift out of phase with it while every one of them
only grumbles.  This last check compares what the fitted model does with what the record
itself measured, independently of the likelihood:

1. **Turning points.**  The model is run once from the fitted release to the record's last
   turning point; each of its turning points is compared with the record's (the turning-point
   analysis, :mod:`escfit.analysis.recordings.turning_points`): the time difference as a phase,
   ``2 pi (t_record - t_model) / period`` (rad, positive: the record turns later), and the
   amplitude difference (the record's amplitude minus the model's, in the readings' unit).
   Each is measured in units of the record's own point-to-point scatter of that difference
   (robust, from differences of turning points two apart, so that a smooth drift and an
   alternating side bias do not count as scatter).  A **drift** is the smooth part: a
   polynomial of degree 2 in the turning-point number (a frequency that drifts linearly moves
   the phase quadratically), plus an alternating term; it is a warning when its largest value
   along the record exceeds :data:`DRIFT_SIGMAS` of that scatter, and a finding when it is also
   gross: the phase more than :data:`PHASE_GROSS` off (a quarter period: the model turns where
   the record is mid-swing) or the envelope off by more than :data:`GROSS_SHARE` both of the
   record's amplitude there and of the amplitude lost by then (at least a fifth of the first).
2. **Start.**  The first :data:`START_TURNS` turning points (the release included when the record
   holds it whole): a finding when the record's amplitude grows among them (a free decay never
   does) and at least two of them leave the trend of the rest of the record by more than
   :data:`START_SIGMAS` of the scatter, as when a hand-guided start is fitted as a free decay.
3. **End.**  The last :data:`END_TURNS` turning points: a finding when, from one of them to the
   record's end, every one leaves the trend of the rest of the record by more than
   :data:`START_SIGMAS` of the scatter and :data:`START_RATIO` times the 95th percentile of the
   others' departures from it, more than the model misses any of the others by, and by more
   than :data:`END_PHASE` of phase or :data:`GROSS_SHARE` of the amplitude: the record ends in another motion (a
   hand that stops the swing, a take spliced on), which a free decay fitted to the whole record
   bends to.  The advice names ``[recording] stop`` at the last turning point that follows.
4. **Two fits of one record.**  For a waveform fit, the turning-point fit of the same scene and
   record (``[observation] model = "amplitude"``, fitted by least squares from the waveform's
   values) and the estimates they share (omega0, the damping, the friction) compared: a
   difference beyond :data:`PARAMETER_SIGMAS` combined standard errors is a finding when it is
   also material (:data:`MATERIAL`: 0.5 % of omega0, 10 % of a damping parameter, enough to
   change what a user concludes), else a warning that the intervals are too narrow.  When the
   material differences are only of damping parameters and go both ways (one loss larger, the
   other smaller: a trade along the ridge of losses), those parameters are not determined by the
   record while the rest stands: the fit is "partly determined".

Findings make the fit's status "not determined" (the command line exits with status 3) with a
first warning saying what disagrees, by how much, and what to change; agreement is a note.
For a turning-point fit a drift of the *times* is a warning only: that fit does not use them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .decrement_law import LAW_DRIFTS, LESS_AT_LARGE, law_mismatch, refuted_caution
from .turn_trend import smooth_trend, trend_spread, turn_scatter

__all__ = ["Agreement", "TurnDifferences", "ParameterDifference", "ModelFacts", "judge", "turn_scatter",
           "smooth_trend", "DRIFT_SIGMAS", "START_SIGMAS", "PARAMETER_SIGMAS"]

DRIFT_SIGMAS = 5.0  # a smooth drift larger than this many point scatters is a finding
START_SIGMAS = 5.0  # ... as are two of the first START_TURNS turning points beyond this many
START_TURNS = 3
START_RATIO = 2.0
END_TURNS = 3  # the last turning points checked for an end in another motion (a hand, a take spliced on)
END_PHASE = math.pi / 4  # rad: an end out of phase by an eighth of a period is another motion
END_SHARE = 0.1  # ... as is one whose amplitude leaves the trend by this share of the first amplitude
PARAMETER_SIGMAS = 3.0  # waveform and turning-point estimates further apart than this (combined) disagree
GROSS_SHARE = 0.3  # a model's amplitudes this far from the record's (a share of them) describe another motion
MIN_DRIFT_TURNS = 20  # below this the scatter is too uncertain for a drift to decide the status (a warning then)
MIN_TURNS = 8  # fewer turning points measure no scatter and no drift
MATERIAL = {"oscillator.omega0": 0.005, "damping": 0.10}  # differences that change what a user concludes
PHASE_GROSS = math.pi / 2  # rad: a model a quarter period out of phase describes another motion
WANDER_TURNS = 6  # turning points averaged (three of each side) to see an envelope's slow wander
WANDER_NOISE = 3.0  # a wander counts when its averages spread this many times what reading noise gives
WANDER_SHARE = 0.2  # ... and it reaches this share of what separates a viscous from a friction decay (a fit
# absorbs what it can of a wander, so what is left understates how far it moved the split)


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
        """Amplitudes: whether the smooth misfit exceeds :data:`GROSS_SHARE` both of the record's
        amplitude and of the amplitude it has lost by then (at least a fifth of its first)
        somewhere, beyond :data:`DRIFT_SIGMAS` scatters: the model describes another motion, not
        the same decay with a slightly different law (whose misfit stays a share of what was lost
        early on, and of what is left late)."""
        if self.size is None or self.drift_sigmas <= DRIFT_SIGMAS:
            return False
        size = np.abs(self.size)
        first = float(np.max(size[:3]))
        lost = np.maximum(first - size, 0.2 * first)
        return bool(np.any(np.abs(self.trend) > GROSS_SHARE * np.maximum(lost, size)))

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


    def end_break(self, size: np.ndarray | None = None) -> int | None:
        """Index of the first turning point of the record's end in another motion, or None.

        From that turning point (one of the last :data:`END_TURNS`) to the last, every one leaves
        the trend of the others, extrapolated, by more than :data:`START_SIGMAS` times its spread
        (its own scatter and the extrapolated trend's, combined) and more than :data:`START_RATIO`
        times the 95th percentile of the others' departures from the trend, more than the model
        misses any of the others by, and by what makes it another motion: :data:`END_PHASE` of
        phase where the swing is still at least :data:`END_SHARE` of its first amplitude, or
        :data:`GROSS_SHARE` of the amplitude there and :data:`END_SHARE` of the first.  Smaller
        departures move the estimates by less than matters, and are left to the drift warnings.

        Parameters
        ----------
        size : ndarray, optional
            The record's amplitudes at the same turning points (default: :attr:`size`); without
            them nothing is decided.
        """
        n = self.swing.size
        size = self.size if size is None else size
        if n < END_TURNS + MIN_TURNS or size is None or np.shape(size) != self.swing.shape:
            return None
        rest, tail = slice(None, n - END_TURNS), slice(n - END_TURNS, None)
        trend = smooth_trend(self.swing[rest], self.difference[rest], at=self.swing)
        others = self.difference[rest] - trend[rest]
        # a tail turning point's own scatter and that of the trend extrapolated to it
        spread = self.scatter * np.sqrt(1.0 + trend_spread(self.swing[rest], self.swing[tail]) ** 2)
        level = np.maximum(START_SIGMAS * spread, START_RATIO * float(np.quantile(np.abs(others), 0.95)))
        # ... and more than the model misses the record by anywhere before (a damping law the model
        # lacks bends its misfit in ways a quadratic trend does not follow to the end)
        level = np.maximum(level, float(np.max(np.abs(self.difference[rest]))))
        excess = np.abs(self.difference[tail] - trend[tail])
        first, here = float(np.max(np.abs(size[:3]))), np.abs(size[tail])
        if self.what == "phase":  # a phase is measured where the swing is well above the noise
            material = (excess > END_PHASE) & (here >= END_SHARE * first)
        else:
            material = (excess > GROSS_SHARE * here) & (excess > END_SHARE * first)
        out = (excess > level) & material
        for k in range(END_TURNS):
            if out[k:].all():
                return n - END_TURNS + k
        return None


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
    undetermined : tuple of str
        Damping parameters the two fits trade against each other (one larger, the other smaller):
        not determined by the record, while the rest of the fit stands.
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
    undetermined: tuple = ()

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

@dataclass(frozen=True)
class EnvelopeWander:
    """How far a record's envelope wanders about the model's, against what splits C from R.

    A viscous loss (C) takes a fixed share of the amplitude each swing, a friction loss (R) a
    fixed amount: the two are told apart only by the curvature of the decay.  An envelope that
    wanders slowly about any smooth decay (a bob that does not swing in a plane, a tracking
    drift), by a fair share of the difference between the two decays, leaves their split to that
    wander, whatever the standard errors computed for white noise say.

    Attributes
    ----------
    wander : float
        Root mean square of the record-minus-model amplitudes averaged over
        :data:`WANDER_TURNS` turning points, less what the reading noise alone gives (the
        readings' unit; 0 when within it).
    noise : float
        What reading noise alone gives those averages: the point scatter over
        ``sqrt(WANDER_TURNS)``.
    separation : float
        Root mean square difference between an exponential decay (viscous only) and a straight
        decay (friction only), each fitted to the record's turning-point amplitudes (the readings'
        unit).
    """

    wander: float
    noise: float
    separation: float

    @property
    def splits(self) -> bool:
        """Whether the wander leaves C and R unsplit: its averages spread more than
        :data:`WANDER_NOISE` times the noise's and it reaches :data:`WANDER_SHARE` of the separation."""
        spread = math.hypot(self.wander, self.noise)
        return spread > WANDER_NOISE * self.noise and self.wander >= WANDER_SHARE * self.separation

    def clause(self, unit: str, short: tuple, *, loss_stands: bool = True) -> str:
        """The caution, for the loss parameters of symbols ``short`` (``("C", "R")``); the swing's
        loss is said to stand unless ``loss_stands`` is false (another caution says the law misses)."""
        which = ", ".join(short[:-1]) + " and " + short[-1]
        stands = "the swing's loss and the other parameters stand" if loss_stands else "the other parameters stand"
        return (f"{which} are not determined by this record: its envelope wanders by {_shown(self.wander, unit)} "
                f"(root mean square, over {WANDER_TURNS} turning points) about the fitted decay, "
                f"{100.0 * self.wander / self.separation:.0f} % of the {_shown(self.separation, unit)} that "
                f"separates a viscous decay from a friction decay through the same amplitudes; {stands}; a record "
                "without the wander, a longer one, or fixing one of them separates them")


def envelope_wander(amplitude: TurnDifferences) -> EnvelopeWander | None:
    """The wander of ``amplitude``'s differences against the C-R separation (None with fewer than
    two averages of :data:`WANDER_TURNS` turning points, or no record amplitudes)."""
    if amplitude.size is None or amplitude.swing.size < 3 * WANDER_TURNS:
        return None
    d = amplitude.difference
    m = (d.size // 2) * 2
    pairs = 0.5 * (d[0:m:2] + d[1:m:2])  # both sides: no side bias
    w = WANDER_TURNS // 2
    means = np.convolve(pairs, np.ones(w) / w, mode="valid")
    noise = amplitude.scatter / math.sqrt(WANDER_TURNS)
    spread = float(np.sqrt(np.mean(means ** 2)))
    wander = math.sqrt(max(spread ** 2 - noise ** 2, 0.0))
    k = amplitude.swing.astype(float)
    a = np.abs(amplitude.size)
    if np.any(a <= 0):
        return None
    exp_fit = np.exp(np.polyval(np.polyfit(k, np.log(a), 1), k))
    line_fit = np.polyval(np.polyfit(k, a, 1), k)
    separation = float(np.sqrt(np.mean((exp_fit - line_fit) ** 2)))
    return EnvelopeWander(wander, noise, separation)


# -- the decision -------------------------------------------------------------------------------

@dataclass(frozen=True)
class ModelFacts:
    """What the decision needs of the fitted model: whether it fitted every sample, the readings'
    unit, its effects (``"drag"``, ``"coulomb"`` ...), its restoring law, and the coefficients
    of its dissipative effects with their symbols (``(("viscous.C", "C"), ("coulomb.R", "R"))``,
    the model family's registry's order): the losses a wandering envelope leaves unsplit."""

    waveform: bool
    unit: str = "rad"
    effects: frozenset = frozenset()
    restoring: str = "spring"
    losses: tuple = ()

    def short(self, name: str) -> str:
        """A parameter's symbol in sentences (``"C"``, ``"omega0"``), else its name."""
        return "omega0" if name == "oscillator.omega0" else dict(self.losses).get(name, name)


def judge(phase: TurnDifferences | None, amplitude: TurnDifferences | None, parameters: list[ParameterDifference],
          model: ModelFacts, *, periods: float, comments: list[str]) -> Agreement:
    """The findings, warnings and advice of the comparisons (see the module docstring).

    Parameters
    ----------
    phase, amplitude : TurnDifferences or None
        The record's turning points against the model's.
    parameters : list of ParameterDifference
        A waveform fit's estimates against the turning-point fit's (empty for other fits).
    model : ModelFacts
        What was fitted.
    periods : float
        Periods the compared turning points span.
    comments : list of str
        What could not be compared.

    Returns
    -------
    Agreement
    """
    findings, cautions = [], []
    driven = amplitude is not None and amplitude.start_growth > START_SIGMAS
    for d in (phase, amplitude):
        if d is None:
            continue
        clause = _drift_clause(d, model.unit)
        if driven and d.start_stands_out:
            findings.append(_start_clause(d, model.unit))
        elif d.drift_sigmas > DRIFT_SIGMAS:
            # the phase of a waveform fit is what it fits; an envelope or the times of a turning-point
            # fit that drift say the model misses something, without making its estimates another record's
            decisive = d.swing.size >= MIN_DRIFT_TURNS
            if decisive and ((model.waveform and d.what == "phase" and abs(d.drift) > PHASE_GROSS) or d.gross):
                findings.append(clause)
            else:
                cautions.append(clause + _remedy(model, d))
    ends = _end_breaks(phase, amplitude)
    if ends and not findings:
        findings.append(_end_clause(*ends[0], model.unit))
    bad = [p for p in parameters if p.sigmas > PARAMETER_SIGMAS]
    wander = envelope_wander(amplitude) if amplitude is not None and not findings else None
    unsplit = wander is not None and wander.splits and {"viscous", "coulomb"} <= model.effects
    losses = tuple(n for n, _ in model.losses)
    traded = [p for p in bad if p.material and p.name in losses] if unsplit else []
    if unsplit:  # the split of the losses is the wander's: their differences decide nothing, the rest does
        bad = [p for p in bad if p.name not in losses]
    said = ", ".join(f"{model.short(p.name)} by {p.sigmas:.2g} standard errors ({p.waveform:.4g} against "
                     f"{p.turning_points:.4g}, {100 * p.relative:.2g} %)" for p in bad)
    material = [p for p in bad if p.material]
    split = _split_only(material) and not findings
    undetermined: tuple = ()
    if unsplit:
        undetermined = losses
        trade = ", ".join(f"{model.short(p.name)} {p.waveform:.4g} against {p.turning_points:.4g}" for p in traded)
        drifts = any(LAW_DRIFTS in c for c in cautions)
        cautions.insert(0, wander.clause(model.unit, tuple(model.short(n) for n in losses), loss_stands=not drifts) + (
            f"; the waveform and turning-point fits trade one loss for the other too ({trade})"
            if _split_only(traded) else ""))
    if split:  # one loss traded for another: the split is not determined, the rest stands
        undetermined = tuple(p.name for p in material)
        cautions.insert(0, f"{' and '.join(model.short(n) for n in undetermined)} are not determined by this record: the "
                           f"waveform and turning-point fits trade one loss for the other ({said}); their sum, the "
                           "swing's loss, and the other parameters agree; a longer record, one at larger "
                           "amplitude, or fixing one of them separates them")
    elif material:
        findings.append("the waveform and turning-point fits disagree on " + said)
    elif bad:
        cautions.append("the waveform and turning-point fits differ on " + said + ", beyond their standard errors "
                        "but by less than matters (" + _materiality() + "): the intervals are too narrow for this "
                        "record")
    said = unsplit or findings or any(c.startswith("the record swings ") for c in cautions)  # a wander, a drift
    refuted = "" if said or not model.losses else refuted_caution(
        amplitude, lambda v: _shown(v, model.unit), " and ".join(model.short(n) for n, _ in model.losses),
        "drag" in model.effects)
    if refuted:
        cautions.insert(0, refuted)
        undetermined = tuple(dict.fromkeys(tuple(undetermined) + losses))
    advice = _advice(model, phase, amplitude) if findings else ""
    return Agreement("waveform" if model.waveform else "amplitude", periods, phase, amplitude, tuple(parameters),
                     tuple(findings), tuple(cautions), advice, tuple(comments), undetermined)


def _split_only(material: list[ParameterDifference]) -> bool:
    """Whether the material differences are only between damping parameters, some larger and some
    smaller in the waveform fit than in the turning-point fit (a trade along the ridge of losses)."""
    if len(material) < 2 or any(p.name == "oscillator.omega0" for p in material):
        return False
    signs = {math.copysign(1.0, p.waveform - p.turning_points) for p in material}
    return signs == {1.0, -1.0}


def _shown(x: float, unit: str) -> str:
    return f"{math.degrees(x):.2g} deg" if unit == "rad" else f"{x:.2g} {unit}"


def _drift_clause(d: TurnDifferences, unit: str) -> str:
    i = d.drift_index
    if d.what == "phase":
        how = "run ahead of" if d.drift > 0 else "lag behind"  # the record turning later: the model runs ahead
        return (f"the model's turning points drift out of phase with the record's (they {how} them by up "
                f"to {abs(d.drift):.2g} rad, {d.drift_sigmas:.0f} standard errors, at t = {d.time[i]:.4g} s)")
    more = "more" if d.drift > 0 else "less"
    return (f"the record swings {_shown(abs(d.drift), unit)} {more} than the model at t = {d.time[i]:.4g} s "
            f"({d.drift_sigmas:.0f} standard errors of a turning point)")


def _remedy(model: ModelFacts, d: TurnDifferences) -> str:
    """What a drift of the envelope or of the times of a turning-point fit suggests."""
    if d.what == "amplitude":
        missing = [f"[effects.{k}]" for k in ("drag", "coulomb") if k not in model.effects]
        law = f" (add {' or '.join(missing)})" if missing else ""
        losses = law_mismatch(d.swing, d.size, np.abs(d.size) - d.difference) if d.size is not None else None
        if losses is not None and losses.at_large < 0:  # no law escfit adds loses less at large amplitude
            law = f"; {LESS_AT_LARGE}"
        return f": {LAW_DRIFTS}{law}; the estimates are a compromise"
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


def _end_breaks(phase, amplitude) -> list[tuple[TurnDifferences, int]]:
    """The comparisons whose record ends in another motion, with the index where it starts
    (amplitudes first; the phase judged with the record's amplitudes at the same turning points)."""
    size = amplitude.size if amplitude is not None else None
    found = []
    for d in (amplitude, phase):
        k = d.end_break(size) if d is not None else None
        if k is not None:
            found.append((d, k))
    return found


def _end_clause(d: TurnDifferences, k: int, unit: str) -> str:
    rest = slice(None, d.swing.size - END_TURNS)
    off = float(d.difference[k] - smooth_trend(d.swing[rest], d.difference[rest], at=d.swing[k:k + 1])[0])
    what = f"{abs(off):.2g} rad of phase" if d.what == "phase" else _shown(abs(off), unit)
    return (f"the record's last turning points do not follow the decay of the others (the swing was stopped, or "
            f"the record ends in another motion): turning point {int(d.swing[k])} at t = {d.time[k]:.4g} s lies "
            f"{what} ({abs(off) / d.scatter:.0f} standard errors) from the trend of the rest")


def _end_stop(phase, amplitude) -> float | None:
    """The time of the last turning point before the record's end in another motion, s."""
    ends = _end_breaks(phase, amplitude)
    if not ends:
        return None
    d, k = min(ends, key=lambda dk: dk[0].time[dk[1]])
    return float(d.time[k - 1])


def _advice(model: ModelFacts, phase, amplitude) -> str:
    start = amplitude is not None and amplitude.start_growth > START_SIGMAS and any(
        d is not None and d.start_stands_out for d in (phase, amplitude))
    if start:
        return ("start the fit where the free decay starts: [recording] start (or release) after the last push, "
                "or leave them out so that escfit finds it")
    stop = _end_stop(phase, amplitude)
    if stop is not None:
        return (f"end the fit where the free decay ends: [recording] stop = {stop:.4g} (or --stop {stop:.4g}), the "
                "last turning point that follows it")
    steps = []
    if model.waveform:
        steps.append('fit the turning points ([observation] model = "amplitude"), which a drifting phase does '
                     "not bias")
    if model.restoring != "pendulum" and "stiffening" not in model.effects:
        steps.append("add an amplitude-dependent restoring torque ([effects.stiffening] k3) if the period changes "
                     "with the amplitude")
    steps.append('or fit a shorter window ([recording] stop = "...")')
    return "; ".join(steps)
