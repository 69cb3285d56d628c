"""The waveform fit's integrator tolerance, chosen from the record's noise.

A pendulum record (DOP853, the pendulum's solver) of known truth: the tolerance the problem
chooses must keep the integrator's actual error (against DOP853 at rtol 1e-13) inside the
budget it states, and the fit at that tolerance must give the estimates and standard errors of
the fit at the fixed 1e-10 it replaces within a tenth of a standard error.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.balance.problems.tolerance import ERROR_SE, LOOSEST, TIGHTEST, noise_rtol
from escfit.balance.recordings.timeseries import TimeSeries
from escfit.balance.waveform import sample_theta
from escfit.core.scene import load_scene
from escfit.inference import least_squares, make_problem

TRUTH = {"oscillator.omega0": 4.0, "viscous.C": 0.03, "coulomb.R": 0.004}
SIGMA = 0.003  # rad

SCENE = """model = "balance"
[oscillator]
restoring = "pendulum"
omega0 = { value = 3.9, vary = true, min = 3, max = 5 }
theta0 = { value = 0.55, vary = true, min = 0.2, max = 1.0 }
[effects.viscous]
C = { value = 0.02, vary = true, min = 0, max = 1 }
[effects.coulomb]
R = { value = 0.002, vary = true, min = 0, max = 1 }
[observation]
model = "waveform"
"""


def _system(scene, values):
    return scene.system({**scene.params.values(), **values})


@pytest.fixture(scope="module")
def pendulum_record() -> TimeSeries:
    """Released at rest at 0.6 rad at t = 0, sampled at 20 Hz for 30 s (19 periods) from t = 0.2 s."""
    scene = load_scene("truth.toml", text=SCENE)
    t = np.arange(0.2, 30.2, 0.05)
    theta, status = sample_theta(_system(scene, {**TRUTH, "oscillator.theta0": 0.6}), t, "dop853", rtol=1e-13)
    assert status in ("ok", "stopped")
    rng = np.random.default_rng(7)
    return TimeSeries(t, theta + SIGMA * rng.standard_normal(t.size), source="pendulum-synthetic")


def test_noise_rtol_follows_the_noise_and_stays_in_bounds():
    loose, _ = noise_rtol(0.01, 0.5, 1000, 20.0)
    tight, _ = noise_rtol(0.0001, 0.5, 1000, 20.0)
    assert loose == pytest.approx(100 * tight, rel=1e-9)  # proportional to the noise inside the bounds
    assert loose == pytest.approx(ERROR_SE * 0.01 / math.sqrt(1000) / (0.5 * 20.0), rel=1e-12)
    assert noise_rtol(1.0, 1e-3, 10, 1.0)[0] == LOOSEST
    assert noise_rtol(1e-12, 1.0, 10**6, 100.0)[0] == TIGHTEST
    assert noise_rtol(math.nan, 0.5, 1000, 20.0)[0] == TIGHTEST


def test_chosen_tolerance_keeps_the_integrator_error_inside_its_budget(pendulum_record):
    problem = make_problem(load_scene("s.toml", text=SCENE), pendulum_record)
    rtol = problem.solver_options["rtol"]
    assert TIGHTEST < rtol <= LOOSEST  # looser than the fixed default: the noise allows it
    assert f"rtol = {rtol:.2g}" in problem.provenance()["solver_tolerance"]
    scene = problem.scene
    values = {**TRUTH, "oscillator.theta0": 0.6}
    t = problem.sample_time
    reference, _ = sample_theta(_system(scene, values), t, "dop853", rtol=1e-13)
    chosen, _ = sample_theta(_system(scene, values), t, "dop853", rtol=rtol)
    budget = ERROR_SE * problem.values({})["observation.sigma"] / math.sqrt(t.size)  # the noise it was chosen from
    assert np.max(np.abs(chosen - reference)) < budget


def test_fit_at_the_chosen_tolerance_matches_the_fixed_one(pendulum_record):
    scene = load_scene("s.toml", text=SCENE)
    chosen = least_squares(make_problem(scene, pendulum_record), n_starts=1)
    fixed = least_squares(make_problem(scene, pendulum_record, solver_options={"rtol": 1e-10}), n_starts=1)
    se = fixed.stderr
    assert np.all(np.isfinite(se))
    assert np.all(np.abs(chosen.value - fixed.value) < 0.1 * se), (chosen.value - fixed.value) / se
    assert np.all(np.abs(chosen.stderr - se) < 0.1 * se)
    for name, truth in TRUTH.items():
        i = chosen.names.index(name)
        assert abs(chosen.value[i] - truth) < 4.0 * chosen.stderr[i], (name, chosen.value[i], truth)
