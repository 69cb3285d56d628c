"""Posterior widths of C, R, X from the same recording read two ways (docs/recordings.md).

    python datasets/recordings/compare_widths.py [--steps 3000] [--out widths.json]

1. A photo-cell pulse train, fitted (a) as notch counts of the turning points (the
   amplitudes alone, as Monday read his charts) and (b) as passage times of every notch.
2. A timegrapher recording, fitted (a) from its amplitude readings alone and (b) with the
   beat times as well.

Each fit: lmfit least squares, then emcee (32 walkers); the widths are posterior standard
deviations and 95 % intervals after burn-in.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import escfit
from escfit.balance.problems.curves import FitProblem
from escfit.inference import least_squares, run_emcee
from escfit.balance.problems.pulses import PulseFitProblem
from escfit.balance.problems.timegrapher import TimegrapherFitProblem
from escfit.balance.synthetic.recorders import record_pulses, record_timegrapher
from escfit.analysis.recordings.pulses import pulses_to_unit_curve

HERE = Path(__file__).resolve().parent
NAMES = ("viscous.C", "coulomb.R", "escapement[2].X")


def _scene(path: Path, swings: int, replace: dict | None = None):
    text = path.read_text().replace("swings = 24", f"swings = {swings}").replace("swings = 64", f"swings = {swings}")
    text = text.replace("swings = 80", f"swings = {swings}")
    for a, b in (replace or {}).items():
        text = text.replace(a, b)
    return escfit.load_scene(f"{path.stem}_{swings}.toml", text=text)


def _run(problem, steps: int, seed: int) -> dict:
    t = time.time()
    lsq = least_squares(problem, n_starts=4, seed=seed)
    mc = run_emcee(problem, lsq, walkers=32, steps=steps, seed=seed)
    flat = mc.chain.reshape(-1, len(problem.names))
    out = {"seconds": round(time.time() - t, 1), "n_data": problem.n_data}
    for n in NAMES:
        col = flat[:, problem.names.index(n)]
        i = lsq.names.index(n)
        out[n] = {"mean": float(col.mean()), "sd": float(col.std()), "q025": float(np.quantile(col, 0.025)),
                  "q975": float(np.quantile(col, 0.975)), "lsq": float(lsq.value[i]), "lsq_se": float(lsq.stderr[i])}
    out["max_tau"] = float(np.nanmax(mc.tau))
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--out", default="widths.json")
    args = ap.parse_args()
    results = {}
    amp_text = (HERE.parent / "scenes" / "monday_unit_angle_fit.toml")
    for swings, sigma_t in ((24, 1e-4), (64, 1e-4), (64, 3e-4)):
        scene = _scene(HERE / "pulses_scene.toml", swings)
        train = record_pulses(scene, swings=swings, sigma_t=sigma_t, seed=1)
        key = f"pulses {swings} half swings, sigma_t {sigma_t:g} s"
        results[key] = {
            "amplitudes (notch counts)": _run(FitProblem(_scene(amp_text, swings), pulses_to_unit_curve(train)),
                                              args.steps, 1),
            "passage times": _run(PulseFitProblem(scene, train), args.steps, 1),
        }
        print(key, json.dumps(results[key], indent=1), flush=True)
    tg = HERE / "timegrapher_scene.toml"
    scene = _scene(tg, 80)
    rec = record_timegrapher(scene, fmt="json", seed=2)
    results["timegrapher 80 half swings, json"] = {
        "amplitudes alone": _run(TimegrapherFitProblem(_scene(tg, 80, {"sigma_t = 1e-4": "sigma_t = 1e-4\nbeats = false"}),
                                                       rec), args.steps, 1),
        "amplitudes and beats": _run(TimegrapherFitProblem(scene, rec), args.steps, 1),
    }
    Path(args.out).write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
