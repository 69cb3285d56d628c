"""What the libraries of ``escfit fit --method leastsq`` cost before escfit does anything.

Run from a checkout:  python benchmarks/library_floor.py [--repeat N]

Each of ``--repeat`` fresh interpreters imports, in the order a least-squares fit needs them,
click, numpy, scipy's optimisers (with ``scipy.integrate``'s DOP853 tables and ``scipy.special``),
numba, one kernel loaded from numba's on-disk cache (numba's first load builds its typing and
target registries, whatever the kernel) and h5netcdf, with dask marked as not installed and
OpenBLAS on one thread as the command line does (:mod:`escfit.core.unused`).  pint with its
cached unit registry, then xarray (with pandas) are timed last, apart: the scene and the record
name only units of :data:`escfit.core.units.COMMON_UNITS`, read without pint, and the results
are written without xarray since they are held as plain arrays (:mod:`escfit.core.plain_tree`),
so neither is part of the floor any more, but their costs say what that saved.  The CPU seconds of each step (the median
over the runs) and their sum are printed: the floor under the whole command's CPU time that no
change inside escfit can lower.  Then the whole command on the string pendulum
(``fits/real/string_pendulum_lab1.toml``), also in fresh interpreters, for comparison.  Python
writes bytecode files here as it does for a user (``PYTHONDONTWRITEBYTECODE`` is removed).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RECIPE = ROOT / "fits" / "real" / "string_pendulum_lab1.toml"

KERNEL = """import numba


@numba.njit(cache=True)
def total(x):
    return x.sum()
"""

PROBE = r"""
import json, sys, time
sys.modules["dask"] = None
c, t = time.process_time, {}
s = c(); import click; t["click"] = c() - s
s = c(); import numpy as np; t["numpy"] = c() - s
s = c(); import scipy.optimize, scipy.special, scipy.integrate; t["scipy (optimize, special, integrate)"] = c() - s
s = c(); import numba; t["numba"] = c() - s
s = c(); import floor_kernel; floor_kernel.total(np.ones(3)); t["numba's first cached kernel"] = c() - s
s = c(); import h5netcdf; t["h5py, h5netcdf"] = c() - s
t["process (with the interpreter's start)"] = c()
s = c(); import pint; pint.UnitRegistry(cache_folder=":auto:"); t["(not needed) pint and its unit registry"] = c() - s
s = c(); import xarray as xr; xr.Dataset({"a": ("x", np.ones(3))}); t["(not needed) xarray, pandas, a dataset"] = c() - s
print("FLOOR " + json.dumps(t))
"""


def _env(folder: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = os.pathsep.join([str(folder), str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env["ESCFIT_QUIET_COMPILE"] = "1"
    env.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the command line sets it
    return env


def _floor(folder: Path) -> dict:
    r = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=_env(folder), cwd=folder,
                       check=True)
    return json.loads([ln for ln in r.stdout.splitlines() if ln.startswith("FLOOR ")][0][6:])


def _command(folder: Path) -> float:
    """CPU seconds of the whole fit command (children's accounting of one fresh process)."""
    before = os.times()
    subprocess.run([sys.executable, "-m", "escfit", "fit", str(RECIPE), "--method", "leastsq", "--out",
                    str(folder / "fit.h5"), "--force", "--quiet"], capture_output=True, env=_env(folder), cwd=folder,
                   check=True)
    after = os.times()
    return (after.children_user - before.children_user) + (after.children_system - before.children_system)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "floor_kernel.py").write_text(KERNEL)
        _floor(folder), _command(folder)  # fill numba's cache and the bytecode files; not counted
        runs = [_floor(folder) for _ in range(args.repeat)]
        whole = [_command(folder) for _ in range(args.repeat)]
    print(f"load average {os.getloadavg()[0]:.2f}; medians of {args.repeat} fresh processes, CPU seconds")
    steps = list(runs[0])
    for step in steps:
        print(f"  {step:42s} {statistics.median(r[step] for r in runs):6.3f}")
    libraries = statistics.median(sum(v for k, v in r.items() if not k.startswith(("process", "(not"))) for r in runs)
    print(f"  {'libraries in all':42s} {libraries:6.3f}")
    print(f"  {'escfit fit (string pendulum, leastsq)':42s} {statistics.median(whole):6.3f}"
          f"  (range {min(whole):.3f}-{max(whole):.3f})")


if __name__ == "__main__":
    main()
