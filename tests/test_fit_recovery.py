"""Fits recover known parameters; results files round-trip; interrupted runs resume."""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np
import pytest

import escfit
from escfit.core.errors import FitError, ResultsError
from escfit.balance.problems.curves import FitProblem
from escfit.inference import fit, least_squares, profile
from escfit.analysis.recordings import read_unit_curve, write_unit_curve
from escfit.balance.synthetic.unit_curves import record_unit_curve
from escfit.results import load_fit

from .conftest import DATASETS

SCENE = DATASETS / "scenes" / "monday_unit_angle_fit.toml"
TRUTH = {"viscous.C": 0.6, "coulomb.R": 100.0, "escapement[2].X": 1500.0}


@pytest.fixture(scope="module")
def monday_like(tmp_path_factory):
    """Synthetic notch readings, written to a CSV file and read back (so they carry a file and its SHA-256)."""
    scene = escfit.load_scene(SCENE)
    synthetic = record_unit_curve(scene, every=4, duration=6.5, notch_deg=6, sigma=0.03, seed=11)
    path = tmp_path_factory.mktemp("data") / "monday_notches.csv"
    write_unit_curve(path, synthetic)
    data = read_unit_curve(path)
    np.testing.assert_array_equal(data.swing, synthetic.swing)  # the file round trip is exact
    np.testing.assert_array_equal(data.value, synthetic.value)
    assert data.notch == synthetic.notch
    return scene, data


@pytest.fixture(scope="module")
def monday_fit(monday_like, tmp_path_factory):
    scene, data = monday_like
    out = tmp_path_factory.mktemp("fit") / "monday.h5"
    return fit(scene, data, method="emcee", walkers=24, steps=3000, seed=5, out=out), out


def test_emcee_intervals_contain_truth_and_lsq_within_3_se(monday_fit):
    res, _ = monday_fit
    s = res.summary()
    for name, true in TRUTH.items():
        assert s[name]["lo95"] < true < s[name]["hi95"], (name, s[name])
    lsq = res.group("least_squares")
    for name, true in TRUTH.items():
        v, se = float(lsq.sel(parameter=name)["value"]), float(lsq.sel(parameter=name)["stderr"])
        assert abs(v - true) < 3 * se, (name, v, se)


def test_results_file_layout_and_readers(monday_like, monday_fit):
    import arviz as az
    import xarray as xr

    _, data = monday_like
    res, path = monday_fit
    back = load_fit(path)
    assert back.attrs["schema_version"] == "escfit-fit/1"
    data_file = Path(data.source)
    assert back.attrs["data_file"] == res.attrs["data_file"] == str(data_file)
    sha = hashlib.sha256(data_file.read_bytes()).hexdigest()
    assert len(sha) == 64
    assert res.attrs["data_sha256"] == sha
    assert back.attrs["data_sha256"] == sha
    for group in ("posterior", "sample_stats", "observed_data", "posterior_predictive", "least_squares", "diagnostics"):
        assert group in back.tree.children
    post = back.group("posterior")
    assert post.sizes == {"chain": 24, "draw": 2250}
    assert "escfit" in back.attrs["versions"] and "seed" in back.attrs
    tree = xr.open_datatree(path, engine="h5netcdf")
    assert set(tree["posterior"].data_vars) >= set(TRUTH)
    idata = az.from_netcdf(path)
    assert "posterior" in idata.groups()
    np.testing.assert_allclose(idata.posterior["viscous.C"].values, post["viscous.C"].values)


def test_results_are_not_overwritten_without_force(monday_like, monday_fit):
    scene, data = monday_like
    _, path = monday_fit
    before = path.read_bytes()
    with pytest.raises(ResultsError, match="exists"):
        fit(scene, data, out=path)
    assert path.read_bytes() == before


def test_angle_mode_full_decay_separates_c_r_x():
    """Readings of every half swing from overbank to steady state determine C, R, X separately."""
    scene = escfit.load_scene(SCENE)
    data = record_unit_curve(scene, every=1, swings=64, sigma=0.005, seed=3)
    text = SCENE.read_text().replace('[observation]\nmodel = "notches"\nnotch_deg = 6\n', "[observation]\n")
    scene2 = escfit.load_scene("full.toml", text=text)
    res = fit(scene2, data, method="leastsq")
    lsq = res.group("least_squares")
    for name, true in TRUTH.items():
        v, se = float(lsq.sel(parameter=name)["value"]), float(lsq.sel(parameter=name)["stderr"])
        assert abs(v - true) < 3 * se and se < 0.1 * true, (name, v, se)
    # (they remain strongly correlated, |r| ~ 0.99, yet each is fixed to a few per cent)


