"""The damping-law check of a fit (:mod:`escfit.analysis.decrement_law`): the record's losses per
half swing against the model's, bin by bin.

References: closed-form decays (a friction decay loses the same amount every half swing; an
exponential one a fixed share), and records whose law is known: the model's own law with noise
(never refuted), and the same decay read through a sensor that reads ``sin(theta)`` (an
accelerometer's tilt), whose losses at large amplitude are ``cos(A)`` of the true ones.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.analysis.decrement_law import LAW_SHARE, LAW_SIGMAS, law_mismatch
from escfit.analysis.recordings.timeseries import TimeSeries
from escfit.balance.waveform import sample_theta
from escfit.core.scene import load_scene
from escfit.inference import make_problem
from escfit.inference.fit import fit_problem

from .test_agreement import SCENE, truth_system

K = np.arange(200)


def test_a_friction_decay_refutes_an_exponential_through_its_ends():
    """Record: 1 rad losing 0.004 rad every half swing; model: the exponential through the same
    first and last amplitudes.  The bins hold the closed forms, and the law is refuted with the
    record's loss flatter than the model's."""
    record = 1.0 - 0.004 * K + 1e-4 * np.random.default_rng(1).standard_normal(K.size)
    c = -math.log(record[-1] / record[0]) / K[-1]
    model = record[0] * np.exp(-c * K)
    law = law_mismatch(K, record, model)
    assert law.record == pytest.approx(0.004, abs=4 * float(np.max(law.error)))
    # the model's loss per half swing is (A_k - A_{k+2}) / 2 = A_k (1 - exp(-2c)) / 2: a fixed share of
    # its amplitude, so it grows from bin to bin as the amplitudes do
    share = (1 - math.exp(-2 * c)) / 2
    assert np.all(np.diff(law.model) > 0) and law.model[-1] / law.model[0] > 3
    assert np.all(law.model >= share * model.min() * 0.999) and np.all(law.model <= share * model.max() * 1.001)
    assert law.refuted and law.at_large < 0
    k = law.worst
    assert law.sigmas[k] > LAW_SIGMAS and law.share[k] > LAW_SHARE


@pytest.mark.parametrize("seed", range(5))
def test_the_models_own_law_with_noise_is_not_refuted(seed):
    model = 1.2 * np.exp(-0.004 * K) - 0.001 * K
    record = model + 0.003 * np.random.default_rng(seed).standard_normal(K.size)
    law = law_mismatch(K, record, model)
    assert law is not None and not law.refuted, (law.sigmas, law.share)


def test_too_few_turning_points_are_not_judged():
    assert law_mismatch(K[:20], np.linspace(1, 0.5, 20), np.linspace(1, 0.5, 20)) is None


def _record(read, *, periods: int = 120, seed: int = 4) -> TimeSeries:
    truth = {"oscillator.omega0": 2 * math.pi, "viscous.C": 0.01, "coulomb.R": 0.02, "oscillator.theta0": 1.2}
    system = load_scene("truth.toml", text=SCENE % "amplitude").system(
        {**load_scene("truth.toml", text=SCENE % "amplitude").params.values(), **truth})
    t = np.arange(0.0, float(periods), 1 / 40.0)
    theta, _ = sample_theta(system, t, "exact")
    return TimeSeries(t, read(theta) + 0.002 * np.random.default_rng(seed).standard_normal(t.size), source="law")


def test_a_sensor_that_reads_sin_theta_is_caught_and_the_split_withdrawn():
    """The true law (viscous damping and friction) read as sin(theta): the fit's law loses too much
    at large amplitude.  A caution names the law and says the record loses less at large
    amplitude (it suggested adding air drag, which loses more), and C and R are not determined;
    the same decay read as theta has no such caution."""
    fit = lambda rec: fit_problem(make_problem(load_scene("fit.toml", text=SCENE % "amplitude"), rec),  # noqa: E731
                                  n_starts=1)
    bent = fit(_record(np.sin))
    said = [w for w in bent.warnings if "damping law does not follow" in w or "does not follow the model's damping law"
            in w]
    # the remedy follows the record: it loses less at large amplitude, which no added law (drag) gives
    assert said and "loses less at large amplitude" in said[0] and "[effects.drag]" not in said[0], bent.warnings
    assert bent.verdict != "determined" and {"viscous.C", "coulomb.R"} <= set(bent.undetermined)
    straight = fit(_record(lambda x: x))
    assert not any("damping law" in w for w in straight.warnings), straight.warnings
    assert straight.verdict == "determined", straight.warnings
