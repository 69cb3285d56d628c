"""What a new user meets in the first hour: file modes, pipes, the Python API, help, fleet
summaries, Ctrl-C, the first compilation, recording headers, warnings, benchmark outputs,
start-up time and the shipped examples."""

from __future__ import annotations

import csv
import importlib.util
import io
import json
import os
import re
import shlex
import signal
import subprocess
import sys
import time
import tomllib
import warnings
from pathlib import Path

import pytest
from click.testing import CliRunner

from escfit.cli.main import EXIT_BROKEN_PIPE, EXIT_INTERRUPTED, cli, quiet_third_party_warnings

from .conftest import DATASETS, ROOT

FLEET = DATASETS / "fleet" / "angle"
FLEET_SCENE = DATASETS / "fleet" / "scenes" / "angle.toml"
ESCFIT = [sys.executable, "-c", "from escfit.cli.main import main; main()"]


def run(*args, **kw):
    return CliRunner().invoke(cli, [str(a) for a in args], **kw)


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    """A two-unit fit-many results folder (least squares, in this process), written under umask 022."""
    out = tmp_path_factory.mktemp("fleet") / "fits"
    old = os.umask(0o022)
    try:
        r = run("fit-many", FLEET / "recordings.csv", "--scene", FLEET_SCENE, "--out", out, "--workers", "0",
                "--n-starts", "2", "--unit", "u01", "--unit", "u02", "--quiet")
    finally:
        os.umask(old)
    assert r.exit_code == 0, r.output
    return out


# 1. output files are readable as the umask allows -------------------------------------------

@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_atomic_files_follow_the_umask(tmp_path, umask, mode):
    from escfit.core.atomic import atomic_path, current_umask

    old = os.umask(umask)
    try:
        assert current_umask() == umask
        with atomic_path(tmp_path / "out.h5") as tmp:
            tmp.write_bytes(b"x")
    finally:
        os.umask(old)
    assert (tmp_path / "out.h5").stat().st_mode & 0o777 == mode


def test_fit_many_folder_is_readable_by_others(fleet):
    for f in [fleet, *fleet.iterdir()]:
        assert f.stat().st_mode & 0o044 == 0o044, f


# 2. a closed pipe ends the command quietly ----------------------------------------------------

