"""The least-squares normal approximation's draws keep to the bounds without breaking correlations.

Two losses that trade along a ridge (correlation -0.999), one on its bound 0: the combination the
data fix (here ``C + 0.68 R``, along which the standard errors give no spread) must keep the best
fit's value in every draw.  Clipping each parameter on its own breaks that (both are pushed up);
leaving out-of-bounds draws out does not.  Closed form: on the ridge the combination is constant.
"""

from __future__ import annotations

import numpy as np

from escfit.report.quantities import N_DRAWS, _bounded_normal

VALUE = np.array([0.0, 0.0226])  # C on its bound, R inside
SE = np.array([0.1056, 0.1549])
CORR = -0.999
COV = np.array([[SE[0] ** 2, CORR * SE[0] * SE[1]], [CORR * SE[0] * SE[1], SE[1] ** 2]])
LO, HI = np.array([0.0, 0.0]), np.array([0.19, 0.24])
FIXED = SE[1] / SE[0]  # C + (se_C/se_R) R is what the data fix: its spread is sqrt(2 (1 + corr)) se_C


def combination(draws: np.ndarray) -> np.ndarray:
    return draws[:, 0] + draws[:, 1] / FIXED


def test_draws_stay_on_the_ridge_inside_the_bounds():
    draws = _bounded_normal(np.random.default_rng(1), VALUE, COV, LO, HI)
    assert draws.shape == (N_DRAWS, 2)
    assert np.all(draws >= LO) and np.all(draws <= HI)
    best = VALUE[0] + VALUE[1] / FIXED
    spread = np.sqrt(2 * (1 + CORR)) * SE[0]  # of the combination, unbounded
    assert abs(np.median(combination(draws)) - best) < 2 * spread
    assert np.quantile(combination(draws), 0.975) - best < 4 * spread


def test_clipping_would_have_moved_the_combination():
    # the reference the module improves on: each parameter clipped on its own
    z = np.random.default_rng(1).multivariate_normal(VALUE, COV, size=N_DRAWS)
    clipped = np.clip(z, LO, HI)
    best = VALUE[0] + VALUE[1] / FIXED
    assert np.median(combination(clipped)) - best > 0.5 * SE[0]


def test_an_approximation_far_out_of_its_bounds_is_clipped_as_a_last_resort():
    draws = _bounded_normal(np.random.default_rng(2), np.array([-1.0, 0.1]), np.diag([1e-4, 1e-4]), LO, HI)
    assert draws.shape == (N_DRAWS, 2) and np.all(draws[:, 0] == 0.0)
