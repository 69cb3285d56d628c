"""The least-squares optimiser against independent references: the closed form of a linear
model, scipy's Levenberg-Marquardt (MINPACK) on a nonlinear decay, and the known truth of a
synthetic record; the multistart ranking of its starts."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest
from scipy.optimize import least_squares as scipy_least_squares

from escfit.inference.lsq import N_REFINE, _ranked, least_squares
from escfit.inference.trf import minimize
from escfit.likelihood.priors import Prior
from escfit.likelihood.problem import ProblemBase


class Toy(ProblemBase):
    """Readings ``y = model(x, t) + e`` with known noise ``sigma``; uniform priors on the bounds."""

    family = "toy"
    reading_units = "rad"

    def __init__(self, model, t, y, sigma, names, lower, upper, initial):
        self.model, self.t, self.y, self.sigma = model, np.asarray(t, float), np.asarray(y, float), sigma
        self.names = list(names)
        self.priors = [Prior("uniform", (a, b), a, b) for a, b in zip(lower, upper)]
        self._bounds = (np.asarray(lower, float), np.asarray(upper, float))
        self._initial = np.asarray(initial, float)
        self.failures = Counter()

    initial = property(lambda self: self._initial)
    bounds = property(lambda self: self._bounds)
    observed = property(lambda self: self.y)

    def values(self, vec):
        if isinstance(vec, dict):
            return {**dict(zip(self.names, self._initial)), **vec}
        return dict(zip(self.names, np.asarray(vec, float)))

    def expected(self, vals):
        return self.model(np.array([vals[n] for n in self.names]), self.t)

    def residuals(self, vals):
        return (self.y - self.expected(vals)) / self.sigma

    def provenance(self):
        return {"data_file": "toy.csv"}


def _decay(x, t):
    amp, tau, omega, phase = x
    return amp * np.exp(-t / tau) * np.cos(omega * t + phase)


def test_linear_model_matches_the_closed_form():
    rng = np.random.default_rng(20261127)
    t = np.linspace(0.0, 10.0, 400)
    design = np.column_stack([np.ones_like(t), t, t * t])
    truth, sigma = np.array([0.3, -1.2, 0.05]), 0.2
    y = design @ truth + sigma * rng.standard_normal(t.size)
    problem = Toy(lambda x, tt: x[0] + x[1] * tt + x[2] * tt * tt, t, y, sigma, ["a", "b", "c"],
                  [-10.0] * 3, [10.0] * 3, [0.0, 0.0, 0.0])
    res = least_squares(problem, n_starts=4, seed=3)
    exact, *_ = np.linalg.lstsq(design, y, rcond=None)
    cov = sigma**2 * np.linalg.inv(design.T @ design)
    se = np.sqrt(np.diag(cov))
    assert np.all(np.abs(res.value - exact) <= 1e-5 * se)
    np.testing.assert_allclose(res.stderr, se, rtol=1e-4)
    np.testing.assert_allclose(res.correlation, cov / np.outer(se, se), atol=1e-4)
    r = (y - design @ exact) / sigma
    assert res.chisqr == pytest.approx(float(r @ r), rel=1e-9)


def test_nonlinear_decay_matches_minpack_and_recovers_the_truth():
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 30.0, 1500)
    truth, sigma = np.array([0.7, 12.0, 3.85, 0.2]), 0.01
    y = _decay(truth, t) + sigma * rng.standard_normal(t.size)
    start = np.array([0.6, 9.0, 3.84, 0.0])
    problem = Toy(_decay, t, y, sigma, ["amp", "tau", "omega", "phase"], [0.0, 0.1, 3.0, -3.0],
                  [2.0, 100.0, 4.5, 3.0], start)
    res = least_squares(problem, n_starts=1)
    ref = scipy_least_squares(lambda x: (y - _decay(x, t)) / sigma, start, method="lm", xtol=1e-12, ftol=1e-12)
    cov = np.linalg.inv(ref.jac.T @ ref.jac)
    se = np.sqrt(np.diag(cov))
    assert np.all(np.abs(res.value - ref.x) <= 1e-3 * se)
    np.testing.assert_allclose(res.stderr, se, rtol=1e-3)
    # the truth, at a fixed seed: within four standard errors in every parameter
    assert np.all(np.abs(res.value - truth) <= 4.0 * res.stderr)


def test_minimize_respects_bounds_and_gives_the_unscaled_covariance():
    t = np.linspace(0.0, 1.0, 50)
    y = 2.0 * t - 0.5  # the unconstrained optimum has an intercept of -0.5, below the bound 0
    res = minimize(lambda x: x[0] + x[1] * t - y, np.array([1.0, 1.0]), np.array([0.0, -5.0]),
                   np.array([5.0, 5.0]))
    assert res.x[0] == pytest.approx(0.0, abs=1e-7)
    # on the bound the slope is the least-squares slope through the origin
    assert res.x[1] == pytest.approx(float(t @ y / (t @ t)), rel=1e-6)
    design = np.column_stack([np.ones_like(t), t])
    np.testing.assert_allclose(res.covar, np.linalg.inv(design.T @ design), rtol=1e-5)


def test_the_multistart_refines_the_cheapest_starts():
    starts = [np.array([v]) for v in (4.0, -1.0, 0.5, 3.0, 2.0)]
    ranked = _ranked(starts, lambda x: x - 0.4, np.array([-10.0]), np.array([10.0]), 3)
    assert [float(x[0]) for x in ranked] == [0.5, -1.0, 2.0]
    assert _ranked(starts, lambda x: x, np.array([-10.0]), np.array([10.0]), 9) is starts


def test_default_multistart_finds_the_global_minimum_from_a_wrong_basin():
    """A frequency started in the wrong basin: a ranked start from the hypercube finds the right one."""
    t = np.linspace(0.0, 20.0, 800)
    y = np.cos(2.0 * t)
    problem = Toy(lambda x, tt: np.cos(x[0] * tt), t, y, 0.05, ["omega"], [0.5], [3.5], [1.2])
    res = least_squares(problem, n_starts=24, seed=1)
    assert res.n_starts == N_REFINE
    assert res.value[0] == pytest.approx(2.0, abs=1e-6)
    assert math.isfinite(res.stderr[0])
