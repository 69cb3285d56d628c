"""What ``escfit fit --method leastsq`` imports, and its ``--timings`` table.

Each check runs the command in a fresh interpreter: the libraries a process has imported are
only known for a clean module table.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RECIPE = ROOT / "fits" / "real" / "string_pendulum_lab1.toml"

# Run escfit's command line in this process, noting the libraries loaded at the least squares'
# first call (the fit phase) and at the end.
DRIVER = r"""
import json, sys
from escfit.core.unused import leave_out, unused_by
leave_out(unused_by(sys.argv[1:]))  # as the console entry point does, before anything is imported
import escfit.inference.fit
module = sys.modules["escfit.inference.fit"]
inner, seen = module.least_squares, {}
WATCH = ("scipy.signal", "scipy.stats", "pandas", "xarray", "h5py", "emcee", "arviz", "arviz_stats", "matplotlib",
         "lmfit", "distributed", "dask", "pint")

def hooked(*a, **k):
    seen.setdefault("before_fit", [m for m in WATCH if sys.modules.get(m) is not None])
    return inner(*a, **k)

module.least_squares = hooked
from escfit.cli.main import cli
try:
    cli.main(sys.argv[1:], prog_name="escfit")
except SystemExit as exc:
    seen["exit"] = exc.code
seen["at_end"] = [m for m in WATCH if sys.modules.get(m) is not None]
print("SEEN " + json.dumps(seen))
"""


def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env["ESCFIT_QUIET_COMPILE"] = "1"
    return env


def test_least_squares_fit_imports_no_signal_stats_or_pandas_before_the_fit(tmp_path):
    out = tmp_path / "fit.h5"
    r = subprocess.run([sys.executable, "-c", DRIVER, "fit", str(RECIPE), "--method", "leastsq", "--out", str(out),
                        "--quiet"], capture_output=True, text=True, env=_env(), cwd=tmp_path, timeout=900)
    line = [ln for ln in r.stdout.splitlines() if ln.startswith("SEEN ")]
    assert line, r.stderr[-3000:]
    seen = json.loads(line[0][5:])
    assert seen.get("exit") in (0, None), r.stderr[-3000:]
    # nothing heavy is needed to read the recipe, the scene and the record and to start the fit
    assert seen["before_fit"] == [], seen
    # the whole command never needs the signal-processing or statistics packages, a sampler, plots,
    # or dask (which pint and xarray would import, and xarray's own writer its cluster scheduler);
    # nor xarray and pandas: the results are built and written as plain arrays; nor pint: the
    # scene and the record name radians and seconds, whose factors need no unit registry
    never = {"scipy.signal", "scipy.stats", "emcee", "arviz", "matplotlib", "distributed", "dask", "xarray", "pandas",
             "pint"}
    assert not never & set(seen["at_end"]), seen
    assert out.is_file()


def test_sampler_fit_imports_no_statistics_signal_or_data_libraries(tmp_path):
    # the quick start's posterior: emcee without scipy.stats, convergence figures without ArviZ's
    # dependencies, results written as plain arrays
    out = tmp_path / "fit.h5"
    recipe = ROOT / "fits" / "monday_unit3.toml"
    r = subprocess.run([sys.executable, "-c", DRIVER, "fit", str(recipe), "--out", str(out), "--quiet"],
                       capture_output=True, text=True, env=_env(), cwd=tmp_path, timeout=900)
    line = [ln for ln in r.stdout.splitlines() if ln.startswith("SEEN ")]
    assert line, r.stderr[-3000:]
    seen = json.loads(line[0][5:])
    assert seen.get("exit") in (0, None), r.stderr[-3000:]
    assert "emcee" in seen["at_end"] and out.is_file()
    # pint neither: the loads are in grams, a unit of the table of exact factors
    never = {"scipy.signal", "scipy.stats", "arviz", "arviz_stats", "matplotlib", "distributed", "dask", "xarray", "pandas",
             "pint"}
    assert not never & set(seen["at_end"]), seen


def test_a_unit_curve_fit_with_its_report_reads_no_xarray(tmp_path):
    # the report of a fit just run is made from the results in memory, as plain arrays
    out = tmp_path / "fit.h5"
    recipe = ROOT / "fits" / "monday_unit3.toml"
    r = subprocess.run([sys.executable, "-c", DRIVER, "fit", str(recipe), "--out", str(out), "--quiet", "--steps",
                        "200", "--report", str(tmp_path / "fit.html")],
                       capture_output=True, text=True, env=_env(), cwd=tmp_path, timeout=900)
    line = [ln for ln in r.stdout.splitlines() if ln.startswith("SEEN ")]
    assert line, r.stderr[-3000:]
    seen = json.loads(line[0][5:])
    assert seen.get("exit") in (0, None), r.stderr[-3000:]
    assert "matplotlib" in seen["at_end"] and (tmp_path / "fit.html").is_file()
    assert not {"xarray", "pandas", "scipy.stats", "arviz"} & set(seen["at_end"]), seen


def test_timings_table_adds_up_to_the_process(tmp_path):
    out = tmp_path / "fit.h5"
    r = subprocess.run([sys.executable, "-m", "escfit", "fit", str(RECIPE), "--method", "leastsq", "--out", str(out),
                        "--quiet", "--timings"], capture_output=True, text=True, env=_env(), cwd=tmp_path, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    rows = {}
    for line in r.stderr.splitlines():
        parts = line.rsplit(None, 2)
        if len(parts) == 3 and parts[1].replace(".", "").isdigit():
            rows[parts[0].strip()] = (float(parts[1]), float(parts[2]))
    expected = {"start-up", "imports", "scene", "record", "least squares", "results", "write", "summary", "other",
                "total (process)"}
    assert expected <= set(rows), r.stderr
    total = rows.pop("total (process)")
    # the phases and the rest make up the whole process, wall and CPU (rounding to 1 ms per row)
    assert abs(sum(v[0] for v in rows.values()) - total[0]) < 0.001 * (len(rows) + 1) + 0.02
    assert abs(sum(v[1] for v in rows.values()) - total[1]) < 0.001 * (len(rows) + 1) + 0.02
    assert rows["least squares"][1] > 0 and rows["record"][1] > 0


def test_the_command_exits_with_its_status_and_keeps_a_profilers_output(tmp_path):
    # the process ends without the interpreter's teardown, but with the command's status, its
    # output flushed, and a profiler's statistics written (they are written at the end)
    args = ["-m", "escfit", "fit", str(tmp_path / "missing.csv"), "--scene", str(tmp_path / "missing.toml")]
    r = subprocess.run([sys.executable, *args], capture_output=True, text=True, env=_env(), cwd=tmp_path, timeout=300)
    assert r.returncode == 2 and "data file not found" in r.stderr
    prof = tmp_path / "run.prof"  # (cProfile itself ends with status 0 whatever the program's)
    r = subprocess.run([sys.executable, "-m", "cProfile", "-o", str(prof), *args], capture_output=True, text=True,
                       env=_env(), cwd=tmp_path, timeout=300)
    assert "data file not found" in r.stderr
    assert prof.is_file() and prof.stat().st_size > 0
    r = subprocess.run([sys.executable, "-m", "escfit", "--version"], capture_output=True, text=True, env=_env(),
                       timeout=300)
    assert r.returncode == 0 and r.stdout.startswith("escfit")


# A command run inside a process (a notebook's or a test's CliRunner) leaves dask alone: only
# the console entry point, whose process ends with the command, marks it as not installed.
IN_PROCESS = r"""
import importlib.util, subprocess, sys
from click.testing import CliRunner
from escfit.cli.main import cli
result = CliRunner().invoke(cli, ["summary", "missing.h5"])
assert result.exit_code == 2, result.output
assert sys.modules.get("dask", 0) is not None and importlib.util.find_spec("dask") is not None
import dask, escfit.core.units
print("OK", dask.__name__)
"""


def test_a_command_in_process_leaves_dask_alone(tmp_path):
    r = subprocess.run([sys.executable, "-c", IN_PROCESS], capture_output=True, text=True, env=_env(), cwd=tmp_path,
                       timeout=300)
    assert r.returncode == 0 and "OK dask" in r.stdout, r.stderr[-3000:]


def test_the_commands_that_leave_dask_out():
    from escfit.core.unused import unused_by

    assert unused_by(["fit", "x.csv"]) == ("dask",)
    assert unused_by(["--debug", "report", "x.h5"]) == ("dask",)
    assert unused_by(["fit-many", "a.csv"]) == ()  # runs its fits on dask
    assert unused_by(["--version"]) == ()


INIT = r"""
import sys
from escfit.core.unused import leave_out, unused_by
leave_out(unused_by(sys.argv[1:]))
from escfit.cli.main import cli
try:
    cli.main(sys.argv[1:], prog_name="escfit")
