"""Runs appended in one file: the clock starting again and the readings jumping at each start.

A remote lab's logger, or a user pasting runs one after another, writes several records into
one file; each run's clock starts again near its first stamp.  They cannot be one record.
:func:`appended_runs` finds them, for the time base (:mod:`escfit.analysis.timebase`) to keep the
longest.  A clock that starts again while the readings go on smoothly is one motion timed by the
logger's rate, not runs; runs of equal length leave the choice to the user.
"""

from __future__ import annotations

import numpy as np

__all__ = ["appended_runs", "RESTART_SHARE", "MAX_RUNS", "MIN_RUN_ROWS", "LONGEST_BY", "RESTART_JUMP"]

RESTART_SHARE = 0.1  # a step back to within this share of the run's span from its start: a restarted clock
MAX_RUNS = 10  # more restarts than this are no runs appended
MIN_RUN_ROWS = 20  # a run shorter than this is no run
LONGEST_BY = 1.1  # the run kept is at least this many times longer than the next
RESTART_JUMP = 5.0  # a new run's first reading jumps this many median steps from the last


def appended_runs(t: np.ndarray, v: np.ndarray | None):
    """The runs of a file whose clock restarts, or None.

    Parameters
    ----------
    t : ndarray
        Stamps, s, in the file's order.
    v : ndarray or None
        Each row's reading (any unit); None: no runs can be told from one motion.

    Returns
    -------
    tuple or None
        ``((lo, hi), bounds, back)``: the longest run as a slice's ends, every run's ends, and the
        rows after which the clock steps back.  None unless every step back returns to within
        :data:`RESTART_SHARE` of the current run's span from its first stamp, there are fewer than
        :data:`MAX_RUNS`, each run has :data:`MIN_RUN_ROWS` rows, the longest is
        :data:`LONGEST_BY` times the next, and the readings jump at every restart
        (:func:`_readings_jump`).
    """
    back = np.flatnonzero(np.diff(t) < 0)
    if not 0 < back.size < MAX_RUNS:
        return None
    starts = [0]
    for i in back.tolist():
        first, last = t[starts[-1]], t[i]
        if not (t[i + 1] <= first + RESTART_SHARE * (last - first) and i + 1 - starts[-1] >= MIN_RUN_ROWS):
            return None  # a row out of order, not a restart
        starts.append(i + 1)
    bounds = list(zip(starts, starts[1:] + [t.size]))
    sizes = sorted((b - a for a, b in bounds), reverse=True)
    if sizes[-1] < MIN_RUN_ROWS or sizes[0] < LONGEST_BY * sizes[1] or not _readings_jump(v, starts[1:]):
        return None
    return max(bounds, key=lambda b: b[1] - b[0]), bounds, back


def _readings_jump(v, starts: list[int]) -> bool:
    """Whether the readings jump where the clock restarts (a new run), by more than
    :data:`RESTART_JUMP` times the median step of the 20 rows before."""
    if v is None:
        return False
    for i in starts:
        before = np.abs(np.diff(v[max(0, i - 21):i]))
        if not abs(v[i] - v[i - 1]) > RESTART_JUMP * float(np.median(before)) + 1e-300:
            return False
    return True
