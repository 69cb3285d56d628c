"""Speed of the exact solver's compiled kernels, against their previous implementation.

Measures microseconds per half swing (CPU and wall clock, min and median over ``--repeat``
repetitions) of

- the single-set angle kernel :func:`escfit.balance.exact.run_angle` on the Monday-like unit
  (``datasets/scenes/monday_unit_angle_fit.toml``, 120 half swings);
- the single-set phase kernel :func:`escfit.balance.exact.run_phase` on Monday's unit 3
  (``datasets/monday1965/unit3_fit.toml``, 40 half swings);
- the batch kernel :func:`escfit.balance.exact.run_angle_many` on 2048 parameter sets
  (C, R and X spread +-30 % around the Monday-like unit's) x 120 half swings, on 1 and 2
  numba threads (per half swing per set);

and the same kernels of the previous implementation, ``escfit/balance/exact.py`` at git
revision ``--baseline`` (default ``2e7e582``), extracted with ``git show`` into a temporary
module and timed the same way in the same process.  The single-set angle case is also timed
with the compiled DOP853 peer (:func:`escfit.balance.dop853.run_dop853`, rtol 1e-10).
Kernels are called with prepared arrays; the single-set kernels from a compiled loop, so
neither Python-side set-up nor numba's dispatch (some microseconds a call) is counted.
The machine's load average is printed before and after: the figures mean little on a busy
machine.

Run:  python benchmarks/kernels.py [--repeat 3] [--json FILE] [--baseline REV]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import ModuleType
from typing import Callable

import numba
import numpy as np

import escfit
from escfit.balance import exact
from escfit.balance.batch import SystemStack
from escfit.balance.dop853 import kernel_inputs, run_dop853
from escfit.balance.solvers import kernel_args
from escfit.core.kernels import kernel

ROOT = Path(__file__).resolve().parents[1]
ANGLE_SCENE = ROOT / "datasets" / "scenes" / "monday_unit_angle_fit.toml"
PHASE_SCENE = ROOT / "datasets" / "monday1965" / "unit3_fit.toml"


def previous_exact(rev: str) -> ModuleType:
    """``escfit/balance/exact.py`` at git revision ``rev`` as an importable module.

    Its relative imports are made absolute (``escfit.``); the file is written to a directory
    named after the revision under the system's temporary directory, so numba's cache of its
    kernels is reused by later runs.
    """
    text = subprocess.run(["git", "show", f"{rev}:escfit/balance/exact.py"], cwd=ROOT, check=True,
                          capture_output=True, text=True).stdout
    text = text.replace("from ..core.", "from escfit.core.").replace("from .", "from escfit.balance.")
    folder = Path(tempfile.gettempdir()) / f"escfit-exact-{rev}"
    folder.mkdir(exist_ok=True)
    name = f"escfit_exact_{rev}"
    path = folder / f"{name}.py"
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def timed(calls: dict[str, Callable[[int], object]], work: int, repeat: int, min_time: float) -> dict:
    """Microseconds per unit of ``work`` of each ``calls[name](reps)`` (``reps`` runs).

    CPU (process) and wall time, min and median over ``repeat`` repetitions; the
    implementations are timed in turn within each repetition, so that they share the machine's
    load.  ``reps`` is set once so that a repetition takes about ``min_time`` seconds.
    """
    reps = {}
    for name, call in calls.items():
        call(1)  # compile or load, and warm the caches
        w0 = time.perf_counter()
        call(1)
        reps[name] = max(1, int(min_time / max(time.perf_counter() - w0, 1e-9)))
    cpu = {name: [] for name in calls}
    wall = {name: [] for name in calls}
    for _ in range(repeat):
        for name, call in calls.items():
            c0, w0 = time.process_time(), time.perf_counter()
            call(reps[name])
            c1, w1 = time.process_time(), time.perf_counter()
            cpu[name].append(1e6 * (c1 - c0) / (reps[name] * work))
            wall[name].append(1e6 * (w1 - w0) / (reps[name] * work))
    return {name: {"cpu_min": min(cpu[name]), "cpu_median": statistics.median(cpu[name]),
                   "wall_min": min(wall[name]), "wall_median": statistics.median(wall[name])} for name in calls}


def _outputs(*shape: int) -> tuple:
    return (np.empty(shape), np.empty(shape), np.empty(shape), np.empty(shape), np.zeros(shape, np.int8))


def in_kernel(func, args: tuple) -> Callable[[int], object]:
    """``reps`` calls of the compiled ``func(*args)`` from compiled code: no Python dispatch."""
    @kernel(cache=False)
    def loop(reps, args):
        total = 0
        for _ in range(reps):
            total += func(*args)[2]
        return total

    return lambda reps: loop(reps, args)


def angle_call(module: ModuleType, swings: int = 120) -> Callable[[int], object]:
    """Runs of ``module.run_angle`` on the Monday-like unit."""
    args = kernel_args(escfit.load_scene(ANGLE_SCENE).build())
    return in_kernel(module.run_angle, (*args, swings, 64 * swings + 1000, *_outputs(swings), np.zeros((0, 9))))


def phase_call(module: ModuleType, swings: int = 40) -> Callable[[int], object]:
    """Runs of ``module.run_phase`` on Monday's unit 3 (scene values)."""
    sys_ = escfit.load_scene(PHASE_SCENE).build()
    args = (float(sys_.theta0), float(sys_.c), float(sys_.r), sys_.omega0 ** 2, np.asarray(sys_.w_lo, float),
            np.asarray(sys_.w_hi, float), np.asarray(sys_.w_x, float), np.asarray(sys_.w_dir, np.int64),
            np.asarray(sys_.drift_thresholds, float), np.asarray(sys_.drift_rates, float))
    return in_kernel(module.run_phase, (*args, swings, *_outputs(swings), np.zeros((0, 9))))


