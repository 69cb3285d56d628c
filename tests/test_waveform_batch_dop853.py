"""The waveform problem's whole-ensemble log posterior with solver dop853 (pendulums, air drag).

``WaveformProblem.log_prob_many`` runs every parameter set's DOP853 integration and samples its
dense solution in one compiled call (:func:`escfit.balance.batch_dop853.sample_batch_dop853`).
The reference is the one-set path (``log_prob``: ``sample_state`` through ``solve_dop853``'s
dense solution, then the observation model's numpy code), row by row: the two must agree to
rounding on a pendulum released at large amplitude (``sin(theta)`` far from linear) with air
drag, on sets that Coulomb or static friction stops, sets released earlier or later, AR(1)
noise, sets outside the prior, and sets that fail (a refused parameter set, a release after the
first sample, a run out of segments or steps), with the same failure counts; and only the
failing sets may go the one-set way.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.balance.batch_dop853 import OMEGA, THETA, sample_batch_dop853
from escfit.analysis.recordings.timeseries import TimeSeries
from escfit.balance.waveform import sample_state
from escfit.core.scene import load_scene
from escfit.inference import make_problem

from .batch_checks import compare_many as _compare, scatter, with_values as _set

SCENE = """model = "balance"
[oscillator]
restoring = "pendulum"
omega0 = { value = 3.7, vary = true, min = 3, max = 4.5 }
theta0 = { value = 1.2, vary = true, min = 0.2, max = 2.0 }
[effects.viscous]
C = { value = 0.05, vary = true, min = 0, max = 2 }
[effects.coulomb]
R = { value = 0.02, vary = true, min = 0, max = 5 }
%s
[effects.drag]
D = { value = 0.05, vary = true, min = 0, max = 1 }
[observation]
model = "waveform"
%s
"""
TRUTH = {"oscillator.omega0": 3.8, "viscous.C": 0.04, "coulomb.R": 0.02, "drag.D": 0.06, "oscillator.theta0": 1.3}
STATIC = "R_static = { value = 0.03, vary = true, min = 0, max = 50 }"
WIDE_RELEASE = "t_release = { value = 0.3, vary = true, min = -1.0, max = 2.0 }"


def _record(*, noise: str = "white", seed: int = 4, quantity: str = "angle") -> TimeSeries:
    """A pendulum released at rest at +1.3 rad (75 deg) at t = 0, with viscous, Coulomb and air
    drag, sampled at 30 Hz from 0.3 s to 8.3 s with an offset, a drift and white or AR(1) noise
    of 0.01 (rad, or rad/s for an angular velocity)."""
    scene = load_scene("truth.toml", text=SCENE % ("", ""))
    system = scene.system({**scene.params.values(), **TRUTH})
    t = np.arange(0.3, 8.3, 1 / 30)
    theta, omega, status = sample_state(system, t, "dop853")
    assert status == "ok"
    rng = np.random.default_rng(seed)
    e = rng.standard_normal(t.size)
    if noise == "ar1":
        for i in range(1, e.size):
            e[i] = 0.6 * e[i - 1] + 0.8 * e[i]
    y = (omega if quantity == "angular_velocity" else theta) + 0.02 - 0.004 * t + 0.01 * e
    return TimeSeries(t, y, source=f"pendulum-{noise}-{seed}", quantity=quantity)


def _problem(coulomb: str = "", observation: str = "", **kw):
    return make_problem(load_scene("fit.toml", text=SCENE % (coulomb, observation)), _record(**kw.pop("record", {})),
                        **kw)


def _sets(problem, n: int, seed: int = 0, spread: float = 0.03) -> np.ndarray:
    """``n`` parameter sets scattered about the truth, clipped to the priors (the release angle
    and instant, the offset and its drift about the problem's start, which the record's first
    turning point gave: the fit's clock starts there)."""
    truth = {k: v for k, v in TRUTH.items() if k != "oscillator.theta0"}
    truth["observation.sigma"] = 0.01
    return scatter(problem, truth, n, seed, spread)


def _summary(problem, vecs: np.ndarray, **options) -> np.ndarray:
    vals = problem.values_many(vecs)
    return sample_batch_dop853(problem.scene.system(vals, len(vecs)), problem.sample_time,
                               vals["observation.t_release"], **options)[1]


def test_large_swings_with_drag_stops_releases_and_prior_bounds():
    problem = _problem()
    assert problem.solver == "dop853" and problem.vectorized
    vecs = _sets(problem, 12)
    t_rel = problem.params["observation.t_release"].value
    extra = [_set(problem, vecs[0], **{"coulomb.R": 3.0}),  # stops within a few half swings
             _set(problem, vecs[1], **{"oscillator.theta0": -1.95, "drag.D": 0.0}),  # 112 deg, no drag
             _set(problem, vecs[2], **{"observation.t_release": t_rel + 0.09}),  # released later
             _set(problem, vecs[3], **{"observation.t_release": t_rel - 0.09}),  # released earlier
             _set(problem, vecs[4], **{"drag.D": -0.01}),  # outside the prior
             _set(problem, vecs[5], **{"oscillator.omega0": 5.0})]  # outside the prior
    vecs = np.vstack([vecs, extra])
    rows, _ = _compare(problem, vecs)
    assert np.isfinite(rows[:-2]).all() and not np.isfinite(rows[-2:]).any()
    summary = _summary(problem, vecs[12:14])
    assert list(summary["status"]) == [1, 0] and list(summary["usable"]) == [1, 1]
    t_last = problem.sample_time[-1] - problem.values(vecs[13])["observation.t_release"]
    # half swings of ~1.05 s at 112 deg (about 1.26 times the small-swing pi/omega0): 7 cover the record
    assert summary["n_done"][0] < 4 and summary["n_done"][1] >= 6 and summary["t"][1] >= t_last


def test_ar1_noise_gain_and_tolerance_options():
    obs = 'noise = "ar1"\ngain = { value = 1.0, vary = true, min = 0.8, max = 1.2 }'
    problem = _problem(observation=obs, record={"noise": "ar1"})
    assert "observation.rho" in problem.names and "observation.gain" in problem.names
    vecs = _sets(problem, 10, seed=5)
    vecs[:, problem.names.index("observation.rho")] = np.linspace(0.0, 0.95, 10)
    _compare(problem, vecs)
    loose = _problem(observation=obs, record={"noise": "ar1"}, solver_options={"rtol": 1e-7, "atol": 1e-9})
    assert loose.vectorized
    _compare(loose, vecs)


def test_static_friction_holds_and_refused_sets_fall_back():
    problem = _problem(STATIC)
    vecs = _sets(problem, 8, seed=1)
    vecs[:, problem.names.index("coulomb.R_static")] = 0.03
    at_release = _set(problem, vecs[0], **{"coulomb.R_static": 20.0})  # never moves (w2 sin(theta0) ~ 14 rad/s^2)
    later = _set(problem, vecs[1], **{"coulomb.R_static": 9.0})  # held at a turning point a few swings on
    refused = _set(problem, vecs[2], **{"coulomb.R_static": 0.001})  # below the sliding friction: refused
    vecs = np.vstack([vecs, at_release, later, refused])
    rows, failures = _compare(problem, vecs, one_at_a_time=1)
    assert np.isfinite(rows[:-1]).all() and rows[-1] == -math.inf
    assert sum(failures.values()) == 1 and "R_static must be >= R" in next(iter(failures))
    summary = _summary(problem, vecs[-3:-1])
    assert list(summary["status"]) == [1, 1] and list(summary["usable"]) == [1, 1]
    assert summary["n_done"][0] == 0 and 1 <= summary["n_done"][1] <= 8


def test_release_after_the_first_sample_and_exhausted_budgets_fail_as_one_at_a_time():
    problem = _problem(observation=WIDE_RELEASE)
    vecs = _sets(problem, 5, seed=2)
    late = _set(problem, vecs[0], **{"observation.t_release": 1.5})  # after the first sample (0.3 s ...)
    rows, failures = _compare(problem, np.vstack([vecs, late]), one_at_a_time=1)
    assert rows[-1] == -math.inf and np.isfinite(rows[:-1]).all()
    assert any("release instant falls after the first sample" in k for k in failures)
    # budgets the swinging sets exceed and the quickly stopped one does not
    for options in ({"max_segments": 6}, {"max_steps": 60}):
        budget = _problem(solver_options=options)
        assert budget.vectorized
        vecs = np.vstack([_sets(budget, 3, seed=3), _set(budget, _sets(budget, 1, seed=4)[0], **{"coulomb.R": 3.0})])
        rows, failures = _compare(budget, vecs, one_at_a_time=3)
        assert not np.isfinite(rows[:3]).any() and np.isfinite(rows[3])
        # (an exhausted step budget is labelled max_segments too: escfit.core.status)
        assert failures["solve failed: solver status max_segments"] == 3, failures


def test_sampled_states_are_those_of_sample_state():
    """Every set's theta and theta' against sample_state's, for both quantities (the compiled
    code is the same, so they agree to the last bit in practice; 1e-12 is asserted)."""
    problem = _problem()
    vecs = np.vstack([_sets(problem, 6, seed=8, spread=0.2), _set(problem, _sets(problem, 1, seed=9)[0],
                                                                   **{"coulomb.R": 3.0})])
    vals = problem.values_many(vecs)
    shift = vals["observation.t_release"]
    for which in (THETA, OMEGA):
        got, summary = sample_batch_dop853(problem.scene.system(vals, len(vecs)), problem.sample_time, shift,
                                           which=which)
        assert summary["usable"].all()
        for i, v in enumerate(vecs):
            theta, omega, status = sample_state(problem.scene.system(problem.values(v)), problem.sample_time - shift[i],
                                                "dop853")
            assert status == ("stopped" if summary["status"][i] == 1 else "ok")
            np.testing.assert_allclose(got[i], theta if which == THETA else omega, rtol=1e-12, atol=1e-15)


def test_an_angular_velocity_record():
    rate = _problem(record={"quantity": "angular_velocity"})
    assert rate.quantity == "angular_velocity" and rate.vectorized
    vecs = _sets(rate, 6, seed=7, spread=0.01)
    vecs[:, rate.names.index("observation.sigma")] = 0.05
    _compare(rate, vecs)


def test_refusals_of_the_batch_call():
    from escfit.core.errors import SolverError

    problem = _problem()
    vals = problem.values_many(_sets(problem, 2))
    system = problem.scene.system(vals, 2)
    with pytest.raises(SolverError, match="ascending"):
        sample_batch_dop853(system, problem.sample_time[::-1], 0.0)
    with pytest.raises(SolverError, match="rtol"):
        sample_batch_dop853(system, problem.sample_time, 0.0, rtol=2.0)
    with pytest.raises(SolverError, match="atol"):
        sample_batch_dop853(system, problem.sample_time, 0.0, atol=0.0)
    # the exact solver's batch refuses a pendulum with drag instead of dropping sin(theta) and the drag
    from escfit.balance.batch_dense import sample_batch

    with pytest.raises(SolverError):
        sample_batch(system, problem.sample_time, 0.0)


@pytest.mark.parametrize("solver", ["rk4", "ivp"])
def test_a_pendulum_with_another_solver_is_evaluated_with_that_solver(solver):
    """rk4 or solve_ivp without options: set by set with that solver, never the exact solver's batch."""
    problem = _problem(solver=solver, solver_options={})
    assert not problem.vectorized
    vecs = _sets(problem, 2, seed=7)
    np.testing.assert_array_equal(problem.log_prob_many(vecs), [problem.log_prob(v) for v in vecs])
