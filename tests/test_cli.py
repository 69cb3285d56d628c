"""The command line: exit codes, JSON output, atomic and non-overwriting outputs."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.cli.main import cli

from .conftest import DATASETS, ROOT


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def test_simulate_json_and_out(tmp_path):
    r = run("simulate", DATASETS / "scenes" / "monday_sample_phase.toml", "--swings", "8", "--json")
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    assert set(d) >= {"amplitude", "half_period", "time", "rate", "status"}
    assert d["amplitude"][1] == pytest.approx(5.548613, abs=1e-6) and d["status"] == "ok"
    out = tmp_path / "run.nc"
    assert run("simulate", DATASETS / "scenes" / "horology_rk4_case.toml", "--swings", "3", "--out", out).exit_code == 0
    before = out.read_bytes()
    again = run("simulate", DATASETS / "scenes" / "horology_rk4_case.toml", "--swings", "4", "--out", out)
    assert again.exit_code == 2 and "exists" in again.output and out.read_bytes() == before
    assert run("simulate", DATASETS / "scenes" / "horology_rk4_case.toml", "--swings", "4", "--out", out,
               "--force").exit_code == 0
    assert not list(tmp_path.glob("*.part"))


@pytest.mark.parametrize("solver", ["rk4", "ivp"])
def test_simulate_other_solvers(solver):
    args = ["--h", "1e-5"] if solver == "rk4" else []
    r = run("simulate", DATASETS / "scenes" / "horology_rk4_case.toml", "--swings", "2", "--solver", solver, "--json", *args)
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["half_period"][0] == pytest.approx(0.1000035078, abs=2e-9)


def test_bad_scene_exits_2_with_one_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('model = "balance"\n[oscillator]\nomega0 = 10\ntheta0 = "3 m"\n')
    r = run("simulate", bad)
    assert r.exit_code == 2
    assert "bad.toml" in r.output and "theta0" in r.output and len(r.output.strip().splitlines()) == 1


def test_fit_recipe_summary_and_reports(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    shutil.copytree(ROOT / "fits", tmp_path / "fits")
    shutil.copytree(DATASETS, tmp_path / "datasets")
    r = run("fit", "fits/monday_unit4.toml", "--steps", "300", "--walkers", "12", "--report", "u4.html")
    assert r.exit_code == 0, r.output
    assert (tmp_path / "monday_unit4.h5").exists() and (tmp_path / "u4.html").exists()
    html = (tmp_path / "u4.html").read_text()
    assert "data:image/png;base64," in html and "coulomb.R[load=165.33 g]" in html and "R-hat" in html
    import html as html_module
    import tomllib

    title = tomllib.loads((ROOT / "fits" / "monday_unit4.toml").read_text())["title"]
    assert f"<h1>{html_module.escape(title)}</h1>" in html  # the recipe's title, kept with the fit
    s = json.loads(run("summary", "monday_unit4.h5", "--json").output)
    assert s["parameters"]["viscous.C"]["unit"] == "1/s"
    assert set(s["parameters"]["viscous.C"]) >= {"median", "lo95", "hi95", "unit"}
    # the report written with the fit (from the results in memory) is the one the file gives
    assert run("report", "monday_unit4.h5", "--out", "again.html").exit_code == 0
    assert (tmp_path / "again.html").read_text() == html
    md = run("report", "monday_unit4.h5", "--format", "md")
    assert md.exit_code == 0 and (tmp_path / "monday_unit4.md").exists()
    again = run("fit", "fits/monday_unit4.toml", "--steps", "300", "--walkers", "12")
    assert again.exit_code == 2 and "exists" in again.output


def test_fit_leastsq_on_data_with_scene(tmp_path):
    out = tmp_path / "u1.h5"
    r = run("fit", DATASETS / "monday1965" / "synthetic" / "unit1.csv", "--scene",
            DATASETS / "monday1965" / "unit1_fit.toml", "--out", out)
    assert r.exit_code == 0, r.output
    assert "coulomb.R[load=330.66 g]" in r.output


def test_fit_rig_and_summary(tmp_path):
    out = tmp_path / "rig.h5"
    r = run("fit", DATASETS / "friction" / "monday1965_session_1095_steel.csv", "--scene",
            DATASETS / "friction" / "monday1965_rig.toml", "--method", "emcee", "--steps", "600", "--out", out)
    assert r.exit_code == 0, r.output
    s = json.loads(run("summary", out, "--json").output)
    mu = s["parameters"]["friction.mu"]
    assert mu["lo95"] < 0.100 < mu["hi95"]  # Monday's printed mu for ruby on 1095 steel
    assert s["parameters"]["rig.k"]["unit"] == "m" and "rhat" in mu
    # 600 steps are about 11 autocorrelation times: said so (the old rig writer always wrote no warnings)
    assert any("autocorrelation" in w for w in s["warnings"])


@pytest.mark.parametrize("args, fragment", [
    (["fit", "nope.csv", "--scene", DATASETS / "scenes" / "monday_unit_angle_fit.toml"], "data file not found"),
    (["fit", DATASETS / "monday1965" / "synthetic" / "unit1.csv"], "--scene"),
    (["summary", "missing.h5"], "results file not found"),
    (["report", DATASETS / "scenes" / "horology_rk4_case.toml"], "not an HDF5 file"),
    (["fit", ROOT / "fits" / "monday_unit3.toml", "--steps", "many"], "neither 'auto' nor a whole number"),
    (["fit", ROOT / "fits" / "monday_unit3.toml", "--steps", "5"], "neither 'auto' nor a whole number"),
])
def test_errors_exit_2(args, fragment):
    r = run(*args)
    assert r.exit_code == 2, r.output
    assert fragment in r.output


@pytest.mark.parametrize("line", ['steps = "many"', "steps = 5", "max_steps = 2.5", "steps = true"])
def test_recipe_run_lengths_of_the_wrong_kind_exit_2_naming_the_key(tmp_path, line):
    recipe = tmp_path / "r.toml"
    text = (ROOT / "fits" / "monday_unit3.toml").read_text().replace("../", str(ROOT) + "/")
    recipe.write_text("\n".join(ln for ln in text.splitlines() if not ln.startswith("steps")) + "\n" + line + "\n")
    r = run("fit", recipe, "--out", tmp_path / "o.h5")
    assert r.exit_code == 2 and f"{recipe} (recipe).{line.split()[0]}" in r.output, r.output
    assert not (tmp_path / "o.h5").exists()


def test_balance_emcee_run_interrupted_and_resumed_from_the_command_line(tmp_path, monkeypatch):
    """A balance recipe killed mid-run continues with --resume to the same draws as an uninterrupted run."""
    from escfit.balance.problems.curves import FitProblem
    from escfit.results import load_fit

    recipe = ROOT / "fits" / "monday_unit4.toml"
    args = [recipe, "--walkers", 12, "--steps", 60, "--burn", 20, "--seed", 7, "--quiet"]
    whole = tmp_path / "whole.h5"
    assert run("fit", *args, "--out", whole).exit_code == 0
    out = tmp_path / "cut.h5"
    calls = {"n": 0}
    original = FitProblem.log_prob_many  # the exact solver evaluates each half-ensemble in one call

    def dying(self, vecs):
        calls["n"] += 1
        if calls["n"] > 1 + 2 * 25 + 1:  # first ensemble, 25 steps, then half of one
            raise KeyboardInterrupt
        return original(self, vecs)

    monkeypatch.setattr(FitProblem, "log_prob_many", dying)
    cut = CliRunner().invoke(cli, ["fit", *map(str, args), "--out", str(out)])
    monkeypatch.setattr(FitProblem, "log_prob_many", original)
    assert cut.exit_code == 130 and not out.exists() and Path(f"{out}.emcee").exists()
    assert "25 sampler steps are saved" in cut.output and "--resume" in cut.output  # every completed step
    refused = run("fit", *args, "--out", out)
    assert refused.exit_code == 2 and "--resume" in refused.output
    assert run("fit", *args, "--out", out, "--resume").exit_code == 0
    a, b = load_fit(out), load_fit(whole)
    assert a.attrs["resumed"] == 1 and a.group("posterior").sizes == {"chain": 12, "draw": 60 - 20}
    for name in a.parameter_names:
        np.testing.assert_array_equal(a.group("posterior")[name].values, b.group("posterior")[name].values)
    assert not Path(f"{out}.emcee").exists()


def test_simulate_records_nearest_mark_notch_readings(tmp_path):
    # 6-degree notches read at the nearest mark against marks counted: every reading n differs by
    # floor(A/d + 1/2) - floor(A/d), 0 or 1, and the two recordings of one seed share their amplitudes
    scene = DATASETS / "monday1965" / "synthetic" / "unit3_load330.66g.toml"
    outs = {}
    for reading in ("counted", "nearest"):
        out = tmp_path / f"{reading}.csv"
        r = run("simulate", scene, "--recorder", "unit-curve", "--notch-deg", "6", "--notch-reading", reading,
                "--noise", "0", "--out", out)
        assert r.exit_code == 0, r.output
        rows = [line.split(",") for line in out.read_text().splitlines() if line and not line.startswith("#")]
        col = rows[0].index("notches")
        outs[reading] = np.array([float(row[col]) for row in rows[1:]])
    diff = outs["nearest"] - outs["counted"]
    assert set(np.unique(diff)) <= {0.0, 1.0} and 0 < diff.sum() < diff.size
    bad = run("simulate", scene, "--recorder", "unit-curve", "--notch-reading", "nearest", "--out", tmp_path / "x.csv")
    assert bad.exit_code == 2 and "--notch-deg" in bad.output and not (tmp_path / "x.csv").exists()
