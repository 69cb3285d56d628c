"""Calibration of escfit's posteriors: do 90 % intervals cover the truth about 90 % of the time?

Synthetic Monday-like recordings (angle switching, released at 6.28 rad, 6-degree notch counts
every second cycle for 6.5 s, 0.03 rad reading jitter) are generated from
``datasets/scenes/monday_unit_angle_fit.toml`` with truths drawn around its values, fitted with
emcee, and the central 90 % intervals of C, R and X checked against the truth.

Run:  python benchmarks/calibration.py [--datasets 20] [--walkers 16] [--steps 2000] [--json]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import escfit
from escfit.inference import fit
from escfit.balance.synthetic.unit_curves import record_unit_curve

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "datasets" / "scenes" / "monday_unit_angle_fit.toml"
NAMES = ("viscous.C", "coulomb.R", "escapement[2].X")


def run(n: int = 20, walkers: int = 16, steps: int = 2000, seed: int = 0) -> dict:
    base = escfit.load_scene(SCENE)
    rng = np.random.default_rng(seed)
    hits = {n_: 0 for n_ in NAMES}
    rows = []
    t0 = time.perf_counter()
    for i in range(n):
        truth = {"viscous.C": rng.uniform(0.4, 0.9), "coulomb.R": rng.uniform(60, 160),
                 "escapement[2].X": rng.uniform(1200, 2000)}
        scene = base.with_values(truth)
        data = record_unit_curve(scene, every=4, duration=6.5, notch_deg=6, sigma=0.03, seed=1000 + i)
        # coverage needs the posterior draws only: no posterior-predictive draws (they cost 15 % of
        # each fit and leave the chain as it is)
        res = fit(base, data, method="emcee", walkers=walkers, steps=steps, seed=i, predictive_draws=1)
        post = res.group("posterior")
        row = {"dataset": i, "max_rhat": float(res.group("diagnostics")["rhat"].max())}
        for name in NAMES:
            lo, hi = np.quantile(post[name].values.ravel(), [0.05, 0.95])
            inside = bool(lo <= truth[name] <= hi)
            hits[name] += inside
            row[name] = {"truth": truth[name], "lo90": float(lo), "hi90": float(hi), "covered": inside}
        rows.append(row)
    coverage = {name: hits[name] / n for name in NAMES}
    return {"datasets": n, "walkers": walkers, "steps": steps, "coverage_90": coverage,
            "max_rhat": max(r["max_rhat"] for r in rows), "seconds": time.perf_counter() - t0, "rows": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--datasets", type=int, default=20)
    ap.add_argument("--walkers", type=int, default=16)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    out = run(a.datasets, a.walkers, a.steps)
    if a.json:
        print(json.dumps(out))
    else:
        print(f"{out['datasets']} datasets, {out['walkers']} walkers x {out['steps']} steps, {out['seconds']:.0f} s")
        for name, c in out["coverage_90"].items():
            print(f"  90% interval coverage of {name}: {c:.2f}")
        print(f"  largest split R-hat (any parameter, any data set): {out['max_rhat']:.3f}")


if __name__ == "__main__":
    main()
