"""Where the free decay of a record starts and where it ends.

A record seldom holds a free decay only.  It may begin with the oscillator held, pulled
further by hand, pushed a second time, or kept going by a drive that is then switched off;
it may end in a long stretch of noise once the swing has faded.  The free decay is the
**last** stretch over which the motion obeys a free oscillator:

- consecutive swings never grow: the peak-to-peak swing after a turning point is not larger
  than the one before it, beyond the record's resolution (a hand, a second pull or a drive
  adds energy; friction only removes it);
- the losses per swing follow a dissipation law: a loss that grows with the amplitude
  (Coulomb friction loses the same at every amplitude, viscous damping in proportion to it,
  air drag in proportion to its square), so a stretch at the largest amplitudes that loses
  almost nothing while the smaller swings after it lose much was driven (a drive switched
  off); a swing that stops decaying is judged on trends over whole stretches with their
  standard errors (:mod:`escfit.analysis.amplitude_trend`), never on neighbouring swings,
  which a slow decay changes by less than their noise;
- a hold (the angle flat for a tenth of a period or more) ends it backwards: the release
  from a hold is where the free motion starts.

Its first point is the reference at which the model is released at rest: the end of a hold
when the motion from it is free, else a turning point, where the velocity is zero, so that a
release there is exact physics whatever the hand did before (a hand that lets go while the
oscillator still moves outwards leaves it to reach that turning point freely).

The end: turning points whose spacing breaks down once the swing has faded are noise, not
motion (:func:`faded_end`).  Functions here take the analysis record of
:mod:`escfit.analysis.recordings.turning_points` (``t``, ``x``, ``xs``, ``period``, ``band``,
``step``, ``notes``, ``refine``) and its refined turning points (:class:`Turn`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...core.errors import DataError
from ...analysis.drive_off import drive_off, not_a_wobble
from ...analysis.segments import amplitude_growth, braked_start, driven_start, find_events, robust_scale, swung_up
from .episodes import envelope, restarted, rises, steady_tail
from .holds import HOLD_PERIODS, flat_start as _flat_start, held_release, turn_at_start as _turn_at_start

__all__ = ["Turn", "Start", "reference", "faded_end", "growth_tolerance", "growth_steps", "find_start",
           "envelope", "rises", "steady_tail",
           "INTERVAL_RANGE", "HOLD_PERIODS"]

INTERVAL_RANGE = (0.6, 1.6)  # admissible interval between turning points, in local half periods
BEAT_EPISODES = 3  # the swing growing again this many times is not one decay (beats, a drive)
SUSTAIN_BLOCK = 4  # half swings per block of the loss-law checks
EARLY_TURNS = 4  # half swings at the start judged by plain growth: too few before them for the step test
CUT_WARNING = 0.25  # leaving out more than this share of the record is a warning, not a note
FADED = 0.1  # a swing under this share of the record's largest has faded into the noise
CLEARLY_SHORTER = 0.8  # a free stretch under this share of the longest one between pushes is not fitted


@dataclass(frozen=True)
class Turn:
    """A turning point found by the extremum search and refined on the raw samples.

    ``first``/``last`` are the sample indices of the smoothed extremum (its plateau);
    ``time`` (s) and ``value`` (rad) the refined vertex, ``None`` when no local fit fits in
    the record there (the very start or end).
    """

    first: int
    last: int
    is_max: bool
    time: float | None
    value: float | None


@dataclass(frozen=True)
class Start:
    """The reference of the free decay: instant (s), angle (rad) and the index of the first
    turning point after it in the list of turns."""

    time: float
    theta: float
    first: int
    kind: str  # "held", "turn", "start" (a turning point at the first sample)
    end: int | None = None  # index after the last turning point of the free decay (None: to the end)


def _amplitudes(values: np.ndarray) -> np.ndarray:
    """Amplitude of each turning point about the centre of the ones around it (rad)."""
    v = np.asarray(values, float)
    if v.size < 3:
        return np.abs(v - np.median(v))
    mid = 0.5 * (v[:-1] + v[1:])
    centre = np.interp(np.arange(v.size), np.arange(mid.size) + 0.5, mid)
    return np.abs(v - centre)


def faded_end(rec, times: np.ndarray, values: np.ndarray) -> int:
    """How many turning points to keep when the spacing breaks down only where the swing has faded.

    A decay that dies into the reading noise ends in extrema of the noise, not of the motion:
    when the first irregular interval comes after the swing has fallen below a tenth of its
    largest amplitude (or three rest bands), the turning points from there on are dropped with
    a note (earlier irregularities are left to the interval check).
    """
    if times.size < 4:
        return times.size
    d = np.diff(times)
    # the intervals before each one set its scale: the noise's own extrema come close together
    local = np.empty(d.size)
    local[:3] = np.median(d[:7])
    for i in range(3, min(6, d.size)):
        local[i] = np.median(d[:i])
    if d.size > 6:
        local[6:] = np.median(np.lib.stride_tricks.sliding_window_view(d[:-1], 6), axis=1)
    ratio = d / local
    bad = np.flatnonzero((ratio < INTERVAL_RANGE[0]) | (ratio > INTERVAL_RANGE[1]))
    if not bad.size:
        return times.size
    amp = _amplitudes(values)
    big = float(np.max(amp))
    before = np.maximum.accumulate(amp)  # largest up to and with each
    after = np.append(np.maximum.accumulate(amp[::-1])[::-1][1:], 0.0)  # largest after each
    for i in bad:
        # faded: small against what came before and nothing large after (a hand's jitter while the
        # oscillator is held before its release is small too, but the swing follows it); small
        # around it too, not only itself (a spurious pair of extrema within a swing that goes on
        # is as small, but the turning points beside it are not)
        around = float(np.median(np.delete(amp[max(0, i - 3):i + 4], min(i, 3))))
        if max(amp[i], around) <= max(0.1 * big, 3.0 * rec.band) and amp[i] < 0.5 * before[i] \
                and max(after[i], 0.0) < 0.5 * before[i]:
            rec.notes.append(f"turning points from t = {times[i + 1]:.4g} s on left out: the swing had faded to "
                             f"{rec.show(amp[i], 2)} and their spacing is irregular (noise, not motion)")
            return int(i) + 1
    return times.size


def growth_tolerance(rec, values: np.ndarray) -> float:
    """Largest change of a peak-to-peak swing that the record's resolution explains, rad."""
    pp = np.abs(np.diff(values)) if values.size > 1 else np.zeros(1)
    return max(rec.step, 0.02 * float(np.median(pp)))


