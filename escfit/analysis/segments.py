"""What happened between the turning points of a record: pushes, centre steps, out-of-line turns.

A free decay's peak-to-peak swing ``p_k = |v_(k+1) - v_k|`` (turning points ``v_k``) shrinks
smoothly: friction and damping take energy out, never in.  Four things make it look otherwise,
and only the first is a reason to cut the record:

- a **push** (a hand, a second release, a drive switched on): energy gained and kept: every
  swing after it stands above where the decay before it was heading;
- a slow **wobble** (a bob that does not swing in a plane, a phone turning in the hand): the
  swing rises and falls by a few percent over tens of swings, smoothly and both ways;
- an **offset step** (a tracked origin or a sensor's zero that moved): the centre jumps while
  the swing keeps its size, so only the one half swing that spans the step looks larger;
- a **glitch** (a tracker that jumped for a few frames): one turning point out of line, so the
  two half swings that touch it change and the rest do not.

The test is a step model with evidence.  At each half swing ``j`` the level of the swings
after it (``p_(j+2) .. p_(j+1+m)``) is compared with the level before it
(``p_(j-1-m) .. p_(j-2)``), each by its median, carried across the gap by the local loss per
half swing (the median of the differences within each side: the slower of the two, never a
rise).  The three half swings
around ``j`` are left out, so an offset step (one half swing) and a glitch (two) change
neither level.  The gain ``G_j`` has two scales:

- the reading noise of the swings: ``s_p`` from the median absolute second difference of ``p``,
  carried through the two levels (medians of ``a`` and ``b`` swings: ``1.25 s_p sqrt(1/a + 1/b)``)
  and through the slope carried across the gap (a median of differences within one side);
- the spread of ``G`` itself along the record (its median absolute deviation): a wobble gives
  gains of both signs at every position, as large as its depth.  Taken as the smaller of that
  and the spread of ``G`` in units of its own noise times that noise: the gains of a long faded
  tail scatter by their noise, not by a wobble, and must not hide a push made where the swing
  is large.

A push is a gain above :data:`Z_PUSH` times the larger scale and above twice the record's
resolution: it stands out of the noise and out of whatever else the swing does along the
record.  The centre is tested the same way, with the mean of three neighbouring turning
points (``(v_k + 2 v_(k+1) + v_(k+2)) / 4``, which cancels the alternation of a decaying swing)
in place of ``p``: a step there with no gain in ``p`` is an offset step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .free_law import free_law_gains, law_pushes, robust_scale, window_medians

__all__ = ["SwingEvent", "swing_gains", "find_events", "driven_start", "braked_start", "amplitude_growth",
           "robust_scale", "stands_out", "SIDE", "Z_PUSH", "BRAKE_FACTOR"]

SIDE = 6  # half swings on each side of a candidate (a median of 6 tolerates two that are out of line)
MIN_SIDE = 3  # fewer on either side: no verdict there (a median of 3 tolerates one out of line)
Z_PUSH = 5.0  # evidence a push needs: gain over the larger of its two scales
MAD = 1.4826  # median absolute deviation -> standard deviation of a normal sample
MEDIAN_SE = math.sqrt(math.pi / 2.0)  # standard error of a median over that of a mean, normal samples
BRAKE_FACTOR = 3.0  # a first half swing losing this many times what the free law allows at its size was braked
WOBBLE_FLOOR = 0.1  # a start's shortfall is held against stretches whose swing is this share of the start's at least


@dataclass(frozen=True)
class SwingEvent:
    """One departure from a free decay found between turning points.

    Attributes
    ----------
    kind : str
        ``"push"`` (energy gained and kept) or ``"offset step"`` (the centre jumps, the swing
        keeps its size).
    half_swing : int
        Index ``k`` of the half swing (from turning point ``k`` to ``k + 1``) it happened in (a
        push: the last half swing it still grew in).
    time : float
        Time of turning point ``k + 1``, s: the first turning point after the event.
    size : float
        Gain of the peak-to-peak swing (push) or jump of the centre (offset step, signed), in the
        record's unit (rad for an angle).
    score : float
        ``size`` over the larger of its two noise scales (see the module docstring).
    evidence : str
        The decision in one sentence, with its numbers.
    """

    kind: str
    half_swing: int
    time: float
    size: float
    score: float
    evidence: str


def _level(side: np.ndarray) -> tuple[float, float]:
    """Level at the middle of ``side`` and its slope per element: the median of the values
    about their own median slope (a value out of line moves it by little more than the noise).

    The slope is a decay's, never a rise, and taken only from four differences or more (from
    fewer, one value out of line sets it)."""
    slope = min(float(np.median(np.diff(side))), 0.0) if side.size >= 5 else 0.0
    k = np.arange(side.size) - 0.5 * (side.size - 1)
    return float(np.median(side - slope * k)), slope


def _full_levels(q: np.ndarray, side: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_level` of every window of ``side`` values of ``q``, by window start (all at once)."""
    if q.size < side:
        return np.zeros(0), np.zeros(0)
    w = np.lib.stride_tricks.sliding_window_view(q, side)
    slope = np.minimum(np.median(np.diff(w, axis=1), axis=1), 0.0) if side >= 5 else np.zeros(w.shape[0])
    k = np.arange(side) - 0.5 * (side - 1)
    return np.median(w - slope[:, None] * k, axis=1), slope


