"""escfit's string-pendulum least squares against a JAX + diffrax + trust-region peer, whole processes, in one run.

Run from a checkout (JAX optional: without it the peer is reported as skipped)::

    python benchmarks/jax_compare.py [--jax-python PATH] [--repeat 5] [--out-dir DIR]

``--jax-python`` names an interpreter with jax and diffrax installed (default: this one), e.g. a
separate venv: ``python -m venv /tmp/jaxenv && /tmp/jaxenv/bin/pip install jax diffrax scipy``.

1. The recipe's problem is built as ``escfit fit`` builds it and fitted once in this process:
   escfit's estimates and standard errors, the AR(1) correlation it settles on, its integrator
   tolerance.
2. The peer's input is written: the very samples escfit fits, the reference time, that
   correlation and escfit's settled noise scale (held), the Gaussian priors escfit puts on the
   sensor's centre and its drift (measured from the record), escfit's tolerance, and escfit's
   starting values (from the record's
   analysis: a JAX user would have to write that analysis; its time is escfit's alone here,
   which favours the peer).
3. Whole processes, in turn (escfit, peer, escfit, peer ...), after one warm-up of each:
   ``python -m escfit fit fits/real/string_pendulum_lab1.toml --method leastsq`` (imports, the
   record's analysis, the multistart, both noise stages, the checks, the results written) against
   ``benchmarks/jax_peer.py`` (imports, jit compilation, one trust-region fit).  Wall time and
   CPU seconds (the operating system's accounting of each child).
4. The peer's optimum is checked with escfit's own residual function and priors: its cost
   against escfit's, and each estimate's distance from escfit's in escfit's standard errors.

Printed, and written to ``jax_compare.md`` / ``jax_compare.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RECIPE = ROOT / "fits" / "real" / "string_pendulum_lab1.toml"
PEER = ROOT / "benchmarks" / "jax_peer.py"
NAMES = ["oscillator.omega0", "oscillator.theta0", "viscous.C", "coulomb.R", "observation.offset",
         "observation.offset_rate", "observation.t_release"]


def escfit_fit():
    """The problem and escfit's least squares, as ``escfit fit`` runs them."""
    from escfit.core.scene import load_scene
    from escfit.inference import registry
    from escfit.inference.lsq import least_squares

    table = tomllib.loads(RECIPE.read_text())
    scene = load_scene(str((RECIPE.parent / table["scene"]).resolve()))
    fam = registry.family(scene.model)
    defaults = dict(getattr(fam, "fit_defaults", {}))
    problem = fam.problem(scene, str((RECIPE.parent / table["data"]).resolve()), **dict(table.get("options", {})))
    start = problem.values(problem.initial)
    lsq = least_squares(problem, n_starts=defaults.get("n_starts", 8), n_refine=defaults.get("n_refine"),
                        seed=int(table.get("seed", 0)))
    return problem, start, lsq


def peer_input(problem, start: dict, lsq, path: Path) -> None:
    rtol = float(problem.solver_options.get("rtol", 1e-10))
    fresh = problem.observation.fresh
    spec = {"time": problem.sample_time.tolist(), "readings": problem.curves[0].y.tolist(),
            "t_ref": float(problem.observation.t_ref), "rho": float(lsq.values["observation.rho"]),
            "rtol": rtol, "atol": 1e-2 * rtol * abs(float(start["oscillator.theta0"])),
            "fresh": [] if fresh is None else np.flatnonzero(fresh).tolist(),
            "sigma": float(lsq.values["observation.sigma"]),
            "priors": {n: list(map(float, problem.priors[problem.names.index(n)].args)) for n in NAMES
                       if problem.priors[problem.names.index(n)].kind == "normal"},
            "start": {n: float(start[n]) for n in NAMES}}
    path.write_text(json.dumps(spec))


