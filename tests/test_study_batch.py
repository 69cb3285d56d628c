"""Batch fits: units from files and unit columns, per-unit files, summary, failures, resume, CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.cli.main import cli
from escfit.core.errors import DataError, FitError, ResultsError
from escfit.balance.recordings import read_unit_curve, write_unit_curve
from escfit.results import load_fit
from escfit.study import LazyClient, discover_units, fit_many, load_fleet, load_summary, unit_seed

from .conftest import DATASETS

FLEET = DATASETS / "fleet" / "angle"
SCENE = DATASETS / "fleet" / "scenes" / "angle.toml"


@pytest.fixture(scope="module")
def split_files(tmp_path_factory):
    """Units u01, u02 in one file (unit column); u03 alone in a file without one; a broken file."""
    d = tmp_path_factory.mktemp("data")
    curve = read_unit_curve(FLEET / "recordings.csv")
    two = curve.select(np.flatnonzero(np.isin(curve.unit, ["u01", "u02"])))
    write_unit_curve(d / "pair.csv", two)
    one = curve.select(np.flatnonzero(curve.unit == "u03"))
    one.unit = np.full(one.swing.size, "", dtype=str)
    write_unit_curve(d / "u03.csv", one)
    # no load column: the scene's [fit.loads] table cannot be applied, so this unit fails
    (d / "noload.csv").write_text("# notch_deg: 6\nswing,notches\n0,59\n4,40\n8,30\n")
    return d


def test_units_from_a_unit_column_and_from_file_names(split_files, tmp_path):
    tasks = discover_units([split_files / "pair.csv", split_files / "u03.csv"], tmp_path)
    assert [t.unit for t in tasks] == ["u01", "u02", "u03"]
    assert [t.results_file.name for t in tasks] == ["u01.h5", "u02.h5", "u03.h5"]
    assert all(t.curve.swing.size == 27 for t in tasks)
    with pytest.raises(DataError, match="appears in"):
        discover_units([split_files / "pair.csv", split_files / "pair.csv"], tmp_path)


def test_unit_seeds_depend_on_name_not_order():
    assert unit_seed(0, "u01") == unit_seed(0, "u01") != unit_seed(0, "u02")
    assert unit_seed(1, "u01") != unit_seed(0, "u01")


def test_failed_unit_is_reported_and_the_others_are_fitted(split_files, tmp_path, capsys):
    out = tmp_path / "fits"
    res = fit_many([split_files / "pair.csv", split_files / "u03.csv", split_files / "noload.csv"], SCENE, out,
                   workers=0, n_starts=2)
    assert sorted(res.fitted) == ["u01", "u02", "u03"]
    assert list(res.failed) == ["noload"] and "load column" in res.failed["noload"]
    assert "unit noload failed" in capsys.readouterr().err
    s = load_summary(out)
    assert list(s["unit"].values) == ["u01", "u02", "u03", "noload"]
    assert list(s["status"].values) == ["ok", "ok", "ok", "failed"]
    assert "load column" in str(s["error"].sel(unit="noload").values)
    assert set(s["parameter"].values) >= {"viscous.C", "coulomb.R", "escapement[2].X", "fit.kappa"}
    assert np.isnan(s["median"].sel(unit="noload")).all()
    truth = load_fleet(FLEET).truth
    for u in ("u01", "u02", "u03"):
        c = float(s["median"].sel(unit=u, parameter="viscous.C"))
        assert c == pytest.approx(truth[u]["viscous.C"], rel=0.5)
        res = load_fit(out / f"{u}.h5")
        assert res.attrs["seed"] == unit_seed(0, u)
        res.tree.close()
    assert s.attrs["n_failed"] == 1 and s.attrs["method"] == "leastsq"

    # a rerun skips what is done, retries the failure, and refits a damaged results file
    (out / "u02.h5").write_bytes(b"not hdf5")
    before = (out / "u01.h5").stat().st_mtime_ns
    again = fit_many([split_files / "pair.csv", split_files / "u03.csv", split_files / "noload.csv"], SCENE, out,
                     workers=0, n_starts=2)
    assert sorted(again.skipped) == ["u01", "u03"] and again.fitted == ["u02"] and list(again.failed) == ["noload"]
    assert (out / "u01.h5").stat().st_mtime_ns == before
    load_fit(out / "u02.h5").tree.close()
    assert list(load_summary(out)["status"].values) == ["skipped", "ok", "skipped", "failed"]

    # nothing left to do: every unit is skipped, no cluster is started, the summary is rebuilt
    lazy = LazyClient(workers=2)
    third = fit_many(split_files / "pair.csv", SCENE, out, scheduler=lazy)
    assert third.skipped == ["u01", "u02"] and not third.fitted and not lazy.started
    assert list(third.summary["status"].values) == ["skipped", "skipped"]
    np.testing.assert_array_equal(third.summary["median"].values, again.summary["median"].values[:2])


def test_results_of_another_scene_or_method_are_not_taken_as_done(split_files, tmp_path):
    fit_many(split_files / "u03.csv", SCENE, tmp_path, workers=0, n_starts=2)
    with pytest.raises(ResultsError, match=r"\['u03'\] were fitted here with another scene or method"):
        fit_many(split_files / "u03.csv", SCENE, tmp_path, workers=0, method="emcee", walkers=10, steps=20)
    with pytest.raises(ResultsError, match="another scene"):
        fit_many(split_files / "u03.csv", DATASETS / "fleet" / "scenes" / "phase.toml", tmp_path, workers=0)


def test_local_cluster_matches_in_process(split_files, tmp_path):
    """The default path: a LocalCluster of worker processes; results equal the in-process ones."""
    pytest.importorskip("distributed")
    a = fit_many(split_files / "pair.csv", SCENE, tmp_path / "a", workers=0, n_starts=2)
    b = fit_many(split_files / "pair.csv", SCENE, tmp_path / "b", workers=2, n_starts=2)
    assert b.ok and "LocalCluster(2 processes" in b.summary.attrs["runner"]
    np.testing.assert_allclose(a.summary["median"].values, b.summary["median"].values, rtol=1e-10)


def test_refusals(split_files, tmp_path):
    with pytest.raises(FitError, match="method"):
        fit_many(split_files / "pair.csv", SCENE, tmp_path, method="nuts")
    with pytest.raises(FitError, match="exclude"):
        fit_many(split_files / "pair.csv", SCENE, tmp_path, workers=0, scheduler="tcp://127.0.0.1:1")
    with pytest.raises(DataError, match="no readings of unit"):
        fit_many(split_files / "pair.csv", SCENE, tmp_path, workers=0, units=["u09"])
    with pytest.raises(ResultsError, match="not found"):
        load_summary(tmp_path / "nothing")


def test_cli_fit_many_reports_failures_with_exit_status_3(split_files, tmp_path):
    out = tmp_path / "cli"
    args = ["fit-many", str(split_files / "pair.csv"), str(split_files / "noload.csv"), "--scene", str(SCENE),
            "--out", str(out), "--workers", "0", "--n-starts", "2", "--quiet"]
    r = CliRunner().invoke(cli, args)
    assert r.exit_code == 3, r.output
    assert "unit noload failed" in r.output  # stderr is mixed into output by CliRunner
    assert "viscous.C" in r.output and "2 fitted, 0 done before, 1 failed" in r.output
    r = CliRunner().invoke(cli, args[:-3] + ["--unit", "u01", "--workers", "0", "--quiet"])
    assert r.exit_code == 0 and "0 fitted, 1 done before" in r.output
    r = CliRunner().invoke(cli, ["fit-many", str(split_files / "pair.csv"), "--scene", str(tmp_path / "no.toml"),
                                 "--out", str(out)])
    assert r.exit_code == 2 and "scene file not found" in r.output
    assert "fit-many" in CliRunner().invoke(cli, ["--help"]).output


def test_summary_records_settings_and_versions(split_files, tmp_path):
    res = fit_many(split_files / "u03.csv", SCENE, tmp_path, workers=0, n_starts=2, seed=7)
    s = res.summary
    assert s.attrs["schema_version"] == "escfit-fleet-summary/1" and s.attrs["seed"] == 7
    assert json.loads(s.attrs["settings"])["n_starts"] == 2
    assert "escfit" in json.loads(s.attrs["versions"])
    assert s["median"].dims == ("unit", "parameter") and s.sizes["unit"] == 1
