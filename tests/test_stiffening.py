"""The stiffening (cubic, Duffing) spring ``[effects.stiffening] k3`` against independent references.

The period of the undamped Duffing oscillator is ``4 K(m) / (omega0 sqrt(1 + k3 A**2))`` with
``m = k3 A**2 / (2 (1 + k3 A**2))`` (``K`` the complete elliptic integral of the first kind);
with damping the turning points are compared with a scipy solve_ivp integration of the same
equation written out in :mod:`tests.effects_reference`.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ellipk

import escfit
from escfit.balance import solve
from escfit.core.errors import SceneError, SolverError

from .conftest import balance_toml
from .effects_reference import reference_turns, scene

INTEGRATORS = {"dop853": {"rtol": 1e-13}, "ivp": {"rtol": 1e-12, "atol": 1e-14}, "rk4": {"h": 2e-5}}


# -- the stiffening spring ------------------------------------------------------------------------

@pytest.mark.parametrize("k3, amp", [(0.1, 1.0), (0.5, 2.0), (2.0, 0.7)])
def test_stiffening_period_is_the_duffing_elliptic_integral(k3, amp):
    w0 = 10.0
    m = k3 * amp**2 / (2.0 * (1.0 + k3 * amp**2))
    half = 2.0 * float(ellipk(m)) / (w0 * math.sqrt(1.0 + k3 * amp**2))
    sc = scene(w0=w0, theta0=amp, swings=6, k3=k3)
    tr = solve(sc, "dop853", rtol=1e-13)
    np.testing.assert_allclose(tr.half_period, half, rtol=1e-12)  # measured: 2e-14
    np.testing.assert_allclose(tr.amplitude, amp, rtol=1e-12)
    assert half < math.pi / w0  # the stiffening spring runs fast at large amplitude
    for solver, tol in (("ivp", 1e-11), ("rk4", 1e-11)):  # the shared torque: no per-effect code
        other = solve(sc, solver, **INTEGRATORS[solver])
        np.testing.assert_allclose(other.half_period, half, rtol=tol)


@pytest.mark.parametrize("solver", sorted(INTEGRATORS))
def test_stiffening_with_friction_matches_solve_ivp(solver):
    w0, th0, C, R, k3 = 10.0, 2.0, 0.4, 3.0, 0.3
    ref, ref_t = reference_turns(w0, th0, 12, C=C, R=R, k3=k3)
    tr = solve(scene(w0=w0, theta0=th0, C=C, R=R, k3=k3), solver, **INTEGRATORS[solver])
    assert len(tr.theta_turn) == 12
    np.testing.assert_allclose(tr.theta_turn, ref, rtol=0, atol=1e-10)  # measured: below 1e-12 rad
    np.testing.assert_allclose(tr.time, ref_t, rtol=1e-11)


def test_exact_refuses_a_stiffening_spring_naming_dop853():
    sc = scene(k3=0.2)
    assert escfit.balance.default_solver(sc) == "dop853"
    with pytest.raises(SolverError, match=r"'exact' has no closed form for \[effects.stiffening\].*'dop853'"):
        solve(sc, "exact")


def test_stiffening_needs_angle_switching():
    text = balance_toml(switching="phase", effects="[effects.stiffening]\nk3 = 0.1\n")
    with pytest.raises(SceneError, match="stiffening.*switching = 'angle'"):
        escfit.load_scene("bad.toml", text=text)
