"""Batch fits: units from files and unit columns, per-unit files, summary, failures, resume, CLI."""

from __future__ import annotations

import json
import os
import sys

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner

from escfit.cli.main import cli
from escfit.core.errors import DataError, FitError, ResultsError
from escfit.analysis.recordings import read_unit_curve, write_unit_curve
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
    assert np.isnan(s["estimate"].sel(unit="noload")).all()
    truth = load_fleet(FLEET).truth
    for u in ("u01", "u02", "u03"):
        c = float(s["estimate"].sel(unit=u, parameter="viscous.C"))
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
    np.testing.assert_array_equal(third.summary["estimate"].values, again.summary["estimate"].values[:2])


def test_results_of_another_scene_or_method_are_not_taken_as_done(split_files, tmp_path):
    fit_many(split_files / "u03.csv", SCENE, tmp_path, workers=0, n_starts=2)
    with pytest.raises(ResultsError, match=r"\['u03'\] were fitted here with another scene or method"):
        fit_many(split_files / "u03.csv", SCENE, tmp_path, workers=0, method="emcee", walkers=10, steps=20)
    with pytest.raises(ResultsError, match="another scene"):
        fit_many(split_files / "u03.csv", DATASETS / "fleet" / "scenes" / "phase.toml", tmp_path, workers=0)


def _kernel_threads() -> tuple[int, int, str]:
    """A worker's numba threads (configured, in use) and OMP_NUM_THREADS."""
    import numba

    return numba.config.NUMBA_NUM_THREADS, numba.get_num_threads(), os.environ.get("OMP_NUM_THREADS", "")


def test_local_cluster_matches_in_process(split_files, tmp_path):
    """The default path: a LocalCluster of worker processes; results equal the in-process ones.
    Its two workers share the cores out instead of each starting a kernel thread per core."""
    pytest.importorskip("distributed")
    from escfit.study.cluster import worker_threads

    a = fit_many(split_files / "pair.csv", SCENE, tmp_path / "a", workers=0, n_starts=2)
    lazy = LazyClient(workers=2)
    try:
        b = fit_many(split_files / "pair.csv", SCENE, tmp_path / "b", scheduler=lazy, n_starts=2)
        threads = lazy().run(_kernel_threads)
    finally:
        lazy.close()
    assert b.ok and "LocalCluster(2 processes" in b.summary.attrs["runner"]
    np.testing.assert_allclose(a.summary["estimate"].values, b.summary["estimate"].values, rtol=1e-10)
    n = worker_threads(2)
    assert len(threads) == 2 and all(t == (n, n, str(n)) for t in threads.values())
    assert n == 1 or 2 * n <= len(os.sched_getaffinity(0))


def test_summary_from_memory_equals_the_one_read_back(tmp_path, monkeypatch):
    """fit-many builds summary.nc from the rows its tasks return, reading no results file back;
    the summary built by reading every unit's file instead is the same, value for value."""
    from escfit.study import batch

    units = ["u01", "u02", "u03", "u04", "u05"]
    reads = []
    load = batch._load_for_summary
    monkeypatch.setattr(batch, "_load_for_summary", lambda p: reads.append(load(p)) or reads[-1])
    res = fit_many(FLEET / "recordings.csv", SCENE, tmp_path, workers=0, n_starts=2, units=units)
    assert res.fitted == units and all(r is None for r in reads)  # only the resume check: no file yet
    monkeypatch.undo()

    s = res.summary
    tasks = [t for t in discover_units([FLEET / "recordings.csv"], tmp_path) if t.unit in units]
    status = {u: {"status": str(s["status"].values[i]), "error": str(s["error"].values[i]),
                  "seconds": float(s["seconds"].values[i])} for i, u in enumerate(units)}
    reread = batch.summarize(tasks, status, attrs=dict(s.attrs))  # no rows: every results file is read
    xr.testing.assert_identical(reread, s)
    reread.to_netcdf(tmp_path / "reread.nc", engine="h5netcdf")
    xr.testing.assert_identical(load_summary(tmp_path / "reread.nc"), load_summary(tmp_path))


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
    assert s["estimate"].dims == ("unit", "parameter") and s.sizes["unit"] == 1


# --- any model family: a folder of recording files, each read by the family on the worker -------

RECORDINGS = DATASETS / "recordings"
FRICTION = DATASETS / "friction"


