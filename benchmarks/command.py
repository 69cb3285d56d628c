"""The whole ``escfit fit`` command, phase by phase, against the previous version in one run.

Run from a checkout::

    python benchmarks/command.py [--previous DIR | --baseline REV] [--repeat 5] [--quickstart] [--trial] [--only]
                                 [--cold]

(``--previous`` a checkout of the previous main, e.g. ``git worktree add --detach DIR main``.)

Each job runs as a user runs it (``python -m escfit fit RECIPE ...``), in a fresh process, the
previous version and this checkout in turn (A B A B ...), so that a drift of the shared
machine's speed hits both alike; the ratio previous/current is taken pair by pair and its
median printed.  Jobs: the string pendulum's least squares (``fits/real/string_pendulum_lab1.toml
--method leastsq``) and, with ``--quickstart``, the README's quick start
(``fits/monday_unit3.toml --report``, emcee), and with ``--trial`` the string pendulum's trial posterior
(``fits/real/string_pendulum_trial1.toml``, emcee, nine parameters); ``--only`` leaves out the least squares.

Phases are timed the same way in both versions, from outside escfit's code: a small harness
wraps, as each module finishes importing, the functions that start each phase (the scene's
loading, the fit, least squares (with the agreement check's turning-point refit), the rest of
the agreement check of the fit with the record's turning points, sampling, the results tree, the write, the printed summary,
the report) and reads the process's wall and CPU clocks around them ("record" is what the fit
spends outside those: reading and analysing the record); start-up and imports are
the time from the process's start (``/proc``) to the first of them.  The same harness counts
the least-squares runs (calls of ``scipy.optimize.least_squares``, one per start, per noise
stage and per refit) and the model runs (a solver's run of one parameter set; a batch call
counts its sets).  The whole process's wall time and CPU seconds (user + system, from the
operating system's accounting of the finished
child) are measured outside.  ``--cold`` adds one run of each version with an empty numba cache
(everything compiled): the first run after an install.

The interpreter writes its bytecode cache under a temporary folder (``PYTHONPYCACHEPREFIX``)
and ``PYTHONDONTWRITEBYTECODE`` is cleared, as for an installed package: otherwise every run
would compile escfit's Python sources again.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from previous import ROOT, checkout  # noqa: E402

BASELINE = "16b1105"
PHASES = ["start-up + imports", "scene", "record", "least squares", "agreement", "sampling", "results", "write", "summary",
          "report", "other"]

# Run as ``python -c HARNESS ARGS...``: escfit's own ``python -m escfit`` with phase clocks.
HARNESS = r'''
import json, os, sys, time, importlib.abc, importlib.util, runpy

def since_start():
    with open("/proc/self/stat", "rb") as fh:
        ticks = int(fh.read().rsplit(b")", 1)[1].split()[19])
    with open("/proc/uptime", "rb") as fh:
        up = float(fh.read().split()[0])
    return up - ticks / os.sysconf("SC_CLK_TCK"), time.process_time()

# module -> [(attribute, phase)]; an attribute missing in a version is skipped
TARGETS = {"escfit.core.scene": [("load_scene", "scene")],
           "escfit.inference.fit": [("fit", "fit"), ("fit_problem", "fit_problem"), ("least_squares", "least squares"),
                                    ("reconcile", "least squares"), ("with_held_uncertainty", "least squares"),
                                    ("run_emcee", "sampling"), ("build_tree", "results"), ("write_fit", "write")],
           "escfit.balance.problems.agreement": [("check_agreement", "agreement")],
           "escfit.cli.summary": [("print_summary", "summary")],
           "escfit.report": [("make_report", "report")]}
# module -> [(attribute, counter)]: scipy's least-squares runs, and the model runs (a batch call counts its sets)
COUNTED = {"scipy.optimize": [("least_squares", "fits")],
           "escfit.balance.solvers": [("solve_system", "model runs")],
           "escfit.balance.batch_dense": [("sample_batch", "model runs")],
           "escfit.balance.batch_dop853": [("sample_batch_dop853", "model runs")]}
totals, stack, first, counts = {}, [], [], {"fits": 0, "model runs": 0}

def counted(func, name):
    def run(*a, **k):
        out = func(*a, **k)
        sets = out[0].shape[0] if name == "model runs" and isinstance(out, tuple) and hasattr(out[0], "shape") else 1
        counts[name] += int(sets)
        return out
    return run

def timed(func, name):
    def run(*a, **k):
        if not first:
            first.append(since_start())
        entry = [time.perf_counter(), time.process_time(), 0.0, 0.0]
        stack.append(entry)
        try:
            return func(*a, **k)
        finally:
            wall, cpu = time.perf_counter() - entry[0], time.process_time() - entry[1]
            stack.pop()
            t = totals.setdefault(name, [0.0, 0.0])
            t[0] += wall - entry[2]
            t[1] += cpu - entry[3]
            if stack:
                stack[-1][2] += wall
                stack[-1][3] += cpu
    return run

class Hook(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name not in TARGETS and name not in COUNTED:
            return None
        sys.meta_path.remove(self)
        try:
            spec = importlib.util.find_spec(name)
        finally:
            sys.meta_path.insert(0, self)
        inner = spec.loader.exec_module
        def exec_module(module):
            inner(module)
            for attr, label in TARGETS.get(name, ()):
                if callable(getattr(module, attr, None)) and not isinstance(getattr(module, attr), type):
                    setattr(module, attr, timed(getattr(module, attr), label))
            for attr, label in COUNTED.get(name, ()):
                if callable(getattr(module, attr, None)):
                    setattr(module, attr, counted(getattr(module, attr), label))
        spec.loader.exec_module = exec_module
        return spec

def report():  # at exit: escfit's command line may end the process without returning here
    end = since_start()
    startup = first[0] if first else end
    out = {"start-up + imports": list(startup), **totals, "process": list(end), "counts": counts}
    os.write(1, ("\nPHASES " + json.dumps(out) + "\n").encode())

import atexit
atexit.register(report)
sys.meta_path.insert(0, Hook())
sys.argv = ["escfit", *sys.argv[1:]]
runpy.run_module("escfit", run_name="__main__", alter_sys=True)
'''


def _phases(raw: dict) -> dict[str, tuple[float, float]]:
    """Wall and CPU seconds per phase: the record is the fit less the rest it wraps, ``other``
    the process less every phase."""
    get = lambda k: tuple(raw.get(k, (0.0, 0.0)))  # noqa: E731
    out = {"start-up + imports": get("start-up + imports")}
    for key in ("scene", "least squares", "agreement", "sampling", "results", "write", "summary", "report"):
        out[key] = get(key)
    # ``fit`` and ``fit_problem`` were charged only what their inner phases left: reading and
    # analysing the record (and the checks around it)
    fit, problem = get("fit"), get("fit_problem")
    out["record"] = (fit[0] + problem[0], fit[1] + problem[1])
    process = get("process")
    out["other"] = tuple(max(process[i] - sum(v[i] for v in out.values()), 0.0) for i in (0, 1))
    return out


def _env(folder: Path, pycache: Path, numba_cache: Path | None) -> dict:
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    env.update(PYTHONPATH=str(folder), PYTHONPYCACHEPREFIX=str(pycache), ESCFIT_QUIET_COMPILE="1")
    if numba_cache is not None:
        env["NUMBA_CACHE_DIR"] = str(numba_cache)
    return env


def run_once(folder: Path, args: list[str], work: Path, pycache: Path, numba_cache: Path | None = None) -> dict:
    """One run of ``escfit ARGS`` under ``folder``'s escfit: its phases, and the process's wall and CPU."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    clock = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", HARNESS, *args], env=_env(folder, pycache, numba_cache),
                          cwd=work, capture_output=True)
    wall = time.perf_counter() - clock
    after = resource.getrusage(resource.RUSAGE_CHILDREN)  # the finished child's user + system seconds
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    stdout, stderr = proc.stdout, proc.stderr
    lines = [ln for ln in stdout.decode().splitlines() if ln.startswith("PHASES ")]
    if not lines:
        raise SystemExit(f"escfit {' '.join(args)} under {folder} failed:\n{stderr.decode()[-3000:]}")
    raw = json.loads(lines[-1][len("PHASES "):])
    if proc.returncode not in (0, 3):  # 3: a fit that ran but determined nothing
        raise SystemExit(f"escfit {' '.join(args)} under {folder} exited {proc.returncode}:\n{stderr.decode()[-3000:]}")
    return {"phases": _phases(raw), "wall": wall, "cpu": cpu, "counts": raw.get("counts", {})}


