"""Samples that leave the swing for a frame or three: a tracker that jumped, a dropped bit.

A free swing moves smoothly: over a fraction of a period it is an arc of a sinusoid of its own
period, whatever its damping.  A tracking glitch puts a few samples (at most :data:`LONGEST`, or
:data:`LONGEST_PERIODS` of a period where that is more: a tracker that lost the bob for a tenth
of a second at 100 frames a second) far off that arc and brings the next ones back; left in, it makes a spurious pair of turning
points that shifts the count of swings after it (and so the period) or passes for a push.

Candidates are found in one pass over the record: the second difference of the samples is,
for smooth motion, ``-(w dt)^2`` times the smoothed swing, so what is left of it after that is
noise (scale ``s``) except where a sample jumps.  Each candidate is then judged on its own: an
arc ``c + a cos(w t) + b sin(w t) + d t`` is fitted to the samples within half a period of it,
leaving out :data:`LONGEST` samples either side; the samples off that arc by more than
:data:`Z_OFF` times the fit's own robust scatter (and by more than :data:`FLOOR` of the
swing), in a run of at most :data:`LONGEST`, that leave the line between the samples either side
of the run by at least :data:`NEIGHBOURS` of that, are a glitch.  Longer departures are motion (a push, a hand), not glitches, and are left to the
segment analysis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Glitch", "find_glitches", "LONGEST", "LONGEST_PERIODS", "Z_OFF"]

LONGEST = 4  # samples: a run longer than this off the arc is motion, not a glitch ...
LONGEST_PERIODS = 0.1  # ... unless it lasts under this share of a period (a tracker that lost the bob a moment)
Z_OFF = 8.0  # a sample this many robust scatters off the arc is off it
Z_CANDIDATE = 8.0  # a second difference this many noise scales from the smooth motion's is looked at
FLOOR = 0.01  # ... and by more than this share of the swing
MAD = 1.4826
MIN_SIDE = 3  # samples on the arc at least before a glitch and after it
NEIGHBOURS = 0.5  # ... and its largest departure from the line between its two neighbours, at least this share of it


@dataclass(frozen=True)
class Glitch:
    """Samples ``first .. last`` (indices, inclusive) off the swing by ``size`` (largest, signed)."""

    first: int
    last: int
    size: float


def _scale(values: np.ndarray) -> float:
    return float(MAD * np.median(np.abs(values - np.median(values)))) if values.size else 0.0


def _judge(t: np.ndarray, x: np.ndarray, i: int, period: float, longest: int = LONGEST) -> Glitch | None:
    """The glitch around sample ``i``, if the samples near it (runs of at most ``longest``) leave
    the arc the others follow."""
    w = 2.0 * math.pi / period
    lo, hi = np.searchsorted(t, [t[i] - 0.5 * period, t[i] + 0.5 * period])
    idx = np.arange(lo, hi)
    near = np.abs(idx - i) <= longest
    fit_idx = idx[~near]
    if fit_idx.size < 8:
        return None
    tc = t[fit_idx] - t[i]
    design = np.stack([np.ones_like(tc), np.cos(w * tc), np.sin(w * tc), tc], axis=1)
    coef, *_ = np.linalg.lstsq(design, x[fit_idx], rcond=None)
    scatter = _scale(x[fit_idx] - design @ coef)
    ta = t[idx] - t[i]
    off = x[idx] - np.stack([np.ones_like(ta), np.cos(w * ta), np.sin(w * ta), ta], axis=1) @ coef
    # off by more than the scatter allows, and by more than a hundredth of the swing (a record
    # without noise has kinks and anharmonic arcs that no glitch threshold should count)
    bad = np.abs(off) > max(Z_OFF * scatter, FLOOR * 0.5 * float(np.ptp(x[idx])))
    if not bad[near].any():
        return None
    run = idx[bad & near]
    first, last = int(run.min()), int(run.max())
    if last - first + 1 > longest or bad[(idx >= first - 1) & (idx <= last + 1) & ~near].any():
        return None
    # a glitch leaves the arc and comes back to it: the arc is followed on both sides of it (at
    # the record's first or last samples one side is missing, and a release from a hold or the
    # record's start bends away from the arc fitted after it without any glitch)
    if np.count_nonzero(fit_idx < first) < MIN_SIDE or np.count_nonzero(fit_idx > last) < MIN_SIDE:
        return None
    inside = (idx >= first) & (idx <= last)
    k = int(np.argmax(np.abs(off[inside])))
    size = float(off[inside][k])
    # the raw samples around the run say it too: a glitch leaves its neighbours as far as it
    # leaves the arc (a sample of a hold, off an arc that cannot follow a hold and its release
    # at once, is where its neighbours are)
    if first > 0 and last + 1 < x.size:
        a, b = x[first - 1], x[last + 1]
        line = a + (b - a) * (t[first:last + 1] - t[first - 1]) / (t[last + 1] - t[first - 1])
        if not np.max(np.abs(x[first:last + 1] - line)) >= NEIGHBOURS * abs(size):
            return None
    return Glitch(first, last, size)


def find_glitches(time: np.ndarray, values: np.ndarray, period: float, smoothed: np.ndarray) -> list[Glitch]:
    """Glitches of a record of a swing of ``period`` (s); ``smoothed`` is its smoothing.

    Returns
    -------
    list of Glitch
        In time order, none overlapping.
    """
    t = np.asarray(time, float)
    x = np.asarray(values, float)
    if t.size < 20 or not math.isfinite(period) or period <= 0:
        return []
    dt = float(np.median(np.diff(t)))
    rest = np.diff(x, 2) + (2.0 * math.pi * dt / period) ** 2 * np.asarray(smoothed, float)[1:-1]
    s = _scale(rest)
    if s <= 0:
        return []
    found: list[Glitch] = []
    longest = max(LONGEST, int(LONGEST_PERIODS * period / dt))
    for i in np.flatnonzero(np.abs(rest) > Z_CANDIDATE * s) + 1:
        if found and i <= found[-1].last + longest:
            continue
        g = _judge(t, x, int(i), period, longest)
        if g is not None and not (found and g.first <= found[-1].last):
            found.append(g)
    return found
