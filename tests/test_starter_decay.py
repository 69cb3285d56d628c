"""init's starting values of C and R from a record's half-swing amplitudes.

A linear oscillator with viscous damping C and Coulomb friction R loses, per half swing of
duration pi/wd, a factor ``q = exp(-C pi / (2 wd))`` and then ``2 R / omega0^2`` (scaled by
``(1 + q) / 2``, as both halves of the swing feel the friction): the amplitudes obey
``a_(k+1) = q a_k - (1 + q) R / omega0^2`` exactly, and are generated that way here.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.balance.starter import decay_estimates

W0, C, R = 4.0, 0.05, 0.02


def amplitudes(n=60, a0=0.5, noise=0.0, seed=0):
    wd = math.sqrt(W0 ** 2 - (C / 2) ** 2)
    q = math.exp(-C * math.pi / (2 * wd))
    a = np.empty(n)
    a[0] = a0
    for k in range(1, n):
        a[k] = q * a[k - 1] - (1 + q) * R / W0 ** 2
    return a + noise * np.random.default_rng(seed).standard_normal(n)


def test_the_split_of_an_exact_decay_is_recovered():
    got = decay_estimates(amplitudes(), W0)
    assert got["C"] == pytest.approx(C, rel=1e-4) and got["R"] == pytest.approx(R, rel=1e-4)


def test_the_split_of_a_noisy_decay_stays_near_the_truth():
    """Sixty amplitudes read to 1 % of the first one: the starts stay within 30 % of R and 15 % of
    C in each of 40 draws (regressing each amplitude on the one before, where both sides carry
    the noise and bias the slope, put R at half the truth in some)."""
    for seed in range(40):
        got = decay_estimates(amplitudes(noise=0.005, seed=seed), W0)
        assert got["C"] == pytest.approx(C, rel=0.15), (seed, got)
        assert got["R"] == pytest.approx(R, rel=0.3), (seed, got)