def swing_gains(series: np.ndarray, side: int = SIDE, *, noise_ratio: float, log: bool = False
                ) -> tuple[np.ndarray, np.ndarray]:
    """Level change of ``series`` across each position and its noise standard error.

    Returns ``(gain, stderr)``, one value per element of ``series`` (``nan`` where a side holds
    fewer than :data:`MIN_SIDE` values).  ``gain[j]`` is the level of ``series[j+2 : j+2+side]``
    minus that of ``series[j-1-side : j-1]`` (:func:`_level`), less the slower of the two
    sides' slopes (never a rise) times the gap; the three elements ``j-1 .. j+1`` are left out
    (see the module docstring).  The slower slope: a gain must not come from carrying a steep
    side's loss across the gap (a drive switched off), nor be excused by a hand's pull.

    ``noise_ratio`` is the scale of the series' second differences over that of its own noise
    (they are not independent: see :func:`find_events`).  With ``log`` the levels are compared
    as logarithms (a relative gain; ``series`` positive): a decay that loses in proportion to
    its size is then a straight line, and a straight line carried across the gap never predicts
    less than such a decay does.  The noise is that of ``series`` itself, so with ``log`` the
    error grows as the level falls.
    """
    p = np.asarray(series, float)
    n = p.size
    gain = np.full(n, np.nan)
    err = np.full(n, np.nan)
    if n < 2 * MIN_SIDE + 3:
        return gain, err
    s_p = robust_scale(np.diff(p, 2)) / noise_ratio
    q = np.log(p) if log else p
    full_level, full_slope = _full_levels(q, side)

    def level(lo: int, hi: int) -> tuple[float, float]:
        return (float(full_level[lo]), float(full_slope[lo])) if hi - lo == side else _level(q[lo:hi])

    for j in range(n):
        b0, b1 = max(0, j - 1 - side), max(0, j - 1)
        a0, a1 = min(n, j + 2), min(n, j + 2 + side)
        nb, na = b1 - b0, a1 - a0
        if nb < MIN_SIDE or na < MIN_SIDE:
            continue
        (lb, sb), (la, sa) = level(b0, b1), level(a0, a1)
        gap = 0.5 * (a0 + a1 - 1) - 0.5 * (b0 + b1 - 1)
        slower = 0 if sb >= sa else 1
        gain[j] = la - lb - min((sb, sa)[slower], 0.0) * gap
        # each value's noise (relative with log), and the slope's from the median of the
        # differences of the side it came from, carried across the gap
        nb_s, na_s = (math.exp(-lb), math.exp(-la)) if log else (1.0, 1.0)
        n_side, s_side = (nb, nb_s) if slower == 0 else (na, na_s)
        slope_var = 2.0 * (s_side * s_side) / max(n_side - 1, 1)
        err[j] = MEDIAN_SE * s_p * math.sqrt(nb_s * nb_s / nb + na_s * na_s / na + gap * gap * slope_var)
    return gain, err


