"""Random balance scenes through every solver: no NaN, no hang, no foreign exception, one answer.

Scenes come from :func:`escfit.balance.synthetic.random_scenes.random_scene` drawing every
registered effect (:data:`~escfit.balance.synthetic.random_scenes.ALL_EFFECTS`: viscous damping
with a quarter near critical, Coulomb and static friction, escapement windows, piecewise
hairsprings, banking, damping drift, cubic stiffening and quadratic drag; angle scales 1e-6 to
3 rad, frequencies 0.05 to 2e4 rad/s); the script stops at once if a registered effect has no
generator.  Each scene is solved by the exact solver and by dop853 at ``rtol = 1e-12``, every
``--rk4-every``-th also by rk4 with events located and 4000 steps per period of the stiffest
spring piece, and every ``--ivp-every``-th by the scipy adapter (DOP853, rtol 1e-12, atol 1e-14
of the release angle).  A solver that does not handle a scene (exact: drag, stiffening; the
integrators: damping drift) refuses it, counted apart.  Counted per solver: scenes, refusals
(escfit's own errors, with their reasons), any other exception (a bug), NaN or infinite numbers,
the slowest solve.  Compared per pair of solvers: the status, and, where both end with the same
status, the turning-point angles over the swings both computed (their largest difference in rad
and relative to the release angle).

Usage (from the repository root)::

    python benchmarks/random_scenes.py [--scenes 10000] [--rk4-every 10] [--ivp-every 10] [--seed 0]
                                       [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from escfit import load_scene  # noqa: E402
from escfit.balance import solve  # noqa: E402
from escfit.balance.effects import EFFECTS as REGISTERED  # noqa: E402
from escfit.balance.synthetic.random_scenes import ALL_EFFECTS, random_scene  # noqa: E402
from escfit.core.errors import EscfitError  # noqa: E402

DOP853 = {"rtol": 1e-12}
SOLVERS = ("exact", "dop853", "rk4", "ivp")
RK4_STEPS_PER_PERIOD = 4000


def rk4_options(scene) -> dict:
    sys_ = scene.build()
    w2 = sys_.field("sp_w2")
    period = 2.0 * math.pi / math.sqrt(float(np.max(w2)))
    return {"h": period / RK4_STEPS_PER_PERIOD, "locate_events": True, "max_steps": 50_000_000}


def run_solver(scene, name: str) -> dict:
    """One solve, timed; its outcome as a record (never raises)."""
    if name == "ivp":
        options = {"rtol": 1e-12, "atol": 1e-14 * abs(scene.build().theta0)}
    else:
        options = DOP853 if name == "dop853" else rk4_options(scene) if name == "rk4" else {}
    t0 = time.perf_counter()
    try:
        tr = solve(scene, name, **options)
    except EscfitError as exc:
        return {"outcome": "refused", "reason": type(exc).__name__ + ": " + exc.message[:80],
                "seconds": time.perf_counter() - t0}
    except Exception as exc:  # noqa: BLE001 - what the benchmark looks for
        return {"outcome": "exception", "reason": f"{type(exc).__name__}: {exc}"[:160],
                "seconds": time.perf_counter() - t0}
    seconds = time.perf_counter() - t0
    arrays = (tr.amplitude, tr.theta_turn, tr.half_period, tr.time)
    finite = all(np.all(np.isfinite(a)) for a in arrays)
    return {"outcome": "solved" if finite else "nan", "status": tr.status, "theta": np.asarray(tr.theta_turn),
            "seconds": seconds}


def compare(a: dict, b: dict, a0: float) -> dict:
    """Status agreement and, with one status, the largest turning-point difference."""
    if a["outcome"] != "solved" or b["outcome"] != "solved":
        return {"kind": "not both solved"}
    if a["status"] != b["status"] or a["theta"].size != b["theta"].size:
        return {"kind": "status", "statuses": (a["status"], b["status"]), "swings": (a["theta"].size, b["theta"].size)}
    if a["theta"].size == 0:
        return {"kind": "same", "abs": 0.0, "rel": 0.0}
    d = float(np.max(np.abs(a["theta"] - b["theta"])))
    return {"kind": "same", "abs": d, "rel": d / a0}


def _run_scenes(args, rng, solved, reasons, slowest, pairs, status_cases, effects_seen, near_critical, t_start):
    """Draw, solve and compare ``args.scenes`` scenes, counting into the tables given."""
    for i in range(args.scenes):
        near_critical["done"] = i
        if i and i % 500 == 0:
            print(f"  ... {i} scenes in {time.perf_counter() - t_start:.0f} s", flush=True)
        text, names = random_scene(rng, effects=ALL_EFFECTS)
        effects_seen.update(names)
        try:
            scene = load_scene(f"random{i}.toml", text=text)
        except EscfitError as exc:
            reasons["exact"]["scene refused: " + exc.message[:60]] += 1
            continue
        sys_ = scene.build()
        a0 = abs(sys_.theta0)
        c = float(sys_.field("c"))
        critical = c > 0 and abs(c / (2.0 * sys_.omega0) - 1.0) <= 1e-3
        near_critical["scenes"] += critical
        runs = {"exact": run_solver(scene, "exact"), "dop853": run_solver(scene, "dop853")}
        if args.rk4_every > 0 and i % args.rk4_every == 0:
            runs["rk4"] = run_solver(scene, "rk4")
        if args.ivp_every > 0 and i % args.ivp_every == 0:
            runs["ivp"] = run_solver(scene, "ivp")
        for name, r in runs.items():
            solved[name][r["outcome"]] += 1
            slowest[name] = max(slowest[name], r["seconds"])
            if r["outcome"] != "solved":
                reasons[name][r["reason"] if "reason" in r else "NaN in the results"] += 1
        for (p, q), rows in pairs.items():
            if p in runs and q in runs:
                cmp = compare(runs[p], runs[q], a0)
                rows.append(cmp)
                if cmp["kind"] == "status":
                    near_critical[f"status disagreements {p}/{q}"] += critical
                    if len(status_cases) < 20:
                        status_cases.append({"scene": i, "pair": f"{p}/{q}", "near_critical": critical, **cmp,
                                             "C/2w0": c / (2.0 * sys_.omega0), "text": text})
    near_critical["done"] = args.scenes


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=10_000)
    ap.add_argument("--rk4-every", type=int, default=10)
    ap.add_argument("--ivp-every", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=None, help="write the figures as JSON here")
    args = ap.parse_args(argv)
    missing = sorted(set(REGISTERED) - set(ALL_EFFECTS))
    if missing:
        raise SystemExit(f"random_scenes: no generator for the registered effects {missing}")
    rng = np.random.default_rng(args.seed)
    solved: dict[str, Counter] = {s: Counter() for s in SOLVERS}
    reasons: dict[str, Counter] = {s: Counter() for s in solved}
    slowest = {s: 0.0 for s in solved}
    pairs = {(p, q): [] for i, p in enumerate(SOLVERS) for q in SOLVERS[i + 1:]}
    status_cases: list[dict] = []
    effects_seen: Counter = Counter()
    near_critical = Counter()
    t_start = time.perf_counter()
    try:
        _run_scenes(args, rng, solved, reasons, slowest, pairs, status_cases, effects_seen, near_critical, t_start)
    except KeyboardInterrupt:  # Ctrl-C: the figures of the scenes done so far
        print(f"  interrupted after {near_critical['done']} scenes")
        args.scenes = near_critical["done"]
    del near_critical["done"]
    elapsed = time.perf_counter() - t_start
    figures = {"scenes": args.scenes, "seed": args.seed, "seconds": round(elapsed, 1), "effects": dict(effects_seen),
               "near_critical": dict(near_critical), "solvers": {}, "pairs": {}, "status_cases": status_cases}
    print(f"{args.scenes} random scenes (seed {args.seed}) in {elapsed:.0f} s; effects drawn: {dict(effects_seen)}")
    for name in solved:
        n = sum(solved[name].values())
        figures["solvers"][name] = {"runs": n, **dict(solved[name]), "slowest_s": round(slowest[name], 4),
                                    "reasons": dict(reasons[name].most_common(8))}
        print(f"  {name:7s}: {n:6d} runs: {dict(solved[name])}; slowest {slowest[name]:.3f} s; "
              f"not solved: {dict(reasons[name].most_common(4)) or 'none'}")
    worst = (0.0, "")
    for (p, q), rows in pairs.items():
        same = [r for r in rows if r["kind"] == "same"]
        status = [r for r in rows if r["kind"] == "status"]
        worst_abs = max((r["abs"] for r in same), default=0.0)
        worst_rel = max((r["rel"] for r in same), default=0.0)
        over = sum(r["abs"] > 1e-9 for r in same)
        figures["pairs"][f"{p}/{q}"] = {"compared": len(rows), "same_status": len(same), "status_disagreements":
                                        len(status), "worst_abs_rad": worst_abs, "worst_rel": worst_rel,
                                        "above_1e-9_rad": over}
        worst = max(worst, (worst_rel, f"{p}/{q}"))
        print(f"  {p} vs {q}: {len(rows)} scenes, {len(same)} with one status, {len(status)} status disagreements; "
              f"worst turning-point difference {worst_abs:.3g} rad ({worst_rel:.3g} of the release angle); "
              f"{over} above 1e-9 rad")
    figures["worst_rel"] = {"pair": worst[1], "rel": worst[0]}
    print(f"  worst disagreement of any pair: {worst[0]:.3g} of the release angle ({worst[1] or 'none'})")
    print(f"  near critical damping (|C/2w0 - 1| <= 1e-3): {dict(near_critical)}")
    for case in status_cases[:5]:
        print(f"  status case: scene {case['scene']} {case['pair']}: {case['statuses']} after {case['swings']} swings, "
              f"C/2w0 = {case['C/2w0']:.15g}")
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=1, default=str))
    return figures


if __name__ == "__main__":
    main()
