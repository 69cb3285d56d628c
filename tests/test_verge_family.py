"""The verge family on the one inference layer: the shipped example through ``escfit``.

The forward model is expensive (one M739 arming run, ~360 motion phases, takes ~45 ms of CPU),
so the emcee runs here are short (4 walkers x 10 steps, the family's de-t moves, as the
recipe says): they check the machinery (draws, resume, summary, report) and that the draws
sit where the independent Laplace approximation puts the posterior, not the tails.  The
converging posterior test is in tests/test_verge_inference.py.
"""

from __future__ import annotations

import hashlib
import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.cli.main import cli
from escfit.core.errors import DataError, FitError, SceneError
from escfit.core.scene import load_scene
from escfit.inference import fit, family
from escfit.results import load_fit
from escfit.verge.data import TurnsData, read_turns_csv
from escfit.verge.problem import TurnsProblem
from escfit.verge.simulate import forward

from .conftest import DATASETS, ROOT

RECIPE = ROOT / "fits" / "verge_m739.toml"
SCENE = DATASETS / "verge" / "m739_fit.toml"
DATA = DATASETS / "verge" / "m739_output_turns.csv"
MU_REPORTED = 0.10  # Lowen & Tepper (1982): 25.8 turns at mu = mu1 = 0.10
SHORT = ["--walkers", "4", "--steps", "10", "--burn", "4"]


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # nothing a recipe writes relative to the working directory lands in the repo


@pytest.fixture(scope="module")
def laplace_sd():
    """Independent Laplace approximation: sd / |dT/dmu| from two forward runs at the published point."""
    scene = load_scene(DATASETS / "verge" / "m739.toml")
    h = 1e-4
    up, down = (forward(scene, {"verge.mu": m, "verge.mu1": m}, step=0.2).turns_to_arm
                for m in (MU_REPORTED + h, MU_REPORTED - h))
    return 0.26 / ((up - down) / (2 * h))


@pytest.fixture(scope="module")
def shipped_emcee(tmp_path_factory):
    """The shipped recipe through ``escfit fit`` with a short emcee run, and its report."""
    d = tmp_path_factory.mktemp("verge_emcee")
    out, html = d / "m739.h5", d / "m739.html"
    r = run("fit", RECIPE, *SHORT, "--out", out, "--report", html)
    assert r.exit_code == 0, r.output
    return out, html, r.output


def test_shipped_example_least_squares(tmp_path, laplace_sd):
    out = tmp_path / "lsq.h5"
    r = run("fit", RECIPE, "--method", "leastsq", "--out", out)
    assert r.exit_code == 0, r.output
    assert "verge.mu" in r.output
    res = load_fit(out)
    lsq = res.group("least_squares")
    mu, se = float(lsq["value"].sel(parameter="verge.mu")), float(lsq["stderr"].sel(parameter="verge.mu"))
    # one reading, one parameter: fitted exactly, with the Laplace standard error
    assert float(lsq["expected"][0]) == pytest.approx(25.8, abs=1e-3)
    assert se == pytest.approx(laplace_sd, rel=0.02)
    assert abs(mu - MU_REPORTED) < 2 * se
    a = res.attrs
    assert a["model"] == "verge" and a["method"] == "leastsq" and a["data_kind"] == "turns-to-arm"
    assert a["data_sha256"] == hashlib.sha256(DATA.read_bytes()).hexdigest()
    assert json.loads(a["solver_options"]) == {"step": 0.2}
    assert res.parameter_names == ["verge.mu"]
    obs = res.group("observed_data")
    assert obs["x"].attrs["units"] == "rpm" and float(obs["x"][0]) == 30000.0


def test_shipped_example_emcee(shipped_emcee, laplace_sd):
    out, _html, output = shipped_emcee
    res = load_fit(out)
    post = res.group("posterior")
    assert post.sizes == {"chain": 4, "draw": 6}  # steps - burn kept per walker
    x = post["verge.mu"].values.ravel()
    lsq = res.group("least_squares")
    mu = float(lsq["value"].sel(parameter="verge.mu"))
    assert np.all(np.isfinite(x))
    assert abs(np.median(x) - mu) < laplace_sd  # the draws sit on the Laplace posterior ...
    assert 0.2 * laplace_sd < x.std() < 2.0 * laplace_sd  # ... and have its width
    assert res.attrs["moves"] == "de-t" and res.attrs["walkers"] == 4
    assert "posterior_predictive" in res.tree.children and "log_likelihood" in res.tree.children
    pred = res.group("posterior_predictive")["expected"].values
    assert np.all(np.abs(pred - 25.8) < 5 * 0.26)  # every stored draw arms near the reading