def growth_steps(values: np.ndarray, tol: float) -> np.ndarray:
    """Indices ``k`` of turning points after which the swing grew: ``|v[k+1]-v[k]| > |v[k]-v[k-1]| + tol``.

    Only swings of at least a fifth of the largest count: where the swing has faded, the noise
    moves turning points by more than its scale sample by sample suggests (correlated noise).
    """
    pp = np.abs(np.diff(np.asarray(values, float)))
    if not pp.size:
        return np.zeros(0, int)
    return np.flatnonzero((pp[1:] > pp[:-1] + tol) & (pp[1:] >= 0.2 * np.max(pp))) + 1


def _regular(interval: float, half: float) -> bool:
    return INTERVAL_RANGE[0] <= interval / half <= INTERVAL_RANGE[1]


def _local_half(times: np.ndarray, i: int, end: int, fallback: float) -> float:
    """Median interval of the turning points from ``i`` on (up to six), or ``fallback``."""
    d = sorted(np.diff(times[i:min(end, i + 7)]).tolist())  # at most six: no numpy call per interval
    if not d:
        return fallback
    if any(v != v for v in d):  # an unrefined turning point (nan): as numpy's median says
        return math.nan
    mid = len(d) // 2
    return float(d[mid]) if len(d) % 2 else 0.5 * (d[mid - 1] + d[mid])


