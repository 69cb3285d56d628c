"""Friction of the verge S&A mechanism from turns-to-arm: the published numbers and recovery.

Everything runs through the one inference layer (:mod:`escfit.inference`) on
:class:`escfit.verge.problem.TurnsProblem`.  References: the report's friction coefficients
(Lowen & Tepper 1982), the exact one-parameter posterior computed on a grid, and the truth of
simulated readings.
"""

from __future__ import annotations

import numpy as np
import pytest

from escfit.core.scene import load_scene
from escfit.inference import family, fit_problem, least_squares
from escfit.verge.data import read_turns_csv
from escfit.verge.problem import FIT_STEP
from escfit.verge.simulate import forward
from escfit.verge.synthetic import synthetic_turns

from .conftest import DATASETS

SCENE = DATASETS / "verge" / "m739_fit.toml"
PUBLISHED = DATASETS / "verge" / "lowen_tepper_1982_turns.csv"


@pytest.fixture(scope="module")
def published():
    return read_turns_csv(PUBLISHED)


def _grid_posterior(problem, centre, sd, n=31, width=4.0):
    """The exact one-parameter posterior on a grid: mean, sd and the equal-tailed 95 % interval."""
    grid = np.linspace(centre - width * sd, centre + width * sd, n)
    logp = np.array([problem.log_prob(np.array([x])) for x in grid])
    w = np.exp(logp - logp.max())
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * np.diff(grid))])
    cdf /= cdf[-1]
    mass = w / w.sum()
    mean = float((mass * grid).sum())
    return mean, float(np.sqrt((mass * (grid - mean) ** 2).sum())), np.interp([0.025, 0.975], cdf, grid)


@pytest.mark.parametrize("index,mu_reported", [(0, 0.10), (1, 0.05), (2, 0.15)])
def test_published_turns_give_the_reported_friction(published, index, mu_reported):
    # each published figure is one reading of a mechanism whose friction is unknown: the
    # three rows are three mechanisms and are inverted one at a time
    problem = family("verge").problem(SCENE, published.subset([index]))
    lsq = least_squares(problem, n_starts=1)
    mu, se = lsq.value[0], lsq.stderr[0]
    assert problem.expected(lsq.values)[0] == pytest.approx(published.turns[index], abs=1e-3)  # fitted exactly
    assert abs(mu - mu_reported) < 2 * se
    # the exact posterior under the scene's uniform(0, 0.3) prior
    mean, sd, (lo, hi) = _grid_posterior(problem, mu, se)
    assert lo < mu_reported < hi and hi - lo < 0.05
    # Laplace approximation (least-squares covariance) against the exact posterior
    assert mean == pytest.approx(mu, abs=0.15 * sd)
    assert sd == pytest.approx(se, rel=0.1)
    assert problem.failures == {}


def test_fit_step_is_converged_and_the_shipped_step_is_close():
    scene = load_scene(DATASETS / "verge" / "m739.toml")
    fine = forward(scene, step=0.01).turns_to_arm
    assert forward(scene, step=FIT_STEP).turns_to_arm == pytest.approx(fine, abs=1e-6)
    assert forward(scene, step=0.2).turns_to_arm == pytest.approx(fine, abs=2e-4)  # m739_fit.toml [fit] step


def test_spin_rates_are_replicates_with_plastic_impacts():
    scene = load_scene(SCENE)
    data = synthetic_turns(scene, {"verge.mu": 0.1}, [12000, 30000], 0.2, seed=1)
    problem = family("verge").problem(scene, data)
    calls = []
    original = problem._simulate
    problem._simulate = lambda vals, rpm: calls.append(rpm) or original(vals, rpm)
    pred = problem.expected(problem.values(np.array([0.1])))
    assert len(calls) == 1 and pred[0] == pred[1]
    # and the simulation agrees: turns to arm do not depend on spin for e = 0
    slow = forward(scene, {"verge.spin": 12000 * np.pi / 30, "verge.mu": 0.1, "verge.mu1": 0.1}, step=0.2)
    assert slow.turns_to_arm == pytest.approx(pred[0], abs=1e-8)
    assert any("replicates" in n for n in problem.notes)


def test_posterior_recovers_a_known_friction_coefficient():
    """Synthetic readings at mu = 0.12: least squares and a converged posterior bracket the truth.

    The mechanism is the M739 with a shorter arming stroke (phi_cut 100 deg instead of 1485:
    six escape-wheel teeth, 2 turns, 10 turns per unit of mu) so that one forward run costs
    ~7 ms and a converged chain (6 walkers x 400 steps, 2400 runs) fits the test budget.  Four
    spin rates, sd 0.2 turns; walkers start from least squares (which starts from the scene's
    0.05, not the truth); differential-evolution moves, because emcee's stretch move mixes
    slowly in one dimension (tau ~ 27 steps against ~5).
    """
    truth = 0.12
    text = SCENE.read_text().replace('phi_cut = "1485 deg"', 'phi_cut = "100 deg"')
    assert 'phi_cut = "100 deg"' in text
    scene = load_scene("m739_short_stroke.toml", text=text)
    data = synthetic_turns(scene, {"verge.mu": truth}, [10000, 17000, 24000, 30000], 0.2, seed=7, step=0.2)
    problem = family("verge").problem(scene, data)
    res = fit_problem(problem, method="emcee", walkers=6, steps=400, burn=50, n_starts=4, seed=5, moves="de",
                      predictive_draws=16)
    lsq = res.group("least_squares")
    mu, se = float(lsq["value"][0]), float(lsq["stderr"][0])
    assert abs(mu - truth) < 1.96 * se
    diag = res.group("diagnostics").sel(parameter="verge.mu")
    assert float(diag["rhat"]) < 1.05 and float(diag["ess_bulk"]) > 100
    x = res.group("posterior")["verge.mu"].values.ravel()
    lo, hi = np.quantile(x, [0.025, 0.975])
    assert lo < truth < hi
    assert 0.5 < (hi - lo) / (2 * 1.96 * se) < 2.0  # the Laplace approximation's width
    assert not any("R-hat" in w for w in res.warnings)
