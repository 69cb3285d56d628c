"""The angle's unit checked against a pendulum's own clock: its period grows with its amplitude.

A gravity pendulum's period depends on its amplitude ``A`` (rad) through the complete elliptic
integral ``K``::

    T(A) = T0 * (2 / pi) * K(m),   m = sin(A / 2)**2    (T(A) ~ T0 (1 + A**2/16 + ...))

so a record of a decaying pendulum measures its amplitude in radians twice: once in the readings,
once in how its period shortens as it decays.  The periods are timed between upward zero crossings
(where the swing is fastest and its time best measured), each with its amplitude.  Radians read as
degrees make every amplitude 57 times too small: the period would hardly change as the swing
decays, where the record's does.  (Degrees read as radians need no clock: a swing of tens of
radians is refused by its size.)

:func:`unit_from_period` fits the record's periods against both readings of the unit, as read
(``scale`` 1) and 180/pi times the amplitudes, with ``T0`` free each time, and compares each
misfit with that of a free curve ``T0 (1 + k1 A**2 + k2 A**4)`` (the noise).  The verdict:

- ``"radians read as degrees"``: 180/pi times fits within :data:`ACCEPT`, the unit as read
  misfits by :data:`DECIDE` more (two readings with one free parameter each: a likelihood
  ratio of some 3e6), and the swing as read is below :data:`SMALL_AS_READ`;
- ``"as read"``: the unit as read fits within :data:`ACCEPT` and the other misfits by
  :data:`DECIDE` more;
- ``"unlike a pendulum"``: the unit as read is rejected and no other reading explains the
  periods (a wrong scale, or no gravity pendulum);
- ``"undecided"``: the amplitudes change too little to tell.

Only free pendulums (a gravity restoring torque, no stiffening effect) are checked: a balance's
hairspring and a mass on a spring have no such clock.

Its waveform is a second witness: a large swing is flattened (it lingers at the turning points,
where ``sin(theta) < theta`` pulls it back less), by a third harmonic of exactly
``q (1 + q) / (3 (1 + q**3))`` of the fundamental (``q`` the elliptic nome,
:func:`third_harmonic_ratio`; ``A**2/192`` to lowest order).  :func:`waveform_shape` measures the
record's, period by period, from :data:`SHAPE_FROM` (60 deg, 0.6 %) up: a column read as an angle
of 60-179 deg whose swing is a plain sinusoid (pixels, millimetres read as degrees) is suspect.
Only suspect: an angle taken from a video track about a pivot placed a fraction ``e`` of the
length off is ``theta - e sin(theta)`` to first order, which adds ``e A**2/24`` to the third
harmonic in the opposite sense and cancels the pendulum's ``A**2/192`` at ``e = 1/8``.  A swing of
180 deg or more goes over the top: no pendulum swings back from it, whatever the sensor
(:func:`escfit.analysis.quantity.swing_unit_check` refuses it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["UnitEvidence", "unit_from_period", "swing_periods", "pendulum_period_factor", "REJECT", "ACCEPT", "DECIDE",
           "MIN_PERIODS", "third_harmonic_ratio", "waveform_shape", "ShapeEvidence", "SHAPE_FROM", "SHAPE_TOL",
           "SHAPE_SIGMA"]

REJECT = 50.0  # chi-square above the free curve's: the scale is rejected
DECIDE = 30.0  # one reading's chi-square this far below the other's decides between them (a likelihood ratio ~3e6)
ACCEPT = 16.0  # ... within this: the scale fits as well as the free curve (4 sigma, one parameter)
MIN_PERIODS = 10
LINEAR_PART = 0.3  # samples within this share of the amplitude of zero time a crossing
MIN_GAP = 0.75  # an upward crossing sooner than this share of the median interval after the last is noise
SCALES = {"as read": 1.0, "radians read as degrees": 180.0 / math.pi}
SMALL_AS_READ = math.radians(3.0)  # radians read as degrees swing at most ~3 "degrees" (3 rad is over the top)


def pendulum_period_factor(amplitude: np.ndarray) -> np.ndarray:
    """``T(A) / T0`` of a gravity pendulum swinging ``amplitude`` rad (exact, complete elliptic integral)."""
    from scipy.special import ellipk

    a = np.abs(np.asarray(amplitude, dtype=float))
    with np.errstate(divide="ignore"):
        return np.where(a < math.pi, 2.0 / math.pi * ellipk(np.sin(np.minimum(a, math.pi) / 2.0) ** 2), math.inf)


@dataclass(frozen=True)
class UnitEvidence:
    """What the periods say of the angle's unit.

    Attributes
    ----------
    misfit : dict of str to float
        Chi-square of each reading of the unit (keys of :data:`SCALES`) above the free curve's.
    periods : int
        Full periods compared.
    amplitudes : (float, float)
        Smallest and largest amplitude compared, rad as read.
    verdict : str
        ``"as read"`` (the unit agrees), another key of :data:`SCALES` (the unit is wrong that
        way), or ``"undecided"`` (the amplitudes change too little to tell).
    """

    misfit: dict
    periods: int
    amplitudes: tuple
    verdict: str

    def sentence(self) -> str:
        """The evidence in words (a note when the unit agrees, the refusal's reason when not)."""
        lo, hi = self.amplitudes
        span = f"{math.degrees(lo):.3g} to {math.degrees(hi):.3g} deg as read"
        if self.verdict == "undecided":
            return (f"the pendulum's period changes too little over {span} to check the angle's unit "
                    f"({self.periods} periods)")
        if self.verdict == "unlike a pendulum":
            change = 100.0 * float(pendulum_period_factor(np.array([hi]))[0] / pendulum_period_factor(np.array([lo]))[0] - 1)
            return (f"the period does not change with the amplitude as a gravity pendulum's does ({self.periods} "
                    f"periods, {span}; a pendulum's would be {change:.2g} % longer at the largest swing than at "
                    f"the smallest; the misfit is {self.misfit['as read']:.0f} chi-square above the best curve)")
        if self.verdict == "as read":
            return (f"the angle's unit agrees with how the pendulum's period shortens as it decays ({self.periods} "
                    f"periods, {span})")
        wrong = self.verdict
        return (f"the pendulum's period changes with its amplitude ({self.periods} periods, {span}) as it does only "
                f"if the angles are 57 times larger: {wrong} (the misfit of the unit as read is "
                f"{self.misfit['as read']:.0f} chi-square above the best curve, {self.misfit[wrong]:.1f} for {wrong})")


def swing_periods(time: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Full periods between upward zero crossings of a centred swing, s, and the amplitude of
    each period (half its peak-to-peak), in the readings' unit.

    Each crossing is where the swing is fastest, so its time is the best measured: a straight
    line is fitted to the samples within :data:`LINEAR_PART` of the amplitude of zero on either
    side (a symmetric window: the sine's cubic term, odd about the crossing, does not move it).
    Reading noise can cross zero back and forth where the swing does (a downward crossing read
    down, up, down makes an upward one half a period early): an upward crossing within
    :data:`MIN_GAP` of the typical interval after the last one kept is no swing's.
    """
    t = np.asarray(time, dtype=float)
    x = np.asarray(theta, dtype=float)
    up = _swing_crossings(t, np.flatnonzero((x[:-1] < 0.0) & (x[1:] >= 0.0)))
    if up.size < 3:
        return np.zeros(0), np.zeros(0)
    hi = np.maximum.reduceat(x, up)[:-1]
    lo = np.minimum.reduceat(x, up)[:-1]
    amp = (hi - lo) / 2.0
    cross = np.empty(up.size - 1)
    for k, i in enumerate(up[:-1]):
        near = LINEAR_PART * amp[k]
        a, b = i, i + 1
        while a > 0 and abs(x[a - 1]) < near and x[a - 1] < 0.0:
            a -= 1
        while b < x.size - 1 and abs(x[b + 1]) < near and x[b + 1] >= 0.0:
            b += 1
        n = min(i - a, b - i - 1)  # as many samples below the crossing as above
        seg = slice(i - n, i + 2 + n)
        tt, xx = t[seg], x[seg]
        slope, icpt = np.polyfit(tt - t[i], xx, 1)
        cross[k] = t[i] - icpt / slope if slope > 0 else t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])
    return np.diff(cross), amp[:-1]


def _swing_crossings(t: np.ndarray, up: np.ndarray) -> np.ndarray:
    """The upward crossings ``up`` (sample indices) less those that follow the last one kept by
    under :data:`MIN_GAP` of the median interval (noise crossing back and forth)."""
    if up.size < 3:
        return up
    gap = MIN_GAP * float(np.median(np.diff(t[up])))
    kept = [int(up[0])]
    for i in up[1:]:
        if t[i] - t[kept[-1]] >= gap:
            kept.append(int(i))
    return np.array(kept, dtype=up.dtype)


def unit_from_period(time: np.ndarray, theta: np.ndarray) -> UnitEvidence | None:
    """Judge the angle's unit from a pendulum's swing (see the module docstring).

    Parameters
    ----------
    time : ndarray
        Sample times, s, increasing.
    theta : ndarray
        The angle about the swing's centre, rad as read.

    Returns
    -------
    UnitEvidence or None
        None when there are fewer than :data:`MIN_PERIODS` full periods.
    """
    period, amp = swing_periods(time, theta)
    ok = np.isfinite(period) & np.isfinite(amp) & (period > 0) & (amp > 0)
    period, amp = period[ok], amp[ok]
    if period.size < MIN_PERIODS:
        return None
    a2 = amp ** 2 / max(float(np.max(amp ** 2)), 1e-300)
    design = np.column_stack([np.ones_like(a2), a2, a2 ** 2])
    coef, *_ = np.linalg.lstsq(design, period, rcond=None)
    free = period - design @ coef
    d = np.diff(period)  # noise from neighbouring differences, robust to a misfit smooth along the record
    sigma = max(1.4826 * float(np.median(np.abs(d - np.median(d)))) / math.sqrt(2.0),
                float(np.sqrt(np.mean(free ** 2))), 1e-9 * float(np.median(period)))
    chi_free = float(np.sum(free ** 2)) / sigma ** 2
    misfit = {}
    for name, scale in SCALES.items():
        shape = pendulum_period_factor(scale * amp)
        if not np.all(np.isfinite(shape)):
            misfit[name] = math.inf  # a swing over the top is no pendulum's swing
            continue
        t0 = float(np.dot(shape, period) / np.dot(shape, shape))
        misfit[name] = max(0.0, float(np.sum((period - t0 * shape) ** 2)) / sigma ** 2 - chi_free)
    wrong = "radians read as degrees"
    if misfit["as read"] - misfit[wrong] > DECIDE and misfit[wrong] < ACCEPT and float(amp.max()) < SMALL_AS_READ:
        verdict = wrong
    elif misfit[wrong] - misfit["as read"] > DECIDE and misfit["as read"] < ACCEPT:
        verdict = "as read"
    elif misfit["as read"] > REJECT:
        verdict = "unlike a pendulum"
    else:
        verdict = "undecided"
    return UnitEvidence(misfit, int(period.size), (float(amp.min()), float(amp.max())), verdict)


# -- the waveform: a large swing is flattened ------------------------------------------------------
SHAPE_FROM = math.radians(60.0)  # from this amplitude on the third harmonic (0.6 % and more) is measured
SHAPE_TOL = 0.5  # the record's third harmonic within this share of the pendulum's ...
SHAPE_SIGMA = 4.0  # ... or within this many standard errors of it
_SHAPE_MIN_SAMPLES = 12  # samples in a period to measure its third harmonic


def third_harmonic_ratio(amplitude: np.ndarray | float) -> np.ndarray:
    """The third harmonic of a free gravity pendulum's angle relative to its fundamental.

    The pendulum swinging ``amplitude`` ``A`` (rad, below pi) has the Fourier series, in the
    sine basis from an upward zero crossing, ``theta = 8 sum_{n odd} q**(n/2) / (n (1 + q**n))
    sin(n w t)`` with the nome ``q = exp(-pi K(1 - m) / K(m))``, ``m = sin(A/2)**2``; so the
    third harmonic over the first is ``q (1 + q) / (3 (1 + q**3))``, positive (a flattened
    swing), ``A**2 / 192`` to lowest order: 0.61 % at 60 deg, 3.1 % at 120 deg.
    """
    from scipy.special import ellipk

    a = np.abs(np.asarray(amplitude, dtype=float))
    m = np.sin(np.minimum(a, math.pi) / 2.0) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        q = np.exp(-math.pi * ellipk(1.0 - m) / ellipk(m))
    q = np.where(a > 0, q, 0.0)
    return q * (1.0 + q) / (3.0 * (1.0 + q ** 3))


@dataclass(frozen=True)
class ShapeEvidence:
    """The record's third harmonic against a pendulum's at the same amplitude.

    Attributes
    ----------
    periods : int
        Periods measured (swinging :data:`SHAPE_FROM` or more).
    amplitude : float
        Their largest amplitude, rad as read.
    measured, expected : float
        The third harmonic over the fundamental (in phase with the swing's turning points),
        the record's (mean over the periods) and the pendulum's at each period's amplitude.
    stderr : float
        Standard error of ``measured``.
    pendulum : bool
        Whether they agree (within :data:`SHAPE_TOL` of ``expected`` or :data:`SHAPE_SIGMA` errors).
    """

    periods: int
    amplitude: float
    measured: float
    expected: float
    stderr: float
    pendulum: bool

    def sentence(self) -> str:
        return (f"a gravity pendulum swinging {math.degrees(self.amplitude):.0f} deg is flattened, its third harmonic "
                f"{100 * self.expected:.2g} % of the fundamental; the record's is {100 * self.measured:.2g} +- "
                f"{100 * self.stderr:.1g} % over {self.periods} periods")


def _period_harmonic(t: np.ndarray, x: np.ndarray, start: float, period: float) -> tuple[float, float]:
    """Third harmonic over fundamental of one period from a turning point at ``start``, in phase
    with it (cosines about the turning point; a linear envelope and drift absorbed), and its error."""
    tau = t - start
    w = 2.0 * math.pi / period
    c, s = np.cos(w * tau), np.sin(w * tau)
    design = np.column_stack([np.ones_like(tau), tau, c, s, tau * c, tau * s, np.cos(3 * w * tau), np.sin(3 * w * tau)])
    coef, *_ = np.linalg.lstsq(design, x, rcond=None)
    dof = max(x.size - design.shape[1], 1)
    var = float(np.sum((x - design @ coef) ** 2)) / dof
    cov = var * np.linalg.pinv(design.T @ design)
    # in the cosine basis about a turning point the pendulum's third harmonic has the opposite sign
    ratio = -coef[6] / coef[2]
    return float(ratio), float(math.sqrt(max(cov[6, 6], 0.0)) / abs(coef[2]))


def waveform_shape(time: np.ndarray, theta: np.ndarray, turn_times: np.ndarray, turn_amplitudes: np.ndarray
                   ) -> ShapeEvidence | None:
    """Hold a record's waveform against a gravity pendulum's at its amplitude (see
    :func:`third_harmonic_ratio`).

    Parameters
    ----------
    time, theta : ndarray
        Samples, s and rad as read, about the swing's centre.
    turn_times, turn_amplitudes : ndarray
        The turning points (s) in time order and their amplitudes about the centre (rad).

    Returns
    -------
    ShapeEvidence or None
        None when no full period swings :data:`SHAPE_FROM` or more with enough samples.
    """
    t, x = np.asarray(time, float), np.asarray(theta, float)
    tt, aa = np.asarray(turn_times, float), np.abs(np.asarray(turn_amplitudes, float))
    measured, expected, weights, amps = [], [], [], []
    for k in range(tt.size - 2):
        amp = float(np.mean(aa[k:k + 3]))
        if amp < SHAPE_FROM or amp >= math.pi:
            continue
        inside = (t >= tt[k]) & (t <= tt[k + 2])
        if np.count_nonzero(inside) < _SHAPE_MIN_SAMPLES:
            continue
        ratio, err = _period_harmonic(t[inside], x[inside], tt[k], tt[k + 2] - tt[k])
        if not (math.isfinite(ratio) and math.isfinite(err)):
            continue
        measured.append(ratio)
        expected.append(float(third_harmonic_ratio(amp)))
        weights.append(1.0 / max(err, 1e-6) ** 2)
        amps.append(amp)
    if not measured:
        return None
    w = np.asarray(weights)
    mean = float(np.sum(w * np.asarray(measured)) / np.sum(w))
    want = float(np.sum(w * np.asarray(expected)) / np.sum(w))
    stderr = math.sqrt(1.0 / float(np.sum(w)))
    if len(measured) > 2:  # the periods' own scatter, when larger than their fits' errors say
        stderr = max(stderr, float(np.std(measured, ddof=1)) / math.sqrt(len(measured)))
    off = abs(mean - want)
    agree = off <= SHAPE_TOL * want or off <= SHAPE_SIGMA * stderr
    return ShapeEvidence(len(measured), max(amps), mean, want, stderr, bool(agree))