def timed(cmd: list[str], env: dict) -> tuple[float, float, int]:
    """Wall and CPU seconds of one child process, and its exit code."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    clock = time.perf_counter()
    code = subprocess.run(cmd, env=env, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
    wall = time.perf_counter() - clock
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), code


def main() -> None:
    from escfit.likelihood.problem import stacked_residuals

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jax-python", default=sys.executable, help="an interpreter with jax and diffrax")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out-dir", default=str(ROOT / "benchmarks" / "results"))
    args = ap.parse_args()
    problem, start, lsq = escfit_fit()
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    with tempfile.TemporaryDirectory() as tmp:
        src, dst, out = Path(tmp) / "in.json", Path(tmp) / "out.json", Path(tmp) / "fit.h5"
        peer_input(problem, start, lsq, src)
        mine = [sys.executable, "-m", "escfit", "fit", str(RECIPE), "--method", "leastsq", "--out", str(out),
                "--force", "--quiet"]
        theirs = [args.jax_python, str(PEER), str(src), str(dst)]
        peer_code = timed(theirs, env)[2]  # warm-up (and is JAX there?)
        if peer_code != 0:
            print(f"the peer did not run (exit {peer_code}): jax and diffrax are not installed for {args.jax_python}; "
                  "pass --jax-python. Peer skipped.")
            return
        timed(mine, env)
        runs = {"escfit": [], "peer": []}
        load = [os.getloadavg()[0]]
        for _ in range(args.repeat):
            runs["escfit"].append(timed(mine, env)[:2])
            runs["peer"].append(timed(theirs, env)[:2])
        load.append(os.getloadavg()[0])
        peer = json.loads(dst.read_text())
    names = list(lsq.names)
    at_peer = problem.values({**lsq.values, **{n: peer["values"][n] for n in NAMES}})
    priors = [problem.priors[problem.names.index(n)] for n in names]

    def cost_vector(vals):
        return stacked_residuals(np.asarray(problem.residuals(vals), float), priors, np.array([vals[n] for n in names]))

    r_peer, r_mine = cost_vector(at_peer), cost_vector(lsq.values)
    shift = {n: (peer["values"][n] - lsq.value[names.index(n)]) / lsq.stderr[names.index(n)] for n in NAMES}
    ratios = [p[1] / e[1] for e, p in zip(runs["escfit"], runs["peer"])]
    med = {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v)) for k, v in runs.items()}
    record = {"runs": runs, "median_wall_cpu": med, "pairwise_cpu_ratio_median": statistics.median(ratios),
              "peer": peer, "cost_escfit_residuals_and_priors": {"escfit": float(r_mine @ r_mine), "peer": float(r_peer @ r_peer)},
              "shift_in_escfit_se": shift, "rtol": problem.solver_options.get("rtol"), "load_average": load}
    lines = [f"String pendulum least squares, whole process, {args.repeat} pairs in turn (load average "
             f"{load[0]:.1f} -> {load[1]:.1f}, 2 CPUs); jax {peer['jax']}, diffrax {peer['diffrax']}; rtol "
             f"{record['rtol']:.2g} for both:", "",
             "| process | median wall s | median CPU s |", "| --- | ---: | ---: |",
             f"| escfit fit --method leastsq | {med['escfit'][0]:.2f} | {med['escfit'][1]:.2f} |",
             f"| JAX + diffrax + least_squares peer | {med['peer'][0]:.2f} | {med['peer'][1]:.2f} |", "",
             f"Pairwise CPU ratio peer / escfit: median {record['pairwise_cpu_ratio_median']:.2f}x "
             f"(range {min(ratios):.2f}-{max(ratios):.2f}x).  The peer's last run: imports {peer['import_s']:.2f} s, "
             f"jit compilation {peer['compile_s']:.2f} s, fit {peer['fit_s']:.2f} s ({peer['nfev']} evaluations, "
             f"{peer['njev']} Jacobians).",
             f"Peer's optimum in escfit's residuals and priors: cost {r_peer @ r_peer:.6g} against escfit's "
             f"{r_mine @ r_mine:.6g}; largest estimate shift {max(abs(v) for v in shift.values()):.2g} of escfit's "
             "standard errors."]
    print("\n".join(lines))
    folder = Path(args.out_dir)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "jax_compare.md").write_text("\n".join(lines) + "\n")
    (folder / "jax_compare.json").write_text(json.dumps(record, indent=1, default=float))


if __name__ == "__main__":
    main()
