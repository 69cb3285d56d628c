"""A pendulum's angle unit judged by its own clock (escfit.analysis.pendulum_unit).

References independent of the code: the series ``T/T0 = 1 + A**2/16 + 11 A**4/3072`` of the
pendulum's period, and records integrated by scipy's ``solve_ivp`` (a damped pendulum
``theta'' + c theta' + omega0**2 sin(theta) = 0`` and a linear oscillator, which has no amplitude
dependence), sampled at 50 Hz with Gaussian reading noise.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from escfit.analysis.pendulum_unit import pendulum_period_factor, swing_periods, unit_from_period

OMEGA0, RATE = 4.0, 50.0


def _record(amplitude, c=0.02, duration=60.0, noise=3e-4, seed=0, linear=False):
    def rhs(_, y):
        return [y[1], -c * y[1] - OMEGA0 ** 2 * (y[0] if linear else math.sin(y[0]))]

    t = np.arange(0.0, duration, 1.0 / RATE)
    sol = solve_ivp(rhs, (0.0, duration), [amplitude, 0.0], t_eval=t, rtol=1e-8, atol=1e-10)
    return t, sol.y[0] + noise * np.random.default_rng(seed).standard_normal(t.size)


def test_period_factor_against_the_series_and_an_integration():
    a = np.array([0.05, 0.2, 0.4])
    np.testing.assert_allclose(pendulum_period_factor(a), 1 + a ** 2 / 16 + 11 * a ** 4 / 3072, rtol=2e-6)
    t, x = _record(1.2, c=0.0, duration=20.0, noise=0.0)
    period, amp = swing_periods(t, x)
    assert np.median(period) == pytest.approx(2 * math.pi / OMEGA0 * pendulum_period_factor(1.2), rel=2e-4)
    assert np.median(amp) == pytest.approx(1.2, rel=2e-3)
    assert pendulum_period_factor(math.pi + 0.1) == math.inf  # over the top: no swing


def test_the_unit_as_read_radians_read_as_degrees_and_no_pendulum():
    t, x = _record(0.4)
    assert unit_from_period(t, x).verdict == "as read"
    as_degrees = unit_from_period(t, np.radians(x))  # the file's radians read as degrees
    assert as_degrees.verdict == "radians read as degrees"
    assert "57 times larger" in as_degrees.sentence()
    t, x = _record(0.5, linear=True)  # a hairspring's or a mass's record: the period keeps still
    assert unit_from_period(t, x).verdict == "unlike a pendulum"


def test_noise_crossing_zero_back_and_forth_makes_no_period():
    """A downward crossing read down, up, down (one sample's noise) gave an upward crossing half a
    period early: two half periods among the full ones, and a clean pendulum called unlike one."""
    t, x = _record(0.3, noise=1e-4)
    down = np.flatnonzero((x[:-1] >= 0.0) & (x[1:] < 0.0))[20]  # a downward crossing mid-record
    x = x.copy()
    x[down + 1], x[down + 2] = -0.01 * abs(x[down + 3]), 0.01 * abs(x[down + 3])  # below 0, back above, then on
    period, _ = swing_periods(t, x)
    assert np.all(np.abs(period / np.median(period) - 1.0) < 0.01)
    assert unit_from_period(t, x).verdict == "as read"


def test_small_swings_in_degrees_are_never_taken_for_radians():
    for seed in range(6):  # 1-3 degree swings, the unit right: the clock cannot say, or agrees
        t, x = _record(math.radians(1.0 + seed / 3), seed=seed, noise=2e-5)
        assert unit_from_period(t, x).verdict in ("as read", "undecided"), seed


def test_too_few_periods_say_nothing():
    t, x = _record(0.4, duration=12.0)
    assert unit_from_period(t, x) is None


def test_a_record_unlike_a_pendulum_fitted_as_one_leaves_omega0_undetermined(tmp_path, monkeypatch):
    """A linear oscillator swinging 0.5 rad, written in degrees and fitted as a gravity pendulum:
    its period keeps still where a pendulum's would shorten by 1.5 % as it decays, so the
    small-swing omega0 (the period shortened by that law at the amplitudes read) is marked not
    determined, with the warning naming the keys."""
    from click.testing import CliRunner

    from escfit.cli.main import cli
    from escfit.results import load_fit

    t, x = _record(0.5, linear=True)
    monkeypatch.chdir(tmp_path)
    np.savetxt("spring.csv", np.c_[t, np.degrees(x)], delimiter=",", header="time (s),angle (deg)", comments="",
               fmt="%.5f")
    runner = CliRunner()
    assert runner.invoke(cli, ["init", "spring.csv", "--pendulum"]).exit_code == 0
    r = runner.invoke(cli, ["fit", "spring.csv", "--scene", "spring.toml", "--out", "f.h5"])
    assert r.exit_code == 0, r.output
    res = load_fit("f.h5")
    assert "oscillator.omega0" in res.undetermined
    assert any(w.startswith("omega0 is not determined: the period does not change with the amplitude") and
               "angle_unit" in w for w in res.warnings), res.warnings
