"""The time base of a record: the sample times checked and, where a logger's clock failed, repaired.

The first stage of a record's analysis.  :func:`time_base` takes the time stamps as read (s, one
per row, in the file's order) and, optionally, each row's reading, and returns a
:class:`TimeBase`: strictly increasing times, the rows they belong to, what was repaired, the
sampling interval and its jitter.

Repairs, in this order, each recorded as a :class:`Repair` whose sentence says what was done:

0. *a clock restarted*: a file holding several runs one after another, the clock starting again
   near its first stamp at each and the readings jumping there (a logger restarted, runs
   appended).  The runs cannot be one record; the longest (a tenth longer than any other) is
   kept, with a warning naming the others' rows.  A clock that starts again while the readings
   go on smoothly is one motion: refused, naming ``sample_rate``;
1. *rows out of time order*: a few isolated rows where the time goes backwards for one row and
   then continues.  A pair of neighbours written in reverse order is swapped; otherwise the row
   whose stamp breaks the order is dropped (of the choices that restore the order, the one that
   leaves the most regular steps);
2. *repeated rows*: a row repeating the previous one exactly (stamp and reading) is dropped
   (not in a record stamped in bursts, where equal rows may be real samples);
3. *a stalled clock*: a stamp repeated over a long run of rows while the readings go on, a
   stamp that repeats and does not catch up afterwards, or one step forward longer than all the
   rest of the record.  The record is cut there and the longest stretch that keeps time kept;
4. *stamps in bursts*: a logger stamping a buffer (the same stamp over runs of rows, regular in
   length or not).  Every row is re-timed on a robust straight line of stamp on row number
   through the bursts' first rows, accepted when no stamp is further from it than the longest
   burst spans.  A few short runs of a repeated stamp in a record stamped row by row are
   instead re-timed evenly between the neighbouring stamps;
   Stamps written with too few digits (never falling, a fifth of the rows sharing a stamp in
   short runs) are re-timed on the same line; a clock written to a few significant digits,
   whose runs grow tenfold with each decade, first (:mod:`escfit.analysis.rounded_stamps`).  So are stamps that arrive in *clusters* (a
   computer stamping rows as they come out of a logger's buffer: most steps shorter than half
   the mean step, many of them above zero), but only when the readings show that the rows were
   taken evenly: they step no more across a cluster's gap than within a cluster.  Otherwise the
   stamps are kept as the sample times, with a note;
5. *gaps*: a step longer than :data:`GAP_INTERVALS` intervals is kept (the fits take irregular
   times) and noted, as is a jitter of the steps above :data:`JITTER_NOTE` of the interval.

What cannot be repaired (the time going backwards often or on a large scale, a clock that
never advances, bursts off a straight line, a non-finite or absurd interval) is refused with a
:class:`~escfit.core.errors.DataError` whose one-line message says what was found and names
the fix: the logger's rate as ``[recording] sample_rate`` (or ``--sample-rate``), with the
rate measured from the stamps where it can be.

Repairs that drop or re-time more than :data:`LARGE_FRACTION` of the rows are the result's
:attr:`TimeBase.warnings`, the others its :attr:`TimeBase.notes`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..core.errors import DataError
from .rounded_stamps import rounded_clock
from .runs import appended_runs

__all__ = ["TimeBase", "Repair", "time_base", "FIX", "LARGE_FRACTION"]

FIX = "set [recording] sample_rate (or --sample-rate) to the logger's rate"
LARGE_FRACTION = 0.05  # repairs touching more of the rows than this are warnings
GAP_INTERVALS = 3.0  # a step longer than this many intervals is a gap (noted)
JITTER_NOTE = 0.10  # a robust spread of the steps above this fraction of the interval is noted
JUMP_INTERVALS = 20.0  # a clock jump is at least this many intervals (and longer than the rest)
STALL_ROWS = 8  # a run of one stamp over this many rows (or STALL_BURSTS bursts) is a stall
STALL_BURSTS = 4
KEEP_FRACTION = 0.25  # a cut must keep at least this fraction of the rows
INTERVAL_RANGE = (1e-9, 1e7)  # s: sampling intervals outside are not a recording's
CATCH_UP = (2.0 / 3.0, 1.5)  # a repeated stamp re-timed locally: the steps it implies, in intervals
CLUSTER_STEP = 0.5  # a step shorter than this many mean intervals lies inside a cluster of stamps
EVEN_STEPS = 2.0  # readings stepping less than this many times more across a gap than inside: rows even
RATE_WINDOW = 64  # rows: the stretches over which a refusal measures the rate it suggests
SMOOTH = 0.5  # readings are smooth in row order: median |second difference| under this share of |first|


@dataclass(frozen=True)
class Repair:
    """One repair of the time base.

    Attributes
    ----------
    kind : str
        ``"order"``, ``"repeated rows"``, ``"stall"``, ``"bursts"``, ``"repeated stamps"``,
        ``"gap"`` or ``"jitter"`` (the last two are notes only).
    rows : int
        Rows dropped or re-timed (0 for a note that changes nothing).
    text : str
        What was found and done, a plain sentence with counts and times (s).
    doubt : bool
        Whether the repair leaves the time base in doubt (a warning however few rows it touches).
    """

    kind: str
    rows: int
    text: str
    doubt: bool = False


@dataclass(frozen=True)
class TimeBase:
    """The repaired time base of a record (see the module docstring).

    Attributes
    ----------
    time : ndarray
        Times of the kept rows, s, strictly increasing (the file's clock; re-timed rows on
        the fitted line).
    rows : ndarray of int
        The kept rows as indices into the stamps given, in the order of ``time`` (a swap of
        neighbours shows as two indices in reverse order).
    repairs : tuple of Repair
        What was done, in the order done.
    interval : float
        Median step of ``time``, s (``nan`` with fewer than two rows).
    jitter : float
        Robust spread (1.4826 median absolute deviation) of the steps about ``interval``, s.
    rows_read : int
        How many stamps were given.
    """

    time: np.ndarray
    rows: np.ndarray
    repairs: tuple[Repair, ...]
    interval: float
    jitter: float
    rows_read: int

    @property
    def rate(self) -> float:
        """Samples per second, 1/``interval`` (Hz)."""
        return 1.0 / self.interval if self.interval > 0 else math.nan

    @property
    def changed(self) -> int:
        """Rows dropped or re-timed by all repairs together."""
        return sum(r.rows for r in self.repairs)

    @property
    def large(self) -> bool:
        """Whether the repairs drop or re-time more than :data:`LARGE_FRACTION` of the rows."""
        return self.changed > LARGE_FRACTION * self.rows_read

    @property
    def notes(self) -> list[str]:
        """Sentences of the repairs that are notes (all of them unless :attr:`large`)."""
        return [r.text for r in self.repairs if not (self.large and r.rows) and not r.doubt]

    @property
    def warnings(self) -> list[str]:
        """Sentences of the repairs that are warnings: those changing rows, when :attr:`large`, and
        those that leave the time base in doubt."""
        return [r.text for r in self.repairs if (self.large and r.rows) or r.doubt]


def time_base(time, values=None, *, where_of_row: Callable[[int], str] | None = None,
              source: str = "the time stamps") -> TimeBase:
    """Check the time stamps of a record and repair what a logger's clock got wrong.

    Parameters
    ----------
    time
        The stamps, s, one per row in the file's order (any origin).
    values
        Each row's reading (any unit), used only to tell a repeated row (same stamp, same
        reading) from a repeated stamp; ``None``: no row counts as repeated.
    where_of_row
        The location of row ``i`` of ``time`` (0-based) for messages, e.g. ``"file.csv:12 [t]"``.
    source
        The location used when ``where_of_row`` is not given.

    Returns
    -------
    TimeBase
        The kept rows' times, their indices, the repairs, interval and jitter.

    Raises
    ------
    DataError
        What cannot be repaired (see the module docstring); the message names
        ``[recording] sample_rate`` and, where the stamps allow, the rate they imply.
    """
    t = np.asarray(time, dtype=float).ravel()
    v = None if values is None else np.asarray(values, dtype=float).ravel()
    if v is not None and v.size != t.size:
        raise ValueError(f"{t.size} stamps but {v.size} readings")

    def where(row: int) -> str:
        return where_of_row(int(row)) if where_of_row is not None else f"{source} (row {int(row) + 1})"

    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise _refuse(f"time value {float(t[bad[0]])!r} is not a finite number", where(bad[0]), t)
    idx = np.arange(t.size)
    v_read = v
    repairs: list[Repair] = []
    with np.errstate(over="ignore", invalid="ignore"):
        if t.size >= 2 and not np.all(np.isfinite(np.diff(t))):
            raise _refuse(f"the time stamps span more than a float holds ({t.min():.3g} to {t.max():.3g} s)",
                          where(0), t)
        t, idx, v = _restarts(t, idx, v, repairs)
        t, idx, v = _order(t, idx, v, where, repairs)
        even = rounded_clock(t)
        if even is not None:  # a clock written with too few digits: every row re-timed on its line
            repairs.append(Repair("rounded", int(t.size), even[1]))
            return _finish(even[0], idx, repairs, where, int(np.size(time)))
        clusters = _clustered(t)
        bursty = _bursty(t) or _rounded(t) or clusters
        t, idx = _repeated_rows(t, idx, v, bursty, repairs)
        t, idx = _stalls(t, idx, bursty, where, repairs)
        kept = None if v_read is None else v_read[idx]
        if clusters:
            t, idx = _clusters(t, idx, kept, where, repairs)
        else:
            t = _retime(t, idx, bursty, where, repairs)
        return _finish(t, idx, repairs, where, int(np.size(time)))


# -- the steps, in order --------------------------------------------------------------------------------
def _restarts(t, idx, v, repairs):
    """Keep the longest run of a file of runs appended (:func:`~escfit.analysis.runs.appended_runs`)."""
    found = appended_runs(t, v)
    if found is None:
        return t, idx, v
    (lo, hi), bounds, back = found
    others = ", ".join(f"rows {int(idx[a]) + 1}-{int(idx[b - 1]) + 1}" for a, b in bounds if a != lo)
    repairs.append(Repair("restarts", int(t.size - (hi - lo)),
                          f"the clock starts again {back.size} time(s) (at t = {float(t[back[0]]):g} s back to "
                          f"{float(t[back[0] + 1]):g} s{' and more' if back.size > 1 else ''}): the file holds "
                          f"{len(bounds)} runs; the longest, rows {int(idx[lo]) + 1}-{int(idx[hi - 1]) + 1} "
                          f"(t = {float(t[lo]):g} to {float(t[hi - 1]):g} s), is kept, not {others} (cut the "
                          "file to fit another)"))
    return t[lo:hi], idx[lo:hi], None if v is None else v[lo:hi]


def _order(t, idx, v, where, repairs):
    """Swap or drop the few isolated rows that break the time order."""
    neg = np.flatnonzero(np.diff(t) < 0)
    if not neg.size:
        return t, idx, v
    limit = max(5, t.size // 100)
    if neg.size > limit:
        i = int(neg[0])
        steps = np.diff(np.asarray(v, dtype=float))
        if v is not None and (np.all(steps <= 0) or np.all(steps >= 0)) and np.ptp(v) > 0:
            raise DataError(f"time goes backwards at {neg.size} of {t.size} rows, and the readings only "
                            f"{'fall' if steps.sum() < 0 else 'rise'} from row to row: the rows are sorted by the "
                            "reading, a table of amplitudes? read it with [recording] readings = \"amplitudes\" "
                            "(or --readings amplitudes)", where(idx[i + 1]))
        raise _refuse(f"time goes backwards at {neg.size} of {t.size} rows (the first: {float(t[i])!r} then "
                      f"{float(t[i + 1])!r} s), too often to be a few rows out of order", where(idx[i + 1]), t)
    h = _typical_step(t)
    dropped: list[tuple[float, float]] = []
    swapped: list[float] = []
    while neg.size:
        i = int(neg[0])
        choice = _fix_at(t, i, h)
        if choice is None or len(dropped) + len(swapped) >= limit:
            raise _refuse(f"time goes backwards: {float(t[i])!r} then {float(t[i + 1])!r} s, and neither dropping "
                          "nor swapping a row restores the order (the clock was reset?)", where(idx[i + 1]), t)
        order = np.arange(t.size)
        if choice == "swap":
            order[i], order[i + 1] = i + 1, i
            swapped.append(float(t[i + 1]))
        else:
            k = i if choice == "drop first" else i + 1
            dropped.append((float(t[k]), float(t[k - 1]) if k > 0 else math.nan))
            order = np.delete(order, k)
        t, idx = t[order], idx[order]
        v = None if v is None else v[order]
        neg = np.flatnonzero(np.diff(t) < 0)
    if swapped:
        repairs.append(Repair("order", 2 * len(swapped),
                              f"{len(swapped)} pair(s) of neighbouring rows written in reverse time order swapped "
                              f"(the first at t = {swapped[0]:g} s)"))
    if dropped:
        at, after = dropped[0]
        repairs.append(Repair("order", len(dropped),
                              f"{len(dropped)} row(s) out of time order dropped (time going backwards for one row: "
                              f"the first stamped {at:g} s" + (f" after {after:g} s)" if math.isfinite(after) else ")")))
    return t, idx, v


def _fix_at(t, i: int, h: float) -> str | None:
    """How to restore the order where ``t[i + 1] < t[i]``: ``"swap"``, ``"drop first"``, ``"drop second"``
    or None; of the choices that leave the rows around in order, the one whose steps are the most
    regular (closest to the typical step ``h``, a dropped row costing one step)."""
    prev = t[i - 1] if i > 0 else -math.inf
    nxt = t[i + 2] if i + 2 < t.size else math.inf
    a, b = t[i], t[i + 1]
    options = {}
    if prev < b and a < nxt:
        options["swap"] = ([b - prev, a - b, nxt - a], 0.0)
    if prev <= b and b <= nxt:
        options["drop first"] = ([b - prev, nxt - b], 1.0)
    if prev <= a and a <= nxt:
        options["drop second"] = ([a - prev, nxt - a], 1.0)
    if not options:
        return None
    if not math.isfinite(h):
        return next(iter(options))

    def cost(item):
        steps, lost = item[1]
        return sum(abs(s - h) for s in steps if math.isfinite(s)) + lost * h

    return min(options.items(), key=cost)[0]


def _bursty(t) -> bool:
    """Whether the stamps come in bursts: at least half the runs of one stamp span two rows or more."""
    starts = np.flatnonzero(np.r_[True, np.diff(t) != 0])
    runs = np.diff(np.r_[starts, t.size])
    return starts.size >= 3 and float(np.median(runs)) >= 1.5


def _rounded(t) -> bool:
    """Whether the stamps are a clock written with too few digits: never falling, a fifth of the
    rows or more sharing a stamp with the row before, in runs of at most :data:`STALL_ROWS` rows
    (a clock written to three significant digits repeats each stamp three times past 10 s at
    30 rows a second).  They are re-timed as bursts are."""
    if t.size < 20:
        return False
    d = np.diff(t)
    _, runs = _runs(t)
    return bool(np.all(d >= 0) and np.mean(d == 0) >= 0.2 and runs.max() < STALL_ROWS)


def _clustered(t) -> bool:
    """Whether the stamps arrive in clusters: never falling, most steps shorter than
    :data:`CLUSTER_STEP` of the mean step (jumps of the clock, a log that waited, aside), and
    most of those short steps above zero (stamps written with too few digits repeat exactly)."""
    if t.size < 20:
        return False
    d = np.diff(t)
    mean = float(np.mean(d[d <= JUMP_INTERVALS * np.percentile(d, 99)]))  # a wait of the log is no cluster's gap
    if not (mean > 0 and np.all(d >= 0)):
        return False
    short = d < CLUSTER_STEP * mean
    return bool(short.mean() >= 0.5 and (~short).sum() >= 3 and np.mean(d[short] > 0) >= 0.5)


def _repeated_rows(t, idx, v, bursty: bool, repairs):
    """Drop rows repeating the previous one exactly (a pasted copy), unless the stamps come in bursts."""
    if v is None or bursty or t.size < 2:
        return t, idx
    same = np.r_[False, (np.diff(t) == 0.0) & (np.diff(v) == 0.0)]
    if not same.any():
        return t, idx
    first = float(t[np.flatnonzero(same)[0]])
    repairs.append(Repair("repeated rows", int(same.sum()),
                          f"{int(same.sum())} row(s) repeating the previous row exactly (stamp and reading) dropped, "
                          f"the first at t = {first:g} s"))
    return t[~same], idx[~same]


def _runs(t):
    starts = np.flatnonzero(np.r_[True, np.diff(t) != 0])
    return starts, np.diff(np.r_[starts, t.size])


def _stalls(t, idx, bursty: bool, where, repairs):
    """Cut the record where the clock stalls or jumps; keep the longest stretch that keeps time."""
    n = t.size
    if n < 3:
        return t, idx
    starts, runs = _runs(t)
    d = np.diff(t)
    h = _typical_step(t)
    burst = float(np.median(runs)) if bursty else 1.0
    long = max(STALL_ROWS, STALL_BURSTS * burst)
    wrong = np.zeros(n, bool)  # rows whose stamp is not their time
    cut = np.zeros(n, bool)  # a cut between row i and row i + 1
    events: list[str] = []
    for s, length in zip(starts.tolist(), runs.tolist()):
        if length < 2:
            continue
        end = s + length  # first row of the next stamp
        if length >= long:
            events.append(f"the stamp {t[s]:g} s repeats over {length} rows")
        elif bursty:
            continue
        elif s == 0 or end == n:
            events.append(f"the stamp {t[s]:g} s repeats over the {'first' if s == 0 else 'last'} {length} rows")
        else:
            step = (t[end] - t[s - 1]) / (length + 1)
            if CATCH_UP[0] * h <= step <= CATCH_UP[1] * h:
                continue  # re-timed between its neighbours (see _retime)
            events.append(f"the stamp {t[s]:g} s repeats over {length} rows and the clock does not catch up")
        if s == 0:
            wrong[:end - 1] = True
        else:
            wrong[s + 1:end] = True
    rest = t[-1] - t[0]
    for i in np.flatnonzero(d > JUMP_INTERVALS * h).tolist():
        if d[i] > rest - d[i]:
            cut[i] = True
            events.append(f"the clock jumps ahead by {d[i]:.4g} s at t = {t[i]:g} s, more than the rest of the "
                          f"record spans ({rest - d[i]:.4g} s)")
    if not events:
        return t, idx
    good = np.flatnonzero(~wrong)
    breaks = np.flatnonzero((np.diff(good) > 1) | cut[good[:-1]]) + 1
    pieces = np.split(good, breaks)
    best = max(pieces, key=len)
    what = ", ".join(events[:3]) + (f" and {len(events) - 3} more" if len(events) > 3 else "")
    if best.size < max(2, KEEP_FRACTION * n):
        first = int(starts[runs >= 2][0]) + 1 if (runs >= 2).any() else int(np.flatnonzero(cut)[0]) + 1
        raise _refuse(f"the clock stalls ({what}) and no stretch of {max(2, math.ceil(KEEP_FRACTION * n))} rows keeps time",
                      where(idx[min(first, n - 1)]), t)
    dropped = n - best.size
    repairs.append(Repair("stall", dropped,
                          f"the clock stalls ({what}): the record is cut there, keeping the longest stretch that "
                          f"keeps time, t = {t[best[0]]:g} to {t[best[-1]]:g} s ({best.size} of {n} rows, "
                          "[recording] start and stop choose another)"))
    return t[best], idx[best]


def _retime(t, idx, bursty: bool, where, repairs):
    """Re-time stamps written in bursts (a line) or a few repeated stamps (between their neighbours)."""
    starts, runs = _runs(t)
    if not (runs > 1).any():
        return t
    if bursty:
        return _burst_line(t, idx, starts, runs, where, repairs)
    t = t.copy()
    count = 0
    first = math.nan
    for s, length in zip(starts.tolist(), runs.tolist()):
        if length < 2:
            continue
        if s == 0 or s + length == t.size:
            continue  # at an end of a stretch cut out of the record: refused by the check of the steps
        first = t[s] if count == 0 else first
        lo, hi = t[s - 1], t[s + length]
        t[s:s + length] = lo + (hi - lo) * np.arange(1, length + 1) / (length + 1)
        count += length
    repairs.append(Repair("repeated stamps", count,
                          f"{count} row(s) sharing a stamp with a neighbour (another reading) re-timed evenly between "
                          f"the neighbouring stamps, the first at t = {first:g} s"))
    return t


def _clusters(t, idx, v, where, repairs):
    """Stamps in clusters: every row on a line when the readings say the rows are even, else the
    stamps kept (a note).  The line goes through the clusters' last rows: a buffer is sent after its
    last row is taken, so the last row's stamp is late by the transfer's latency only."""
    mean = (t[-1] - t[0]) / (t.size - 1)
    d = np.diff(t)
    starts = np.flatnonzero(np.r_[True, d >= CLUSTER_STEP * mean])
    runs = np.diff(np.r_[starts, t.size])
    across, inside = _steps_of_readings(t, v)
    said = (f"time stamps arrive in clusters (up to {runs.max()} rows; "
            f"{100.0 * np.mean(d < CLUSTER_STEP * mean):.0f} % of the steps under half the mean step)")
    if not (math.isfinite(across) and across / inside < EVEN_STEPS):
        if math.isfinite(across):
            repairs.append(Repair("clusters", 0, f"{said}: the readings step {across / inside:.3g} times more "
                                                 "across a cluster's gap than within it, as samples taken in bursts "
                                                 "do, so the stamps are kept as the sample times"))
        else:
            repairs.append(Repair("clusters", 0, f"{said}: the readings cannot tell whether the rows were taken "
                                                 "evenly (stamps of arrival can be a tenth of a second late), so the "
                                                 f"stamps are kept as the sample times; if the logger samples evenly, "
                                                 f"{FIX}", doubt=True))
        return _one_row_a_stamp(t, idx, v, repairs)
    line = _burst_line(t, idx, starts + runs - 1, runs, where, [])  # rows arrive after the last is taken
    off = float(np.max(np.abs(t - line)))
    repairs.append(Repair("clusters", int(t.size),
                          f"{said}, but the readings step as evenly across a cluster's gap as within it "
                          f"({across / inside:.2f} times): the logger sampled evenly and the stamps are arrival "
                          f"times. All {t.size} rows re-timed by a straight line of stamp on row number, "
                          f"{(t.size - 1) / (line[-1] - line[0]):.6g} Hz (every stamp within {off:.3g} s of it)"))
    return line, idx


def _one_row_a_stamp(t, idx, v, repairs):
    """Stamps kept as the sample times: a row on the same stamp as the row before it is dropped
    (one instant holds one reading; a copy of the row, or a second reading the logger wrote on
    the same tick)."""
    same = np.r_[False, np.diff(t) == 0.0]
    if not same.any():
        return t, idx
    n = int(same.sum())
    copies = int(np.sum(same[1:] & (np.diff(v) == 0.0))) if v is not None else 0
    what = ("all repeating its reading too" if copies == n else
            f"{copies} repeating its reading too" if copies else "with another reading")
    repairs.append(Repair("repeated rows", n, f"{n} row(s) on the same stamp as the row before ({what}) dropped, "
                                              f"the first at t = {float(t[np.flatnonzero(same)[0]]):g} s: the "
                                              "stamps are the sample times, and one instant holds one reading"))
    return t[~same], idx[~same]


def _steps_of_readings(t, v) -> tuple[float, float]:
    """Median size of the readings' steps across the clusters' gaps and within the clusters.

    ``(nan, nan)`` when the readings cannot say: none given, fewer than ten steps of either kind,
    or readings not smooth in row order (noise: the median second difference over
    :data:`SMOOTH` of the median first difference)."""
    if v is None or t.size < 20:
        return math.nan, math.nan
    mean = (t[-1] - t[0]) / (t.size - 1)
    d, dv = np.diff(t), np.abs(np.diff(v))
    gap, inside = d > 2.0 * mean, d < CLUSTER_STEP * mean
    if gap.sum() < 10 or inside.sum() < 10:
        return math.nan, math.nan
    small = float(np.median(dv[inside]))
    if not (small > 0 and np.median(np.abs(np.diff(v, 2))) <= SMOOTH * np.median(dv)):
        return math.nan, math.nan
    return float(np.median(dv[gap])), small


def _burst_line(t, idx, starts, runs, where, repairs):
    """Every row on a robust line of stamp on row number through the rows ``starts`` (the bursts'
    first rows)."""
    x, y = starts.astype(float), t[starts]
    keep = np.ones(x.size, bool)
    slope = intercept = math.nan
    for _ in range(3):
        slope, intercept = np.polyfit(x[keep], y[keep], 1)
        res = y - (intercept + slope * x)
        mad = 1.4826 * float(np.median(np.abs(res[keep] - np.median(res[keep]))))
        new = np.abs(res) <= max(4.0 * mad, abs(slope))
        if new.sum() < 3 or np.array_equal(new, keep):
            break
        keep = new
    rows = np.arange(t.size, dtype=float)
    fitted = intercept + slope * rows
    off = np.abs(t - fitted)
    worst = int(np.argmax(off))
    if not (slope > 0 and math.isfinite(slope)) or off[worst] > (runs.max() + 1) * slope:
        what = (f"repeat in bursts (~{np.median(runs):.0f} rows)" if np.median(runs) >= 1.5 else
                f"repeat ({int((runs > 1).sum())} stamps shared by neighbouring rows)")
        raise _refuse(f"time stamps {what} but do not follow a straight line "
                      f"of stamp on row number (stamp {float(t[worst])!r} is {off[worst]:.3g} s from it)",
                      where(idx[worst]), t)
    said = (f"time stamps repeat in bursts of ~{np.median(runs):.0f} rows"
            + (f" ({runs.min()} to {runs.max()})" if runs.min() < runs.max() else "")
            if np.median(runs) >= 1.5 else
            f"time stamps written too coarsely to tell every row apart ({int((runs > 1).sum())} stamps shared by "
            f"{runs.min() if runs.min() > 1 else 2} to {runs.max()} rows)")
    repairs.append(Repair("bursts", int(t.size),
                          said + f": all {t.size} rows re-timed by a straight line of stamp on row number "
                          f"through the bursts' first rows, {1.0 / slope:.6g} Hz (every stamp within "
                          f"{off[worst]:.3g} s of it)"))
    return fitted


def _finish(t, idx, repairs, where, rows_read: int) -> TimeBase:
    """Interval, jitter, the checks on them and the notes of gaps and jitter."""
    if t.size < 2:
        return TimeBase(t, idx, tuple(repairs), math.nan, math.nan, rows_read)
    d = np.diff(t)
    if not np.all(d > 0):  # the repairs leave increasing times; kept as a guard
        i = int(np.flatnonzero(~(d > 0))[0])
        raise _refuse(f"time does not increase: {float(t[i])!r} then {float(t[i + 1])!r} s", where(idx[i + 1]), t)
    h = float(np.median(d))
    jitter = 1.4826 * float(np.median(np.abs(d - h)))
    lo, hi = INTERVAL_RANGE
    if not (math.isfinite(h) and lo <= h <= hi):
        raise _refuse(f"the sampling interval is {h:.3g} s, not a recording's ({lo:g} to {hi:g} s)", where(idx[0]), t)
    gaps = np.flatnonzero(d > max(GAP_INTERVALS * h, h + 5.0 * jitter))
    if gaps.size:
        big = int(gaps[np.argmax(d[gaps])])
        repairs.append(Repair("gap", 0, f"{gaps.size} gap(s) in the samples kept as gaps (the fit takes irregular "
                                        f"times): the longest {d[big]:.4g} s ({d[big] / h:.0f} intervals) after "
                                        f"t = {t[big]:g} s"))
    if jitter > JITTER_NOTE * h:
        repairs.append(Repair("jitter", 0, f"the sampling interval jitters: {h:.4g} s +- {jitter:.2g} s "
                                           f"({100.0 * jitter / h:.0f} %), each row keeps its own time"))
    return TimeBase(t, idx, tuple(repairs), h, jitter, rows_read)


# -- helpers -------------------------------------------------------------------------------------------
def _typical_step(t) -> float:
    """Median of the positive steps, s (nan when there are none)."""
    d = np.diff(t)
    d = d[d > 0]
    return float(np.median(d)) if d.size else math.nan


def _rate_guess(t) -> float:
    """Samples per second the stamps imply, or nan when they do not say: the median over
    stretches of :data:`RATE_WINDOW` rows or a twentieth of the record (the longer) of rows over
    the time spanned (robust to bursts and clusters, a stall, a jump or a reset of the clock)."""
    t = t[np.isfinite(t)]
    if t.size < 3 or np.mean(np.diff(t) < 0) > 0.1:  # stamps mostly out of order say nothing of a rate
        return math.nan
    w = min(max(RATE_WINDOW, t.size // 20), t.size - 1)
    spans = t[w::w] - t[:-w:w][:t[w::w].size]
    spans = spans[spans > 0]
    rate = w / float(np.median(spans)) if spans.size else math.nan
    return rate if 1.0 / INTERVAL_RANGE[1] <= rate <= 1.0 / INTERVAL_RANGE[0] else math.nan


def _refuse(what: str, where: str, t) -> DataError:
    rate = _rate_guess(np.asarray(t, dtype=float))
    hint = f" (about {rate:.4g} Hz, measured from the stamps)" if math.isfinite(rate) else ""
    return DataError(f"{what}: {FIX}{hint}", where)
