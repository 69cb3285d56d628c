"""The README's quick start, phase by phase, against an earlier version in the same run.

Runs ``escfit fit fits/monday_unit3.toml --report ...`` (Monday's unit 3, three loads, emcee)
in a fresh Python process for the current checkout and for an earlier revision extracted
with ``git archive`` (default: the last revision before the sampler and likelihood rework),
each with its own recipe as shipped at that revision, and prints where the time goes:

* ``imports``: the command's imports (escfit, numpy, scipy, xarray, lmfit, emcee, pint ...);
* ``compile``: first call of the exact solver's kernels, single and batch (compiled, or
  loaded from numba's cache when warm);
* ``least_squares``, ``sampling`` (emcee without saving), ``checkpoint`` (saving the
  sampler's state), ``diagnostics`` (R-hat/ESS, predictive draws, checks: the results tree),
  ``write`` (the results file), ``report`` (the HTML report);
* ``process``: the whole command, interpreter start to exit, measured outside.

"cold" runs use an empty numba cache directory (everything compiles); "warm" runs reuse the
cache the cold run filled.  Each configuration is repeated ``--repeat`` times; min and median
are printed, with the ratio old/new of each phase's median.  The machine's load average is
printed before and after (other work on the 2 cores inflates times; ratios from one run are
more robust).

Usage (from the repository root)::

    python benchmarks/quickstart.py [--baseline 2e7e582] [--repeat 3] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PHASES = ["imports", "compile", "least_squares", "sampling", "checkpoint", "diagnostics", "write", "report",
          "process"]

HARNESS = r"""
import json, sys, time
t0 = time.perf_counter()
import escfit.cli.main
import escfit.inference.fit
import escfit.report
# the modules, not the functions of the same names their packages export
cli_main, F, R = (sys.modules[m] for m in ("escfit.cli.main", "escfit.inference.fit", "escfit.report"))
phases = {"imports": time.perf_counter() - t0}

def wrap(owner, name, key):
    f = getattr(owner, name)
    def timed(*a, **k):
        s = time.perf_counter()
        try:
            return f(*a, **k)
        finally:
            phases[key] = phases.get(key, 0.0) + time.perf_counter() - s
    setattr(owner, name, timed)

wrap(F, "least_squares", "least_squares")
wrap(F, "run_emcee", "emcee")
wrap(F, "build_tree", "diagnostics")
wrap(F, "write_fit", "write")
wrap(R, "make_report", "report")
import escfit.inference.mcmc
M = sys.modules["escfit.inference.mcmc"]
if hasattr(M, "save_checkpoint"):
    wrap(M, "save_checkpoint", "checkpoint")  # chunked checkpoint
else:
    import emcee
    wrap(emcee.backends.HDFBackend, "save_step", "checkpoint")  # emcee's per-step HDF5 backend

recipe, out, report = sys.argv[1:4]
import escfit
from escfit.core.scene import load_scene
from escfit.balance.solvers import solve_system
from escfit.balance.batch import solve_batch
import tomllib, pathlib
doc = tomllib.loads(pathlib.Path(recipe).read_text())
scene = load_scene(str((pathlib.Path(recipe).parent / doc["scene"]).resolve()))
s = time.perf_counter()
system = scene.system(scene.params.values())
solve_system(system, 4, "exact")
solve_batch([system, system], 4)
phases["compile"] = time.perf_counter() - s
try:
    cli_main.cli.main(["fit", recipe, "--out", out, "--report", report, "--quiet"], standalone_mode=False)
finally:
    phases["sampling"] = phases.pop("emcee", 0.0) - phases.get("checkpoint", 0.0)
    print("PHASES " + json.dumps(phases))
"""


def _load() -> list[float]:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:  # pragma: no cover
        return []


def _extract(rev: str, into: Path) -> Path:
    """The package, recipes and datasets of ``rev`` in ``into`` (git archive, nothing else touched)."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "escfit", "fits", "datasets"],
                             check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


def _run(root: Path, cache: Path, work: Path, tag: str) -> dict:
    out, report = work / f"{tag}.h5", work / f"{tag}.html"
    for f in (out, report):
        f.unlink(missing_ok=True)
    env = {**os.environ, "PYTHONPATH": str(root), "NUMBA_CACHE_DIR": str(cache)}
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", HARNESS, str(root / "fits" / "monday_unit3.toml"), str(out),
                           str(report)], env=env, capture_output=True, text=True, cwd=work)
    wall = time.perf_counter() - start
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("PHASES ")]
    if proc.returncode != 0 or not line:
        raise SystemExit(f"{tag}: the quick start failed (exit {proc.returncode}):\n{proc.stdout[-2000:]}\n"
                         f"{proc.stderr[-2000:]}")
    phases = json.loads(line[0][len("PHASES "):])
    phases["process"] = wall
    steps = [ln for ln in proc.stdout.splitlines() if ln.startswith("emcee:")]
    phases["run"] = steps[0] if steps else "fixed length (the recipe's steps)"
    return phases


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default="2e7e582", help="earlier revision to compare with (git)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", default=None, help="write the figures to this file")
    ap.add_argument("--force", action="store_true", help="replace existing output files")
    args = ap.parse_args(argv)
    for out in (args.json,):  # refused before the run, not after it
        if out and Path(out).exists() and not args.force:
            ap.error(f"{out} exists; pass --force to replace it")
    before = _load()
    records: dict = {"baseline": args.baseline, "load_before": before, "runs": {}}
    with tempfile.TemporaryDirectory(prefix="escfit-quickstart-") as tmp:
        tmp = Path(tmp)
        (tmp / "baseline").mkdir()
        base = _extract(args.baseline, tmp / "baseline")
        for label, root in (("baseline", base), ("current", ROOT)):
            cache = tmp / f"cache-{label}"
            cache.mkdir()
            work = tmp / f"work-{label}"
            work.mkdir()
            records["runs"][f"{label} cold"] = [_run(root, cache, work, "cold")]
            records["runs"][f"{label} warm"] = [_run(root, cache, work, f"warm{i}") for i in range(args.repeat)]
    records["load_after"] = _load()
    _print(records)
    if args.json:
        Path(args.json).write_text(json.dumps(records, indent=1))
    return records


def _print(records: dict) -> None:
    runs = records["runs"]
    print(f"quick start (fits/monday_unit3.toml): baseline {records['baseline']} vs current checkout; "
          f"load average before {records['load_before']}, after {records['load_after']}")
    cols = list(runs)
    print("phase (s, min / median)".ljust(24) + "".join(c.rjust(22) for c in cols) + "   old/new (warm median)")
    for ph in PHASES:
        cells = []
        for c in cols:
            v = [r.get(ph, 0.0) for r in runs[c]]
            cells.append(f"{min(v):.2f} / {statistics.median(v):.2f}".rjust(22))
        old = statistics.median(r.get(ph, 0.0) for r in runs["baseline warm"])
        new = statistics.median(r.get(ph, 0.0) for r in runs["current warm"])
        ratio = f"{old / new:.1f}x" if new > 1e-3 else "-"
        print(ph.ljust(24) + "".join(cells) + ratio.rjust(12))
    for c in cols:
        print(f"{c}: {runs[c][0]['run']}")


if __name__ == "__main__":
    main()
