"""Where the motion of a record ends: at rest, or sunk into the record's noise.

A record that rests at the end is cut where it rests (:func:`resting_tail`: within the rest
band of its final level for a period, no swing left above the noise).  Many records never do: a
phone's gyroscope reads its bias, its noise and, now and then, a step of the bias long after
the swing has gone; a tracker keeps wandering.  Past the point where the swing has sunk into
that noise, its turning points are the noise's, and a wobble of the noise or a bias step looks
like the swing growing again (a push, beating, a drive) although nothing moved.

The swing and the noise are measured together, window by window: over two periods, stepped by
a quarter period, the samples are fitted with ``c + d s + (a + a' s) cos(w s) + (b + b' s)
sin(w s)`` (``w`` the record's angular frequency, ``s`` the time from the window's centre, the
amplitude free to change linearly across the window as a decay makes it).  ``hypot(a, b)`` is
the swing's amplitude at the window's centre; the root mean square of what the fit leaves is
the noise there (anything that is not the swing: reading noise, a bias step, a wobble).

- **Noise floor**: the median residual of the windows after the largest swing in which the
  swing does not stand :data:`CUT_RATIO` times above its own window's residual.
- **End of motion**: the first window after the last one that still swings well above the
  floor (amplitude over :data:`AGAIN_RATIO` floors and over :data:`CUT_RATIO` times its own
  residual) whose amplitude is at most :data:`CUT_RATIO` floors: the record is cut at its
  centre.  A window that "swings" by a bias step leaves a residual as large as its amplitude,
  so it is no motion; a push after the swing had sunk makes a new decay, well above the floor,
  and the end is looked for after it.

No end is found when the swing never sinks to :data:`CUT_RATIO` floors, or does so less than
:data:`MIN_TAIL_PERIODS` period before the record ends.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...core.errors import DataError
from .extrema import local_amplitude
from .series import quantity_words

__all__ = ["SunkEnd", "resting_tail", "noise_tail", "window_fits", "sunk_end", "sunk_end_before", "describe", "CUT_RATIO", "AGAIN_RATIO", "CUT_WARNING"]

RESUME_SHARE = 0.3  # a tail that swings again by this share of the swing before it is motion, not noise
MOVING_SIGMAS = 6.0  # a window's swing above this many of its noise scales is motion (the resting tail)
CUT_RATIO = 3.0  # the swing has sunk where its amplitude is this many noise floors
AGAIN_RATIO = 6.0  # twice that: a later window this far above the floor swings again
WINDOW_PERIODS = 2.0  # long enough to average the noise, short enough to follow a decay
STEP_PERIODS = 0.25
MIN_TAIL_PERIODS = 1.0  # a shorter tail after the end is not worth a cut
MIN_NOISE_WINDOWS = 4  # a period of windows in the noise at least
CUT_WARNING = 0.25  # leaving out more than this share of the record is a warning


@dataclass(frozen=True)
class SunkEnd:
    """Where the swing sank into the noise, with the evidence.

    Attributes
    ----------
    time : float
        The end of motion, s (the record's clock): the centre of the first window whose swing
        is at most :data:`CUT_RATIO` noise floors.
    index : int
        The first sample left out.
    floor : float
        The noise floor (the samples' unit): root mean square of the samples about the local
        swing where the swing no longer stands out.
    amplitude : float
        The swing's amplitude at the end (the samples' unit).
    share : float
        Share of the record's duration left out as noise (0 to 1).
    at_rest : float
        Share of the record's duration after the noise where the record rests (left out as
        rest, not counted in ``share``).
    """

    time: float
    index: int
    floor: float
    amplitude: float
    share: float
    at_rest: float = 0.0


def window_fits(t: np.ndarray, x: np.ndarray, period: float, *, width: float = WINDOW_PERIODS,
                step: float = STEP_PERIODS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centre (s), swing amplitude and residual scale of each window (see the module docstring).

    Windows are ``width`` periods long, ``step`` periods apart; amplitude and residual are
    ``nan`` in a window with fewer than 12 samples.
    """
    w = 2.0 * math.pi / period
    span = width * period
    starts = np.arange(t[0], t[-1] - span + 1e-9 * span, step * period)
    centres = starts + 0.5 * span
    amp = np.full(starts.size, math.nan)
    resid = np.full(starts.size, math.nan)
    lo = np.searchsorted(t, starts)
    hi = np.searchsorted(t, starts + span)
    for k, (a, b) in enumerate(zip(lo, hi)):
        n = b - a
        if n < 12:
            continue
        s = t[a:b] - centres[k]
        c, si = np.cos(w * s), np.sin(w * s)
        basis = np.stack([np.ones_like(s), s, c, si, s * c, s * si], axis=1)
        coef, *_ = np.linalg.lstsq(basis, x[a:b], rcond=None)
        r = x[a:b] - basis @ coef
        amp[k] = math.hypot(coef[2], coef[3])
        resid[k] = math.sqrt(float(r @ r) / (n - basis.shape[1]))
    return centres, amp, resid