def _driven_prefix(values: np.ndarray, tol: float) -> int:
    """Turning points at the start of a run that a drive kept going (0 when none).

    A prefix of at least two blocks of half swings of one size (peak to peak, within ``tol``),
    followed by a decay that loses more than ``3 tol`` in two blocks from that same size and at
    least four times what the prefix lost per half swing: a free oscillator's loss depends on its
    amplitude only, so the prefix was driven.  The last turning point of the prefix is where the
    free motion starts.
    """
    pp = np.abs(np.diff(np.asarray(values, float)))
    n = pp.size
    if n < 3 * SUSTAIN_BLOCK:
        return 0
    off = np.abs(pp - pp[0]) > tol
    steady = int(np.argmax(off)) if off.any() else n
    if steady < 2 * SUSTAIN_BLOCK or steady > n - 2 * SUSTAIN_BLOCK:
        return 0
    prefix_loss = (pp[0] - pp[steady - 1]) / max(steady - 1, 1)
    after = (pp[steady - 1] - pp[steady - 1 + 2 * SUSTAIN_BLOCK]) / (2 * SUSTAIN_BLOCK)
    if after * 2 * SUSTAIN_BLOCK > 3 * tol and prefix_loss < 0.25 * after \
            and not_a_wobble(pp, steady, after - prefix_loss):  # a slow wobble keeps a size for a while too
        return steady
    return 0


def find_start(rec, turns: list[Turn], end: int, *, at_start: bool = False) -> Start:
    """The reference of the free decay among ``turns[:end]`` (see the module docstring).

    Appends what was found to ``rec.notes``.  ``turns`` must be refined (``time`` set) from
    the first one that can be the reference on; an unrefined first turn (at the very start
    of the record) is handled by the caller.  ``at_start``: ``turns[0]`` is a turning point at
    the record's first sample (the caller notes it).
    """
    ok = [i for i in range(end) if turns[i].time is not None]
    if not ok:
        raise DataError(f"no turning point found: the {rec.quantity.replace('_', ' ')} never comes back by more than "
                        f"{rec.show(rec.step, 3)}", rec.where)
    first_ok = ok[0]
    times = np.array([turns[i].time if turns[i].time is not None else np.nan for i in range(end)])
    values = np.array([turns[i].value if turns[i].value is not None else np.nan for i in range(end)])
    tol = growth_tolerance(rec, values[first_ok:])
    r, why, cut = _free_stretch(rec, times, values, first_ok, end, tol)
    if cut is not None:
        end = cut
    grown = swung_up(values[r:end])
    if grown:
        why = (f"the swing grows from {rec.show(abs(values[r + 1] - values[r]) / 2, 2)} to "
               f"{rec.show(abs(values[r + grown + 1] - values[r + grown]) / 2, 2)} until t = {times[r + grown]:.4g} s, "
               "which a free swing never does: driven (or swung up) until then")
        r += grown
    # a hold within the run (a long interval after a flat turn) ends it backwards: the last one is the release
    for i in range(end - 1, r, -1):
        half = _local_half(times, i, end, 0.5 * rec.period)
        if (times[i] - times[i - 1]) / half > INTERVAL_RANGE[1] \
                and held_release(rec, turns[i - 1], 0.5 * abs(values[i] - values[i - 1])) is not None:
            r, why = i - 1, f"the oscillator is held at {rec.show(values[i - 1], 4)} before t = {times[i]:.4g} s"
            break
    driven = _driven_prefix(values[r:end], tol)
    off = drive_off(values[r:_regular_end(times, r, end)]) if not driven else None
    if driven:
        why = (f"the swing keeps its amplitude until t = {times[r + driven]:.4g} s and then decays at that same "
               "amplitude (a drive switched off)")
        r += driven
    elif off is not None:
        r += off.half_swing + 1  # the split may fall in the half swing the drive stopped in: the next is free
        why = (f"until t = {times[r]:.4g} s the swing loses {rec.show(off.loss_before, 2)} per half swing (peak to "
               f"peak), then {rec.show(off.loss_after, 2)} at a smaller amplitude, where a free swing loses less, not "
               f"more ({off.score:.0f} standard errors): driven until then (a drive switched off)")
    elif r == first_ok:
        steady = driven_start(values[r:end])
        if steady:
            r += steady + 1
            why = (f"the first {steady} half swing(s) lose less than half of what the swing loses freely just after, "
                   f"at the same amplitude: driven (or guided) until t = {times[r]:.4g} s")
    braked = braked_start(values[r:end])
    if braked:
        p = np.abs(np.diff(values[r:end]))
        free = float(np.median(p[braked:braked + 6] - p[braked + 1:braked + 7]))
        r += braked
        why = (f"its first half swing loses {rec.show(0.5 * (p[0] - p[1]), 2)} of amplitude where the swings after it "
               f"lose {rec.show(0.5 * free, 2)}, more than any free swing's loss grows with its size: guided or braked "
               f"(a hand that let go while it moved) until t = {times[r]:.4g} s")
    pulled = r == first_ok + 1 and held_release(rec, turns[first_ok]) is not None
    if pulled:
        rec.notes.append(f"held at {rec.show(values[first_ok], 4)}, then moved to "
                         f"{rec.show(values[r], 4)} by hand: the free swing starts at that turning point "
                         f"(t = {times[r]:.4g} s), the reference")
    elif r > first_ok:
        rec.notes.append(f"the record before t = {times[r]:.4g} s is not a free decay ({why}); the free decay is "
                         "taken from there")
        if cut is None:  # else the choice between pushes was warned of with what it leaves out
            _warn_if_large_cut(rec, times, first_ok, r, end, why)
    amplitude = 0.5 * abs(values[r + 1] - values[r]) if r + 1 < end else math.inf
    held = held_release(rec, turns[r], amplitude)
    if held is not None and r + 1 < end \
            and _regular(times[r + 1] - held[0], _local_half(times, r + 1, end, 0.5 * rec.period)):
        rec.notes.append(f"held at {rec.show(held[1], 4)} until the release at t = {held[0]:.4g} s")
        return Start(held[0], held[1], r + 1, "held", cut)
    if r == first_ok and not (at_start and r == 0):
        _note_pull(rec, turns[r])
    return Start(float(times[r]), float(values[r]), r + 1, "turn", cut)


