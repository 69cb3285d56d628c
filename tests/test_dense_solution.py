"""Every solver's dense solution: theta(t), theta'(t), level crossings and turning points.

The references are independent of the solvers: the closed form of a damped oscillator, and for
the friction and escapement scene the exact solver's own dense solution (closed form per
segment), which each integrating solver must reproduce to its tolerance.  Passage-time and
timegrapher fits read only this interface, so any solver can serve them.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import escfit
from escfit.balance import solve
from escfit.core.errors import SolverError

from .conftest import balance_toml

W0, C, TH0 = 7.0, 0.6, 1.3
DAMPED = balance_toml(omega0=W0, theta0=TH0, swings=12, effects=f"[effects.viscous]\nC = {C}\n")
WINDOWS = ('[[effects.escapement]]\nkind = "unlock"\nfrom = -0.6\nto = -0.3\nX = 40.0\n'
           '[[effects.escapement]]\nkind = "impulse"\nfrom = -0.3\nto = 0.3\nX = 400.0\n')
RICH = balance_toml(omega0=16.174, theta0=3.0, swings=12,
                    effects="[effects.viscous]\nC = 0.833\n[effects.coulomb]\nR = 30.0\n" + WINDOWS)
OPTIONS = {"exact": {}, "dop853": {"rtol": 1e-12}, "rk4": {"h": 2e-5}, "ivp": {"rtol": 1e-12, "atol": 1e-14}}
TOL = {"exact": 1e-12, "dop853": 1e-9, "rk4": 1e-9, "ivp": 1e-8}


def _damped(t):
    wd = math.sqrt(W0**2 - C**2 / 4)
    e = np.exp(-C * t / 2)
    theta = TH0 * e * (np.cos(wd * t) + C / (2 * wd) * np.sin(wd * t))
    omega = -TH0 * e * (W0**2 / wd) * np.sin(wd * t)
    return theta, omega


@pytest.mark.parametrize("solver", sorted(OPTIONS))
def test_theta_and_omega_match_the_damped_oscillator(solver):
    traj = solve(escfit.load_scene("d.toml", text=DAMPED), solver, dense=True, **OPTIONS[solver])
    t = np.sort(np.random.default_rng(1).uniform(0.0, traj.time[-1], 400))
    theta, omega = traj.dense.state(t)
    ref_theta, ref_omega = _damped(t)
    np.testing.assert_allclose(theta, ref_theta, rtol=0, atol=TOL[solver])
    np.testing.assert_allclose(omega, ref_omega, rtol=0, atol=TOL[solver] * W0)
    # unsorted times give the same values, and theta'(t) is the derivative of theta(t)
    perm = np.random.default_rng(2).permutation(t.size)
    np.testing.assert_array_equal(traj.dense.theta(t[perm]), theta[perm])
    h = 1e-6
    mid = t[(t > h) & (t < traj.time[-1] - h)][:50]
    slope = (traj.dense.theta(mid + h) - traj.dense.theta(mid - h)) / (2 * h)
    np.testing.assert_allclose(slope, traj.dense.omega(mid), rtol=0, atol=1e-5 * W0 * TH0)


@pytest.mark.parametrize("solver", sorted(OPTIONS))
def test_every_solver_reproduces_the_exact_dense_solution_with_friction_and_windows(solver):
    scene = escfit.load_scene("rich.toml", text=RICH)
    ref = solve(scene, "exact", dense=True)
    traj = solve(scene, solver, dense=True, **OPTIONS[solver])
    assert traj.status == ref.status == "ok"
    t = np.linspace(0.0, ref.time[-1], 997)
    np.testing.assert_allclose(traj.dense.theta(t), ref.dense.theta(t), rtol=0, atol=TOL[solver] * 3)
    # crossings of window edges and of zero, in the swing frame of each half swing
    m = np.repeat(np.arange(1, 13), 4)
    levels = np.tile([-0.45, -0.3, 0.0, 0.3], 12)
    got, expected = traj.dense.crossings(m, levels), ref.dense.crossings(m, levels)
    np.testing.assert_allclose(got, expected, rtol=0, atol=TOL[solver] * 30)
    # the angle at a crossing is the level, in the scene's frame
    s = np.where(m % 2 == 1, -1.0, 1.0)  # released at +3 rad: the first half swing runs down
    np.testing.assert_allclose(s * traj.dense.theta(got), levels, rtol=0, atol=TOL[solver] * 30)
    tp_t, tp_theta = traj.dense.turning_points()
    np.testing.assert_array_equal(tp_t, traj.time)
    np.testing.assert_array_equal(tp_theta, traj.theta_turn)


@pytest.mark.parametrize("solver", ["exact", "dop853", "ivp", "rk4"])
def test_after_a_stop_the_balance_stays_at_rest_and_unreached_levels_clamp(solver):
    scene = escfit.load_scene("c.toml", text=balance_toml(omega0=10.0, theta0=1.0, swings=50,
                                                          effects="[effects.coulomb]\nR = 30.0\n"))
    traj = solve(scene, solver, dense=True, **OPTIONS[solver])
    assert traj.status == "stopped"
    later = traj.time[-1] + np.array([0.1, 1.0, 10.0])
    theta, omega = traj.dense.state(later)
    np.testing.assert_allclose(theta, traj.theta_turn[-1], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(omega, 0.0)
    # a level beyond the turning point clamps to it, one behind the start to the start
    t = traj.dense.crossings(np.array([2, 2]), np.array([10.0, -10.0]))
    np.testing.assert_allclose(t, [traj.time[1], traj.time[0]], rtol=0, atol=1e-12)
    assert np.isnan(traj.dense.crossings(np.array([len(traj.time) + 1]), np.array([0.0]))).all()


def test_naive_rk4_has_no_dense_solution():
    with pytest.raises(SolverError, match="locate_events=True"):
        solve(escfit.load_scene("d.toml", text=DAMPED), "rk4", h=1e-4, locate_events=False, dense=True)


def test_dop853_continuous_extension_is_of_order_seven():
    """The continuous extension inside one DOP853 step, against the damped oscillator's closed
    form: it starts at the step's start, and its error at interior points falls as h**8 (a
    polynomial of order 7: halving the step divides the error by about 256, where the step's
    own end, of order 8, gains about 512)."""
    from escfit.balance.kernel_records import blank
    from escfit.balance.steps import N_EXTENDED, dop853_extension, extension_at

    k = blank(1)
    k["c"] = C
    regime = (W0 * W0, 0.0, k[0])
    coef = np.empty((7, 2))
    stages = (np.empty(N_EXTENDED), np.empty(N_EXTENDED))
    errors = []
    for h in (0.12, 0.06):  # omega0 h = 0.84 and 0.42 rad
        dop853_extension((TH0, 0.0, -W0 * W0 * TH0), h, regime, stages, coef)  # released at rest
        r = np.linspace(0.0, 1.0, 41)
        x, v = np.array([extension_at(coef, TH0, 0.0, ri) for ri in r]).T
        theta, omega = _damped(r * h)
        assert x[0] == TH0 and v[0] == 0.0
        errors.append(np.max(np.maximum(np.abs(x - theta), np.abs(v - omega) / W0)))
    assert 150.0 < errors[0] / errors[1] < 400.0 and errors[1] < 2e-9
