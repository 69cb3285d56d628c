"""Numerically hard cases: correct answers or a clear status, never NaN or a hang."""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.balance import solve

WINDOWS = """
[[effects.escapement]]
kind = "unlock"
from = -0.6
to = -0.3
X = {xu}
[[effects.escapement]]
kind = "impulse"
from = -0.3
to = 0.3
X = {xi}
"""


def _finite(traj):
    for a in (traj.amplitude, traj.half_period, traj.time):
        assert np.all(np.isfinite(a))


@pytest.mark.parametrize("factor", [2.0, 2.0 * (1 + 1e-12), 2.0 * (1 - 1e-12), 3.0, 50.0])
def test_critical_and_overdamped_creep_to_rest(make_scene, factor):
    w0 = 10.0
    traj = solve(make_scene(omega0=w0, theta0=1.0, effects=f"[effects.viscous]\nC = {factor * w0!r}\n"))
    _finite(traj)
    # barely underdamped (factor < 2) included: the turn would come 10^6 s later, exp(-2e6) past
    # the rest position, so it is a creep to rest like the critical and overdamped cases
    assert traj.status == "stopped" and len(traj.amplitude) == 0
    assert math.isfinite(traj.final[1]) and abs(traj.final[1]) < 1e-9


CRITICAL_WITH_FRICTION = "[effects.viscous]\nC = {C!r}\n[effects.coulomb]\nR = 1.0\n"
SOLVERS = ("exact", "dop853", "rk4", "ivp")


@pytest.mark.parametrize("solver", SOLVERS)
def test_near_critical_creep_is_a_stop_for_every_solver(make_scene, solver):
    # omega0 = 10, C = 2 omega0 (1 - 1e-8): the closed form turns after pi/omega_d = 2221 s, exp(-22214) past
    # the rest position R/omega0**2: no recorder sees that turn, and every solver says "stopped"
    options = {"rk4": {"h": 1e-4}}.get(solver, {})
    traj = solve(make_scene(omega0=10.0, theta0=1.0, effects=CRITICAL_WITH_FRICTION.format(C=19.9999998)),
                 solver, **options)
    assert traj.status == "stopped" and len(traj.amplitude) == 0


@pytest.mark.parametrize("solver", SOLVERS)
def test_heavily_damped_visible_overshoot_is_a_swing_for_every_solver(make_scene, solver):
    # damping ratio 0.95: the first turn overshoots the rest position theta_e = R/omega0**2 by
    # (theta0 - theta_e) exp(-pi zeta / sqrt(1 - zeta**2)) = 7.0e-5 rad, which the rule keeps as a swing;
    # the turn lies inside the friction band |theta| <= theta_e, so the balance then stops there
    w0, zeta, theta0 = 10.0, 0.95, 1.0
    theta_e = 1.0 / w0**2
    q = math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2))
    expected = theta_e - (theta0 - theta_e) * q
    options = {"rk4": {"h": 1e-4}}.get(solver, {})
    traj = solve(make_scene(omega0=w0, theta0=theta0, effects=CRITICAL_WITH_FRICTION.format(C=2 * zeta * w0)),
                 solver, **options)
    assert traj.status == "stopped" and len(traj.amplitude) == 1
    assert traj.amplitude[0] == pytest.approx(expected, rel=1e-6)
    assert traj.half_period[0] == pytest.approx(math.pi / (w0 * math.sqrt(1 - zeta**2)), rel=1e-6)


def test_overdamped_with_impulse_keeps_going(make_scene):
    # an impulse strong enough to push an overdamped balance through the windows
    w0 = 10.0
    traj = solve(make_scene(omega0=w0, theta0=1.0, swings=20,
                            effects=f"[effects.viscous]\nC = 25.0\n" + WINDOWS.format(xu=10.0, xi=2000.0)))
    _finite(traj)
    assert traj.status in ("ok", "stopped")


@pytest.mark.parametrize("C, R", [(0.0, 0.0), (0.0, 5.0), (1.0, 0.0)])
def test_zero_damping_and_zero_friction(make_scene, C, R):
    traj = solve(make_scene(omega0=10.0, theta0=1.0, swings=50,
                            effects=f"[effects.viscous]\nC = {C}\n[effects.coulomb]\nR = {R}\n" + WINDOWS.format(xu=10.0, xi=80.0)))
    _finite(traj)
    assert traj.status == "ok" and len(traj.amplitude) == 50


def test_turning_point_inside_a_window_and_on_its_edge(make_scene):
    # amplitude that decays into the impulse window: turning points end up inside it
    traj = solve(make_scene(omega0=10.0, theta0=1.0, swings=200,
                            effects="[effects.coulomb]\nR = 40.0\n" + WINDOWS.format(xu=0.0, xi=30.0)))
    _finite(traj)
    # release exactly on a window edge, and a turning point landing exactly on an edge
    for th0 in (0.3, 0.6, -0.3):
        t2 = solve(make_scene(omega0=10.0, theta0=th0, swings=20, effects=WINDOWS.format(xu=5.0, xi=50.0)))
        _finite(t2)
        assert t2.status in ("ok", "stopped")


