"""Time a 4-parameter unit-curve posterior: C, R, X and the reading jitter of notch counts.

The Monday-like scene (``datasets/scenes/monday_unit_angle_fit.toml``) is recorded every
second cycle over 120 half swings (6-degree notches, 0.03 rad jitter, seed 11) and sampled
with emcee, by default 32 walkers x 5000 steps, through the vectorised log posterior (one
parallel batch of the exact solver per half-ensemble).  The clock starts before escfit is
imported, so the time includes imports and numba compilation; ``--cold`` compiles into an
empty numba cache (the script re-runs itself with ``NUMBA_CACHE_DIR`` set to a new
temporary directory), so nothing compiled earlier is reused.

``--compare REV`` times the same run (warm cache, fresh interpreter each time) for this
checkout and for the package as it was at git revision REV (extracted with ``git archive``
into a temporary directory and put first on ``PYTHONPATH``), ``--repeat`` times each,
alternating, and prints min/median of each and the ratio old/new of the medians.

Run:  python benchmarks/posterior_speed.py [--walkers 32] [--steps 5000] [--cold] [--json]
      python benchmarks/posterior_speed.py --compare 2e7e582 [--repeat 3]
"""

from __future__ import annotations

import time

T_START = time.perf_counter()

import argparse  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "datasets" / "scenes" / "monday_unit_angle_fit.toml"
SWINGS = 120


def run(walkers: int = 32, steps: int = 5000, vectorize: bool | None = None, seed: int = 0) -> dict:
    import numpy as np

    import escfit
    from escfit.balance.problems.curves import FitProblem
    from escfit.inference import run_emcee
    from escfit.balance.synthetic.unit_curves import record_unit_curve

    scene = escfit.load_scene(SCENE)
    data = record_unit_curve(scene, every=4, swings=SWINGS, notch_deg=6, sigma=0.03, seed=11)
    problem = FitProblem(scene, data)
    t_ready = time.perf_counter()
    problem.log_prob_many(np.array([problem.initial] * 2))  # compiles (or loads) the batch kernel
    problem.log_prob(problem.initial)  # and the one-set kernel the start ball uses
    t_compiled = time.perf_counter()
    mc = run_emcee(problem, None, walkers=walkers, steps=steps, seed=seed, vectorize=vectorize)
    t_end = time.perf_counter()
    flat = mc.chain.reshape(-1, len(problem.names))
    return {
        "walkers": walkers, "steps": steps, "swings": SWINGS, "parameters": problem.names,
        "vectorized": bool(problem.vectorized if vectorize is None else vectorize),
        "readings": int(data.swing.size),
        "seconds_imports_and_setup": t_ready - T_START,
        "seconds_compile": t_compiled - t_ready,
        "seconds_sampling": t_end - t_compiled,
        "seconds_total": t_end - T_START,
        "us_per_swing": 1e6 * (t_end - t_compiled) / (walkers * steps * SWINGS),
        "median": dict(zip(problem.names, map(float, np.median(flat, axis=0)))),
        "acceptance": float(np.mean(mc.acceptance)),
        "numba_cache_dir": os.environ.get("NUMBA_CACHE_DIR", ""),
        "load_average": os.getloadavg()[0],
    }


def run_cold(walkers: int, steps: int) -> dict:
    """Run in a fresh interpreter with an empty numba cache; the wall time includes its start."""
    with tempfile.TemporaryDirectory(prefix="escfit-numba-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, __file__, "--walkers", str(walkers), "--steps", str(steps), "--json"],
                             env=env, capture_output=True, text=True, check=True)
        wall = time.perf_counter() - t0
    result = json.loads(out.stdout)
    result["seconds_process_wall"] = wall
    result["cold_cache"] = True
    return result


def run_in(root: Path, walkers: int, steps: int, cache: str) -> dict:
    """One warm run in a fresh interpreter importing escfit from ``root``."""
    env = dict(os.environ, PYTHONPATH=str(root), NUMBA_CACHE_DIR=cache)
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, __file__, "--walkers", str(walkers), "--steps", str(steps), "--json"],
                         env=env, capture_output=True, text=True, check=True)
    result = json.loads(out.stdout)
    result["seconds_process_wall"] = time.perf_counter() - t0
    return result


def compare(rev: str, walkers: int, steps: int, repeat: int) -> dict:
    """This checkout against revision ``rev``, each run ``repeat`` times (alternating), warm caches."""
    import statistics

    with tempfile.TemporaryDirectory(prefix="escfit-compare-") as tmp:
        base = Path(tmp) / "baseline"
        base.mkdir()
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "escfit"], check=True,
                                 capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(base)], input=archive, check=True)
        roots = {"baseline": base, "current": ROOT}
        caches = {k: str(Path(tmp) / f"cache-{k}") for k in roots}
        for k in roots:  # fill each cache once (compilation is not what is compared)
            run_in(roots[k], walkers, 20, caches[k])
        runs = {k: [] for k in roots}
        for _ in range(repeat):
            for k in roots:
                runs[k].append(run_in(roots[k], walkers, steps, caches[k]))
    print(f"posterior benchmark, {walkers} walkers x {steps} steps, warm cache; baseline {rev}; load average "
          f"{os.getloadavg()[0]:.2f}")
    summary = {"baseline": rev, "walkers": walkers, "steps": steps, "runs": runs}
    for key in ("seconds_sampling", "seconds_process_wall"):
        med = {k: statistics.median(r[key] for r in runs[k]) for k in runs}
        lows = {k: min(r[key] for r in runs[k]) for k in runs}
        print(f"{key:24s} baseline {lows['baseline']:.2f} / {med['baseline']:.2f}   current {lows['current']:.2f} / "
              f"{med['current']:.2f}   (min / median)   ratio {med['baseline'] / med['current']:.2f}x")
        summary[f"ratio_{key}"] = med["baseline"] / med["current"]
    return summary


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walkers", type=int, default=32)
    ap.add_argument("--steps", type=int, default=5000)
    ap.add_argument("--cold", action="store_true", help="empty numba cache, fresh interpreter")
    ap.add_argument("--per-walker", action="store_true", help="emcee without vectorize (for comparison)")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--compare", metavar="REV", default=None, help="also time the package at git revision REV")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    if args.compare:
        compare(args.compare, args.walkers, args.steps, args.repeat)
        return 0
    if args.cold:
        result = run_cold(args.walkers, args.steps)
    else:
        result = run(args.walkers, args.steps, vectorize=False if args.per_walker else None)
    if args.json:
        print(json.dumps(result))
    else:
        for k, v in result.items():
            print(f"{k:28s} {v}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
