"""The batch path: many parameter sets through the exact kernel, and the vectorised posterior.

Batch results must be bit-for-bit those of the one-set solver (it is the same compiled
kernel on the same coefficient records), whatever the number of threads; refusals and failures must come back as the
one-set path reports them; the vectorised log posterior must equal ``log_prob`` row by row.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import escfit
from escfit.balance import System
from escfit.balance.batch import solve_batch
from escfit.balance.solvers import solve_system
from escfit.core.errors import SolverError
from escfit.balance.problems.curves import FitProblem
from escfit.inference import run_emcee
from escfit.balance.synthetic.unit_curves import record_unit_curve

from .conftest import DATASETS, balance_toml

MONDAY = DATASETS / "scenes" / "monday_unit_angle_fit.toml"
FIELDS = ("amplitude", "theta_turn", "half_period", "time", "banked")

RICH = balance_toml(omega0=12.0, theta0=2.5, swings=40, effects="""
[effects.viscous]
C = 0.4
[effects.coulomb]
R = 30.0
[[effects.escapement]]
kind = "unlock"
from = -0.5
to = -0.2
X = 60.0
swings = "positive"
[[effects.escapement]]
kind = "impulse"
from = -0.2
to = 0.3
X = 500.0
[effects.hairspring]
angles = [-1.0, 1.5]
omega0 = [11.0, 12.0, 13.5]
[effects.banking]
angle = 2.6
restitution = 0.3
[effects.viscous_drift]
thresholds = [0.5, 0.2]
rates = [0.02, 0.01, 0.0]
""").replace("omega0 = 12.0\n", "", 1)

PHASE = balance_toml(omega0=16.174, theta0=6.28, swings=60, switching="phase", effects="""
[effects.viscous]
C = 0.833
[effects.coulomb]
R = 305.5
[[effects.escapement]]
kind = "unlock"
from = -0.6338
to = -0.2787
X = 143.4
[[effects.escapement]]
kind = "impulse"
from = -0.2787
to = 0.2787
X = 1245.8
""")


def _perturbed(scene, n, seed=0, spread=0.4):
    rng = np.random.default_rng(seed)
    free = [p for p in scene.params if p.tie is None and p.value != 0 and p.name != "oscillator.theta0"]
    return [scene.build({p.name: p.value * (1 + spread * (rng.random() - 0.5)) for p in free}) for _ in range(n)]


def _assert_same(single, batch_one):
    assert single.status == batch_one.status
    for f in FIELDS:
        np.testing.assert_array_equal(getattr(single, f), getattr(batch_one, f), err_msg=f)
    assert single.final == batch_one.final
    assert single.n_segments == batch_one.n_segments


@pytest.mark.parametrize("text, switching, swings", [
    (MONDAY.read_text(), "angle", 120),
    ((DATASETS / "scenes" / "horology_rk4_case.toml").read_text(), "angle", 50),
    (RICH, "angle", 40),
    (PHASE, "phase", 60),
])
def test_batch_is_bit_for_bit_the_single_set_solver(text, switching, swings):
    scene = escfit.load_scene("batch.toml", text=text)
    systems = _perturbed(scene, 24)
    batch = solve_batch(systems, swings)
    assert len(batch) == 24
    for i, sys in enumerate(systems):
        _assert_same(solve_system(sys, swings, "exact"), batch[i])
        assert np.all(np.isnan(batch.amplitude[i, batch.n_done[i]:]))


def test_thread_count_does_not_change_results():
    scene = escfit.load_scene(MONDAY)
    stack = System.stack(_perturbed(scene, 33, seed=2))
    one = solve_batch(stack, 120, threads=1)
    two = solve_batch(stack, 120, threads=2)
    for f in FIELDS:
        np.testing.assert_array_equal(getattr(one, f), getattr(two, f))
    np.testing.assert_array_equal(one.status, two.status)


def test_stopped_and_banked_sets_report_their_status():
    scene = escfit.load_scene("rich.toml", text=RICH)
    dead = scene.build({"coulomb.R": 5000.0})  # friction holds it at the release angle
    banks = scene.build({"escapement[2].X": 4000.0})
    batch = solve_batch([scene.build(), dead, banks], 40)
    assert batch.status[1] == "stopped" and batch.n_done[1] == 0
    assert batch.status[2] == "banked" and batch.banked[2].any()
    for i, sys in enumerate([scene.build(), dead, banks]):
        _assert_same(solve_system(sys, 40, "exact"), batch[i])


@pytest.mark.parametrize("change, message", [
    ({"viscous.C": math.nan}, "parameter C = nan is not finite"),
    ({"viscous.C": -1.0}, "C must be >= 0"),
    ({"escapement[2].X": math.inf}, "escapement magnitudes must be finite"),
])
def test_refusals_match_the_single_set_solver(change, message):
    scene = escfit.load_scene(MONDAY)
    bad = scene.build(change)
    with pytest.raises(SolverError, match="parameter set 1: .*" + message.replace("(", r"\(")):
        solve_batch([scene.build(), bad], 10)
    with pytest.raises(SolverError) as single:
        solve_system(bad, 10, "exact")
    batch = solve_batch([scene.build(), bad], 10, throw=False)
    assert list(batch.status) == ["ok", "failed"]
    assert batch[1].message == str(single.value)
    assert batch.n_done[1] == 0 and np.all(np.isnan(batch.amplitude[1]))


def test_phase_batch_refuses_overdamping_like_the_single_solver():
    scene = escfit.load_scene("phase.toml", text=PHASE)
    bad = scene.build({"viscous.C": 40.0})
    batch = solve_batch([bad, scene.build()], 10, throw=False)
    assert list(batch.status) == ["failed", "ok"]
    assert "C < 2*omega0" in batch.message[0]


def test_sets_of_any_structure_share_a_batch_and_bad_requests_are_refused():
    """Every set carries its whole coefficient record, so sets of different scenes share a batch
    and each gives its one-set result; what the batch cannot run is refused before any work."""
    a = escfit.load_scene(MONDAY).build()
    b = escfit.load_scene("rich.toml", text=RICH).build()
    batch = solve_batch([a, b], 40)
    for i, sys in enumerate([a, b]):
        _assert_same(solve_system(sys, 40, "exact"), batch[i])
    with pytest.raises(SolverError, match="at least one parameter set"):
        System.stack([])
    with pytest.raises(SolverError, match="n_swings"):
        solve_batch([a], 0)
    with pytest.raises(SolverError, match="one switching law"):
        solve_batch([a, escfit.load_scene("phase.toml", text=PHASE).build()], 3)


def test_every_record_field_reaches_the_batch_path():
    """A field the scene fills is never left out of the stacked records: the batch of one scene's
    sets built in one pass (scene.system(values, n)) holds, field by field, what building each
    set alone gives."""
    scene = escfit.load_scene("rich.toml", text=RICH)
    rng = np.random.default_rng(5)
    free = [p for p in scene.params if p.tie is None and p.name != "oscillator.theta0"]
    rows = [{p.name: p.value * (1 + 0.2 * rng.random()) for p in free} for _ in range(5)]
    base = scene.params.values()
    arrays = {**base, **{p.name: np.array([r[p.name] for r in rows]) for p in free}}
    many = scene.system(arrays, 5)
    for i, r in enumerate(rows):
        one = scene.system({**base, **r})
        for name in many.k.dtype.names:
            np.testing.assert_array_equal(many.k[name][i], one.k[name][0], err_msg=name)


# -- the vectorised posterior --------------------------------------------------------------

@pytest.fixture(scope="module")
def problem():
    scene = escfit.load_scene(MONDAY)
    data = record_unit_curve(scene, every=4, swings=120, notch_deg=6, sigma=0.03, seed=11)
    return FitProblem(scene, data)


def test_log_prob_many_equals_log_prob_row_by_row(problem):
    rng = np.random.default_rng(4)
    vecs = problem.initial * (1 + 0.5 * rng.standard_normal((60, len(problem.names))))
    vecs[3, 0] = -0.1  # outside the prior
    vecs[7, 1] = math.nan  # refused by the solver: counted as a failure
    vecs[9, 2] = 1e9  # outside the prior
    problem.failures.clear()
    many = problem.log_prob_many(vecs)
    failures_many = dict(problem.failures)
    problem.failures.clear()
    one = np.array([problem.log_prob(v) for v in vecs])
    np.testing.assert_array_equal(many, one)
    assert failures_many == dict(problem.failures)
    assert np.isinf(many[[3, 7, 9]]).all() and np.isfinite(many).sum() >= 50


def test_out_of_segments_falls_back_to_the_scalar_failure(problem):
    tight = FitProblem(problem.scene, problem.data, solver_options={"max_segments": 10})
    vecs = np.array([tight.initial, tight.initial * 1.01])
    many = tight.log_prob_many(vecs)
    failures_many = dict(tight.failures)
    tight.failures.clear()
    one = np.array([tight.log_prob(v) for v in vecs])
    np.testing.assert_array_equal(many, one)
    assert failures_many == dict(tight.failures) and any("out of segments" in k for k in failures_many)


def test_emcee_vectorised_draws_are_the_per_walker_draws(problem):
    assert problem.vectorized
    fast = run_emcee(problem, None, walkers=10, steps=40, seed=3)
    slow = run_emcee(problem, None, walkers=10, steps=40, seed=3, vectorize=False)
    np.testing.assert_array_equal(fast.chain, slow.chain)
    np.testing.assert_array_equal(fast.log_prob, slow.log_prob)


def test_vectorisation_is_declared_by_the_problem_and_can_be_turned_off(problem, monkeypatch):
    """The whole-array path is the problem's declaration (exact solver), not guessed; a caller
    replacing log_prob turns it off explicitly and then every walker is evaluated one by one."""
    assert not FitProblem(problem.scene, problem.data, solver="rk4", solver_options={"h": 1e-4}).vectorized
    calls = []
    original = FitProblem.log_prob

    def counting(self, vec):
        calls.append(1)
        return original(self, vec)

    monkeypatch.setattr(FitProblem, "log_prob", counting)
    run_emcee(problem, None, walkers=8, steps=10, seed=1, vectorize=False)
    assert len(calls) >= 8 * 10
