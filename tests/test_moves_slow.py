"""The quick start's posterior sampled with de-t against differential evolution alone (slow).

The second method is the run the quick start shipped before (``moves = "de"``, 9082 steps with
its seed); both runs stop by the same convergence criteria.  Medians must agree to a fifth of a
posterior standard deviation and the 90 % intervals' widths to 10 % (measured: 0.02 sd and
3.3 %, ``benchmarks/mcmc_speed.py``); the seeds are fixed.
"""

from __future__ import annotations

import numpy as np
import pytest

from escfit.inference.lsq import least_squares
from escfit.inference.mcmc import run_emcee
from escfit.inference.reconcile import reconcile
from escfit.inference.registry import make_problem

from .conftest import DATASETS

pytestmark = pytest.mark.slow


def test_quick_start_posterior_is_the_differential_evolution_one():
    problem = make_problem(str(DATASETS / "monday1965" / "unit3_fit.toml"),
                           str(DATASETS / "monday1965" / "synthetic" / "unit3.csv"))
    lsq, *_ = reconcile(problem, least_squares(problem, seed=3, priors_count=True), seed=3, priors_count=True)
    runs = {m: run_emcee(problem, lsq, walkers=32, steps="auto", seed=3, moves=m) for m in ("de", "de-t")}
    assert all(r.converged for r in runs.values())
    assert runs["de-t"].steps < 0.5 * runs["de"].steps
    ref, new = (runs[m].chain.reshape(-1, len(problem.names)) for m in ("de", "de-t"))
    sd = ref.std(axis=0)
    np.testing.assert_array_less(np.abs(np.median(new, axis=0) - np.median(ref, axis=0)) / sd, 0.2)
    width = lambda x: np.subtract(*np.quantile(x, [0.95, 0.05], axis=0))  # noqa: E731
    np.testing.assert_allclose(width(new), width(ref), rtol=0.10)
