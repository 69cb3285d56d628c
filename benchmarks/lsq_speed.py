"""Least squares of the real-data recipes: this checkout against the previous version and the scipy way, in one run.

Run from a checkout:  python benchmarks/lsq_speed.py [--baseline REV] [--only NAME ...] [--out-dir DIR]

Three timings of the 116 s string pendulum record (``fits/real/string_pendulum_lab1.toml``),
one after the other in fresh processes:

(a) the previous version (git revision ``--baseline``, extracted by ``benchmarks/previous.py``),
(b) this checkout,
(c) a hand-written scipy fit of the same record (``benchmarks/lsq_peer.py``: ``least_squares``
    around ``solve_ivp`` LSODA, rtol 1e-6, one start).

(a) and (b) run the least squares ``escfit fit`` runs (the family's multistart, the AR(1)
stages, the reconciliation), warm (numba's kernels loaded before the clock starts; see
``benchmarks/lsq_probe.py``).  Then every other ``fits/real/`` recipe whose method is leastsq,
previous and current.  Printed and written to ``lsq_speed.md`` / ``lsq_speed.json``: wall clock
and CPU seconds, model evaluations, the ratios, and how far the current estimates are from the
previous ones in the previous standard errors.  The machine is shared: CPU seconds are the
steadier figure when it is loaded; the load average is recorded.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import tomllib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from previous import ROOT, checkout, run_in  # noqa: E402

PROBE = ROOT / "benchmarks" / "lsq_probe.py"
PEER = ROOT / "benchmarks" / "lsq_peer.py"
HEADLINE = ROOT / "fits" / "real" / "string_pendulum_lab1.toml"
#: the last revision before least squares left lmfit (override with --baseline)
BASELINE = "9f98f15"


def leastsq_recipes(only: list[str] | None) -> list[Path]:
    found = [p for p in sorted((ROOT / "fits" / "real").glob("*.toml"))
             if tomllib.loads(p.read_text()).get("method") == "leastsq"]
    return [p for p in found if not only or p.stem in only]


def shift(old: dict, new: dict) -> float:
    """Largest |current - previous| estimate over the previous standard error (nan when none is finite)."""
    worst = math.nan
    for a, b, se in zip(old["value"], new["value"], old["stderr"]):
        if math.isfinite(se) and se > 0:
            d = abs(b - a) / se
            worst = d if not math.isfinite(worst) else max(worst, d)
    return worst


def _evals(rec: dict, prefix: str = "") -> str:
    """One-set evaluations, and the parameter sets batch Jacobians ran (when any)."""
    sets = rec.get(f"{prefix}batch_sets", 0)
    augmented = rec.get(f"{prefix}augmented", 0)
    return f"{rec[f'{prefix}evaluations']}" + (f" + {sets}" if sets else "") + (f" + {augmented} aug." if augmented else "")


def row(old: dict, new: dict) -> dict:
    return {"recipe": new["recipe"], "previous_s": old["seconds"], "current_s": new["seconds"],
            "previous_cpu_s": old["cpu_seconds"], "current_cpu_s": new["cpu_seconds"],
            "speedup": old["seconds"] / new["seconds"], "cpu_speedup": old["cpu_seconds"] / new["cpu_seconds"],
            "previous_evaluations": old["evaluations"], "current_evaluations": new["evaluations"],
            "previous_batch_sets": old.get("batch_sets", 0), "current_batch_sets": new.get("batch_sets", 0),
            "previous_augmented": old.get("augmented", 0), "current_augmented": new.get("augmented", 0),
            "max_shift_in_se": shift(old, new), "chisqr_previous": old["chisqr"], "chisqr_current": new["chisqr"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default=BASELINE, help="previous revision (git)")
    ap.add_argument("--only", nargs="*", help="recipe names besides the string pendulum (default: all leastsq)")
    ap.add_argument("--out-dir", default=str(ROOT / "benchmarks" / "results"))
    args = ap.parse_args()
    folder = checkout(args.baseline)
    load_before = os.getloadavg()
    old = run_in(folder, PROBE, [str(HEADLINE)])[0]
    new = run_in(None, PROBE, [str(HEADLINE)])[0]
    peer = run_in(None, PEER, [])
    head = row(old, new)
    head.update({"peer_s": peer["seconds"], "peer_cpu_s": peer["cpu_seconds"], "peer_evaluations": peer["evaluations"],
                 "peer_rms_rad": peer["rms_rad"], "current_rms_rad": new["rms_reading"],
                 "vs_peer": peer["seconds"] / new["seconds"], "vs_peer_cpu": peer["cpu_seconds"] / new["cpu_seconds"]})
    others = [p for p in leastsq_recipes(args.only) if p != HEADLINE]
    rows = [head]
    if others:
        olds = run_in(folder, PROBE, [str(p) for p in others])
        news = run_in(None, PROBE, [str(p) for p in others])
        rows += [row(a, b) for a, b in zip(olds, news)]
    record = {"baseline": args.baseline, "python": platform.python_version(), "cpus": os.cpu_count(),
              "load_average_before": load_before, "load_average_after": os.getloadavg(),
              "headline": head, "recipes": rows, "peer": peer}
    lines = [f"String pendulum least squares (fits/real/string_pendulum_lab1.toml, {len(new['names'])} parameters, "
             f"warm), load average {load_before[0]:.1f} before / {os.getloadavg()[0]:.1f} after on "
             f"{os.cpu_count()} CPUs:",
             "",
             "| run | wall s | CPU s | model evaluations (+ sets in batch Jacobians, + augmented sensitivity runs) |",
             "| --- | ---: | ---: | ---: |",
             f"| previous ({args.baseline}) | {old['seconds']:.2f} | {old['cpu_seconds']:.2f} | {_evals(old)} |",
             f"| current | {new['seconds']:.2f} | {new['cpu_seconds']:.2f} | {_evals(new)} |",
             f"| scipy peer (solve_ivp LSODA + least_squares, one start) | {peer['seconds']:.2f} | "
             f"{peer['cpu_seconds']:.2f} | {peer['evaluations']} |",
             "",
             f"current vs previous: {head['speedup']:.1f}x wall, {head['cpu_speedup']:.1f}x CPU; "
             f"current vs scipy peer: "
             f"{head['vs_peer']:.1f}x wall, {head['vs_peer_cpu']:.1f}x CPU.  RMS residual: escfit "
             f"{new['rms_reading']:.4g} rad, peer {peer['rms_rad']:.4g} rad.",
             "",
             "Every fits/real/ recipe with method leastsq (warm, seconds; shift: largest change of an estimate in "
             "the previous standard errors):",
             "",
             "| recipe | previous s | current s | speed-up | CPU speed-up | evaluations before / after "
             "(+ batch sets, + augmented runs) | shift (se) |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        lines.append(f"| {r['recipe']} | {r['previous_s']:.2f} | {r['current_s']:.2f} | {r['speedup']:.1f}x | "
                     f"{r['cpu_speedup']:.1f}x | {_evals(r, 'previous_')} / {_evals(r, 'current_')} | "
                     f"{r['max_shift_in_se']:.2g} |")
    text = "\n".join(lines) + "\n"
    print(text)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "lsq_speed.md").write_text(text)
    (out / "lsq_speed.json").write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
