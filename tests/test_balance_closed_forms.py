"""Closed-form cases of the balance equation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.balance import solve


def test_pure_coulomb_loses_2r_per_half_swing_then_stops(make_scene):
    w0, R, th0 = 10.0, 3.0, 1.0
    traj = solve(make_scene(omega0=w0, theta0=th0, swings=100, effects=f"[effects.coulomb]\nR = {R}\n"))
    r = R / w0**2
    n = len(traj.amplitude)
    expected = th0 - 2 * r * np.arange(1, n + 1)
    np.testing.assert_allclose(traj.amplitude, np.abs(expected), atol=1e-12)
    assert traj.status == "stopped"
    # it stops at the first turning point where friction can hold it: w0^2 |theta| <= R
    assert w0**2 * traj.amplitude[-1] <= R + 1e-12
    assert all(w0**2 * a > R for a in traj.amplitude[:-1])
    # each half swing of pure Coulomb motion lasts exactly pi/omega0
    np.testing.assert_allclose(traj.half_period, math.pi / w0, rtol=1e-12)


def test_same_side_turning_point(make_scene):
    # r = 0.3, theta0 = 0.5: first turn at -(0.5 - 0.6) = +0.1, same side as the release
    traj = solve(make_scene(omega0=10.0, theta0=0.5, swings=10, effects="[effects.coulomb]\nR = 30.0\n"))
    assert traj.theta_turn[0] == pytest.approx(0.1, abs=1e-12)
    assert traj.status == "stopped" and len(traj.amplitude) == 1


@pytest.mark.parametrize("C, R", [(0.3, 2.0), (1.7, 0.5), (0.0, 4.0), (2.5, 0.0)])
def test_viscous_plus_coulomb_recurrence(make_scene, C, R):
    w0, th0 = 10.0, 3.0
    traj = solve(make_scene(omega0=w0, theta0=th0, swings=60,
                            effects=f"[effects.viscous]\nC = {C}\n[effects.coulomb]\nR = {R}\n"))
    r = R / w0**2
    q = math.exp(-math.pi * C / (2 * math.sqrt(w0**2 - C**2 / 4)))
    a = th0
    for got in traj.amplitude:
        a = (a - r) * q - r
        assert got == pytest.approx(a, abs=1e-10)


def test_pure_viscous_half_cycle_decay(make_scene):
    C, w0 = 0.8, 5.0
    traj = solve(make_scene(omega0=w0, theta0=2.0, swings=30, effects=f"[effects.viscous]\nC = {C}\n"))
    w1 = math.sqrt(w0**2 - C**2 / 4)
    np.testing.assert_allclose(traj.amplitude[1:] / traj.amplitude[:-1], math.exp(-math.pi * C / (2 * w1)), rtol=1e-12)
    np.testing.assert_allclose(traj.half_period, math.pi / w1, rtol=1e-12)
