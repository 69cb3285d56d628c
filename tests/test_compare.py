"""``escfit compare``: ranking fits of the same readings, its numbers and its refusals.

Synthetic unit curves from the exact solver with a known damping law (viscous only, or
viscous + Coulomb), read every half swing with Gaussian noise of known scale, are fitted by
a viscous-only model and by the viscous + Coulomb model that nests it.  The numbers are
checked against independent references: the Gaussian log-likelihood written out from the
stored readings and expectations, scipy's normal density, and ArviZ's own ``compare``.
"""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest
from click.testing import CliRunner

from escfit import load_scene
from escfit.balance.synthetic.instruments import record
from escfit.cli.main import cli
from escfit.core.errors import ResultsError
from escfit.inference import fit
from escfit.inference.compare import compare_fits
from escfit.results import load_fit, write_fit

OMEGA0 = 2 * math.pi
TRUTH = {"viscous": "[effects.viscous]\nC = 0.05\n",
         "viscous_coulomb": "[effects.viscous]\nC = 0.05\n[effects.coulomb]\nR = 0.1\n"}
NOISE = 0.003  # rad: a tenth of the Coulomb decrement 2R/omega0^2 = 5e-3 rad per half swing is 5e-4

FIT_V = """model = "balance"
[oscillator]
omega0 = 6.283185307179586
theta0 = { value = 1.0, vary = true, min = 0.5, max = 1.5 }
[effects.viscous]
C = { value = 0.1, vary = true, min = 0, max = 1 }
"""
FIT_VC = FIT_V + "[effects.coulomb]\nR = { value = 0.05, vary = true, min = 0, max = 1 }\n"
FREE_SIGMA = '[observation]\nsigma = { value = 0.01, vary = true, min = 1e-4, max = 0.1 }\n'


def _truth(tmp, law: str, seed: int):
    scene = tmp / f"truth_{law}.toml"
    scene.write_text(f'model = "balance"\n[oscillator]\nomega0 = {OMEGA0!r}\ntheta0 = 1.0\n[run]\nswings = 40\n'
                     + TRUTH[law])
    data = tmp / f"{law}.csv"
    record(load_scene(scene), "unit-curve", data, noise=NOISE, seed=seed, every=1)
    return data


def _fit(tmp, data, scene_text: str, name: str, **kw):
    scene = tmp / f"{name}.toml"
    scene.write_text(scene_text)
    out = tmp / f"{name}.h5"
    fit(scene, data, out=out, seed=1, **{"n_starts": 2, **kw})
    return out


