"""The sampler's own cost per step against the model's, on the quick start.

Run from a checkout::

    python benchmarks/sampler_overhead.py [--previous DIR] [--repeat 5]

Two figures, CPU time in fresh interpreters, medians of ``--repeat``:

* **bookkeeping**: emcee with escfit's default ``de-t`` moves (32 walkers, 1220 steps) on a
  five-parameter Gaussian whose log density costs a few microseconds: what the proposals and
  emcee's own step cost, per step; and the same with nine parameters (the string pendulum's
  trial posterior: seven sub-ensembles a step);
* **model**: the quick start's log posterior (Monday's unit 3, three loads, five free
  parameters) for one half-ensemble of 16 walkers near the optimum, per call; a step makes two.

With ``--previous`` (a checkout of the previous version, e.g. ``git worktree add --detach DIR
main``) both are measured for it too, in turn with this checkout.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

BOOKKEEPING = r"""
import json, sys, time
import numpy as np
from escfit.inference.moves import de_t_moves, emcee
try:  # the sampler class the fits use (emcee's own before it existed)
    from escfit.inference.ensemble import ArraySampler as Sampler
except ImportError:
    Sampler = emcee.EnsembleSampler
ndim = int(sys.argv[2])
prec = np.diag(1.0 / np.arange(1.0, ndim + 1.0))
log_prob = lambda x: -0.5 * np.einsum("ij,jk,ik->i", x, prec, x)
sampler = Sampler(32, ndim, log_prob, vectorize=True, moves=de_t_moves())
start = np.random.default_rng(0).normal(size=(32, ndim))
t = time.process_time()
sampler.run_mcmc(start, 1220, progress=False, store=False)
print("FIGURE " + json.dumps((time.process_time() - t) / 1220 * 1e3))
"""

MODEL = r"""
import json, sys, time
import numpy as np
from escfit.core.scene import load_scene
from escfit.inference.lsq import least_squares
from escfit.inference.registry import family
root = sys.argv[1]
scene = load_scene(f"{root}/datasets/monday1965/unit3_fit.toml")
problem = family(scene.model).problem(scene, f"{root}/datasets/monday1965/synthetic/unit3.csv")
lsq = least_squares(problem, n_starts=1, seed=0)
best = np.array([lsq.values[n] for n in problem.names])
walkers = best * (1 + 1e-3 * np.random.default_rng(0).normal(size=(16, best.size)))
problem.log_prob_many(walkers)
t = time.process_time()
for _ in range(1000):
    problem.log_prob_many(walkers)
print("FIGURE " + json.dumps((time.process_time() - t)))
"""


def _figure(script: str, code: Path, *extra: str) -> float:
    env = dict(os.environ, PYTHONPATH=str(code), OPENBLAS_NUM_THREADS="1", ESCFIT_QUIET_COMPILE="1")
    r = subprocess.run([sys.executable, "-c", script, str(code), *extra], capture_output=True, text=True, env=env,
                       cwd=code, check=True)
    return json.loads([ln for ln in r.stdout.splitlines() if ln.startswith("FIGURE ")][0][7:])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--previous", type=Path, default=None, help="a checkout of the previous version")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    versions = [("current", ROOT)] + ([("previous", args.previous.resolve())] if args.previous else [])
    runs: dict[str, dict[str, list[float]]] = {name: {"bookkeeping": [], "bookkeeping 9": [], "model": []}
                                               for name, _ in versions}
    for _ in range(args.repeat):
        for name, code in versions:  # in turn, so that a drift of the machine hits both
            runs[name]["bookkeeping"].append(_figure(BOOKKEEPING, code, "5"))
            runs[name]["bookkeeping 9"].append(_figure(BOOKKEEPING, code, "9"))
            runs[name]["model"].append(_figure(MODEL, code))
    print(f"load average {os.getloadavg()[0]:.2f}; medians of {args.repeat} fresh processes, CPU ms")
    for name, _ in versions:
        book, book9, model = (statistics.median(runs[name][k]) for k in ("bookkeeping", "bookkeeping 9", "model"))
        print(f"  {name:9s} proposals and emcee's step {book:.3f} ms a step (5 parameters; 9 parameters, seven "
              f"sub-ensembles: {book9:.3f}); the quick start's model {model:.3f} ms a call, {2 * model:.3f} a step "
              "(two half-ensembles)")


if __name__ == "__main__":
    main()
