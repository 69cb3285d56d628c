"""What a sloppy forward model costs inside a fit: bias of C, R, X against the posterior width.

The same synthetic recordings of the Monday-like unit (``datasets/scenes/monday_unit_angle_fit.toml``,
truth C = 0.6 1/s, R = 100 rad/s^2, X = 1500 rad/s^2, 120 half swings) are fitted with the
exact solver (least squares, then emcee for the posterior width) and with cheaper or cruder
forward models.  Each of those is fitted by minimising its chi-square with Nelder-Mead in
units of the exact posterior's standard deviations, started from the exact optimum: the
cheap models' chi-squares are not smooth in the parameters (a fixed-step integrator that
steps over switches, an adaptive one whose step sequence changes with them), so
finite-difference least squares stalls on them.  The shift of the optimum in standard
deviations is the bias a user buys with that forward model; the ratio of the minimum
chi-squares says how much of the forward error the parameters could not absorb and that
ends up as apparent reading noise instead.  The forward model's own error is the largest amplitude error over the 120
half swings at the truth.  Two recordings:

- ``notches``: Monday-like, 6-degree notch counts every second cycle, 0.03 rad jitter;
- ``precise``: continuous amplitudes of every half swing with 0.005 rad noise.

Run:  python benchmarks/fit_accuracy.py [--quick] [--json] [--markdown]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import escfit
from escfit.balance import solve
from escfit.balance.problems.curves import FitProblem
from escfit.inference import least_squares, run_emcee
from escfit.balance.synthetic.unit_curves import record_unit_curve

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "datasets" / "scenes" / "monday_unit_angle_fit.toml"
SWINGS = 120
NAMES = ("viscous.C", "coulomb.R", "escapement[2].X")
SHORT = {"viscous.C": "C", "coulomb.R": "R", "escapement[2].X": "X", "chi2": "chi2"}

MODELS = [  # (label, solver, options)
    ("exact", "exact", {}),
    ("rk4 naive h=1e-3", "rk4", {"h": 1e-3, "locate_events": False}),
    ("rk4 naive h=1e-4", "rk4", {"h": 1e-4, "locate_events": False}),
    ("rk4 naive h=1e-5", "rk4", {"h": 1e-5, "locate_events": False}),
    ("rk4 h=1e-2", "rk4", {"h": 1e-2}),
    ("rk4 h=1e-3", "rk4", {"h": 1e-3}),
    ("ivp RK45 rtol=1e-3", "ivp", {"method": "RK45", "rtol": 1e-3, "atol": 1e-6}),
    ("ivp RK45 rtol=1e-6", "ivp", {"method": "RK45", "rtol": 1e-6, "atol": 1e-9}),
    ("ivp DOP853 rtol=1e-3", "ivp", {"method": "DOP853", "rtol": 1e-3, "atol": 1e-6}),
    ("ivp DOP853 rtol=1e-4", "ivp", {"method": "DOP853", "rtol": 1e-4, "atol": 1e-7}),
    ("ivp DOP853 rtol=1e-5", "ivp", {"method": "DOP853", "rtol": 1e-5, "atol": 1e-8}),
]
QUICK_MODELS = ("exact", "rk4 naive h=1e-3", "rk4 h=1e-2")


def _scene_without_banking(text: str) -> str:
    # naive RK4 refuses banking; the 120 swings never reach the pins, so every model runs without it
    return text.replace("[effects.banking]\nangle = 6.28\n", "")


def recordings() -> dict:
    text = _scene_without_banking(SCENE.read_text())
    notch_scene = escfit.load_scene("monday_fit_accuracy.toml", text=text)
    precise_text = text.replace('[observation]\nmodel = "notches"\nnotch_deg = 6\n', "[observation]\n")
    precise_text = precise_text.replace('sigma = { value = 0.03, vary = true, min = 0.001, max = 0.5, prior = '
                                        '"loguniform(0.001, 0.5)" }',
                                        'sigma = { value = 0.005, vary = true, min = 0.0005, max = 0.5, prior = '
                                        '"loguniform(0.0005, 0.5)" }')
    precise_scene = escfit.load_scene("monday_fit_accuracy_precise.toml", text=precise_text)
    return {
        "notches": (notch_scene, record_unit_curve(notch_scene, every=4, swings=SWINGS, notch_deg=6, sigma=0.03,
                                                   seed=11)),
        "precise": (precise_scene, record_unit_curve(precise_scene, every=1, swings=SWINGS, sigma=0.005, seed=3)),
    }


def forward_error(scene, solver: str, options: dict) -> tuple[float, float]:
    """Largest amplitude error (rad) over the swings at the truth, and CPU ms per solve."""
    ref = solve(scene, "exact", swings=SWINGS)
    solve(scene, solver, swings=2, **options)  # compile
    t0 = time.process_time()
    tr = solve(scene, solver, swings=SWINGS, **options)
    ms = 1e3 * (time.process_time() - t0)
    if tr.amplitude.size != ref.amplitude.size:
        return float("inf"), ms
    return float(np.max(np.abs(tr.amplitude - ref.amplitude))), ms


def study(*, quick: bool = False, walkers: int = 32, steps: int = 3000,
          progress=lambda s: None) -> dict:
    models = [m for m in MODELS if not quick or m[0] in QUICK_MODELS]
    out = {"models": [], "datasets": {}}
    recs = recordings()
    scene0 = recs["notches"][0]
    for label, solver, options in models:
        err, ms = forward_error(scene0, solver, options)
        out["models"].append({"model": label, "solver": solver, "options": options, "amplitude_error_rad": err,
                              "ms_per_solve": ms})
        progress(f"forward {label:22s} amplitude error {err:9.2e} rad  {ms:9.1f} ms per {SWINGS}-swing solve")
    for key, (scene, data) in recs.items():
        exact = FitProblem(scene, data)
        lsq = least_squares(exact, n_starts=4, seed=0)
        mc = run_emcee(exact, lsq, walkers=walkers, steps=steps if not quick else 400, seed=1)
        flat = mc.chain.reshape(-1, len(exact.names))
        sd = {n: float(np.std(flat[:, exact.names.index(n)], ddof=1)) for n in NAMES}
        mean = {n: float(np.mean(flat[:, exact.names.index(n)])) for n in NAMES}
        optimum = {n: float(lsq.value[lsq.names.index(n)]) for n in NAMES}
        start = scene.with_values(optimum)
        rows = []
        for label, solver, options in models:
            t0 = time.perf_counter()
            shift, chi2, nfev = _nelder_mead(FitProblem(start, data, solver, dict(options)), optimum, sd)
            rows.append({"model": label, "estimate": {n: optimum[n] + shift[n] * sd[n] for n in NAMES},
                         "bias_over_sd": shift, "chi2": chi2, "evaluations": nfev,
                         "seconds": time.perf_counter() - t0})
            progress(f"{key:8s} {label:22s} " + "  ".join(f"{SHORT[n]} {shift[n]:+8.3f} sd" for n in NAMES)
                     + f"  chi2 {chi2:9.2f}  ({nfev} evaluations)")
        for row in rows:
            row["misfit_ratio"] = row["chi2"] / rows[0]["chi2"]  # rows[0] is the exact model
        out["datasets"][key] = {"readings": int(data.swing.size), "posterior_sd": sd, "posterior_mean": mean,
                                "exact_optimum": optimum, "rows": rows, "walkers": walkers,
                                "steps": steps if not quick else 400}
    return out


def _nelder_mead(problem: FitProblem, optimum: dict, sd: dict) -> tuple[dict, float, int]:
    """Minimum of the chi-square in z = (theta - optimum)/sd, from z = 0; returns z, chi2, evaluations."""
    from scipy.optimize import minimize

    def chi2(z):
        vals = problem.values({n: optimum[n] + zi * sd[n] for n, zi in zip(NAMES, z)})
        return float(np.sum(problem.residuals(vals) ** 2))

    z, nfev = np.zeros(len(NAMES)), 0
    for size in (0.5, 0.1):  # a restart with a smaller simplex guards against early collapse
        simplex = np.vstack([z, z + size * np.eye(len(NAMES))])
        res = minimize(chi2, z, method="Nelder-Mead",
                       options={"initial_simplex": simplex, "xatol": 1e-3, "fatol": 1e-4, "maxfev": 1500})
        z, nfev = res.x, nfev + res.nfev
    return dict(zip(NAMES, map(float, z))), float(res.fun), nfev


def markdown(result: dict) -> str:
    lines = ["| forward model | amplitude error (rad) | ms per 120-swing solve | "
             + " | ".join(f"{k}: bias {SHORT[n]} / sd" for k in result["datasets"] for n in [*NAMES, "chi2"]).replace(
                 "bias chi2 / sd", "chi2 / exact") + " |",
             "|---|---:|---:|" + "---:|" * (4 * len(result["datasets"]))]
    for i, m in enumerate(result["models"]):
        cells = [m["model"], f"{m['amplitude_error_rad']:.1e}", f"{m['ms_per_solve']:.1f}"]
        for d in result["datasets"].values():
            row = d["rows"][i]
            cells += [f"{row['bias_over_sd'][n]:+.2f}" for n in NAMES]
            cells.append(f"{row['misfit_ratio']:.2f}")
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    for k, d in result["datasets"].items():
        lines.append(f"- {k}: {d['readings']} readings; posterior sd " + ", ".join(
            f"{SHORT[n]} {d['posterior_sd'][n]:.3g}" for n in NAMES)
            + f" ({d['walkers']} walkers x {d['steps']} steps)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--markdown", action="store_true", help="print the docs table")
    args = ap.parse_args(argv)
    result = study(quick=args.quick, progress=lambda s: print(s, file=sys.stderr, flush=True))
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        print(markdown(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
