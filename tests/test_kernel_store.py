"""The kernels shipped compiled (escfit/_kernels): a first run on a new machine compiles none of
what the examples need, and gives the same estimates as kernels compiled for the machine.

Each check runs escfit in a fresh interpreter with an empty numba cache folder
(``NUMBA_CACHE_DIR``), as on a machine that has never run escfit, and records every kernel numba
would have to compile (:func:`escfit.core.kernels.notice_compilation` is called exactly then).
A stored kernel that no longer matches its source is one of those: the message says how to
rebuild the store.  Skipped where the store cannot apply (another processor family, numba or
Python version): there escfit compiles as before.
"""

from __future__ import annotations

import json
import os
import pickle
import platform
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest

from escfit.core.kernel_store import STORE

ROOT = Path(__file__).resolve().parents[1]
REBUILD = "the shipped kernels are stale: rebuild them with `python -m escfit.cli.kernel_build`"

DRIVER = r"""
import json, sys
import escfit.core.kernels as kernels
compiled = []
kernels.notice_compilation = lambda py_func, **kw: compiled.append(f"{py_func.__module__}.{py_func.__qualname__}")
from escfit.cli.main import cli
try:
    cli.main(sys.argv[1:], prog_name="escfit")
except SystemExit as exc:
    code = exc.code
print("COMPILED " + json.dumps({"exit": code, "kernels": compiled}))
"""


def _applies() -> str | None:
    """Why the store cannot apply here, or None."""
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return f"kernels are stored for x86-64, this is {platform.machine()}"
    index = sorted(STORE.glob("*.nbi"))
    if not index:
        return "no stored kernels"
    tag = f".py{sys.version_info[0]}{sys.version_info[1]}.nbi"
    if not index[0].name.endswith(tag):
        return f"kernels are stored for another Python ({index[0].name})"
    with open(index[0], "rb") as f:
        version = pickle.load(f)
    if version != numba.__version__:
        return f"kernels are stored for numba {version}, this is numba {numba.__version__}"
    if os.environ.get("ESCFIT_KERNEL_STORE", "1") == "0":
        return "ESCFIT_KERNEL_STORE=0"
    return None


def _first_run(tmp_path: Path, args: list[str]) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba-cache"), ESCFIT_QUIET_COMPILE="1")
    env.pop("NUMBA_CPU_NAME", None)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    r = subprocess.run([sys.executable, "-c", DRIVER, *args], capture_output=True, text=True, env=env, cwd=ROOT,
                       timeout=900)
    line = [ln for ln in r.stdout.splitlines() if ln.startswith("COMPILED ")]
    assert line, r.stderr[-3000:]
    return json.loads(line[0][9:])


def test_a_first_least_squares_fit_compiles_nothing(tmp_path):
    why = _applies()
    if why:
        pytest.skip(why)
    out = tmp_path / "fit.h5"
    seen = _first_run(tmp_path, ["fit", "fits/real/string_pendulum_lab1.toml", "--method", "leastsq",
                                 "--out", str(out), "--quiet"])
    assert seen["exit"] in (0, None), seen
    assert seen["kernels"] == [], f"{REBUILD}; compiled: {seen['kernels']}"
    # the same estimates as with kernels compiled for this machine (the store turned off)
    env = dict(os.environ, ESCFIT_KERNEL_STORE="0", ESCFIT_QUIET_COMPILE="1")
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    own = tmp_path / "own.h5"
    r = subprocess.run([sys.executable, "-m", "escfit", "fit", "fits/real/string_pendulum_lab1.toml", "--method",
                        "leastsq", "--out", str(own), "--quiet"], capture_output=True, text=True, env=env, cwd=ROOT,
                       timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    from escfit.results import load_fit

    a, b = load_fit(out).group("least_squares"), load_fit(own).group("least_squares")
    se = b["stderr"].values
    assert np.all(np.abs(a["value"].values - b["value"].values) <= 1e-6 * se), (a["value"].values, b["value"].values)


@pytest.mark.parametrize("recipe", ["fits/real/encoder_pendulum_jensen.toml", "fits/monday_unit3.toml"])
def test_the_examples_first_runs_compile_nothing(tmp_path, recipe):
    why = _applies()
    if why:
        pytest.skip(why)
    seen = _first_run(tmp_path, ["fit", recipe, "--out", str(tmp_path / "fit.h5"), "--quiet"])
    assert seen["exit"] in (0, 3, None), seen
    assert seen["kernels"] == [], f"{REBUILD}; compiled: {seen['kernels']}"
