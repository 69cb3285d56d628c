"""A second least-squares optimum near the best one: found by refits from the intervals' ends.

References: (1) a two-parameter residual with two exact optima of known place and cost; (2) the
Pohl wheel's real readings, where the second optimum is checked independently by scipy's
least squares started there (it stays) and by the cost there against the best fit's.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import least_squares as scipy_least_squares

from escfit.inference import make_problem
from escfit.inference.lsq import least_squares
from escfit.inference.neighbours import LEVEL_95, nearby_optima, nearby_warning
from escfit.inference.trf import minimize

ROOT = Path(__file__).resolve().parents[1]


def _two_wells(k: float, d: float, lift: float):
    """r = (k x (x - d), sqrt(lift) * step(x), y - 0.3): exact optima at x = 0 (cost 0) and
    x = d (cost ``lift``); the step, a smoothstep from 0 below d/3 to 1 above 2d/3, is flat at both."""
    def fun(v):
        u = min(max(3.0 * v[0] / d - 1.0, 0.0), 1.0)
        return np.array([k * v[0] * (v[0] - d), np.sqrt(lift) * u * u * (3.0 - 2.0 * u), v[1] - 0.3])
    return fun


@pytest.mark.parametrize("lift, warned", [(0.5, True), (3.0, True), (4.5, False)])
def test_a_second_well_within_the_95_level_is_reported(lift, warned):
    k, d = 10.0, 0.6  # the curvature at 0 gives se(x) = 1 / (k d) = 0.167: the second well is 3.6 se away
    # (the 95 % level of a known noise scale is 3.84)
    fun = _two_wells(k, d, lift)
    lo, hi = np.array([-5.0, -5.0]), np.array([5.0, 5.0])
    best = minimize(fun, np.array([-0.05, 0.0]), lo, hi)
    assert abs(best.x[0]) < 1e-6
    cov = np.linalg.inv(best.jac.T @ best.jac)
    found = nearby_optima(lambda x: minimize(fun, x, lo, hi), lambda x: float(fun(x) @ fun(x)), best, cov, lo, hi)
    assert len(found) == 1
    other = scipy_least_squares(fun, [d, 0.3], xtol=1e-14, ftol=1e-14, gtol=1e-14)  # the second well, independently
    assert found[0].x == pytest.approx([d, 0.3], abs=1e-6) and other.x == pytest.approx([d, 0.3], abs=1e-6)
    assert found[0].rise == pytest.approx(lift, rel=1e-6)
    text = nearby_warning(found[0], ["x", "y"], LEVEL_95)
    assert (text is not None) == warned
    if warned:
        assert "x = " in text and "y = " not in text  # y did not move


def test_one_well_has_no_neighbour():
    fun = lambda v: np.array([3.0 * (v[0] - 1.0), v[0] * v[1] - 2.0, 0.1 * v[1]])  # noqa: E731
    lo, hi = np.array([-10.0, -10.0]), np.array([10.0, 10.0])
    best = minimize(fun, np.array([0.5, 1.0]), lo, hi)
    cov = np.linalg.inv(best.jac.T @ best.jac)
    assert nearby_optima(lambda x: minimize(fun, x, lo, hi), lambda x: float(fun(x) @ fun(x)), best, cov, lo, hi) == []


def test_the_pohl_wheels_second_optimum():
    recipe = ROOT / "fits" / "real" / "pohl_amplitudes.toml"
    doc = tomllib.loads(recipe.read_text())
    problem = make_problem(str((recipe.parent / doc["scene"]).resolve()), str((recipe.parent / doc["data"]).resolve()))
    res = least_squares(problem, n_starts=8, seed=1, nearby=True)
    assert not [w for w in least_squares(problem, n_starts=8, seed=1).warnings if "second optimum" in w]
    said = [w for w in res.warnings if "second optimum" in w]
    assert len(said) == 1, res.warnings
    # the place the warning names, refitted by scipy from there with escfit's residual: it stays
    i_c, i_r = res.names.index("viscous.C"), res.names.index("coulomb.R")
    c2 = float(said[0].split("viscous.C = ")[1].split(",")[0])
    r2 = float(said[0].split("coulomb.R = ")[1].split(" ")[0])
    assert 0.125 < c2 < 0.15 and 0.55 < r2 < 0.62  # the upper branch of the notebook's profile
    fixed = {n: v for n, v in res.values.items() if n in problem.names and n not in res.names}

    def fun(x):
        vals = problem.values({**fixed, **dict(zip(res.names, x))})
        return np.asarray(problem.residuals(vals), float)[:problem.n_data] / (res.sigma_hat / fixed_sigma)

    fixed_sigma = problem.values({})["observation.sigma"]
    x0 = res.value.copy()
    x0[i_c], x0[i_r] = c2, r2
    lo, hi = res.lower, res.upper
    there = scipy_least_squares(fun, np.clip(x0, lo, hi), bounds=(lo, hi), xtol=1e-12, ftol=1e-12)
    here = scipy_least_squares(fun, res.value, bounds=(lo, hi), xtol=1e-12, ftol=1e-12)
    assert there.x[i_c] == pytest.approx(c2, rel=2e-3) and there.x[i_r] == pytest.approx(r2, rel=2e-3)
    rise = 2 * (there.cost - here.cost)  # in units of the profiled noise: the 95 % level is about 3.84 * F/chi2
    assert 0 < rise < LEVEL_95


def test_a_better_optimum_nearby_is_adopted():
    """Started in the upper well (x = d, cost 0.5), the look finds the lower one (x = 0, cost 0)
    and returns it with a warning."""
    from escfit.inference.neighbours import look_nearby

    k, d = 10.0, 0.6
    fun = _two_wells(k, d, 0.5)
    lo, hi = np.array([-5.0, -5.0]), np.array([5.0, 5.0])
    upper = minimize(fun, np.array([0.62, 0.0]), lo, hi)
    assert upper.x[0] == pytest.approx(d, abs=1e-6)
    cov = np.linalg.inv(upper.jac.T @ upper.jac)
    best, said, other = look_nearby(lambda x: minimize(fun, x, lo, hi), lambda x: float(fun(x) @ fun(x)), upper,
                                    cov, (lo, hi), 1.0, ["x", "y"])
    assert other == {}  # adopted: no other optimum to name
    assert best.x == pytest.approx([0.0, 0.3], abs=1e-6) and best.chisqr < 1e-12
    assert len(said) == 1 and "lower one (0.5 less" in said[0]


def test_the_plain_summary_names_the_second_optimum(tmp_path):
    """The results keep the second optimum (``other_optimum``), and the plain sentences name its
    physical parameters in display units, as the least-squares warning does."""
    import json

    from click.testing import CliRunner

    from escfit.cli.main import cli
    from escfit.results import load_fit

    out = tmp_path / "pohl.h5"
    r = CliRunner().invoke(cli, ["fit", str(ROOT / "fits" / "real" / "pohl_amplitudes.toml"), "--method", "leastsq",
                                 "--out", str(out), "--quiet"])
    assert r.exit_code == 0, r.output
    other = json.loads(load_fit(out).attrs["other_optimum"])
    assert set(other) >= {"viscous.C", "coulomb.R"}
    text = " ".join(CliRunner().invoke(cli, ["summary", str(out)]).output.split())
    import re

    said = re.search(r"Another fit of this record is nearly as good, with viscous damping C = ([\d.]+) 1/s and "
                     r"Coulomb friction R = ([\d.]+) rad/s\^2: the ranges above belong to the best fit alone", text)
    assert said, text
    assert float(said.group(1)) == pytest.approx(other["viscous.C"], rel=5e-3)  # three significant digits
    assert float(said.group(2)) == pytest.approx(other["coulomb.R"], rel=5e-3)
