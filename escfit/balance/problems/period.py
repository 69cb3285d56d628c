"""What a sampled record's measured period says about omega0, before and after a fit.

A record of the angle in time measures its own period (twice the slope of the turning times
on their number, :func:`~escfit.analysis.recordings.turning_points.period_of`).  That fixes the
natural frequency far better than any amplitude does, so it is used three ways:

- **before the fit**, a scene that fixes ``oscillator.omega0`` (or bounds it) where the
  period says otherwise is refused: every C and R fitted against a wrong frequency would be
  wrong by the same factor, with nothing in the residuals to show it;
- **turning-point amplitudes** depend on ``C/omega0``, ``R/omega0^2`` and the escapement's
  ``X/omega0^2`` only (time can be rescaled out of the equation of motion), so they cannot
  determine omega0 at all: it is held at the period's value instead of being fitted;
- **after the fit**, :func:`period_consistency` compares the fitted model's own period (its
  turning times, reduced by the same rule) with the measured one; the inference layer refits or
  says the parameters are not determined when they disagree
  (:mod:`escfit.inference.reconcile`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ...core.errors import DataError
from ...likelihood.consistency import Implied

__all__ = ["MeasuredPeriod", "measured_period", "implied_omega0", "check_pendulum_period", "PENDULUM_MAX_PERIOD", "check_scene_omega0", "hold_omega0",
           "start_omega0", "period_consistency", "held_omega0_effects", "REL_TOL", "CHECK_SIGMAS"]

REL_TOL = 0.03  # a scene's omega0 within this fraction of the period's value (plus damping) is accepted
CHECK_SIGMAS = 5.0  # a fit's period further than this many standard errors from the measured one disagrees
MIN_REL = 0.002  # ... and further than this fraction of it
PENDULUM_MAX_PERIOD = 60.0  # s: a gravity pendulum slower than this would be over 900 m long


@dataclass(frozen=True)
class MeasuredPeriod:
    """The record's period and what it was measured on.

    Attributes
    ----------
    period, stderr : float
        s.
    swings : ndarray of int
        Half swings (numbered from the reference) whose turning times gave it.
    amplitude : float
        The amplitude the period belongs to (rad, weighted as the period's regression weights
        the turning points: a pendulum's period depends on it).
    source : str
        The data file, for messages.
    """

    period: float
    stderr: float
    swings: np.ndarray
    amplitude: float
    source: str = ""

    def describe(self) -> str:
        se = f" +- {self.stderr:.2g}" if math.isfinite(self.stderr) else ""
        return f"{self.period:.5g}{se} s"


def measured_period(tp, source: str = "") -> MeasuredPeriod:
    """The period of a turning-point analysis with the swings it rests on."""
    amps = np.abs(np.r_[tp.release_theta, tp.theta] - tp.centre(np.r_[tp.release_time, tp.time]))
    n = amps.size
    if math.isfinite(getattr(tp, "stop_time", math.nan)) and n > 1 and tp.stop_time == tp.time[-1]:
        n -= 1  # a stop is no turning point of the free motion
    first = 1 if n > 3 else 0  # as reduce_series: the reference is left out when it can be
    swings = np.r_[0, np.asarray(tp.swing, np.int64)][first:n]  # half swings counted across gaps in the samples
    w = amps[first:n] ** 2
    amplitude = float(np.sum(w * amps[first:n]) / np.sum(w)) if np.sum(w) > 0 else float(np.median(amps))
    return MeasuredPeriod(float(tp.period), float(getattr(tp, "period_stderr", math.nan)), swings, amplitude, source)


def check_pendulum_period(restoring: str, mp: MeasuredPeriod) -> None:
    """Refuse a gravity pendulum whose period needs a string longer than any hall holds.

    A clock read in milliseconds as seconds makes every period a thousand times too long and
    every rate a thousand times too small, and nothing else in the record says so: a pendulum's
    length ``g (P / 2 pi)**2`` does (a period of :data:`PENDULUM_MAX_PERIOD` is 900 m).
    """
    if restoring != "pendulum" or not mp.period > PENDULUM_MAX_PERIOD:
        return
    from ...core.units import STANDARD_GRAVITY

    def length(period: float) -> str:
        metres = STANDARD_GRAVITY * (period / (2.0 * math.pi)) ** 2
        return f"{metres / 1000:.3g} km" if metres >= 1000 else (f"{metres:.3g} m" if metres >= 1 else
                                                                  f"{100 * metres:.3g} cm")

    raise DataError(f"the record's period is {mp.describe()}: a gravity pendulum that slow would be "
                    f"{length(mp.period)} long.  If the time column is in milliseconds (a period of "
                    f"{mp.period / 1000:.4g} s, {length(mp.period / 1000)}), set [recording] time_unit = \"ms\" (escfit "
                    "init --time-unit ms); a torsion or horizontal pendulum swings as a spring (--spring)", mp.source)


def implied_omega0(restoring: str, mp: MeasuredPeriod, c: float = 0.0) -> float:
    """omega0 (rad/s) whose free motion has the measured period.

    ``2 pi / P`` for a spring, ``4 K(sin^2(A/2)) / P`` for a gravity pendulum at amplitude
    ``A`` (``K`` the complete elliptic integral of the first kind); viscous damping ``c``
    (1/s) lengthens the period: ``omega0^2 = omega_1^2 + c^2/4``.
    """
    if restoring == "pendulum":
        from scipy.special import ellipk

        w1 = 4.0 * float(ellipk(math.sin(0.5 * min(mp.amplitude, 3.1)) ** 2)) / mp.period
    else:
        w1 = 2.0 * math.pi / mp.period
    return math.sqrt(w1 * w1 + 0.25 * c * c)


def _damping_range(scene) -> tuple[float, float]:
    """Smallest and largest viscous C the scene allows (1/s)."""
    if "viscous.C" not in scene.params:
        return 0.0, 0.0
    p = scene.params["viscous.C"]
    if not p.vary:
        return p.value, p.value
    return max(p.min, 0.0), (p.max if math.isfinite(p.max) else p.value)


def check_scene_omega0(scene, mp: MeasuredPeriod) -> list[str]:
    """Refuse a scene whose omega0 (fixed, or its range) contradicts the measured period.

    Returns notes; raises :class:`~escfit.core.errors.DataError` naming the measured period,
    the omega0 it implies and the scene's value or range.
    """
    if "oscillator.omega0" not in scene.params:
        return []
    p = scene.params["oscillator.omega0"]
    c_lo, c_hi = _damping_range(scene)
    lo, hi = implied_omega0(scene.restoring, mp, c_lo), implied_omega0(scene.restoring, mp, c_hi)
    slack = REL_TOL + (CHECK_SIGMAS * mp.stderr / mp.period if math.isfinite(mp.stderr) else 0.0)
    lo, hi = lo * (1.0 - slack), hi * (1.0 + slack)
    value = implied_omega0(scene.restoring, mp, c_lo)
    what = "pendulum" if scene.restoring == "pendulum" else "oscillator"
    if not p.vary and not lo <= p.value <= hi:
        raise DataError(f"the record's period is {mp.describe()} (omega0 = {value:.4g} rad/s for this {what}) but the "
                        f"scene fixes omega0 = {p.value:.4g} rad/s (a period of {2 * math.pi / p.value:.4g} s): every "
                        f"damping fitted at that frequency would be wrong; set omega0 near {value:.4g} rad/s, or let "
                        "it vary", mp.source)
    if p.vary and (p.max < lo or p.min > hi):
        raise DataError(f"the record's period is {mp.describe()} (omega0 = {value:.4g} rad/s for this {what}), outside "
                        f"the scene's range of omega0 [{p.min:.4g}, {p.max:.4g}] rad/s: widen the range, [oscillator] omega0 = "
                        f"{{ value = {value:.4g}, vary = true, min = {0.5 * value:.4g}, max = {1.5 * value:.4g} }}, or "
                        "check the time unit", mp.source)
    return []


def start_omega0(scene, mp: MeasuredPeriod) -> list[str]:
    """Start a free omega0 at the measured period's value, in place; notes."""
    if "oscillator.omega0" not in scene.params or not scene.params["oscillator.omega0"].vary:
        return []
    p = scene.params["oscillator.omega0"]
    c = scene.params["viscous.C"].value if "viscous.C" in scene.params else 0.0
    w = min(max(implied_omega0(scene.restoring, mp, c), p.min), p.max)
    scene.params.params[p.name] = replace(p, value=w)
    return [f"omega0 started at {w:.4g} rad/s from the measured period {mp.describe()}"]


def hold_omega0(scene, mp: MeasuredPeriod) -> list[str]:
    """Hold a free omega0 at the measured period's value for a turning-point fit, in place; notes."""
    if "oscillator.omega0" not in scene.params or not scene.params["oscillator.omega0"].vary:
        return []
    p = scene.params["oscillator.omega0"]
    c = scene.params["viscous.C"].value if "viscous.C" in scene.params else 0.0
    w = implied_omega0(scene.restoring, mp, c)
    scene.params.params[p.name] = replace(p, value=w, vary=False, prior=None)
    rel = f" (+- {100 * mp.stderr / mp.period:.2g} %)" if math.isfinite(mp.stderr) else ""
    return [f"omega0 held at {w:.5g} rad/s{rel}, the value of the measured period {mp.describe()}: turning-point "
            "amplitudes depend only on C/omega0 and R/omega0^2, so they cannot determine omega0 (fit every sample, "
            "[observation] model = \"waveform\", to estimate it with the damping)"]


def model_period(problem, values) -> float:
    """The fitted model's period (s), its turning times reduced as the record's were."""
    from ...analysis.recordings.turning_points import period_of
    from ..solvers import solve_system

    mp = problem.measured_period
    n = int(mp.swings.max()) if mp.swings.size else 0
    if n < 2:
        return math.nan
    sys = problem.scene.system(values)
    tr = solve_system(sys, n, problem.solver, **dict(problem.solver_options or {}))
    times = np.r_[0.0, np.asarray(tr.time, float)]
    amps = np.r_[abs(sys.theta0), np.asarray(tr.amplitude, float)]
    if times.size <= n:
        return math.nan
    return period_of(times[mp.swings], amps[mp.swings], mp.swings)[0]


def period_consistency(problem, values) -> list[Implied]:
    """omega0 against the measured period at the fitted ``values`` (empty when nothing was measured)."""
    mp = getattr(problem, "measured_period", None)
    if mp is None or "oscillator.omega0" not in values:
        return []
    try:
        p_model = model_period(problem, values)
    except (ValueError, ArithmeticError, DataError):
        return []
    if not math.isfinite(p_model) or p_model <= 0:
        return []
    w = float(values["oscillator.omega0"])
    implied = w * p_model / mp.period  # exact for a rescaling of time (amplitude readings), close otherwise
    se = mp.stderr if math.isfinite(mp.stderr) else 0.0
    tolerance = max(CHECK_SIGMAS * se, MIN_REL * mp.period) / mp.period * w
    return [Implied("oscillator.omega0", w, implied, tolerance,
                    f"the fitted model's period is {p_model:.5g} s where the record's is {mp.describe()}")]


#: the exponent of time in the parameters' canonical units, read without pint (held against pint in tests)
TIME_POWERS = {"": 0.0, "rad": 0.0, "deg": 0.0, "1/rad": 0.0, "1/rad**2": 0.0, "m": 0.0, "s": 1.0, "1/s": -1.0,
               "rad/s": -1.0, "1/s**2": -2.0, "rad/s**2": -2.0}


def _time_power(unit: str) -> float:
    """Exponent of time in a unit (-1 for 1/s, -2 for rad/s^2); 0 when it has none or is unknown."""
    if not unit:
        return 0.0
    if unit in TIME_POWERS:
        return TIME_POWERS[unit]
    from ...core.units import registry

    ureg = registry()

    try:
        return float(ureg.Quantity(1.0, unit).dimensionality.get("[time]", 0.0))
    except Exception:  # noqa: BLE001 - a unit pint cannot read scales with nothing
        return 0.0


def held_omega0_effects(problem, values) -> list[tuple[str, float, dict[str, float]]]:
    """The held omega0's standard error and how the fitted parameters move with it.

    Turning-point amplitudes fix only time-free combinations (``C/omega0``, ``R/omega0^2``):
    along the family of equally good fits a parameter whose unit holds time to the power
    ``-k`` moves as ``omega0^k``, so its derivative is ``k * value / omega0``.
    """
    mp = getattr(problem, "measured_period", None)
    if mp is None or "oscillator.omega0" not in getattr(problem, "held", ()) or not math.isfinite(mp.stderr):
        return []
    w = float(values["oscillator.omega0"])
    se = w * mp.stderr / mp.period
    slopes = {}
    for name in problem.names:
        if name.startswith("observation."):  # read against the record's own clock: they do not rescale
            continue
        k = -_time_power(problem.params[name].unit)
        if k:
            slopes[name] = k * float(values[name]) / w
    return [("oscillator.omega0", se, slopes)]
