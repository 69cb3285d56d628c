"""The waveform problem's whole-ensemble log posterior against its one-set path.

``WaveformProblem.log_prob_many`` runs every parameter set's exact solution and samples it in
one compiled call, then the waveform likelihood of all sets in another.  The reference is the
one-set path (``log_prob``: ``sample_state`` through the solver's dense solution, then the
observation model's numpy code), row by row: the two must agree to rounding on sets that swing
to the end of the record, sets that friction stops (sliding and static friction), sets released
earlier or later, sets outside the prior, and sets that fail (a refused parameter set, a release
after the first sample, a run out of segments), with the same failure counts.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.balance.batch_dense import OMEGA, THETA, sample_batch
from escfit.analysis.recordings.timeseries import TimeSeries
from escfit.balance.waveform import sample_state
from escfit.core.scene import load_scene
from escfit.inference import make_problem

from .batch_checks import compare_many as _compare, scatter, with_values as _set

SCENE = """model = "balance"
[oscillator]
omega0 = { value = 6.2, vary = true, min = 4, max = 8 }
theta0 = { value = 0.45, vary = true, min = 0.2, max = 0.8 }
[effects.viscous]
C = { value = 0.2, vary = true, min = 0, max = 2 }
[effects.coulomb]
R = { value = 0.5, vary = true, min = 0, max = 5 }
%s
[observation]
model = "waveform"
%s
"""
STATIC = "R_static = { value = 0.6, vary = true, min = 0, max = 50 }"
# a release instant free far beyond the record's first samples (s, the record's clock)
WIDE_RELEASE = "t_release = { value = 0.3, vary = true, min = -1.0, max = 2.0 }"


def _record(*, noise: str = "white", seed: int = 4, quantity: str = "angle") -> TimeSeries:
    """A free decay released at rest at +0.5 rad at t = 0 (omega0 2 pi, C 0.3, R 0.5), sampled at
    50 Hz from 0.3 s to 6.3 s with an offset, a drift and white or AR(1) noise of 0.01."""
    scene = load_scene("truth.toml", text=SCENE % ("", ""))
    system = scene.system({**scene.params.values(), "oscillator.omega0": 2 * math.pi, "viscous.C": 0.3,
                           "coulomb.R": 0.5, "oscillator.theta0": 0.5})
    t = np.arange(0.3, 6.3, 0.02)
    theta, omega, status = sample_state(system, t, "exact")
    assert status in ("ok", "stopped")
    rng = np.random.default_rng(seed)
    e = rng.standard_normal(t.size)
    if noise == "ar1":
        for i in range(1, e.size):
            e[i] = 0.6 * e[i - 1] + 0.8 * e[i]
    y = (omega if quantity == "angular_velocity" else theta) + 0.02 - 0.004 * t + 0.01 * e
    return TimeSeries(t, y, source=f"batch-{noise}-{seed}", quantity=quantity)


def _problem(coulomb: str = "", observation: str = "", **kw):
    return make_problem(load_scene("fit.toml", text=SCENE % (coulomb, observation)), _record(**kw.pop("record", {})),
                        **kw)


def _sets(problem, n: int, seed: int = 0, spread: float = 0.03) -> np.ndarray:
    """``n`` parameter sets scattered about the truth, inside the priors (the release angle and
    instant, the offset and its drift about the problem's start, which the record's reference
    turning point gave)."""
    truth = {"oscillator.omega0": 2 * math.pi, "viscous.C": 0.3, "coulomb.R": 0.5, "observation.sigma": 0.01}
    return scatter(problem, truth, n, seed, spread)


def test_white_noise_sets_about_the_truth_stops_releases_and_prior_bounds():
    problem = _problem()
    assert problem.vectorized
    vecs = _sets(problem, 14)
    t_rel = problem.params["observation.t_release"].value
    extra = [_set(problem, vecs[0], **{"coulomb.R": 4.0}),  # stops within a few half swings
             _set(problem, vecs[1], **{"coulomb.R": 0.05}),  # swings past the end of the record
             _set(problem, vecs[2], **{"observation.t_release": t_rel + 0.09}),  # released later
             _set(problem, vecs[3], **{"observation.t_release": t_rel - 0.09}),  # released earlier
             _set(problem, vecs[4], **{"viscous.C": -0.1}),  # outside the prior
             _set(problem, vecs[5], **{"oscillator.omega0": 9.0})]  # outside the prior
    vecs = np.vstack([vecs, extra])
    rows, _ = _compare(problem, vecs)
    assert np.isfinite(rows).sum() == 18 and not np.isfinite(rows[-2:]).any()
    # the batch itself ran the stopped and the swinging sets (no fallback, see _compare)
    vals = problem.values_many(vecs[14:16])
    _, summary = sample_batch(problem.scene.system(vals, 2), problem.sample_time, vals["observation.t_release"])
    assert list(summary["status"]) == [1, 0] and list(summary["usable"]) == [1, 1]
    assert summary["n_done"][0] < 8 and summary["t"][1] >= problem.sample_time[-1] - vals["observation.t_release"][1]


def test_static_friction_holds_and_refused_sets_fall_back():
    problem = _problem(STATIC)
    vecs = _sets(problem, 10, seed=1)
    i_static = problem.names.index("coulomb.R_static")
    vecs[:, i_static] = 0.6
    at_release = _set(problem, vecs[0], **{"coulomb.R_static": 40.0})  # never moves (w2*theta0 ~ 20 rad/s^2)
    later = _set(problem, vecs[1], **{"coulomb.R_static": 15.0})  # held at a turning point a few swings on
    refused = _set(problem, vecs[2], **{"coulomb.R_static": 0.1})  # below the sliding friction: refused
    vecs = np.vstack([vecs, at_release, later, refused])
    rows, failures = _compare(problem, vecs, one_at_a_time=1)
    assert np.isfinite(rows[:-1]).all() and rows[-1] == -math.inf
    assert sum(failures.values()) == 1 and "R_static must be >= R" in next(iter(failures))
    vals = problem.values_many(np.vstack([at_release, later]))
    _, summary = sample_batch(problem.scene.system(vals, 2), problem.sample_time, vals["observation.t_release"])
    assert list(summary["status"]) == [1, 1] and list(summary["usable"]) == [1, 1]
    assert summary["n_done"][0] == 0 and 2 <= summary["n_done"][1] <= 8


def test_release_after_the_first_sample_and_runs_out_of_segments_fail_as_one_at_a_time():
    problem = _problem(observation=WIDE_RELEASE)
    vecs = _sets(problem, 6, seed=2)
    late = _set(problem, vecs[0], **{"observation.t_release": 1.5})  # after the first sample (0.3 s ...)
    vecs = np.vstack([vecs, late])
    rows, failures = _compare(problem, vecs, one_at_a_time=1)
    assert rows[-1] == -math.inf and np.isfinite(rows[:-1]).all()
    assert any("release instant falls after the first sample" in k for k in failures)
    # a segment budget the swinging sets exceed and the quickly stopped ones do not
    budget = _problem(solver_options={"max_segments": 6})
    assert budget.vectorized
    vecs = np.vstack([_sets(budget, 4, seed=3), _set(budget, _sets(budget, 1, seed=4)[0], **{"coulomb.R": 4.5})])
    rows, failures = _compare(budget, vecs, one_at_a_time=4)
    assert not np.isfinite(rows[:4]).any() and np.isfinite(rows[4])
    assert failures["solve failed: solver status max_segments"] == 4


def test_ar1_noise_and_a_gain():
    problem = _problem(observation='noise = "ar1"\ngain = { value = 1.0, vary = true, min = 0.8, max = 1.2 }',
                       record={"noise": "ar1"})
    assert "observation.rho" in problem.names and "observation.gain" in problem.names
    vecs = _sets(problem, 12, seed=5)
    vecs[:, problem.names.index("observation.rho")] = np.linspace(0.0, 0.95, 12)
    _compare(problem, vecs)


def test_whole_step_readings_and_an_angular_velocity_record():
    _compare(_problem(observation="quantum = 0.02\nsigma = { value = 0.01, vary = true, min = 0.002, max = 0.1 }"),
             _sets(_problem(observation="quantum = 0.02\nsigma = { value = 0.01, vary = true, min = 0.002, max = 0.1 }"),
                   8, seed=6))
    rate = _problem(record={"quantity": "angular_velocity"})
    assert rate.quantity == "angular_velocity" and rate.vectorized
    vecs = _sets(rate, 8, seed=7, spread=0.01)
    vecs[:, rate.names.index("observation.sigma")] = 0.05
    _compare(rate, vecs)


def test_sampled_states_are_those_of_sample_state():
    problem = _problem()
    vecs = np.vstack([_sets(problem, 6, seed=8), _set(problem, _sets(problem, 1, seed=9)[0], **{"coulomb.R": 4.0})])
    vals = problem.values_many(vecs)
    shift = vals["observation.t_release"]
    for which in (THETA, OMEGA):
        got, summary = sample_batch(problem.scene.system(vals, len(vecs)), problem.sample_time, shift, which=which)
        for i, v in enumerate(vecs):
            one = problem.values(v)
            theta, omega, status = sample_state(problem.scene.system(one), problem.sample_time - shift[i], "exact")
            assert status == ("stopped" if summary["status"][i] == 1 else "ok")
            np.testing.assert_allclose(got[i], theta if which == THETA else omega, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("solver, options", [("rk4", {"h": 1e-3}), ("rk4", {}), ("ivp", {})])
def test_other_solvers_keep_the_row_by_row_path(solver, options):
    """A solver without a batch path is evaluated set by set with that solver (also without options,
    where the batch path once ran the exact solver in its place)."""
    problem = _problem(solver=solver, solver_options=options)
    assert not problem.vectorized
    vecs = _sets(problem, 3, seed=10)
    np.testing.assert_array_equal(problem.log_prob_many(vecs), [problem.log_prob(v) for v in vecs])



def test_sample_batch_refuses_unsorted_times():
    from escfit.core.errors import SolverError

    problem = _problem()
    vals = problem.values_many(_sets(problem, 2))
    system = problem.scene.system(vals, 2)
    with pytest.raises(SolverError, match="ascending"):
        sample_batch(system, problem.sample_time[::-1], 0.0)
