"""The gravity pendulum, the compiled DOP853 solver and theta(t) sampling."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ellipk

import escfit
from escfit import SceneError, SolverError
from escfit.balance import SOLVERS, default_solver, sample_scene, sample_theta, solve
from escfit.balance.batch import solve_batch

from .conftest import DATASETS, balance_toml

TIGHT = {"rtol": 1e-13, "atol": 1e-15}
WINDOWS = """[effects.viscous]\nC = 0.5\n[effects.coulomb]\nR = 20.0\n
[[effects.escapement]]\nkind = "unlock"\nfrom = -0.43\nto = -0.21\nX = 100.0\n
[[effects.escapement]]\nkind = "impulse"\nfrom = -0.21\nto = 0.37\nX = 900.0\n"""


def as_pendulum(text: str, restoring: str = "pendulum") -> str:
    return text.replace("[oscillator]\n", f'[oscillator]\nrestoring = "{restoring}"\n')


def pendulum(*, theta0, omega0=3.0, swings=4, effects=""):
    text = balance_toml(omega0=omega0, theta0=theta0, swings=swings, effects=effects)
    return escfit.load_scene("pendulum.toml", text=as_pendulum(text))


@pytest.mark.parametrize("deg", [10, 90, 150, 179])
@pytest.mark.parametrize("solver", ["dop853", "ivp"])
def test_undamped_pendulum_period_is_the_complete_elliptic_integral(deg, solver):
    th0, w0 = math.radians(deg), 3.0
    period = 4.0 * ellipk(math.sin(th0 / 2) ** 2) / w0
    traj = solve(pendulum(theta0=th0, omega0=w0), solver, **TIGHT)
    assert traj.status == "ok"
    assert 2.0 * traj.time[0] == pytest.approx(period, rel=1e-10)  # first turning point after release
    assert traj.time[1] == pytest.approx(period, rel=1e-10)  # back where it was released
    np.testing.assert_allclose(traj.amplitude, th0, rtol=0, atol=1e-10)


def test_coulomb_pendulum_loses_its_energy_to_friction_then_sticks():
    w0, R, th0 = 3.0, 0.9, math.radians(150)
    traj = solve(pendulum(theta0=th0, omega0=w0, swings=200, effects=f"[effects.coulomb]\nR = {R}\n"), rtol=1e-12,
                 atol=1e-14)
    assert traj.solver == "dop853" and traj.status == "stopped"
    turns = np.concatenate([[th0], traj.theta_turn])
    # per unit inertia: potential energy given up = work against friction over the path
    lost = w0**2 * (np.cos(turns[1:]) - np.cos(turns[:-1]))
    np.testing.assert_allclose(lost, R * np.abs(np.diff(turns)), rtol=1e-9)
    # friction holds it at the first turning point where gravity cannot overcome it
    assert w0**2 * math.sin(traj.amplitude[-1]) <= R * (1 + 1e-12)
    assert np.all(w0**2 * np.sin(traj.amplitude[:-1]) > R)
    assert len(traj.amplitude) > 5


def test_dop853_pendulum_agrees_with_ivp_and_rk4_under_every_effect():
    eff = WINDOWS.replace("X = 900.0", "X = 400.0") + "[effects.banking]\nangle = 2.2\nrestitution = 0.4\n"
    scene = pendulum(theta0=2.1, omega0=31.4, swings=40, effects=eff)
    ref = solve(scene, "dop853", **TIGHT)
    assert ref.status == "banked" and ref.banked.any() and len(ref.amplitude) == 40
    for other in (solve(scene, "ivp", **TIGHT), solve(scene, "rk4", h=2e-5)):
        assert other.status == ref.status
        np.testing.assert_allclose(other.theta_turn, ref.theta_turn, atol=1e-8)
        np.testing.assert_allclose(other.time, ref.time, atol=1e-8)


@pytest.mark.parametrize("solver", ["dop853", "ivp", "rk4"])
def test_a_pendulum_driven_over_the_top_fails_with_a_reason(solver):
    traj = solve(pendulum(theta0=2.0, omega0=31.4, swings=10, effects=WINDOWS), solver)
    assert traj.status == "failed" and "over the top" in traj.message


def test_dop853_agrees_with_the_exact_solver_on_monday_sample():
    scene = escfit.load_scene(DATASETS / "scenes" / "monday_sample_angle.toml")
    ex, dp = solve(scene, "exact"), solve(scene, "dop853")
    assert dp.status == ex.status and len(dp.amplitude) == len(ex.amplitude)
    np.testing.assert_allclose(dp.theta_turn, ex.theta_turn, rtol=0, atol=1e-9)
    np.testing.assert_allclose(dp.time, ex.time, rtol=0, atol=1e-10)
    np.testing.assert_array_equal(dp.banked, ex.banked)


def test_dop853_error_falls_with_the_tolerance():
    scene = escfit.load_scene("w.toml", text=balance_toml(omega0=31.4, theta0=2.0, swings=100, effects=WINDOWS))
    ex = solve(scene, "exact")
    errs = []
    for rtol in (1e-6, 1e-8, 1e-10, 1e-12):
        dp = solve(scene, "dop853", rtol=rtol, atol=rtol * 1e-2)
        assert dp.status == "ok" and len(dp.amplitude) == 100
        errs.append(max(np.max(np.abs(dp.amplitude - ex.amplitude)), np.max(np.abs(dp.time - ex.time))))
    assert all(b < 0.1 * a for a, b in zip(errs, errs[1:])), errs
    assert errs[-1] < 1e-10, errs


def test_sample_theta_exact_matches_the_damped_oscillator():
    w0, C, th0 = 7.0, 0.6, 1.3
    text = balance_toml(omega0=w0, theta0=th0, effects=f"[effects.viscous]\nC = {C}\n")
    sys = escfit.load_scene("v.toml", text=text).build()
    t = np.sort(np.random.default_rng(1).uniform(0.0, 12.0, 1000))
    theta, status = sample_theta(sys, t)
    wd = math.sqrt(w0**2 - C**2 / 4)
    expected = th0 * np.exp(-C * t / 2) * (np.cos(wd * t) + C / (2 * wd) * np.sin(wd * t))
    assert status == "ok"
    np.testing.assert_allclose(theta, expected, rtol=0, atol=1e-12)


SOFT_HAIRSPRING = balance_toml(omega0=10.0, theta0=1.0, effects=(
    "[effects.viscous]\nC = 0.1\n[effects.hairspring]\nangles = [-0.2, 0.2]\nomega0 = [3.0, 10.0, 3.0]\n"
)).replace("omega0 = 10.0\n", "", 1)


@pytest.mark.parametrize("text, t_end", [
    (balance_toml(omega0=16.174, theta0=3.0, effects="[effects.viscous]\nC = 0.833\n[effects.coulomb]\nR = 3.0\n"),
     5.5),
    (SOFT_HAIRSPRING, 30.0),  # half swings far longer than pi/omega0: the exact run is extended
])
def test_sample_theta_dop853_matches_exact_on_a_spring_with_friction(text, t_end):
    sys = escfit.load_scene("spring.toml", text=text).build()
    t = np.sort(np.random.default_rng(2).uniform(0.0, t_end, 1000))
    ex, s_ex = sample_theta(sys, t)
    dp, s_dp = sample_theta(sys, t, solver="dop853")
    assert s_ex == s_dp == "ok"
    np.testing.assert_allclose(dp, ex, rtol=0, atol=1e-8)


@pytest.mark.parametrize("solver", ["exact", "dop853"])
def test_sampled_theta_stays_at_rest_after_a_stop(solver):
    text = balance_toml(omega0=10.0, theta0=1.0, effects="[effects.coulomb]\nR = 30.0\n")
    scene = escfit.load_scene("c.toml", text=text)
    traj = solve(scene, solver, swings=50)
    assert traj.status == "stopped"
    t = np.linspace(0.0, 3.0 * traj.time[-1], 301)
    theta, status = sample_scene(scene, t, solver=solver)
    after = theta[t > traj.time[-1]]
    assert status == "stopped" and after.size > 100
    assert np.all(after == after[0]) and after[0] == pytest.approx(traj.theta_turn[-1], abs=1e-10)


def test_sampled_pendulum_passes_through_its_turning_points():
    scene = pendulum(theta0=math.radians(120), omega0=3.0, swings=8, effects="[effects.viscous]\nC = 0.1\n")
    traj = solve(scene, **TIGHT)
    theta, status = sample_scene(scene, np.concatenate([[0.0], traj.time]), rtol=1e-13, atol=1e-15)
    assert status == "ok"
    np.testing.assert_allclose(theta, np.concatenate([[math.radians(120)], traj.theta_turn]), rtol=0, atol=1e-10)


def test_exact_solver_refuses_a_pendulum_before_any_work():
    scene = pendulum(theta0=1.0)
    assert default_solver(scene) == "dop853" and default_solver(scene.build()) == "dop853"
    assert "smooth" not in SOLVERS["exact"].handles and "smooth" in SOLVERS["dop853"].handles
    for call in (lambda: solve(scene, "exact"), lambda: sample_scene(scene, np.array([0.1]), solver="exact"),
                 lambda: solve_batch([scene.build()], 4)):
        with pytest.raises(SolverError) as info:
            call()
        msg = str(info.value)
        assert "pendulum" in msg and "'dop853'" in msg and "'ivp'" in msg and "exact" in msg


@pytest.mark.parametrize("text, fragments", [
    (balance_toml(theta0=math.radians(190)), ["[oscillator].theta0", "180 deg", "3.31613"]),
    (balance_toml(effects="[effects.hairspring]\nangles = [0.5]\nomega0 = [9.0, 11.0]\n"),
     ["[oscillator].restoring", "hairspring", "pendulum"]),
    (balance_toml(switching="phase"), ["[oscillator].restoring", "switching = 'angle'"]),
])
def test_pendulum_scene_refusals_name_the_key(text, fragments):
    with pytest.raises(SceneError) as info:
        escfit.load_scene("bad.toml", text=as_pendulum(text))
    for frag in fragments:
        assert frag in str(info.value), (frag, str(info.value))


def test_unknown_restoring_is_refused():
    with pytest.raises(SceneError, match=r"\[oscillator\]\.restoring.*'magnet'"):
        escfit.load_scene("bad.toml", text=as_pendulum(balance_toml(), "magnet"))


def test_cli_simulates_a_pendulum_with_dop853(tmp_path):
    import json

    from click.testing import CliRunner

    from escfit.cli.main import cli

    path = tmp_path / "pendulum.toml"
    path.write_text(as_pendulum(balance_toml(theta0=1.0, swings=3)))
    r = CliRunner().invoke(cli, ["simulate", str(path), "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.output)
    assert out["solver"] == "dop853" and out["status"] == "ok" and len(out["amplitude"]) == 3