@pytest.fixture(scope="module")
def lsq_fits(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("compare")
    out = {}
    for law, seed in (("viscous_coulomb", 1), ("viscous", 2)):
        data = _truth(tmp, law, seed)
        out[law] = {"data": data,
                    "v": _fit(tmp, data, FIT_V + FREE_SIGMA, f"{law}_fit_v"),
                    "vc": _fit(tmp, data, FIT_VC + FREE_SIGMA, f"{law}_fit_vc")}
    data = out["viscous_coulomb"]["data"]
    out["viscous_coulomb"]["vc_known"] = _fit(tmp, data, FIT_VC + f"[observation]\nsigma = {NOISE}\n", "fit_vc_known")
    return tmp, out


def run(*args):
    return CliRunner().invoke(cli, ["compare", *map(str, args)])


def test_least_squares_prefers_the_true_law_with_coulomb(lsq_fits):
    _, fits = lsq_fits
    f = fits["viscous_coulomb"]
    cmp = compare_fits([f["v"], f["vc"]])
    assert cmp.criterion == "aicc" and cmp.best == str(f["vc"])
    worse = cmp.rows[1]
    # Coulomb friction of 5e-3 rad per half swing over 40 half swings with 3e-3 rad noise: decisive
    assert worse["d_aicc"] > 10 and worse["d_bic"] > 10 and worse["akaike_weight"] < 1e-3
    assert "strongly preferred" in cmp.notes[-1]


def test_least_squares_does_not_invent_coulomb_friction(lsq_fits):
    _, fits = lsq_fits
    f = fits["viscous"]
    cmp = compare_fits([f["vc"], f["v"]])
    by = {r["file"]: r for r in cmp.rows}
    # the nesting model can only gain likelihood; with the fixed seed its gain stays well below the
    # two units of AICc its extra parameter costs, so the verdict cannot flip on round-off
    gain = 2 * (by[str(f["vc"])]["loglike"] - by[str(f["v"])]["loglike"])
    assert -1e-6 <= gain < 1.0
    assert cmp.best == str(f["v"]) and cmp.rows[1]["d_bic"] > 2
    assert "prefer the simplest" in cmp.notes[-1] or "preferred" in cmp.notes[-1]


def test_loglike_and_criteria_against_the_gaussian_likelihood_written_out(lsq_fits):
    _, fits = lsq_fits
    f = fits["viscous_coulomb"]
    cmp = compare_fits([f["v"], f["vc"]])
    for row in cmp.rows:
        res = load_fit(row["file"])
        y = res.group("observed_data")["reading"].values
        e = res.group("least_squares")["expected"].values
        n, rss = y.size, float(np.sum((y - e) ** 2))
        ll = -0.5 * n * (math.log(2 * math.pi * rss / n) + 1.0)  # sigma at its maximum-likelihood value
        k = len(res.parameter_names)  # theta0, C (and R), sigma: every free parameter, the profiled scale too
        assert row["n_params"] == k and row["n_readings"] == n == 41
        assert row["loglike"] == pytest.approx(ll, rel=1e-9)
        assert row["aicc"] == pytest.approx(-2 * ll + 2 * k + 2 * k * (k + 1) / (n - k - 1), rel=1e-9)
        assert row["bic"] == pytest.approx(-2 * ll + k * math.log(n), rel=1e-9)
        assert "Gaussian" in row["noise_model"] and "profiled" in row["noise_model"]
    w = np.array([r["akaike_weight"] for r in cmp.rows])
    d = np.array([r["d_aicc"] for r in cmp.rows])
    assert w.sum() == pytest.approx(1.0) and w[1] / w[0] == pytest.approx(math.exp(-d[1] / 2), rel=1e-9)


def test_the_report_prints_the_criteria_compare_ranks_by(lsq_fits):
    """The report's fit statistics and escfit compare print one computation: the AICc and BIC of
    the Gaussian likelihood written out from the stored readings (profiled scale, every free
    parameter counted), to the digits the report shows."""
    import re

    from escfit.report.tables import fit_statistics

    _, fits = lsq_fits
    f = fits["viscous_coulomb"]
    for path in (f["v"], f["vc"]):
        res = load_fit(path)
        y = res.group("observed_data")["reading"].values
        e = res.group("least_squares")["expected"].values
        n, rss = y.size, float(np.sum((y - e) ** 2))
        ll = -0.5 * n * (math.log(2 * math.pi * rss / n) + 1.0)
        k = len(res.parameter_names)
        text = fit_statistics(res)
        got = {m.group(1): float(m.group(2)) for m in re.finditer(r"(AICc|BIC) (-?[0-9.]+(?:e[-+]?[0-9]+)?)", text)}
        assert got["AICc"] == pytest.approx(-2 * ll + 2 * k + 2 * k * (k + 1) / (n - k - 1), rel=1e-5), text
        assert got["BIC"] == pytest.approx(-2 * ll + k * math.log(n), rel=1e-5), text
        row = next(r for r in compare_fits([f["v"], f["vc"]]).rows if r["file"] == str(path))
        assert got["AICc"] == pytest.approx(row["aicc"], rel=1e-5) and got["BIC"] == pytest.approx(row["bic"], rel=1e-5)
        assert "aic" not in res.group("least_squares").attrs  # the old number that dropped constants is gone


def test_known_noise_scale_is_not_a_parameter_and_enters_the_likelihood(lsq_fits):
    from scipy.stats import norm

    _, fits = lsq_fits
    f = fits["viscous_coulomb"]
    cmp = compare_fits([f["vc_known"], f["vc"]])
    row = next(r for r in cmp.rows if r["file"] == str(f["vc_known"]))
    res = load_fit(f["vc_known"])
    y, e = res.group("observed_data")["reading"].values, res.group("least_squares")["expected"].values
    assert row["loglike"] == pytest.approx(float(np.sum(norm.logpdf(y, e, NOISE))), rel=1e-9)
    assert row["n_params"] == 3 and "fixed by the scene" in row["noise_model"]
    assert "different noise models" in " ".join(cmp.notes)


@pytest.fixture(scope="module")
def posterior_fits(lsq_fits):
    tmp, fits = lsq_fits
    data = fits["viscous_coulomb"]["data"]
    kw = {"method": "emcee", "walkers": 10, "steps": 240, "predictive_draws": 200, "n_starts": 2}
    return {"v": _fit(tmp, data, FIT_V + FREE_SIGMA, "mc_v", **kw),
            "vc": _fit(tmp, data, FIT_VC + FREE_SIGMA, "mc_vc", **kw)}


@pytest.mark.filterwarnings("ignore")  # arviz.compare's own Pareto-k and pandas notices
def test_loo_ranks_and_differences_agree_with_arviz_compare(posterior_fits):
    import arviz as az

    cmp = compare_fits([posterior_fits["v"], posterior_fits["vc"]])
    assert cmp.criterion == "loo" and cmp.best == str(posterior_fits["vc"])
    idata = {}
    for key, path in posterior_fits.items():
        res = load_fit(path)
        idata[str(path)] = az.InferenceData(posterior=res.group("posterior"), log_likelihood=res.group("log_likelihood"))
    ref = az.compare(idata, ic="loo")
    for row in cmp.rows:
        r = ref.loc[row["file"]]
        assert row["rank"] == int(r["rank"]) + 1
        assert row["elpd_loo"] == pytest.approx(float(r["elpd_loo"]), rel=1e-12)
        assert row["elpd_diff"] == pytest.approx(float(r["elpd_diff"]), abs=1e-9)
        assert row["dse"] == pytest.approx(float(r["dse"]), abs=1e-9)
        assert row["se"] == pytest.approx(float(r["se"]), rel=1e-12)
    assert cmp.rows[1]["elpd_diff"] > 4 * cmp.rows[1]["dse"]


def test_cli_text_and_json(lsq_fits, posterior_fits):
    _, fits = lsq_fits
    f = fits["viscous_coulomb"]
    r = run(f["v"], f["vc"])
    assert r.exit_code == 0, r.output
    assert "AICc" in r.output and "no standard error" in r.output and "verdict" in r.output
    lines = r.output.splitlines()
    assert lines[2].split()[1] == f["vc"].name  # best first, under the header line
    j = run(f["v"], f["vc"], "--json")
    assert j.exit_code == 0, j.output
    doc = json.loads(j.output)
    assert doc["criterion"] == "aicc" and doc["data"]["n_readings"] == 41
    assert [x["file"] for x in doc["fits"]] == [str(f["vc"]), str(f["v"])]
    assert [x["rank"] for x in doc["fits"]] == [1, 2] and doc["fits"][0]["d_aicc"] == 0.0
    j = run(posterior_fits["v"], posterior_fits["vc"], "--json")
    doc = json.loads(j.output)
    assert doc["criterion"] == "loo" and doc["fits"][0]["file"] == str(posterior_fits["vc"])
    assert {"elpd_loo", "se", "elpd_diff", "dse", "max_pareto_k", "n_pareto_k_high"} <= set(doc["fits"][1])


def _one_line_refusal(r, *words):
    assert r.exit_code == 2, r.output
    line = r.output.strip()
    assert len(line.splitlines()) == 1 and line.startswith("escfit: error:")
    for w in words:
        assert w in line, line


def test_refusals(lsq_fits, posterior_fits, tmp_path):
    _, fits = lsq_fits
    f, g = fits["viscous_coulomb"], fits["viscous"]
    _one_line_refusal(run(f["v"]), "at least two")
    _one_line_refusal(run(), "at least two")
    _one_line_refusal(run(f["v"], f["v"]), "twice")
    _one_line_refusal(run(f["v"], g["v"]), "different data", g["v"].name)
    _one_line_refusal(run(f["vc"], posterior_fits["v"]), "mixed methods", "--method")
    damaged = tmp_path / "damaged.h5"
    damaged.write_bytes(f["vc"].read_bytes()[:5000])
    _one_line_refusal(run(f["v"], damaged), "damaged.h5")
    garbage = tmp_path / "garbage.h5"
    garbage.write_text("not a results file\n")
    _one_line_refusal(run(f["v"], garbage), "garbage.h5")
    _one_line_refusal(run(f["v"], tmp_path / "missing.h5"), "missing.h5")


def _altered_copy(src, dst, change):
    res = load_fit(src)
    change(res.tree)
    write_fit(res, dst)
    return dst


def test_refuses_other_readings_of_the_same_file_and_other_observation_models(lsq_fits, tmp_path):
    _, fits = lsq_fits
    f = fits["viscous_coulomb"]

    def cut(tree):
        obs = tree["observed_data"].to_dataset()
        tree["observed_data"] = obs.assign(reading=obs["reading"] * 1.0 + 1e-3)

    other = _altered_copy(f["vc"], tmp_path / "shifted.h5", cut)
    _one_line_refusal(run(f["v"], other), "different readings", "reading values differ")

    def relabel(tree):
        tree.attrs["scene"] = tree.attrs["scene"].replace("[observation]\n", '[observation]\nmodel = "waveform"\n')

    other = _altered_copy(f["vc"], tmp_path / "waveform.h5", relabel)
    _one_line_refusal(run(f["v"], other), "different observation model", "waveform")

    def older(tree):
        ls = tree["least_squares"].to_dataset()
        ls.attrs = {k: v for k, v in ls.attrs.items() if k not in ("loglike", "n_params")}
        tree["least_squares"] = ls

    other = _altered_copy(f["vc"], tmp_path / "older.h5", older)
    _one_line_refusal(run(f["v"], other), "older escfit", "older.h5")


def test_refuses_failed_draws(posterior_fits, tmp_path):
    def fail(tree):
        ll = tree["log_likelihood"].to_dataset()
        values = ll["reading"].values.copy()
        values[0, 0, 3] = -np.inf
        tree["log_likelihood"] = ll.assign(reading=(ll["reading"].dims, values))

    other = _altered_copy(posterior_fits["vc"], tmp_path / "failed.h5", fail)
    _one_line_refusal(run(posterior_fits["v"], other), "not finite", "failed.h5")


def test_library_refusal_is_a_results_error(lsq_fits):
    _, fits = lsq_fits
    with pytest.raises(ResultsError, match="different data"):
        compare_fits([fits["viscous"]["v"], fits["viscous_coulomb"]["v"]])
    with pytest.raises(OSError):  # escfit errors are also the built-in kinds (a results problem: OSError)
        compare_fits([fits["viscous"]["v"]])


def test_same_names_in_different_folders_are_told_apart(lsq_fits, tmp_path):
    _, fits = lsq_fits
    f = fits["viscous_coulomb"]
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a, b = tmp_path / "a" / "fit.h5", tmp_path / "b" / "fit.h5"
    shutil.copy(f["v"], a)
    shutil.copy(f["vc"], b)
    cmp = compare_fits([a, b])
    assert {r["label"] for r in cmp.rows} == {str(a), str(b)}


def test_verdict_names_the_simplest_then_the_best_ranked_of_equally_simple_fits():
    from escfit.inference.compare import _undecided, verdict_choice

    rows = [{"file": "vc.h5", "label": "vc.h5", "n_params": 4}, {"file": "c.h5", "label": "c.h5", "n_params": 3},
            {"file": "v.h5", "label": "v.h5", "n_params": 3}]  # best first
    assert verdict_choice(rows)["file"] == "c.h5"  # not nested with v.h5: the criterion ranks them
    text, choice = _undecided(rows, "dAICc below 2")
    assert choice == "c.h5" and "of those with 3 parameters, c.h5 ranks best" in text
    text, choice = _undecided(rows[:2], "dAICc below 2")
    assert choice == "c.h5" and "prefer the simplest, c.h5 (3 parameters)" in text


def _ar1_loglike_max(r: np.ndarray) -> float:
    """The exact Gaussian AR(1) log-likelihood of residuals ``r``, maximised over (sigma, rho) by a
    fine grid in rho with sigma in closed form: the reference for the stored number."""
    best = -math.inf
    for rho in np.linspace(-0.995, 0.995, 4001):
        q = 1.0 - rho * rho
        ss = r[0] ** 2 + np.sum((r[1:] - rho * r[:-1]) ** 2) / q  # = n sigma^2 at the optimum
        s2 = ss / r.size
        best = max(best, -0.5 * r.size * (math.log(2 * math.pi * s2) + 1.0) - 0.5 * (r.size - 1) * math.log(q))
    return best


def test_ar1_fits_store_the_likelihood_maximised_over_rho_so_a_nesting_law_never_scores_lower():
    """AR(1) readings (rho 0.8) fitted with viscous damping and with viscous + Coulomb friction: the
    stored log-likelihood is the AR(1) likelihood maximised over the noise scale and rho at each
    optimum (checked against a grid), so the nesting law's is never below the nested one's."""
    from escfit.inference import least_squares, make_problem
    from escfit.inference.information import information_attrs

    from .test_waveform_fit import SCENE, correlated_record

    vc = (SCENE % "waveform") + 'noise = "ar1"\n'
    v = vc.replace("[effects.coulomb]\nR = { value = 0.2, vary = true, min = 0, max = 5 }\n", "")
    assert "coulomb" not in v
    for seed in range(3):
        rec = correlated_record(seed)
        ll = {}
        for name, text in (("v", v), ("vc", vc)):
            problem = make_problem(load_scene("s.toml", text=text), rec)
            res = least_squares(problem, n_starts=1)
            a = information_attrs(problem, res)
            r = problem.observed - problem.expected(res.values)
            assert a["loglike"] == pytest.approx(_ar1_loglike_max(r), abs=2e-3)
            assert "maximising the likelihood" in a["noise_model"]
            ll[name] = a["loglike"]
        assert ll["vc"] >= ll["v"] - 1e-6, (seed, ll)


def test_the_reports_criteria_are_the_numbers_compare_ranks_by(lsq_fits, tmp_path):
    """The report's information-criteria line and ``escfit compare`` read one stored likelihood:
    the same log L, parameter count, AICc and BIC for every fit."""
    import re

    _, fits = lsq_fits
    f = fits["viscous_coulomb"]
    rows = {r["file"]: r for r in compare_fits([f["v"], f["vc"]]).rows}
    for path in (f["v"], f["vc"]):
        md = tmp_path / f"{path.stem}.md"
        res = CliRunner().invoke(cli, ["report", str(path), "--format", "md", "--out", str(md)])
        assert res.exit_code == 0, res.output
        text = " ".join(md.read_text().split())
        m = re.search(r"log-likelihood (\S+) with its normalising constants, (\d+) parameters? counted.*?"
                      r"AICc (\S+), BIC (\S+),", text)
        assert m, text[:2000]
        row = rows[str(path)]
        assert int(m.group(2)) == row["n_params"]
        for got, want in zip(m.group(1, 3, 4), (row["loglike"], row["aicc"], row["bic"])):
            assert float(got) == pytest.approx(want, rel=1e-5, abs=1e-3)
