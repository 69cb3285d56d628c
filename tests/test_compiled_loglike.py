"""The compiled log-likelihood of turning-point readings against the observation models' numpy code.

The unit-curve problem sums its readings' log-probabilities in one compiled kernel
(:mod:`escfit.balance.observation.compiled`), for one parameter set and for a whole ensemble;
the observation models' numpy methods (``loglike`` on the predicted turning points, with
scipy's ``log_ndtr``) are the independent reference, and the two must agree to rounding for
notch counts (both conventions, both switching laws) and Gaussian amplitudes with an offset
and a drifting centre.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import special

import escfit
from escfit.balance.observation import compiled
from escfit.balance.observation.notches import log_interval_mass
from escfit.balance.problems.curves import FitProblem
from escfit.balance.synthetic.unit_curves import record_unit_curve

from .conftest import DATASETS

MONDAY = DATASETS / "scenes" / "monday_unit_angle_fit.toml"
UNIT3 = DATASETS / "monday1965" / "unit3_fit.toml"
UNIT3_DATA = DATASETS / "monday1965" / "synthetic" / "unit3.csv"


def _python_loglike(problem: FitProblem, vals) -> float:
    """The numpy observation model on the predicted turning points, summed curve by curve."""
    pred = problem.predict(vals)
    return float(sum(problem.observation.loglike(p, c.y, vals, problem.sides(c), c.time)
                     for p, c in zip(pred, problem.curves)))


def _sets(problem: FitProblem, n: int, spread: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    vecs = problem.initial * (1 + spread * rng.standard_normal((n, len(problem.names))))
    lo, hi = problem.bounds
    return np.clip(vecs, lo + 1e-9, hi - 1e-9)


def test_log_ndtr_and_interval_mass_match_scipy_in_both_tails():
    x = np.concatenate([np.linspace(-45, 40, 1701), [-20.0, -19.999, 6.0, 6.001, 0.0]])
    got = np.array([compiled.log_ndtr(v) for v in x])
    np.testing.assert_allclose(got, special.log_ndtr(x), rtol=1e-12, atol=1e-300)  # erfc to a few ulp
    rng = np.random.default_rng(1)
    a = rng.uniform(-40, 40, 400)
    b = a + rng.uniform(1e-3, 5, 400)
    got = np.array([compiled.log_interval_mass(p, q) for p, q in zip(a, b)])
    ref = log_interval_mass(a, b)
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("reading", ["counted", "nearest"])
def test_notch_counts_angle_switching(reading):
    text = MONDAY.read_text().replace('notch_deg = 6', f'notch_deg = 6\nnotch_reading = "{reading}"')
    scene = escfit.load_scene("near.toml", text=text)
    data = record_unit_curve(scene, every=4, swings=60, notch_deg=6, sigma=0.03, seed=7, notch_reading=reading)
    problem = FitProblem(scene, data)
    assert problem._compiled_model() == compiled.NOTCHES
    vecs = _sets(problem, 8, 0.05, 3)
    for v in vecs:
        vals = problem.values(v)
        ref = _python_loglike(problem, vals)
        assert math.isfinite(ref)
        assert problem.log_likelihood(vals) == pytest.approx(ref, rel=1e-12, abs=1e-9)
    many = problem.log_prob_many(vecs)
    np.testing.assert_array_equal(many, [problem.log_prob(v) for v in vecs])


def test_notch_counts_phase_switching_at_three_loads():
    """The quick start's problem: Monday's phase convention (nominal sides), three loads."""
    problem = escfit.inference.registry.make_problem(str(UNIT3), str(UNIT3_DATA))
    assert problem.scene.switching == "phase" and len(problem.curves) == 3
    centre = np.array([2.35, 0.026, 981.3, 2029.0, 3030.0])
    rng = np.random.default_rng(2)
    scale = np.array([0.05, 0.009, 2.2, 2.6, 4.0])
    vecs = centre + 3 * scale * rng.standard_normal((10, 5))
    vecs[:, 1] = np.abs(vecs[:, 1]) + 0.002
    for v in vecs:
        vals = problem.values(v)
        assert problem.log_likelihood(vals) == pytest.approx(_python_loglike(problem, vals), rel=1e-12, abs=1e-9)
    many = problem.log_prob_many(vecs)
    np.testing.assert_array_equal(many, [problem.log_prob(v) for v in vecs])


def test_gaussian_amplitudes_with_offset_and_drift():
    text = MONDAY.read_text().split("[observation]")[0] + (
        '[observation]\nmodel = "amplitude"\n'
        'sigma = { value = 0.02, vary = true, min = 0.001, max = 0.5 }\n'
        'offset = { value = 0.01, vary = true, min = -0.2, max = 0.2 }\n'
        'offset_rate = { value = 0.0005, vary = true, min = -0.01, max = 0.01 }\n')
    scene = escfit.load_scene("amp.toml", text=text)
    data = record_unit_curve(scene, every=2, swings=60, sigma=0.02, offset=0.01, seed=4)
    # the drift needs reading times (a recording with a time column): half a period per half swing
    data = dataclasses.replace(data, time=data.swing * math.pi / 15.9)
    problem = FitProblem(scene, data)
    assert problem._compiled_model() == compiled.GAUSSIAN
    vecs = _sets(problem, 8, 0.05, 5)
    for v in vecs:
        vals = problem.values(v)
        assert problem.log_likelihood(vals) == pytest.approx(_python_loglike(problem, vals), rel=1e-12, abs=1e-9)
    many = problem.log_prob_many(vecs)
    np.testing.assert_array_equal(many, [problem.log_prob(v) for v in vecs])


def test_student_t_amplitudes_keep_the_numpy_path():
    text = MONDAY.read_text().split("[observation]")[0] + (
        '[observation]\nmodel = "amplitude"\nnoise = "student_t"\n'
        'sigma = { value = 0.02, vary = true, min = 0.001, max = 0.5 }\n')
    scene = escfit.load_scene("t.toml", text=text)
    data = record_unit_curve(scene, every=4, swings=40, sigma=0.02, seed=4)
    problem = FitProblem(scene, data)
    assert problem._compiled_model() is None
    vals = problem.values(problem.initial)
    assert problem.log_likelihood(vals) == _python_loglike(problem, vals)


def _predictive_problems():
    monday = MONDAY.read_text()
    amp = escfit.load_scene("amp.toml", text=monday.split("[observation]")[0] + (
        '[observation]\nmodel = "amplitude"\n'
        'sigma = { value = 0.02, vary = true, min = 0.001, max = 0.5 }\n'
        'offset = { value = 0.01, vary = true, min = -0.2, max = 0.2 }\n'
        'offset_rate = { value = 0.0005, vary = true, min = -0.01, max = 0.01 }\n'))
    data = record_unit_curve(amp, every=2, swings=60, sigma=0.02, offset=0.01, seed=4)
    student = escfit.load_scene("t.toml", text=monday.split("[observation]")[0] + (
        '[observation]\nmodel = "amplitude"\nnoise = "student_t"\n'
        'sigma = { value = 0.02, vary = true, min = 0.001, max = 0.5 }\n'))
    near = escfit.load_scene("near.toml", text=monday)
    phase = escfit.load_scene("phase.toml", text=UNIT3.read_text().split("[fit.loads]")[0])  # one load
    return {"phase, every half swing": FitProblem(phase, record_unit_curve(phase, every=1, swings=30, notch_deg=6,
                                                                           sigma=0.03, seed=2)),
            "unit3": escfit.inference.registry.make_problem(str(UNIT3), str(UNIT3_DATA)),
            "amplitude drift": FitProblem(amp, dataclasses.replace(data, time=data.swing * math.pi / 15.9)),
            "student-t": FitProblem(student, record_unit_curve(student, every=4, swings=40, sigma=0.02, seed=4)),
            "notches": FitProblem(near, record_unit_curve(near, every=4, swings=60, notch_deg=6, sigma=0.03, seed=7))}


@pytest.mark.parametrize("name", ["unit3", "phase, every half swing", "amplitude drift", "student-t", "notches"])
def test_predictive_of_many_draws_is_the_one_draw_methods(name):
    """The posterior predictive's batch (expected readings and pointwise log-likelihood of many
    draws at once) against :meth:`expected` and :meth:`loglike_pointwise` one draw at a time,
    including draws far enough out that the balance stops before the last reading."""
    problem = _predictive_problems()[name]
    assert (name == "phase, every half swing") == (problem.scene.switching == "phase" and
                                                   np.any(problem._layout()["side"] < 0))
    vecs = _sets(problem, 12, 0.08, 9)
    lo, hi = problem.bounds
    vecs[0] = np.clip(problem.initial * np.where(np.array(["coulomb" in n for n in problem.names]), 6.0, 1.0),
                      lo, hi)  # six times the friction: stops early
    exp, ll = problem.predictive_many(vecs)
    assert exp.shape == ll.shape == (12, problem.n_data)
    for i, v in enumerate(vecs):
        vals = problem.values(v)
        np.testing.assert_allclose(exp[i], problem.expected(vals), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(ll[i], problem.loglike_pointwise(vals), rtol=1e-10, atol=1e-9)
