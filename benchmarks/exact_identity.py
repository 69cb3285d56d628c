"""Are the exact solver's results bit for bit those of the previous version?

Runs the same scenes -- every spring scene shipped in ``datasets/`` and a few hundred generated
ones (viscous and Coulomb friction, escapement windows on one or both swings, piecewise
hairsprings, banking with restitution, damping drift, phase switching, over- and critically
damped cases) -- through the exact solver of this checkout and of the previous version (git
revision ``--baseline``, default ``main``, in a subprocess: see ``benchmarks/previous.py``),
single-set and batch, and compares amplitudes, turning angles, half periods, times, banking
flags, statuses and final states bit for bit.  Prints one line per group and exits 1 when any
value differs.  Both runs use this machine's numpy and numba, so the comparison is meaningful
only within one environment: it is a check of the redesign, not a test.

Run:  python benchmarks/exact_identity.py [--baseline main] [--scenes 300]
"""

from __future__ import annotations

import argparse
import base64
import inspect
import json
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve()
sys.path.insert(0, str(HERE.parent))


def generated(n: int, seed: int = 1) -> list[str]:
    """``n`` random balance scenes as TOML text (angle and phase switching)."""
    rng = np.random.default_rng(seed)
    texts = []
    for i in range(n):
        w0 = float(rng.uniform(3.0, 30.0))
        th0 = float(rng.uniform(0.1, 6.0) * rng.choice([-1.0, 1.0]))
        phase = i % 5 == 4
        c = float(rng.choice([0.0, rng.uniform(0.0, 0.5 * w0), rng.uniform(0.0, 3.0 * w0)]))
        if phase:
            c = float(rng.uniform(0.0, 1.9 * w0))
        r = float(rng.choice([0.0, rng.uniform(0.0, 0.3) * w0**2 * abs(th0) / 3]))
        eff = f"[effects.viscous]\nC = {c!r}\n[effects.coulomb]\nR = {r!r}\n"
        lo = float(rng.uniform(-0.6, -0.1)) * min(abs(th0), 1.5)
        mid = float(rng.uniform(0.3, 0.9)) * lo
        hi = -mid
        sw = ["both", "positive", "negative"][int(rng.integers(0, 3))] if not phase else "both"
        if rng.random() < 0.8:
            eff += (f'[[effects.escapement]]\nkind = "unlock"\nfrom = {lo!r}\nto = {mid!r}\n'
                    f'X = {float(rng.uniform(0, 0.3)) * w0**2!r}\nswings = "{sw}"\n')
            eff += (f'[[effects.escapement]]\nkind = "impulse"\nfrom = {mid!r}\nto = {hi!r}\n'
                    f'X = {float(rng.uniform(0, 3.0)) * w0**2!r}\n')
        spring = not phase and rng.random() < 0.25
        if spring:
            b = sorted([float(rng.uniform(-1.5, -0.05)) * abs(th0), float(rng.uniform(0.05, 1.5)) * abs(th0)])
            ws = [w0 * float(rng.uniform(0.7, 1.4)) for _ in range(2)]
            eff += f"[effects.hairspring]\nangles = [{b[0]!r}, {b[1]!r}]\nomega0 = [{ws[0]!r}, {w0!r}, {ws[1]!r}]\n"
        if not phase and rng.random() < 0.3:
            eff += f"[effects.banking]\nangle = {abs(th0) * float(rng.uniform(1.0, 1.3))!r}\n" \
                   f"restitution = {float(rng.choice([0.0, 0.5, 1.0]))!r}\n"
        if rng.random() < 0.25:
            eff += "[effects.viscous_drift]\nthresholds = [0.5, 0.1]\nrates = [0.02, 0.01, 0.0]\n"
        osc = "" if spring else f"omega0 = {w0!r}\n"
        texts.append(f'model = "balance"\nswitching = "{"phase" if phase else "angle"}"\n[oscillator]\n{osc}'
                     f"theta0 = {th0!r}\n[run]\nswings = 60\n[effects]\n{eff}")
    return texts


