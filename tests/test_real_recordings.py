"""Every shipped real recording, read raw (no hand conversion) and fitted by least squares.

References are independent of escfit: the sources' own fits (the Pohl tracker's damped sine,
the multi-arm pendulum's identified parameters), a naive log-linear envelope of the turning
points, and physics (a string pendulum in air has no dry friction to speak of).
"""

from __future__ import annotations

import math
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from escfit.inference import least_squares, make_problem
from escfit.core.scene import load_scene

RECIPES = Path(__file__).resolve().parents[1] / "fits" / "real"


def fit_recipe(name: str):
    doc = tomllib.loads((RECIPES / f"{name}.toml").read_text())
    scene = load_scene((RECIPES / doc["scene"]).resolve())
    problem = make_problem(scene, str((RECIPES / doc["data"]).resolve()))
    res = least_squares(problem, n_starts=2)
    return problem, res, {n: (v, e) for n, v, e in zip(res.names, res.value, res.stderr)}


def test_pohl_tracker_frequency_matches_the_authors_damped_sine():
    problem, res, p = fit_recipe("pohl_tracker")
    assert any("wraps" in n for n in problem.notes)  # atan2 angles unwrapped, said so
    w, se = p["oscillator.omega0"]
    assert abs(w - 4.610) < 0.005 * 4.610  # Tracker's DampedSine fit: B = 4.610 rad/s
    assert p["coulomb.R"][0] > 5 * p["coulomb.R"][1]  # ball bearings and a plastic spring: dry friction


def test_string_pendulum_in_air_gets_no_coulomb_friction():
    problem, res, p = fit_recipe("string_pendulum_lab1")
    r, se = p["coulomb.R"]
    assert r + 1.96 * se < 0.003  # rad/s^2: a Coulomb loss < 1e-3 rad per half swing at omega0^2 = 14.8
    sys.path.insert(0, str(RECIPES))
    from gallery import envelope_c

    c = p["viscous.C"][0]
    assert abs(c / envelope_c(problem) - 1) < 0.25  # the naive envelope: 0.0214 1/s


def test_multiarm_pendulum_frequency_matches_the_authors_and_dry_friction_is_found():
    # their identified a1 = 0.1478 m, m1 = 0.1476 kg, I1 = 1.091e-4 kg m^2, g = 9.810
    a1, m1, i1, g = 0.147754901, 0.147584572, 1.09118505e-4, 9.81001310
    omega0 = math.sqrt(m1 * g * a1 / (m1 * a1**2 + i1))
    for name in ("multiarm_estimation", "multiarm_free_swing"):
        problem, res, p = fit_recipe(name)
        assert abs(p["oscillator.omega0"][0] / omega0 - 1) < 0.015, name
        assert p["coulomb.R"][0] > 10 * p["coulomb.R"][1], name


def test_pohl_scale_readings_read_raw_as_amplitudes():
    problem, res, p = fit_recipe("pohl_amplitudes")
    assert problem.n_data == 21
    assert p["coulomb.R"][0] > 5 * p["coulomb.R"][1]


def test_cli_fits_a_raw_recording_with_a_scene(tmp_path):
    out = tmp_path / "trial1.h5"
    run = subprocess.run(["escfit", "fit",
                          str(RECIPES.parents[1] / "datasets/real/string_pendulum_video/trial1_rawdata.txt"),
                          "--scene", str(RECIPES.parents[1] / "datasets/real/scenes/string_pendulum_trial1.toml"),
                          "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "note: the record starts mid-swing" in run.stdout
    assert out.exists()


@pytest.mark.slow
def test_string_pendulum_with_air_drag_leaves_no_structure_and_no_dry_friction(tmp_path):
    """The 116 s string pendulum fitted with viscous + Coulomb friction and with quadratic air drag
    added (``string_pendulum_lab1_drag``): drag removes the residual runs and the correlated
    innovations that viscous + Coulomb leave (a decrement growing with the amplitude), AICc prefers
    it by far, and R stays at zero (a pendulum in air)."""
    import json

    import h5py

    from escfit.inference import fit
    from escfit.inference.compare import compare_fits

    files = {}
    for name in ("string_pendulum_lab1", "string_pendulum_lab1_drag"):
        doc = tomllib.loads((RECIPES / f"{name}.toml").read_text())
        files[name] = tmp_path / f"{name}.h5"
        fit(load_scene((RECIPES / doc["scene"]).resolve()), str((RECIPES / doc["data"]).resolve()), out=files[name],
            seed=1)
    misfit = {k: json.loads(h5py.File(f).attrs["misfit"]) for k, f in files.items()}
    assert misfit["string_pendulum_lab1"]["runs_z"] < -4 and misfit["string_pendulum_lab1"]["lag1_autocorrelation"] > 0.5
    assert misfit["string_pendulum_lab1_drag"]["runs_z"] > -4  # the runs test no longer flags
    assert misfit["string_pendulum_lab1_drag"]["lag1_autocorrelation"] < 0.5  # nor the innovations
    cmp = compare_fits(list(files.values()))
    assert cmp.best == str(files["string_pendulum_lab1_drag"]) and cmp.rows[1]["d_aicc"] > 100
    with h5py.File(files["string_pendulum_lab1_drag"]) as h:
        names = [n.decode() if isinstance(n, bytes) else str(n) for n in h["least_squares/parameter"][:]]
        hi = dict(zip(names, h["least_squares/hi95"][:]))
        lo = dict(zip(names, h["least_squares/lo95"][:]))
    assert hi["coulomb.R"] < 0.005  # rad/s^2: below 7e-4 rad per half swing at omega0^2 = 14.8
    assert lo["drag.D"] > 0.005  # 1/rad: drag resolved well away from zero