def _regular_end(times: np.ndarray, first: int, end: int) -> int:
    """End (exclusive) of the turning points from ``first`` whose intervals stay regular: within
    :data:`INTERVAL_RANGE` of their median (after a missed or spurious extremum, or a gap in the
    samples, the swings measured between turning points are not the swing's)."""
    d = np.diff(times[first:end])
    if d.size < 3 or not np.all(np.isfinite(d)):
        return end
    ratio = d / float(np.median(d))
    bad = np.flatnonzero((ratio < INTERVAL_RANGE[0]) | (ratio > INTERVAL_RANGE[1]))
    return first + int(bad[0]) + 1 if bad.size else end


def _free_stretch(rec, times: np.ndarray, values: np.ndarray, first_ok: int, end: int,
                  tol: float) -> tuple[int, str, int | None]:
    """The free decay among ``turns[first_ok:end]`` between pushes: its first turning point,
    why the record before it is left out (``""``: nothing is), and the end (exclusive) of its
    turning points when a push follows it (None: the record's end).

    Along the record a push is energy gained and kept, beyond the reading noise of the swings
    and beyond their rise and fall elsewhere (:func:`escfit.analysis.segments.find_events`); a
    wobble, an offset step or a glitch is none.  The first half swings have too few before them
    for that test: there a swing larger than the one before it by more than ``tol`` (a hand's
    start, a swing-up) is the evidence.  Offset steps found are kept on ``rec.steps``.

    Pushes cut the record into free stretches; the last is fitted unless an earlier one holds
    clearly more half swings above the noise (:data:`CLEARLY_SHORTER`), and then the record after
    that one is left out with a warning naming the keys that choose another.
    """
    events = find_events(times[first_ok:end], values[first_ok:end], resolution=rec.step, quantum=rec.quantum,
                         show=lambda v: rec.show(v, 2))
    for e in events:
        if e.kind == "offset step" and rec.find_steps:
            k = first_ok + e.half_swing  # searched from the turning point before to the one after
            at = _jump_instant(rec, times[max(k - 1, first_ok)], times[min(k + 2, end - 1)], e.size)
            rec.steps.append((at, e.size, f"{e.evidence}: not a push; the samples from t = {at:.4g} s on are moved "
                                          f"back by {rec.show(e.size, 2, signed=True)} and the record is kept whole"))
    pushes = [e for e in events if e.kind == "push"]
    if not pushes:
        early = growth_steps(values[first_ok:min(end, first_ok + EARLY_TURNS + 2)], tol)
        if early.size:
            r = first_ok + int(early[-1])
            return r, f"the swing grows after the turning point at t = {times[r]:.4g} s (a push or pull)", None
        return first_ok, "", None
    # stretch i runs from the turning point after push i - 1 to the last one before push i began
    starts = [first_ok] + [first_ok + e.half_swing + 1 for e in pushes]
    ends = [_push_began(values[:end], first_ok, first_ok + e.half_swing) for e in pushes] + [end]
    # a stretch counts the half swings that have not faded into the noise (the noise's extrema
    # after a swing sank, before a new push, carry no decay): over a tenth of the largest swing
    swing = np.abs(np.diff(values[:end]))
    big = float(np.nanmax(swing[first_ok:])) if swing[first_ok:].size else 0.0
    sizes = [int(np.count_nonzero(swing[a:max(a, b - 1)] > FADED * big)) for a, b in zip(starts, ends)]
    # the last stretch unless an earlier one is clearly longer (it follows every push)
    best = max(i for i in range(len(sizes)) if sizes[i] >= CLEARLY_SHORTER * max(sizes))
    r = starts[best]
    why = pushes[best - 1].evidence if best > 0 else ""
    if best == len(pushes):
        return r, why, None
    cut = ends[best]
    # the half swing after the last turning point kept is free too (the push began after it)
    rec.cut_end = 0.5 * float(times[cut - 1] + times[cut])
    span = times[end - 1] - times[first_ok]
    share = 100.0 * (span - (rec.cut_end - times[r])) / span if span > 0 else 0.0
    when = " and ".join(f"{e.time:.4g} s" for e in pushes) if len(pushes) <= 3 else \
        f"{pushes[0].time:.4g} s to {pushes[-1].time:.4g} s"
    others = ", ".join(f"{times[a]:.4g} to {times[b - 1]:.4g} s" for i, (a, b) in enumerate(zip(starts, ends))
                       if i != best and b - a >= 2)
    text = (f"the swing is pushed {_times(len(pushes))} (it grows again at t = {when}); the longest free "
            f"decay between pushes, t = {times[r]:.4g} to {rec.cut_end:.4g} s ({sizes[best]} half swings), is "
            f"fitted and {share:.0f} % of the record is left out. The push after it: {pushes[best].evidence}"
            + (f". The other free stretches ({others}) can be fitted by setting [recording] start and stop (or "
               "--start and --stop) around them" if others else ""))
    (rec.warnings if share > 100 * CUT_WARNING else rec.notes).append(text)
    return r, why, cut


