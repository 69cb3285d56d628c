"""A drive that kept the swing steady, switched off: where the free decay starts (analysis.drive_off).

The records: a linear oscillator kept at a steady amplitude by a drive (the drive no more steady
than a real motor's, its amplitude wandering by a percent) until it is switched off at a turning
point, then the closed-form viscous decay, long (30 periods and more, as after a lab's pendulum
drive) or short; with white reading noise.  The truth: the turning point where the drive
stopped, and the damping of the decay.  A free decay of any loss law is never taken for a
driven one, and the user's start or release still wins.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.analysis.drive_off import drive_off
from escfit.analysis.recordings.timeseries import TimeSeries
from escfit.analysis.recordings.turning_points import reduce_series
from escfit.analysis.recordings.window import RecordWindow
from escfit.core.scene import load_scene
from escfit.inference import make_problem
from escfit.inference.fit import fit_problem

from .test_motion_end import SCENE, covers
from .test_motion_found import viscous

PERIOD, RATE, SIGMA, A0 = 1.0, 40.0, 0.002, 0.5  # s, samples per s, rad, rad
W0 = 2 * math.pi / PERIOD


def driven_then_free(driven: float, q: float, *, duration: float = 40.0, unsteady: float = 0.01, seed: int = 0):
    """Steady at ``A0`` (wandering by ``unsteady``) until the turning point nearest ``driven`` s,
    then free with quality factor ``q``.  Returns the series and the instant the drive stopped."""
    t = np.arange(0.0, duration, 1.0 / RATE)
    off = round(driven / (0.5 * PERIOD)) * 0.5 * PERIOD
    free, _, _ = viscous(t, A0, PERIOD, q, release=off)
    wander = 1.0 + unsteady * np.sin(2 * math.pi * (t - off) / 2.3)  # 1 at the switch-off: no jump
    y = np.where(t < off, A0 * wander * np.cos(W0 * (t - off)), free)
    y = y + SIGMA * np.random.default_rng(seed).standard_normal(t.size)
    return TimeSeries(t, y, source="driven.csv"), off


@pytest.mark.parametrize("driven, q", [(5.0, 40.0), (5.0, 6.0), (2.0, 40.0), (0.5, 40.0), (0.5, 6.0), (1.0, 6.0)])
def test_the_free_decay_starts_where_the_drive_stopped(driven, q):
    """Driven for 5 s (then a 40-period decay, or a fast one), 2 s, a period and half a period
    (one steady half swing before a decay that loses a quarter of the swing in each: fitted as
    free from the first turning point, C came out 14 % low)."""
    series, off = driven_then_free(driven, q, duration=40.0 if q > 10 else 15.0)
    tp = reduce_series(series)
    assert abs(tp.release_time - off) <= PERIOD + 0.05, (tp.release_time, off, tp.notes)
    assert any("not a free decay" in n for n in tp.notes), tp.notes
    res = fit_problem(make_problem(load_scene("fit.toml", text=SCENE), series), n_starts=1)
    covers(res, "viscous.C", W0 / q)


@pytest.mark.parametrize("seed", range(4))
def test_a_long_drive_with_a_long_decay_after_it(seed):
    """The case a steadiness tolerance set by the record's median swing misses: the median is the
    long decay's, and the drive's one-percent wander exceeds 2 % of it."""
    series, off = driven_then_free(5.0, 40.0, duration=45.0, seed=seed)
    tp = reduce_series(series)
    assert abs(tp.release_time - off) <= PERIOD + 0.05, (tp.release_time, off, tp.notes)


def loss_law_turns(n: int, linear: float, coulomb: float, drag: float, noise: float, seed: int) -> np.ndarray:
    """Alternating turning points of a free decay losing ``linear a + coulomb + drag a^2`` per half swing."""
    a = [A0]
    for _ in range(n - 1):
        x = a[-1]
        a.append(max(x - linear * x - coulomb - drag * x * x, 0.0))
    rng = np.random.default_rng(seed)
    return np.array(a) * (-1.0) ** np.arange(n) + noise * rng.standard_normal(n) + 0.01


@pytest.mark.parametrize("law", [(0.02, 0.0, 0.0), (0.0, 0.004, 0.0), (0.0, 0.0, 0.08), (0.3, 0.0, 0.0),
                                 (0.005, 0.002, 0.05)])
def test_a_free_decay_of_any_loss_law_is_never_driven(law):
    """Viscous, Coulomb (whose swings fall in a straight line), drag, a fast decay and a mixture;
    reading noise from a fiftieth of the loss to ten times it."""
    for n in (10, 30, 80):
        for noise in (1e-4, 1e-3, 5e-3):
            for seed in range(10):
                assert drive_off(loss_law_turns(n, *law, noise, seed)) is None, (law, n, noise, seed)


def test_the_change_is_found_in_the_swings_alone():
    """Steady for twelve half swings (a percent of wander), then viscous: the first free half swing
    is the thirteenth, within one, and the losses are the decay's."""
    k = np.arange(60)
    a = np.where(k < 12, A0 * (1 + 0.01 * np.sin(k / 2.0)), A0 * 0.96 ** np.maximum(k - 12, 0))
    v = a * (-1.0) ** k + 1e-3 * np.random.default_rng(1).standard_normal(k.size)
    got = drive_off(v)
    assert got is not None and abs(got.half_swing - 12) <= 1
    # the peak-to-peak swing 2 A0 loses 4 % per half swing just after the change
    assert got.loss_after == pytest.approx(2 * A0 * 0.04, rel=0.35)
    assert got.loss_before < 0.5 * got.loss_after


