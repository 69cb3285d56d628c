"""Time the waveform log posterior of a 16-walker half-ensemble: this checkout against a previous version.

The problem (``--case``) is one of ``benchmarks/mcmc_worker.py``'s cases: ``waveform120`` (a
synthetic 120-swing free decay at 50 Hz, 2995 samples used, 8 free parameters, exact solver;
the default) or a real-data recipe of ``fits/real/`` by name, e.g. ``string_pendulum_trial1``
(a string pendulum released at 82 deg, 17 s tracked at ~30 Hz, AR(1) noise, solver dop853).
Sixteen parameter sets scattered about the truth (waveform120) or the recipe's starting values
(relative spread 1e-3, as a converged ensemble's proposals) are evaluated by ``problem.log_prob_many`` (what emcee calls per half-ensemble) and, for
reference, by ``problem.log_prob`` set by set.  Each version runs in a fresh process
(``benchmarks/previous.py``), alternating, ``--repeat`` times; printed: wall and CPU
microseconds per set (medians of the repeats, each the median of ``--calls`` calls) and the
ratio previous/this.

Run:  python benchmarks/waveform_batch.py [--baseline 18d2cf5] [--repeat 3] [--calls 40] [--sets 16] [--case waveform120]
      python benchmarks/waveform_batch.py --case string_pendulum_trial1 --baseline b1a8df2
      python benchmarks/waveform_batch.py --worker WORKDIR SETS CALLS CASE   (one measurement, JSON)
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))


def _measure(work: Path, n_sets: int, calls: int, case: str = "waveform120") -> dict:
    import numpy as np

    from mcmc_worker import _case
    from escfit.inference.registry import make_problem

    scene, data, *_ = _case(case, work)
    problem = make_problem(str(scene), str(data))
    truth = {"oscillator.omega0": 2 * np.pi, "viscous.C": 0.02, "coulomb.R": 0.01, "observation.sigma": 0.01} \
        if case == "waveform120" else {}
    centre = np.array([truth.get(n, v) for n, v in zip(problem.names, problem.initial)])
    rng = np.random.default_rng(0)
    vecs = centre + 1e-3 * rng.standard_normal((n_sets, centre.size)) * np.maximum(np.abs(centre), 1e-2)
    problem.log_prob_many(vecs)  # compiles (or loads) the kernels
    problem.log_prob(vecs[0])

    def timed(fn) -> tuple[float, float]:
        wall, cpu = [], []
        for _ in range(calls):
            t0, c0 = time.perf_counter(), time.process_time()
            fn()
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        return statistics.median(wall) / n_sets * 1e6, statistics.median(cpu) / n_sets * 1e6

    many = timed(lambda: problem.log_prob_many(vecs))
    rows = timed(lambda: [problem.log_prob(v) for v in vecs])
    lp_many = problem.log_prob_many(vecs)
    lp_rows = np.array([problem.log_prob(v) for v in vecs])
    return {"many_wall_us": many[0], "many_cpu_us": many[1], "rows_wall_us": rows[0], "rows_cpu_us": rows[1],
            "samples": int(problem.sample_time.size), "vectorized": bool(getattr(problem, "vectorized", False)),
            "solver": problem.solver,
            "max_rel_diff": float(np.max(np.abs(lp_many - lp_rows) / np.abs(lp_rows)))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default="18d2cf5")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--calls", type=int, default=40)
    ap.add_argument("--sets", type=int, default=16)
    ap.add_argument("--case", default="waveform120", help="waveform120 or a recipe of fits/real/ by name")
    ap.add_argument("--worker", nargs=4, metavar=("WORKDIR", "SETS", "CALLS", "CASE"))
    args = ap.parse_args()
    if args.worker:
        work, n_sets, calls, case = args.worker
        print(json.dumps(_measure(Path(work), int(n_sets), int(calls), case)))
        return
    from previous import checkout, run_in

    old = checkout(args.baseline)
    runs: dict[str, list[dict]] = {"previous": [], "this": []}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeat):
            for tag, folder in (("previous", old), ("this", None)):
                runs[tag].append(run_in(folder, Path(__file__), ["--worker", tmp, str(args.sets), str(args.calls),
                                                                            args.case]))
    med = {tag: {k: statistics.median(r[k] for r in rs) for k in rs[0] if k not in ("vectorized", "solver")}
           for tag, rs in runs.items()}
    print(f"{args.case} log posterior (solver {runs['this'][0]['solver']}), {args.sets} sets, "
          f"{med['this']['samples']:.0f} samples; medians of {args.repeat} runs x {args.calls} calls")
    for tag in ("previous", "this"):
        m = med[tag]
        print(f"  {tag:8s} ({args.baseline if tag == 'previous' else 'checkout'}): log_prob_many "
              f"{m['many_wall_us']:7.1f} us/set wall {m['many_cpu_us']:7.1f} us/set CPU; log_prob row by row "
              f"{m['rows_wall_us']:7.1f} / {m['rows_cpu_us']:7.1f}; vectorized={runs[tag][0]['vectorized']}; "
              f"max |many - rows|/|rows| {m['max_rel_diff']:.1e}")
    print(f"  log_prob_many previous/this: {med['previous']['many_wall_us'] / med['this']['many_wall_us']:.2f}x wall, "
          f"{med['previous']['many_cpu_us'] / med['this']['many_cpu_us']:.2f}x CPU")


if __name__ == "__main__":
    main()
