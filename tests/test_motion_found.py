"""Where a recorded free decay starts and ends, on records of known truth.

Every record is the closed form of a damped linear oscillator (or the exact balance solver)
with white reading noise, preceded by what real records begin with: a hold, a hold and a
further pull by hand, a rest and a push, a drive switched off; and followed by a long stretch
of noise.  The free decay must start at the last release and run until the swing sinks into
the record's noise, for periods from a watch balance's 0.1 s to a seismometer's 10 s and Q
from 3 to 10^4, and a record with three turning points above its noise is never refused.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.analysis.recordings.timeseries import TimeSeries
from escfit.analysis.recordings.turning_points import reduce_series
from escfit.core.errors import DataError


def viscous(t, a0: float, period: float, q: float, release: float = 0.0):
    """Angle (rad) of ``theta'' + (w0/Q) theta' + w0^2 theta = 0`` released at rest at ``a0`` at
    ``release`` (held before), ``w0 = 2 pi / period``, and its turning points ``(times, angles)``."""
    w0 = 2 * math.pi / period
    g = w0 / (2 * q)
    w1 = math.sqrt(w0 * w0 - g * g)
    tau = np.maximum(np.asarray(t, float) - release, 0.0)
    y = a0 * np.exp(-g * tau) * (np.cos(w1 * tau) + g / w1 * np.sin(w1 * tau))
    k = np.arange(int((np.max(t) - release) * w1 / math.pi) + 1)
    return y, release + k * math.pi / w1, a0 * np.exp(-g * k * math.pi / w1) * (-1.0) ** k


def pushed(t, v0: float, period: float, q: float, start: float):
    """At rest at 0 until ``start``, then pushed: ``v0/w1 e^(-g tau) sin(w1 tau)``; and its turning points."""
    w0 = 2 * math.pi / period
    g = w0 / (2 * q)
    w1 = math.sqrt(w0 * w0 - g * g)
    tau = np.maximum(np.asarray(t, float) - start, 0.0)
    y = v0 / w1 * np.exp(-g * tau) * np.sin(w1 * tau)
    k = np.arange(int((np.max(t) - start) * w1 / math.pi) + 1)
    tt = start + math.atan2(w1, g) / w1 + k * math.pi / w1
    return y, tt, v0 / w1 * np.exp(-g * (tt - start)) * np.sin(w1 * (tt - start))


def series(t, y) -> TimeSeries:
    return TimeSeries(np.asarray(t, float), np.asarray(y, float), source="synthetic.csv")


def matched(tp, tt, tv, period, sigma=0.0):
    """Index of the true turning point of each one found: within a quarter period of it (so
    that no neighbour could be meant), its value within the noise, in order, none skipped."""
    found = np.r_[tp.release_time, tp.time]
    k = np.argmin(np.abs(found[:, None] - tt[None, :]), axis=1)
    assert np.all(np.abs(found[1:] - tt[k[1:]]) < period / 4), (found, tt[k])
    np.testing.assert_array_equal(np.diff(k), 1)  # none skipped, none spurious
    if sigma:
        values = np.r_[tp.release_theta, tp.theta]
        assert np.all(np.abs(values - tv[k]) < 5 * sigma + 1e-3 * np.abs(tv[k])), (values, tv[k])
    return k


def above_noise(tv, sigma, per_window):
    """How many true turning points a period-long window sees above six noise scales."""
    return int(np.sum(np.abs(tv) > 6 * sigma * math.sqrt(2.0 / per_window)))


@pytest.mark.parametrize("q", [3, 7, 30])
@pytest.mark.parametrize("start", ["held", "pull", "push", "mid-swing"])
def test_slow_strongly_damped_decays_at_10_hz(q, start):
    """A 9 s period sampled at 10 Hz, the noise 1 % of the first swing: the decay is found from
    its last release to where it sinks into the noise, for every kind of start."""
    rng = np.random.default_rng(q)
    period, sigma = 9.0, 0.01
    t = np.arange(0.0, 120.0, 0.1)
    if start == "push":
        y, tt, tv = pushed(t, 1.0, period, q, 10.0)
    elif start == "mid-swing":
        y, tt, tv = viscous(t + 2.0, 1.0, period, q)
        tt = tt - 2.0
    else:
        y, tt, tv = viscous(t, 1.0, period, q, release=10.0)
        if start == "pull":  # held at 0.85 rad, pulled to 1 rad by hand over 1.5 s, let go at once
            ramp = np.clip((t - 8.5) / 1.5, 0.0, 1.0)
            y = np.where(t < 10.0, 0.85 + 0.15 * (0.5 - 0.5 * np.cos(math.pi * ramp)), y)
    tp = reduce_series(series(t, y + sigma * rng.standard_normal(t.size)))
    k = matched(tp, tt, tv, period, sigma)
    first = 1 if start == "mid-swing" else 0
    assert k[0] == first, tp.notes
    assert tp.release_time == pytest.approx(tt[first], abs=0.06 * period)
    assert tp.release_theta == pytest.approx(tv[first], abs=5 * sigma)
    # every turning point whose swing a whole period of samples shows above the noise is kept, up
    # to the last two (their spacing decides whether they are noise)
    visible = np.flatnonzero(np.abs(tv) > 10 * sigma)
    assert k[-1] >= visible[-1] - 1, (k, np.abs(tv[:k[-1] + 3]))
    w1 = math.pi / (tt[1] - tt[0])
    assert tp.period == pytest.approx(2 * math.pi / w1, abs=max(4 * tp.period_stderr, 0.01 * period))
    if start == "held":
        assert any(n.startswith("held at") for n in tp.notes)
    if start in ("pull", "push"):
        assert any("moved to" in n or "not a free decay" in n for n in tp.notes), tp.notes


@pytest.mark.parametrize("period, rate, q, sigma, duration", [
    (0.1, 2000.0, 1e4, 1e-3, 20.0),   # a watch balance: hardly decays in 200 periods
    (0.4, 500.0, 300.0, 2e-3, 30.0),
    (10.0, 20.0, 3.0, 5e-3, 150.0),   # a seismometer: gone in a few periods
    (10.0, 20.0, 1e3, 5e-3, 200.0),
])
def test_short_and_long_periods(period, rate, q, sigma, duration):
    rng = np.random.default_rng(5)
    t = np.arange(0.0, duration, 1.0 / rate) + 0.3 * period  # starts mid-swing
    y, tt, tv = viscous(t, 0.8, period, q)
    tp = reduce_series(series(t, y + sigma * rng.standard_normal(t.size)))
    k = matched(tp, tt, tv, period)
    visible = np.flatnonzero((np.abs(tv) > 10 * sigma) & (tt < t[-1] - 0.2 * period))
    assert k[-1] >= visible[-1] - 1
    w1 = math.pi / (tt[1] - tt[0])
    assert tp.period == pytest.approx(2 * math.pi / w1, abs=max(4 * tp.period_stderr, 1e-3 * period))


def test_three_turning_points_above_the_noise_are_enough():
    """A record of one period and a bit: the reference and two more turning points."""
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 11.0, 0.05)
    y, tt, tv = viscous(t, 1.0, 9.0, 30.0, release=0.5)
    tp = reduce_series(series(t, y + 0.005 * rng.standard_normal(t.size)))
    assert tp.swing.size + 1 == 3
    matched(tp, tt, tv, 9.0)


def test_a_drive_switched_off_starts_the_decay_where_the_drive_stops():
    """Driven at resonance at constant amplitude for six periods, then left to decay (Q = 30)."""
    rng = np.random.default_rng(3)
    period, q = 1.0, 30.0
    t = np.arange(0.0, 40.0, 0.01)
    w0 = 2 * math.pi / period
    off = 6.0  # the drive stops at a turning point (the steady motion is a cosine)
    y, tt, tv = viscous(t, 1.0, period, q, release=off)
    y = np.where(t < off, np.cos(w0 * t), y)
    tp = reduce_series(series(t, y + 0.003 * rng.standard_normal(t.size)))
    assert tp.release_time == pytest.approx(off, abs=0.3 * period)
    assert any("drive switched off" in n for n in tp.notes), tp.notes


def test_a_second_pull_restarts_the_decay():
    """Let go at 0.6 rad, pulled out again to 1 rad after 8 s of decay, let go again."""
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 40.0, 0.01)
    y1, _, _ = viscous(t, 0.6, 1.0, 20.0)
    y2, tt, tv = viscous(t, 1.0, 1.0, 20.0, release=9.0)
    ramp = np.clip((t - 8.0) / 1.0, 0.0, 1.0)
    y = np.where(t < 8.0, y1, np.where(t < 9.0, y1[np.searchsorted(t, 8.0)] * (1 - ramp) + ramp, y2))
    tp = reduce_series(series(t, y + 0.002 * rng.standard_normal(t.size)))
    k = matched(tp, tt, tv, 1.0)
    assert k[0] == 0 and tp.release_theta == pytest.approx(1.0, abs=0.01)


@pytest.mark.parametrize("make, message", [
    (lambda t: np.cos(2 * math.pi * 20 * t) * np.exp(-t / 3) + np.cos(2 * math.pi * 21 * t) * np.exp(-t / 3),
     r"grows again \d+ times .* beating modes"),
])
def test_what_is_not_one_free_decay_is_refused(make, message):
    t = np.arange(0.0, 8.0, 1.0 / 1024)
    rng = np.random.default_rng(1)
    with pytest.raises(DataError, match=message):
        reduce_series(series(t, make(t) + 0.01 * rng.standard_normal(t.size)))


def test_a_swing_that_levels_off_is_marked_sustained():
    """A decay that settles on a steady swing (an escapement or a motor keeps it going)."""
    rng = np.random.default_rng(6)
    t = np.arange(0.0, 60.0, 0.01)
    y, _, _ = viscous(t, 1.0, 1.0, 10.0)
    y = 0.3 * np.cos(2 * math.pi * t / np.sqrt(1 - 1 / 400)) + 0.7 * y
    tp = reduce_series(series(t, y + 0.003 * rng.standard_normal(t.size)))
    assert math.isfinite(tp.sustained_from) and tp.sustained_from < 20.0


def test_a_driven_oscillation_is_refused_as_driven():
    """Driven 10 % above resonance from rest (Q = 20): the transient beats against the drive,
    then the swing settles at the drive's steady amplitude for the rest of the record.  The
    analysis marks where it settles, and a fit with a scene that has no drive refuses it."""
    from escfit.core.scene import load_scene
    from escfit.inference import make_problem

    rng = np.random.default_rng(7)
    t = np.arange(0.0, 120.0, 0.01)
    w0, q, wd = 2 * math.pi, 20.0, 1.1 * 2 * math.pi
    g = w0 / (2 * q)
    amp = 1.0 / math.hypot(w0 * w0 - wd * wd, 2 * g * wd)
    phase = math.atan2(2 * g * wd, w0 * w0 - wd * wd)
    steady = amp * np.cos(wd * t - phase)
    w1 = math.sqrt(w0 * w0 - g * g)
    x0, v0 = -amp * math.cos(phase), -amp * wd * math.sin(phase)  # the transient cancels the start
    transient = np.exp(-g * t) * (-x0 * np.cos(w1 * t) - (v0 + g * x0) / w1 * np.sin(w1 * t))
    record = series(t, (steady + transient) / amp + 0.003 * rng.standard_normal(t.size))
    tp = reduce_series(record)
    # the transient's last beat still gains energy from the drive (3 % at t = 27.7 s), so the
    # free-decay search starts there and the steady state is marked a few periods later
    assert 5.0 < tp.sustained_from < 35.0
    scene = load_scene("s.toml", text='model = "balance"\n[oscillator]\nomega0 = { value = 6, vary = true, min = 3, '
                                      'max = 9 }\n[effects.viscous]\nC = { value = 0.2, vary = true, min = 0, max = 2 }\n')
    with pytest.raises(DataError, match=r"keeps its amplitude .* something drives it"):
        make_problem(scene, record)
