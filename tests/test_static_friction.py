"""Static friction (``[effects.coulomb] R_static``) and the decrements of Coulomb and viscous damping.

References independent of escfit's solvers: pure Coulomb friction's turning points
``theta0 - 2 n R/omega0**2``, which static friction ends at the first half swing ``n`` with
``omega0**2 (theta0 - 2 n R/omega0**2) <= R_static``; the viscous-plus-Coulomb recurrence
``A' = q (A - r) - r`` with ``q = exp(-pi C / (2 omega1))``; a scipy solve_ivp integration of the
equation (:mod:`tests.effects_reference`); the decrements per half swing at small damping,
Coulomb ``2R/omega0**2`` and viscous ``pi C A / (2 omega0)``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import escfit
from escfit.balance import solve
from escfit.core.errors import SceneError, SolverError

from .conftest import balance_toml
from .effects_reference import reference_turns, scene

INTEGRATORS = {"dop853": {"rtol": 1e-13}, "ivp": {"rtol": 1e-12, "atol": 1e-14}, "rk4": {"h": 2e-5}}


# -- static friction ------------------------------------------------------------------------------

@pytest.mark.parametrize("R_static", [3.0, 20.0, 55.0, 90.0])
@pytest.mark.parametrize("solver", ["exact", "dop853", "rk4", "ivp"])
def test_static_friction_stops_pure_coulomb_at_the_predicted_half_swing(solver, R_static):
    """Turning points 1 - 2 n r (r = R/omega0**2 = 0.03); the balance stays at the first n with
    omega0**2 (1 - 2 n r) <= R_static, i.e. n = ceil((1 - R_static/omega0**2) / (2 r))."""
    w0, th0, R = 10.0, 1.0, 3.0
    r, r_s = R / w0**2, R_static / w0**2
    n_stop = max(0, math.ceil((th0 - r_s) / (2 * r) - 1e-12))
    tr = solve(scene(w0=w0, theta0=th0, swings=100, R=R, R_static=R_static), solver,
               **({} if solver == "exact" else INTEGRATORS[solver]))
    assert tr.status == "stopped"
    assert len(tr.amplitude) == n_stop
    expected = th0 - 2 * r * np.arange(1, n_stop + 1)
    np.testing.assert_allclose(tr.amplitude, np.abs(expected), rtol=0, atol=1e-12 if solver == "exact" else 1e-10)
    if n_stop:  # it moved at every earlier turning point and stays at the last
        assert w0**2 * tr.amplitude[-1] <= R_static < w0**2 * (tr.amplitude[-2] if n_stop > 1 else th0)


def test_static_friction_with_viscous_damping_follows_the_recurrence_and_solve_ivp():
    w0, th0, C, R, R_static = 10.0, 3.0, 0.5, 4.0, 60.0
    r, r_s = R / w0**2, R_static / w0**2
    q = math.exp(-math.pi * C / (2 * math.sqrt(w0**2 - C**2 / 4)))
    a, expected = th0, []
    while a > r_s:
        a = q * (a - r) - r
        expected.append(a)
    tr = solve(scene(w0=w0, theta0=th0, swings=200, C=C, R=R, R_static=R_static))
    assert tr.status == "stopped"
    np.testing.assert_allclose(tr.amplitude, expected, rtol=0, atol=1e-12)
    ref, _ = reference_turns(w0, th0, 200, C=C, R=R, R_static=R_static)
    np.testing.assert_allclose(tr.theta_turn, ref, rtol=0, atol=1e-10)  # measured: 4e-13 rad


def test_static_friction_equal_to_the_sliding_one_changes_nothing():
    plain = solve(scene(theta0=1.0, swings=60, C=0.3, R=3.0))
    same = solve(scene(theta0=1.0, swings=60, C=0.3, R=3.0, R_static=3.0))
    assert plain.status == same.status
    for f in ("amplitude", "theta_turn", "half_period", "time"):
        np.testing.assert_array_equal(getattr(plain, f), getattr(same, f))


def test_static_friction_holds_a_release_it_cannot_start():
    tr = solve(scene(w0=10.0, theta0=0.5, R=3.0, R_static=60.0))
    assert tr.status == "stopped" and len(tr.amplitude) == 0


def test_static_friction_below_the_sliding_one_is_refused():
    with pytest.raises(SceneError, match="R_static.*at least R"):
        scene(R=3.0, R_static=2.0)
    sc = scene(R=3.0, R_static=4.0)
    with pytest.raises(SolverError, match="R_static must be >= R"):
        solve(sc, values={"coulomb.R_static": 1.0})
    text = balance_toml(switching="phase", effects="[effects.coulomb]\nR = 3.0\nR_static = 4.0\n")
    with pytest.raises(SceneError, match="static friction needs switching = 'angle'"):
        escfit.load_scene("bad.toml", text=text)


# -- decrements per half swing at small damping -----------------------------------------------------

def test_coulomb_and_viscous_decrements_per_half_swing():
    w0 = 10.0
    tr = solve(scene(w0=w0, theta0=1.0, swings=20, R=0.5))
    np.testing.assert_allclose(-np.diff(tr.amplitude), 2 * 0.5 / w0**2, rtol=1e-9)
    C = 1e-3 * w0
    tr = solve(scene(w0=w0, theta0=1.0, swings=20, C=C))
    a = tr.amplitude
    mean = 0.5 * (a[:-1] + a[1:])
    np.testing.assert_allclose(a[:-1] - a[1:], math.pi * C * mean / (2 * w0), rtol=1e-6)
