"""Speed of the balance solvers' compiled kernels, against the previous version, in one run.

Measures microseconds per half swing (CPU and wall clock, min and median over ``--repeat``
repetitions) of

- the exact solver's single-set angle kernel on the Monday-like unit
  (``datasets/scenes/monday_unit_angle_fit.toml``, 120 half swings);
- its single-set phase kernel on Monday's unit 3 (``datasets/monday1965/unit3_fit.toml``, 40);
- its batch kernel on 2048 parameter sets (C, R and X spread +-30 % around the Monday-like
  unit's) x 120 half swings, on 1 and 2 numba threads (per half swing per set);
- the compiled DOP853 kernel on the Monday-like unit (rtol 1e-10);
- the whole Python call ``solve(scene, "exact")`` on the Monday-like unit (scene values to
  trajectory: building the coefficients, the checks, the kernel and the result).

Kernels are called with prepared inputs from a compiled loop, so neither Python-side set-up
nor numba's dispatch is counted, except in the last case.  The previous version (git revision
``--baseline``, default ``main``; see ``benchmarks/previous.py``) and this checkout each run
in a subprocess, alternately within each repetition so that they share the machine's load;
each builds its inputs with its own interface (positional arrays before, coefficient records
now).  The machine's load average is printed before and after: the figures mean little on a
busy machine.

Run:  python benchmarks/kernels.py [--repeat 3] [--json FILE] [--baseline main]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Callable

HERE = Path(__file__).resolve()
sys.path.insert(0, str(HERE.parent))

ANGLE_SCENE = "datasets/scenes/monday_unit_angle_fit.toml"
PHASE_SCENE = "datasets/monday1965/unit3_fit.toml"
CASES = ("angle single, 120 swings", "phase single, 40 swings", "angle batch 2048 x 120, 1 thread",
         "angle batch 2048 x 120, 2 threads", "dop853 single, 120 swings, rtol 1e-10",
         "solve() call, 120 swings")


# -- the worker: runs in a subprocess with one version of escfit on its path ------------------

def _in_kernel(func, args: tuple) -> Callable[[int], object]:
    """``reps`` calls of the compiled ``func(*args)`` from compiled code: no Python dispatch."""
    from escfit.core.kernels import kernel

    @kernel(cache=False)
    def loop(reps, args):
        total = 0
        for _ in range(reps):
            total += func(*args)[2]
        return total

    return lambda reps: loop(reps, args)


def _outputs(*shape):
    import numpy as np

    return (np.empty(shape), np.empty(shape), np.empty(shape), np.empty(shape), np.zeros(shape, np.int8))


def _calls_previous(root: Path, n_sets: int) -> dict:
    """Each case's ``call(reps)`` with the previous interface (positional arrays)."""
    import numpy as np
    import numba

    import escfit
    from escfit.balance import exact, solve
    from escfit.balance.batch import SystemStack
    from escfit.balance.dop853 import kernel_inputs, run_dop853
    from escfit.balance.solvers import kernel_args

    scene = escfit.load_scene(root / ANGLE_SCENE)
    sys_ = scene.build()
    args = kernel_args(sys_)
    ph = escfit.load_scene(root / PHASE_SCENE).build()
    ph_args = (float(ph.theta0), float(ph.c), float(ph.r), ph.omega0 ** 2, np.asarray(ph.w_lo, float),
               np.asarray(ph.w_hi, float), np.asarray(ph.w_x, float), np.asarray(ph.w_dir, np.int64),
               np.asarray(ph.drift_thresholds, float), np.asarray(ph.drift_rates, float))
    d_args, _ = kernel_inputs(sys_, "angle", 120, rtol=1e-10)
    stack = SystemStack.from_systems(_spread(scene, n_sets))
    n = stack.size
    b_out = _outputs(n, 120)
    b_rest = (np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n, np.int64), np.empty((n, 3)))
    active = np.ones(n, np.bool_)

    def batch(threads):
        def call(reps):
            previous = numba.get_num_threads()
            numba.set_num_threads(threads)
            try:
                for _ in range(reps):
                    exact.run_angle_many(stack.theta0, stack.c, stack.r, stack.sp_bp, stack.sp_w2, stack.sp_off,
                                         stack.w_lo, stack.w_hi, stack.w_x, stack.w_dir, stack.bank,
                                         stack.restitution, stack.drift_thresholds, stack.drift_rates, active, 120,
                                         64 * 120 + 1000, *b_out, *b_rest)
            finally:
                numba.set_num_threads(previous)
        return call

    return {
        CASES[0]: _in_kernel(exact.run_angle, (*args, 120, 64 * 120 + 1000, *_outputs(120), np.zeros((0, 9)))),
        CASES[1]: _in_kernel(exact.run_phase, (*ph_args, 40, *_outputs(40), np.zeros((0, 9)))),
        CASES[2]: batch(1), CASES[3]: batch(2),
        CASES[4]: _in_kernel(run_dop853, (*d_args, np.zeros(0), np.zeros(0), *_outputs(120))),
        CASES[5]: lambda reps: [solve(scene, "exact") for _ in range(reps)],
    }