def test_summary_json_and_report(shipped_emcee):
    out, html, _output = shipped_emcee
    r = run("summary", out, "--json")
    assert r.exit_code == 0, r.output
    s = json.loads(r.output)
    assert list(s["parameters"]) == ["verge.mu"]
    row = s["parameters"]["verge.mu"]
    assert row["unit"] == "" and {"median", "lo95", "hi95", "rhat", "ess_bulk"} <= set(row)
    assert s["method"] == "emcee" and s["data_file"].endswith("m739_output_turns.csv")
    assert any("sd column" in n for n in s["notes"])
    text = html.read_text()
    assert "verge.mu" in text and "R-hat" in text
    again = run("report", out, "--out", html.with_name("again.html"))
    assert again.exit_code == 0 and "verge.mu" in html.with_name("again.html").read_text()


def test_interrupted_run_resumes_to_the_same_draws(shipped_emcee, tmp_path, monkeypatch):
    reference = load_fit(shipped_emcee[0]).group("posterior")["verge.mu"].values
    out = tmp_path / "resume.h5"
    calls = {"n": 0}
    original = TurnsProblem.log_prob

    def dying(self, vec):
        calls["n"] += 1
        if calls["n"] > 4 + 4 * 5:  # walker placement, then five steps
            raise KeyboardInterrupt
        return original(self, vec)

    monkeypatch.setattr(TurnsProblem, "log_prob", dying)
    r = run("fit", RECIPE, *SHORT, "--out", out)
    assert r.exit_code != 0 and calls["n"] > 4 + 4 * 5
    monkeypatch.setattr(TurnsProblem, "log_prob", original)
    assert not out.exists() and (tmp_path / "resume.h5.emcee").exists()
    refused = run("fit", RECIPE, *SHORT, "--out", out)
    assert refused.exit_code == 2 and "resume" in refused.output
    r = run("fit", RECIPE, *SHORT, "--out", out, "--resume")
    assert r.exit_code == 0, r.output
    res = load_fit(out)
    assert res.attrs["resumed"] == 1
    post = res.group("posterior")["verge.mu"].values
    assert post.shape == (4, 10 - 4)
    np.testing.assert_array_equal(post, reference)
    assert not (tmp_path / "resume.h5.emcee").exists()


# -- the family entry and the problem ------------------------------------------------------
def test_family_reads_detects_and_refuses():
    fam = family("verge")
    assert fam.detect(DATA) == "turns-to-arm" and set(fam.formats) == {"turns-to-arm"}
    with pytest.raises(DataError, match="not a turns-to-arm table"):
        fam.detect(DATASETS / "monday1965" / "synthetic" / "unit1.csv")
    with pytest.raises(FitError, match="solver"):
        fam.problem(SCENE, DATA, solver="ivp")
    assert fam.figures(None) == {}
    assert {"walkers", "steps", "n_starts", "predictive_draws"} <= set(fam.fit_defaults)
    problem = fam.problem(SCENE, DATA)
    assert problem.names == ["verge.mu"] and problem.noise_names == ()
    assert problem.priors[0].kind == "uniform" and problem.priors[0].support == (0.0, 0.3)  # from the scene
    assert problem.values(np.array([0.07]))["verge.mu1"] == 0.07  # mu1 = "mu" ties it


def test_python_api_fit_of_an_in_memory_reading(laplace_sd):
    data = TurnsData(np.array([30000.0]), np.array([25.8]), np.array([0.26]), ("published",))
    res = fit(SCENE, data, method="leastsq")
    lsq = res.group("least_squares")
    assert float(lsq["value"][0]) == pytest.approx(MU_REPORTED, abs=2 * laplace_sd)
    assert res.attrs["data_sha256"] == ""


