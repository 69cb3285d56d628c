"""Every fit recipe's problem as lmfit Parameters, and lmfit's notebook run end to end.

The Parameters must carry what the problem declares (independently: its ``names``, ``bounds``,
``noise_names``, ``units`` and the scene's fixed parameters); the residual's sum of squares at
escfit's least-squares optimum must be escfit's cost there (readings' chi-square plus the
Gaussian priors' terms, computed here from the priors directly).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from escfit.inference.lmfit_params import lmfit_key, lmfit_problem
from escfit.inference.lsq import least_squares

from .test_lmfit_path import ROOT, recipe_problem

lmfit = pytest.importorskip("lmfit")

RECIPES = sorted(str(p.relative_to(ROOT / "fits")) for p in (ROOT / "fits").rglob("*.toml"))


@pytest.mark.parametrize("recipe", RECIPES)
def test_every_recipe_is_an_lmfit_problem(recipe):
    _, problem = recipe_problem(recipe)
    lp = lmfit_problem(problem)
    lo, hi = problem.bounds
    noise = set(problem.noise_names)
    for i, name in enumerate(problem.names):
        p = lp.params[lmfit_key(name)]
        assert p.user_data["name"] == name and p.user_data["unit"] == problem.units.get(name, "")
        assert p.vary == (name not in noise) and p.min == lo[i] and p.max == hi[i]
    for q in problem.params:
        if q.name not in problem.names:
            p = lp.params[lmfit_key(q.name)]
            assert not p.vary and (p.expr is not None) == (q.tie is not None and q.tie[0] in lp.keys)


def test_a_tie_is_an_lmfit_expression():
    from escfit.core.params import Param, ParamSet
    from types import SimpleNamespace

    from escfit.likelihood.priors import uniform

    params = ParamSet()
    params.add(Param("escapement[1].M", 2.0, "1/s**2", "impulse", vary=True, min=0, max=10))
    params.add(Param("escapement[1].S", math.nan, "1/s**2", "unlock", tie=("escapement[1].M", 0.25)))
    fake = SimpleNamespace(family="balance", names=["escapement[1].M"], initial=np.array([2.0]), params=params,
                           bounds=(np.array([0.0]), np.array([10.0])), noise_names=(), priors=[uniform(0, 10)],
                           units={"escapement[1].M": "1/s**2", "escapement[1].S": "1/s**2"}, meanings={},
                           values=lambda m: {**dict(m), "escapement[1].S": 0.25 * dict(m)["escapement[1].M"]})
    lp = lmfit_problem(fake, {"escapement[1].M": 4.0})
    assert lp.params["escapement_1__S"].expr == "0.25 * escapement_1__M"
    assert lp.params["escapement_1__S"].value == pytest.approx(1.0)


def test_the_residual_is_escfits_cost():
    """The friction rig: noise known (not profiled), normal priors on the geometry and slopes."""
    _, problem = recipe_problem("friction_monday_steel.toml")
    lsq = least_squares(problem, n_starts=3, seed=1)
    assert not lsq.profiled
    lp = lmfit_problem(problem, lsq.values)
    r = lp.residual(lp.params)
    n = problem.n_data
    priors = 0.0
    for name in lp.fitted:
        pr = problem.priors[problem.names.index(name)]
        if pr.kind == "normal":
            priors += ((lsq.values[name] - pr.args[0]) / pr.args[1]) ** 2
    assert priors > 0 and r.size > n
    assert float(r[:n] @ r[:n]) == pytest.approx(lsq.chisqr, rel=1e-9)
    assert float(r[n:] @ r[n:]) == pytest.approx(priors, rel=1e-9)


def test_conf_interval_brackets_the_delta_method_interval():
    """geneva_trace: 201 readings, mu nearly linear in the readings: the profile (lmfit's F test)
    and escfit's delta-method 95 % interval agree to a tenth of their width."""
    fam, problem = recipe_problem("geneva_trace.toml")
    lsq = least_squares(problem, n_starts=fam.fit_defaults["n_starts"], n_refine=fam.fit_defaults["n_refine"], seed=1)
    assert lsq.at_bound.tolist() == [0, 0]
    lp = lmfit_problem(problem, lsq.values)
    mini = lp.minimizer()
    best = mini.minimize(method="least_squares")
    ci = lmfit.conf_interval(mini, best, p_names=["geneva__mu"], sigmas=[0.95])
    i = lsq.names.index("geneva.mu")
    lo, hi = lsq.intervals["lo95"][i], lsq.intervals["hi95"][i]
    width = hi - lo
    assert abs(ci["geneva__mu"][0][1] - lo) < 0.1 * width and abs(ci["geneva__mu"][2][1] - hi) < 0.1 * width


def test_conf_interval_with_a_parameter_on_its_bound():
    """A linear least squares whose best fit has w on its bound 0: conf_interval through escfit's
    Minimizer against the exact profile (scipy's bounded linear solver at each trial value, the
    F test's 95 % rise found by root search).  On one side the profile keeps w on its bound,
    where lmfit's bounds transform is flat and a plain MINPACK refit does not move."""
    from scipy import stats
    from scipy.optimize import brentq, lsq_linear

    from escfit.inference.lmfit_bounds import bound_aware_minimizer

    rng = np.random.default_rng(3)
    a = rng.normal(size=(60, 3))
    a[:, 2] += 0.8 * a[:, 0]  # w correlated with u, so that the profile of u moves w
    b = a @ np.array([0.8, 1.5, -0.6]) + 0.1 * rng.normal(size=60)
    lower, upper = np.array([-10.0, -10.0, 0.0]), np.array([10.0, 10.0, 1.0])
    params = lmfit.Parameters()
    for name, lo_, hi_ in zip("uvw", lower, upper):
        params.add(name, value=0.0, min=lo_, max=hi_)
    mini = bound_aware_minimizer(lmfit)(lambda p: a @ np.array([p["u"].value, p["v"].value, p["w"].value]) - b,
                                        params)
    best = mini.minimize(method="least_squares", ftol=1e-12, xtol=1e-12, gtol=1e-12)
    exact = lsq_linear(a, b, bounds=(lower, upper), tol=1e-12)
    assert exact.active_mask.tolist() == [0, 0, -1]
    chi_best = float(np.sum((a @ exact.x - b) ** 2))
    nfree = a.shape[0] - 3
    level = stats.f.ppf(0.95, 1, nfree) * chi_best / nfree

    def rise(u):
        rest = lsq_linear(a[:, 1:], b - a[:, 0] * u, bounds=(lower[1:], upper[1:]), tol=1e-12)
        return float(np.sum((a[:, 1:] @ rest.x - (b - a[:, 0] * u)) ** 2)) - chi_best - level

    ends = [brentq(rise, exact.x[0] - 1.0, exact.x[0]), brentq(rise, exact.x[0], exact.x[0] + 1.0)]
    ci = lmfit.conf_interval(mini, best, p_names=["u"], sigmas=[0.95])
    width = ends[1] - ends[0]
    assert ci["u"][0][1] == pytest.approx(ends[0], abs=1e-3 * width)
    assert ci["u"][2][1] == pytest.approx(ends[1], abs=1e-3 * width)


def test_the_lmfit_notebook_runs(tmp_path, monkeypatch):
    for module in ("jupytext", "nbclient", "ipykernel", "matplotlib"):
        pytest.importorskip(module)
    import jupytext
    from nbclient import NotebookClient

    monkeypatch.setenv("ESCFIT_LMFIT_FIGURES", str(tmp_path))
    monkeypatch.setenv("ESCFIT_LMFIT_STEPS", "600")
    monkeypatch.setenv("PYTHONPATH", str(ROOT))
    nb = jupytext.read(ROOT / "notebooks" / "04_lmfit.py")
    NotebookClient(nb, timeout=900, kernel_name="python3",
                   resources={"metadata": {"path": str(ROOT / "notebooks")}}).execute()
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
              if o.get("output_type") == "error"]
    assert not errors
    assert (tmp_path / "lmfit_profile.png").stat().st_size > 10_000