def _calls_current(root: Path, n_sets: int) -> dict:
    """Each case's ``call(reps)`` with the coefficient records."""
    import numpy as np
    import numba

    import escfit
    from escfit.balance import System, dop853, exact, solve
    from escfit.balance.batch import SUMMARY
    from escfit.balance.kernel_records import half_swings, run_options

    scene = escfit.load_scene(root / ANGLE_SCENE)
    k = scene.build().k
    ph = escfit.load_scene(root / PHASE_SCENE).build().k
    stack = System.stack(_spread(scene, n_sets))
    n = len(stack)
    b_out, summary, active = half_swings(n, 120), np.zeros(n, SUMMARY), np.ones(n, np.bool_)
    run = run_options(120, max_segments=64 * 120 + 1000)

    def batch(threads):
        def call(reps):
            previous = numba.get_num_threads()
            numba.set_num_threads(threads)
            try:
                for _ in range(reps):
                    exact.run_angle_many(stack.k, run, active, b_out, summary)
            finally:
                numba.set_num_threads(previous)
        return call

    d_run = run_options(120, max_segments=64 * 120 + 1000, max_steps=10_000 * 120 + 100_000, rtol=1e-10,
                        atol_x=1e-12 * abs(float(k["theta0"][0])), atol_v=1e-12 * abs(float(k["theta0"][0])) *
                        math.sqrt(float(k["sp_w2"][0, 0])))
    return {
        CASES[0]: _in_kernel(exact.run_one, (k, run, half_swings(120), np.zeros((0, 9)))),
        CASES[1]: _in_kernel(exact.run_phase_one, (ph, run_options(40), half_swings(40), np.zeros((0, 9)))),
        CASES[2]: batch(1), CASES[3]: batch(2),
        CASES[4]: _in_kernel(dop853.run_one, (k, d_run, half_swings(120), np.zeros((0, 9)))),
        CASES[5]: lambda reps: [solve(scene, "exact") for _ in range(reps)],
    }


def _spread(scene, n_sets: int, seed: int = 0) -> list:
    """Parameter sets spread +-30 % around the Monday-like unit's C, R and X."""
    import numpy as np

    rng = np.random.default_rng(seed)
    base = {name: scene.params[name].value for name in ("viscous.C", "coulomb.R", "escapement[2].X")}
    return [scene.build({key: v * rng.uniform(0.7, 1.3) for key, v in base.items()}) for _ in range(n_sets)]


def worker(min_time: float, n_sets: int, only: str = "") -> dict:
    """One repetition of every case (whose name holds ``only``): microseconds per unit of work."""
    import escfit.balance.solvers as solvers

    root = Path(os.getcwd())
    previous = hasattr(solvers, "kernel_args")
    calls = (_calls_previous if previous else _calls_current)(root, n_sets)
    work = {CASES[0]: 120, CASES[1]: 40, CASES[2]: n_sets * 120, CASES[3]: n_sets * 120, CASES[4]: 120,
            CASES[5]: 120}
    out = {}
    for name, call in calls.items():
        if only not in name:
            continue
        call(1)  # compile or load, and warm the caches
        w0 = time.perf_counter()
        call(1)
        reps = max(1, int(min_time / max(time.perf_counter() - w0, 1e-9)))
        c0, w0 = time.process_time(), time.perf_counter()
        call(reps)
        c1, w1 = time.process_time(), time.perf_counter()
        out[name] = {"cpu": 1e6 * (c1 - c0) / (reps * work[name]), "wall": 1e6 * (w1 - w0) / (reps * work[name])}
    return out