def _times(n: int) -> str:
    return {1: "once", 2: "twice"}.get(n, f"{n} times")


def _push_began(values: np.ndarray, first: int, k: int) -> int:
    """End (exclusive) of the free turning points before the push whose last grown half swing is ``k``.

    The push began in the earliest of the half swings up to ``k`` over which the amplitude grew
    (beyond three times the noise of one peak-to-peak swing) without a break; the turning point
    that half swing starts from is left to the push too, since a hand acts before the swing
    shows the energy it gave.
    """
    v = np.asarray(values[first:], float)
    p = np.abs(np.diff(v))
    noise = 3.0 * robust_scale(np.diff(p, 2)) / math.sqrt(2.0) if p.size > 4 else 0.0
    began = k - first
    while began - 1 > 0 and began + 2 < v.size and amplitude_growth(v, began - 1) > noise:
        began -= 1
    return first + max(began, 1)


def _jump_instant(rec, t0: float, t1: float, size: float) -> float:
    """Time (s) of the first sample after a jump of ``size`` between ``t0`` and ``t1``.

    Each sample between them is tried as the first one moved: the samples from a quarter period
    before ``t0`` to a quarter after ``t1``, less ``size`` from that sample on, are fitted with
    an arc of the record's period whose amplitude may change linearly (``c + (a + a' t) cos(w t)
    + (b + b' t) sin(w t)``); the jump is where that fit is best.  (The change between two
    samples cannot tell a jump from the motion when a period spans few samples.)
    """
    t, x = rec.t, rec.x
    lo, hi = np.searchsorted(t, [t0 - 0.25 * rec.period, t1 + 0.25 * rec.period])
    tt = t[lo:hi] - 0.5 * (t0 + t1)
    if tt.size < 8:
        return float(t1)
    w = 2.0 * math.pi / rec.period
    design = np.stack([np.ones_like(tt), np.cos(w * tt), np.sin(w * tt), tt * np.cos(w * tt), tt * np.sin(w * tt)],
                      axis=1)
    best, at = math.inf, float(t1)
    for j in range(int(np.searchsorted(t, t0)), int(np.searchsorted(t, t1, side="right"))):
        y = x[lo:hi] - size * (t[lo:hi] >= t[j])
        coef, *_ = np.linalg.lstsq(design, y, rcond=None)
        cost = float(np.sum((y - design @ coef) ** 2))
        if cost < best:
            best, at = cost, float(t[j])
    return at


