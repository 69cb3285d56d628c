"""Run every shipped fit recipe and write the table the README and the docs quote.

Run from a checkout:  python benchmarks/recipes.py [--out-dir benchmarks/results] [--only NAME ...]

Each recipe of ``fits/*.toml`` and ``fits/real/*.toml`` is run as a user runs it
(``escfit fit RECIPE``), one at a time, into a scratch folder; its results file is then read for
every free parameter's estimate and 95 % interval (in the report's display units), split R-hat,
bulk and tail ESS, the run length and whether the automatic run length converged, and the time
taken (wall clock and CPU).  Writes ``recipes.md`` (a Markdown table) and ``recipes.json`` into
``--out-dir``; prints the table.  The convergence thresholds are the sampler's own
(:mod:`escfit.inference.convergence`): R-hat <= 1.01, bulk and tail ESS >= 400.  Nothing here
loosens them: a recipe that ends unconverged is printed as such and makes the exit status 1.
"""

from __future__ import annotations

import argparse
import json
import platform
import resource
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def recipes(only: list[str] | None = None) -> list[Path]:
    found = sorted((ROOT / "fits").glob("*.toml")) + sorted((ROOT / "fits" / "real").glob("*.toml"))
    return [p for p in found if not only or p.stem in only]


def run_recipe(path: Path, scratch: Path) -> dict:
    """Run one recipe with the command line; return its timings and the results file."""
    out = scratch / f"{path.stem}.h5"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    clock = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "escfit.cli.main", "fit", str(path), "--out", str(out), "--quiet",
                           "--force"], capture_output=True, text=True, cwd=scratch)
    wall = time.perf_counter() - clock
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"recipe": str(path.relative_to(ROOT)), "returncode": proc.returncode, "wall_s": round(wall, 1),
            "cpu_s": round(cpu, 1), "out": str(out), "stderr": proc.stderr.strip()[-500:]}


def summarise(record: dict) -> dict:
    """Estimates, intervals and diagnostics of a finished recipe (display units)."""
    from escfit.core.display import format_row, load_unit, to_display
    from escfit.core.names import plain_name
    from escfit.report.params import CENTRE_BASE, centre_row
    from escfit.results import load_fit

    res = load_fit(record["out"])
    a = res.attrs
    meanings = json.loads(a.get("meanings", "{}") or "{}")
    loads_in = load_unit(meanings)
    rows = []
    for name, r in res.summary().items():
        if name not in res.parameter_names:
            continue
        if name in CENTRE_BASE:
            r = centre_row(name, r, a)
        value, unit = to_display(r["estimate"], r.get("unit"), name)
        lo, hi = (to_display(r[k], r.get("unit"), name)[0] for k in ("lo95", "hi95"))
        text, (lo_t, hi_t) = format_row(value, (lo, hi), hi - lo)
        rows.append({"parameter": name, "plain": plain_name(name, meanings.get(name, ""), loads_in), "unit": unit,
                     "estimate": text, "lo95": lo_t, "hi95": hi_t, "kind": r.get("estimate_kind"),
                     "rhat": r.get("rhat"), "ess_bulk": r.get("ess_bulk"), "ess_tail": r.get("ess_tail")})
    return {**record, "title": a.get("title", ""), "method": a.get("method"), "walkers": a.get("walkers"),
            "steps": a.get("steps"), "steps_mode": a.get("steps_mode"),
            "converged": None if a.get("method") != "emcee" else _converged(rows, a), "parameters": rows,
            "warnings": res.warnings}


def _converged(rows: list[dict], a: dict) -> bool:
    from escfit.inference.convergence import ESS_MIN, RHAT_MAX

    ok = all(r["rhat"] is not None and r["rhat"] <= RHAT_MAX and r["ess_bulk"] >= ESS_MIN and r["ess_tail"] >= ESS_MIN
             for r in rows)
    return ok and (a.get("steps_mode") != "auto" or bool(int(a.get("converged", 0))))