def dop853_call(swings: int = 120, rtol: float = 1e-10) -> Callable[[int], object]:
    """Runs of the compiled DOP853 peer on the Monday-like unit."""
    args, _ = kernel_inputs(escfit.load_scene(ANGLE_SCENE).build(), "angle", swings, rtol=rtol)
    empty = np.zeros(0)
    return in_kernel(run_dop853, (*args, empty, empty, *_outputs(swings)))


def batch_stack(n_sets: int = 2048, seed: int = 0) -> SystemStack:
    """Parameter sets spread +-30 % around the Monday-like unit's C, R and X."""
    scene = escfit.load_scene(ANGLE_SCENE)
    rng = np.random.default_rng(seed)
    base = {n: scene.params[n].value for n in ("viscous.C", "coulomb.R", "escapement[2].X")}
    return SystemStack.from_systems([scene.build({k: v * rng.uniform(0.7, 1.3) for k, v in base.items()})
                                     for _ in range(n_sets)])


def batch_call(module: ModuleType, stack: SystemStack, threads: int, swings: int = 120) -> Callable[[int], object]:
    """Calls of ``module.run_angle_many`` on ``threads`` numba threads."""
    n = stack.size
    amp, turn, half, tm, banked = _outputs(n, swings)
    n_done, status, n_seg, final = np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n, np.int64), np.empty((n, 3))
    active = np.ones(n, np.bool_)

    def call(reps):
        previous = numba.get_num_threads()
        numba.set_num_threads(threads)
        try:
            for _ in range(reps):
                module.run_angle_many(stack.theta0, stack.c, stack.r, stack.sp_bp, stack.sp_w2, stack.sp_off,
                                      stack.w_lo, stack.w_hi, stack.w_x, stack.w_dir, stack.bank, stack.restitution,
                                      stack.drift_thresholds, stack.drift_rates, active, swings, 64 * swings + 1000,
                                      amp, turn, half, tm, banked, n_done, status, n_seg, final)
        finally:
            numba.set_num_threads(previous)

    return call


