"""Sampling in declared coordinates: the bijection, its Jacobian, and the distribution it samples.

References: the identity u -> x -> u; a finite-difference Jacobian; a target with closed-form
marginals (a lognormal scale, a uniform correlation, a normal location) sampled in the AR(1)
coordinates; the run without declared coordinates driven by emcee directly (the draws before
sampler coordinates existed); an uninterrupted run with the same seed (resumption).
"""

from __future__ import annotations

import math
from collections import Counter

import emcee
import h5py
import numpy as np
import pytest

from escfit.core.errors import ResultsError
from escfit.inference.checkpoint import load_checkpoint
from escfit.inference.convergence import assess
from escfit.inference.mcmc import _start, run_emcee
from escfit.inference.space import Transformed, sampler_space
from escfit.likelihood.coordinates import AR1Coordinates, SamplerCoordinates

AR1 = AR1Coordinates(sigma=0, rho=1)


def _u(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-12.0, 3.0, n), rng.uniform(-3.5, 3.5, n), rng.normal(size=n)])


def test_the_bijection_round_trips():
    u = _u(500)
    x = AR1.to_problem(u)
    assert np.all(x[:, 0] > 0) and np.all(np.abs(x[:, 1]) < 1) and np.array_equal(x[:, 2], u[:, 2])
    np.testing.assert_allclose(AR1.to_sampler(x), u, rtol=0, atol=1e-12 * (1 + np.abs(u)).max())
    # the defining relations: u1 the log innovation scale, u2 = atanh(rho)
    np.testing.assert_allclose(u[:, 0], np.log(x[:, 0] * np.sqrt(1 - x[:, 1] ** 2)), atol=1e-12)
    np.testing.assert_allclose(x[:, 1], np.tanh(u[:, 1]), atol=1e-15)
    assert isinstance(AR1, SamplerCoordinates)


def test_the_log_jacobian_is_that_of_finite_differences():
    u = _u(40, seed=1)
    h = 1e-6
    for row in u:
        jac = np.empty((3, 3))
        for k in range(3):
            step = np.zeros(3)
            step[k] = h
            jac[:, k] = (AR1.to_problem(row + step) - AR1.to_problem(row - step)) / (2 * h)
        assert AR1.log_jacobian(row) == pytest.approx(math.log(abs(np.linalg.det(jac))), abs=1e-7)
        x = AR1.to_problem(row)
        assert AR1.log_jacobian(row) == pytest.approx(math.log(x[0]) + math.log1p(-x[1] ** 2), abs=1e-12)


def test_points_outside_the_domain_are_minus_infinity_not_nan():
    target = ScaleCorrelation()
    space = Transformed(target, AR1)
    u = np.array([[800.0, 0.2, 0.0],  # the scale overflows
                  [-3.0, 40.0, 0.0],  # tanh rounds to 1 and cosh overflows
                  [np.nan, 0.1, 0.0], [-3.0, -np.inf, 0.0],
                  [math.log(0.02), 0.3, 1.0]])  # inside
    with np.errstate(all="raise"):
        lp = space.log_prob_many(u)
    assert np.array_equal(np.isneginf(lp), [True, True, True, True, False])
    assert np.isnan(AR1.to_sampler(np.array([[0.0, 0.5, 1.0], [0.1, 1.0, 1.0], [0.1, -1.5, 1.0]]))[:, :2]).all()
    assert not AR1.in_domain(np.array([[0.0, 0.5, 1.0], [0.1, 1.0, 1.0]])).any()


# -- sampling a closed-form target through the coordinates -------------------------------------------

MU, S = math.log(0.02), 0.4  # log sigma ~ normal(MU, S)
RHO_MAX = 0.99  # rho ~ uniform(0, RHO_MAX)
M, SD_M = 1.0, 0.5  # m ~ normal(M, SD_M)


class ScaleCorrelation:
    """sigma lognormal, rho uniform on [0, 0.99], m normal, independent; declares the AR(1) coordinates."""

    names = ["observation.sigma", "observation.rho", "m"]
    initial = np.array([0.02, 0.5, 1.0])
    bounds = (np.array([1e-6, 0.0, -20.0]), np.array([10.0, RHO_MAX, 20.0]))
    vectorized = True

    def __init__(self, coordinates=AR1, die_after: int | None = None):
        self.sampler_coordinates = coordinates
        self.failures: Counter = Counter()
        self.calls, self.die_after = 0, die_after

    def log_prob_many(self, x: np.ndarray) -> np.ndarray:
        x = np.atleast_2d(x)
        if len(x) > 1:  # ensemble calls (placing the walkers goes one by one)
            self.calls += 1
            if self.die_after is not None and self.calls > self.die_after:
                raise KeyboardInterrupt
        lo, hi = self.bounds
        inside = np.all((x >= lo) & (x <= hi), axis=1)
        s = np.where(inside, x[:, 0], 1.0)
        lp = -np.log(s) - 0.5 * ((np.log(s) - MU) / S) ** 2 - 0.5 * ((x[:, 2] - M) / SD_M) ** 2
        return np.where(inside, lp, -math.inf)

    def log_prob(self, x: np.ndarray) -> float:
        return float(self.log_prob_many(np.asarray(x)[None, :])[0])


