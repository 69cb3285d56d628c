"""Verge escapement S&A model: reproduction of Lowen & Tepper (1982), numerics, hard cases.

Published values come from ARLCD-TR-82013: the text ("Input Data", "Output Data",
"Conclusions") and the first lines of the sample output of Appendix A (the later part of
that printout is corrupted by the text conversion and is not used).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from escfit.core.errors import SceneError, SolverError, UnitError
from escfit.core.scene import load_scene
from escfit.verge import coupled_state, forward, free_state, impact, json_summary, run, simulate
from escfit.verge.geometry import fuze_angles
from escfit.verge.kinematics import coupled_kinematics

M739 = Path(__file__).resolve().parents[1] / "datasets" / "verge" / "m739.toml"
DEG = math.pi / 180


def rel(a, b):
    return abs(a - b) / abs(b)


@pytest.fixture(scope="module")
def scene():
    return load_scene(M739)


@pytest.fixture(scope="module")
def m739_run(scene):
    return simulate(scene)


def _variant(text: str, **repl) -> str:
    """Replace ``key = value`` lines of the M739 scene text."""
    lines = []
    for line in text.splitlines():
        key = line.split("=")[0].strip()
        if key in repl:
            line = f"{key} = {repl[key]}"
        lines.append(line)
    return "\n".join(lines)


def load_variant(**repl):
    return load_scene("m739_variant.toml", text=_variant(M739.read_text(), **repl))


# --- geometry and the state at T = 0 -------------------------------------------------------

def test_fuze_body_angles_match_printout():
    inch = 1.0  # angles only depend on ratios
    ang = fuze_angles(r1=0.25 * inch, r2=0.317, r3=0.309, r4=0.304, a=0.226, c1=0.41214 + 0.05796,
                      c2=0.19039 + 0.04231, configuration=2, where="test")
    assert ang.beta1 / DEG == pytest.approx(218.87, abs=0.01)
    assert ang.beta2 / DEG == pytest.approx(134.90, abs=0.01)
    assert ang.beta3 / DEG == pytest.approx(92.11, abs=0.01)
    # printed without their minus signs; the third reads 188.34 in the OCR (see docs)
    assert ang.gamma2 / DEG == pytest.approx(-111.47, abs=0.01)
    assert ang.gamma3 / DEG == pytest.approx(-155.09, abs=0.01)


def test_state_at_t0_matches_first_printed_line(scene):
    # the listing takes +1 for the friction signs of a zero sliding and verge speed
    s = coupled_state(scene, 139 * DEG, 0.0, 0.0, at_rest_signs="listing")
    assert rel(s["phiddot"], 0.1568e7) < 1e-3
    assert rel(s["PN"], 0.3312) < 1e-3
    assert rel(s["PNPSI"], 0.3312) < 1e-3
    assert rel(s["F23"], 2.4663) < 1e-3
    assert rel(s["F12"], 9.6322) < 1e-3
    assert s["psi"] / DEG == pytest.approx(42.08, abs=0.005)
    assert s["g"] == pytest.approx(0.0222, abs=0.00005)


def test_second_printed_line_uses_the_sliding_direction(scene):
    # once the tooth slides, the face friction takes the sliding direction and the
    # acceleration drops to the printed .1212E+07
    s = coupled_state(scene, 139 * DEG, 6.35, 0.0, at_rest_signs="motion")
    assert rel(s["phiddot"], 0.1212e7) < 2e-3
    assert rel(s["F23"], 2.5031) < 2e-3
    assert rel(s["F12"], 9.6925) < 2e-3
    assert rel(s["PN"], 0.3305) < 2e-3
    assert s["PN"] == pytest.approx(s["PNPSI"], rel=1e-12)


def test_verge_acceleration_coefficient_is_the_second_derivative(scene):
    # C28 is printed with a leading minus sign; the listing has none.  Finite differences decide.
    k = scene.constants()
    for alpha in (k.alpha_en, k.alpha_ex):
        phi0 = 139 * DEG if alpha == k.alpha_en else 212 * DEG
        h = 1e-4
        psi = [coupled_kinematics(k.a, k.b, k.c, alpha, phi0 + d)[0] for d in (-h, 0.0, h)]
        u, v = coupled_kinematics(k.a, k.b, k.c, alpha, phi0)[2:4]
        assert (psi[2] - psi[0]) / (2 * h) == pytest.approx(u, rel=1e-6)
        assert (psi[2] - 2 * psi[1] + psi[0]) / h**2 == pytest.approx(v, rel=1e-4)


def test_impact_map_on_printed_pre_impact_state(scene):
    out = impact(scene, 211.782 * DEG, 315.922 * DEG, 620.77, 456.64, side="exit", restitution=0.0)
    assert rel(out["VP"], 47.109) < 1e-3
    assert rel(out["VS"], -71.706) < 1e-3
    assert rel(out["phidot"], 113.856) < 1e-3
    assert rel(out["psidot"], -127.482) < 1e-3
    assert out["VP_after"] == pytest.approx(out["VS_after"], rel=1e-12)  # plastic impact
    assert rel(abs(out["VP_after"]), 13.152) < 1e-3


def test_impact_conserves_energy_when_elastic(scene):
    k = scene.constants()
    phi, psi, pd, qd = 211.782 * DEG, 315.922 * DEG, 620.77, 456.64
    out = impact(scene, phi, psi, pd, qd, side="exit", restitution=1.0)
    e0 = k.istot * pd**2 + k.ip * qd**2
    e1 = k.istot * out["phidot"] ** 2 + k.ip * out["psidot"] ** 2
    assert e1 == pytest.approx(e0, rel=1e-12)
    assert out["phidot"] < 0  # this impact reverses the train


def test_first_free_motion_forces(scene):
    s = free_state(scene, 210.25 * DEG, 473.07, 314.59 * DEG, 493.93, 5.80 * DEG, side="exit")
    assert rel(s["FF12"], 9.439) < 2e-3
    assert rel(s["FF23"], 2.359) < 2e-3
    # for a centred verge only pivot friction acts on it in free motion
    assert s["psiddot"] == pytest.approx(-7.629e5, rel=1e-3)


def test_exit_coupled_equations_reproduce_printed_line_with_listings_mesh_state(scene):
    # First exit-coupled line of the sample: PHI 211.78, PHIDOT 113.86, PHITOT 7.33.  The
    # listing advanced the mesh roll angles about 30 times too fast (see docs/verge.md); with
    # the roll angles it must have had there (0.4086, 0.5181 rad: mesh 2 just past its pitch
    # point) the exit-side equations give the printed forces to four digits.
    from escfit.verge.dynamics import coupled_eval, coupled_signs

    k = scene.constants()
    phi, phid, phi_total = 211.78 * DEG, 113.86, 7.33 * DEG
    u1 = (k.al1_start - k.al1_in) + k.n31 * phi_total
    u2 = (k.al2_start - k.al2_in) - k.n32 * phi_total
    n1 = (k.al1_in + u1 - 0.4086) / k.al1_range  # tooth "index" that puts the roll angle there
    n2 = (k.al2_in + u2 - 0.5181) / k.al2_range
    s4, s5 = coupled_signs(k, -1.0, phi, phid, 1.0)
    r = coupled_eval(k, -1.0, phi, phid, phi_total, n1, n2, 1.0, -1.0, s4, s5, 1.0, 1.0, 1.0)
    assert rel(r[0], 0.1124e7) < 2e-3
    assert rel(r[4], 2.4000) < 1e-3
    assert rel(r[5], 9.7741) < 1e-3
    assert rel(r[6], 0.3925) < 1e-3
    assert r[8] == pytest.approx(-0.0115, abs=5e-5)  # G
    assert r[1] / DEG == pytest.approx(315.90, abs=0.005)


# --- the M739 run ----------------------------------------------------------------------------

def test_m739_time_and_turns_to_arm(m739_run):
    ds = m739_run
    assert ds.attrs["status"] == "armed"
    assert rel(float(ds["time_to_arm"]), 0.05156) < 0.03
    assert rel(float(ds["turns_to_arm"]), 25.8) < 0.03
    assert math.degrees(float(ds["phi_total"][-1])) == pytest.approx(1485.0, abs=1e-6)


def test_m739_maximum_contact_forces(m739_run):
    published = {"F23": 3.24, "F12": 11.41, "FF23": 2.93, "FF12": 10.94, "PN": 0.66}
    for key, value in published.items():
        assert rel(float(m739_run[f"{key}_max"]), value) < 0.03, key


def test_m739_regime_cycle(m739_run):
    ds = m739_run
    regimes = ds["regime"].values
    changes = regimes[np.r_[True, regimes[1:] != regimes[:-1]]]
    cycle = ["entrance_coupled", "free", "exit_coupled", "free"]
    assert list(changes[:8]) == cycle * 2
    assert ds.attrs["n_impacts"] == 181
    assert ds.attrs["n_reversals"] == 0
    assert np.all(ds["train_direction"].values == 1)
    assert np.all(np.isfinite(ds["phidot"].values))
    # the coupled-motion contact force is positive and agrees with the verge-side value
    coupled = regimes != "free"
    assert np.all(ds["PN"].values[coupled] > 0)
    # each beat pair advances the wheel by one tooth: 1485 deg / (360/22) deg ~ 90.75 pairs
    assert ds.attrs["n_impacts"] == pytest.approx(2 * 1485 / (360 / 22), abs=1.5)


@pytest.mark.parametrize("mu,published", [(0.05, 22.0), (0.15, 31.0)])
def test_turns_to_arm_other_friction(scene, mu, published):
    p = forward(scene, {"verge.mu": mu, "verge.mu1": mu})
    assert p.status == "armed"
    assert rel(p.turns_to_arm, published) < 0.05


def test_json_summary_and_netcdf(m739_run, tmp_path):
    summary = json.loads(json.dumps(json_summary(m739_run)))
    assert summary["status"] == "armed"
    assert summary["time_to_arm"] == pytest.approx(float(m739_run["time_to_arm"]))
    assert summary["turns_to_arm"] == pytest.approx(float(m739_run["turns_to_arm"]))
    assert set(summary["max_forces"]) == {"F23", "F12", "FF23", "FF12", "PN"}
    path = tmp_path / "verge.nc"
    m739_run.to_netcdf(path, engine="h5netcdf")
    import xarray as xr

    back = xr.load_dataset(path, engine="h5netcdf")
    assert back.attrs["status"] == "armed"
    assert list(back["regime"].values[:3]) == list(m739_run["regime"].values[:3])


# --- numerics ----------------------------------------------------------------------------------

def test_rk4_fourth_order_within_a_phase(scene):
    # Start of the first coupled phase, where the right-hand side is smooth.  (Later the
    # argument of one of the "conservative" absolute values in the pivot reactions passes
    # through zero; such kinks are part of the model and lower the local order there.)
    speeds = []
    for step in (0.32, 0.16, 0.08, 0.04):
        res = run(scene, solver="rk4", step=step, t_max=1e-4)
        assert res.reason == "time_limit"
        speeds.append(res.trajectory[-1, 2])
    errors = np.diff(speeds)
    orders = np.log2(errors[:-1] / errors[1:])
    assert np.all((3.8 < orders) & (orders < 4.2))


def test_rk4_converges_over_the_whole_run(scene):
    coarse = forward(scene, step=0.04).turns_to_arm
    fine = forward(scene, step=0.005).turns_to_arm
    assert abs(coarse - fine) < 1e-6


def test_adaptive_solver_agrees_with_rk4(scene):
    a = run(scene, solver="rk4", record=False)
    b = run(scene, solver="ivp", record=False)
    assert b.status == "armed"
    assert b.time_to_arm == pytest.approx(a.time_to_arm, rel=1e-7)
    assert b.impacts.shape == a.impacts.shape
    for key in a.maxima:
        assert b.maxima[key] == pytest.approx(a.maxima[key], rel=1e-6)


def test_turns_to_arm_do_not_depend_on_spin(scene):
    # every load is proportional to omega^2, so time scales as 1/omega and turns are fixed
    slow = forward(scene, {"verge.spin": 3000 * math.pi / 30})
    fast = forward(scene)
    assert slow.turns_to_arm == pytest.approx(fast.turns_to_arm, rel=1e-9)
    assert fast.maxima["F23"] / slow.maxima["F23"] == pytest.approx(100.0, rel=1e-9)


# --- hard cases --------------------------------------------------------------------------------

def test_high_friction_stalls_with_clear_status(scene):
    ds = simulate(scene.with_values({"verge.mu": 0.2, "verge.mu1": 0.2}))
    assert ds.attrs["status"] == "not_armed"
    assert ds.attrs["reason"] == "stalled"
    assert "friction" in ds.attrs["message"]
    assert math.isnan(float(ds["time_to_arm"]))
    summary = json.loads(json.dumps(json_summary(ds)))
    assert summary["turns_to_arm"] is None and summary["status"] == "not_armed"


def test_very_low_spin_hits_the_time_limit(scene):
    res = run(scene, {"verge.spin": 30 * math.pi / 30}, t_max=1.0)
    assert res.status == "not_armed" and res.reason == "time_limit"
    assert res.t_end == pytest.approx(1.0)
    # the train barely moves: 1 s at 30 rpm is 1 ms at 30,000 rpm (about one tooth)
    fast = run(scene, t_max=1e-3)
    assert res.phi_total_end == pytest.approx(fast.phi_total_end, rel=1e-9)
    assert math.degrees(res.phi_total_end) < 25
    assert np.all(np.isfinite(res.trajectory))


@pytest.mark.parametrize("e", [0.0, 0.3, 1.0])
def test_restitution_extremes_arm_without_nan(scene, e):
    ds = simulate(scene.with_values({"verge.restitution": e}))
    assert ds.attrs["status"] == "armed"
    for name in ("phi", "phidot", "psi", "psidot", "F23", "F12", "PN"):
        assert np.all(np.isfinite(ds[name].values)), name
    if e == 0.0:
        assert ds.attrs["n_reversals"] == 0
    if e == 0.3:
        assert float(ds["turns_to_arm"]) == pytest.approx(23.96, abs=0.05)  # brief's check value


def test_elastic_impacts_reverse_the_train_and_its_friction(scene):
    ds = simulate(scene.with_values({"verge.restitution": 1.0}))
    assert ds.attrs["n_reversals"] > 0
    assert np.any(ds["phidot_after"].values < 0)
    direction = ds["train_direction"].values
    speed = ds["phidot"].values
    moving = np.abs(speed) > 1e-6
    # gear-train friction follows the direction of the train
    assert np.all(np.sign(speed[moving]) == direction[moving])
    assert np.any(direction == -1)


def test_heavy_verge_reverses_train_in_coupled_motion(scene):
    # a verge much heavier than the referred train throws the wheel back at every plastic impact
    ip = scene.params["verge.ip"].value
    ds = simulate(scene.with_values({"verge.ip": 5 * ip}))
    assert ds.attrs["status"] == "armed"
    assert np.any(ds["phidot_after"].values < 0)
    coupled_back = (ds["regime"].values != "free") & (ds["train_direction"].values == -1)
    assert coupled_back.any()
    assert np.all(np.isfinite(ds["phidot"].values))


@pytest.mark.slow
def test_adaptive_solver_agrees_for_elastic_impacts(scene):
    sc = scene.with_values({"verge.restitution": 1.0})
    a = run(sc, solver="rk4", record=False)
    b = run(sc, solver="ivp", record=False)
    assert b.time_to_arm == pytest.approx(a.time_to_arm, rel=1e-5)
    assert b.impacts.shape == a.impacts.shape


def test_phase_limit_bounds_the_run(scene):
    from escfit.verge.hybrid import run_rk4

    res = run_rk4(scene.constants(), phi_start=139 * DEG, t_max=1.0, record=False, max_phases=10)
    assert res.status == "not_armed" and res.reason == "phase_limit"


# --- scene and option errors -------------------------------------------------------------------

@pytest.mark.parametrize("key,value,match", [
    ("spin", "30000", "unit"),
    ("spin", '"500 turn"', "not an angular frequency"),
    ("spin", '"2 rad*Hz"', "mixes Hz"),
    ("mu", "-0.1", "physical range"),
    ("restitution", "1.5", "physical range"),
    ("rp2", '"0.05706 in"', "tooth ratio"),
    ("phi_start", '"160 deg"', "entrance face"),
    ("configuration", "3", "configuration"),
    ("m1", '"0.3 in"', "dimension"),
    ("teeth_spanned", "22", "span"),
    ("caprb1", '"0.30 in"', "base radius"),
    ("r4", '"2 in"', "triangle"),
])
def test_bad_values_are_refused_naming_key_and_value(key, value, match):
    with pytest.raises(SceneError) as err:
        load_variant(**{key: value})
    text = str(err.value)
    assert match in text
    assert key in text or "r1..r4" in text
    assert "m739_variant.toml" in text
    if key not in ("r4",):
        assert value.strip('"').split()[0] in text


def test_unknown_and_missing_keys_are_refused():
    text = M739.read_text().replace("mu1 = 0.10", "mu_1 = 0.10")
    with pytest.raises(SceneError, match="mu_1"):
        load_scene("bad.toml", text=text)
    text = M739.read_text().replace('phi_cut = "1485 deg"', "")
    with pytest.raises(SceneError, match="phi_cut"):
        load_scene("bad.toml", text=text)


def test_spin_unit_error_is_a_unit_error():
    with pytest.raises(UnitError):
        load_variant(spin="30000")


def test_mu1_can_be_tied_to_mu():
    sc = load_variant(mu='{ value = 0.15, vary = true, min = 0, max = 0.3 }', mu1='"mu"')
    assert sc.params.values()["verge.mu1"] == pytest.approx(0.15)
    assert sc.constants({"verge.mu": 0.05}).mu1 == pytest.approx(0.05)
    assert [p.name for p in sc.params.free()] == ["verge.mu"]


def test_probe_refuses_bad_arguments_naming_the_value(scene):
    with pytest.raises(SceneError, match="side = 'left'"):
        coupled_state(scene, 139 * DEG, side="left")
    with pytest.raises(SceneError, match="at_rest_signs = 'guess'"):
        coupled_state(scene, 139 * DEG, at_rest_signs="guess")
    with pytest.raises(SceneError, match=r"restitution = 1\.5"):
        impact(scene, 211.782 * DEG, 315.922 * DEG, 620.77, 456.64, restitution=1.5)
    with pytest.raises(SceneError, match="restitution = nan"):
        impact(scene, 211.782 * DEG, 315.922 * DEG, 620.77, 456.64, restitution=float("nan"))


def test_simulate_refuses_foreign_options(scene):
    with pytest.raises(SolverError, match="swings"):
        simulate(scene, swings=3)
    with pytest.raises(SolverError, match="exact"):
        simulate(scene, "exact")
    with pytest.raises(SolverError, match="step"):
        simulate(scene, "ivp", step=0.01)