def sunk_end(t: np.ndarray, x: np.ndarray, period: float) -> SunkEnd | None:
    """Where the swing of ``x`` (samples at times ``t``, s) sank into the noise; ``None`` if it never does.

    ``period`` is the swing's period, s.  See the module docstring for the rule.
    """
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    if t.size < 24 or not (math.isfinite(period) and period > 0) or t[-1] - t[0] < 4.0 * period:
        return None
    centres, amp, resid = window_fits(t, x, period)
    ok = np.isfinite(amp)
    if np.count_nonzero(ok) < 2 * MIN_NOISE_WINDOWS:
        return None
    top = int(np.nanargmax(amp))
    after = ok & (np.arange(amp.size) > top)
    quiet = after & (amp < CUT_RATIO * resid)
    if np.count_nonzero(quiet) < MIN_NOISE_WINDOWS:
        return None
    floor = float(np.median(resid[quiet]))
    if not floor > 0:
        return None
    swinging = after & (amp > AGAIN_RATIO * floor) & (amp > CUT_RATIO * resid)
    last = int(np.flatnonzero(swinging)[-1]) if swinging.any() else top
    sunk = np.flatnonzero(ok & (np.arange(amp.size) > last) & (amp <= CUT_RATIO * floor))
    if not sunk.size:
        return None
    k = int(sunk[0])
    end = float(centres[k])
    if t[-1] - end < MIN_TAIL_PERIODS * period:
        return None
    index = int(np.searchsorted(t, end))
    return SunkEnd(end, index, floor, float(amp[k]), float((t[-1] - end) / (t[-1] - t[0])))


def describe(end: SunkEnd, show, origin: float = 0.0) -> tuple[str, str]:
    """The note on ``end`` and, when more than :data:`CUT_WARNING` of the record is left out, a warning.

    ``show(value)`` writes a value of the record's quantity; ``origin`` is subtracted from the
    times shown (the record's first sample).
    """
    at = end.time - origin
    ratio = f"{end.amplitude / end.floor:.2g} times the noise floor of {show(end.floor)}"
    after = f"{_percent(end.share + end.at_rest)} of it"
    if end.at_rest > 0:
        after += f": {_percent(end.share)} noise, then {_percent(end.at_rest)} at rest"
    note = (f"the swing sinks into the record's noise at t = {at:.4g} s: its amplitude there is "
            f"{show(end.amplitude)}, {ratio} (the scatter of the samples about the local swing where the swing no "
            f"longer stands out; {CUT_RATIO:g} floors or less is noise); the record after it is left out ({after}) as "
            "noise, not motion (its wobbles and steps are no push); [recording] stop sets the end otherwise")
    warning = ""
    if end.share > CUT_WARNING:
        warning = (f"{_percent(end.share)} of the record (from t = {at:.4g} s on) is left out: the swing has sunk "
                   f"there to {show(end.amplitude)}, {ratio}, and what follows is noise; if the motion goes on there, "
                   "set [recording] stop later to keep it")
    return note, warning


def _percent(share: float) -> str:
    """A share of the record (0-1) in per cent: whole per cent, or "under 1 %"."""
    return "under 1 %" if 0 < share < 0.005 else f"{100 * share:.0f} %"


