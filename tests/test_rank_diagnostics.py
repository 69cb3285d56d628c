"""escfit's rank-normalised split R-hat and bulk/tail ESS against ArviZ (``arviz_stats``), the reference.

Chains of known autocorrelation (AR(1)), chains that repeat values as a rejecting sampler's
walkers do (ties in the ranks), odd lengths, a drifting chain, and the sampler's own layout.
"""

from __future__ import annotations

import numpy as np
import pytest

from escfit.inference.rank_diagnostics import ess_bulk, ess_tail, split_rhat

array_stats = pytest.importorskip("arviz_stats.base").array_stats


def _ar1(rng, chains, draws, phi):
    x = np.empty((chains, draws))
    x[:, 0] = rng.normal(size=chains)
    for t in range(1, draws):
        x[:, t] = phi * x[:, t - 1] + np.sqrt(1 - phi * phi) * rng.normal(size=chains)
    return x


def _sticky(rng, chains, draws, accept):
    """Chains that keep their value with probability 1 - accept (ties, as emcee's rejections give)."""
    x = _ar1(rng, chains, draws, 0.5)
    for t in range(1, draws):
        stay = rng.random(chains) > accept
        x[stay, t] = x[stay, t - 1]
    return x


CASES = {
    "independent": lambda rng: rng.normal(size=(32, 400)),
    "ar1 0.9": lambda rng: _ar1(rng, 32, 500, 0.9),
    "ar1 0.99, odd length": lambda rng: _ar1(rng, 8, 1001, 0.99),
    "sticky walkers": lambda rng: _sticky(rng, 32, 600, 0.3),
    "one chain drifts": lambda rng: _ar1(rng, 16, 300, 0.7) + np.r_[np.zeros(15), 2.0][:, None],
    "skewed, two chains": lambda rng: np.exp(_ar1(rng, 2, 250, 0.5)),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_figures_equal_arviz(case):
    x = CASES[case](np.random.default_rng(sorted(CASES).index(case)))
    assert split_rhat(x) == pytest.approx(float(array_stats.rhat(x, chain_axis=0, draw_axis=1)), rel=1e-9)
    assert ess_bulk(x) == pytest.approx(float(array_stats.ess(x, chain_axis=0, draw_axis=1, method="bulk")), rel=1e-9)
    want = float(array_stats.ess(x, chain_axis=0, draw_axis=1, method="tail", prob=(0.05, 0.95)))
    assert ess_tail(x) == pytest.approx(want, rel=1e-9)


def test_figures_say_what_the_chains_are():
    rng = np.random.default_rng(7)
    good = rng.normal(size=(32, 500))
    assert split_rhat(good) < 1.01 and ess_bulk(good) > 0.8 * good.size  # independent draws: ESS ~ draws
    slow = _ar1(rng, 32, 500, 0.9)  # tau = (1 + 0.9) / (1 - 0.9) = 19
    assert ess_bulk(slow) == pytest.approx(slow.size / 19, rel=0.25)
    apart = good + np.r_[np.zeros(31), 3.0][:, None]  # one walker elsewhere
    assert split_rhat(apart) > 1.05
