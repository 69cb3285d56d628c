"""Reproduction targets from the seed documents (see the seeds' README)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import escfit
from escfit.balance import solve

from .conftest import DATASETS

HOROLOGY = DATASETS / "scenes" / "horology_rk4_case.toml"


@pytest.fixture(scope="module")
def horology():
    return escfit.load_scene(HOROLOGY)


def test_horology_half_period_and_rate(horology):
    ds = escfit.simulate(horology, swings=2)
    assert ds.half_period.values[0] == pytest.approx(0.1000035078, abs=1e-9)
    assert ds.rate.values[0] == pytest.approx(-3.0306, abs=5e-5)
    # The book's -3.023894 s/day = 86400*(1/(10*0.1000035) - 1) is its graphical reading of
    # T/2 to 7 digits, not the physics: the computed half period rounds to that reading.
    assert round(float(ds.half_period.values[0]), 7) == 0.1000035


# Theory of Horology 3-2 in SI units, written out here independently of the scene reader.
HOROLOGY_SI = {"I": 1.2e-9, "k": 1.184352528e-6, "c": 8.41e-11, "R": 2.85e-9, "M": 2.73e-7, "eps": 0.3,
               "A0": math.radians(300.0)}


def _horology_half_swing_by_dop853(p):
    """First half swing from rest at ``A0`` by scipy's DOP853, region by region (no escfit).

    Swing frame ``x = -theta`` (the balance runs from ``x = -A0`` towards ``+A``):
    ``I x'' = -k x - c x' - R + torque(x)`` with the unlock torque ``-eps*M`` on
    ``[-25, -15) deg`` and the impulse ``+M`` on ``[-13, 22) deg``.  Returns the time and
    the angle (rad) of the turning point.
    """
    from scipy.integrate import solve_ivp

    d = math.radians
    windows = [(d(-25.0), d(-15.0), -p["eps"] * p["M"]), (d(-13.0), d(22.0), p["M"])]
    cuts = sorted({b for lo, hi, _ in windows for b in (lo, hi)})

    def stop(_t, s):
        return s[1]

    stop.terminal, stop.direction = True, -1
    t, x, v = 0.0, -p["A0"], 0.0
    for b in [c for c in cuts if c > x] + [math.inf]:
        probe = 0.5 * (x + b) if math.isfinite(b) else x + 1e-9
        tau = sum(q for lo, hi, q in windows if lo <= probe < hi)

        def rhs(_t, s, tau=tau):
            return [s[1], (-p["k"] * s[0] - p["c"] * s[1] - p["R"] + tau) / p["I"]]

        def cross(_t, s, b=b):
            return s[0] - b

        cross.terminal, cross.direction = True, 1
        events = [cross, stop] if math.isfinite(b) else [stop]
        sol = solve_ivp(rhs, (t, t + 1.0), [x, v], method="DOP853", rtol=1e-13, atol=1e-16, events=events)
        if sol.t_events[-1].size:  # turned before reaching b
            return float(sol.t_events[-1][0]), float(sol.y_events[-1][0][0])
        t, v, x = float(sol.t_events[0][0]), float(sol.y_events[0][0][1]), b
    raise AssertionError("the balance never turned")


def test_horology_half_swing_agrees_with_an_independent_dop853_integration(horology):
    half_period, amplitude = _horology_half_swing_by_dop853(HOROLOGY_SI)
    assert half_period == pytest.approx(0.1000035078, abs=1e-9)  # the README's reproduction target
    ds = escfit.simulate(horology, swings=2)
    assert float(ds.half_period.values[0]) == pytest.approx(half_period, rel=0, abs=1e-12)
    assert float(ds.amplitude.values[0]) == pytest.approx(amplitude, rel=1e-10)
    # rate in s/day against the free period pi/omega0 (0.1 s here)
    nominal = math.pi / math.sqrt(HOROLOGY_SI["k"] / HOROLOGY_SI["I"])
    assert float(ds.rate.values[0]) == pytest.approx(86400 * (nominal / half_period - 1), rel=1e-8)


def test_horology_grows_to_steady_state_near_310_deg(horology):
    amp = np.degrees(escfit.simulate(horology, swings=2000).amplitude.values)
    assert amp[0] > 300.0 and amp[10] > amp[0]
    assert amp[-1] == pytest.approx(310.17, abs=0.05)
    assert abs(amp[-1] - amp[-101]) < 1e-3  # converged


@pytest.mark.parametrize("solver, options, tol_t, tol_a", [
    ("rk4", {"h": 1e-6}, 1e-12, 1e-10),
    ("ivp", {"rtol": 1e-12, "atol": 1e-14}, 1e-12, 1e-10),
    ("rk4", {"h": 1e-6, "locate_events": False}, 2e-9, 2e-5),  # steps over switches: first order
])
def test_solvers_agree_on_horology(horology, solver, options, tol_t, tol_a):
    ref = solve(horology, "exact", swings=6)
    other = solve(horology, solver, swings=6, **options)
    assert other.status == "ok"
    np.testing.assert_allclose(other.half_period, ref.half_period, rtol=0, atol=tol_t)
    np.testing.assert_allclose(other.amplitude, ref.amplitude, rtol=0, atol=tol_a)


def test_phase_mode_sample_problem():
    scene = escfit.load_scene(DATASETS / "scenes" / "monday_sample_phase.toml")
    traj = solve(scene, swings=400)
    per_cycle = traj.amplitude[1::2]
    np.testing.assert_allclose(per_cycle[:4], [5.548613, 4.926520, 4.397389, 3.947328], atol=1e-6)
    assert per_cycle[-1] == pytest.approx(1.3856, abs=5e-5)
    C, w0 = 0.833, 16.174
    lam = math.exp(-math.pi * C / math.sqrt(w0**2 - C**2 / 4))
    steady = per_cycle[-1]
    ratios = (per_cycle[1:30] - steady) / (per_cycle[:29] - steady)
    np.testing.assert_allclose(ratios, lam, rtol=1e-8)
    # phase mode: every half cycle lasts pi/omega1 exactly
    np.testing.assert_allclose(traj.half_period, math.pi / math.sqrt(w0**2 - C**2 / 4), rtol=1e-14)
