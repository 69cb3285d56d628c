"""Samples off the swing for a frame or three (escfit.analysis.glitches), and the analysis without them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.analysis.glitches import find_glitches
from escfit.analysis.recordings.extrema import smooth
from escfit.analysis.recordings.series import TimeSeries
from escfit.analysis.recordings.turning_points import reduce_series

from .test_turning_points import decay

RATE = 30.0  # a phone video
PERIOD = 1.0


def record(seed, noise=2e-3):
    """An exact viscous + Coulomb decay (the kink at every turning point included), 60 s at 30 Hz."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 60.0, 1.0 / RATE)
    y, tt, tv = decay(t, 0.3, c=0.02, r=0.05)
    return t, y + noise * rng.standard_normal(t.size), tt, tv


def glitches(t, x):
    return find_glitches(t, x, PERIOD, smooth(x, PERIOD * RATE))


@pytest.mark.parametrize("noise", [0.0, 1e-4, 2e-3])
@pytest.mark.parametrize("seed", range(3))
def test_a_clean_decay_has_no_glitch(seed, noise):
    t, x, *_ = record(seed, noise)
    assert glitches(t, x) == []


@pytest.mark.parametrize("length", [1, 2, 3])
@pytest.mark.parametrize("where", [0.31, 0.52, 0.77])
def test_a_few_frames_off_the_swing_are_found_exactly(length, where):
    """``length`` samples moved by a fifth of the first swing: that run and only it."""
    t, x, *_ = record(1)
    i = int(where * t.size)
    x[i:i + length] += 0.06
    found = glitches(t, x)
    assert [(g.first, g.last) for g in found] == [(i, i + length - 1)]
    assert found[0].size == pytest.approx(0.06, abs=0.01)


def test_a_run_longer_than_a_glitch_is_motion_not_a_glitch():
    t, x, *_ = record(2)
    i = int(0.4 * t.size)
    x[i:i + 8] += 0.06
    assert glitches(t, x) == []


def test_the_analysis_leaves_a_glitch_out_and_counts_the_swings_right():
    """A three-frame jump in mid swing would add a spurious pair of turning points; left out, the
    turning points and the period are the exact decay's."""
    t, x, tt, tv = record(3, noise=1e-3)
    i = int(0.3 * t.size)
    x[i:i + 3] -= 0.09
    tp = reduce_series(TimeSeries(t, x, source="glitch.csv"))
    assert any("tracking glitch" in n for n in tp.notes), tp.notes
    assert len(tp.dropped) == 1 and tp.dropped[0][0] == pytest.approx(t[i])
    assert tp.period == pytest.approx(2 * math.pi / math.sqrt((2 * math.pi) ** 2 - 0.02 ** 2 / 4), rel=1e-3)
    found = np.r_[tp.release_time, tp.time][:60]  # the swings well above the noise (none spurious, none lost)
    k = np.argmin(np.abs(found[:, None] - tt[None, :]), axis=1)
    assert np.all(np.abs(found - tt[k]) < 0.05 * PERIOD) and np.all(np.diff(k) == 1)
