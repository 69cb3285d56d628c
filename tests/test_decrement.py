"""The decrement per half swing: each law's part against independent references, and the
figure's numbers computed from a saved fit.

References: the exact piecewise solver (linear spring, angle and phase switching), the compiled
dop853 pendulum, and scipy's ``solve_ivp`` for quadratic drag (which no escfit solver had when
this was written).  Simulated decrements are ``A_n - A_(n+1)`` at the mean amplitude
``(A_n + A_(n+1))/2``, where the parts are evaluated.
"""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr
from scipy.integrate import solve_ivp

from escfit import load_scene
from escfit.balance import sample_scene, solve
from escfit.balance.decrement import Window, binned, from_readings, from_turns, law_parts

W0 = 2 * math.pi


def _scene(text: str, theta0: float = 1.0, omega0: float = W0, switching: str = "angle", restoring: str = "spring"):
    return load_scene("t.toml", text=f'model = "balance"\nswitching = "{switching}"\n[oscillator]\n'
                                    f'restoring = "{restoring}"\nomega0 = {omega0!r}\ntheta0 = {theta0!r}\n{text}')


def _simulated(scene, swings=40, solver=None):
    tr = solve(scene, solver, swings=swings)
    a = np.concatenate([[abs(scene.params["oscillator.theta0"].value)], np.abs(tr.theta_turn)])
    return (a[:-1] + a[1:]) / 2, a[:-1] - a[1:]


def test_viscous_and_coulomb_on_a_spring_add_exactly_at_the_mean_amplitude():
    C, R = 0.05, 0.1
    amp, dec = _simulated(_scene(f"[effects.viscous]\nC = {C}\n[effects.coulomb]\nR = {R}\n"))
    parts = law_parts(amp, omega0=W0, C=C, R=R)
    assert set(parts) == {"coulomb", "viscous"}
    assert np.allclose(parts["coulomb"], 2 * R / W0**2, rtol=0, atol=1e-15)  # 5.07e-3 rad, constant
    # exact: 2 tanh(pi C/(4 omega1)) A + 2R/omega0^2 (see escfit.balance.decrement), to round-off
    assert np.max(np.abs(parts["coulomb"] + parts["viscous"] - dec) / dec) < 1e-10
    # the textbook first-order form pi C A/(2 omega0) differs by C^2/(8 omega0^2) + (pi C/omega0)^2/48 of
    # the viscous part: 2.2e-5 relative here
    first_order = math.pi * C * amp / (2 * W0)
    assert np.max(np.abs(first_order / parts["viscous"] - 1)) < 3e-5


def test_pendulum_parts_from_the_energy_balance():
    C, R = 0.02, 0.05
    scene = _scene(f"[effects.viscous]\nC = {C}\n[effects.coulomb]\nR = {R}\n", theta0=1.2, restoring="pendulum")
    amp, dec = _simulated(scene, solver="dop853")
    parts = law_parts(amp, omega0=W0, C=C, R=R, restoring="pendulum")
    total = parts["coulomb"] + parts["viscous"]
    # first order in the damping: the neglected terms are of relative size (C/omega0)^2 = 1e-5 and
    # (R/(omega0^2 A))^2 < 1e-5 (measured: 3e-8, the mean amplitude cancels most of them)
    assert np.max(np.abs(total - dec) / dec) < 1e-5
    spring = law_parts(amp, omega0=W0, C=C, R=R)
    assert np.max(np.abs(spring["coulomb"] + spring["viscous"] - dec) / dec) > 0.1  # 69 deg: the spring forms miss


