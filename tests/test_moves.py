"""The de-t move mixture samples the right posterior, and mixes faster than differential evolution.

References are closed forms: the moments of a Gaussian posterior with a 30-fold ridge and the
quantiles of a skewed (gamma) marginal.  An independence proposal with a wrong Hastings ratio
pulls the draws towards the proposal (a normal fitted to the walkers), which the gamma
quantiles would show.  Seeds are fixed; the tolerances are five or more Monte Carlo standard
errors of the runs' effective sample sizes.
"""

from __future__ import annotations

from collections import Counter

import emcee
import numpy as np
import pytest
from scipy import stats

from escfit.inference.ensemble import ArraySampler
from escfit.inference.mcmc import run_emcee
from escfit.inference.moves import EnsembleTMove, complement_splits, de_t_moves


class Target:
    """Independent gamma(2) coordinates (``skewed``) and a correlated Gaussian block."""

    def __init__(self, ndim: int, skewed: int, ridge: float = 30.0):
        rng = np.random.default_rng(0)
        g = ndim - skewed
        q, _ = np.linalg.qr(rng.standard_normal((g, g)))
        sds = np.geomspace(1.0, 1.0 / ridge, g)
        self.cov = (q * sds**2) @ q.T
        self.prec = np.linalg.inv(self.cov)
        self.mean = np.arange(1.0, g + 1.0)
        self.skewed, self.ndim = skewed, ndim
        self.names = [f"x{i}" for i in range(ndim)]
        self.initial = np.concatenate([np.full(skewed, 2.0), self.mean])
        self.bounds = (np.concatenate([np.zeros(skewed), np.full(g, -100.0)]), np.full(ndim, 100.0))
        self.vectorized = True
        self.failures: Counter = Counter()

    def log_prob_many(self, x: np.ndarray) -> np.ndarray:
        x = np.atleast_2d(x)
        s, d = x[:, :self.skewed], x[:, self.skewed:] - self.mean
        with np.errstate(divide="ignore", invalid="ignore"):
            lg = np.sum(np.where(s > 0, np.log(s) - s, -np.inf), axis=1)
        return lg - 0.5 * np.einsum("ij,jk,ik->i", d, self.prec, d)

    def log_prob(self, x: np.ndarray) -> float:
        return float(self.log_prob_many(np.asarray(x)[None, :])[0])


def test_complement_splits_keep_three_walkers_per_dimension():
    assert complement_splits(32, 5) == 2  # the quick start: 16 walkers against 16
    assert complement_splits(32, 8) == 4  # 8 against 24
    for walkers, ndim in [(32, 7), (40, 9), (64, 12), (16, 8), (10, 4)]:
        n = complement_splits(walkers, ndim)
        assert walkers // n >= 2
        assert walkers - -(-walkers // n) >= 3 * ndim or walkers // (n + 1) < 2


def test_de_t_reproduces_a_ridge_and_a_skewed_marginal():
    target = Target(ndim=5, skewed=1)
    mc = run_emcee(target, None, walkers=32, steps=3000, seed=11, moves="de-t")
    flat = mc.chain.reshape(-1, 5)
    ess = flat.shape[0] / np.max(mc.tau)
    assert ess > 3000
    g = flat[:, 1:]
    sd = np.sqrt(np.diag(target.cov))
    np.testing.assert_array_less(np.abs(g.mean(axis=0) - target.mean) / sd, 6 / np.sqrt(ess))
    np.testing.assert_allclose(np.std(g, axis=0), sd, rtol=0.05)
    np.testing.assert_allclose(np.corrcoef(g.T), target.cov / np.outer(sd, sd), atol=0.05)
    q = np.quantile(flat[:, 0], [0.05, 0.5, 0.95])
    np.testing.assert_allclose(q, stats.gamma(2.0).ppf([0.05, 0.5, 0.95]), rtol=0.05)


def test_the_independence_move_alone_keeps_the_skewed_posterior():
    """No differential evolution to hide it: the Hastings factor alone must undo the proposal."""
    target = Target(ndim=3, skewed=2)
    rng = np.random.default_rng(3)
    start = target.initial + 0.1 * rng.random((24, 3))
    sampler = emcee.EnsembleSampler(24, 3, target.log_prob_many, vectorize=True, moves=EnsembleTMove())
    sampler.random_state = np.random.RandomState(5).get_state()
    sampler.run_mcmc(start, 3000)
    flat = sampler.get_chain(discard=500, flat=True)
    ref = stats.gamma(2.0).ppf([0.05, 0.25, 0.5, 0.75, 0.95])
    for i in range(2):
        np.testing.assert_allclose(np.quantile(flat[:, i], [0.05, 0.25, 0.5, 0.75, 0.95]), ref, rtol=0.05)
    assert 0.3 < np.mean(sampler.acceptance_fraction) < 0.95


def test_de_t_mixes_faster_than_de_on_a_ridge():
    target = Target(ndim=5, skewed=0)
    de = run_emcee(target, None, walkers=32, steps=1500, seed=2, moves="de")
    det = run_emcee(target, None, walkers=32, steps=1500, seed=2, moves="de-t")
    assert np.max(det.tau) < 0.5 * np.max(de.tau)


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="df and scale"):
        EnsembleTMove(df=0.0)
    with pytest.raises(ValueError, match="t_weight"):
        de_t_moves(1.0)


