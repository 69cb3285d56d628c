"""The drift of the centre: Theil-Sen in bounded memory against scipy's all-pairs one and a known slope."""

import math

import numpy as np
import pytest
from scipy.stats import theilslopes

from escfit.analysis.recordings.centre import measure_centre, theil_sen


@pytest.mark.parametrize("n", [4, 37, 500, 1414])
def test_every_pair_up_to_the_limit_gives_scipys_result(n):
    rng = np.random.default_rng(n)
    x = np.sort(rng.uniform(0.0, 100.0, n))
    y = 0.01 * x + 0.3 * rng.standard_normal(n)
    y[::5] = np.round(y[::5], 1)  # ties in y enter Sen's variance
    x[1::9] = x[::9][: x[1::9].size]  # and ties in x (pairs with equal x are left out)
    want = theilslopes(y, x)
    got = theil_sen(y, x)
    assert got == pytest.approx((want.slope, want.low_slope, want.high_slope), rel=1e-12, abs=1e-15)


def test_sampled_pairs_stay_within_a_tenth_of_the_interval_of_all_pairs():
    # 3000 points: 4.5 million pairs, of which 10^6 are used; a tenth of the outliers far off
    rng = np.random.default_rng(3)
    n = 3000
    x = 0.1 * np.arange(n)
    y = 1e-4 * x + 0.01 * rng.standard_normal(n)
    y[rng.integers(0, n, n // 10)] += 1.0
    want = theilslopes(y, x)
    width = want.high_slope - want.low_slope
    got = theil_sen(y, x)
    for g, w in zip(got, (want.slope, want.low_slope, want.high_slope)):
        assert abs(g - w) < 0.1 * width


def test_sampled_pairs_are_the_same_each_run():
    x = np.linspace(0.0, 10.0, 2000)
    y = np.sin(7 * x)
    assert theil_sen(y, x) == theil_sen(y, x)


def test_a_known_drift_is_found_in_18000_turning_points_in_bounded_memory():
    # an hour of a watch balance: 18000 alternating turning points of a decay whose centre
    # creeps by 2e-5 rad/s (0.07 rad over the hour); all pairs would need gigabytes
    rng = np.random.default_rng(11)
    n = 18000
    t = 0.2 * np.arange(n)
    amplitude = 0.5 * np.exp(-t / 3000.0)
    sign = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    rate = 2e-5
    values = 0.01 + rate * t + sign * amplitude + 1e-3 * rng.standard_normal(n)
    c = measure_centre(t, values, band=4e-3)
    assert c.rate == c.measured_rate
    # the estimates' noise (1e-3 rad, neighbours sharing turning points) gives a slope error of
    # some 1e-3 / sqrt(n * T^2 / 12) ~ 1e-8 rad/s
    assert c.measured_rate == pytest.approx(rate, abs=5 * c.rate_stderr)
    assert c.rate_stderr < 1e-7
    assert c.offset == pytest.approx(0.01 + rate * t[0], abs=5 * c.offset_stderr)
    assert "drifts" in c.note


def test_no_drift_is_kept_when_the_interval_holds_zero():
    rng = np.random.default_rng(12)
    n = 5000
    t = 0.2 * np.arange(n)
    sign = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    values = -0.02 + sign * 0.3 * np.exp(-t / 2000.0) + 1e-3 * rng.standard_normal(n)
    c = measure_centre(t, values, band=4e-3)
    assert c.rate == 0.0
    assert abs(c.measured_rate) < 5 * c.rate_stderr
    assert c.offset == pytest.approx(-0.02, abs=5 * c.offset_stderr)
    assert math.isfinite(c.offset_stderr) and c.note == ""
