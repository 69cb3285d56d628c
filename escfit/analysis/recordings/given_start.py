"""The free decay's start where the user set it: ``[recording] release`` or ``start``.

The user always wins over the automatic search of :mod:`escfit.analysis.recordings.motion`: with
a window (:class:`~escfit.analysis.recordings.window.RecordWindow`) whose ``release`` or ``start``
is set, :func:`~escfit.analysis.recordings.turning_points.reduce_series` calls :func:`user_reference`
instead of :func:`~escfit.analysis.recordings.motion.reference`, and no push, pull, hold or drive
before that instant is looked for.

- ``release`` at ``T``: the model is released at rest there.  When the record is flat over the
  tenth of a period before ``T`` (held), the release is at ``T`` from the held angle (the
  angle at ``T`` of a polynomial without linear term fitted to the samples after it, as for a
  file's own release instant).  Else the refined turning point within :data:`NEAR_PERIODS`
  periods of ``T`` is the reference: a release at rest is exact physics only where the
  velocity vanishes.  An instant farther from any turning point takes the next one at or
  after it, with a note.
- ``start`` alone: the first turning point at or after it (the series is already cut there),
  found as the automatic analysis finds a record's first turning point (one at the first
  sample, a held start).

The faded end of the record is still cut afterwards (:func:`~escfit.analysis.recordings.motion.faded_end`):
the end is ``stop``'s, or the analysis'.
"""

from __future__ import annotations

import numpy as np

from ...core.errors import DataError
from .extrema import vertex_at
from .holds import HOLD_PERIODS, START_TURN_PERIODS, flat_start, turn_at_start
from .motion import Turn

__all__ = ["user_reference", "NEAR_PERIODS"]

NEAR_PERIODS = 0.1  # a release instant this close to a turning point (in periods) means that turning point


def user_reference(rec, turns: list[Turn], window) -> tuple[float, float, list[Turn]]:
    """Reference instant (s), angle (rad) and the refined turning points after it, as the user set them.

    Parameters
    ----------
    rec
        The analysis record of :mod:`~escfit.analysis.recordings.turning_points`.
    turns
        Its refined extrema, in order (``time`` ``None`` where no local fit fits).
    window
        The user's window on the record's clock (``release`` or ``start`` set).

    Raises
    ------
    DataError
        No turning point at or after the instant.
    """
    turns = _first_turn(rec, list(turns))
    done = [u for u in turns if u.time is not None]
    if window.release is not None:
        return _release(rec, done, float(window.release), window)
    start = float(window.start)
    after = [u for u in done if u.time >= start - START_TURN_PERIODS * rec.period]
    if not after:
        raise DataError(f"no turning point at or after [recording] start (t = {start:.4g} s)",
                        rec.where)
    ref = after[0]
    rec.notes.append(f"window set by [recording] start: the free decay is taken from the first turning point at or "
                     f"after it, at t = {ref.time:.4g} s ({rec.show(ref.value, 4)} on the sensor's scale); no push, "
                     "hold or drive before it was looked for")
    return float(ref.time), float(ref.value), after[1:]


def _first_turn(rec, turns: list[Turn]) -> list[Turn]:
    """The extremum at the very start (no local fit fits there) placed as the automatic analysis
    places it: a turning point at the first sample, or the release of a held start; else dropped."""
    if not turns or turns[0].time is not None:
        return turns
    at = turn_at_start(rec)
    flat = flat_start(rec) if at is None or at[2] != turns[0].is_max else None
    if flat is not None:
        return [Turn(turns[0].first, turns[0].last, turns[0].is_max, flat[0], flat[1])] + turns[1:]
    if at is not None:
        rest = turns[1:] if at[2] == turns[0].is_max else turns[2:]
        return [Turn(0, 0, at[2], at[0], at[1])] + rest
    return turns[1:]


def _held_angle(rec, instant: float) -> float | None:
    """The held angle (rad) when the record is flat over the tenth of a period up to ``instant``, else None.

    A free turning point is flat there too when the swing is small against the rest band; it is
    told from a hold by its other side: over the same time before ``instant`` (up to a quarter
    period) a turning point moves about as far as after it, a hold not a quarter as far.
    """
    t, x = rec.t, rec.x
    lo, hi = np.searchsorted(t, [instant - HOLD_PERIODS * rec.period, instant], side="right")
    if hi - lo < 3 or t[0] > instant - HOLD_PERIODS * rec.period:
        return None
    level = float(np.median(x[lo:hi]))
    if np.any(np.abs(rec.xs[lo:hi] - level) > rec.band):
        return None
    h = min(0.25 * rec.period, instant - t[0], t[-1] - instant)
    moved_before = abs(float(np.interp(instant - h, t, rec.xs)) - level)
    if moved_before > 0.25 * abs(float(np.interp(instant + h, t, rec.xs)) - level):
        return None
    right = (t >= instant) & (t <= instant + rec.half_width())
    if np.count_nonzero(right) < 4:
        return level
    return float(vertex_at(t[right] - instant, x[right], rec.degree)[1])


def _release(rec, done: list[Turn], instant: float, window) -> tuple[float, float, list[Turn]]:
    """The reference for ``[recording] release`` (see the module docstring)."""
    said = f"release set by [recording] release (t = {instant:.4g} s)"
    held = _held_angle(rec, instant)
    if held is not None:
        later = [u for u in done if u.time > instant + 0.25 * rec.period and rec.t[u.first] > instant]
        rec.notes.append(f"{said}: released at rest from the held {rec.show(held, 4)}; no push, hold or drive before "
                         "it was looked for")
        return instant, held, later
    if not done:
        raise DataError(f"no turning point near or after [recording] release (t = {instant:.4g} s)",
                        rec.where)
    gap = np.array([abs(u.time - instant) for u in done])
    k = int(np.argmin(gap))
    if gap[k] > NEAR_PERIODS * rec.period:
        following = [i for i, u in enumerate(done) if u.time >= instant]
        if not following:
            raise DataError(f"no turning point at or after [recording] release (t = {instant:.4g} "
                            "s)", rec.where)
        near, k = done[k], following[0]
        rec.notes.append(f"{said} is not at a turning point (the nearest, at t = {near.time:.4g} s, is "
                         f"{gap[int(np.argmin(gap))]:.3g} s away, more than {NEAR_PERIODS:g} period): the model is "
                         f"released at the next turning point, at t = {done[k].time:.4g} s")
    else:
        rec.notes.append(f"{said}: released at rest at the turning point at t = {done[k].time:.4g} s "
                         f"({rec.show(done[k].value, 4)} on the sensor's scale); no push, hold or drive before it was "
                         "looked for")
    return float(done[k].time), float(done[k].value), done[k + 1:]