def test_an_interrupted_de_t_run_resumes_to_identical_draws(tmp_path):
    """The move draws from the sampler's own generator only, so the checkpoint's state replays it."""
    from escfit.inference.checkpoint import load_checkpoint

    class Dying(Target):
        calls = 0

        def log_prob_many(self, x):
            if np.ndim(x) == 2 and len(x) > 1:
                self.calls += 1
                if self.calls > 1 + 2 * 150:
                    raise KeyboardInterrupt
            return super().log_prob_many(x)

    whole = run_emcee(Target(ndim=5, skewed=1), None, walkers=32, steps=300, seed=8, moves="de-t")
    ck = tmp_path / "run.emcee"
    with pytest.raises(KeyboardInterrupt):
        run_emcee(Dying(ndim=5, skewed=1), None, walkers=32, steps=300, seed=8, moves="de-t", checkpoint=ck,
                  checkpoint_every=1e9)
    assert 0 < load_checkpoint(ck, 32, [f"x{i}" for i in range(5)]).steps < 300
    again = run_emcee(Target(ndim=5, skewed=1), None, walkers=32, steps=300, seed=8, moves="de-t", checkpoint=ck,
                      resume=True)
    np.testing.assert_array_equal(again.chain, whole.chain)
    np.testing.assert_array_equal(again.log_prob, whole.log_prob)


class _EmceeLoopT(EnsembleTMove):
    """The independence move with emcee's own red-blue loop, the reference for the array update."""

    propose = emcee.moves.RedBlueMove.propose


@pytest.mark.parametrize("ndim, skewed, walkers", [(9, 2, 32), (2, 1, 8), (5, 0, 24)])
def test_the_array_update_draws_what_emcees_loop_draws(ndim, skewed, walkers):
    """Same seed, same moves, emcee's per-walker loop and conversion of the log densities against
    the array update and :class:`ArraySampler`: the same chain, bit for bit (the skewed
    coordinates' bound makes some proposals -inf)."""
    target = Target(ndim, skewed)
    start = target.initial + 0.01 * np.random.default_rng(1).standard_normal((walkers, ndim))
    start[:, :skewed] = np.abs(start[:, :skewed])
    chains = []
    for moves, kind in ((de_t_moves(), ArraySampler), ([(_EmceeLoopT(), 0.8), (emcee.moves.DEMove(), 0.2)],
                                                          emcee.EnsembleSampler)):
        sampler = kind(walkers, ndim, target.log_prob_many, vectorize=True, moves=moves)
        sampler.random_state = np.random.RandomState(7).get_state()
        sampler.run_mcmc(start, 300, progress=False)
        chains.append((sampler.get_chain(), sampler.get_log_prob(), sampler.acceptance_fraction))
    assert 0.05 < chains[0][2].mean() < 0.95  # both kinds of outcome were exercised
    for got, want in zip(*chains):
        np.testing.assert_array_equal(got, want)


def test_array_sampler_refuses_what_emcee_refuses():
    sampler = ArraySampler(4, 1, lambda x: np.where(x[:, 0] > 0, 0.0, np.nan), vectorize=True)
    with pytest.raises(ValueError, match="NaN"):
        sampler.compute_log_prob(np.array([[1.0], [-1.0], [2.0], [3.0]]))
    with pytest.raises(ValueError, match="infinite"):
        sampler.compute_log_prob(np.array([[1.0], [np.inf], [2.0], [3.0]]))
    short = ArraySampler(4, 1, lambda x: np.zeros(2), vectorize=True)
    with pytest.raises(ValueError, match="shape"):
        short.compute_log_prob(np.ones((4, 1)))
    lp, blobs = ArraySampler(2, 1, lambda x: [0.5, -np.inf], vectorize=True).compute_log_prob(np.ones((2, 1)))
    assert lp.tolist() == [0.5, -np.inf] and blobs is None