def job_args(job: str, out: Path) -> list[str]:
    if job == "leastsq":
        recipe = "fits/real/string_pendulum_lab1.toml"
        return ["fit", recipe, "--method", "leastsq", "--out", str(out), "--force", "--quiet"]
    if job == "trial":
        return ["fit", "fits/real/string_pendulum_trial1.toml", "--out", str(out), "--force", "--quiet"]
    return ["fit", "fits/monday_unit3.toml", "--out", str(out), "--force", "--quiet", "--report",
            str(out.with_suffix(".html"))]


def measure(job: str, previous: Path, repeat: int, tmp: Path, cold: bool) -> dict:
    runs: dict[str, list] = {"previous": [], "current": []}
    pycache = tmp / "pycache"
    for label, folder in (("previous", previous), ("current", ROOT)):  # warm: numba's cache, the bytecode
        run_once(folder, _abs(job_args(job, tmp / f"{label}-{job}.h5"), folder), folder, pycache)
    for _ in range(repeat):
        for label, folder in (("previous", previous), ("current", ROOT)):
            runs[label].append(run_once(folder, _abs(job_args(job, tmp / f"{label}-{job}.h5"), folder), folder,
                                        pycache))
    record = {"runs": runs}
    if job == "leastsq":
        record["shift"] = estimate_shift(tmp / f"previous-{job}.h5", tmp / f"current-{job}.h5")
    if cold:
        for label, folder in (("previous", previous), ("current", ROOT)):
            cache = Path(tempfile.mkdtemp(prefix="numba-cold-", dir=tmp))
            record[f"{label} cold"] = run_once(folder, _abs(job_args(job, tmp / f"{label}-cold.h5"), folder),
                                               folder, pycache, numba_cache=cache)
    return record


