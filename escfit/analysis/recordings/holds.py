"""How the free motion of a record begins: a hold and its release, a turning point at the first sample.

A held oscillator is flat within the rest band for at least :data:`HOLD_PERIODS` periods and then
moves; the release is where that motion starts (:func:`release_instant`: the swing that follows
fitted as a free start from rest).  A record that starts at a turning point has its vertex within
:data:`START_TURN_PERIODS` periods of the first sample (:func:`turn_at_start`).  The functions
take the analysis record of :mod:`escfit.analysis.recordings.sampled`.
"""

from __future__ import annotations

import math

import numpy as np

from .extrema import vertex_at
from .sampled import ARC_SAMPLES_PER_PERIOD

__all__ = ["held_release", "release_instant", "flat_start", "turn_at_start", "HOLD_PERIODS", "START_TURN_PERIODS",
           "RELEASE_DEGREE"]

HOLD_PERIODS = 0.1  # a flat stretch at least this long is a held oscillator
START_TURN_PERIODS = 0.03  # a turn this close before the first sample counts as a start at a turn
# a cubic after a release: a quartic's freedom trades the release instant against the first
# curvature when the noise is some 1 % of the swing (errors of 0.6 s on a 9 s period)
RELEASE_DEGREE = 3
TURN_MISFIT = 3.0  # a free turning point's misfit (in reading noises) above which flat samples are held
DEPARTED = 0.03  # a sample this share of the swing off the held level has left the hold


def held_release(rec, turn, amplitude: float = math.inf) -> tuple[float, float] | None:
    """The release from a hold at ``turn`` (a :class:`~escfit.analysis.recordings.motion.Turn`): the
    instant motion starts and the held angle.

    ``None`` unless the angle stays within the rest band of the turn's level up to the departure
    for at least :data:`HOLD_PERIODS` periods, and flatter than a free turning point of that
    ``amplitude`` (rad, about the centre) would (:func:`_flatter_than_a_turn`: a small swing is
    flat near its turning points for a good part of a period).
    """
    t, x, xs = rec.t, rec.x, rec.xs
    k = max(1, int(round(0.05 * rec.period / rec.dt)))
    lo, hi = max(0, turn.first - k), min(t.size, turn.last + k + 1)
    level = float(np.median(x[lo:hi]))
    out = np.abs(xs - level) > rec.band
    right = np.flatnonzero(out[turn.last:])
    if not right.size:
        return None
    j1 = _raw_departure(rec, turn.last + int(right[0]), level)
    # the hold's start, by the samples themselves too: the smoothing spreads a motion or one
    # sample's step (a sensor's quantum) into the hold around it
    left = np.flatnonzero(out[:turn.first + 1] & (np.abs(x[:turn.first + 1] - level) > rec.band))
    j0 = int(left[-1]) + 1 if left.size else 0
    if not _flatter_than_a_turn(rec, j0, j1, turn.is_max, amplitude):
        return None
    got = release_instant(rec, j1)
    if got is None:
        got = rec.refine(j1, j1, flat="left", degree=RELEASE_DEGREE)
    return got if got is not None else (float(t[j1]), float(np.median(x[j0:j1])))


def release_instant(rec, j1: int) -> tuple[float, float] | None:
    """When a held oscillator was let go, and where it was held, from the swing that follows.

    ``j1`` is the first sample that left the hold.  Released at rest, a free oscillator
    starts as ``level + a (1 - cos(w (t - t_r)))`` with ``w = 2 pi / period``: the samples from
    a quarter period before ``j1`` to a fifth of a period after it are fitted with that, flat
    before ``t_r`` (``level`` and ``a`` by linear least squares for each ``t_r``, ``t_r`` searched
    in the quarter period before ``j1``).  Damping and friction change the swing little over a
    fifth of a period; a local polynomial needs many samples there (at 20 samples per period it
    put a release a tenth of a period early).  ``None`` when too few samples follow.
    """
    t, x, period = rec.t, rec.x, rec.period
    w = 2.0 * math.pi / period
    lo, hi = np.searchsorted(t, [t[j1] - 0.25 * period, t[j1] + 0.2 * period])
    if hi - j1 < 3 or hi - lo < 6:
        return None
    tt, xx = t[lo:hi], x[lo:hi]

    def fit(tr: float) -> tuple[float, float]:
        g = 1.0 - np.cos(w * np.clip(tt - tr, 0.0, None))
        design = np.stack([np.ones_like(g), g], axis=1)
        coef, *_ = np.linalg.lstsq(design, xx, rcond=None)
        r = xx - design @ coef
        return float(r @ r), float(coef[0])

    grid = np.linspace(max(tt[0], t[j1] - 0.25 * period), t[j1], 101)
    costs = [fit(tr)[0] for tr in grid]
    k = int(np.argmin(costs))
    from scipy.optimize import minimize_scalar

    step = grid[1] - grid[0]
    found = minimize_scalar(lambda tr: fit(tr)[0], bounds=(grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)] + 1e-12 * step),
                            method="bounded", options={"xatol": 1e-6 * period})
    tr = float(found.x) if found.fun <= costs[k] else float(grid[k])
    return tr, fit(tr)[1]


