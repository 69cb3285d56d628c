"""The profiled noise scale settled on the optimum's Jacobian, against refitting until it settles.

A waveform fit carries Gaussian priors (the record's measured centre and drift), so its reading
scale is profiled as a fixed point: the scale equals the scatter of the residuals at the optimum
found with it.  The fit used to refit with the trust-region method until the scale moved by
less than 1e-9; :func:`escfit.inference.noise_scale.settle_scale` finds the same point by linear
steps on the optimum's Jacobian.  Here the previous procedure is written out again (the loop
below) and both run on synthetic records of known truth with AR(1) noise (white stage, rho from
its residuals, AR(1) stage): estimates, standard errors, the reading scale and rho must agree
within a tenth of a standard error, and the truth must lie within the intervals.  A second test
counts the least-squares runs and model runs of one whole fit (a count, not a time).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import escfit.inference.lsq as lsq_module
from escfit.core.scene import load_scene
from escfit.inference import least_squares, make_problem

from .test_waveform_fit import SCENE, TRUTH, correlated_record

AR1_SCENE = (SCENE % "waveform") + 'noise = "ar1"\n'


def record(seed: int):
    """Released at rest at +0.5 rad at t = 0, sampled at 50 Hz from t = 0.3 s for 6 s, with a
    drifting centre and AR(1) reading noise (rho 0.8, marginal scale 0.01 rad)."""
    return correlated_record(500 + seed)


def refit_until_settled(best, scale, n, lower, upper, *, dof, evaluate, polish):
    """The previous procedure: re-estimate the scale from the reading residuals, refit from the
    last optimum, until the scale moves by less than 1e-9 of itself."""
    rounds = 0
    for _ in range(50):
        r = best.residual[:n] * scale[0]
        new = math.sqrt(float(r @ r) / dof(best))
        done = abs(new - scale[0]) <= 1e-9 * scale[0]
        scale[0] = new
        if done:
            break
        best = polish(best.x)
        rounds += 1
    return best, rounds


def _fit(problem_text: str, data):
    return least_squares(make_problem(load_scene("s.toml", text=problem_text), data), n_starts=4, seed=1)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_settled_scale_matches_refitting_until_the_scale_settles(seed, monkeypatch):
    data = record(seed)
    text = AR1_SCENE
    now = _fit(text, data)
    with monkeypatch.context() as m:
        m.setattr(lsq_module, "settle_scale", refit_until_settled)
        before = _fit(text, data)
    assert now.names == before.names
    se = before.stderr
    assert np.all(np.isfinite(se)) and np.all(se > 0)
    assert np.all(np.abs(now.value - before.value) < 0.1 * se), (now.value - before.value) / se
    assert np.all(np.abs(now.stderr - se) < 0.1 * se), now.stderr / se
    assert abs(now.sigma_hat - before.sigma_hat) < 0.01 * before.sigma_hat
    assert abs(now.values["observation.rho"] - before.values["observation.rho"]) < 0.01
    for name, truth in TRUTH.items():  # the known truth inside a 4-standard-error band of both
        i = now.names.index(name)
        assert abs(now.value[i] - truth) < 4.0 * now.stderr[i], (name, now.value[i], truth, now.stderr[i])


class Counts:
    """Least-squares runs (scipy) and model runs (a batch call counts its sets) while active."""

    def __init__(self, monkeypatch):
        import scipy.optimize

        import escfit.balance.batch_dense as batch_dense
        import escfit.balance.solvers as solvers
        import escfit.balance.waveform as waveform

        self.fits = self.runs = 0

        def count_fit(func):
            def run(*a, **k):
                self.fits += 1
                return func(*a, **k)
            return run

        def count_runs(func):
            def run(*a, **k):
                out = func(*a, **k)
                self.runs += out[0].shape[0] if isinstance(out, tuple) else 1
                return out
            return run

        monkeypatch.setattr(scipy.optimize, "least_squares", count_fit(scipy.optimize.least_squares))
        monkeypatch.setattr(solvers, "solve_system", count_runs(solvers.solve_system))
        monkeypatch.setattr(waveform, "solve_system", count_runs(waveform.solve_system))
        monkeypatch.setattr(batch_dense, "sample_batch", count_runs(batch_dense.sample_batch))


#: least-squares runs and model runs of one whole waveform fit with AR(1) noise, and the agreement
#: check's turning-point refits, at most (measured: 8 runs and 519 model runs; the procedure that
#: refitted until the noise scale settled and searched the noise likelihood by model runs made
#: 28 runs and 997 model runs on this record)
MAX_FITS, MAX_MODEL_RUNS = 10, 600


def test_one_leastsq_command_stays_within_its_count_of_fits_and_model_runs(monkeypatch):
    from escfit.inference.fit import fit

    data = record(0)
    scene = load_scene("s.toml", text=AR1_SCENE)
    counts = Counts(monkeypatch)
    result = fit(scene, data, method="leastsq", seed=1)
    assert result.group("least_squares") is not None
    assert 0 < counts.fits <= MAX_FITS, counts.fits
    assert 0 < counts.runs <= MAX_MODEL_RUNS, counts.runs


def _line_with_prior():
    """A straight line of 200 noisy readings (scene noise 0.1, true scatter 0.3) and a Gaussian
    prior 0.5 +- 0.2 on its intercept: the profiled scale is a fixed point away from 1."""
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 1.0, 200)
    y = 1.0 + 2.0 * t + 0.3 * rng.standard_normal(t.size)
    return t, y


def _fixed_point_by_normal_equations(t, y, dof):
    """The reference: weighted linear least squares (numpy) and the scale iterated to its fixed point."""
    a = np.column_stack([np.ones_like(t), t])
    s = 1.0
    for _ in range(500):
        rows = np.vstack([a / (0.1 * s), [[1.0 / 0.2, 0.0]]])
        rhs = np.r_[y / (0.1 * s), 0.5 / 0.2]
        x = np.linalg.lstsq(rows, rhs, rcond=None)[0]
        r = (y - a @ x) / 0.1
        s = math.sqrt(float(r @ r) / dof)
    return x, s


@pytest.mark.parametrize("jacobian", [True, False])
def test_settle_scale_finds_the_fixed_point_of_a_line_with_a_prior(jacobian):
    from escfit.inference.noise_scale import settle_scale
    from escfit.inference.trf import minimize

    t, y = _line_with_prior()
    n, dof = t.size, t.size - 2.0
    scale = [1.0]

    def residual(x):
        return np.r_[(y - x[0] - x[1] * t) / 0.1 / scale[0], (x[0] - 0.5) / 0.2]

    lo, hi = np.full(2, -np.inf), np.full(2, np.inf)
    best = minimize(residual, np.zeros(2), lo, hi)
    if not jacobian:  # an optimiser without a Jacobian: the refits
        best.jac = None
    out, polished = settle_scale(best, scale, n, lo, hi, dof=lambda _: dof, evaluate=residual,
                                 polish=lambda x: minimize(residual, x, lo, hi))
    x_ref, s_ref = _fixed_point_by_normal_equations(t, y, dof)
    assert 2.5 < s_ref < 3.5  # far from the scene's noise: the settling matters
    assert scale[0] == pytest.approx(s_ref, rel=1e-6)
    assert out.x == pytest.approx(x_ref, rel=1e-6)
    assert polished <= (1 if jacobian else 50)
