"""The whole-vector prior (:class:`escfit.likelihood.prior_block.PriorBlock`) against the priors
one at a time: the same numbers to the last bit, inside, outside and at the bounds."""

import math

import numpy as np
import pytest

from escfit.likelihood.prior_block import PriorBlock
from escfit.likelihood.priors import Prior


def _priors():
    return [Prior("uniform", (-1.0, 3.0), -1.0, 3.0),
            Prior("loguniform", (1e-4, 10.0), 1e-4, 10.0),
            Prior("normal", (0.3, 0.2), -1.0, 2.0),
            Prior("halfnormal", (0.5,), 0.0, 4.0),
            Prior("lognormal", (-1.0, 0.7), 0.0, math.inf),
            Prior("flat", (), -math.inf, math.inf),
            Prior("normal", (5.0, 1.5), 4.0, math.inf),  # upper tail: log mass from the survival function
            Prior("uniform", (0.0, 1.0), 0.0, 1.0)]


def _loop(priors, x):
    """The sum one prior at a time, left to right, as the free parameters summed them before."""
    total = np.zeros(x.shape[0])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for i, p in enumerate(priors):
            total = total + p.logpdf_array(x[:, i])
    return total


@pytest.mark.parametrize("grouped", [False, True])
def test_same_bits_as_one_prior_at_a_time(grouped):
    """Forms scattered over the vector, and each form's columns side by side (read as slices)."""
    priors = sorted(_priors(), key=lambda p: p.kind) if grouped else _priors()
    rng = np.random.default_rng(3)
    x = np.column_stack([rng.uniform(p.lo - 0.5 if math.isfinite(p.lo) else -3, p.hi + 0.5 if math.isfinite(p.hi)
                                     else 9, 4000) for p in priors])
    x[::97, 2] = np.nan
    x[5, 0], x[6, 0], x[7, 1] = -1.0, 3.0, 1e-4  # exactly on bounds: inside
    got = PriorBlock(priors).log_density(x)
    want = _loop(priors, x)
    assert np.isneginf(want).any() and np.isfinite(want).any()
    np.testing.assert_array_equal(got, want)
    assert np.isfinite(got[5]) or np.isneginf(want[5])


@pytest.mark.parametrize("k", range(8))
def test_each_form_matches_its_closed_form(k):
    """Each column alone against the closed-form density (scipy.stats, renormalised on the bounds)."""
    from scipy import stats

    p = _priors()[k]
    if p.kind == "flat":
        assert PriorBlock([p]).log_density(np.array([[1e9]]))[0] == 0.0
        return
    dist = {"uniform": lambda a, b: stats.uniform(a, b - a), "loguniform": stats.loguniform,
            "normal": stats.norm, "halfnormal": lambda s: stats.halfnorm(scale=s),
            "lognormal": lambda m, s: stats.lognorm(s, scale=math.exp(m))}[p.kind](*p.args)
    hi = p.hi if math.isfinite(p.hi) else p.lo + 10.0
    x = np.linspace(p.lo, hi, 41)[1:-1, None]
    mass = dist.cdf(p.hi) - dist.cdf(p.lo)
    np.testing.assert_allclose(PriorBlock([p]).log_density(x), dist.logpdf(x[:, 0]) - math.log(mass), rtol=1e-12,
                               atol=1e-12)
    assert PriorBlock([p]).log_density(np.array([[p.lo - 1.0]]))[0] == -math.inf


def test_no_free_parameters():
    assert PriorBlock([]).log_density(np.zeros((3, 0))).tolist() == [0.0, 0.0, 0.0]