def test_a_held_bound_does_not_leak_into_the_next_fit():
    """After a leastsq that held w on its bound, the Minimizer's own Parameters still vary w (as
    plain lmfit leaves them), so the next fit from them moves w: checked against the exact
    unbounded optimum of a linear problem whose second fit widens w's range."""
    from escfit.inference.lmfit_bounds import bound_aware_minimizer

    rng = np.random.default_rng(5)
    a = rng.normal(size=(40, 2))
    b = a @ np.array([1.0, -0.5]) + 0.05 * rng.normal(size=40)
    params = lmfit.Parameters()
    params.add("u", value=0.0, min=-10, max=10)
    params.add("w", value=0.0, min=0.0, max=1.0)  # the optimum wants w < 0: held on 0
    mini = bound_aware_minimizer(lmfit)(lambda p: a @ np.array([p["u"].value, p["w"].value]) - b, params)
    first = mini.minimize(method="leastsq")
    assert first.params["w"].value == 0.0 and first.params["w"].vary
    assert mini.params["w"].vary
    mini.params["w"].set(min=-10.0)
    second = mini.minimize(method="least_squares")
    exact = np.linalg.lstsq(a, b, rcond=None)[0]
    assert np.allclose([second.params["u"].value, second.params["w"].value], exact, atol=1e-6)