def _family_registered(module: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(module) is not None


@pytest.fixture(scope="module")
def pulse_folder(tmp_path_factory):
    """Two photo-cell recordings (a balance format the worker reads from the file's bytes), the
    scene beside them and a note, which are not recordings."""
    d = tmp_path_factory.mktemp("pulses")
    (d / "shipped.csv").write_bytes((RECORDINGS / "monday_pulses.csv").read_bytes())
    r = CliRunner().invoke(cli, ["simulate", str(RECORDINGS / "pulses_scene.toml"), "--recorder", "pulses",
                                 "--noise", "1e-4", "--seed", "2", "--swings", "16", "--out", str(d / "second.csv")])
    assert r.exit_code == 0, r.output
    (d / "scene.toml").write_bytes((RECORDINGS / "pulses_scene.toml").read_bytes())
    (d / "README.md").write_text("two recordings of a Monday-like unit\n")
    return d, RECORDINGS / "pulses_scene.toml", ["second", "shipped"]


@pytest.fixture(scope="module")
def friction_folder(tmp_path_factory):
    """Two of Monday's friction sessions (model = "friction_rig"), when that family is registered."""
    if not _family_registered("escfit.friction.family"):
        pytest.skip("the friction family (escfit/friction/family.py) is not registered yet")
    d = tmp_path_factory.mktemp("friction")
    names = ["monday1965_session_1095_steel", "monday1965_session_aluminum"]
    for n in names:
        (d / f"{n}.csv").write_bytes((FRICTION / f"{n}.csv").read_bytes())
    return d, FRICTION / "monday1965_rig.toml", names


@pytest.mark.parametrize("case", ["pulse_folder", "friction_folder"])
def test_fit_many_over_a_folder_equals_single_fits(case, request, tmp_path):
    """Each file of the folder is one unit (named after the file); its estimates are those of a
    single `escfit fit` of the same file with the unit's seed, to 1e-10."""
    folder, scene, units = request.getfixturevalue(case)
    out = tmp_path / "fits"
    r = CliRunner().invoke(cli, ["fit-many", str(folder), "--scene", str(scene), "--out", str(out),
                                 "--method", "leastsq", "--workers", "0", "--quiet"])
    assert r.exit_code == 0, r.output
    assert "2 fitted, 0 done before, 0 failed" in r.output
    s = load_summary(out)
    assert list(s["unit"].values) == units and list(s["status"].values) == ["ok", "ok"]
    assert s.attrs["model"] == load_fit(out / f"{units[0]}.h5").attrs["model"]
    for u in units:
        source = folder / f"{u}.csv"
        ref_file = tmp_path / f"{u}-single.h5"
        r = CliRunner().invoke(cli, ["fit", str(source), "--scene", str(scene), "--method", "leastsq",
                                     "--seed", str(unit_seed(0, u)), "--out", str(ref_file)])
        assert r.exit_code == 0, r.output
        ref, got = load_fit(ref_file), load_fit(out / f"{u}.h5")
        assert ref.parameter_names == got.parameter_names
        want, have = ref.group("least_squares"), got.group("least_squares")
        assert list(have["parameter"].values) == list(want["parameter"].values)
        np.testing.assert_allclose(have["value"].values, want["value"].values, rtol=1e-10)
        # the summary is built from the fit in memory: the same numbers as the single fit's summary
        row = ref.summary()
        names = list(row)
        assert list(s["parameter"].values) == names
        for stat in ("estimate", "lo95", "hi95"):
            np.testing.assert_allclose(s[stat].sel(unit=u).values, [row[n][stat] for n in names], rtol=1e-10)
        assert int(s["n_data"].sel(unit=u)) == ref.group("least_squares").attrs["n_data"]
        # provenance names the client's file (not the worker's temporary copy), with its hash
        assert got.attrs["data_file"] == str(source) and got.attrs["data_sha256"] == ref.attrs["data_sha256"]
        assert str(s["data_file"].sel(unit=u).values) == str(source)
        ref.tree.close()
        got.tree.close()

    # a rerun skips both (reading only their results files) and rebuilds the same summary
    again = fit_many(folder, scene, out, workers=0, method="leastsq")
    assert again.skipped == units and not again.fitted
    np.testing.assert_array_equal(again.summary["estimate"].values, s["estimate"].values)


def test_a_folder_of_unit_curve_files_keeps_the_unit_column(split_files, tmp_path):
    """Balance unit curves in a folder are read by the client and split by their unit column;
    scenes and notes beside them are not recordings."""
    d = tmp_path / "data"
    d.mkdir()
    for name in ("pair.csv", "u03.csv"):
        (d / name).write_bytes((split_files / name).read_bytes())
    (d / "unit.toml").write_bytes(SCENE.read_bytes())
    (d / "notes.md").write_text("fleet notes\n")
    (d / ".hidden.csv").write_text("swing,notches\n")
    tasks = discover_units([d], tmp_path / "out")
    assert [t.unit for t in tasks] == ["u01", "u02", "u03"]
    assert all(t.curve is not None and t.curve.swing.size == 27 for t in tasks)
    assert {t.data_file for t in tasks} == {str(d / "pair.csv"), str(d / "u03.csv")}
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "unit.toml").write_text("")
    with pytest.raises(DataError, match="no recording files"):
        discover_units([empty], tmp_path / "out")


def test_fit_many_without_dask_names_the_extra(split_files, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "dask", None)  # `import dask` now raises ImportError
    monkeypatch.setitem(sys.modules, "distributed", None)
    r = CliRunner().invoke(cli, ["fit-many", str(split_files / "u03.csv"), "--scene", str(SCENE),
                                 "--out", str(tmp_path / "out"), "--quiet"])
    assert r.exit_code == 2, r.output
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and "escfit[study]" in lines[0] and "fit-many" in lines[0], r.output
    assert not (tmp_path / "out").exists()  # refused before anything was read or written
    # in this process (--workers 0) no dask is needed
    r = CliRunner().invoke(cli, ["fit-many", str(split_files / "u03.csv"), "--scene", str(SCENE),
                                 "--out", str(tmp_path / "out"), "--workers", "0", "--n-starts", "2", "--quiet"])
    assert r.exit_code == 0, r.output
