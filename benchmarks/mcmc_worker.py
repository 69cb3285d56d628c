"""One case of ``benchmarks/mcmc_speed.py`` in a fresh process (run with the escfit under test first on PYTHONPATH).

Usage:  python benchmarks/mcmc_worker.py CASE MOVES WORKDIR    -> one JSON object on stdout
"""

from __future__ import annotations

import json
import math
import sys
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

TRUTH = """model = "balance"
[oscillator]
omega0 = 6.283185307179586
theta0 = 0.5
[run]
swings = 120
[effects.viscous]
C = 0.02
[effects.coulomb]
R = 0.01
"""

FIT = """model = "balance"
[oscillator]
omega0 = { value = 6.2, vary = true, min = 4, max = 8 }
[effects.viscous]
C = { value = 0.05, vary = true, min = 0, max = 2 }
[effects.coulomb]
R = { value = 0.05, vary = true, min = 0, max = 5 }
[observation]
model = "waveform"
"""


def _case(case: str, work: Path):
    """(scene, data, walkers, seed, max_steps) of a case."""
    if case == "quickstart":
        doc = tomllib.loads((ROOT / "fits" / "monday_unit3.toml").read_text())
        base = ROOT / "fits"
        return base / doc["scene"], base / doc["data"], int(doc["walkers"]), int(doc["seed"]), 20000
    if case == "waveform120":
        from escfit.balance.synthetic.instruments import record
        from escfit.core.scene import load_scene

        rec = work / "waveform120.csv"
        if not rec.exists():
            record(load_scene("truth.toml", text=TRUTH), "timeseries", rec, noise=0.01, seed=5, rate_hz=50.0)
        scene = work / "waveform120_fit.toml"
        scene.write_text(FIT)
        return scene, rec, 32, 1, 20000
    path = ROOT / "fits" / "real" / f"{case}.toml"
    doc = tomllib.loads(path.read_text())
    # (a least-squares recipe names no walkers: emcee's recipes use 32)
    return (path.parent / doc["scene"], path.parent / doc["data"], int(doc.get("walkers", 32)),
            int(doc.get("seed", 1)), int(doc.get("max_steps", 20000)))


def main() -> None:
    case, moves, work = sys.argv[1], sys.argv[2], Path(sys.argv[3])
    import numpy as np
    import arviz as az

    from escfit.inference.lsq import least_squares
    from escfit.inference.mcmc import run_emcee
    from escfit.inference.reconcile import reconcile
    from escfit.inference.registry import make_problem

    scene, data, walkers, seed, max_steps = _case(case, work)
    t0 = time.perf_counter()
    problem = make_problem(str(scene), str(data))
    problem.log_prob(problem.initial)  # compiles (or loads) the kernels outside the timings
    t1 = time.perf_counter()
    lsq = least_squares(problem, seed=seed, priors_count=True)
    lsq, *_ = reconcile(problem, lsq, seed=seed, priors_count=True)
    t2, c2 = time.perf_counter(), time.process_time()
    mc = run_emcee(problem, lsq, walkers=walkers, steps="auto", seed=seed, moves=moves, max_steps=max_steps)
    t3, c3 = time.perf_counter(), time.process_time()
    sampling = float(mc.timings.get("sampling_s", t3 - t2))
    tau = float(np.max(mc.tau))
    rhat = [float(az.rhat(mc.chain[:, :, i])) for i in range(len(mc.names))]
    ess = [min(float(az.ess(mc.chain[:, :, i], method="bulk")), float(az.ess(mc.chain[:, :, i], method="tail")))
           for i in range(len(mc.names))]
    flat = mc.chain.reshape(-1, len(mc.names))
    q = np.quantile(flat, [0.05, 0.5, 0.95], axis=0)
    out = {"case": case, "moves": moves, "names": mc.names, "walkers": walkers, "steps": int(mc.steps),
           "converged": bool(mc.converged), "setup_s": t1 - t0, "lsq_s": t2 - t1, "sampling_s": sampling,
           "s_per_step": sampling / mc.steps,
           "cpu_s": c3 - c2, "cpu_s_per_step": (c3 - c2) / mc.steps, "tau": [float(t) for t in mc.tau], "tau_max": tau,
           "tau_per_s": mc.steps / tau / sampling if math.isfinite(tau) and tau > 0 else float("nan"),
           "ess_per_s": walkers * mc.steps / tau / sampling if math.isfinite(tau) and tau > 0 else float("nan"),
           "rhat_max": max(rhat), "ess_min": min(ess), "acceptance": float(np.mean(mc.acceptance)),
           "quantiles": {n: {"q05": float(q[0, i]), "q50": float(q[1, i]), "q95": float(q[2, i])}
                         for i, n in enumerate(mc.names)},
           "sd": {n: float(np.std(flat[:, i], ddof=1)) for i, n in enumerate(mc.names)}}
    print(json.dumps(out))


if __name__ == "__main__":
    main()
