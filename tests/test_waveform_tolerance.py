"""The waveform fit's integrator tolerance, from the record's noise and the Jacobian's steps.

On a pendulum record (DOP853, the pendulum's solver) of known truth, the tolerance the noise
allows must keep the integrator's actual error (against DOP853 at rtol 1e-13) inside the budget
it states; the tolerance used is never looser than a forward-difference Jacobian allows, is what
the noise allows when least squares differentiates by the integrator's sensitivities, and the
results state both.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.balance.problems.tolerance import (ERROR_SE, JACOBIAN_RTOL, LOOSEST, TIGHTEST, noise_allowed_rtol,
                                              noise_rtol)
from escfit.analysis.recordings.timeseries import TimeSeries
from escfit.balance.waveform import sample_theta
from escfit.core.scene import load_scene
from escfit.inference import make_problem

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


def test_noise_allowed_rtol_follows_the_noise():
    loose = noise_allowed_rtol(0.01, 0.5, 1000, 20.0)
    assert loose == pytest.approx(100 * noise_allowed_rtol(0.0001, 0.5, 1000, 20.0), rel=1e-9)
    assert loose == pytest.approx(ERROR_SE * 0.01 / math.sqrt(1000) / (0.5 * 20.0), rel=1e-12)
    assert math.isnan(noise_allowed_rtol(math.nan, 0.5, 1000, 20.0))


def test_rtol_is_the_tighter_of_the_noise_and_the_jacobian():
    rtol, why = noise_rtol(0.01, 0.5, 1000, 20.0)  # the noise allows 3e-7
    assert rtol == JACOBIAN_RTOL and "forward-difference Jacobian" in why and "3.2e-07" in why
    rtol, why = noise_rtol(1e-7, 1.0, 10**5, 500.0)  # a quiet, long record: the noise asks for less
    assert rtol == pytest.approx(noise_allowed_rtol(1e-7, 1.0, 10**5, 500.0)) and rtol < JACOBIAN_RTOL
    assert noise_rtol(math.nan, 0.5, 1000, 20.0)[0] == JACOBIAN_RTOL
    assert noise_rtol(1e-12, 1.0, 10**6, 1000.0)[0] == TIGHTEST


def test_rtol_with_sensitivities_is_what_the_noise_allows():
    allowed = noise_allowed_rtol(0.004, 0.5, 2000, 70.0)  # 2.5e-8, as the string pendulum's record
    rtol, why = noise_rtol(0.004, 0.5, 2000, 70.0, sensitivities=True)
    assert rtol == pytest.approx(allowed, rel=1e-12) and JACOBIAN_RTOL < rtol < LOOSEST and "sensitivities" in why
    rtol, why = noise_rtol(0.01, 0.5, 1000, 20.0, sensitivities=True)  # the noise allows 3e-7
    assert rtol == LOOSEST and "3.2e-07" in why and "loosest" in why
    assert noise_rtol(math.nan, 0.5, 1000, 20.0, sensitivities=True)[0] == JACOBIAN_RTOL


def test_noise_allowed_tolerance_keeps_the_integrator_error_inside_its_budget(pendulum_record):
    problem = make_problem(load_scene("s.toml", text=SCENE), pendulum_record)
    sigma = problem.values({})["observation.sigma"]  # the noise the tolerance was chosen from
    t = problem.sample_time
    allowed = noise_allowed_rtol(sigma, 0.5 * float(np.ptp(problem.curves[0].y)), t.size,
                                 float(t[-1] - t[0]) * TRUTH["oscillator.omega0"] / (2 * math.pi))
    assert 1e-8 < allowed < 1e-5
    # least squares differentiates this scene by the integrator's sensitivities: no Jacobian floor
    used = min(allowed, LOOSEST)
    assert problem.solver_options["rtol"] == pytest.approx(used, rel=1e-9)
    assert problem.provenance()["solver_tolerance"].startswith(f"rtol = {used:.2g}")
    values = {**TRUTH, "oscillator.theta0": 0.6}
    reference, _ = sample_theta(_system(problem.scene, values), t, "dop853", rtol=1e-13)
    chosen, _ = sample_theta(_system(problem.scene, values), t, "dop853", rtol=allowed)
    assert np.max(np.abs(chosen - reference)) < ERROR_SE * sigma / math.sqrt(t.size)