def _centres(values: np.ndarray) -> np.ndarray:
    """Centre of each half swing, ``(v_k + 2 v_(k+1) + v_(k+2)) / 4`` at index ``k`` (the last: nan)."""
    v = np.asarray(values, float)
    c = np.full(max(v.size - 1, 0), np.nan)
    if v.size >= 3:
        c[:-1] = 0.25 * (v[:-2] + 2.0 * v[1:-1] + v[2:])
    return c


def amplitude_growth(v: np.ndarray, k: int) -> float:
    """How much the amplitude grew over half swing ``k`` (from turning point ``k`` to ``k + 1``).

    Both amplitudes are taken about one centre, that of the three turning points after the
    half swing (``(v_(k+1) + 2 v_(k+2) + v_(k+3)) / 4``): those are all on the far side of a
    push that ended in it, and an unknown centre cancels.
    """
    centre = 0.25 * (v[k + 1] + 2.0 * v[k + 2] + v[k + 3])
    return abs(v[k + 1] - centre) - abs(v[k] - centre)


def _pushed_half_swings(v: np.ndarray, run: np.ndarray, noise: float, beyond_law: np.ndarray | None = None) -> int:
    """The last half swing of the push found at the positions ``run``.

    Among those positions (from the first one's window before it on, to two after the last),
    the half swings over which the amplitude grew by over three times the noise of a growth
    (``noise``) and by over a quarter of the largest growth there; the last of them, and after
    it those that still grew that much or lost less than the free law by three times that
    law's scatter (``beyond_law``: a hand that pushes over a whole swing, or only makes up the
    loss).  Where none grew in amplitude, the swing grew only in size: a hold let go (the half
    swing before the one whose size jumped the most).
    """
    lo, hi = max(int(run[0]) - SIDE - 1, 0), min(int(run[-1]) + 2, v.size - 4)
    if hi < lo:
        return int(run[0])
    growth = np.array([amplitude_growth(v, k) for k in range(lo, hi + 1)])
    enough = max(3.0 * noise, 0.25 * float(growth.max()))
    grew = np.flatnonzero(growth >= enough)
    law_scale = robust_scale(beyond_law) if beyond_law is not None else math.nan
    if not grew.size and math.isfinite(law_scale):  # a small push: seen against the free law only
        grew = np.flatnonzero(beyond_law[lo:hi + 1] > 3.0 * law_scale)
    if not grew.size:
        # the swing grew in size but not in amplitude: a hold (tiny swings about a held angle)
        # let go at a turning point, the start of the half swing whose size jumped the most
        p = np.abs(np.diff(v))
        jump = p[lo + 1:hi + 2] - p[lo:hi + 1]
        return lo + int(np.argmax(jump))
    last = lo + int(grew[-1])
    # a hand still pushing: the amplitude grows, or the swing loses much less than its free law
    # (beyond_law, escfit.analysis.free_law) says it should: a hand that only makes up the loss
    while last + 1 <= v.size - 4 and (amplitude_growth(v, last + 1) > 3.0 * noise or (
            math.isfinite(law_scale) and last + 1 < beyond_law.size and beyond_law[last + 1] > 3.0 * law_scale)):
        last += 1
    return last


def _one_sided(v: np.ndarray, j: int, gain: float, s_p: float, near: int = 3) -> bool:
    """Whether the swing's gain across half swing ``j`` came on one side of the centre only.

    A push adds swing on both sides: the maxima after it step up and the minima step down, by
    about half the gain each.  A tracker that read a few maxima (or minima) short and then right
    again moves one side only: that side steps by the whole gain, the other not at all.  Each
    side's step is fitted to its ``near`` turning points before half swing ``j`` (the last one
    the swing grew in; the turning point it starts from is left out, a push of two half swings
    moved it part way) and ``near`` from its end on, with a straight line for the decay
    (``a + b i + step [i > j]``).  One-sided:
    one side's step within a quarter of the gain (and three times its noise) of zero while the
    other carries over half of it.  (A centre that jumps as well, a wrap or a moved origin, moves
    both sides: that is not this.)  ``s_p`` is the noise of a peak-to-peak swing.
    """
    steps, noise = [], []
    for side in (0, 1):
        before = [i for i in range(max(0, j - 2 * near), j) if i % 2 == side]
        after = [i for i in range(j + 1, min(j + 1 + 2 * near, v.size)) if i % 2 == side]
        if not before or len(after) < 2:  # at the record's start one turning point before will do
            return False
        idx = np.array(before + after, float)
        design = np.stack([np.ones_like(idx), idx - j, (idx > j).astype(float)], axis=1)
        coef, *_ = np.linalg.lstsq(design, v[np.array(before + after)], rcond=None)
        steps.append(abs(float(coef[2])))
        # turning points scatter by s_p / sqrt(2) (a peak-to-peak swing shares two of them)
        var = float(np.linalg.pinv(design.T @ design)[2, 2])
        noise.append((s_p / math.sqrt(2.0)) * math.sqrt(var) if math.isfinite(s_p) else 0.0)
    still, moved = (0, 1) if steps[0] <= steps[1] else (1, 0)
    return steps[still] <= max(0.25 * gain, 3.0 * noise[still]) and steps[moved] > 0.5 * gain