# -- the driver --------------------------------------------------------------------------------

def run(repeat: int, baseline: str, min_time: float, n_sets: int, only: str = "") -> dict:
    """All measurements, as a JSON-ready dictionary."""
    from previous import checkout, run_in

    folders = {"previous": checkout(baseline), "new": None}
    cases = [case for case in CASES if only in case]
    samples = {impl: {case: {"cpu": [], "wall": []} for case in cases} for impl in folders}
    args = ["--worker", "--min-time", str(min_time), "--sets", str(n_sets), "--only", only]
    for _ in range(repeat):
        for impl, folder in folders.items():
            res = run_in(folder, HERE, args)
            for case, m in res.items():
                for clock in ("cpu", "wall"):
                    samples[impl][case][clock].append(m[clock])
    records = []
    for case in cases:
        rec = {"case": case}
        for impl in folders:
            s = samples[impl][case]
            rec[impl] = {"cpu_min": min(s["cpu"]), "cpu_median": statistics.median(s["cpu"]),
                         "wall_min": min(s["wall"]), "wall_median": statistics.median(s["wall"])}
        rec["ratio previous/new cpu_min"] = rec["previous"]["cpu_min"] / rec["new"]["cpu_min"]
        rec["ratio previous/new wall_min"] = rec["previous"]["wall_min"] / rec["new"]["wall_min"]
        records.append(rec)
    return {"baseline": baseline, "repeat": repeat, "records": records}


def table(result: dict) -> str:
    """The measurements as text: microseconds per half swing (per set for the batch)."""
    lines = [f"us per half swing (per set for the batch); min / median of {result['repeat']} repetitions; "
             f"previous = {result['baseline']}",
             f"{'case':40s} {'version':9s} {'cpu min':>8s} {'cpu med':>8s} {'wall min':>8s} {'wall med':>8s}"]
    for rec in result["records"]:
        for impl in ("previous", "new"):
            m = rec[impl]
            lines.append(f"{rec['case']:40s} {impl:9s} {m['cpu_min']:8.4f} {m['cpu_median']:8.4f} "
                         f"{m['wall_min']:8.4f} {m['wall_median']:8.4f}")
        lines.append(f"{'':40s} {'prev/new':9s} cpu {rec['ratio previous/new cpu_min']:.2f}x, "
                     f"wall {rec['ratio previous/new wall_min']:.2f}x")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3, help="repetitions per measurement (default 3)")
    parser.add_argument("--json", metavar="FILE", help="also write the measurements to FILE as JSON")
    parser.add_argument("--baseline", default="main", help="git revision of the previous version (default main)")
    parser.add_argument("--min-time", type=float, default=0.3, help="seconds per case and repetition (default 0.3)")
    parser.add_argument("--sets", type=int, default=2048, help="parameter sets of the batch cases (default 2048)")
    parser.add_argument("--force", action="store_true", help="replace existing output files")
    parser.add_argument("--only", default="", help="run only the cases whose name contains this text")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        print(json.dumps(worker(args.min_time, args.sets, args.only)))
        return 0
    if args.json and Path(args.json).exists() and not args.force:  # refused before the run, not after it
        parser.error(f"{args.json} exists; pass --force to replace it")
    if args.repeat < 1 or not math.isfinite(args.min_time) or args.min_time <= 0:
        parser.error("--repeat must be >= 1 and --min-time > 0")
    before = os.getloadavg()
    print(f"load average before: {before[0]:.2f} {before[1]:.2f} {before[2]:.2f} ({os.cpu_count()} cpus)")
    result = run(args.repeat, args.baseline, args.min_time, args.sets, args.only)
    after = os.getloadavg()
    result["load_average_before"], result["load_average_after"] = before, after
    print(table(result))
    print(f"load average after: {after[0]:.2f} {after[1]:.2f} {after[2]:.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
