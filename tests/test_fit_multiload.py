"""Several curves of one unit at different loads, fitted jointly."""

from __future__ import annotations

import csv

import numpy as np
import pytest

import escfit
from escfit.core.errors import SceneError
from escfit.inference import fit
from escfit.analysis.recordings import read_unit_curve

from .conftest import DATASETS

SYN = DATASETS / "monday1965" / "synthetic"


def _truth(unit):
    rows = [r for r in csv.DictReader(l for l in open(DATASETS / "monday1965" / "table1_unit_curve_comparisons.csv")
                                      if not l.startswith("#")) if r["unit"] == str(unit)]
    return float(rows[0]["C_per_s"]), {float(r["load_g"]): float(r["R_rad_s2"]) for r in rows}


@pytest.mark.parametrize("unit", [1, 4])
def test_shared_c_and_r_per_load_recovered(unit):
    c_true, r_true = _truth(unit)
    res = fit(DATASETS / "monday1965" / f"unit{unit}_fit.toml", SYN / f"unit{unit}.csv", method="leastsq")
    lsq = res.group("least_squares")
    c, se = float(lsq.sel(parameter="viscous.C")["value"]), float(lsq.sel(parameter="viscous.C")["stderr"])
    assert abs(c - c_true) < 3 * se + 1e-3 * c_true
    for load, r in r_true.items():
        name = f"coulomb.R[load={load:g}]"
        v, se = float(lsq.sel(parameter=name)["value"]), float(lsq.sel(parameter=name)["stderr"])
        assert abs(v - r) < 3 * se + 2e-3 * r, (name, v, se, r)


def test_linear_friction_rule():
    text = (DATASETS / "monday1965" / "unit1_fit.toml").read_text().replace('friction = "free"', 'friction = "linear"')
    scene = escfit.load_scene("linear.toml", text=text)
    res = fit(scene, SYN / "unit1.csv", method="leastsq")
    s = res.summary()
    # Table I unit 1: R grows by about 3.09 rad/s^2 per gram of load
    _, r_true = _truth(1)
    loads = sorted(r_true)
    slope = np.polyfit(loads, [r_true[x] for x in loads], 1)[0]
    assert s["fit.kappa"]["best_fit"] == pytest.approx(slope, rel=0.02)
    assert s["coulomb.R"]["best_fit"] == pytest.approx(r_true[loads[0]], rel=0.01)


def test_several_loads_need_a_rule():
    text = (DATASETS / "monday1965" / "unit1_fit.toml").read_text()
    text = text[: text.index("[fit.loads]")]
    with pytest.raises(SceneError, match="fit.loads"):
        fit(escfit.load_scene("norule.toml", text=text), SYN / "unit1.csv")


def test_regenerated_recordings_match_the_shipped_files(tmp_path, monkeypatch):
    import importlib.util
    import shutil

    for f in SYN.iterdir():
        shutil.copy(f, tmp_path / f.name)
    shutil.copy(DATASETS / "monday1965" / "table1_unit_curve_comparisons.csv", tmp_path.parent / "table1_unit_curve_comparisons.csv")
    spec = importlib.util.spec_from_file_location("gen", tmp_path / "generate.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    gen.main()
    for unit in range(1, 6):
        assert (tmp_path / f"unit{unit}.csv").read_text() == (SYN / f"unit{unit}.csv").read_text()
    curve = read_unit_curve(SYN / "unit2.csv")
    assert curve.kind == "notches" and len(curve.groups()) == 3