def test_not_arming_is_minus_infinity_with_the_reason_counted():
    problem = family("verge").problem(SCENE, DATA)
    assert problem.log_prob(np.array([0.25])) == -math.inf  # stalls above mu = 0.169
    assert problem.failures["not_armed: stalled"] == 1
    vals = problem.values(np.array([0.25]))
    assert np.all(problem.residuals(vals) == 1e6)
    assert np.all(problem.loglike_pointwise(vals) == -math.inf)
    assert problem.failures["not_armed: stalled"] == 1  # cached: one simulation per parameter set
    with pytest.raises(FitError, match="does not arm"):
        problem.expected(vals)
    assert problem.log_prior(np.array([0.35])) == -math.inf  # outside the scene's [0, 0.3]


def _scene(tmp_path, extra: str, replace: tuple[str, str] | None = None):
    text = SCENE.read_text()
    if replace:
        text = text.replace(*replace)
    path = tmp_path / "scene.toml"
    path.write_text(text.replace("[fit]\n", extra + "\n[fit]\n", 1))
    return path


def test_observation_sigma_from_the_scene(tmp_path):
    data = read_turns_csv(DATA)
    fixed = family("verge").problem(_scene(tmp_path, "[observation]\nsigma = 0.52"), data)
    assert fixed.names == ["verge.mu"] and fixed.units["observation.sigma"] == "turns"
    vals = fixed.values(np.array([0.1]))
    known = family("verge").problem(SCENE, data)
    # sigma = 2 x the sd column halves the standardised residual
    assert fixed.residuals(vals)[0] == pytest.approx(known.residuals(known.values(np.array([0.1])))[0] / 2, rel=1e-12)
    in_degrees = family("verge").problem(_scene(tmp_path, '[observation]\nsigma = "187.2 deg"'), data)
    assert in_degrees.sigma(vals)[0] == pytest.approx(0.52, rel=1e-12)  # 187.2 deg of spin = 0.52 turn
    free = family("verge").problem(_scene(tmp_path, '[observation]\nsigma = { value = "0.3 turn", vary = true, '
                                                    'prior = "loguniform(0.05, 2)" }'), data)
    assert free.names == ["verge.mu", "observation.sigma"] and free.noise_names == ("observation.sigma",)
    assert free.initial[1] == pytest.approx(0.3) and free.priors[1].kind == "loguniform"


def test_scene_and_data_refusals_name_the_key(tmp_path):
    fam = family("verge")
    with pytest.raises(SceneError, match=r"\[observation\].*noise"):
        fam.problem(_scene(tmp_path, "[observation]\nnoise = 0.3"), DATA)
    nosd = tmp_path / "nosd.csv"
    nosd.write_text("label,spin_rpm,turns\na,30000,25.8\n")
    assert read_turns_csv(nosd).sd is None
    with pytest.raises(SceneError, match=r"observation.sigma"):
        fam.problem(SCENE, nosd)
    with pytest.raises(SceneError, match=r"\[fit\].*solver"):
        fam.problem(_scene(tmp_path, "", ("step = 0.2", 'solver = "ivp"')), DATA)
    with pytest.raises(FitError, match="proper prior"):
        fam.problem(_scene(tmp_path, "", ('rho1 = "0.03075 in"', 'rho1 = { value = "0.03075 in", vary = true }')),
                    DATA)
    with pytest.raises(FitError, match="spin"):
        fam.problem(_scene(tmp_path, "", ('spin = "30000 rpm"', 'spin = { value = "30000 rpm", vary = true, '
                                          'min = "1000 rpm", max = "40000 rpm" }')), DATA)


@pytest.mark.parametrize("text,where,match", [
    ("label,spin_rpm,turns,sd\na,30000,many,0.3\n", ":2", "'turns'.*'many'"),
    ("# comment\n\nlabel,spin_rpm,turns,sd\na,30000,25,-0.3\n", ":4", "'sd'.*positive"),
    ("label,spin_rpm,turns\na,30000\n", ":2", "2 fields"),
    ("label,spin_rpm,sd\na,30000,0.3\n", ":1", "turns"),
    ("# nothing\n", "", "empty"),
])
def test_reader_errors_name_file_line_and_column(tmp_path, text, where, match):
    path = tmp_path / "turns.csv"
    path.write_text(text)
    with pytest.raises(DataError, match=match) as err:
        read_turns_csv(path)
    assert err.value.where == f"{path}{where}"


def test_cli_refuses_balance_options_for_verge(tmp_path):
    r = run("fit", DATA, "--scene", SCENE, "--unit", "a", "--out", tmp_path / "x.h5")
    assert r.exit_code == 2 and "balance" in r.output
