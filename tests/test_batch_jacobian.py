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


@pytest.mark.parametrize("case, rel_step", [(exact_case, None), (pendulum_case, None), (exact_case, 1e-6)])
def test_batch_jacobian_is_scipys_two_point_jacobian(case, rel_step):
    problem = _problem(case)
    x = case._sets(problem, 1, seed=3)[0]
    lo, hi = problem.bounds
    at = problem.names.index("viscous.C")
    x[at] = hi[at]  # on the upper bound: the step goes backwards

    def one(v):
        return problem.residuals(problem.values(v))

    ref = approx_derivative(one, x, method="2-point", rel_step=rel_step, bounds=(lo, hi))
    calls = []

    def rows(points):
        calls.append(len(points))
        return problem.residuals_many(points)

    for f0 in (None, one(x)):
        calls.clear()
        jac = batch_jacobian(rows, x, lo, hi, f0=f0, rel_step=rel_step)
        assert calls == [x.size + (f0 is None)]
        scale = np.max(np.abs(ref), axis=0)
        np.testing.assert_allclose(jac / scale, ref / scale, rtol=0, atol=1e-9)
    assert np.all(np.abs(ref[:, at]) < np.inf) and np.any(ref[:, at] != 0)


def _fit(problem, jac=None):
    problem.lsq_options = {} if jac is None else {"jac": jac}
    try:
        return least_squares(problem, n_starts=1)
    finally:
        del problem.lsq_options


@pytest.mark.parametrize("case", [exact_case, pendulum_case])
def test_fit_with_the_batch_jacobian_is_the_two_point_fit(case):
    problem = _problem(case)
    problem.residual_jacobian = lambda vals, names: None  # the forward differences, not the sensitivities
    calls = []
    many = problem.residuals_many
    problem.residuals_many = lambda vecs: calls.append(len(vecs)) or many(vecs)
    batch = _fit(problem)
    del problem.residuals_many
    assert calls and all(c >= len(batch.names) for c in calls)
    ref = _fit(problem, "2-point")
    start = np.asarray(problem.initial)[[problem.names.index(n) for n in batch.names]]
    assert np.max(np.abs(batch.value - start) / batch.stderr) > 1.0  # the fit went somewhere
    assert batch.names == ref.names and batch.success and ref.success
    np.testing.assert_allclose(batch.value, ref.value, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(batch.stderr, ref.stderr, rtol=1e-6)
    assert batch.chisqr == pytest.approx(ref.chisqr, rel=1e-9)


def test_real_string_pendulum_fit_is_the_two_point_fit():
    """The 116 s string pendulum recipe (dop853, AR(1) noise: two stages), as ``escfit fit`` builds it."""
    import tomllib
    from pathlib import Path

    from escfit.core.scene import load_scene
    from escfit.inference import registry

    recipe = Path(__file__).resolve().parents[1] / "fits" / "real" / "string_pendulum_lab1.toml"
    table = tomllib.loads(recipe.read_text())
    scene = load_scene(str((recipe.parent / table["scene"]).resolve()))
    fam = registry.family(scene.model)
    problem = fam.problem(scene, str((recipe.parent / table["data"]).resolve()), **dict(table.get("options", {})))
    assert problem.vectorized and problem.solver == "dop853"
    problem.residual_jacobian = lambda vals, names: None  # the forward differences, not the sensitivities
    defaults = dict(getattr(fam, "fit_defaults", {}))
    kw = dict(n_starts=defaults.get("n_starts", 8), n_refine=defaults.get("n_refine"), seed=int(table.get("seed", 0)))
    batch = least_squares(problem, **kw)
    problem.lsq_options = {"jac": "2-point"}
    ref = least_squares(problem, **kw)
    np.testing.assert_allclose(batch.value, ref.value, rtol=1e-6)
    np.testing.assert_allclose(batch.stderr, ref.stderr, rtol=1e-6)
    assert np.all(np.isfinite(batch.stderr)) and batch.chisqr == pytest.approx(ref.chisqr, rel=1e-9)
