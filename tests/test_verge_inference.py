"""Friction of the verge S&A mechanism from turns-to-arm: least squares and posterior.

The MCMC runs here are deliberately short (a one-parameter posterior, six walkers); they
check that the machinery finds and brackets the right value, not the tails.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from escfit.core.errors import DataError, FitError
from escfit.core.scene import load_scene
from escfit.verge.inference import (
    TurnsData, TurnsProblem, credible_interval, fit_least_squares, read_turns_csv, sample_posterior,
    synthetic_turns,
)

ROOT = Path(__file__).resolve().parents[1]
M739 = ROOT / "datasets" / "verge" / "m739.toml"
PUBLISHED = ROOT / "datasets" / "verge" / "lowen_tepper_1982_turns.csv"


@pytest.fixture(scope="module")
def scene():
    return load_scene(M739)


@pytest.fixture(scope="module")
def published():
    return read_turns_csv(PUBLISHED)


@pytest.mark.parametrize("index,mu_reported", [(0, 0.10), (1, 0.05), (2, 0.15)])
def test_published_turns_give_the_reported_friction(scene, published, index, mu_reported):
    # each published figure is one observation of a mechanism whose friction is unknown
    problem = TurnsProblem(scene, published.subset([index]))
    lsq = fit_least_squares(problem)
    assert lsq.prediction[0] == pytest.approx(published.turns[index], abs=1e-3)  # one number, fitted exactly
    assert abs(lsq.best[0] - mu_reported) < 2 * lsq.stderr[0]
    idata = sample_posterior(problem, walkers=6, steps=24, burn=8, lsq=lsq, seed=11)
    lo, hi = credible_interval(idata, "verge.mu", 0.95)
    assert lo < mu_reported < hi
    assert hi - lo < 0.05
    assert int(idata.sample_stats["forward_status"].max()) == 0


def test_synthetic_recovery(scene):
    truth = 0.12
    data = synthetic_turns(scene, {"verge.mu": truth}, [12000, 20000, 30000], sd=0.3, seed=7)
    problem = TurnsProblem(scene, data)
    lsq = fit_least_squares(problem)
    assert abs(lsq.best[0] - truth) < 3 * lsq.stderr[0]
    idata = sample_posterior(problem, walkers=6, steps=24, burn=8, lsq=lsq, seed=3)
    lo, hi = credible_interval(idata, "verge.mu", 0.95)
    assert lo < truth < hi
    for group in ("posterior", "log_likelihood", "observed_data", "constant_data", "sample_stats"):
        assert group in idata.groups()
    assert idata.log_likelihood["turns"].shape[-1] == 3
    assert idata.attrs["priors"] == "verge.mu: uniform(0, 0.3)"
    # with plastic impacts the spin rate does not matter: one prediction for all three
    pred = idata.posterior["turns_model"].values
    assert np.allclose(pred[..., 0], pred[..., 2])


def _grid_posterior(problem, grid):
    logp = np.array([problem.log_prior([x]) + problem.log_likelihood(problem.predict([x])[0]).sum() for x in grid])
    w = np.exp(logp - logp.max())
    w /= w.sum()
    mean = float((w * grid).sum())
    return mean, float(np.sqrt((w * (grid - mean) ** 2).sum()))


def test_laplace_approximation_matches_exact_one_dimensional_posterior(scene, published):
    # a one-parameter posterior can be computed on a grid: check the least-squares
    # covariance (and with it the sampler's starting region) against it
    problem = TurnsProblem(scene, published.subset([0]))
    lsq = fit_least_squares(problem)
    grid = np.linspace(lsq.best[0] - 5 * lsq.stderr[0], lsq.best[0] + 5 * lsq.stderr[0], 41)
    mean, sd = _grid_posterior(problem, grid)
    assert mean == pytest.approx(lsq.best[0], abs=0.1 * sd)
    assert sd == pytest.approx(lsq.stderr[0], rel=0.1)


@pytest.mark.slow
def test_sampler_matches_exact_one_dimensional_posterior(scene, published):
    problem = TurnsProblem(scene, published.subset([2]))
    lsq = fit_least_squares(problem)
    grid = np.linspace(lsq.best[0] - 6 * lsq.stderr[0], lsq.best[0] + 6 * lsq.stderr[0], 61)
    mean, sd = _grid_posterior(problem, grid)
    idata = sample_posterior(problem, walkers=8, steps=300, burn=60, lsq=lsq, seed=21)
    draws = idata.posterior["verge.mu"].values.ravel()
    assert draws.mean() == pytest.approx(mean, abs=0.15 * sd)
    assert draws.std() == pytest.approx(sd, rel=0.2)


def test_sampler_is_reproducible(scene):
    data = TurnsData(np.array([30000.0]), np.array([25.9]), np.array([0.3]), ("a",))
    problem = TurnsProblem(scene, data)
    lsq = fit_least_squares(problem)
    a = sample_posterior(problem, walkers=4, steps=4, burn=0, lsq=lsq, seed=5)
    b = sample_posterior(problem, walkers=4, steps=4, burn=0, lsq=lsq, seed=5)
    assert np.array_equal(a.posterior["verge.mu"].values, b.posterior["verge.mu"].values)


def test_not_armed_has_zero_likelihood(scene):
    data = TurnsData(np.array([30000.0]), np.array([25.9]), np.array([0.3]), ("a",))
    problem = TurnsProblem(scene, data)
    pred, status = problem.predict([0.25])
    assert status == 1 and math.isnan(pred[0])
    assert problem.log_likelihood(pred)[0] == -math.inf
    assert problem.log_prior([0.35]) == -math.inf  # outside uniform(0, 0.3)


def test_bad_inputs_are_refused(scene, tmp_path):
    bad = tmp_path / "turns.csv"
    bad.write_text("label,spin_rpm,turns,sd\na,30000,many,0.3\n")
    with pytest.raises(DataError, match="many"):
        read_turns_csv(bad)
    bad.write_text("label,spin_rpm,turns\na,30000,25,0.3\n")
    with pytest.raises(DataError, match="sd"):
        read_turns_csv(bad)
    data = TurnsData(np.array([30000.0]), np.array([25.9]), np.array([0.3]), ("a",))
    with pytest.raises(DataError, match="sd"):
        TurnsData(np.array([30000.0]), np.array([25.9]), np.array([0.0]), ("a",))
    with pytest.raises(FitError, match="verge.nu"):
        TurnsProblem(scene, data, free=("verge.nu",))
    with pytest.raises(FitError, match="tied"):
        TurnsProblem(scene, data, free=("verge.mu", "verge.mu1"))
    with pytest.raises(FitError, match="prior"):
        TurnsProblem(scene, data, free=("verge.rho1",))
    with pytest.raises(FitError, match="walkers"):
        sample_posterior(TurnsProblem(scene, data), walkers=3, steps=4)


@pytest.mark.slow
def test_separate_coefficients_trade_off(scene):
    # turns-to-arm alone constrain a combination of mu and mu1: the posterior is a ridge
    data = synthetic_turns(scene, {"verge.mu": 0.1, "verge.mu1": 0.1}, [20000, 30000], sd=0.2, seed=2)
    problem = TurnsProblem(scene, data, free=("verge.mu", "verge.mu1"), tie_mu1=False)
    idata = sample_posterior(problem, walkers=8, steps=120, burn=40, seed=4)
    mu = idata.posterior["verge.mu"].values.ravel()
    mu1 = idata.posterior["verge.mu1"].values.ravel()
    assert np.corrcoef(mu, mu1)[0, 1] < -0.5