def shipped() -> list[tuple[str, str]]:
    """(name, text) of every spring balance scene under datasets/ of this checkout."""
    root = HERE.parents[1] / "datasets"
    out = []
    for path in sorted(root.rglob("*.toml")):
        text = path.read_text()
        if 'model = "balance"' not in text or "pendulum" in text or "theta0" not in text:
            continue
        out.append((str(path.relative_to(root)), text))
    return out


def _pack(a) -> str:
    return base64.b64encode(np.ascontiguousarray(a, float).tobytes()).decode()


def compute(texts: list[str]) -> dict:
    """Exact-solver results of every scene (single set) and of each batch, as base64 float64."""
    import escfit
    from escfit.balance import solve
    from escfit.balance.batch import solve_batch

    out = {}
    for i, text in enumerate(texts):
        try:
            scene = escfit.load_scene(f"s{i}.toml", text=text)
        except escfit.core.errors.EscfitError as err:
            out[str(i)] = {"refused": str(err)}
            continue
        tr = solve(scene, "exact")
        rec = {f: _pack(getattr(tr, f)) for f in ("amplitude", "theta_turn", "half_period", "time", "banked")}
        rec.update(status=tr.status, final=_pack(tr.final), n_segments=int(tr.n_segments))
        free = [p for p in scene.params if p.tie is None and p.value != 0 and p.name != "oscillator.theta0"]
        rng = np.random.default_rng(i)
        systems = [scene.build({p.name: p.value * (1 + 0.3 * (rng.random() - 0.5)) for p in free}) for _ in range(4)]
        if "switching" in inspect.signature(solve_batch).parameters:  # the previous face
            batch = solve_batch(systems, scene.swings, scene.switching, throw=False)
        else:
            batch = solve_batch(systems, scene.swings, throw=False)
        rec["batch"] = {f: _pack(getattr(batch, f)) for f in ("amplitude", "theta_turn", "half_period", "time")}
        rec["batch_status"] = [str(s) for s in batch.status]
        out[str(i)] = rec
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--baseline", default="main", help="git revision of the previous version (default main)")
    parser.add_argument("--scenes", type=int, default=300, help="generated scenes (default 300)")
    parser.add_argument("--compute", metavar="FILE", help=argparse.SUPPRESS)  # the subprocesses' entry
    args = parser.parse_args(argv)
    if args.compute:
        print(json.dumps(compute(json.loads(Path(args.compute).read_text()))))
        return 0
    import tempfile

    from previous import checkout, run_in

    names_texts = shipped() + [(f"generated {i}", t) for i, t in enumerate(generated(args.scenes))]
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump([t for _, t in names_texts], f)
    old = run_in(checkout(args.baseline), HERE, ["--compute", f.name])
    new = run_in(None, HERE, ["--compute", f.name])
    Path(f.name).unlink()
    differ, compared, refused = [], 0, 0
    for i, (name, _) in enumerate(names_texts):
        a, b = old[str(i)], new[str(i)]
        if "refused" in a or "refused" in b:
            refused += 1
            if ("refused" in a) != ("refused" in b):
                differ.append(f"{name}: refused by one version only ({a.get('refused') or b.get('refused')})")
            continue
        compared += 1
        same = a == b
        if not same:
            keys = [k for k in a if a[k] != b[k]]
            differ.append(f"{name}: {', '.join(keys)} differ")
    print(f"baseline {args.baseline}: {compared} scenes compared (single set and a batch of 4 each), "
          f"{refused} refused by both")
    if differ:
        print(f"NOT IDENTICAL in {len(differ)} scene(s):")
        print("\n".join("  " + d for d in differ[:30]))
        return 1
    print("bit-identical: every amplitude, turning angle, half period, time, banking flag, status, final state "
          "and segment count")
    return 0


if __name__ == "__main__":
    sys.exit(main())
