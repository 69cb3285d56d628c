"""Monday (1965) Chapter VI: the printed table, the reconstructed sessions and their fits
(through the one inference layer, :func:`escfit.inference.fit`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from escfit.friction import compare_laws, mu_from_reading, read_readings
from escfit.friction import monday
from escfit.core.scene import load_scene
from escfit.inference import fit

DATA = Path(__file__).resolve().parents[1] / "datasets" / "friction"
TABLE = DATA / "monday1965_mu.csv"
GF = 0.00980665
IN = 0.0254


@pytest.fixture(scope="module")
def rows():
    return monday.read_mu_table(TABLE)


#: Savage-Dickey BF01 of each material before the port to the one inference layer (the
#: package's own emcee driver, 32 walkers x 3000 steps, burn 1000, seed 20 + line), as in
#: docs/friction.md.  Replaying that chain through the ported evidence code gives these numbers
#: to the last digit; a new chain differs by Monte Carlo noise only.
BF01_BEFORE = {
    "1095 steel (hard)": {"friction.mu_v": 3.4576, "friction.mu_w": 1.5251},
    "17-4 PH stainless": {"friction.mu_v": 10.638, "friction.mu_w": 3.3812e-3},
    "aluminum": {"friction.mu_v": 10.223, "friction.mu_w": 1.6584e-7},
}


#: Five sds of ln BF01 of the load slope between sampler seeds (+ the mean offset from the chain
#: of BF01_BEFORE), per material
LOAD_TOLERANCE = {"1095 steel (hard)": 0.25, "17-4 PH stainless": 0.5, "aluminum": 2.0}


@pytest.fixture(scope="module")
def fitted(rows):
    """Posterior of every material's session file with the committed scene (about 5 s each):
    the shipped recipe's run (32 walkers x 3000 steps, burn 1000, about 35 autocorrelation
    times kept per walker)."""
    scene = load_scene(DATA / "monday1965_rig.toml")
    out = {}
    for row in rows:
        path = DATA / monday.session_file(row)
        out[row.material] = (read_readings(path), fit(scene, path, method="emcee", walkers=32, steps=3000, burn=1000,
                                                     seed=20 + row.line))
    return scene, out


def test_table_digitised_as_printed(rows):
    assert [(r.material, r.mu) for r in rows] == [
        ("1095 steel (hard)", 0.100), ("17-4 PH stainless", 0.125), ("aluminum", 0.160)]
    assert all(r.load == pytest.approx(2.2 * GF) and r.pallet == "synthetic ruby" for r in rows)
    assert rows[0].handbook == "0.15-0.4" and rows[1].handbook == ""
    assert "Chapter VI" in TABLE.read_text()


def test_committed_files_regenerate_exactly(tmp_path):
    written = monday.write_sessions(TABLE, tmp_path)
    assert len(written) == 4
    for path in written:
        assert path.read_text() == (DATA / path.name).read_text(), path.name


def test_sessions_reproduce_the_printed_means(rows):
    a = monday.ASSUMPTIONS
    for row in rows:
        r = read_readings(DATA / monday.session_file(row))
        assert len(r) == 20 and r.materials() == [row.material]
        mu = mu_from_reading(r.load, r.dw, a["k_inch"] * IN, a["d_inch"] * IN)
        # written to 0.1 mg, so the printed three decimals are reproduced, not more
        assert round(float(np.mean(mu)), 3) == row.mu
        at_ref = np.isclose(r.load, 2.2 * GF)
        assert abs(np.mean(mu[at_ref]) - row.mu) < 0.05 * row.mu


def test_monday_materials_within_their_intervals(rows, fitted):
    scene, out = fitted
    for row in rows:
        _, res = out[row.material]
        x = res.group("posterior")["friction.mu"].values.ravel()
        lo, hi = np.quantile(x, [0.025, 0.975])
        assert lo < row.mu < hi, row.material
        # the interval is set by the stated rig uncertainties: about +-4 % of mu
        half = (hi - lo) / 2 / row.mu
        assert 0.03 < half < 0.06, (row.material, half)
        diag = res.group("diagnostics")
        kept = res.attrs["steps"] - res.attrs["burn"]
        assert kept / float(diag["tau"].max()) > 30
        assert float(diag["rhat"].max()) < 1.05 and not any("R-hat" in w for w in res.warnings), res.warnings


def test_monday_speed_and_load_findings(rows, fitted):
    scene, out = fitted
    evidence = {row.material: compare_laws(out[row.material][1], scene) for row in rows}
    # the FitResult carries its scene and readings: the same numbers without passing them
    steel = rows[0].material
    assert compare_laws(out[steel][1])["friction.mu_w"].bf01 == evidence[steel]["friction.mu_w"].bf01
    for row in rows:
        speed = evidence[row.material]["friction.mu_v"]
        assert speed.method == "conditional"
        assert speed.bf01 > 3, (row.material, speed.bf01)  # "no appreciable variation with velocity"
        assert speed.ci95[0] < 0 < speed.ci95[1]
    # the generated -6 %/gf load slope is seen clearly at the larger mu, not at mu = 0.100
    load = {m: e["friction.mu_w"] for m, e in evidence.items()}
    assert load["aluminum"].bf01 < 1 / 100 and load["17-4 PH stainless"].bf01 < 1 / 20
    assert load["1095 steel (hard)"].ci95[0] < -0.06 * 0.100 / GF < load["1095 steel (hard)"].ci95[1]
    # the numbers of the port's predecessor, within the Monte Carlo noise of one run: five sds of
    # ln BF01 between seeds (measured over 29 seeds: 0.0019, 0.0004, 0.0006 for the speed slopes,
    # 0.037, 0.094, 0.39 for the load slopes of steel, stainless, aluminum).  The former limits of
    # 0.15 and 0.8 were 1.6 and 2.1 sds and failed for one seed in ten (a library version is a seed)
    for row in rows:
        for name, before in BF01_BEFORE[row.material].items():
            tol = 0.02 if name == "friction.mu_v" else LOAD_TOLERANCE[row.material]
            shift = math.log(evidence[row.material][name].bf01 / before)
            assert shift == pytest.approx(0, abs=tol), (row.material, name)


def test_least_squares_agrees_with_posterior(rows, fitted):
    scene, out = fitted
    for row in rows:
        _, res = out[row.material]
        lsq = res.group("least_squares").sel(parameter="friction.mu")
        x = res.group("posterior")["friction.mu"].values.ravel()
        assert float(lsq["value"]) == pytest.approx(np.mean(x), rel=0.005)
        assert float(lsq["stderr"]) == pytest.approx(np.std(x), rel=0.1)
        # and it reproduces the printed coefficient to 1 %
        assert float(lsq["value"]) == pytest.approx(row.mu, rel=0.01)


def test_scene_file_matches_module_text():
    assert (DATA / "monday1965_rig.toml").read_text() == monday.SCENE_TEXT
    s = monday.scene()
    assert s.load_ref == pytest.approx(2.2 * GF)
    assert s.params["observation.sigma"].value / GF == pytest.approx(math.sqrt(1 / 6) * 0.5 * 5 / 138)