def _warn_if_large_cut(rec, times: np.ndarray, first: int, r: int, end: int, why: str) -> None:
    """A warning when the free decay kept starts after more than a quarter of the record's turning points' span."""
    span = times[end - 1] - times[first]
    if span > 0 and (times[r] - times[first]) > CUT_WARNING * span:
        rec.warnings.append(f"{100 * (times[r] - times[first]) / span:.0f} % of the record (t = {times[first]:.4g} to "
                            f"{times[r]:.4g} s) is left out as not a free decay: {why}; if that part is free, set "
                            f"[recording] start (or --start) to keep it")


def _note_pull(rec, turn: Turn) -> None:
    """Note how the record reached its reference turning point."""
    t, x = rec.t, rec.x
    k = max(3, int(np.sum(t < t[0] + 0.05 * rec.period)))
    level = float(np.median(x[:k]))
    moved = np.abs(rec.xs[:turn.first + 1] - level) > rec.band
    j = int(np.argmax(moved)) if moved.any() else turn.first
    if t[j] - t[0] >= HOLD_PERIODS * rec.period and abs(level - turn.value) > rec.band:
        rec.notes.append(f"held at {rec.show(level, 4)} until t = {t[j]:.4g} s, then moved to "
                         f"{rec.show(turn.value, 4)}: the free swing starts at that turning point "
                         f"(t = {turn.time:.4g} s), the reference")
    elif turn.first > 0 or turn.time > t[0] + 0.05 * rec.period:
        rec.notes.append(f"the record starts mid-swing; reference: the first turning point at t = {turn.time:.4g} s "
                         f"({rec.show(turn.value, 4)} on the sensor's scale)")


