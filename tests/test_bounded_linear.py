"""The bounded linear least squares (:func:`escfit.inference.bounded_linear.bounded_lstsq`)
against scipy's :func:`~scipy.optimize.lsq_linear` run to a tight tolerance, and against the
closed form of one column."""

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from escfit.inference import bounded_linear
from escfit.inference.bounded_linear import bounded_lstsq


def _problem(rng, m, p, cond):
    """Rows ``m``, columns ``p`` of magnitudes spread over ``cond``, optimum partly outside a box."""
    a = rng.normal(size=(m, p)) * np.logspace(0, np.log10(cond), p)
    truth = rng.normal(size=p) / np.logspace(0, np.log10(cond), p)
    b = a @ truth + 0.05 * rng.normal(size=m)
    width = np.abs(truth) * rng.uniform(0.2, 1.5, p)  # some bounds cut the optimum off, some not
    lower = np.where(rng.uniform(size=p) < 0.3, -np.inf, -width)
    upper = np.where(rng.uniform(size=p) < 0.3, np.inf, width)
    return a, b, lower, upper


@pytest.mark.parametrize("seed", range(40))
def test_same_minimum_as_scipy(seed):
    rng = np.random.default_rng(seed)
    p = int(rng.integers(1, 9))
    a, b, lower, upper = _problem(rng, int(rng.integers(p, 400)), p, cond=10.0 ** rng.uniform(0, 6))
    exact = lsq_linear(a, b, bounds=(lower, upper), method="bvls", tol=1e-14)
    got = bounded_lstsq(a, b, lower, upper)
    assert np.all(got >= lower) and np.all(got <= upper)
    cost = float(np.sum((a @ got - b) ** 2))
    best = float(np.sum((a @ exact.x - b) ** 2))
    assert cost <= best * (1 + 1e-10) + 1e-300
    scale = np.maximum(np.abs(exact.x), np.abs(upper - lower).clip(max=1.0) * 1e-3)
    np.testing.assert_allclose(got, exact.x, rtol=0, atol=1e-6 * float(np.max(scale)) + 1e-12)


def test_bounds_binding_take_the_active_set_path(monkeypatch):
    """A case with an upper and a lower bound binding, solved without scipy (the fallback would
    raise here); the cost matches scipy's."""
    rng = np.random.default_rng(7)
    a = rng.normal(size=(200, 4))
    b = a @ np.array([2.0, -3.0, 0.5, 0.1]) + 0.01 * rng.normal(size=200)
    lower, upper = np.array([-1.0, -1.0, -1.0, -1.0]), np.array([1.0, 1.0, 1.0, 1.0])
    exact = lsq_linear(a, b, bounds=(lower, upper), tol=1e-14)
    assert exact.active_mask[0] == 1 and exact.active_mask[1] == -1  # the case meant
    monkeypatch.setattr(bounded_linear, "lsq_linear", None, raising=False)
    x = bounded_linear._active_set(a, b, lower, upper)
    assert x is not None and x[0] == 1.0 and x[1] == -1.0
    np.testing.assert_allclose(x, exact.x, atol=1e-8)


def test_one_column_is_the_clipped_projection():
    """One parameter: the unbounded slope a.b/a.a clipped into the box (closed form)."""
    rng = np.random.default_rng(11)
    a = rng.normal(size=(50, 1))
    b = 3.0 * a[:, 0] + rng.normal(size=50)
    slope = float(a[:, 0] @ b / (a[:, 0] @ a[:, 0]))
    for lo, hi in ((-np.inf, np.inf), (0.0, 1.0), (4.0, 9.0), (slope, slope)):
        assert bounded_lstsq(a, b, np.array([lo]), np.array([hi]))[0] == pytest.approx(min(max(slope, lo), hi),
                                                                                       rel=1e-12)


@pytest.mark.parametrize("case", ["rank-deficient", "not finite", "fewer rows"])
def test_hard_cases_go_to_scipy(case):
    """Where the optimality check cannot vouch for an answer, scipy solves it: a finite point
    inside the bounds, scipy's own."""
    rng = np.random.default_rng(5)
    a = rng.normal(size=(30, 3))
    b = rng.normal(size=30)
    if case == "rank-deficient":
        a[:, 2] = a[:, 0]
    elif case == "not finite":
        b[3] = np.inf
    else:
        a = a[:2]
        b = b[:2]
    lower, upper = -np.ones(3), np.ones(3)
    assert bounded_linear._active_set(a, b, lower, upper) is None
    if case != "not finite":
        x = bounded_lstsq(a, b, lower, upper)
        assert np.all(np.isfinite(x)) and np.all(np.abs(x) <= 1.0)
