"""The swing's envelope over a record, and the episodes in which it grows.

:func:`envelope` measures the swing over windows of one and a half periods; :func:`rises` finds
the episodes in which it grows; :func:`steady_tail` finds a drive's steady state at the end; and
:func:`restarted` tells a record swung again and again by hand from beats and drives.

A hand that sets an oscillator swinging again does it within a swing or two, and the swing then
decays freely for much longer.  Beats rise and fall alike, and a drive's transient does too.
So a record whose every episode rises within :data:`RESTART_RISE` periods, and then falls for at
least :data:`RESTART_FALL` times as long, is a series of free decays: the segmentation fits the
longest of them (the pushes' rule in :mod:`escfit.analysis.recordings.motion`) instead of
refusing the record as beats.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["envelope", "rises", "steady_tail", "restarted", "Restarts", "RESTART_RISE", "RESTART_FALL"]

RESTART_RISE = 2.5  # periods, at most, over which a hand's restart lifts the envelope (its window is 1.5 wide)
RESTART_FALL = 3.0  # ... and the fall after it lasts at least this many times as long


def envelope(rec) -> tuple[np.ndarray, np.ndarray]:
    """Start times (s) and swing (rad) of windows of one and a half periods, a quarter apart.

    The swing is half the range of the smoothed angle in the window: long enough to hold a
    whole swing of a pendulum whose period shortens as it decays, and blind to the frequency.
    """
    t, xs = rec.t, rec.xs
    width = 1.5 * rec.period
    starts = np.arange(t[0], t[-1] - width + 1e-9 * width, 0.25 * rec.period)
    lo = np.searchsorted(t, starts)
    hi = np.searchsorted(t, starts + width)
    return starts, 0.5 * _window_range(xs, lo, hi)


def _window_range(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``max - min`` of ``x[lo[k]:hi[k]]`` for each window (0 for an empty one), in linear time.

    The windows' ends cut ``x`` into segments; each window is a run of whole segments, so its
    range comes from the segments' maxima and minima (one ``reduceat`` each) over the few
    segments it spans, instead of one pass over its samples per window.
    """
    out = np.zeros(lo.size)
    full = hi > lo
    if not full.any():
        return out
    lo, hi = lo[full], hi[full]
    cuts = np.unique(np.concatenate([lo, hi]))
    cuts = cuts[cuts < x.size]
    top, bottom = np.maximum.reduceat(x, cuts), np.minimum.reduceat(x, cuts)
    first = np.searchsorted(cuts, lo)
    spans = np.searchsorted(cuts, hi) - first  # segments in each window (hi = x.size: up to the end)
    spans = np.where(hi >= x.size, cuts.size - first, spans)
    high, low = top[first], bottom[first]
    for j in range(1, int(spans.max())):
        more = spans > j
        high[more] = np.maximum(high[more], top[first[more] + j])
        low[more] = np.minimum(low[more], bottom[first[more] + j])
    out[full] = high - low
    return out


def rises(rec) -> list[float]:
    """Start times (s) of the episodes in which the swing grows, from its :func:`envelope`.

    An episode starts when the envelope climbs a quarter above its lowest value since the last
    episode (and by more than the smoothed noise can), and ends once it has fallen a tenth below
    its highest.  A release from a hold or from rest is one episode, beating modes make one per
    beat.
    """
    starts, env = envelope(rec)
    if starts.size < 3:
        return []
    floor = 3.0 * rec.sigma + 2.0 * rec.quantum
    out: list[float] = []
    low, high, rising = env[0], env[0], False
    for s, e in zip(starts, env):
        if rising:
            high = max(high, e)
            if e < 0.9 * high:
                rising, low = False, e
        else:
            low = min(low, e)
            if e > 1.25 * low + floor:
                rising, high = True, e
                out.append(float(s))
    return out


