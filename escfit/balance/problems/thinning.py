"""Which samples of a long record a waveform fit reads.

A waveform fit evaluates its likelihood at every sample it keeps, so it keeps at most
:data:`~escfit.balance.observation.waveform.WaveformObservation.MAX_SAMPLES` of them.  Taking
every ``k``-th sample keeps the whole span at an even rate, which is right while a period
still holds :data:`MIN_EVEN` samples after the thinning.  A longer record (thousands of
periods) would keep about one sample a period or less: the phase of each swing is then no
longer read, and a fit of the decay can slip whole cycles.  There the samples are kept in **blocks**
of whole periods, each at :data:`MIN_PER_PERIOD` samples a period or more, spread evenly over
the record (the first and the last period always among them): every block reads the swing's
amplitude and phase where it lies, and the model, integrated over the whole span, joins them.

Correlated (AR(1)) reading noise runs from sample to sample within a block only: the first
sample of each block starts the chain afresh (``fresh``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Thinned", "thin_samples", "MIN_PER_PERIOD", "MIN_EVEN"]

MIN_PER_PERIOD = 12  # samples a period a block keeps
MIN_EVEN = 4  # an even thinning that leaves fewer samples a period than this gives way to blocks


@dataclass(frozen=True)
class Thinned:
    """The samples kept: indices into the record, which start an AR(1) chain, and a note.

    Attributes
    ----------
    index : ndarray of int
        Indices of the samples kept, in time order.
    fresh : ndarray of bool or None
        Per kept sample, whether it starts a block (None: one block, the first sample only).
    note : str
        What was kept, for the fit's notes ("" when every sample is).
    """

    index: np.ndarray
    fresh: np.ndarray | None
    note: str


def thin_samples(time: np.ndarray, index: np.ndarray, period: float, budget: int, every: int = 0) -> Thinned:
    """The samples of ``time[index]`` a waveform fit keeps (see the module docstring).

    Parameters
    ----------
    time : ndarray
        The record's sample times, s.
    index : ndarray of int
        The samples within the fit's window.
    period : float
        The swing's period, s.
    budget : int
        At most this many samples are kept.
    every : int
        The scene's ``[observation] thin`` (0: automatic): every ``every``-th sample, as given.
    """
    index = np.asarray(index)
    n = index.size
    if every:
        kept = index[::every]
        return Thinned(kept, None, f"one sample in {every} used ({kept.size} of {n})" if every > 1 else "")
    if n <= budget:
        return Thinned(index, None, "")
    stride = math.ceil(n / budget)
    t = np.asarray(time, float)[index]
    span = float(t[-1] - t[0])
    per_period = (n - 1) / span * period if span > 0 and period > 0 else math.inf
    if not math.isfinite(per_period) or per_period / stride >= MIN_EVEN:
        kept = index[::stride]
        return Thinned(kept, None, f"one sample in {stride} used ({kept.size} of {n})")
    return _blocks(t, index, period, budget, per_period)


def _blocks(t: np.ndarray, index: np.ndarray, period: float, budget: int, per_period: float) -> Thinned:
    """Whole periods at :data:`MIN_PER_PERIOD` samples a period or more, spread over the span."""
    step = max(1, int(per_period // MIN_PER_PERIOD))  # within a block
    in_block = per_period / step  # samples a kept period holds
    cycle = np.floor((t - t[0]) / period).astype(np.int64)
    periods = int(cycle[-1]) + 1
    most = math.ceil(in_block)  # samples a block can hold
    keep_periods = max(1, budget // most - 1)  # the last period comes on top of the evenly spread ones
    gap = max(1, math.ceil(periods / keep_periods))
    chosen = (cycle % gap == 0) | (cycle == cycle[-1])
    positions = np.flatnonzero(chosen)
    # within each chosen period, every step-th sample from its first
    first_of_run = np.r_[True, np.diff(positions) > 1]
    run_id = np.cumsum(first_of_run) - 1
    start = positions[first_of_run][run_id]
    take = ((positions - start) % step) == 0
    kept_pos = positions[take]
    fresh = np.r_[True, np.diff(kept_pos) > step]
    kept = index[kept_pos]
    blocks = int(np.count_nonzero(fresh))
    note = (f"a long record: {kept.size} of {index.size} samples used, in {blocks} blocks of one period at "
            f"{in_block:.3g} samples a period, one period in {gap} (every sample in {step} within a block), so that "
            "each block reads the swing's phase; correlated noise runs within a block only")
    return Thinned(kept, fresh, note)