def _spans_jump(v: np.ndarray, p: np.ndarray, k: int, jump: float) -> bool:
    """Whether half swing ``k`` alone carries the jump: longer (or shorter) than its neighbours'
    mean by the jump, as a move of the centre within it makes it, within a third of the jump.

    A rising half swing (``v_(k+1) > v_k``) is lengthened by an upward jump, a falling one
    shortened; beating or a changing swing moves the centre estimates without that signature.
    """
    if k < 1 or k + 1 >= p.size:
        return False
    odd = p[k] - 0.5 * (p[k - 1] + p[k + 1])
    expected = jump if v[k + 1] > v[k] else -jump
    return abs(odd - expected) < abs(jump) / 3.0


def _clusters(flags: np.ndarray, merge: int = 1) -> list[np.ndarray]:
    """Runs of True indices, those less than ``merge`` apart joined."""
    idx = np.flatnonzero(flags)
    if not idx.size:
        return []
    breaks = np.flatnonzero(np.diff(idx) > merge) + 1
    return np.split(idx, breaks)


def _push_runs(level: np.ndarray, law: np.ndarray) -> list[np.ndarray]:
    """The positions of each push, from the flags of the level test and of the free-law test.

    The level test's windows are wide: its flags within ``SIDE + 3`` of each other are one
    push.  The free law's flags of one push are contiguous, so where two or more runs of them
    fall within one run of the level test, they split it (pushes close together); otherwise a
    level run and the law runs that touch it are one push, and law runs away from any level run
    are pushes of their own.  Level positions are kept only in a push they decide alone.
    """
    law_runs = _clusters(law, merge=1)
    runs, used = [], set()
    for lv in _clusters(level, merge=SIDE + 3):
        touching = [i for i, r in enumerate(law_runs) if r[0] <= lv[-1] + 2 and r[-1] >= lv[0] - 2]
        used.update(touching)
        if len(touching) > 1:
            runs += [law_runs[i] for i in touching]
        else:
            runs.append(np.union1d(lv, law_runs[touching[0]]) if touching else lv)
    runs += [r for i, r in enumerate(law_runs) if i not in used]
    return sorted(runs, key=lambda r: int(r[0]))


