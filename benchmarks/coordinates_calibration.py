"""Spread of the closed-form z-scores of ``tests/test_sampler_coordinates.py`` over many seeds.

The test samples a target with closed-form marginals (a lognormal scale, a uniform correlation,
a normal location) in the AR(1) sampler coordinates and requires seven summaries within a
limit of Monte Carlo standard errors of the closed forms.  This script reruns that sampling for
seeds ``--first`` .. ``--last - 1`` and prints, per summary, the mean, sd and largest |z| (the
figures the test's limit is justified by).

Run:  python benchmarks/coordinates_calibration.py [--first 0] [--last 300]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> dict:
    from escfit.inference.mcmc import run_emcee
    from tests.test_sampler_coordinates import ScaleCorrelation, closed_form_z

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--last", type=int, default=300)
    args = ap.parse_args(argv)
    rows, steps, converged = [], [], 0
    for seed in range(args.first, args.last):
        res = run_emcee(ScaleCorrelation(), walkers=16, steps="auto", seed=seed, moves="de-t", max_steps=20000)
        rows.append(closed_form_z(res.chain))
        steps.append(res.steps)
        converged += bool(res.converged)
    print(f"{len(rows)} seeds, {converged} converged, median {np.median(steps):.0f} steps")
    out = {}
    for key in rows[0]:
        z = np.array([r[key] for r in rows])
        out[key] = {"mean": float(z.mean()), "sd": float(z.std(ddof=1)), "max_abs": float(np.abs(z).max())}
        print(f"  {key:16s} mean {z.mean():+.2f}  sd {z.std(ddof=1):.2f}  largest |z| {np.abs(z).max():.2f}")
    return out


if __name__ == "__main__":
    main()