def run(repeat: int = 3, baseline: str = "2e7e582", min_time: float = 0.3, n_sets: int = 2048) -> dict:
    """All measurements, as a JSON-ready dictionary."""
    try:
        old = previous_exact(baseline)
    except (OSError, subprocess.CalledProcessError) as err:
        print(f"previous implementation unavailable ({err}); no ratios", file=sys.stderr)
        old = None
    stack = batch_stack(n_sets)
    cases = [("angle single, 120 swings", lambda m: angle_call(m), 120),
             ("phase single, 40 swings", lambda m: phase_call(m), 40)]
    for k in (1, 2):
        if k <= numba.config.NUMBA_NUM_THREADS:
            cases.append((f"angle batch {n_sets} x 120, {k} thread{'s' if k > 1 else ''}",
                          lambda m, k=k: batch_call(m, stack, k), n_sets * 120))
    records = []
    for name, make, work in cases:
        calls = {"new": make(exact)}
        if old is not None:
            calls["previous"] = make(old)
        if name.startswith("angle single"):
            calls["dop853 rtol 1e-10"] = dop853_call()
        rec = {"case": name, **timed(calls, work, repeat, min_time)}
        for other in ("previous", "dop853 rtol 1e-10"):
            if other in rec:
                rec[f"ratio {other}/new cpu_min"] = rec[other]["cpu_min"] / rec["new"]["cpu_min"]
                rec[f"ratio {other}/new wall_min"] = rec[other]["wall_min"] / rec["new"]["wall_min"]
        records.append(rec)
    return {"baseline": baseline, "repeat": repeat, "numba_threads": numba.config.NUMBA_NUM_THREADS,
            "records": records}


def table(result: dict) -> str:
    """The measurements as text: microseconds per half swing (per set for the batch)."""
    lines = [f"us per half swing (per set for the batch); min / median of {result['repeat']} repetitions; "
             f"previous = exact.py at {result['baseline']}",
             f"{'case':36s} {'implementation':18s} {'cpu min':>8s} {'cpu med':>8s} {'wall min':>8s} {'wall med':>8s}"]
    for rec in result["records"]:
        for impl in ("new", "previous", "dop853 rtol 1e-10"):
            if impl in rec:
                m = rec[impl]
                lines.append(f"{rec['case']:36s} {impl:18s} {m['cpu_min']:8.4f} {m['cpu_median']:8.4f} "
                             f"{m['wall_min']:8.4f} {m['wall_median']:8.4f}")
        for other in ("previous", "dop853 rtol 1e-10"):
            if f"ratio {other}/new cpu_min" in rec:
                lines.append(f"{'':36s} {other + '/new':18s} cpu {rec[f'ratio {other}/new cpu_min']:.2f}x, "
                             f"wall {rec[f'ratio {other}/new wall_min']:.2f}x")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3, help="repetitions per measurement (default 3)")
    parser.add_argument("--json", metavar="FILE", help="also write the measurements to FILE as JSON")
    parser.add_argument("--baseline", default="2e7e582", help="git revision of the previous exact.py")
    parser.add_argument("--min-time", type=float, default=0.3, help="seconds per repetition (default 0.3)")
    parser.add_argument("--sets", type=int, default=2048, help="parameter sets of the batch case (default 2048)")
    parser.add_argument("--force", action="store_true", help="replace existing output files")
    args = parser.parse_args(argv)
    for out in (args.json,):  # refused before the run, not after it
        if out and Path(out).exists() and not args.force:
            parser.error(f"{out} exists; pass --force to replace it")
    if args.repeat < 1 or not math.isfinite(args.min_time) or args.min_time <= 0:
        parser.error("--repeat must be >= 1 and --min-time > 0")
    before = os.getloadavg()
    print(f"load average before: {before[0]:.2f} {before[1]:.2f} {before[2]:.2f} ({os.cpu_count()} cpus)")
    result = run(args.repeat, args.baseline, args.min_time, args.sets)
    after = os.getloadavg()
    result["load_average_before"], result["load_average_after"] = before, after
    print(table(result))
    print(f"load average after: {after[0]:.2f} {after[1]:.2f} {after[2]:.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