def markdown(records: list[dict]) -> str:
    head = ("| recipe | method, run | parameter | estimate [95 % interval] | R-hat | ESS bulk / tail | converged | "
            "time (wall / CPU) |")
    lines = [head, "|---|---|---|---|---:|---:|---|---:|"]
    for rec in records:
        if rec.get("returncode"):
            lines.append(f"| {rec['recipe']} | failed | | {rec['stderr'][-120:]} | | | | |")
            continue
        run = (f"emcee, {rec['walkers']} walkers x {rec['steps']} steps" if rec["method"] == "emcee"
               else "least squares")
        conv = {True: "yes", False: "**no**", None: "-"}[rec["converged"]]
        times = f"{rec['wall_s']:.0f} / {rec['cpu_s']:.0f} s"
        for i, p in enumerate(rec["parameters"]):
            first = i == 0
            rhat = f"{p['rhat']:.3f}" if p["rhat"] is not None else "-"
            ess = f"{p['ess_bulk']:.0f} / {p['ess_tail']:.0f}" if p["ess_bulk"] is not None else "-"
            unit = f" {p['unit']}" if p["unit"] and p["unit"] != "dimensionless" else ""
            lines.append(f"| {rec['recipe'] if first else ''} | {run if first else ''} | {p['plain']} | "
                         f"{p['estimate']} [{p['lo95']}, {p['hi95']}]{unit} | {rhat} | {ess} | "
                         f"{conv if first else ''} | {times if first else ''} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--only", nargs="*", help="recipe names (file stems) to run")
    ap.add_argument("--keep", type=Path, default=None, help="keep the results files in this folder (reports)")
    ap.add_argument("--from-kept", type=Path, default=None,
                    help="do not run: re-read the results files kept by an earlier --keep run, with the times of its "
                         "recipes.json (in --out-dir)")
    args = ap.parse_args(argv)
    records = []
    if args.from_kept is not None:
        earlier = json.loads((args.out_dir / "recipes.json").read_text())["recipes"]
        for rec in earlier:
            if rec.get("returncode"):
                records.append(rec)
                continue
            keep = {k: rec[k] for k in ("recipe", "returncode", "wall_s", "cpu_s", "stderr")}
            records.append(summarise({**keep, "out": str(args.from_kept / f"{Path(rec['recipe']).stem}.h5")}))
        return _write(records, args.out_dir)
    with tempfile.TemporaryDirectory(prefix="escfit-recipes-") as tmp:
        scratch = args.keep or Path(tmp)
        scratch.mkdir(parents=True, exist_ok=True)
        for path in recipes(args.only):
            print(f"running {path.relative_to(ROOT)} ...", file=sys.stderr, flush=True)
            rec = run_recipe(path, scratch)
            records.append(summarise(rec) if rec["returncode"] == 0 else rec)
            print(f"  {rec['wall_s']:.0f} s wall, {rec['cpu_s']:.0f} s CPU, converged: {records[-1].get('converged')}",
                  file=sys.stderr, flush=True)
    return _write(records, args.out_dir)


def _write(records: list[dict], out_dir: Path) -> int:
    """Write recipes.json and recipes.md, print the table; 1 when a recipe failed or did not converge."""
    for rec in records:
        rec.pop("out", None)
    table = markdown(records)
    meta = {"python": platform.python_version(), "machine": platform.machine(), "processors": _cpus(),
            "date": time.strftime("%Y-%m-%d")}
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "recipes.json").write_text(json.dumps({"meta": meta, "recipes": records}, indent=1, default=str))
    (out_dir / "recipes.md").write_text(f"Shipped recipes, run by `python benchmarks/recipes.py` on {meta['date']} "
                                              f"({meta['processors']} processors, Python {meta['python']}).  Wall times depend on what else "
                                         "runs on the machine; CPU times are the fits' own.  The run length of "
                                         "every emcee recipe is set by convergence: split R-hat <= 1.01, bulk and "
                                         "tail ESS >= 400, longer than 50 autocorrelation times.\n\n" + table)
    print(table)
    bad = [r["recipe"] for r in records if r.get("returncode") or r.get("converged") is False]
    if bad:
        print(f"not converged or failed: {', '.join(bad)}", file=sys.stderr)
    return 1 if bad else 0


def _cpus() -> int:
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 0


if __name__ == "__main__":
    sys.exit(main())