SHIFT = r'''
import json, sys
import numpy as np
from escfit.results import load_fit
old, new = (load_fit(p).group("least_squares") for p in sys.argv[1:3])
se = old["stderr"].values
print(json.dumps({"names": [str(n) for n in old["parameter"].values],
                  "value_se": ((new["value"].values - old["value"].values) / se).tolist(),
                  "stderr_rel": (new["stderr"].values / se - 1.0).tolist(),
                  "rtol": load_fit(sys.argv[2]).attrs.get("solver_options", "")}))
'''


def estimate_shift(previous: Path, current: Path) -> dict:
    """How far the current least-squares estimates lie from the previous version's, in the
    previous standard errors, and how the standard errors changed (read by this checkout's escfit)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", SHIFT, str(previous), str(current)], env=env, capture_output=True,
                         text=True)
    if out.returncode != 0:
        return {"error": out.stderr[-500:]}
    return json.loads(out.stdout)


def _abs(args: list[str], folder: Path) -> list[str]:
    """Recipe paths of a job, under the version's own folder (its own recipes and datasets)."""
    return [str(folder / a) if a.startswith("fits/") else a for a in args]


def report(job: str, record: dict) -> list[str]:
    runs = record["runs"]
    med = lambda label, f: statistics.median(f(r) for r in runs[label])  # noqa: E731
    lines = [f"## {job}", "", "| phase | previous wall / CPU s | current wall / CPU s |", "| --- | ---: | ---: |"]
    for ph in PHASES:
        old = (med("previous", lambda r: r["phases"][ph][0]), med("previous", lambda r: r["phases"][ph][1]))
        new = (med("current", lambda r: r["phases"][ph][0]), med("current", lambda r: r["phases"][ph][1]))
        if max(old + new) < 0.0005:
            continue
        lines.append(f"| {ph} | {old[0]:.3f} / {old[1]:.3f} | {new[0]:.3f} / {new[1]:.3f} |")
    pairs = list(zip(runs["previous"], runs["current"]))
    for key, name in (("wall", "whole process, wall"), ("cpu", "whole process, CPU")):
        old, new = med("previous", lambda r: r[key]), med("current", lambda r: r[key])
        ratio = statistics.median(a[key] / b[key] for a, b in pairs)
        lines.append(f"| **{name}** | {old:.3f} | {new:.3f} (previous/current, pairwise median {ratio:.2f}x) |")
    for key in ("fits", "model runs"):
        old, new = (med(label, lambda r: r["counts"].get(key, 0)) for label in ("previous", "current"))
        what = "least-squares runs (scipy)" if key == "fits" else "model runs (a batch call counts its sets)"
        lines.append(f"| {what} | {old:.0f} | {new:.0f} |")
    shift = record.get("shift")
    if shift and "names" in shift:
        worst = int(np.argmax(np.abs(shift["value_se"])))
        lines.append(f"| largest estimate shift, previous standard errors | | {shift['value_se'][worst]:+.2e} "
                     f"({shift['names'][worst]}); standard errors within {max(map(abs, shift['stderr_rel'])):.1e} "
                     f"relative; current solver options {shift['rtol']} |")
    for label in ("previous", "current"):
        cold = record.get(f"{label} cold")
        if cold:
            lines.append(f"| cold ({label}, empty numba cache), wall / CPU | | "
                         f"{cold['wall']:.2f} / {cold['cpu']:.2f} |")
    return lines + [""]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--previous", default=None, help="a folder holding the previous version's escfit/ and fits/")
    ap.add_argument("--baseline", default=BASELINE, help="else this git revision, extracted with git archive")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--quickstart", action="store_true", help="also the quick start (emcee, with its report)")
    ap.add_argument("--trial", action="store_true", help="also the string pendulum's trial posterior (emcee, 9 "
                    "parameters, to R-hat <= 1.01)")
    ap.add_argument("--only", action="store_true", help="leave out the least squares")
    ap.add_argument("--cold", action="store_true", help="also one run each with an empty numba cache")
    ap.add_argument("--json", default=None, help="write the figures here")
    args = ap.parse_args(argv)
    previous = Path(args.previous).resolve() if args.previous else checkout(args.baseline)
    if not (previous / "fits").is_dir():
        ap.error(f"{previous} holds no fits/ folder: give --previous a checkout")
    load = os.getloadavg()
    record = {"previous": str(previous), "cpus": os.cpu_count(), "load_before": load, "jobs": {}}
    lines = []
    with tempfile.TemporaryDirectory(prefix="escfit-command-") as tmp:
        jobs = ([] if args.only else ["leastsq"]) + (["quickstart"] if args.quickstart else []) + (
            ["trial"] if args.trial else [])
        for job in jobs:
            record["jobs"][job] = measure(job, previous, args.repeat, Path(tmp), args.cold)
            lines += report(job, record["jobs"][job])
    record["load_after"] = os.getloadavg()
    head = [f"escfit fit, whole command: previous ({previous}) against this checkout, medians of {args.repeat} "
            f"interleaved runs; load average {load[0]:.1f} before, {record['load_after'][0]:.1f} after, "
            f"{os.cpu_count()} CPUs", ""]
    print("\n".join(head + lines))
    if args.json:
        Path(args.json).write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