def resting_tail(rec) -> tuple[int, float]:
    """Index of the first sample at rest (``t.size`` when the record ends in motion) and the rest angle.

    At rest means within the rest band of the final level for at least a period *and* no
    swing left above the noise: a slow record's small swings hide in the band sample by
    sample but stand out over a whole period (:func:`~escfit.analysis.recordings.extrema.local_amplitude`).
    """
    t, n = rec.t, rec.t.size
    final = t >= t[-1] - rec.period
    rest = float(np.median(rec.x[final]))
    out = np.flatnonzero(np.abs(rec.xs - rest) > rec.band)
    if not out.size:
        raise DataError(f"no motion: the {quantity_words(rec.quantity)} stays within {rec.show(rec.band)} of "
                        f"{rec.show(rest, 4)}", rec.where)
    i = int(out[-1]) + 1
    if i >= n or t[-1] - t[i] < rec.period:
        return n, math.nan
    starts, amp = local_amplitude(t[i:], rec.x[i:], rec.period)
    per_window = max(rec.period / rec.dt, 8.0)
    # an encoder without dither cannot show a swing under half a count, however many samples
    floor = max(MOVING_SIGMAS * max(rec.sigma, 0.5 * rec.quantum) * math.sqrt(2.0 / per_window), 0.5 * rec.quantum)
    moving = np.flatnonzero(amp > floor)
    if moving.size:  # the swing goes on below the band: motion ends after the last window that shows it
        i = int(np.searchsorted(t, starts[moving[-1]] + rec.period))
        if i >= n or t[-1] - t[i] < rec.period:
            return n, math.nan
    return i, float(np.median(rec.x[i:]))


def noise_tail(rec, i_rest: int | None = None) -> tuple[object, SunkEnd | None]:
    """The record up to where its swing sank into the noise before it rests (at sample ``i_rest``,
    :func:`resting_tail`; ``None``: it never rests), with the note (and warning) added, and that
    end; the record unchanged and ``None`` when the swing does not sink before it rests, or when
    it swings again after it (:func:`resumes`): motion that resumes had not ended (beating
    modes, repeated impacts), and the analysis that follows says what it is."""
    end = sunk_end_before(rec.t, rec.x, rec.period, i_rest)
    if end is None or resumes(rec.t, rec.x, end.index, rec.period):
        return rec, None
    note, warning = describe(end, lambda v: rec.show(v, 2))
    rec.notes.append(note)
    if warning:
        rec.warnings.append(warning)
    return rec.head(end.index), end


def resumes(t: np.ndarray, x: np.ndarray, index: int, period: float) -> bool:
    """Whether the record swings again after sample ``index`` by :data:`RESUME_SHARE` of its swing
    before it (half its peak-to-peak range there).  The record after is cut into one-period
    stretches, each less its straight line (a drifting zero, an integrated bias); the second
    largest half range counts, so that one step of the zero does not.  A noise tail stays far
    below the swing; a beat or another impact comes back to its size, again and again."""
    before, after, ta = np.asarray(x[:index], float), np.asarray(x[index:], float), np.asarray(t[index:], float)
    if before.size < 2 or after.size < 8 or not (math.isfinite(period) and period > 0):
        return False
    swing = 0.5 * float(np.max(before) - np.min(before))
    edges = np.searchsorted(ta, np.arange(ta[0], ta[-1], period))
    ranges = []
    for lo, hi in zip(edges, np.r_[edges[1:], ta.size]):
        if hi - lo >= 4:
            u, y = ta[lo:hi] - ta[lo], after[lo:hi]
            r = y - np.polyval(np.polyfit(u, y, 1), u)
            ranges.append(0.5 * float(np.max(r) - np.min(r)))
    return len(ranges) >= 2 and sorted(ranges)[-2] > RESUME_SHARE * swing


def sunk_end_before(t: np.ndarray, x: np.ndarray, period: float, i_rest: int | None = None) -> SunkEnd | None:
    """:func:`sunk_end` when it comes before the rest that starts at sample ``i_rest`` (``None``:
    the record never rests), its ``share`` that of the record left out as noise before the rest.

    The floor is measured over the whole record, the rest included: where a swing stops dead
    (dry friction) the windows that span the stop leave a residual of the fit's own, not noise.
    """
    n = t.size if i_rest is None else int(i_rest)
    end = sunk_end(t, x, period)
    if end is None or end.index >= n:
        return None
    span = float(t[-1]) - float(t[0])
    share = (float(t[n - 1]) - end.time) / span
    return SunkEnd(end.time, end.index, end.floor, end.amplitude, max(share, 0.0),
                   max((float(t[-1]) - float(t[n - 1])) / span, 0.0))