PHASE_FIT = """model = "balance"
switching = "phase"
[oscillator]
omega0 = 16.174
theta0 = 6.28
[run]
swings = 60
[effects.viscous]
C = { value = 0.833, vary = true, min = 0.0, max = 3.0 }
[effects.coulomb]
R = { value = 305.546, vary = true, min = 0.0, max = 2000.0 }
[[effects.escapement]]
kind = "unlock"
from = -0.6338
to = -0.2787
X = 143.41
[[effects.escapement]]
kind = "impulse"
from = -0.2787
to = 0.2787
X = { value = 1245.8, vary = true, min = 0.0, max = 8000.0 }
[observation]
sigma = { value = 0.02, vary = false }
"""


def test_phase_mode_posterior_lies_on_the_k_ridge():
    scene = escfit.load_scene("phase.toml", text=PHASE_FIT)
    data = record_unit_curve(scene, every=2, swings=60, sigma=0.02, seed=4)
    res = fit(scene, data, method="emcee", walkers=16, steps=1500, seed=1)
    post = res.group("posterior")
    r, x = post["coulomb.R"].values.ravel(), post["escapement[2].X"].values.ravel()
    assert np.corrcoef(r, x)[0, 1] > 0.99  # R and X trade off along the ridge
    k = post["K"].values.ravel()
    assert np.std(k) / np.mean(k) < 0.1 * (np.std(r) / np.mean(r))  # K is what the curve determines
    assert k.mean() == pytest.approx(0.2037, rel=0.05)
    assert any("phase switching" in w for w in res.warnings)


def test_profile_likelihood_of_r_is_flat_in_phase_mode():
    scene = escfit.load_scene("phase.toml", text=PHASE_FIT)
    data = record_unit_curve(scene, every=2, swings=60, sigma=0.02, seed=4)
    prob = FitProblem(scene, data)
    prof = profile(prob, "coulomb.R", [200.0, 305.5, 500.0], n_starts=2)
    assert np.all(prof["delta"] < 1.0)  # X compensates R exactly


def test_interrupted_emcee_run_resumes(monday_like, tmp_path, monkeypatch):
    scene, data = monday_like
    out = tmp_path / "resume.h5"
    calls = {"n": 0}
    original = FitProblem.log_prob_many  # the exact solver's whole-ensemble path

    def dying(self, vecs):
        calls["n"] += len(vecs)
        if calls["n"] > 16 * 60:
            raise KeyboardInterrupt
        return original(self, vecs)

    monkeypatch.setattr(FitProblem, "log_prob_many", dying)
    with pytest.raises(KeyboardInterrupt):
        fit(scene, data, method="emcee", walkers=16, steps=120, seed=2, out=out)
    monkeypatch.setattr(FitProblem, "log_prob_many", original)
    assert not out.exists() and (tmp_path / "resume.h5.emcee").exists()
    with pytest.raises(FitError, match="resume"):
        fit(scene, data, method="emcee", walkers=16, steps=120, seed=2, out=out)
    res = fit(scene, data, method="emcee", walkers=16, steps=120, seed=2, out=out, resume=True)
    post = res.group("posterior")
    assert post.sizes == {"chain": 16, "draw": 90}  # the first quarter of 120 steps discarded
    assert res.attrs["resumed"] == 1
    diag = res.group("diagnostics")
    assert np.all(np.isfinite(diag["rhat"].values)) and np.all(diag["acceptance"].values > 0)
    assert not (tmp_path / "resume.h5.emcee").exists()


def test_least_squares_refuses_nothing_to_fit():
    scene = escfit.load_scene("fixed.toml", text=PHASE_FIT.replace("vary = true", "vary = false"))
    data = record_unit_curve(scene, every=2, swings=10, sigma=0.02, seed=4)
    with pytest.raises(FitError, match="no free parameters"):
        FitProblem(scene, data)


def test_failed_solves_become_minus_infinity(monday_like):
    scene, data = monday_like
    prob = FitProblem(scene, data)
    vals = prob.values(prob.initial)
    vals["viscous.C"] = math.nan
    assert prob.log_likelihood(vals) == -math.inf
    assert any("solve failed" in k for k in prob.failures)
    assert np.all(prob.residuals(vals) == 1e6)