def reference(rec, turns: list[Turn]) -> tuple[float, float, list[Turn]]:
    """The reference instant and angle of a record without a given release, and the turning
    points after it (see the module docstring and :mod:`escfit.analysis.recordings.turning_points`)."""
    if not turns:
        raise DataError(f"no turning point found: the {rec.quantity.replace('_', ' ')} never comes back by more than "
                        f"{rec.show(rec.step, 3)}", rec.where)
    at_start = held = False
    if turns[0].time is None and rec.moving_at_start:  # an extremum at the first sample is where the cut fell
        turns = turns[1:]
    elif turns[0].time is None:  # the first extremum lies too close to the start for a local fit
        start = _turn_at_start(rec)
        flat = _flat_start(rec) if start is None or start[2] != turns[0].is_max else None
        if flat is not None:  # a held start fits a cubic's turn of the wrong kind
            start = None
        if start is not None:
            at_start = True
            # the turn found may be the extremum after the first sample, not the sample itself
            rest = turns[1:] if start[2] == turns[0].is_max else turns[2:]
            turns = [Turn(0, 0, start[2], start[0], start[1])] + rest
        elif flat is not None:
            at_start = held = True
            turns = [Turn(turns[0].first, turns[0].last, turns[0].is_max, flat[0], flat[1])] + turns[1:]
        else:
            turns = turns[1:]
    episodes = rises(rec)
    again = restarted(rec, episodes) if len(episodes) >= BEAT_EPISODES else None
    if again is not None:  # separate free decays: the pushes' rule below picks the longest
        rec.notes.append(again.sentence())
    elif len(episodes) >= BEAT_EPISODES:
        when = ", ".join(f"{s:.4g}" for s in episodes[:6])
        settled, level, periods = steady_tail(rec)
        if math.isfinite(settled):
            raise DataError(f"the swing grows again {len(episodes)} times and from about t = {settled:.4g} s keeps an "
                            f"amplitude of {rec.show(level, 3)} for {periods:.0f} periods, to the end: a "
                            "driven oscillation (a drive's steady state), not a free decay; a decay after the drive "
                            "is switched off can be cut out with [recording] start and stop", rec.where)
        raise DataError(f"the swing grows again {len(episodes)} times (from about t = {when} s): beating modes, a "
                        "drive or repeated pushes, not one oscillator's free decay; cut the record to one decay with "
                        "[recording] start and stop", rec.where)
    if len(episodes) >= 2 and again is None:  # a decay, then the oscillator was set swinging again: the last one counts
        later = [i for i, u in enumerate(turns) if u.time is not None and u.time >= episodes[-1] - 0.5 * rec.period]
        if later and later[0] > 0:
            rec.notes.append(f"the swing grows again from about t = {episodes[-1]:.4g} s (a second push or pull): "
                             "the record before is left out")
            turns, at_start, held = turns[later[0]:], False, False
    end = len(turns)
    while end and turns[end - 1].time is None:
        end -= 1
    done = [u for u in turns[:end] if u.time is not None]
    _check_decay(np.array([u.time for u in done]), np.array([u.value for u in done]), rec)
    if done:  # the faded end first: extrema of the noise must not pass for a push
        skipped = end - len(done)
        end = skipped + faded_end(rec, np.array([u.time for u in done]), np.array([u.value for u in done]))
    found = find_start(rec, turns, end, at_start=at_start)
    if at_start and found.first == 1 and found.kind == "turn":
        if held:
            rec.notes.append(f"held at {rec.show(found.theta, 4)} until the release at t = "
                             f"{found.time:.4g} s")
        else:
            rec.notes.append(f"the record starts at a turning point ({rec.show(found.theta, 4)} on the "
                             "sensor's scale)")
    # an extremum next to the start that no local fit could place (time None) is no turning point
    last = end if found.end is None else found.end
    return found.time, found.theta, [u for u in turns[found.first:last] if u.time is not None]


def _check_decay(times: np.ndarray, values: np.ndarray, rec) -> None:
    """Refuse a swing that grows steadily (most peak-to-peak swings larger than the one before): not a free decay.

    Grows: the last third of the swings a fifth larger than the first third, most of them larger
    than the one before; or a tenth larger with three in four larger than the one before (a
    decay's noise makes successive swings larger and smaller by turns, not three times in four).
    """
    size = np.abs(np.diff(values))
    if size.size < 4:
        return
    m = max(1, size.size // 3)
    first, last = float(np.mean(size[:m])), float(np.mean(size[-m:]))
    growing = float(np.mean(np.diff(size) > 0))
    if (last > 1.2 * first and growing > 0.6) or (last > 1.1 * first and growing >= 0.75):
        raise DataError(f"the swing grows from {rec.show(first, 4)} to {rec.show(last, 4)} "
                        f"(peak to peak) between t = {times[0]:.4g} s and {times[-1]:.4g} s: a driven or sustained "
                        "oscillation (a drive, an escapement, a sound), not a free decay", rec.where)