def test_quadratic_drag_against_solve_ivp():
    D = 0.01  # 1/rad: torque per inertia -D |theta'| theta'

    def rhs(t, y):
        return [y[1], -D * abs(y[1]) * y[1] - W0**2 * y[0]]

    def turn(t, y):
        return y[1]

    sol = solve_ivp(rhs, (0.0, 20.5), [1.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-14, events=turn)
    t_turn, y_turn = sol.t_events[0], sol.y_events[0][:, 0]
    a = np.abs(y_turn[t_turn > 1e-9])
    a = np.concatenate([[1.0], a])
    amp, dec = (a[:-1] + a[1:]) / 2, a[:-1] - a[1:]
    assert a.size > 30
    parts = law_parts(amp, omega0=W0, D=D)
    assert list(parts) == ["drag"]
    # 4 D A^2/3 is first order; the next term is of relative size (D A)^2 <= 1e-4 (measured 2.6e-5)
    assert np.max(np.abs(parts["drag"] / dec - 1)) < 1e-4
    # and the shape: the decrement over A^2 is constant, unlike A (viscous) or 1 (Coulomb)
    assert np.ptp(dec / amp**2) / np.mean(dec / amp**2) < 1e-3 and np.ptp(dec / amp) / np.mean(dec / amp) > 0.3


# -- the stiffening spring: no part of its own, every other part changed ---------------------------
STIFF_CASES = {"coulomb": "[effects.coulomb]\nR = 0.5\n", "viscous": "[effects.viscous]\nC = 0.02\n",
               "drag": "[effects.drag]\nD = 0.002\n",
               "all three": "[effects.viscous]\nC = 0.02\n[effects.coulomb]\nR = 0.5\n[effects.drag]\nD = 0.002\n"}


@pytest.mark.parametrize("k3", [0.3, 1.0])
@pytest.mark.parametrize("case", sorted(STIFF_CASES))
def test_stiffening_spring_parts_against_dop853(case, k3):
    """A Duffing spring, omega0 = 10 rad/s, from 2 rad over 60 half swings (k3 A^2 from 1.2 to 4):
    the parts on the stiffened swing sum to the solver's decrements to 1e-5 (measured 3e-8 to 2e-6;
    first order in the damping, whose per-swing loss is below 1e-3 of A), where the linear-spring
    forms are off by 28 % to 400 %."""
    text = STIFF_CASES[case] + f"[effects.stiffening]\nk3 = {k3}\n"
    sc = _scene(text, theta0=2.0, omega0=10.0)
    tr = solve(sc, "dop853", swings=60, rtol=1e-13)
    a = np.concatenate([[2.0], tr.amplitude])
    mean, dec = (a[:-1] + a[1:]) / 2, a[:-1] - a[1:]
    coeff = {k: sc.params[n].value for k, n in (("C", "viscous.C"), ("R", "coulomb.R"), ("D", "drag.D"))
             if n in sc.params}
    parts = law_parts(mean, omega0=10.0, k3=k3, **coeff)
    np.testing.assert_allclose(sum(parts.values()), dec, rtol=1e-5)
    linear = law_parts(mean, omega0=10.0, **coeff)
    assert np.max(np.abs(sum(linear.values()) / dec - 1)) > 0.25
    if "R" in coeff:  # exact energy balance of a constant friction torque: 2R/(omega0^2 (1 + k3 (An^2 + An+1^2)/2))
        only = _scene(f"[effects.coulomb]\nR = 0.5\n[effects.stiffening]\nk3 = {k3}\n", theta0=2.0, omega0=10.0)
        b = np.concatenate([[2.0], solve(only, "dop853", swings=60, rtol=1e-13).amplitude])
        np.testing.assert_allclose(b[:-1] - b[1:], 2 * 0.5 / (100.0 * (1 + k3 * (b[:-1] ** 2 + b[1:] ** 2) / 2)),
                                   rtol=1e-9)


def test_stiffening_on_a_pendulum_against_dop853():
    """A leaf-spring pendulum (gravity plus a cubic term, k3 = 0.5) from 2 rad, 200 half swings
    with viscous damping, Coulomb friction and drag: the energy-balance parts to 2e-5 (measured
    4.4e-6); the pendulum's forms without the cubic term are off by more than 100 %."""
    text = ("[effects.viscous]\nC = 0.01\n[effects.coulomb]\nR = 0.05\n[effects.drag]\nD = 0.005\n"
            "[effects.stiffening]\nk3 = 0.5\n")
    tr = solve(_scene(text, theta0=2.0, omega0=5.0, restoring="pendulum"), "dop853", swings=200, rtol=1e-13)
    assert tr.status == "ok"
    a = np.concatenate([[2.0], tr.amplitude])
    mean, dec = (a[:-1] + a[1:]) / 2, a[:-1] - a[1:]
    kw = {"omega0": 5.0, "C": 0.01, "R": 0.05, "D": 0.005, "restoring": "pendulum"}
    np.testing.assert_allclose(sum(law_parts(mean, k3=0.5, **kw).values()), dec, rtol=2e-5)
    assert np.max(np.abs(sum(law_parts(mean, **kw).values()) / dec - 1)) > 1.0


def test_stiffened_quadrature_reduces_to_the_closed_forms():
    """With k3 -> 0 the quadrature of the stiffened swing gives the pendulum's elliptic-integral
    viscous part and the spring's first-order pi C A/(2 omega0)."""
    a = np.array([0.05, 0.5, 1.0, 2.0, 3.0])
    pend = law_parts(a, omega0=3.0, C=0.1, restoring="pendulum")["viscous"]
    np.testing.assert_allclose(law_parts(a, omega0=3.0, C=0.1, k3=1e-13, restoring="pendulum")["viscous"], pend,
                               rtol=1e-10)
    np.testing.assert_allclose(law_parts(a, omega0=3.0, C=0.1, k3=1e-13)["viscous"], math.pi * 0.1 * a / 6.0,
                               rtol=1e-10)


def test_escapement_part_in_angle_switching():
    X_imp, X_unl = 0.5, 0.3
    scene = _scene("[effects.viscous]\nC = 0.05\n[[effects.escapement]]\nkind = \"impulse\"\nfrom = -0.2\nto = 0.2\n"
                   f"X = {X_imp}\n[[effects.escapement]]\nkind = \"unlock\"\nfrom = -0.4\nto = -0.2\nX = {X_unl}\n")
    amp, dec = _simulated(scene)
    windows = (Window(1.0, X_imp, -0.2, 0.2), Window(-1.0, X_unl, -0.4, -0.2))
    parts = law_parts(amp, omega0=W0, C=0.05, windows=windows)
    esc = parts["escapement"]
    assert np.all(esc < 0)  # a gain
    assert np.allclose(esc * amp, -(X_imp * 0.4 - X_unl * 0.2) / W0**2)  # ~ 1/A while both windows are swept
    # first order in the impulse: the error is of order esc^2/A (2.6e-5 rad here; measured 7e-6)
    assert np.max(np.abs(parts["viscous"] + esc - dec)) < np.max(esc**2 / amp)


def test_phase_convention_constant_is_exact():
    # Monday's unit 3 at 330.66 g: Coulomb friction and the escapement are each some 8-9 rad per half swing
    w0, C, R = 15.78, 2.32, 982.6
    windows = "".join(f'[[effects.escapement]]\nkind = "{k}"\nfrom = {lo}\nto = {hi}\nX = {x}\n'
                      for k, lo, hi, x in (("unlock", -0.612, -0.28, 473.07), ("impulse", -0.28, 0.28, 4119.339)))
    scene = _scene(f"[effects.viscous]\nC = {C}\n[effects.coulomb]\nR = {R}\n{windows}", theta0=6.28, omega0=w0,
                   switching="phase")
    amp, dec = _simulated(scene, swings=20)
    parts = law_parts(amp, omega0=w0, C=C, R=R, switching="phase",
                      windows=(Window(-1.0, 473.07, -0.612, -0.28), Window(1.0, 4119.339, -0.28, 0.28)))
    assert set(parts) == {"viscous", "constant"}
    assert np.max(np.abs(parts["viscous"] + parts["constant"] - dec)) < 1e-9 * np.max(np.abs(parts["viscous"]))
    # the first-order constant (2R - sum of +-X (sin hi - sin lo))/omega0^2 nets terms of 8-9 rad to -0.685 rad,
    # 1.1 % from the exact -0.693: the exact map removes that error
    first = (2 * R - 4119.339 * 2 * math.sin(0.28) + 473.07 * (math.sin(-0.28) - math.sin(-0.612))) / w0**2
    assert 1e-3 < abs(first / parts["constant"][0] - 1) < 0.02


def test_measured_decrements_cancel_a_zero_offset():
    rng = np.random.default_rng(0)
    a = 1.0 * 0.97 ** np.arange(30) + 0.01 * rng.random(30)
    off = 0.02 * np.where(np.arange(30) % 2 == 0, 1.0, -1.0)  # readings on alternate sides
    clean, shifted = from_readings(np.arange(30), a), from_readings(np.arange(30), a + off)
    assert np.allclose(clean.decrement, shifted.decrement, atol=1e-15)
    assert np.allclose(clean.amplitude, shifted.amplitude, atol=1e-15)
    assert np.allclose(clean.decrement, (a[:-2] - a[2:]) / 2)
    sparse = from_readings(np.arange(0, 30, 4), (a + off)[::4], half_width=0.05)  # every fourth: same side
    assert np.allclose(sparse.decrement, (a[:-4:4] - a[4::4]) / 4) and np.allclose(sparse.error, 0.1 / 4)
    odd = from_readings(np.array([0, 3, 6]), a[[0, 3, 6]])  # odd gaps mix the sides: not used
    assert odd.decrement.size == 0


def test_turning_points_need_no_centre():
    a = 0.8 * 0.95 ** np.arange(12)
    theta = 0.3 + a * np.where(np.arange(12) % 2 == 0, 1.0, -1.0)  # about a centre at 0.3 rad
    d = from_turns(theta)
    ref = from_readings(np.arange(12), a)
    assert np.allclose(d.decrement, ref.decrement) and np.allclose(d.amplitude, ref.amplitude)


def test_binned_means():
    a = np.linspace(0.1, 1.0, 40)
    d = 0.1 * a + np.where(np.arange(40) % 2 == 0, 0.01, -0.01)
    amp, dec, se = binned(a, d, bins=4)
    assert amp.size == 4 and np.allclose(dec, 0.1 * amp, atol=1e-12) and np.all(se > 0)


# -- the figure's numbers, from a saved fit ------------------------------------------------------
class _Saved:
    """What the figure reads of a results file: ``attrs`` and ``arrays(name)``."""

    def __init__(self, attrs, **groups):
        self.attrs, self._groups = attrs, groups

    def arrays(self, name):
        return self._groups.get(name)


def _saved(scene_text, kind, observed, expected, best, coords, meanings=None):
    obs = xr.Dataset({"reading": ("obs", observed)}, coords={"obs": np.arange(observed.size), **coords})
    lsq = xr.Dataset({"value": ("parameter", list(best.values())), "expected": ("obs", expected)},
                     coords={"parameter": list(best), "obs": np.arange(observed.size)})
    attrs = {"scene": scene_text, "data_kind": kind, "meanings": json.dumps(meanings or {})}
    return _Saved(attrs, observed_data=obs, least_squares=lsq)


FIT_SCENE = """model = "balance"
[oscillator]
omega0 = 6.283185307179586
theta0 = 1.0
[effects.viscous]
C = { value = 0.1, vary = true, min = 0, max = 1 }
[effects.coulomb]
R = { value = 0.05, vary = true, min = 0, max = 1 }
"""


def test_panel_of_amplitude_readings_from_saved_results():
    from escfit.balance.decrement_figure import decrement_figure, decrement_panels

    C, R = 0.05, 0.1
    truth = _scene(f"[effects.viscous]\nC = {C}\n[effects.coulomb]\nR = {R}\n")
    tr = solve(truth, swings=30)
    a = np.concatenate([[1.0], np.abs(tr.theta_turn)])
    rng = np.random.default_rng(1)
    y = a + 0.002 * rng.standard_normal(a.size) + 0.01 * np.where(np.arange(a.size) % 2 == 0, -1, 1)
    res = _saved(FIT_SCENE, "amplitude", y, a, {"viscous.C": C, "coulomb.R": R, "observation.sigma": 0.002},
                 {"swing": ("obs", np.arange(a.size)), "curve": ("obs", np.full(a.size, "curve"))})
    (panel,), notes = decrement_panels(res)
    assert not notes and set(panel.parts) == {"coulomb", "viscous"}
    # the model's decrements at its own amplitudes are the parts' sum, exactly (spring, C + R)
    ref = law_parts(panel.model.amplitude, omega0=W0, C=C, R=R)
    assert np.allclose(panel.model.decrement, ref["coulomb"] + ref["viscous"], rtol=1e-10, atol=0)
    # the measured ones scatter about it by the reading noise (sd 0.002/sqrt(2) per decrement); the offset cancels
    resid = panel.measured.decrement - panel.model.decrement
    assert abs(resid.mean()) < 4 * 0.0015 / math.sqrt(resid.size) and resid.std() < 0.003
    png = decrement_figure(res)
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and "horizontal line" in png.caption and "parabola" in png.caption
    assert "Quadratic drag is not in this model" in png.caption


def test_panel_of_a_stiffening_spring_draws_the_stiffened_parts():
    """A scene with a stiffening spring gets its parts (it used to get none) computed on the
    stiffened swing, and the caption says what the spring does and by how much."""
    from escfit.balance.decrement_figure import decrement_figure, decrement_panels

    C, R, k3 = 0.05, 0.1, 0.8
    text = FIT_SCENE + f"[effects.stiffening]\nk3 = {{ value = 0.5, vary = true, min = 0, max = 5 }}\n"
    truth = _scene(f"[effects.viscous]\nC = {C}\n[effects.coulomb]\nR = {R}\n[effects.stiffening]\nk3 = {k3}\n")
    a = np.concatenate([[1.0], solve(truth, "dop853", swings=30, rtol=1e-12).amplitude])
    res = _saved(text, "amplitude", a, a, {"viscous.C": C, "coulomb.R": R, "stiffening.k3": k3},
                 {"swing": ("obs", np.arange(a.size)), "curve": ("obs", np.full(a.size, "curve"))})
    (panel,), notes = decrement_panels(res)
    assert not notes and set(panel.parts) == {"coulomb", "viscous"}
    grid, coul = panel.parts["coulomb"]
    np.testing.assert_allclose(coul, 2 * R / (W0**2 * (1 + k3 * grid**2)), rtol=1e-12)
    # the model's decrements lie on the parts' sum (first order in the damping: 1e-3 here)
    total = np.interp(panel.model.amplitude, grid, sum(d for _, d in panel.parts.values()))
    np.testing.assert_allclose(panel.model.decrement, total, rtol=1e-3)
    png = decrement_figure(res)
    assert "stiffening spring (k3 = 0.8 1/rad^2) dissipates nothing" in png.caption
    top = max(panel.measured.amplitude.max(), panel.model.amplitude.max())
    assert f"Coulomb (dry) friction's {100 * (1 - 1 / (1 + k3 * top**2)):.0f} % smaller" in png.caption


def test_panels_of_several_loads_use_each_loads_values():
    from escfit.balance.decrement_figure import decrement_panels

    text = (FIT_SCENE.replace("[effects.coulomb]", '[[effects.escapement]]\nkind = "impulse"\nfrom = -0.1\nto = 0.1\n'
                              'X = 2.0\n[effects.coulomb]') + '[fit.loads]\nreference = "100 g"\nfriction = "free"\n')
    loads = np.repeat([100.0, 200.0], 10)
    swing = np.tile(np.arange(10), 2)
    y = np.tile(0.9 ** np.arange(10), 2)
    best = {"viscous.C": 0.05, "coulomb.R[load=100]": 0.1, "coulomb.R[load=200]": 0.2}
    curves = np.array([f"unit load {ld:g}" for ld in loads])
    res = _saved(text, "amplitude", y, y, best, {"swing": ("obs", swing), "curve": ("obs", curves),
                                                 "load": ("obs", loads)},
                 meanings={"coulomb.R[load=100]": "Coulomb friction at load 100 g"})
    panels, _ = decrement_panels(res)
    assert [p.coefficients["R"] for p in panels] == [0.1, 0.2]
    for p, load in zip(panels, (100.0, 200.0)):
        grid, esc = p.parts["escapement"]
        x = 2.0 * load / 100.0  # the escapement scales with the load
        assert np.allclose(esc, -x * np.clip(np.minimum(0.1, grid) + np.minimum(0.1, grid), 0, None) / (W0**2 * grid))


def test_turning_points_of_samples_show_no_false_curvature():
    """A viscous pendulum sampled at 20 Hz with tracker-like noise: the measured decrements
    follow the viscous part (a straight line), so curvature like the string pendulum's is the
    recording's, not the method's."""
    from escfit.balance.decrement_figure import decrement_panels

    w0, C, theta0 = 3.85, 0.024, 0.65
    text = (f'model = "balance"\n[oscillator]\nrestoring = "pendulum"\nomega0 = {w0}\ntheta0 = {theta0}\n'
            f'[effects.viscous]\nC = {C}\n[observation]\nmodel = "waveform"\n')
    scene = load_scene("p.toml", text=text)
    t = np.arange(0.0, 116.0, 0.05)
    theta, status = sample_scene(scene, t)
    assert status == "ok"
    rng = np.random.default_rng(2)
    y = theta + 0.003 * rng.standard_normal(t.size) - 0.01  # a sensor zero off the centre
    res = _saved(text, "timeseries", y, theta - 0.01, {"viscous.C": C, "observation.offset": 0.01},
                 {"swing": ("obs", np.arange(t.size)), "curve": ("obs", np.full(t.size, "waveform")),
                  "time": ("obs", t)})
    (panel,), _ = decrement_panels(res)
    m, model = panel.measured, panel.model
    assert m.decrement.size > 120
    ref = law_parts(model.amplitude, omega0=w0, C=C, restoring="pendulum")["viscous"]
    assert np.allclose(model.decrement, ref, rtol=2e-3)  # noise-free samples: turning points to ~1e-4 rad
    # quadratic term of a fit of the measured decrements against A: zero within its standard error (over 300
    # noise seeds its z-score had sd 0.26, at most 1.1: the overlapping decrements are anticorrelated)
    coef, cov = np.polyfit(m.amplitude, m.decrement, 2, cov=True)
    assert abs(coef[0]) < 3 * math.sqrt(cov[0, 0])
    # mean offset from the model: over 300 seeds 7e-5 +- 6.5e-5 rad (a slight vertex bias), against
    # decrements of 2e-3 to 6e-3 rad; 5e-4 rad is 6.6 sd away
    assert abs(np.mean(m.decrement - np.interp(m.amplitude, np.sort(model.amplitude),
                                               model.decrement[np.argsort(model.amplitude)]))) < 5e-4


def test_no_figure_without_amplitudes():
    from escfit.balance.decrement_figure import decrement_figure

    res = _saved(FIT_SCENE, "pulses", np.arange(5.0), np.arange(5.0), {"viscous.C": 0.1},
                 {"swing": ("obs", np.arange(5)), "curve": ("obs", np.full(5, "notch"))})
    assert decrement_figure(res) is None
    assert decrement_figure(SimpleNamespace(attrs={}, arrays=lambda name: None)) is None