@pytest.mark.parametrize("args", [["--help"], ["summary", "{fit}"], ["summary", "{fleet}", "--csv"]])
def test_broken_pipe_exits_quietly(fleet, args):
    """The reader is gone before escfit writes (as after `| head -1`): exit 141, nothing on stderr."""
    args = [a.format(fit=fleet / "u01.h5", fleet=fleet) for a in args]
    proc = subprocess.Popen([*ESCFIT, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == EXIT_BROKEN_PIPE, err
    assert err == ""


def test_pipe_into_head(fleet):
    command = " ".join(map(shlex.quote, [*ESCFIT, "summary", str(fleet / "u01.h5")]))
    r = subprocess.run(f"{command} | head -1", shell=True, capture_output=True, text=True, timeout=120)
    whole = run("summary", fleet / "u01.h5").output
    assert r.stdout == whole.splitlines(keepends=True)[0] and r.stdout.strip()  # the first line, and quietly
    assert "Error" not in r.stderr and "Traceback" not in r.stderr


# 3. the documented Python API exists, and `import escfit` stays light ------------------------

def test_documented_api_names_exist_and_import_is_light():
    pages = [ROOT / "README.md", ROOT / "docs" / "reference" / "api.md", ROOT / "docs" / "fitting.md",
             ROOT / "docs" / "physics" / "balance.md"]
    names = set(re.findall(r"`escfit\.([a-z_]+)\(", "".join(p.read_text() for p in pages)))
    code = ("import sys, escfit; light = 'pint' not in sys.modules and 'xarray' not in sys.modules; "
            f"print(light, all(callable(getattr(escfit, n)) for n in {sorted(names | {'fit'})!r}), "
            "escfit.inference.fit is escfit.fit)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.stdout.split() == ["True", "True", "True"], r.stderr
    assert {"simulate", "load_fit"} <= names


# 4. --version, -h -------------------------------------------------------------------------------

def test_version_and_short_help_everywhere():
    r = run("--version")
    assert r.exit_code == 0 and "escfit, version" in r.output
    assert run("-h").output == run("--help").output
    for name in cli.list_commands(None):
        r = run(name, "-h")
        assert r.exit_code == 0 and "Usage: " in r.output and "-h, --help" in r.output, name


# 5. escfit summary of a fleet, and CSV -----------------------------------------------------------

def test_summary_of_a_fleet_prints_one_row_per_unit(fleet):
    for target in (fleet, fleet / "summary.nc"):
        r = run("summary", target)
        assert r.exit_code == 0, r.output
        lines = r.output.splitlines()
        assert lines[0].split()[:3] == ["unit", "status", "viscous.C"]
        assert [ln.split()[:2] for ln in lines[1:3]] == [["u01", "ok"], ["u02", "ok"]]
        assert re.search(r"u01\s+ok\s+[\d.]+ \[[\d.]+, [\d.]+\]", r.output)


def test_summary_csv_of_a_fleet_and_of_a_fit(fleet):
    rows = list(csv.DictReader(io.StringIO(run("summary", fleet, "--csv").output)))
    assert [r["unit"] for r in rows] == ["u01", "u02"]
    one = rows[0]
    assert float(one["viscous.C_lo95"]) < float(one["viscous.C"]) < float(one["viscous.C_hi95"])
    fit_rows = {r["parameter"]: r for r in csv.DictReader(io.StringIO(run("summary", fleet / "u01.h5", "--csv").output))}
    c = fit_rows["viscous.C"]
    assert c["estimate_kind"] in ("best fit", "median") and c["unit"] == "1/s"
    assert float(c["estimate"]) == pytest.approx(float(one["viscous.C"]), rel=1e-9)
    js = json.loads(run("summary", fleet, "--json").output)
    assert [u["unit"] for u in js["units"]] == ["u01", "u02"]
    r = run("summary", fleet, "--csv", "--json")
    assert r.exit_code == 2 and "alternatives" in r.output


def test_fit_csv_falls_back_to_the_median_of_older_rows():
    from escfit.cli.summary import _fit_csv

    head, rows = _fit_csv({"a": {"unit": "1/s", "median": 1.5, "lo95": 1.0, "hi95": 2.0, "rhat": 1.001}})
    row = dict(zip(head, rows[0]))
    assert (row["estimate"], row["estimate_kind"], row["rhat"], row["ess_bulk"]) == ("1.5", "median", "1.001", "")


# 6. Ctrl-C says how to go on, and never "Aborted!" ---------------------------------------------

def test_ctrl_c_during_emcee_tells_how_to_resume(tmp_path):
    out = tmp_path / "u3.h5"
    proc = subprocess.Popen([*ESCFIT, "fit", ROOT / "fits" / "monday_unit3.toml", "--out", out, "--steps", "20000",
                             "--checkpoint-every", "0.5", "--quiet"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 240
    checkpoint = Path(f"{out}.emcee")
    while not checkpoint.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == EXIT_INTERRUPTED, err
    assert "--resume" in err and "Aborted!" not in err and "Traceback" not in err


def test_ctrl_c_elsewhere_and_in_fit_many(monkeypatch, tmp_path):
    import escfit.study.batch

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(escfit.study.batch, "fit_many", interrupted)
    r = run("fit-many", FLEET / "recordings.csv", "--scene", FLEET_SCENE, "--out", tmp_path, "--quiet")
    assert r.exit_code == EXIT_INTERRUPTED
    assert "same command again" in r.output and "Aborted!" not in r.output
    monkeypatch.setattr("escfit.core.scene.load_scene", interrupted)
    r = run("simulate", DATASETS / "scenes" / "monday_unit3.toml")
    assert r.exit_code == EXIT_INTERRUPTED and "interrupted" in r.output and "Aborted!" not in r.output


# 7. the first compilation is announced once ------------------------------------------------------

def test_compile_notice_once_per_process(monkeypatch):
    from escfit.core import kernels

    def verge_kernel():
        pass

    verge_kernel.__module__ = "escfit.verge.solver"
    monkeypatch.setattr(kernels, "_NOTICE_GIVEN", False)
    monkeypatch.delenv("ESCFIT_QUIET_COMPILE", raising=False)
    first, second = io.StringIO(), io.StringIO()
    assert kernels.notice_compilation(verge_kernel, stream=first)
    assert not kernels.notice_compilation(verge_kernel, stream=second)
    assert first.getvalue().startswith("escfit: compiling the verge integrator for this machine (first run only")
    assert first.getvalue().count("\n") == 1 and second.getvalue() == ""


def test_compile_notice_only_on_a_cold_cache(tmp_path, monkeypatch):
    """A kernel with an empty cache asks for the notice; the same kernel, cached, does not."""
    from escfit.core import kernels

    src = tmp_path / "tiny_kernel_module.py"
    src.write_text("from escfit.core.kernels import kernel\n\n@kernel\ndef add_one(x):\n    return x + 1\n")

    def fresh(name):
        spec = importlib.util.spec_from_file_location(name, src)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module

    asked = []
    monkeypatch.setattr(kernels, "notice_compilation", lambda fn, **kw: asked.append(fn.__name__))
    assert fresh("tiny_kernel_module").add_one(1) == 2
    assert asked == ["add_one"]
    assert fresh("tiny_kernel_module").add_one(2) == 3  # a new dispatcher finds the cache warm
    assert asked == ["add_one"]


def test_compile_notice_not_in_captured_stderr(monkeypatch, capsys):
    from escfit.core import kernels

    monkeypatch.setattr(kernels, "_NOTICE_GIVEN", False)
    monkeypatch.delenv("ESCFIT_QUIET_COMPILE", raising=False)
    assert not kernels.notice_compilation(test_compile_notice_not_in_captured_stderr)
    assert capsys.readouterr().err == ""


# 8. recording headers in another case, and near misses -------------------------------------------

def test_header_case_and_spaces_do_not_matter(tmp_path):
    from escfit.analysis.recordings.detect import detect_format, read_recording

    lower, upper = tmp_path / "lower.csv", tmp_path / "upper.csv"
    body = "0,30\n2,28\n4,26\n6,24\n"
    lower.write_text("# notch_deg: 10\nswing,notches\n" + body)
    upper.write_text("# notch_deg: 10\n Swing , NOTCHES\n" + body)
    assert detect_format(upper) == "unit-curve"
    a, b = read_recording(lower), read_recording(upper)
    assert (a.kind, list(a.value), list(a.swing)) == (b.kind, list(b.value), list(b.swing))
    series = tmp_path / "series.csv"
    series.write_text("Time_s,Theta_Deg\n0,1\n0.1,2\n0.2,1\n0.3,-1\n0.4,-2\n0.5,-1\n0.6,1\n")
    assert detect_format(series) == "timeseries"


def test_close_but_unknown_column_is_named(tmp_path):
    from escfit.analysis.recordings.detect import read_recording
    from escfit.core.errors import DataError

    typo = tmp_path / "typo.csv"
    typo.write_text("# notch_deg: 10\nswing,notchez\n0,30\n2,28\n")
    with pytest.raises(DataError, match=r"'notchez' is not known \(did you mean 'notches'\?\)"):
        read_recording(typo)
    r = run("fit", typo, "--scene", FLEET_SCENE, "--out", tmp_path / "t.h5")
    assert r.exit_code == 2 and "notchez" in r.output and "notches" in r.output
    unknown = tmp_path / "unknown.csv"
    unknown.write_text("swimg,notchez\n0,30\n")
    with pytest.raises(DataError, match="cannot tell the recording format.*'swimg'.*'swing'"):
        read_recording(unknown)


# 9. no third-party warnings on the console -------------------------------------------------------

def test_third_party_warnings_filtered_own_warnings_kept(monkeypatch):
    monkeypatch.delenv("PYTHONWARNINGS", raising=False)
    monkeypatch.setattr(sys, "warnoptions", [])
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        assert quiet_third_party_warnings([])
        for module in ("lmfit.minimizer", "numpy.core", "arviz.data", "dask.array", "escfit.inference.fit"):
            warnings.warn_explicit("something", RuntimeWarning, "x.py", 1, module=module)
        warnings.warn_explicit("ArviZ is undergoing a major refactor", FutureWarning, "y.py", 1, module="escfit.x")
    assert [w.filename for w in seen] == ["x.py"]
    assert not quiet_third_party_warnings(["--debug", "fit"])


def test_real_recording_fit_prints_no_warning(tmp_path):
    real = DATASETS / "real"
    r = subprocess.run([*ESCFIT, "fit", real / "string_pendulum_video" / "lab1_data.txt", "--scene",
                        real / "scenes" / "string_pendulum_lab1.toml", "--out", tmp_path / "lab1.h5", "--quiet"],
                       capture_output=True, text=True, timeout=600, env={**os.environ, "PYTHONWARNINGS": ""})
    assert r.returncode == 0, r.stderr
    assert "Warning" not in r.stderr, r.stderr


# 10. benchmarks write to a new folder and replace nothing without --force -------------------------

def test_bench_outputs_default_to_a_new_folder(tmp_path):
    from datetime import datetime

    from escfit.cli.bench import JSON_NAME, PLOT_NAME, new_run_folder, output_paths

    now = datetime(2026, 3, 1, 9, 5, 7)
    first = new_run_folder(tmp_path, now=now)
    assert first.name == "bench-20260301-090507"
    first.mkdir()
    assert new_run_folder(tmp_path, now=now).name == "bench-20260301-090507-2"
    folder, plot, js = output_paths(None, None, None)
    assert folder.name.startswith("bench-") and (plot.name, js.name) == (PLOT_NAME, JSON_NAME)
    assert output_paths(None, None, "a.json") == (None, None, Path("a.json"))
    assert output_paths(str(tmp_path), None, None, plot=False) == (tmp_path, None, tmp_path / JSON_NAME)


def test_bench_refuses_existing_outputs_before_running(tmp_path):
    (tmp_path / JSON_NAME_FILE).write_text("[]")
    r = run("bench", "--out-dir", tmp_path)
    assert r.exit_code == 2 and "--force" in r.output
    r = run("bench", "--json-out", tmp_path / "missing" / "x.json")
    assert r.exit_code == 2 and "does not exist" in r.output


JSON_NAME_FILE = "work_precision.json"


# 11. help answers at once: nothing heavy is imported ----------------------------------------------

def test_help_and_version_import_nothing_heavy():
    code = ("import sys\nfrom escfit.cli.main import cli\n"
            "for args in (['--help'], ['-h'], ['--version'], ['fit', '--help'], ['summary', '-h']):\n"
            "    try:\n        cli.main(args, prog_name='escfit')\n    except SystemExit:\n        pass\n"
            "heavy = [m for m in ('pint', 'xarray', 'numba', 'scipy', 'lmfit', 'h5py') if m in sys.modules]\n"
            "print('HEAVY', heavy, file=sys.stderr)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert "HEAVY []" in r.stderr, r.stderr


# 12. escfit examples ------------------------------------------------------------------------------

def test_examples_copies_datasets_and_recipes(tmp_path):
    dest = tmp_path / "ex"
    r = run("examples", dest)
    assert r.exit_code == 0, r.output
    assert f"cd {dest} && escfit fit fits/monday_unit3.toml" in r.output
    assert (dest / "datasets" / "real" / "string_pendulum_video" / "LICENSE").is_file()
    assert (dest / "datasets" / "real" / "string_pendulum_video" / "SOURCE.txt").is_file()
    assert not list(dest.rglob("__pycache__")) and not list(dest.rglob("*.pyc"))
    for recipe in (dest / "fits").glob("*.toml"):
        doc = tomllib.loads(recipe.read_text())
        assert (recipe.parent / doc["data"]).exists() and (recipe.parent / doc["scene"]).is_file(), recipe
    r = run("examples", dest)  # again: the same files are there, nothing to copy
    assert r.exit_code == 0 and "copied 0 files" in r.output, r.output
    (dest / "fits" / "monday_unit3.toml").write_text("changed")
    r = run("examples", dest)
    assert r.exit_code == 2 and "fits/monday_unit3.toml differs" in r.output and "--force" in r.output
    assert (dest / "fits" / "monday_unit3.toml").read_text() == "changed"  # refused: nothing replaced
    assert run("examples", dest, "--force").exit_code == 0
    assert (dest / "fits" / "monday_unit3.toml").read_text() == (ROOT / "fits" / "monday_unit3.toml").read_text()
