"""`escfit init`: a starter scene measured from a recording, then a fit with it.

Synthetic records have a known truth (the simulator's scene); real records are checked against
their sources' own values (the Pohl tracker's damped sine, the multi-arm pendulum's identified
parameters, physics: a string pendulum in air has no dry friction).  Fits here are least
squares, as the starter scene's first use is.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.cli.main import cli
from escfit.core.scene import load_scene
from escfit.inference import fit

from .conftest import DATASETS, SHARED
from .cli_folder import new_folder

REAL = DATASETS / "real"


def _truth_scene(tmp_path, *, restoring="pendulum", omega0=4.0, theta0="30 deg", C=0.05, R=0.02, swings=30):
    text = (f'model = "balance"\n[oscillator]\n{"restoring = " + repr(restoring) if restoring == "pendulum" else ""}\n'
            f'omega0 = {omega0}\ntheta0 = "{theta0}"\n[run]\nswings = {swings}\n'
            f"[effects.viscous]\nC = {C}\n[effects.coulomb]\nR = {R}\n").replace("'", '"')
    path = tmp_path / "truth.toml"
    path.write_text(text)
    return load_scene(path)


def _decay_file(tmp_path, scene, *, name="decay.csv", rate=25.0, sigma_deg=0.2, offset_deg=0.5, t0=2.3,
                columns="deg", seed=1) -> Path:
    """A user's own file: time and angle in a table (optionally a third, unrelated column, no header)."""
    from escfit.balance.synthetic.instruments import record_timeseries

    ts = record_timeseries(scene, rate_hz=rate, sigma=math.radians(sigma_deg), offset=math.radians(offset_deg),
                           seed=seed)
    t = ts.time + t0
    path = tmp_path / name
    if columns == "deg":
        rows = ["time (s),angle (deg)"] + [f"{a:.4f},{b:.4f}" for a, b in zip(t, np.degrees(ts.theta))]
    else:  # whitespace, no header, radians, a third column of something else (a fit residual)
        junk = np.random.default_rng(seed + 1).normal(0, 1e-3, t.size)
        rows = [f"{a:.4f} {b:.6f} {c:.6f}" for a, b, c in zip(t, ts.theta, junk)]
    path.write_text("\n".join(rows) + "\n")
    return path


def _init(args, tmp_path, input=None):
    runner = CliRunner()
    with new_folder(tmp_path) as here:
        result = runner.invoke(cli, ["init", *map(str, args)], input=input, catch_exceptions=False)
        return result, Path(here)


def _covers(res, name, truth):
    row = res.summary()[name]
    return row["lo95"] <= truth <= row["hi95"], (name, truth, row["lo95"], row["hi95"])


def test_init_then_fit_recovers_a_synthetic_pendulum_decay(tmp_path):
    scene = _truth_scene(tmp_path)
    data = _decay_file(tmp_path, scene)
    result, here = _init([data, "--pendulum"], tmp_path)
    assert result.exit_code == 0, result.output
    assert "wrote decay.toml" in result.output
    assert f"next: escfit fit {data} --scene decay.toml --out decay_fit.h5 --report decay.html" in result.output
    doc = tomllib.loads((here / "decay.toml").read_text())
    assert doc["oscillator"]["restoring"] == "pendulum"
    assert doc["observation"]["model"] == "waveform"
    assert "recording" not in doc  # the header said it all
    w = doc["oscillator"]["omega0"]
    assert w["vary"] and w["min"] < 4.0 < w["max"] and abs(w["value"] / 4.0 - 1) < 0.01  # the measured period
    for key, truth in (("viscous", 0.05), ("coulomb", 0.02)):
        p = doc["effects"][key]["C" if key == "viscous" else "R"]
        assert p["vary"] and p["min"] == 0.0 and truth < p["max"] and truth / 3 < p["value"] < 3 * truth  # a start, not a fit
    res = fit(here / "decay.toml", str(data), n_starts=2)
    for name, truth in (("oscillator.omega0", 4.0), ("viscous.C", 0.05), ("coulomb.R", 0.02)):
        ok, why = _covers(res, name, truth)
        assert ok, why


