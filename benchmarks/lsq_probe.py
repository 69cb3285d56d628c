"""Time one recipe's least squares in this process and print its estimates as JSON.

Run by ``benchmarks/lsq_speed.py`` under the current and the previous version of escfit
(``PYTHONPATH`` selects which):  python benchmarks/lsq_probe.py RECIPE.toml [RECIPE.toml ...]

For each recipe: the problem is built as ``escfit fit`` builds it, the model is run once (numba's
kernels loaded, so the timing is warm), then the least squares ``escfit fit`` runs (the family's
multistart, then the reconciliation of estimates on bounds) is timed.  Printed: wall-clock and CPU seconds, model
evaluations (calls of ``problem.residuals``; with a batch Jacobian also the parameter sets of
``problem.residuals_many``, counted apart as ``batch_sets``; with a Jacobian from the integrator's
sensitivities the augmented runs, ``augmented``), and every fitted parameter's estimate and standard error.
"""

from __future__ import annotations

import json
import sys
import time
import tomllib
from pathlib import Path

import numpy as np


def probe(recipe: Path) -> dict:
    from escfit.core.scene import load_scene
    from escfit.inference import registry
    from escfit.inference.lsq import least_squares
    from escfit.inference.reconcile import reconcile

    table = tomllib.loads(recipe.read_text())
    scene = load_scene(str((recipe.parent / table["scene"]).resolve()))
    data = str((recipe.parent / table["data"]).resolve())
    seed = int(table.get("seed", 0))
    fam = registry.family(scene.model)
    defaults = dict(getattr(fam, "fit_defaults", {}))
    problem = fam.problem(scene, data, **dict(table.get("options", {})))
    problem.residuals(problem.values(problem.initial))  # warm: kernels loaded before the clock starts
    calls = [0]
    inner = problem.residuals

    def counted(vals):
        calls[0] += 1
        return inner(vals)

    problem.residuals = counted
    batch = [0]
    many = getattr(problem, "residuals_many", None)
    if many is not None:
        many(np.array([problem.initial]))  # warm: the batch kernels loaded too

        def counted_many(vecs):
            batch[0] += len(vecs)
            return many(vecs)

        problem.residuals_many = counted_many
    augmented = [0]
    exact = getattr(problem, "residual_jacobian", None)
    if exact is not None and getattr(problem, "has_sensitivities", False):
        fitted = [n for n in problem.names if n not in ("observation.sigma", "observation.rho")]
        exact(problem.values(problem.initial), fitted)  # warm: the sensitivity kernels loaded too

        def counted_exact(vals, names):
            jac = exact(vals, names)
            augmented[0] += jac is not None
            return jac

        problem.residual_jacobian = counted_exact
    import scipy.optimize  # noqa: F401 - warm: the optimiser's import is start-up, whichever phase first needs it

    clock, cpu = time.perf_counter(), time.process_time()
    lsq = least_squares(problem, n_starts=defaults.get("n_starts", 8), n_refine=defaults.get("n_refine"), seed=seed)
    lsq, *_ = reconcile(problem, lsq, seed=seed)
    seconds, cpu = time.perf_counter() - clock, time.process_time() - cpu
    return {"recipe": recipe.stem, "seconds": seconds, "cpu_seconds": cpu, "evaluations": calls[0],
            "batch_sets": batch[0], "augmented": augmented[0], "names": list(lsq.names),
            "value": [float(v) for v in lsq.value], "stderr": [float(v) for v in lsq.stderr],
            "chisqr": float(lsq.chisqr),
            "rms_reading": float(np.sqrt(np.mean((problem.observed - problem.expected(lsq.values)) ** 2)))}


if __name__ == "__main__":
    print(json.dumps([probe(Path(p).resolve()) for p in sys.argv[1:]]))
