"""Least squares' Jacobian from one batch call, against scipy's own forward differences.

``WaveformProblem.residuals_many`` gives the residuals of many parameter sets from one batch
solve; the reference is ``residuals`` row by row.  :func:`escfit.inference.fdjac.batch_jacobian`
takes scipy's "2-point" steps and runs them in one such call; the reference is scipy's
``approx_derivative`` of the one-set residual function (independent code, the one
``jac="2-point"`` runs), here with a parameter on its upper bound (the step taken backwards).
A fit with the batch Jacobian must reproduce the estimates and standard errors of one with
``jac="2-point"``, on a synthetic record (exact solver) and a pendulum (dop853).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize._numdiff import approx_derivative

from . import test_waveform_batch as exact_case
from . import test_waveform_batch_dop853 as pendulum_case
from escfit.inference.fdjac import batch_jacobian, forward_steps
from escfit.inference.lsq import least_squares


def _problem(case, observation=""):
    problem = case._problem(observation=observation)
    assert problem.vectorized
    return problem


CASES = [(exact_case, ""), (exact_case, "noise = \"ar1\"\ngain = { value = 1.0, vary = true, min = 0.5, max = 2 }"),
         (pendulum_case, "")]


@pytest.mark.parametrize("case, observation", CASES)
def test_residuals_many_are_the_one_set_residuals(case, observation):
    problem = _problem(case, observation)
    vecs = case._sets(problem, 6)
    t_rel = problem.params["observation.t_release"].value
    late = case._set(problem, vecs[0], **{"observation.t_release": problem.sample_time[0] + 0.5})  # fails
    vecs = np.vstack([vecs, late])
    problem.failures.clear()
    many = problem.residuals_many(vecs)
    failures = dict(problem.failures)
    problem.failures.clear()
    rows = np.array([problem.residuals(problem.values(v)) for v in vecs])
    assert t_rel < problem.sample_time[0] and failures == dict(problem.failures) and sum(failures.values()) == 1
    assert np.all(np.isfinite(many))
    np.testing.assert_allclose(many, rows, rtol=1e-12, atol=1e-14)


def test_forward_steps_follow_the_bounds():
    x = np.array([0.0, -3.0, 2.0, 1.0, 0.5])
    lo = np.array([-1.0, -5.0, 0.0, 0.0, 0.5 - 1e-12])
    hi = np.array([1.0, 5.0, 2.0, np.inf, 0.5 + 1e-12])
    h = forward_steps(x, lo, hi)
    eps = np.sqrt(np.finfo(float).eps)
    # default steps sqrt(eps) max(1, |x|) with x's sign; at the upper bound backwards; a range
    # narrower than the step: to the farther bound (here the upper one, equally far)
    np.testing.assert_allclose(h[:4], [eps, -3 * eps, -2 * eps, eps], rtol=1e-15)
    assert h[4] == pytest.approx(hi[4] - x[4], rel=1e-12)
    assert np.all((x + h >= lo) & (x + h <= hi))


@pytest.mark.parametrize("case", [exact_case, pendulum_case])
def test_batch_jacobian_is_scipys_two_point_jacobian(case):
    problem = _problem(case)
    x = case._sets(problem, 1, seed=3)[0]
    lo, hi = problem.bounds
    at = problem.names.index("viscous.C")
    x[at] = hi[at]  # on the upper bound: the step goes backwards

    def one(v):
        return problem.residuals(problem.values(v))

    ref = approx_derivative(one, x, method="2-point", bounds=(lo, hi))
    calls = []

    def rows(points):
        calls.append(len(points))
        return problem.residuals_many(points)

    for f0 in (None, one(x)):
        calls.clear()
        jac = batch_jacobian(rows, x, lo, hi, f0=f0)
        assert calls == [x.size + (f0 is None)]
        scale = np.max(np.abs(ref), axis=0)
        np.testing.assert_allclose(jac / scale, ref / scale, rtol=0, atol=1e-9)
    assert np.all(np.abs(ref[:, at]) < np.inf) and np.any(ref[:, at] != 0)
