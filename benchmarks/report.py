"""The HTML report's cost, against an earlier version in the same run.

For each results file, ``make_report`` is timed in a fresh Python process for the current
checkout and for an earlier revision (extracted with ``git archive``), in two settings:

* ``after fit``: the modules a finished ``escfit fit`` has loaded are imported first (escfit's
  command line and fit, R-hat and ESS computed once on a small chain, which imports what the
  revision uses for them: ArviZ with its plotting layer and matplotlib up to 18d2cf5, arviz-stats
  after it, and the results file read once), as in ``escfit fit ... --report``; then
  ``make_report`` is timed;
* ``escfit report``: the whole ``python -m escfit report`` process, interpreter start to exit.

The runs of the two versions alternate (baseline, current, baseline, ...) so that a change in
the machine's load touches both.  Medians and minima of ``--repeat`` runs, the ratio of medians,
the report's bytes and its largest embedded PNG are printed, with the load average before and
after.

The results files: ``--results`` files, and unless ``--no-default``, fits made here with the
current checkout: the quick start (``fits/monday_unit3.toml``, emcee, 5 parameters), the string
pendulum record by least squares (``fits/real/string_pendulum_lab1.toml``, a 2327-sample
waveform, no posterior) and Pohl's wheel tracked on video by emcee with a fixed 1500 steps
(``fits/real/pohl_tracker.toml --steps 1500``, a waveform, 9 parameters).

Usage (from the repository root)::

    python benchmarks/report.py [--baseline 18d2cf5] [--repeat 3] [--results fit.h5 ...] [--json out.json]
"""

from __future__ import annotations

import argparse
import base64
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from quickstart import ROOT, _extract, _load  # noqa: E402  (the same revision extraction and load average)

AFTER_FIT = r"""
import sys, time
import escfit
assert escfit.__file__.startswith(sys.argv[3]), (escfit.__file__, sys.argv[3])
import numpy as np
import escfit.cli.main, escfit.inference.fit
from escfit.inference.convergence import assess
assess(np.random.default_rng(0).normal(size=(40, 8, 2)))  # R-hat and ESS: whatever the revision imports for them
from escfit.results import load_fit
load_fit(sys.argv[1])  # the fit wrote it: xarray and h5netcdf are warm
import escfit.report
make_report = sys.modules["escfit.report"].make_report
t = time.perf_counter()
make_report(sys.argv[1], sys.argv[2], force=True)
print("SECONDS", time.perf_counter() - t)
"""

DEFAULT_FITS = {
    "quick start (monday_unit3, emcee)": ["fits/monday_unit3.toml"],
    "string pendulum lab1 (waveform, leastsq)": ["fits/real/string_pendulum_lab1.toml", "--method", "leastsq"],
    "Pohl tracker (waveform, emcee 1500 steps)": ["fits/real/pohl_tracker.toml", "--steps", "1500"],
}


def _env(root: Path) -> dict:
    return {**os.environ, "PYTHONPATH": str(root)}


def _fit(args: list[str], out: Path) -> Path:
    proc = subprocess.run([sys.executable, "-m", "escfit", "fit", *args, "--out", str(out), "--quiet", "--force"],
                          cwd=ROOT, env=_env(ROOT), capture_output=True, text=True)
    if not out.exists():
        raise SystemExit(f"the fit {' '.join(args)} failed (exit {proc.returncode}):\n{proc.stderr[-2000:]}")
    return out


def _sizes(page: Path) -> tuple[int, int]:
    text = page.read_text(encoding="utf-8")
    images = [len(base64.b64decode(b)) for b in re.findall(r"base64,([A-Za-z0-9+/=]+)", text)]
    return len(text.encode()), max(images, default=0)


def _time(root: Path, results: Path, page: Path, mode: str) -> float:
    page.unlink(missing_ok=True)
    if mode == "after fit":
        proc = subprocess.run([sys.executable, "-c", AFTER_FIT, str(results), str(page), str(root)], env=_env(root),
                              capture_output=True, text=True, cwd=page.parent)  # not a checkout: "" leads sys.path
        found = [ln for ln in proc.stdout.splitlines() if ln.startswith("SECONDS ")]
        if proc.returncode or not found:
            raise SystemExit(f"{root}: the report of {results} failed:\n{proc.stderr[-2000:]}")
        return float(found[0].split()[1])
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "escfit", "report", str(results), "--out", str(page), "--force"],
                          env=_env(root), capture_output=True, text=True, cwd=page.parent)
    if proc.returncode:
        raise SystemExit(f"{root}: escfit report {results} failed:\n{proc.stderr[-2000:]}")
    return time.perf_counter() - start


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default="18d2cf5", help="earlier revision to compare with (git)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--results", nargs="*", default=[], help="more results files to report on")
    ap.add_argument("--no-default", action="store_true", help="only the --results files (no fits made here)")
    ap.add_argument("--json", default=None, help="write the figures to this file")
    ap.add_argument("--force", action="store_true", help="replace an existing --json file")
    args = ap.parse_args(argv)
    if args.json and Path(args.json).exists() and not args.force:
        ap.error(f"{args.json} exists; pass --force to replace it")
    records: dict = {"baseline": args.baseline, "load_before": _load(), "rows": []}
    with tempfile.TemporaryDirectory(prefix="escfit-report-bench-") as tmp:
        tmp = Path(tmp)
        (tmp / "baseline").mkdir()
        roots = {"baseline": _extract(args.baseline, tmp / "baseline"), "current": ROOT}
        files = {} if args.no_default else {name: _fit(fit, tmp / f"fit{i}.h5")
                                            for i, (name, fit) in enumerate(DEFAULT_FITS.items())}
        files.update({Path(f).name: Path(f).resolve() for f in args.results})
        for name, results in files.items():
            for mode in ("after fit", "escfit report"):
                times: dict[str, list[float]] = {"baseline": [], "current": []}
                for _ in range(args.repeat):
                    for label, root in roots.items():
                        times[label].append(_time(root, results, tmp / f"{label}.html", mode))
                sizes = {label: _sizes(tmp / f"{label}.html") for label in roots}
                records["rows"].append({"results": name, "mode": mode, "seconds": times, "bytes": sizes})
    records["load_after"] = _load()
    _print(records)
    if args.json:
        Path(args.json).write_text(json.dumps(records, indent=1))
    return records


def _print(records: dict) -> None:
    print(f"HTML report: baseline {records['baseline']} vs current checkout; load average before "
          f"{records['load_before']}, after {records['load_after']}")
    print("results".ljust(44) + "setting".ljust(15) + "baseline s (min/med)".rjust(22) + "current s (min/med)".rjust(22)
          + "old/new".rjust(9) + "   page kB old/new, largest PNG kB old/new")
    for row in records["rows"]:
        t = row["seconds"]
        cells = [f"{min(t[k]):.2f} / {statistics.median(t[k]):.2f}".rjust(22) for k in ("baseline", "current")]
        ratio = statistics.median(t["baseline"]) / statistics.median(t["current"])
        (page_old, png_old), (page_new, png_new) = row["bytes"]["baseline"], row["bytes"]["current"]
        print(row["results"][:43].ljust(44) + row["mode"].ljust(15) + "".join(cells) + f"{ratio:.1f}x".rjust(9)
              + f"   {page_old / 1e3:.0f} / {page_new / 1e3:.0f}, {png_old / 1e3:.0f} / {png_new / 1e3:.0f}")


if __name__ == "__main__":
    main()