def closed_form_z(chain: np.ndarray) -> dict[str, float]:
    """Errors of the draws' summaries against the closed forms, in Monte Carlo standard errors
    (each from the bulk effective sample size of the quantity it averages)."""
    log_s, rho, m = np.log(chain[..., 0]), chain[..., 1], chain[..., 2]

    def z(values: np.ndarray, truth: float, sd: float) -> float:
        ess = float(assess(values.T[:, :, None], burn=0).ess_bulk[0])
        return float((values.mean() - truth) / (sd / math.sqrt(ess)))

    p = 0.5 / RHO_MAX  # P(rho < 0.5)
    return {"mean log sigma": z(log_s, MU, S),
            "var log sigma": z((log_s - MU) ** 2, S**2, S**2 * math.sqrt(2.0)),
            "mean rho": z(rho, RHO_MAX / 2, RHO_MAX / math.sqrt(12.0)),
            "var rho": z((rho - RHO_MAX / 2) ** 2, RHO_MAX**2 / 12.0, RHO_MAX**2 / math.sqrt(180.0)),
            "P(rho < 0.5)": z((rho < 0.5).astype(float), p, math.sqrt(p * (1 - p))),
            "mean m": z(m, M, SD_M), "var m": z((m - M) ** 2, SD_M**2, SD_M**2 * math.sqrt(2.0))}


def test_sampling_in_the_coordinates_gives_the_closed_form_distribution():
    """Seven summaries within 5 Monte Carlo standard errors of the closed forms.

    The z-scores measured over seeds 0-299 (2100 of them; every run converged, in 1525 steps at
    the median): means -0.05 to +0.03, sds 0.98 to 1.14 per summary, largest |z| 3.99.  At sd
    1.14 the limit 5 is 4.4 sd, a two-sided normal tail of 1.1e-5 per summary, 8e-5 for the
    seven.  A missing Jacobian moves them by tens of standard errors (the next test).
    """
    res = run_emcee(ScaleCorrelation(), walkers=16, steps="auto", seed=5, moves="de-t", max_steps=20000)
    assert res.converged
    assert np.all(res.chain[..., 0] > 0) and np.all((res.chain[..., 1] >= 0) & (res.chain[..., 1] <= RHO_MAX))
    z = closed_form_z(res.chain)
    assert all(abs(v) < 5.0 for v in z.values()), z
    # what users see is the x-space log posterior, not the sampler's log density
    np.testing.assert_allclose(res.log_prob, ScaleCorrelation().log_prob_many(res.chain.reshape(-1, 3))
                               .reshape(res.log_prob.shape), rtol=1e-12, atol=1e-12)


def test_the_sampler_density_omitting_the_jacobian_is_caught():
    """The check above has power: the same run without the Jacobian fails it."""

    class NoJacobian(AR1Coordinates):
        def log_jacobian(self, u):
            return np.zeros(np.shape(u)[:-1])

    res = run_emcee(ScaleCorrelation(NoJacobian(0, 1)), walkers=16, steps=3000, seed=5, moves="de-t")
    z = closed_form_z(res.chain)
    assert max(abs(v) for v in z.values()) > 10, z


# -- no declared coordinates: the draws of before ------------------------------------------------------

class Identity:
    name = "identity-test"

    def in_domain(self, x):
        return np.ones(np.shape(x)[:-1], bool)

    def to_sampler(self, x):
        return np.array(x, float)

    def to_problem(self, u):
        return np.array(u, float)

    def log_jacobian(self, u):
        return np.zeros(np.shape(u)[:-1])