def find_events(times: np.ndarray, values: np.ndarray, *, resolution: float, quantum: float = 0.0,
                show: Callable[[float], str] = lambda v: f"{v:.3g}") -> list[SwingEvent]:
    """Pushes and offset steps among alternating turning points ``values`` at ``times`` (s).

    Parameters
    ----------
    times, values
        Turning points in order, maxima and minima alternating (rad for an angle).
    resolution
        Smallest change the record resolves (the extremum search's hysteresis), same unit.
    quantum
        The sensor's step, same unit (0: none known): a gain beyond the free law must exceed
        three of them (the turning points are fitted on many samples, so their own noise,
        measured from their scatter, is the test's scale, not the hysteresis).
    show
        Writes a value of the record's quantity for the evidence sentences.

    Returns
    -------
    list of SwingEvent
        In time order.  A wobble, a glitch and noise give none.
    """
    t = np.asarray(times, float)
    v = np.asarray(values, float)
    if v.size < 2 * MIN_SIDE + 4:
        return []
    p = np.abs(np.diff(v))
    floor = 2.0 * resolution
    events: list[SwingEvent] = []
    # p_k and p_(k+1) share a turning point: turning points of noise s give p a noise of
    # sqrt(2) s and second differences of p one of 2 s
    gain, err = swing_gains(np.fmax(p, 0.5 * floor if floor > 0 else 1e-300), noise_ratio=math.sqrt(2.0), log=True)
    s_p = robust_scale(np.diff(p, 2)) / math.sqrt(2.0)
    spread = robust_scale(gain)
    # a wobble changes the swing by a share of itself at every amplitude, while the noise of a
    # relative gain grows as the swing fades: measured against that noise, a long faded tail's
    # scattered gains no longer set the wobble's scale where the swing is large
    relative = robust_scale(gain / err) * err
    scale = np.fmax(err, np.fmin(spread, relative) if math.isfinite(spread) else 0.0)
    j = np.arange(p.size)
    level = window_medians(p, np.maximum(0, j - 1 - SIDE), np.maximum(1, j - 1))
    absolute = level * np.expm1(np.nan_to_num(gain))  # the gain in the record's unit
    pushes = np.isfinite(gain) & (gain > Z_PUSH * scale) & (absolute > floor)
    # pushes a short record with several of them hides from the level test: energy gained
    # beyond the record's own free law (escfit.analysis.free_law)
    law, law_step, law_err, deepest = law_pushes(p, 3.0 * quantum)
    beyond = free_law_gains(p) if np.isfinite(law_step).any() else None
    for run in _push_runs(pushes, law):
        # turning points of noise s_p / sqrt(2) and centres of noise sqrt(6)/4 of it: a growth's
        # noise is about that of one peak-to-peak swing
        k = _pushed_half_swings(v, run, s_p, beyond)
        level_run = run[pushes[run]]
        if level_run.size:  # the level test's evidence where it has some, else the free law's
            j = int(level_run[np.argmax(gain[level_run])])
            size, score = float(absolute[j]), float(gain[j] / scale[j]) if scale[j] > 0 else math.inf
            said = (f"the swing gains {100 * np.expm1(gain[j]):.0f} % ({show(size)} peak to peak) in the half swing "
                    f"ending at t = {t[k + 1]:.4g} s and keeps it: {score:.0f} times the larger of its reading noise "
                    f"({100 * err[j]:.2g} %) and the rise and fall of the swing elsewhere in the record "
                    f"({100 * spread:.2g} %)")
        else:
            j = int(run[np.argmax(law_step[run])])
            size, score = float(law_step[j]), float(law_step[j] / law_err[j]) if law_err[j] > 0 else math.inf
            said = (f"the swing gains {show(size)} peak to peak ({100 * size / level[j]:.0f} %) beyond what the "
                    f"record's own free decay loses at that size, in the half swing ending at t = {t[k + 1]:.4g} s, "
                    f"and keeps it: {score:.0f} times its reading noise, and nowhere else does the swing fall short "
                    f"of that law by more than {show(deepest)}")
        if not _one_sided(v, k, size, s_p):  # else a tracker that read one side short, then right again
            events.append(SwingEvent("push", k, float(t[k + 1]), size, score, said))
    c = _centres(v)
    # c_k = (v_k + 2 v_(k+1) + v_(k+2)) / 4 and its second differences scatter alike (sqrt(6)/4 s)
    step, step_err = swing_gains(c, noise_ratio=1.0)
    c_spread = robust_scale(step)
    c_scale = np.fmax(step_err, c_spread if math.isfinite(c_spread) else 0.0)
    moved = np.isfinite(step) & (np.abs(step) > Z_PUSH * c_scale) & (np.abs(step) > floor) & ~(pushes | law)
    for run in _clusters(moved):
        j = int(run[np.argmax(np.abs(step[run]))])
        if any(abs(e.half_swing - j) <= 2 for e in events):
            continue
        # a jump in half swing k moves c by a quarter at k-1, three quarters at k and whole from k+1
        # on: the largest change of c is from k-1 to k
        lo, hi = max(j - 2, 1), min(j + 2, c.size - 2)
        k = lo + int(np.argmax(np.sign(step[j]) * np.diff(c[lo - 1:hi + 1])))
        if not _spans_jump(v, p, k, float(step[j])):
            continue
        score = float(abs(step[j]) / c_scale[j]) if c_scale[j] > 0 else math.inf
        events.append(SwingEvent(
            "offset step", k, float(t[k + 1]), float(step[j]), score,
            f"the centre jumps by {show(step[j])} in the half swing ending at t = {t[k + 1]:.4g} s while the swing "
            f"keeps its size ({score:.0f} times the scatter of the centre): the tracked origin or the sensor's zero "
            "moved"))
    return sorted(events, key=lambda e: e.time)