def steady_tail(rec) -> tuple[float, float, float]:
    """Where the swing settles for good while a free decay could not: start (s), amplitude (rad)
    and length (periods) of the final stretch of the :func:`envelope` that stays within 15 % of
    itself; ``(nan, nan, 0)`` when there is none.

    A free decay may slow down as it fades (air drag loses with the square of the speed), but
    its logarithmic decrement cannot fall faster than the square of the amplitude: with the
    decrement of the first three periods after the largest swing, ``d0`` at amplitude ``A0``, a
    stretch at amplitude ``A`` must lose at least ``d0 (A/A0)^2`` per period.  A stretch of ten
    periods or more that is expected to lose over a quarter of its amplitude that way and loses
    under a quarter of that is kept going by something (a drive's steady state after its
    transient, an escapement).
    """
    starts, env = envelope(rec)
    if starts.size < 40:
        return math.nan, math.nan, 0.0
    k = env.size - 1
    while k > 0 and np.max(env[k - 1:]) <= 1.15 * np.min(env[k - 1:]):
        k -= 1
    periods = (starts[-1] - starts[k]) / rec.period
    level = float(np.mean(env[k:]))
    top = int(np.argmax(env))
    later = top + int(round(3 * 4))  # windows are a quarter period apart
    if periods < 10 or level < 20 * (rec.sigma + rec.quantum) or later >= k:
        return math.nan, math.nan, 0.0
    d0 = math.log(env[top] / max(env[later], 1e-300)) / 3.0
    expected = d0 * (level / env[top]) ** 2 * periods
    observed = math.log(np.max(env[k:]) / max(np.min(env[k:]), 1e-300))
    if expected > math.log(4.0 / 3.0) and observed < 0.25 * expected:
        return float(starts[k]), level, periods
    return math.nan, math.nan, 0.0


@dataclass(frozen=True)
class Restarts:
    """A record set swinging again and again: each episode's start, rise and fall.

    Attributes
    ----------
    starts : tuple of float
        When each episode's rise began (s).
    rise, fall : tuple of float
        How long each rise and the fall after it lasted (periods); the last fall, which the
        record's end cuts short, is not among the falls.
    """

    starts: tuple
    rise: tuple
    fall: tuple

    def sentence(self) -> str:
        """The decision and its evidence, in one sentence."""
        when = ", ".join(f"{s:.4g}" for s in self.starts[:6]) + (", ..." if len(self.starts) > 6 else "")
        return (f"the oscillator is set swinging again {len(self.starts)} times (the swing grows from about t = "
                f"{when} s), each time within {max(self.rise):.2g} periods, and then decays for at least "
                f"{min(self.fall):.2g} periods (the last until the record ends): separate free decays one after "
                "another, not beats or a drive")


def restarted(rec, episodes: list[float]) -> Restarts | None:
    """The episodes as restarts when every one rises within :data:`RESTART_RISE` periods and falls
    for :data:`RESTART_FALL` times as long after it (see the module docstring); else None."""
    starts, env = envelope(rec)
    if starts.size < 3 or len(episodes) < 2:
        return None
    step = 0.25  # periods between the envelope's windows
    bounds = [int(np.searchsorted(starts, s)) for s in episodes] + [starts.size]
    rise, fall = [], []
    for k in range(len(episodes)):
        seg = env[bounds[k]:bounds[k + 1]]
        last = k == len(episodes) - 1
        if seg.size < 2:
            if last:  # the record ends within the last restart: nothing of it to judge
                continue
            return None
        top = int(np.argmax(seg))
        if last and top == seg.size - 1:  # still rising where the record ends
            continue
        rise.append(top * step)
        fall.append((seg.size - 1 - top) * step)
    # the record's end cuts the last fall short: only the rise of the last restart is judged
    judged = len(episodes) - 1
    if len(fall[:judged]) < 2 or max(rise) > RESTART_RISE \
            or any(f < RESTART_FALL * max(r, 1.0) for r, f in zip(rise[:judged], fall[:judged])):
        return None
    return Restarts(tuple(float(s) for s in episodes), tuple(rise), tuple(fall[:judged]))
