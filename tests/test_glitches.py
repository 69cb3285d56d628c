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



def test_samples_off_the_arc_at_the_records_edge_are_no_glitch():
    """Two samples off the arc at the record's very start: a glitch comes back to an arc followed
    on both sides of it, and here one side is missing, so they may as well be a release from a
    hold or the record starting as the oscillator was let go (on a salt-water pendulum's video
    four such frames were left out as a glitch, and the release with them).  The same two
    samples inside the record are a glitch."""
    t = np.arange(0.0, 20.0, 1.0 / RATE)
    x = 0.3 * np.exp(-0.05 * t) * np.cos(2 * math.pi * (t + 0.3)) + 1e-3 * np.random.default_rng(1).standard_normal(t.size)
    edge = x.copy()
    edge[:2] += 0.1
    assert glitches(t, edge) == []
    inside = x.copy()
    inside[300:302] += 0.1
    found = glitches(t, inside)
    assert [(g.first, g.last) for g in found] == [(300, 301)] and found[0].size == pytest.approx(0.1, abs=0.01)


@pytest.mark.parametrize("hold", [0.1, 0.25])
def test_a_release_at_the_records_start_is_no_glitch(hold):
    """Held for a few frames at the start of the record, then released: the flat samples leave
    the arc fitted after them, but a glitch comes back to an arc followed on both sides, and here
    one side is missing.  They were left out as a glitch, and the release with them (a salt-water
    pendulum's record then started half a period late)."""
    t = np.arange(0.0, 20.0, 1.0 / RATE)
    y, tt, tv = decay(t, 0.3, c=0.2, r=0.0, release=hold)
    x = y + 1e-3 * np.random.default_rng(7).standard_normal(t.size)
    assert glitches(t, x) == []
    tp = reduce_series(TimeSeries(t, x, source="video.csv"))
    assert not any("tracking glitch" in n for n in tp.notes), tp.notes
    assert abs(tp.release_time - hold) < 0.5 / RATE + 0.05, (tp.release_time, tp.notes)


@pytest.mark.parametrize("length,found", [(6, True), (10, True), (15, False)])
def test_at_a_fast_rate_a_glitch_may_last_a_tenth_of_a_period(length, found):
    """At 100 samples a period a tracker that lost the bob for a tenth of a period leaves ten
    samples off the swing: a glitch, found exactly; fifteen (0.15 of a period) are motion."""
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 30.0, 0.01)
    x, *_ = decay(t, 0.3, c=0.02, r=0.05)
    x = x + 1e-3 * rng.standard_normal(t.size)
    i = int(0.45 * t.size)
    x[i:i + length] -= 0.2
    got = find_glitches(t, x, PERIOD, smooth(x, PERIOD * 100))
    assert [(g.first, g.last) for g in got] == ([(i, i + length - 1)] if found else [])
