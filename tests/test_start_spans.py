"""Where a waveform fit's multistart draws omega0, C and R (:mod:`escfit.balance.problems.start_spans`).

The reference is a linear oscillator with viscous damping, whose free motion is known in closed
form, ``theta = A exp(-C t / 2) cos(omega_d t)``, ``omega_d = sqrt(omega0^2 - C^2 / 4)``: a
60-period record with reading noise.  The spans must hold the truth and follow the record's
period and decay; a start with more loss than the record can hold must be one that fails (the
reason for the spans); every start drawn in them must end at the one optimum.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.analysis.recordings.timeseries import TimeSeries
from escfit.core.scene import load_scene
from escfit.inference import make_problem
from escfit.inference.lsq import least_squares
from escfit.inference.starts import multistart_points

OMEGA0, C, AMPLITUDE, NOISE = 2 * math.pi, 0.03, 0.3, 0.004
SCENE = """model = "balance"
[oscillator]
omega0 = { value = 6.3, vary = true, min = 4, max = 9 }
[effects.viscous]
C = { value = 0.05, vary = true, min = 0, max = 2 }
[effects.coulomb]
R = { value = 0.001, vary = true, min = 0, max = 5 }
[observation]
model = "waveform"
"""


def _record(periods: float = 60.0, seed: int = 2) -> TimeSeries:
    t = np.arange(0.0, periods, 1 / 25)
    wd = math.sqrt(OMEGA0 ** 2 - C ** 2 / 4)
    theta = AMPLITUDE * np.exp(-0.5 * C * t) * (np.cos(wd * t) + 0.5 * C / wd * np.sin(wd * t))
    return TimeSeries(t, theta + NOISE * np.random.default_rng(seed).standard_normal(t.size), source="closed-form")


@pytest.fixture(scope="module")
def problem():
    return make_problem(load_scene("fit.toml", text=SCENE), _record())


def test_spans_hold_the_truth_and_follow_the_record(problem):
    spans = problem.start_spans
    assert set(spans) == {"oscillator.omega0", "viscous.C", "coulomb.R"}  # not the bounds 4-9, 0-2 and 0-5
    c_lo, c_hi = spans["viscous.C"]
    assert c_lo == 0 and c_hi == pytest.approx(3 * C, rel=0.05)  # three times the C that alone explains the decay
    r_lo, r_hi = spans["coulomb.R"]
    # Coulomb friction alone: a straight decay from the first amplitude to the last, 2R/omega0^2 a half swing
    a_end = AMPLITUDE * math.exp(-0.5 * C * problem.sample_time[-1])
    assert r_lo == 0 and r_hi == pytest.approx(3 * OMEGA0 ** 2 * (AMPLITUDE - a_end) / (2 * 2 * 60), rel=0.05)
    # the quarter turn over the record on either side (C up to 0.09 1/s moves omega0 by 2e-4 rad/s)
    w_lo, w_hi = spans["oscillator.omega0"]
    fitted = float(problem.sample_time[-1] - problem.sample_time[0])
    assert w_lo < OMEGA0 < w_hi and w_hi - w_lo == pytest.approx(math.pi / fitted, rel=0.02)


def test_a_loss_the_record_cannot_hold_is_a_start_that_fails(problem):
    # friction of 1 rad/s^2 stops a 0.3 rad swing within six half swings: the model is flat after that,
    # and the fit stays there, five hundred times the best chi-square
    best = least_squares(problem, n_starts=1)
    stuck = least_squares(problem, n_starts=1, start={"coulomb.R": 1.0})
    assert stuck.chisqr > 100 * best.chisqr
    i = best.names.index("viscous.C")
    assert abs(best.value[i] - C) < 4 * best.stderr[i]


@pytest.mark.parametrize("w", [5.0, 7.5])
def test_a_frequency_far_outside_its_span_is_found_as_a_rule(problem, w):
    # 20 % off against 60 periods (the span is 0.8 % wide), losses at the scene's start: the fit still
    # finds the record's frequency; the span is a margin, not a guess
    fit = least_squares(problem, n_starts=1, start={"oscillator.omega0": w})
    i, j = fit.names.index("oscillator.omega0"), fit.names.index("viscous.C")
    assert abs(fit.value[i] - OMEGA0) < 4 * fit.stderr[i]
    assert abs(fit.value[j] - C) < 4 * fit.stderr[j]


def test_every_start_drawn_in_the_spans_ends_at_the_best_optimum(problem):
    fit = least_squares(problem, n_starts=8)
    names = [n for n in problem.names if n not in problem.noise_names]
    idx = [problem.names.index(n) for n in names]
    lo, hi = (np.asarray(b, float)[idx] for b in problem.bounds)
    x0 = np.asarray(problem.initial, float)[idx]
    spans = {names.index(n): s for n, s in problem.start_spans.items()}
    pts = np.array(multistart_points([problem.priors[k] for k in idx], x0, lo, hi, 8, 0, spans))
    for k, (a, b) in spans.items():
        assert np.all((pts[1:, k] >= a) & (pts[1:, k] <= b))
    ends = [least_squares(problem, n_starts=1, start=dict(zip(names, x))).chisqr for x in pts[1:]]
    assert max(ends) == pytest.approx(fit.chisqr, rel=1e-6)


def test_other_axes_are_unmoved_by_a_span():
    class Flat:
        kind = "uniform"

    x0, lo, hi = np.array([1.0, 2.0]), np.array([0.0, 0.0]), np.array([4.0, 8.0])
    plain = np.array(multistart_points([Flat(), Flat()], x0, lo, hi, 9, seed=5))
    narrow = np.array(multistart_points([Flat(), Flat()], x0, lo, hi, 9, seed=5, spans={0: (0.9, 1.1)}))
    np.testing.assert_array_equal(plain[:, 1], narrow[:, 1])
    assert np.all((narrow[1:, 0] >= 0.9) & (narrow[1:, 0] <= 1.1))
    # a span reaching past a bound is cut at the bound
    cut = np.array(multistart_points([Flat(), Flat()], x0, lo, hi, 9, seed=5, spans={0: (-3.0, 0.5)}))
    assert np.all((cut[1:, 0] >= 0.0) & (cut[1:, 0] <= 0.5))