def braked_start(values: np.ndarray, *, most: int = 3, reference: int = 6) -> int:
    """Half swings at the start of ``values`` (alternating turning points) that lost more than a free swing can.

    A free swing's loss per half swing grows with its amplitude at most as its square (air
    drag; Coulomb friction takes the same at every amplitude, viscous damping in proportion to
    it).  The first loss ``l_0 = p_0 - p_1`` (``p`` the peak-to-peak swings) is held against the
    most that law allows at ``p_0``: the median loss of the ``reference`` half swings after it
    times ``(p_0 / their median swing)**2``, times :data:`BRAKE_FACTOR` for the scatter of a
    median of few.  A loss beyond that by six standard errors (the losses' noise from the
    second differences of ``p``) was taken out by something other than the oscillator's losses:
    a hand that guided the first swing and let go while it moved, or braked it.  The free decay
    is then taken from the next turning point, and the test repeated there (at most ``most``
    times).

    Returns
    -------
    int
        ``m`` (0: none): the free decay is taken from turning point ``m``.
    """
    p = np.abs(np.diff(np.asarray(values, float)))
    if p.size < reference + 3 or not np.all(np.isfinite(p)):
        return 0
    loss = -np.diff(p)
    s_l = robust_scale(np.diff(p, 2)) / math.sqrt(2.0)
    m = 0
    while m < most and loss.size - m > reference:
        ahead = slice(m + 1, m + 1 + reference)
        size = float(np.median(p[ahead]))
        allowed = BRAKE_FACTOR * max(float(np.median(loss[ahead])), 0.0) * (p[m] / size) ** 2 if size > 0 else math.inf
        if not loss[m] > allowed + 6.0 * s_l:
            break
        m += 1
    return m


def driven_start(values: np.ndarray, *, most: int = 4, reference: int = 6) -> int:
    """Half swings at the start of ``values`` (alternating turning points) that a drive kept up.

    A free swing loses at every half swing, and never less at a larger amplitude than at a
    smaller one: Coulomb friction takes the same at every amplitude, viscous damping in
    proportion to it, air drag in proportion to its square.  The losses ``l_k = p_k - p_(k+1)``
    of the first half swings (at most ``most``) are compared with the loss the free swing just
    after them takes at their own amplitude: a straight line of loss against peak-to-peak
    swing through the ``reference`` half swings after a candidate prefix of ``m`` (the half
    swing after the prefix, in which the drive stops, left out), carried up to the prefix's
    swings.  For a loss law of those three kinds that line lies below the law above the
    swings it was fitted on, so the expectation errs low, never high.  Leading losses under
    three quarters of it were made up by a drive (or a hand) that was then switched off; the
    start found is the turning point after the drive's last half swing (the half swing in which
    it stops loses about half the free loss, so one half swing late at most).  Decided only
    where the leading losses fall short of the line by four standard errors (the losses' noise
    from the second differences of ``p``, and the line's own uncertainty where it is carried),
    so that no free start is taken for a driven one by chance.  A fast decay is measured as
    well as a slow one: its losses shrink along the record, and the line follows them.

    Returns
    -------
    int
        ``m`` (0: none): the free decay is taken from turning point ``m + 1``.
    """
    v = np.asarray(values, float)
    p = np.abs(np.diff(v))
    if p.size < most + reference + 2 or not np.all(np.isfinite(p)):
        return 0
    loss = -np.diff(p)
    # the second differences of p are differences of successive losses: sqrt(2) times their noise
    s_l = robust_scale(np.diff(p, 2)) / math.sqrt(2.0)
    found, evidence = 0, None
    for m in range(1, most + 1):
        expected, spread = _free_loss_line(p[m + 1:m + 1 + reference], loss[m + 1:m + 1 + reference], p[:m])
        if not loss[m - 1] < 0.75 * expected[m - 1]:
            break
        deficit = float(np.mean(expected - loss[:m]))
        se = s_l * math.sqrt(1.0 / m + float(np.mean(spread)))
        found, evidence = m, (deficit, se)
    if not found or evidence[0] < 4.0 * evidence[1]:
        return 0
    m, deficit = found, evidence[0]
    # a slow wobble of the swing makes its losses run short and long by turns all along the
    # record: the start's shortfall must stand out of the same shortfall measured everywhere else
    # the swing still stands out (where it has faded to noise, the shortfall over the swing is noise
    # over almost nothing)
    start = float(np.mean(p[:m + reference]))
    windows = [j for j in range(1, loss.size - most - reference)
               if np.mean(p[j:j + m + reference]) >= WOBBLE_FLOOR * start]
    later = [float(np.median(loss[j + most + 1:j + most + 1 + reference])) - float(np.mean(loss[j:j + m]))
             for j in windows]
    size = [float(np.mean(p[j:j + m + reference])) for j in windows]
    if stands_out(deficit / start, np.array(later) / np.array(size)) is False:
        return 0
    return m