except SystemExit as exc:
    print("EXIT", exc.code)
print("INTEGRATE", "scipy.integrate" in sys.modules)
"""


def test_init_reads_the_dop853_tables_without_scipy_integrate(tmp_path):
    import numpy as np
    import scipy.integrate._ivp.dop853_coefficients as scipys

    from escfit.balance.dop853_tables import tables

    for name in ("N_STAGES", "A", "B", "C", "D", "E3", "E5"):  # the file scipy's solve_ivp reads
        assert np.array_equal(getattr(tables, name), getattr(scipys, name)), name
    record = ROOT / "datasets" / "real" / "encoder_pendulum_jensen" / "pendulum_free_swing_data_02.txt"
    r = subprocess.run([sys.executable, "-c", INIT, "init", str(record), "--pendulum", "--out",
                        str(tmp_path / "scene.toml")], capture_output=True, text=True, env=_env(), cwd=tmp_path,
                       timeout=900)
    assert "EXIT 0" in r.stdout or (tmp_path / "scene.toml").is_file(), r.stderr[-2000:]
    assert "INTEGRATE False" in r.stdout, r.stdout[-2000:]


def test_the_command_line_sets_one_blas_thread_and_freezes_what_the_imports_leave():
    """Set when the command line loads, before numpy (escfit/cli/process.py); the environment's
    own BLAS setting wins; after a full collection its survivors are out of the next one's walk,
    for the first passes only, and the collector's thresholds stay Python's; callbacks registered
    after it (dask's count passes) see every pass start and stop."""
    code = ("import gc, os, sys; default = gc.get_threshold(); import escfit.cli.main as m\n"
            "pairs = []; gc.callbacks.append(lambda phase, info: pairs.append(phase))\n"
            "before = gc.get_freeze_count(); junk = [[i] for i in range(50000)]; gc.collect()\n"
            "frozen = gc.get_freeze_count() - before\n"
            "gc.collect(); gc.collect(); gc.collect(); after = gc.get_freeze_count()\n"
            "gc.collect(); print(os.environ['OPENBLAS_NUM_THREADS'], frozen > 50000, gc.get_freeze_count() == after, "
            "gc.get_threshold() == default, 'numpy' in sys.modules, pairs.count('start') == pairs.count('stop'))")
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    assert out.split() == ["1", "True", "True", "True", "False", "True"]  # every callback saw each pass end
    env["OPENBLAS_NUM_THREADS"] = "2"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    assert out.split()[0] == "2"
