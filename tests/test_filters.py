"""The numpy Tukey window and Savitzky-Golay smoother against scipy.signal, the reference."""

import numpy as np
import pytest
from scipy import signal

from escfit.core.filters import savgol_coeffs, savgol_filter, tukey


@pytest.mark.parametrize("n", [0, 1, 2, 3, 10, 11, 101, 1000])
@pytest.mark.parametrize("alpha", [0.0, 0.1, 0.5, 1.0, 1.5])
def test_tukey_matches_scipy(n, alpha):
    np.testing.assert_allclose(tukey(n, alpha), signal.windows.tukey(n, alpha), rtol=0, atol=1e-14)


def test_tukey_hann_and_rectangle():
    n = 64
    k = np.arange(n)
    np.testing.assert_allclose(tukey(n, 1.0), 0.5 - 0.5 * np.cos(2 * np.pi * k / (n - 1)), atol=1e-14)
    assert np.array_equal(tukey(n, 0.0), np.ones(n))


@pytest.mark.parametrize("window,order", [(5, 2), (7, 2), (11, 2), (101, 2), (9, 3), (5, 0)])
def test_savgol_coeffs_match_scipy(window, order):
    np.testing.assert_allclose(savgol_coeffs(window, order), signal.savgol_coeffs(window, order), atol=1e-12)


@pytest.mark.parametrize("n,window", [(5, 5), (40, 5), (200, 11), (5000, 201), (1001, 7)])
def test_savgol_filter_matches_scipy(n, window):
    rng = np.random.default_rng(n)
    t = np.linspace(0, 10, n)
    x = np.exp(-0.2 * t) * np.cos(3 * t) + 0.01 * rng.standard_normal(n) + 5.0
    ours = savgol_filter(x, window, 2)
    ref = signal.savgol_filter(x, window, 2, mode="interp")
    np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-10 * np.max(np.abs(x)))


def test_savgol_filter_keeps_a_parabola():
    # a quadratic is reproduced exactly by a quadratic smoother, ends included
    t = np.arange(50.0)
    x = 0.3 * t ** 2 - 2 * t + 1
    np.testing.assert_allclose(savgol_filter(x, 9, 2), x, rtol=1e-10, atol=1e-9)


def test_savgol_refusals():
    with pytest.raises(ValueError, match="odd"):
        savgol_coeffs(4, 2)
    with pytest.raises(ValueError, match="longer than the series"):
        savgol_filter(np.ones(3), 5, 2)