def test_init_finds_the_swinging_column_of_a_headerless_table(tmp_path):
    scene = _truth_scene(tmp_path, restoring="spring", omega0=6.0, theta0="0.5 rad", C=0.08, R=0.05)
    data = _decay_file(tmp_path, scene, name="lab.txt", columns="rad", rate=40.0, sigma_deg=0.1)
    result, here = _init([data, "--spring", "--out", "lab.toml"], tmp_path)
    assert result.exit_code == 0, result.output
    doc = tomllib.loads((here / "lab.toml").read_text())
    assert doc["recording"] == {"angle_column": 2, "angle_unit": "rad"}
    assert "restoring" not in doc["oscillator"]
    assert "column 2 swings" in result.output and "rad assumed" in result.output
    res = fit(here / "lab.toml", str(data), n_starts=2)
    for name, truth in (("oscillator.omega0", 6.0), ("viscous.C", 0.08), ("coulomb.R", 0.05)):
        ok, why = _covers(res, name, truth)
        assert ok, why


def test_init_says_what_it_assumed_off_a_terminal_and_refuses_to_overwrite(tmp_path):
    scene = _truth_scene(tmp_path, swings=12)
    data = _decay_file(tmp_path, scene)
    result, here = _init([data], tmp_path)
    assert result.exit_code == 0
    assert "assumed a spring" in result.output and f"escfit init {data} --pendulum --force" in result.output
    before = (here / "decay.toml").read_text()
    runner = CliRunner()
    import os

    cwd = os.getcwd()
    os.chdir(here)
    try:
        again = runner.invoke(cli, ["init", str(data), "--pendulum"])
        assert again.exit_code == 2 and "exists" in again.output and "--force" in again.output
        assert (here / "decay.toml").read_text() == before
        assert not list(here.glob(".decay.toml.*"))  # no temporary left behind
        forced = runner.invoke(cli, ["init", str(data), "--pendulum", "--force"])
        assert forced.exit_code == 0
        assert 'restoring = "pendulum"' in (here / "decay.toml").read_text()
    finally:
        os.chdir(cwd)


def test_init_refuses_an_unreadable_record_in_one_line_and_writes_nothing(tmp_path):
    bad = tmp_path / "empty.csv"
    bad.write_text("")
    result, here = _init([bad], tmp_path)
    assert result.exit_code == 2
    assert result.output.count("\n") == 1 and "empty" in result.output
    assert not (here / "empty.toml").exists()


def test_fit_without_a_scene_names_init_off_a_terminal(tmp_path):
    scene = _truth_scene(tmp_path, swings=12)
    data = _decay_file(tmp_path, scene)
    result = CliRunner().invoke(cli, ["fit", str(data)])
    assert result.exit_code == 2
    assert result.output.count("\n") == 1 and f"escfit init {data}" in result.output


def test_fit_without_a_scene_on_a_terminal_writes_the_starter_and_fits(tmp_path, monkeypatch):
    import escfit.cli.init as init_module

    monkeypatch.setattr(init_module, "interactive", lambda: True)
    scene = _truth_scene(tmp_path, swings=16)
    data = _decay_file(tmp_path, scene)
    runner = CliRunner()
    with new_folder(tmp_path) as here:
        result = runner.invoke(cli, ["fit", str(data), "--out", "d.h5", "--quiet"], input="y\npendulum\n")
        assert result.exit_code == 0, result.output
        assert "wrote decay.toml" in result.output and "wrote d.h5" in result.output
        assert 'restoring = "pendulum"' in (Path(here) / "decay.toml").read_text()
        declined = runner.invoke(cli, ["fit", str(data), "--out", "e.h5"], input="n\n")
        assert declined.exit_code == 2 and "decay.toml exists" in declined.output


def test_init_reads_amplitude_rows_and_the_fit_finds_dry_friction(tmp_path):
    data = REAL / "pohl_heilaut" / "derived" / "decay_amplitude_halfperiod.csv"
    result, here = _init([data, "--spring"], tmp_path)
    assert result.exit_code == 0, result.output
    doc = tomllib.loads((here / "decay_amplitude_halfperiod.toml").read_text())
    assert doc["recording"]["readings"] == "amplitudes" and doc["recording"]["angle_column"] == 2
    assert doc["oscillator"]["omega0"] == pytest.approx(math.pi / 0.715, rel=1e-3)  # T/2 = 0.715 s, the source's
    res = fit(here / "decay_amplitude_halfperiod.toml", str(data), n_starts=2)
    r = res.summary()["coulomb.R"]
    assert r["lo95"] > 0.2 * r["estimate"]  # ball bearings and a plastic spring: dry friction, clearly
    # the author's exponential fit of all 21 points: b = -0.158 1/s; viscous and dry friction share that decay:
    # the viscous part alone must decay no faster than it
    assert res.summary()["viscous.C"]["estimate"] / 2 < 0.158