def test_without_declared_coordinates_the_draws_are_emcees_own():
    """The run of a problem without coordinates is emcee driven directly, bit for bit; declared
    identity coordinates (the transformed path with nothing to transform) draw the same."""
    problem = ScaleCorrelation(coordinates=None)
    assert not sampler_space(problem).transformed
    mine = run_emcee(problem, walkers=12, steps=200, seed=7, moves="de")
    sampler = emcee.EnsembleSampler(12, 3, problem.log_prob_many, vectorize=True, moves=emcee.moves.DEMove())
    sampler.random_state = np.random.RandomState(7).get_state()
    sampler.run_mcmc(_start(problem, None, 12, np.random.default_rng(7)), 200)
    burn = mine.burn
    np.testing.assert_array_equal(mine.chain, sampler.get_chain()[burn:].transpose(1, 0, 2))
    np.testing.assert_array_equal(mine.log_prob, sampler.get_log_prob()[burn:].T)
    same = run_emcee(ScaleCorrelation(coordinates=Identity()), walkers=12, steps=200, seed=7, moves="de")
    np.testing.assert_array_equal(same.chain, mine.chain)
    np.testing.assert_array_equal(same.log_prob, mine.log_prob)


# -- checkpoints -------------------------------------------------------------------------------------

def test_an_interrupted_run_in_the_coordinates_resumes_to_the_same_draws(tmp_path):
    whole = run_emcee(ScaleCorrelation(), walkers=12, steps=300, seed=2, moves="de-t")
    ck = tmp_path / "run.emcee"
    with pytest.raises(KeyboardInterrupt):  # the start ensemble, then one call per sub-ensemble and step
        run_emcee(ScaleCorrelation(die_after=1 + 2 * 90 + 1), walkers=12, steps=300, seed=2, moves="de-t",
                  checkpoint=ck, checkpoint_every=1e9)
    saved = load_checkpoint(ck, 12, ScaleCorrelation.names)
    assert saved.coordinates == AR1.name and saved.steps > 0
    # the checkpoint holds the sampler's own draws: mapped to x they are the run's first steps
    first = run_emcee(ScaleCorrelation(), walkers=12, steps=saved.steps, burn=0, seed=2, moves="de-t")
    np.testing.assert_array_equal(AR1.to_problem(saved.chain), first.chain.transpose(1, 0, 2))
    again = run_emcee(ScaleCorrelation(), walkers=12, steps=300, seed=2, moves="de-t", checkpoint=ck, resume=True)
    assert again.resumed and again.steps == 300
    np.testing.assert_array_equal(again.chain, whole.chain)
    np.testing.assert_array_equal(again.log_prob, whole.log_prob)
    # a run in other coordinates refuses the checkpoint instead of reading u as x
    with pytest.raises(ResultsError, match="sampler coordinates 'ar1"):
        run_emcee(ScaleCorrelation(coordinates=None), walkers=12, steps=400, seed=2, moves="de-t", checkpoint=ck,
                  resume=True)


def test_a_checkpoint_written_before_coordinates_existed_is_read_in_the_parameters(tmp_path):
    ck = tmp_path / "old.emcee"
    run_emcee(ScaleCorrelation(coordinates=None), walkers=12, steps=60, seed=1, moves="de", checkpoint=ck)
    with h5py.File(ck, "r+") as f:  # version 2: no coordinates attribute
        f.attrs["version"] = 2
        del f.attrs["coordinates"]
    assert load_checkpoint(ck, 12, ScaleCorrelation.names).coordinates == "identity"
    done = run_emcee(ScaleCorrelation(coordinates=None), walkers=12, steps=100, seed=1, moves="de", checkpoint=ck,
                     resume=True)
    assert done.resumed and done.steps == 100
    with pytest.raises(ResultsError, match="sampler coordinates 'identity'.*samples in 'ar1"):
        run_emcee(ScaleCorrelation(), walkers=12, steps=100, seed=1, moves="de", checkpoint=ck, resume=True)


# -- the waveform problem declares them ------------------------------------------------------------------

def test_the_waveform_problem_samples_ar1_noise_in_the_coordinates():
    from .test_waveform_batch import _problem, _sets

    problem = _problem(observation='noise = "ar1"', record={"noise": "ar1"})
    names = problem.names
    coords = problem.sampler_coordinates
    assert coords == AR1Coordinates(names.index("observation.sigma"), names.index("observation.rho"))
    vecs = _sets(problem, 6, seed=2)
    vecs[:, names.index("observation.rho")] = np.linspace(0.1, 0.95, 6)
    space = sampler_space(problem)
    u = space.to_sampler(vecs)
    expect = problem.log_prob_many(vecs) + coords.log_jacobian(u)
    np.testing.assert_allclose(space.log_prob_many(u), expect, rtol=1e-12)
    assert _problem().sampler_coordinates is None  # white noise
    fixed = _problem(observation='noise = "ar1"\nrho = 0.6', record={"noise": "ar1"})
    assert "observation.rho" not in fixed.names and fixed.sampler_coordinates is None
