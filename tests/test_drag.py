"""Quadratic air drag ``[effects.drag] D`` against independent references.

- a scipy solve_ivp integration of the same balance-frame equation, written out in
  :mod:`tests.effects_reference` (turning points to 1e-10 rad; measured: below 1e-12);
- the decrement per half swing at small damping, ``4 D A**2 / 3``: the energy lost over a half
  swing ``D * integral |theta'|**3 dt = (4/3) D omega0**2 A**3`` divided by ``dE/dA = omega0**2 A``
  (in the averaged form ``A_n - A_{n+1} = (4 D / 3) A_n A_{n+1}``, which the averaged equation
  ``dA/dn = -(4 D / 3) A**2`` integrates to over one half swing);
- that the laws stay apart: the decrement grows with A**2 under drag, with A under viscous
  damping and not at all under Coulomb friction.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import escfit
from escfit.balance import default_solver, solve
from escfit.balance.batch import solve_batch
from escfit.core.errors import SceneError, SolverError

from .conftest import balance_toml
from .effects_reference import reference_turns, scene

INTEGRATORS = {"dop853": {"rtol": 1e-13}, "ivp": {"rtol": 1e-12, "atol": 1e-14}, "rk4": {"h": 2e-5}}


@pytest.mark.parametrize("solver", sorted(INTEGRATORS))
@pytest.mark.parametrize("effects", [{"D": 0.2}, {"D": 0.1, "C": 0.3, "R": 2.0}, {"D": 0.05, "k3": 0.2, "R": 1.0}],
                         ids=["drag", "drag+viscous+coulomb", "drag+stiffening+coulomb"])
def test_drag_matches_solve_ivp(solver, effects):
    w0, th0 = 10.0, 2.0
    ref, ref_t = reference_turns(w0, th0, 12, **effects)
    tr = solve(scene(w0=w0, theta0=th0, **effects), solver, **INTEGRATORS[solver])
    assert len(tr.theta_turn) == len(ref) > 4
    np.testing.assert_allclose(tr.theta_turn, ref, rtol=0, atol=1e-10)
    np.testing.assert_allclose(tr.time, ref_t, rtol=1e-11)


def test_drag_decrement_per_half_swing_is_four_thirds_d_a_squared():
    w0, D = 10.0, 1e-3
    tr = solve(scene(w0=w0, theta0=1.0, swings=40, D=D), "dop853", rtol=1e-13)
    a = np.concatenate([[1.0], tr.amplitude])
    # the averaging error is of order (D A)**2 ~ 1e-6; measured 1.8e-7
    np.testing.assert_allclose(a[:-1] - a[1:], 4.0 * D / 3.0 * a[:-1] * a[1:], rtol=1e-6)
    mean = 0.5 * (a[:-1] + a[1:])
    np.testing.assert_allclose(a[:-1] - a[1:], 4.0 * D * mean**2 / 3.0, rtol=1e-5)


def test_the_three_laws_have_decrements_of_different_powers_of_the_amplitude():
    """Decrement against amplitude over a decay from 2 to ~0.5 rad: the log-log slope is 0
    for Coulomb friction, 1 for viscous damping and 2 for air drag."""
    slopes = {}
    for law, eff in {"coulomb": {"R": 0.3}, "viscous": {"C": 0.02}, "drag": {"D": 2e-3}}.items():
        tr = solve(scene(w0=10.0, theta0=2.0, swings=200, **eff), "dop853", rtol=1e-12)
        a = np.concatenate([[2.0], tr.amplitude])
        mean, dec = 0.5 * (a[:-1] + a[1:]), a[:-1] - a[1:]
        keep = mean > 0.5
        slopes[law] = np.polyfit(np.log(mean[keep]), np.log(dec[keep]), 1)[0]
    assert slopes["coulomb"] == pytest.approx(0.0, abs=0.01)
    assert slopes["viscous"] == pytest.approx(1.0, abs=0.01)
    assert slopes["drag"] == pytest.approx(2.0, abs=0.01)


def test_exact_and_the_batch_path_refuse_drag_naming_dop853():
    sc = scene(D=0.1)
    assert default_solver(sc) == "dop853"
    with pytest.raises(SolverError, match=r"'exact' has no closed form for \[effects.drag\].*'dop853'"):
        solve(sc, "exact")
    with pytest.raises(SolverError, match=r"\[effects.drag\].*'dop853'"):
        solve_batch([sc.build()], 4)


def test_passage_times_with_drag_come_from_the_integrator():
    """A photo-cell's crossings of a drag scene: the dense solution of dop853, at the levels."""
    sc = scene(D=0.1, C=0.2)
    tr = solve(sc, dense=True)
    assert tr.solver == "dop853"
    m = np.repeat(np.arange(1, 9), 3)
    levels = np.tile([-0.5, 0.0, 0.5], 8)
    t = tr.dense.crossings(m, levels)
    s = np.where(m % 2 == 1, -1.0, 1.0)  # released at +2 rad: the first half swing runs down
    np.testing.assert_allclose(s * tr.dense.theta(t), levels, rtol=0, atol=1e-9)


def test_drag_scene_keys_are_checked():
    with pytest.raises(SceneError, match="drag.*switching = 'angle'"):
        escfit.load_scene("bad.toml", text=balance_toml(switching="phase", effects="[effects.drag]\nD = 0.1\n"))
    with pytest.raises(SceneError, match=r"\[effects.drag\]"):
        escfit.load_scene("bad.toml", text=balance_toml(effects="[effects.drag]\nD = -0.1\n"))
    # D in 1/deg is converted: 0.01 per degree is 0.573 per radian
    sc = escfit.load_scene("deg.toml", text=balance_toml(effects='[effects.drag]\nD = "0.01 / deg"\n'))
    assert sc.params["drag.D"].value == pytest.approx(0.01 * 180.0 / math.pi)


def test_a_least_squares_fit_recovers_drag_and_viscous_damping_from_turning_points():
    """The whole path with a smooth torque: scene -> records -> dop853 (the scene's default) ->
    amplitude readings -> least squares.  Every half swing read with 1e-4 rad noise (seed fixed):
    D and C come back within 4 standard errors, and the fit does not invent Coulomb friction."""
    from escfit.balance.problems.curves import FitProblem
    from escfit.balance.synthetic.unit_curves import record_unit_curve
    from escfit.inference import least_squares

    truth = {"drag.D": 0.02, "viscous.C": 0.05}
    text = balance_toml(omega0=6.0, theta0=1.5, swings=80, effects=(
        "[effects.viscous]\nC = { value = 0.05, vary = true, min = 0, max = 1 }\n"
        "[effects.coulomb]\nR = { value = 0.0, vary = true, min = 0, max = 1 }\n"
        "[effects.drag]\nD = { value = 0.02, vary = true, min = 0, max = 1 }\n"))
    sc = escfit.load_scene("drag_fit.toml", text=text)
    data = record_unit_curve(sc, every=1, sigma=1e-4, seed=3)
    start = sc.with_values({"drag.D": 0.01, "viscous.C": 0.08, "coulomb.R": 0.01})
    problem = FitProblem(start, data)
    assert problem.solver == "dop853" and not problem.vectorized
    res = least_squares(problem, n_starts=2)
    est = dict(zip(res.names, zip(res.value, res.stderr)))
    for name, true in truth.items():
        v, se = est[name]
        assert abs(v - true) < 4 * se and se < 0.1 * true, (name, v, se)
    r, se_r = est["coulomb.R"]
    assert r < 4 * se_r + 1e-9, (r, se_r)
