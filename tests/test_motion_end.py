"""Where a swing that never rests ends: sunk into the record's noise floor (analysis.recordings.noise_end).

The records are the closed form of a damped linear oscillator with white reading noise of
scale ``SIGMA`` (the floor), running on long after the swing has sunk into it, with and without
a step of the sensor's zero in that tail.  The truth for the end: where the amplitude
``a0 exp(-g t)`` meets three floors.  A push well above the floor is still a push, a clean
decay loses nothing, and the user's ``stop`` wins.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from escfit.analysis.recordings.noise_end import CUT_RATIO, sunk_end
from escfit.analysis.recordings.timeseries import TimeSeries
from escfit.analysis.recordings.turning_points import reduce_series
from escfit.analysis.recordings.window import RecordWindow
from escfit.core.scene import load_scene
from escfit.inference import make_problem
from escfit.inference.fit import fit_problem

from .test_motion_found import pushed, viscous
from .cli_folder import new_folder

PERIOD, Q, SIGMA, RATE = 1.0, 30.0, 0.005, 50.0  # s, -, rad, samples per second
W0 = 2 * math.pi / PERIOD
G = W0 / (2 * Q)  # the amplitude's decay rate, 1/s; C = 2 G
SCENE = """model = "balance"
[oscillator]
omega0 = 6.283185307179586
[effects.viscous]
C = { value = 0.1, vary = true, min = 0, max = 2 }
[observation]
model = "amplitude"
"""


def sunk_record(step: float, *, seed: int = 0, a0: float = 0.5, release: float = 1.0, duration: float = 50.0):
    """Released from a hold at ``a0`` (rad) at ``release``; a zero step of ``step`` rad at 42 s.
    Returns the series and the instant the amplitude meets ``CUT_RATIO`` floors."""
    t = np.arange(0.0, duration, 1.0 / RATE)
    y, _, _ = viscous(t, a0, PERIOD, Q, release=release)
    y = y + SIGMA * np.random.default_rng(seed).standard_normal(t.size) + step * (t >= 42.0)
    meets = release + math.log(a0 / (CUT_RATIO * SIGMA)) / G
    return TimeSeries(t, y, source="sunk.csv"), meets


def covers(res, name: str, truth: float) -> None:
    row = res.summary()[name]
    assert row["lo95"] <= truth <= row["hi95"], (name, truth, row["lo95"], row["hi95"])


@pytest.mark.parametrize("step", [0.0, 8 * SIGMA, 40 * SIGMA])
def test_a_decay_into_the_noise_ends_where_it_meets_three_floors(step):
    series, meets = sunk_record(step)
    tp = reduce_series(series)
    assert tp.release_time == pytest.approx(1.0, abs=0.05 * PERIOD), tp.notes  # the step is no push
    assert abs(tp.stop_time - meets) < 2 * PERIOD, (tp.stop_time, meets)
    assert tp.noise_floor == pytest.approx(SIGMA, rel=0.2)
    assert tp.time[-1] <= tp.stop_time
    note = [n for n in tp.notes if n.startswith("the swing sinks into the record's noise")]
    assert note and "noise floor" in note[0], tp.notes
    # over a quarter of the record left out: a warning that names the key that keeps it
    share = (series.time[-1] - tp.stop_time) / series.time[-1]
    assert share > 0.25 and any("[recording] stop" in w and "noise floor" in w for w in tp.warnings), tp.warnings
    w1 = math.sqrt(W0 * W0 - G * G)
    assert tp.period == pytest.approx(2 * math.pi / w1, abs=4 * tp.period_stderr)
    res = fit_problem(make_problem(load_scene("fit.toml", text=SCENE), series), n_starts=1)
    covers(res, "viscous.C", 2 * G)


def test_the_floor_and_the_end_on_their_own():
    """The window fits measure the floor as the samples' scatter, and the end lies where the
    amplitude is three of them, for several noise draws."""
    for seed in range(5):
        series, meets = sunk_record(8 * SIGMA, seed=seed)
        end = sunk_end(series.time, series.theta, PERIOD)
        assert end is not None
        assert end.floor == pytest.approx(SIGMA, rel=0.15)
        assert end.amplitude == pytest.approx(CUT_RATIO * end.floor, rel=0.2)
        assert abs(end.time - meets) < 2 * PERIOD


def test_a_push_after_the_swing_sank_starts_a_new_decay_and_its_end_is_found():
    """Sunk by 15 s, pushed again well above the floor at 20 s, sunk again, a zero step at 42 s."""
    t = np.arange(0.0, 50.0, 1.0 / RATE)
    q = 10.0
    g = W0 / (2 * q)
    first, _, _ = viscous(t, 0.5, PERIOD, q, release=1.0)
    again, tt, _ = pushed(t, 0.4 * W0, PERIOD, q, 20.0)
    y = first + again + SIGMA * np.random.default_rng(3).standard_normal(t.size) + 8 * SIGMA * (t >= 42.0)
    tp = reduce_series(TimeSeries(t, y, source="pushed.csv"))
    assert tp.release_time == pytest.approx(tt[0], abs=PERIOD), tp.notes
    meets = 20.0 + math.log(0.4 / (CUT_RATIO * SIGMA)) / g
    assert abs(tp.stop_time - meets) < 2 * PERIOD, (tp.stop_time, meets)


def test_a_push_well_above_the_floor_is_still_a_push():
    """A push at 10 s while the swing is some twenty floors: the free decay starts after it."""
    t = np.arange(0.0, 50.0, 1.0 / RATE)
    y, _, _ = viscous(t, 0.5, PERIOD, Q, release=1.0)
    extra, tt, _ = pushed(t, 0.3 * W0, PERIOD, Q, 10.0)
    y = y + extra + SIGMA * np.random.default_rng(4).standard_normal(t.size) + 8 * SIGMA * (t >= 42.0)
    tp = reduce_series(TimeSeries(t, y, source="pushed.csv"))
    assert 10.0 < tp.release_time < 10.0 + PERIOD, tp.notes
    assert any("not a free decay" in n for n in tp.notes), tp.notes


@pytest.mark.parametrize("seed", range(3))
def test_a_clean_decay_from_its_release_loses_nothing(seed):
    """From a turning point at the first sample, 40 periods, never near the floor: no cut either end."""
    t = np.arange(0.0, 40.0, 1.0 / RATE)
    y, _, _ = viscous(t, 0.5, PERIOD, 100.0)
    tp = reduce_series(TimeSeries(t, y + 0.002 * np.random.default_rng(seed).standard_normal(t.size),
                                  source="clean.csv"))
    assert tp.release_time == pytest.approx(0.0, abs=0.02)
    assert math.isnan(tp.stop_time) and math.isnan(tp.noise_floor)
    assert tp.time[-1] > 39.0 - PERIOD
    assert not tp.warnings and not any("not a free decay" in n or "sinks" in n for n in tp.notes), tp.notes


def test_the_users_stop_wins():
    """A stop the user set further into the noise (the reader already cut the samples there): no
    end of its own is looked for."""
    series, meets = sunk_record(0.0)
    keep = series.time <= 40.0
    cut = TimeSeries(series.time[keep], series.theta[keep], source="sunk.csv", window=RecordWindow(0.0, stop=40.0))
    tp = reduce_series(cut, user_window=cut.window)
    assert math.isnan(tp.noise_floor)
    assert not any("sinks into" in n for n in tp.notes), tp.notes
    assert reduce_series(cut).stop_time < 40.0 - PERIOD  # without the key, it would have been cut


def test_init_writes_the_stop_for_a_gyroscope_sunk_into_its_noise(tmp_path):
    """A phone's rate (rad/s) decays into its noise and its bias steps later: init writes the end of
    motion as an active stop, and the fit with that scene covers the truth."""
    from click.testing import CliRunner

    from escfit.cli.main import cli
    from escfit.inference import fit

    w0, C, a0, sigma = 5.0, 0.5, 0.1, 0.004  # rad/s, 1/s, rad, rad/s
    wd = math.sqrt(w0 ** 2 - C ** 2 / 4)
    t = np.arange(0.0, 26.0, 0.02)
    rate = -a0 * np.exp(-C * t / 2) * (w0 ** 2 / wd) * np.sin(wd * t)
    rate += np.random.default_rng(5).normal(0, sigma, t.size) + 0.01 + 6 * sigma * (t >= 21.0)
    meets = math.log(a0 * w0 / (CUT_RATIO * sigma)) / (C / 2)
    data = tmp_path / "gyro.csv"
    data.write_text("t (s),Gyroscope z (rad/s)\n" + "".join(f"{a:.3f},{b:.5f}\n" for a, b in zip(t, rate)))
    runner = CliRunner()
    with new_folder(tmp_path) as here:
        result = runner.invoke(cli, ["init", str(data), "--spring", "--out", "gyro.toml"], catch_exceptions=False)
        assert result.exit_code == 0, result.output
        text = (tmp_path / here / "gyro.toml").read_text()
    doc = tomllib.loads(text)
    stop = float(doc["recording"]["stop"].split()[0])
    assert abs(stop - meets) < 2 * 2 * math.pi / wd, (stop, meets)
    assert "sinks into the record's noise" in text
    res = fit(tmp_path / here / "gyro.toml", str(data), n_starts=1)
    covers(res, "oscillator.omega0", w0)
    covers(res, "viscous.C", C)


def test_a_swing_that_comes_back_after_sinking_has_not_ended():
    """A decay that sinks into the noise and is struck again (an impact test's second hammer blow)
    has not reached its end of motion; a noise tail with one step of its zero, or a drifting zero,
    does not swing again."""
    from escfit.analysis.recordings.noise_end import resumes

    rng = np.random.default_rng(4)
    t = np.arange(0.0, 40.0, 0.02)
    decay = np.exp(-0.5 * t) * np.cos(2 * np.pi * t)
    noise = 1e-3 * rng.standard_normal(t.size)
    i = int(np.searchsorted(t, 12.0))
    struck = decay + np.where(t > 20, np.exp(-0.5 * (t - 20)) * np.cos(2 * np.pi * (t - 20)), 0.0) + noise
    assert resumes(t, struck, i, 1.0)
    stepped = decay + noise + np.where(t > 25, 0.2, 0.0)  # a step of a fifth of the first swing
    drifting = decay + noise + 0.01 * t  # an integrated bias
    assert not resumes(t, stepped, i, 1.0) and not resumes(t, drifting, i, 1.0)


def test_a_tail_that_comes_to_rest_is_counted_whole():
    """Noise that ends in a rest: the note gives the whole tail left out, then its noise and its
    rest (it said "0 % of it" of a record whose last 12 % rested), each from the record's clock."""
    from escfit.analysis.recordings.noise_end import describe, sunk_end_before

    series, _ = sunk_record(0.0)
    t, y = np.asarray(series.time), np.asarray(series.theta)
    end = sunk_end(t, y, PERIOD)
    i_rest = end.index + int(0.5 * RATE)  # half a second of noise, then the rest
    got = sunk_end_before(t, y, PERIOD, i_rest)
    span = t[-1] - t[0]
    assert got.share == pytest.approx((t[i_rest - 1] - end.time) / span, rel=1e-12)
    assert got.at_rest == pytest.approx((t[-1] - t[i_rest - 1]) / span, rel=1e-12)
    note, _ = describe(got, lambda v: f"{v:.2g} rad")
    whole = round(100 * (t[-1] - end.time) / span)
    assert f"is left out ({whole} % of it: {round(100 * got.share)} % noise, then " \
           f"{round(100 * got.at_rest)} % at rest)" in note, note
