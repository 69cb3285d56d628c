"""Checks shared by the tests of the whole-ensemble log posteriors (waveform, exact and dop853).

A batch path must give what the one-set path gives: :func:`compare_many` runs ``log_prob_many``
and ``log_prob`` row by row on the same sets and compares values, -inf rows and failure counts.
"""

from __future__ import annotations

from collections import Counter

import numpy as np


def scatter(problem, truth: dict, n: int, seed: int = 0, spread: float = 0.03) -> np.ndarray:
    """``n`` parameter vectors about ``truth`` (names -> values; the problem's start for the rest),
    with relative spread ``spread``, clipped to the priors' bounds."""
    rng = np.random.default_rng(seed)
    centre_values = dict(problem.values(problem.initial))
    centre_values.update(truth)
    centre = np.array([centre_values[n] for n in problem.names])
    lo, hi = problem.bounds
    vecs = centre + spread * rng.standard_normal((n, centre.size)) * np.maximum(np.abs(centre), 1e-2)
    return np.clip(vecs, np.where(np.isfinite(lo), lo, -np.inf), np.where(np.isfinite(hi), hi, np.inf))


def with_values(problem, vec: np.ndarray, **values) -> np.ndarray:
    """A copy of ``vec`` with the named parameters set."""
    out = vec.copy()
    for name, value in values.items():
        out[problem.names.index(name)] = value
    return out


def compare_many(problem, vecs: np.ndarray, one_at_a_time: int = 0) -> tuple[np.ndarray, Counter]:
    """log_prob_many against log_prob row by row: the same -inf, finite values to 1e-9, the same
    failures; and only ``one_at_a_time`` sets went the one-set way inside log_prob_many."""
    problem.failures.clear()
    calls = []
    one_set = problem.log_likelihood
    problem.log_likelihood = lambda vals: calls.append(1) or one_set(vals)
    try:
        many = problem.log_prob_many(vecs)
    finally:
        del problem.log_likelihood
    assert len(calls) == one_at_a_time
    failures_many = Counter(problem.failures)
    problem.failures.clear()
    rows = np.array([problem.log_prob(v) for v in vecs])
    assert np.array_equal(np.isfinite(many), np.isfinite(rows)), (many, rows)
    ok = np.isfinite(rows)
    np.testing.assert_allclose(many[ok], rows[ok], rtol=1e-9, atol=0.0)
    assert failures_many == problem.failures
    return rows, failures_many