def test_grazing_turning_point_at_edge(make_scene):
    # pure Coulomb: the first turn is at -(theta0 - 2r); place the window edge exactly there
    w0, R, th0 = 10.0, 10.0, 1.0  # r = 0.1, first turn at -0.8 -> swing frame x = +0.8
    eff = f"[effects.coulomb]\nR = {R}\n[[effects.escapement]]\nkind = \"impulse\"\nfrom = 0.8\nto = 0.9\nX = 50.0\n"
    traj = solve(make_scene(omega0=w0, theta0=th0, swings=4, effects=eff))
    _finite(traj)
    assert traj.amplitude[0] == pytest.approx(0.8, abs=1e-12)


def test_banking_clips_amplitude_and_flags(make_scene):
    eff = WINDOWS.format(xu=5.0, xi=400.0) + "[effects.banking]\nangle = 1.2\nrestitution = 0.5\n"
    traj = solve(make_scene(omega0=10.0, theta0=1.0, swings=50, effects=eff))
    _finite(traj)
    assert traj.status == "banked"
    assert traj.banked.any()
    assert np.all(traj.amplitude <= 1.2 + 1e-12)
    np.testing.assert_allclose(traj.amplitude[traj.banked], 1.2, atol=1e-12)


@pytest.mark.parametrize("e", [0.0, 1.0])
def test_banking_restitution_limits(make_scene, e):
    eff = f"[effects.viscous]\nC = 0.1\n[effects.banking]\nangle = 0.5\nrestitution = {e}\n"
    traj = solve(make_scene(omega0=10.0, theta0=0.5, swings=10, effects=eff))
    _finite(traj)
    assert traj.status in ("ok", "banked")


@pytest.mark.parametrize("scale", [1e-12, 1e6])
def test_tiny_and_huge_parameters(make_scene, scale):
    w0 = 10.0 * scale if scale > 1 else 10.0
    eff = (f"[effects.viscous]\nC = {0.1 * scale!r}\n[effects.coulomb]\nR = {1e-3 * scale!r}\n"
           + WINDOWS.format(xu=repr(1e-3 * scale), xi=repr(1e-2 * scale)))
    traj = solve(make_scene(omega0=w0, theta0=1.0, swings=40, effects=eff))
    _finite(traj)
    assert traj.status in ("ok", "stopped")


def test_many_stops_and_restarts_bounded_time(make_scene):
    # an impulse that restarts the balance from rest at every turn inside the window
    traj = solve(make_scene(omega0=10.0, theta0=0.25, swings=5000,
                            effects="[effects.coulomb]\nR = 20.0\n" + WINDOWS.format(xu=0.0, xi=25.0)))
    _finite(traj)


def test_phase_mode_refuses_overdamping(make_scene):
    from escfit.core.errors import SolverError

    with pytest.raises(SolverError, match="C < 2\\*omega0"):
        solve(make_scene(omega0=1.0, theta0=1.0, switching="phase", effects="[effects.viscous]\nC = 2.0\n"))


def test_phase_breakdown_status(make_scene):
    traj = solve(make_scene(omega0=1.0, theta0=1.0, switching="phase", effects="[effects.coulomb]\nR = 2.0\n"))
    assert traj.status == "phase_breakdown"
    _finite(traj)


def test_ivp_locates_an_edge_passed_and_turned_back_within_one_step(make_scene):
    # found by the stability suite: swing 5 leaves the unlock window at x = -0.28726 so slowly
    # that DOP853 passes the edge and turns within one step; without locating that crossing
    # the turning point came out at x = -0.28477, in the unlock window's dynamics, and the run
    # stopped there instead of going on to an amplitude of 1.1107 rad
    effects = """
[effects.coulomb]
R = 1.0141620678513064
[[effects.escapement]]
kind = "impulse"
from = -0.1393904175977709
to = 0.1393904175977709
X = 68.18952762075706
[[effects.escapement]]
kind = "unlock"
from = -0.6256583410030291
to = -0.2872560809465752
X = 74.80456357959548
"""
    scene = make_scene(omega0=5.554423127538406, theta0=2.0853158787438373, effects=effects)
    exact = solve(scene, swings=8)
    ivp = solve(scene, "ivp", swings=8, method="DOP853", rtol=1e-11, atol=1e-13)
    assert exact.amplitude[4] == pytest.approx(1.11073636, abs=1e-8)
    assert ivp.status == exact.status and len(ivp.amplitude) == len(exact.amplitude)
    np.testing.assert_allclose(ivp.amplitude, exact.amplitude, rtol=0, atol=1e-9)
    np.testing.assert_allclose(ivp.half_period, exact.half_period, rtol=1e-9)
