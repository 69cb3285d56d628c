"""emcee sampling speed against the previous version, in one run: seconds per step, steps to convergence, posteriors.

Cases (each a least-squares fit, then emcee with ``steps = "auto"``: split R-hat <= 1.01, bulk
and tail ESS >= 400, longer than 50 autocorrelation times):

* ``quickstart``: the README's quick start problem (``fits/monday_unit3.toml``: Monday's unit 3,
  three loads, notch counts, phase convention), 32 walkers, seed 3;
* ``waveform120``: a synthetic 120-swing free decay (omega0 = 2 pi rad/s, C = 0.02 1/s,
  R = 0.01 rad/s^2, released at 0.5 rad) written by escfit's own recorder
  (:func:`escfit.balance.synthetic.instruments.record`, 50 Hz, white noise 0.01 rad, seed 5), fitted
  as a waveform (8 free parameters: omega0, theta0, C, R, sigma, offset, its drift, the release
  instant), 32 walkers, seed 1;
* with ``--recipes``: the real-data emcee recipes ``fits/real/pohl_amplitudes.toml`` and
  ``fits/real/pohl_tracker.toml`` (long: the previous version needs tens of thousands of steps
  for the second).

Each case runs in a fresh process for the previous version (``git archive`` of ``--baseline``,
see ``benchmarks/previous.py``) with the move it shipped (``"de"``), and for this checkout with
the ``"de-t"`` mixture (and, with ``--same-moves``, also with ``"de"``, which separates the
cost per step from the number of steps).  Printed per run: steps, sampling seconds, seconds
per step, the largest integrated autocorrelation time tau (steps), autocorrelation times per
second (steps / tau / seconds) and effective draws per second (walkers * steps / tau /
seconds); then the posterior agreement of the new run with the previous one (median shift in
posterior standard deviations, relative change of the 90 % interval's width).  The quick
start's whole command (``escfit fit fits/monday_unit3.toml --report ...``, warm numba cache)
is timed too, ``--repeat`` times each.  Writes ``benchmarks/results/mcmc_speed.{md,json}``.

Run:  python benchmarks/mcmc_speed.py [--baseline 9f98f15] [--repeat 2] [--recipes] [--same-moves]
      python benchmarks/mcmc_speed.py --cases waveform120 --repeat 0 --name mcmc_speed_waveform
      python benchmarks/mcmc_speed.py --cases string_pendulum_trial1 --moves de --baseline b1a8df2 --repeat 0 \
          --name mcmc_speed_pendulum
      python benchmarks/mcmc_speed.py --cases string_pendulum_trial1 --moves de-t --same-moves --baseline fb297d2 \
          --repeat 0 --name mcmc_speed_pendulum_coords     (likewise pohl_tracker -> mcmc_speed_pohl_coords)
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from previous import checkout, run_in  # noqa: E402

WORKER = ROOT / "benchmarks" / "mcmc_worker.py"
CASES = ["quickstart", "waveform120"]
RECIPES = ["pohl_amplitudes", "pohl_tracker"]


def _load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def _quickstart_command(folder: Path | None, moves: str | None, work: Path, tag: str) -> float:
    """Wall seconds of ``escfit fit fits/monday_unit3.toml --report`` (interpreter start to exit)."""
    out, report = work / f"{tag}.h5", work / f"{tag}.html"
    env = {**os.environ, "PYTHONPATH": str(folder or ROOT), "ESCFIT_QUIET_COMPILE": "1"}
    recipe = ROOT / "fits" / "monday_unit3.toml"
    if moves:  # the recipe as the previous version shipped it: its moves, the same data and scene
        text = recipe.read_text()
        for key in ("data", "scene"):
            rel = tomllib.loads(text)[key]
            text = text.replace(f'"{rel}"', json.dumps(str((recipe.parent / rel).resolve())))
        recipe = work / "monday_unit3_previous.toml"
        recipe.write_text("\n".join(ln if not ln.startswith("moves") else f'moves = "{moves}"'
                                     for ln in text.splitlines()) + "\n")
    cmd = [sys.executable, "-m", "escfit.cli.main", "fit", str(recipe), "--out", str(out), "--report", str(report),
           "--quiet", "--force"]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=work)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"the quick start failed under {folder or ROOT}:\n{proc.stderr[-2000:]}")
    return wall


def agreement(old: dict, new: dict) -> dict:
    """Median shift (posterior sds of the previous run) and 90 % interval width change, per parameter."""
    out = {}
    for name, q in new["quantiles"].items():
        p = old["quantiles"].get(name)
        if p is None:
            continue
        sd = old["sd"][name]
        width_old, width_new = p["q95"] - p["q05"], q["q95"] - q["q05"]
        out[name] = {"median_shift_sd": (q["q50"] - p["q50"]) / sd if sd > 0 else float("nan"),
                     "width90_change": width_new / width_old - 1.0 if width_old > 0 else float("nan"),
                     "q05_shift_width": (q["q05"] - p["q05"]) / width_old if width_old > 0 else float("nan"),
                     "q95_shift_width": (q["q95"] - p["q95"]) / width_old if width_old > 0 else float("nan")}
    return out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default="9f98f15", help="the previous version (git revision)")
    ap.add_argument("--repeat", type=int, default=2, help="timings of the quick start's whole command")
    ap.add_argument("--recipes", action="store_true", help="also the two real-data emcee recipes (long)")
    ap.add_argument("--same-moves", action="store_true", help="also this checkout with the previous moves (de)")
    ap.add_argument("--cases", nargs="*", default=None,
                    help=f"subset of {CASES + RECIPES}, or any emcee recipe of fits/real/ by name")
    ap.add_argument("--moves", default="de-t", help="this checkout's moves (de: the previous version's own, which "
                                                    "leaves the cost per step as the only difference)")
    ap.add_argument("--out-dir", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--name", default="mcmc_speed", help="file name of the results (NAME.md, NAME.json)")
    args = ap.parse_args(argv)
    prev = checkout(args.baseline)
    cases = args.cases or (CASES + (RECIPES if args.recipes else []))
    record: dict = {"baseline": args.baseline, "load_before": _load(), "cpus": os.cpu_count(), "cases": {},
                    "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
    with tempfile.TemporaryDirectory(prefix="escfit-mcmc-speed-") as tmp:
        work = Path(tmp)
        if "quickstart" in cases and args.repeat > 0:
            timings = {"previous (de)": [], "current (de-t)": []}
            for i in range(args.repeat):  # alternating, so both see the same load
                timings["previous (de)"].append(_quickstart_command(prev, "de", work, f"prev{i}"))
                timings["current (de-t)"].append(_quickstart_command(None, None, work, f"cur{i}"))
            record["quickstart_command"] = timings
            print("quick start command (s): " + ", ".join(f"{k} {statistics.median(v):.1f} (min {min(v):.1f})"
                                                          for k, v in timings.items()), flush=True)
        for case in cases:
            runs = {"previous (de)": run_in(prev, WORKER, [case, "de", str(work)])}
            if args.same_moves and args.moves != "de":
                runs["current (de)"] = run_in(None, WORKER, [case, "de", str(work)])
            current = f"current ({args.moves})"
            runs[current] = run_in(None, WORKER, [case, args.moves, str(work)])
            record["cases"][case] = {"runs": runs, "agreement": agreement(runs["previous (de)"], runs[current])}
            _print_case(case, record["cases"][case])
            _write(record, args.out_dir, args.name)  # each case as it ends: a long run stopped early keeps the others
    _write(record, args.out_dir, args.name)
    return record


def _write(record: dict, out_dir: Path, name: str) -> None:
    record["load_after"] = _load()
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / f"{name}.json").write_text(json.dumps(record, indent=1))
    (out_dir / f"{name}.md").write_text(markdown(record))


def _row(label: str, r: dict) -> str:
    cpu = f"{1e3 * r['cpu_s_per_step']:.2f}" if "cpu_s_per_step" in r else "-"
    return (f"| {label} | {r['steps']} | {r['sampling_s']:.1f} | {1e3 * r['s_per_step']:.2f} | {cpu} | {r['tau_max']:.1f} | "
            f"{r['tau_per_s']:.1f} | {r['ess_per_s']:.0f} | {r['rhat_max']:.3f} | {r['ess_min']:.0f} | "
            f"{r['acceptance']:.2f} |")


def _print_case(case: str, data: dict) -> None:
    print(f"\n{case}")
    for label, r in data["runs"].items():
        print(f"  {label:16s} {r['steps']:6d} steps  {r['sampling_s']:7.1f} s  {1e3 * r['s_per_step']:6.2f} ms/step  "
              f"tau {r['tau_max']:5.1f}  tau/s {r['tau_per_s']:6.1f}  draws/s {r['ess_per_s']:6.0f}  "
              f"R-hat {r['rhat_max']:.3f}  ESS {r['ess_min']:.0f}")
    worst = max(abs(a["median_shift_sd"]) for a in data["agreement"].values())
    wid = max(abs(a["width90_change"]) for a in data["agreement"].values())
    print(f"  new vs previous: largest median shift {worst:.3f} sd, largest 90 % width change {100 * wid:.1f} %",
          flush=True)


def markdown(record: dict) -> str:
    lines = [f"emcee speed, `python benchmarks/mcmc_speed.py` on {record['date']} ({record['cpus']} processors, load "
             f"average {record['load_before']} before, {record['load_after']} after); previous version "
             f"{record['baseline']}.", "",
             "| case, version (moves) | steps | sampling s | ms/step | CPU ms/step | max tau | tau/s | draws/s | "
             "max R-hat | min ESS | acceptance |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for case, data in record["cases"].items():
        for label, r in data["runs"].items():
            lines.append(_row(f"{case}, {label}", r))
    lines += ["", "Posterior of the current version against the previous one (shift of the median in posterior "
              "standard deviations; change of the 90 % interval's width):", "",
              "| case | parameter | median shift (sd) | 90 % width change |", "|---|---|---:|---:|"]
    for case, data in record["cases"].items():
        for name, a in data["agreement"].items():
            lines.append(f"| {case} | {name} | {a['median_shift_sd']:+.3f} | {100 * a['width90_change']:+.1f} % |")
    if "quickstart_command" in record:
        lines += ["", "The quick start's whole command, warm (`escfit fit fits/monday_unit3.toml --report ...`), s:", ""]
        for k, v in record["quickstart_command"].items():
            lines.append(f"- {k}: median {statistics.median(v):.1f}, runs {', '.join(f'{x:.1f}' for x in v)}")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