def _free_loss_line(swing: np.ndarray, loss: np.ndarray, at: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The loss per half swing a line through ``(swing, loss)`` gives at the swings ``at``, and
    the variance of each, in units of one loss's noise variance (least squares; a flat line at
    the mean where the swings hardly differ)."""
    centre = float(np.mean(swing))
    sxx = float(np.sum((swing - centre) ** 2))
    mean = float(np.mean(loss))
    if sxx <= 1e-12 * max(centre * centre, 1e-300) * swing.size:
        return np.full(at.size, mean), np.full(at.size, 1.0 / swing.size)
    slope = float(np.sum((swing - centre) * (loss - mean))) / sxx
    d = at - centre
    return mean + slope * d, 1.0 / swing.size + d * d / sxx


def swung_up(values: np.ndarray, *, share: float = 0.5, span: int = 5) -> int:
    """The turning point where a swing that grew over many half swings peaks (0: it did not grow).

    A free oscillator only loses energy: its swing is never larger than at its start.  A record
    whose swing grows from under ``share`` of its largest (a drive or a hand swinging it up, a
    resonance building) was driven until it peaked, and its free decay cannot start before that.
    The swings are medians of ``span`` consecutive peak-to-peak swings, so that a glitch, a
    tracking slip or a few noisy turns neither make a peak nor hide one; growth within the noise
    or a wobble of a few per cent never reaches a factor ``1/share``.

    Returns
    -------
    int
        Index into ``values`` of the first turning point of the largest median swing (where the
        decay may begin), or 0.
    """
    p = np.abs(np.diff(np.asarray(values, float)))
    if p.size < 3 * span or not np.all(np.isfinite(p)):
        return 0
    smooth = np.array([np.median(p[i:i + span]) for i in range(p.size - span + 1)])
    peak = int(np.argmax(smooth))
    if peak < span or smooth[0] >= share * smooth[peak]:
        return 0
    # the largest single swing within the peak's window: its first turning point
    return peak + int(np.argmax(p[peak:peak + span]))


def stands_out(change: float, elsewhere: np.ndarray, *, factor: float = 2.0, least: int = 5) -> bool | None:
    """Whether ``change`` at a record's start exceeds ``factor`` times the 90th percentile of
    the same change measured along the rest of the record (``elsewhere``, same scale and sign:
    a decay whose loss shrinks as it fades gives changes of the other sign, which do not count).

    A drive switched off or a hand's guided start changes the record once; a slow wobble of
    the swing changes it by as much, both ways, all along (over the wobbling decays of the
    artefact suite the start's change was at most 1.3 times that percentile, after a real drive
    3.8 times or more).  None when fewer than ``least`` measures elsewhere can say.
    """
    e = np.asarray(elsewhere, float)
    e = e[np.isfinite(e)]
    if e.size < least:
        return None
    return bool(change > factor * max(float(np.quantile(e, 0.9)), 0.0))