@pytest.mark.parametrize("light", [0.999, 0.99])
def test_a_free_decay_stopped_by_a_hand_is_not_a_drive(light):
    """A long free decay (0.1 % or 1 % lost per half swing) that a hand stops within three half
    swings at its end: the same two slopes as a drive switched off (little loss, then much at a
    smaller amplitude), but the free decay is the stretch before, so no drive may be found."""
    k = np.arange(110)
    a = A0 * light ** k
    a[-3:] = a[-4] * np.array([0.6, 0.25, 0.05])  # the hand
    v = a * (-1.0) ** k + 1e-3 * np.random.default_rng(2).standard_normal(k.size)
    assert drive_off(v) is None
    # the same swings with the release ten half swings before the hand are long enough after it
    steady = np.where(k < 60, A0, A0 * 0.96 ** np.maximum(k - 60, 0))
    assert drive_off(steady * (-1.0) ** k) is not None


def test_the_users_start_and_release_win_over_the_drive():
    series, off = driven_then_free(5.0, 40.0)
    from dataclasses import replace

    for window in (RecordWindow(0.0, start=0.0), RecordWindow(0.0, release=0.0)):
        given = replace(series, window=window)
        tp = reduce_series(given, user_window=given.window)
        assert tp.release_time == pytest.approx(0.0, abs=0.05), tp.notes
        assert not any("not a free decay" in n for n in tp.notes), tp.notes


def test_a_resonance_built_up_held_then_released():
    """The record of a driven torsion pendulum: the swing builds from rest to its steady size over
    about 25 periods, is held there for 40 more, then the drive is switched off and it decays.
    Fitted from the start, the build-up made the whole record look sustained and it was refused;
    the free decay starts where the drive stopped, within a period."""
    t = np.arange(0.0, 110.0, 1.0 / RATE)
    off = 70.0
    build = A0 * (1.0 - np.exp(-t / 8.0)) * np.cos(W0 * (t - off))
    free, _, _ = viscous(t, A0 * (1.0 - math.exp(-off / 8.0)), PERIOD, 40.0, release=off)
    y = np.where(t < off, build, free) + SIGMA * np.random.default_rng(0).standard_normal(t.size)
    series = TimeSeries(t, y, source="torsione.csv")
    tp = reduce_series(series)
    assert abs(tp.release_time - off) <= PERIOD + 0.05, (tp.release_time, tp.notes)
    res = fit_problem(make_problem(load_scene("fit.toml", text=SCENE), series), n_starts=1)
    covers(res, "viscous.C", W0 / 40.0)