@pytest.mark.parametrize("recipe, flag", [("pohl_tracker", "--spring"), ("string_pendulum_lab1", "--pendulum")])
def test_init_on_real_records_fits_the_sources_values(tmp_path, recipe, flag):
    doc = tomllib.loads((DATASETS.parent / "fits" / "real" / f"{recipe}.toml").read_text())
    data = (DATASETS.parent / "fits" / "real" / doc["data"]).resolve()
    result, here = _init([data, flag, "--out", "s.toml"], tmp_path)
    assert result.exit_code == 0, result.output
    res = fit(here / "s.toml", str(data), n_starts=2)
    p = res.summary()
    if recipe == "pohl_tracker":
        assert abs(p["oscillator.omega0"]["estimate"] / 4.610 - 1) < 0.005  # Tracker's damped sine: B = 4.610 rad/s
        assert p["coulomb.R"]["lo95"] > 0.5 * p["coulomb.R"]["estimate"]  # dry friction found
    else:
        assert p["coulomb.R"]["hi95"] < 0.003  # in air: no dry friction to speak of
        assert abs(p["viscous.C"]["estimate"] / 0.0214 - 1) < 0.25  # the naive envelope of the turning points


def test_init_on_the_multiarm_free_swing_finds_the_authors_frequency(tmp_path):
    a1, m1, i1, g = 0.147754901, 0.147584572, 1.09118505e-4, 9.81001310  # their identified values
    omega0 = math.sqrt(m1 * g * a1 / (m1 * a1**2 + i1))
    data = REAL / "multiarm_pendulum" / "SingleDataFreeSwing_1_Dt_0_0001.mat"
    result, here = _init([data, "--pendulum", "--out", "s.toml"], tmp_path)
    assert result.exit_code == 0, result.output
    p = fit(here / "s.toml", str(data), n_starts=2).summary()
    assert abs(p["oscillator.omega0"]["estimate"] / omega0 - 1) < 0.015
    assert p["coulomb.R"]["lo95"] > 0.5 * p["coulomb.R"]["estimate"]  # the dead stop: dry friction


GALILEO = SHARED / "realdata" / "gpl_tests_only" / "arduino_encoder_galileo_ferrucci" / "galileo_2024-07-19_15-25-54.csv"


@pytest.mark.skipif(not GALILEO.exists(), reason="shared real data not present")
def test_init_reads_an_arduino_encoder_log_in_degrees(tmp_path):
    result, here = _init([GALILEO, "--pendulum", "--out", "s.toml"], tmp_path)
    assert result.exit_code == 0, result.output
    doc = tomllib.loads((here / "s.toml").read_text())
    assert doc["recording"] == {"angle_unit": "deg"}  # 1-decimal degrees; the reader's suggestion, taken
    p = fit(here / "s.toml", str(GALILEO), n_starts=2).summary()
    # the source's period 1.36 s is measured on swings of a few degrees (the decay's long tail)
    assert abs(2 * math.pi / p["oscillator.omega0"]["estimate"] / 1.36 - 1) < 0.02


def test_init_reads_a_gyroscope_rate_and_the_fit_recovers_the_decay(tmp_path):
    """A phone gyroscope's rate in deg/s (a linear viscous oscillator, the closed form's derivative):
    init takes it as a rate, and the fit of theta'(t) covers the truth."""
    w0, C, a0 = 5.0, 0.12, 0.4  # rad/s, 1/s, rad
    wd = math.sqrt(w0 ** 2 - C ** 2 / 4)
    t = np.arange(0.0, 14.0, 0.02)
    # theta = a0 e^(-Ct/2) (cos wd t + C/(2 wd) sin wd t), released at rest; its exact derivative:
    rate = -a0 * np.exp(-C * t / 2) * (w0 ** 2 / wd) * np.sin(wd * t)
    rate += np.random.default_rng(4).normal(0, 0.01, t.size) + 0.02  # noise and a bias, rad/s
    data = tmp_path / "gyro.csv"
    data.write_text("t (s),Gyroscope z (deg/s)\n" + "".join(f"{a:.3f},{math.degrees(b):.4f}\n"
                                                          for a, b in zip(t + 1.0, rate)))
    result, here = _init([data, "--spring", "--out", "gyro.toml"], tmp_path)
    assert result.exit_code == 0, result.output
    doc = tomllib.loads((here / "gyro.toml").read_text())
    assert doc["recording"]["velocity_column"] == "Gyroscope z (deg/s)"
    assert "zeros of the rate" in result.output
    res = fit(here / "gyro.toml", str(data), n_starts=2)
    for name, truth in (("oscillator.omega0", w0), ("viscous.C", C)):
        ok, why = _covers(res, name, truth)
        assert ok, why