def flat_start(rec) -> tuple[float, float] | None:
    """A record that starts flat (held, however briefly) and then moves: the release and the held angle."""
    t, x = rec.t, rec.x
    k = max(3, int(np.sum(t < t[0] + 0.02 * rec.period)))
    level = float(np.median(x[:k]))
    out = np.flatnonzero(np.abs(rec.xs - level) > rec.band)
    if not out.size or out[0] < 3:
        return None
    j1 = _raw_departure(rec, int(out[0]), level)
    got = release_instant(rec, j1)
    return got if got is not None else rec.refine(j1, j1, flat="left", degree=RELEASE_DEGREE)


def _flatter_than_a_turn(rec, j0: int, j1: int, is_max: bool, amplitude: float) -> bool:
    """Whether the samples ``j0 .. j1 - 1`` (read as held) are a hold rather than a free turning
    point of that ``amplitude`` (rad, about the centre).

    They must last :data:`HOLD_PERIODS` periods at least, and a free turning point must not
    follow them: ``v - s a (1 - cos(w (t - t_v)))`` (``s`` = +1 at a maximum, ``w = 2 pi /
    period``, ``a`` the amplitude, ``v`` and ``t_v`` fitted) leaves a root mean square residual
    above :data:`TURN_MISFIT` times the reading noise (or the sensor step's).  Two samples
    either side of a free vertex (a coarse record) or a rest band widened by the noise are then
    no hold; a hand's hold to within a sensor step, with the swing that leaves it, is.
    """
    t, x = rec.t, rec.x
    last = max(j1 - 1, j0)
    if t[last] - t[j0] < HOLD_PERIODS * rec.period:
        return False
    if not math.isfinite(amplitude):  # no swing to compare with: the duration decides
        return True
    if last - j0 < 2:  # a free vertex passes through any two samples
        return False
    noise = max(rec.sigma, rec.quantum / math.sqrt(12.0), 1e-12)
    return _free_turn_misfit(t[j0:last + 1], x[j0:last + 1], rec.period, is_max, amplitude) > TURN_MISFIT * noise


def _free_turn_misfit(tt: np.ndarray, xx: np.ndarray, period: float, is_max: bool, amplitude: float) -> float:
    """Root mean square residual (rad) of the best free turning point of ``amplitude`` through the
    samples, its vertex time searched from a tenth of a period before them to a tenth after."""
    w = 2.0 * math.pi / period
    sign = 1.0 if is_max else -1.0
    best = math.inf
    for vertex in np.linspace(tt[0] - 0.1 * period, tt[-1] + 0.1 * period, 201):  # memory: one row at a time
        r = xx + sign * amplitude * (1.0 - np.cos(w * (tt - vertex)))
        best = min(best, float(np.var(r)))
    return math.sqrt(best)


def _raw_departure(rec, j: int, level: float) -> int:
    """The first sample from ``j`` on whose own reading has left ``level`` by more than the rest
    band and :data:`DEPARTED` of the swing: the smoothing reaches back from the motion into the
    hold (a third of a period and more at 20 samples a period), and a hand's hold wanders by a
    sensor step or two, so the smoothed record leaves the band before the oscillator moves.  A
    swing released at rest leaves by that share within 0.04 periods, well inside the quarter
    period before it in which :func:`release_instant` looks for the release."""
    far = max(rec.band, DEPARTED * 0.5 * float(np.ptp(rec.xs)))
    raw = np.flatnonzero(np.abs(rec.x[j:] - level) > far)
    return j + int(raw[0]) if raw.size else j


def turn_at_start(rec) -> tuple[float, float, bool] | None:
    """Time, angle and kind (maximum?) of a turning point within a few hundredths of a period
    of the first sample; or None.

    A cubic through the first fifth of a period decides (its slope vanishes there); the
    vertex itself comes from a one-sided polynomial without linear term whose vertex time is
    searched within 0.02 periods of that (:func:`~escfit.analysis.recordings.extrema.vertex_at`),
    or, below :data:`~escfit.analysis.recordings.sampled.ARC_SAMPLES_PER_PERIOD` samples a period,
    from the arc of the oscillation through the first half period (a polynomial through the few
    samples there missed the release angle by 0.1 % at 25 samples a period, and a decay fit
    anchored at it read the miss as damping).
    """
    t, x, period = rec.t, rec.x, rec.period
    sel = t <= t[0] + 0.2 * period
    s = (t[sel] - t[0]) / period
    if s.size < 6:
        return None
    poly = np.polynomial.Polynomial.fit(s, x[sel], 3).convert()
    slope = poly.deriv()
    roots = slope.roots()
    roots = roots[np.isreal(roots)].real
    roots = roots[(roots >= -START_TURN_PERIODS) & (roots <= 0.05)]
    if not roots.size:
        return None
    r = float(roots[np.argmin(np.abs(roots))])
    is_max = bool(slope.deriv()(r) < 0)
    t_turn = float(t[0] + r * period)
    if period / rec.dt < ARC_SAMPLES_PER_PERIOD:  # the oscillation's arc over the first half period
        arc = rec.fit_arc(t <= t[0] + 0.5 * period, t_turn)
        if arc is not None:
            u = arc.vertex(is_max, 0.0)
            if abs(u) <= 0.02 * period and t_turn + u >= t[0] - START_TURN_PERIODS * period:
                return float(t_turn + u), float(arc.at(u)[0]), is_max
    near = t <= t_turn + rec.half_width()
    if np.count_nonzero(near) < 6:
        return t_turn, float(poly(r)), is_max
    bounds = (max(-START_TURN_PERIODS * period, r * period - 0.02 * period), r * period + 0.02 * period)
    sc, value = vertex_at(t[near] - t[0], x[near], rec.degree, search=bounds)
    return float(t[0] + sc), value, is_max
