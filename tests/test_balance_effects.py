"""Effects beyond the closed forms: hairspring, damping drift, dense output."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

import escfit
from escfit.balance import dense_output, solve

from .conftest import balance_toml


def test_piecewise_hairspring_half_period_matches_quadrature():
    # conservative balance, stiffer beyond +-0.5 rad: half period from energy conservation
    w_in, w_out, b, a0 = 10.0, 14.0, 0.5, 1.2
    text = balance_toml(theta0=a0, swings=4, effects=f"[effects.hairspring]\nangles = [{-b}, {b}]\n"
                                                   f"omega0 = [{w_out}, {w_in}, {w_out}]\n").replace("omega0 = 10.0\n", "", 1)
    traj = solve(escfit.load_scene("spring.toml", text=text))

    def potential(x):
        x = abs(x)
        return 0.5 * w_in**2 * x**2 if x <= b else 0.5 * w_in**2 * b**2 + w_in**2 * b * (x - b) + 0.5 * w_out**2 * (x - b) ** 2

    e = potential(a0)
    f = lambda x: 1.0 / math.sqrt(max(2.0 * (e - potential(x)), 1e-300))  # noqa: E731
    # integrate with the endpoint singularity handled by a substitution-friendly split
    half = 2 * (integrate.quad(f, 0, b)[0] + integrate.quad(f, b, a0, limit=200)[0])
    np.testing.assert_allclose(traj.amplitude, a0, rtol=1e-12)
    assert traj.half_period[0] == pytest.approx(half, rel=1e-7)
    assert traj.half_period[0] < math.pi / w_in  # a stiffer outer spring runs fast at large amplitude


def test_viscous_drift_follows_monday_bands():
    # phase switching: every half cycle lasts pi/omega1, which reveals the current C
    w0, c0 = 10.0, 0.4
    eff = f"[effects.viscous]\nC = {c0}\n[effects.viscous_drift]\nthresholds = [0.15, 0.03, 0.005]\nrates = [0.03, 0.015, 0.005, 0.0]\n"
    traj = solve(escfit.load_scene("drift.toml", text=balance_toml(omega0=w0, swings=400, switching="phase", effects=eff)))
    c = 2 * np.sqrt(w0**2 - (math.pi / traj.half_period) ** 2)
    c_cycle = c[::2]
    growth = c_cycle[1:] / c_cycle[:-1] - 1
    env = np.exp(-0.5 * np.cumsum(c[1::2] * traj.half_period[1::2] + c[::2] * traj.half_period[::2]))[:-1]
    expected = np.select([env > 0.15, env > 0.03, env > 0.005], [0.03, 0.015, 0.005], 0.0)
    np.testing.assert_allclose(growth, expected, atol=1e-9)
    assert c_cycle[0] == pytest.approx(c0) and c_cycle[-1] > c0 * 1.2


def test_dense_output_passes_through_the_turning_points():
    scene = escfit.load_scene("sample.toml", text=balance_toml(
        omega0=16.174, theta0=6.28, swings=6, effects="[effects.viscous]\nC = 0.833\n[effects.coulomb]\nR = 30.0\n"))
    traj = solve(scene, dense=True)
    ds = dense_output(traj)
    for t, th in zip(traj.time, traj.theta_turn):
        i = int(np.argmin(np.abs(ds.t.values - t)))
        assert ds.theta.values[i] == pytest.approx(th, abs=1e-12)
        assert abs(ds.omega.values[i]) < 1e-9
    assert np.all(np.diff(ds.t.values) >= 0)
