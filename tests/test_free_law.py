"""Energy gained beyond a record's own free law (escfit.analysis.free_law) and the choice of
the free stretch between several pushes (escfit.analysis.recordings.motion).

The turning points are made in closed form: a linear oscillator with viscous damping and
Coulomb friction loses a fixed share and a fixed amount of its amplitude per half swing,
``a_(k+1) = ratio a_k - loss`` exactly, about a fixed centre; a push (which adds swing on both
sides of the centre) is put in by hand where and as large as the test says.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from escfit.analysis.free_law import free_law_gains, law_pushes, law_steps
from escfit.analysis.segments import find_events


def amplitudes(n=41, a0=0.25, ratio=0.985, loss=5e-4, pushes=None):
    """Amplitudes of a free decay at its turning points, ``a_(k+1) = ratio a_k - loss``;
    ``pushes`` maps a half swing ``k`` to the share of the amplitude a push adds from turning
    point ``k + 1`` on (the decay then goes on from the larger swing)."""
    pushes = pushes or {}
    a = np.empty(n)
    a[0] = a0
    for k in range(1, n):
        a[k] = (ratio * a[k - 1] - loss) * (1.0 + pushes.get(k - 1, 0.0))
    return a


def turning_points(a, noise=0.0, seed=0, centre=0.01):
    """Turning points alternating about ``centre`` with amplitudes ``a`` (first one a maximum),
    with reading noise: a push adds swing on both sides of the centre, as a hand does."""
    v = centre + a * (-1.0) ** np.arange(a.size) + noise * np.random.default_rng(seed).standard_normal(a.size)
    return np.arange(a.size) * 0.5, v


def swings(noise=0.0, seed=0, pushes=None, **kw):
    """Peak-to-peak swings of :func:`amplitudes` read with noise."""
    return np.abs(np.diff(turning_points(amplitudes(pushes=pushes, **kw), noise, seed)[1]))


def test_a_free_decay_gains_nothing_beyond_its_law():
    """The law (loss linear in the swing, inside the fitted quadratic) is found exactly."""
    gains = free_law_gains(swings())
    assert np.max(np.abs(gains)) < 1e-12


@pytest.mark.parametrize("at, gain", [(12, 0.03), (20, 0.1), (27, 0.2)])
def test_a_push_is_a_step_of_its_size(at, gain):
    """The swings after half swing ``at`` raised by ``gain`` of the swing there: the step of the
    energy gained is that rise (peak to peak) within 5 %, and it is flagged as a push."""
    a = amplitudes(pushes={at: gain})
    t, v = turning_points(a, 1e-4, seed=at)
    p = np.abs(np.diff(v))
    rise = gain / (1.0 + gain) * 2 * a[at + 1]  # the peak-to-peak swing gains twice the amplitude's rise
    flags, step, err, deepest = law_pushes(p)
    assert step[at] == pytest.approx(rise, rel=0.1)
    assert flags[at] and deepest < 0.1 * rise
    # flagged only around it (the steps' windows of six half swings straddle it there)
    assert np.all(np.abs(np.flatnonzero(flags) - at) <= 6)
    assert [e.half_swing for e in find_events(t, v, resolution=1e-5) if e.kind == "push"] == [at]


def test_three_small_pushes_in_a_short_record_are_each_found():
    """Forty half swings pushed by 4, 8 and 12 % after half swings 9, 19 and 29: the level test
    alone is blurred by the slopes carried across its gap; the free law finds each of them in the
    half swing it happened."""
    t, v = turning_points(amplitudes(pushes={9: 0.04, 19: 0.08, 29: 0.12}), 1.5e-4, seed=4)
    pushes = [e for e in find_events(t, v, resolution=1e-5) if e.kind == "push"]
    assert [e.half_swing for e in pushes] == [9, 19, 29]


@pytest.mark.parametrize("kind", ["glitch", "offset"])
def test_a_glitch_or_an_offset_step_is_no_gain(kind):
    """One turning point 20 % of the swing out of line, or the centre moved by 10 % of it from
    turning point 21 on: the energy gained moves at one or two values, and no push is flagged."""
    t, v = turning_points(amplitudes(), 1e-4, seed=7)
    p = np.abs(np.diff(v))
    if kind == "glitch":
        v[21] += 0.2 * p[20] * np.sign(v[21] - v[20])
    else:
        v[21:] += 0.1 * p[20]
    flags, *_ = law_pushes(np.abs(np.diff(v)))
    assert not flags.any()


def test_one_side_read_short_and_then_right_again_is_no_push():
    """A tracker that reads four maxima short by a tenth of the swing (at the record's start, or
    in its middle) and then right again: the swing 'gains' when they come right, but on one side
    of the centre only, which no push does (the level and free-law tests both see a gain)."""
    for first in (1, 17):
        t, v = turning_points(amplitudes(), 1e-4, seed=first)
        short = np.arange(first, first + 8)
        short = short[v[short] > 0.01][:4]
        v[short] -= 0.1 * 0.25
        assert [e for e in find_events(t, v, resolution=1e-5) if e.kind == "push"] == [], first


def test_a_record_with_gaps_or_too_few_swings_gives_no_verdict():
    p = swings()
    p[5] = np.nan
    assert np.isnan(law_steps(p)[0]).all()
    assert np.isnan(law_steps(swings(n=9))[0]).all()
    assert np.isnan(law_steps(np.full(30, 0.2))[0]).all()  # a constant swing: no law to fit


def _artefact(name, seed, periods):
    sys.path.insert(0, str(Path(__file__).parent))
    from artefacts.make import make

    return make(name, seed, periods=periods)


def test_the_longest_free_stretch_between_pushes_is_the_one_reduced():
    """A pendulum pushed twice (free 25 %, 45 % and 30 % of the time): the turning points kept
    are those of the middle stretch, its end is the stop, and a warning says what was left out
    and which keys choose another stretch."""
    from escfit.analysis.recordings.timeseries import TimeSeries
    from escfit.analysis.recordings.turning_points import reduce_series

    art = _artefact("three_pushes", 3, 20)
    rows = np.loadtxt(art.csv.splitlines(), delimiter=",", skiprows=1)
    tp = reduce_series(TimeSeries(rows[:, 0], np.radians(rows[:, 1]), source="pushed.csv"))
    (a, b), = art.truth.all_windows()
    period = 2 * math.pi / art.truth.omega0
    assert a - 0.25 * period <= tp.release_time <= a + 0.75 * period
    assert tp.pushed_after and b - period <= tp.stop_time <= b + 0.25 * period
    assert tp.time[-1] <= tp.stop_time
    warning = [w for w in tp.warnings if w.startswith("the swing is pushed twice")]
    assert warning and "[recording] start and stop" in warning[0], tp.warnings
