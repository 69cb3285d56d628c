"""Start-up of the command line: this checkout against the previous version, in one run.

Run from a checkout:  python benchmarks/startup.py [--baseline REV] [--repeat N] [--out-dir DIR]

Times, each the shortest of ``--repeat`` fresh processes (warm: numba's cache and the OS's file
cache filled by a first, untimed run), for the previous version (git revision ``--baseline``,
see ``benchmarks/previous.py``) and this checkout:

* ``escfit --help`` and ``escfit fit --help`` (``python -m escfit.cli.main``);
* ``escfit fit fits/real/string_pendulum_lab1.toml`` up to its first model evaluation
  (``benchmarks/startup_probe.py``): imports, reading the record, building the problem;
* ``import escfit.inference.fit`` alone, and which heavy libraries it leaves unimported.

Printed and written to ``startup.md`` / ``startup.json``.  The machine's load average is
recorded: on a shared machine the figures of one run are comparable with each other only.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from previous import ROOT, checkout  # noqa: E402

RECIPE = ROOT / "fits" / "real" / "string_pendulum_lab1.toml"
PROBE = ROOT / "benchmarks" / "startup_probe.py"
BASELINE = "9f98f15"
HEAVY = ("xarray", "h5py", "scipy.stats", "lmfit", "emcee", "arviz", "matplotlib", "pandas", "scipy.signal")
IMPORTS = ("import sys, time; t = time.perf_counter(); import escfit.inference.fit; "
           "print(time.perf_counter() - t, ' '.join(m for m in %r if m in sys.modules))" % (HEAVY,))


def _env(folder: Path | None) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(folder or ROOT)
    env.setdefault("ESCFIT_QUIET_COMPILE", "1")
    return env


def wall(cmd: list[str], folder: Path | None) -> float:
    clock = time.perf_counter()
    subprocess.run(cmd, env=_env(folder), cwd=folder or ROOT, check=True, capture_output=True)
    return time.perf_counter() - clock


def first_evaluation(folder: Path | None) -> float:
    res = subprocess.run([sys.executable, str(PROBE), str(RECIPE), repr(time.time())], env=_env(folder),
                         cwd=folder or ROOT, check=True, capture_output=True, text=True)
    return float(json.loads(res.stdout.strip().splitlines()[-1])["first_evaluation_s"])


def imports(folder: Path | None) -> tuple[float, str]:
    res = subprocess.run([sys.executable, "-c", IMPORTS], env=_env(folder), cwd=folder or ROOT, check=True,
                         capture_output=True, text=True)
    seconds, *loaded = res.stdout.strip().splitlines()[-1].split()
    return float(seconds), ", ".join(loaded)


def measure(folder: Path | None, repeat: int) -> dict:
    cli = [sys.executable, "-m", "escfit.cli.main"]
    first_evaluation(folder)  # warm: numba's cache, the file cache
    out = {"help_s": min(wall(cli + ["--help"], folder) for _ in range(repeat)),
           "fit_help_s": min(wall(cli + ["fit", "--help"], folder) for _ in range(repeat)),
           "first_evaluation_s": min(first_evaluation(folder) for _ in range(repeat))}
    runs = [imports(folder) for _ in range(repeat)]
    out["import_fit_s"] = min(r[0] for r in runs)
    out["heavy_loaded_by_import"] = runs[0][1]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default=BASELINE)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out-dir", default=str(ROOT / "benchmarks" / "results"))
    args = ap.parse_args()
    folder = checkout(args.baseline)
    load = os.getloadavg()
    old = measure(folder, args.repeat)
    new = measure(None, args.repeat)
    record = {"baseline": args.baseline, "repeat": args.repeat, "cpus": os.cpu_count(), "load_average_before": load,
              "load_average_after": os.getloadavg(), "previous": old, "current": new}
    rows = [("escfit --help", "help_s"), ("escfit fit --help", "fit_help_s"),
            ("escfit fit string_pendulum_lab1.toml: to the first model evaluation", "first_evaluation_s"),
            ("import escfit.inference.fit", "import_fit_s")]
    lines = [f"Start-up, warm, shortest of {args.repeat} runs; load average {load[0]:.1f} before / "
             f"{os.getloadavg()[0]:.1f} after on {os.cpu_count()} CPUs:", "",
             f"| step | previous ({args.baseline}) s | current s | ratio |", "| --- | ---: | ---: | ---: |"]
    for label, key in rows:
        lines.append(f"| {label} | {old[key]:.2f} | {new[key]:.2f} | {old[key] / new[key]:.2f}x |")
    lines += ["", f"heavy libraries `import escfit.inference.fit` loads: previous "
              f"{old['heavy_loaded_by_import'] or 'none'}; current {new['heavy_loaded_by_import'] or 'none'}"]
    text = "\n".join(lines) + "\n"
    print(text)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "startup.md").write_text(text)
    (out / "startup.json").write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
