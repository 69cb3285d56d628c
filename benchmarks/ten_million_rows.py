"""A record of 10^7 rows: refused, or analysed, within 2 GB of memory.

Run from a checkout:  python benchmarks/ten_million_rows.py [--rows 1e7] [--ceiling-mb 2048] [--folder DIR]

The record is the synthetic sampled decay of ``benchmarks/analysis_scale.py`` (a small-angle
pendulum with viscous and Coulomb damping sampled at 1 kHz with 1 mrad reading noise, period
0.2 s: 10^5 turning points in 10^7 rows, a CSV of some 180 MB), written once into ``--folder``.
The user's commands then run on it, each in a fresh process started by a small runner process
that reads the command's peak resident memory with ``resource.getrusage(RUSAGE_CHILDREN)``
once it has ended:

* ``escfit init FILE --pendulum --out scene.toml`` (reads and analyses the record, writes a scene);
* ``escfit fit FILE --scene scene.toml --out fit.h5`` (when init wrote the scene).

Each runs under an address-space limit (``--limit-mb``, default 4096) so that a runaway ends in
a MemoryError instead of exhausting a shared machine.  Printed per command: exit status, wall
and CPU seconds, peak resident memory (MB, interpreter and imports included), whether it stayed
within ``--ceiling-mb`` (default 2048), and the command's last line on stderr (a refusal says
why).  Nothing is asserted; ``--md FILE`` writes the command line, the load and the table.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from analysis_scale import write_record  # noqa: E402  (the same synthetic decay)

# Runs the command given as its arguments under an address-space limit and prints, as JSON, its
# exit status, wall and CPU seconds and peak resident memory (getrusage of the ended child).
RUNNER = r"""
import json, resource, subprocess, sys, time
limit = int(sys.argv[1]) << 20
def cap():
    if limit > 0:
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
wall = time.perf_counter()
r = subprocess.run(sys.argv[2:], preexec_fn=cap, capture_output=True, text=True)
wall = time.perf_counter() - wall
use = resource.getrusage(resource.RUSAGE_CHILDREN)
lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
print(json.dumps({"exit": r.returncode, "wall": wall, "cpu": use.ru_utime + use.ru_stime,
                  "peak_mb": use.ru_maxrss / 1024.0, "said": lines[-1][:300] if lines else ""}))
"""


def run(args: list[str], cwd: Path, limit_mb: int) -> dict:
    """One escfit command in a fresh process, measured by the runner."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "ESCFIT_QUIET_COMPILE": "1"}
    cmd = [sys.executable, "-c", RUNNER, str(limit_mb), sys.executable, "-m", "escfit", *args]
    res = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd, env=env)
    if res.returncode != 0:
        return {"exit": None, "said": res.stderr.strip()[-300:]}
    return json.loads(res.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--rows", type=float, default=1e7)
    p.add_argument("--ceiling-mb", type=float, default=2048.0, help="the memory the commands must stay within")
    p.add_argument("--limit-mb", type=int, default=4096, help="address-space limit of each command (0: none)")
    p.add_argument("--folder", type=Path, default=None, help="where the record is kept (default: a temp folder)")
    p.add_argument("--md", type=Path, default=None, help="write the command, the load and the table as Markdown")
    args = p.parse_args(argv)
    rows = int(args.rows)
    folder = args.folder or Path(tempfile.gettempdir()) / "escfit-analysis-scale"
    folder.mkdir(parents=True, exist_ok=True)
    clock = time.perf_counter()
    record = write_record(folder, rows, 1000.0, 1e-3)
    print(f"record of {rows:,} rows: {record} ({record.stat().st_size / 1e6:.0f} MB; {time.perf_counter() - clock:.0f} s "
          "to make or find)", flush=True)
    load = os.getloadavg()
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        steps = [("init", ["init", str(record), "--pendulum", "--out", "scene.toml"]),
                 ("fit", ["fit", str(record), "--scene", "scene.toml", "--out", "fit.h5", "--quiet"])]
        for name, cmd in steps:
            if name == "fit" and not (work / "scene.toml").is_file():
                results.append({"command": name, "said": "not run: init wrote no scene"})
                continue
            r = {"command": name, **run(cmd, work, args.limit_mb)}
            results.append(r)
            print(f"  {name:<5} {_row(r, args.ceiling_mb)}", flush=True)
    head = "| command | exit | wall s | CPU s | peak MB | within {:.0f} MB | last line on stderr |".format(args.ceiling_mb)
    lines = [head, "|---|---:|---:|---:|---:|---|---|"]
    for r in results:
        if "peak_mb" not in r:
            lines.append(f"| {r['command']} | - | - | - | - | - | {r.get('said', '')} |")
            continue
        within = "yes" if r["peak_mb"] <= args.ceiling_mb else "NO"
        lines.append(f"| {r['command']} | {r['exit']} | {r['wall']:.1f} | {r['cpu']:.1f} | {r['peak_mb']:.0f} | "
                     f"{within} | {r['said'].replace('|', '/')} |")
    table = "\n".join(lines)
    print()
    print(table)
    if args.md:
        command = "python benchmarks/ten_million_rows.py " + " ".join(sys.argv[1:] if argv is None else argv)
        args.md.write_text("\n".join([
            f"# A record of {rows:,} rows against a {args.ceiling_mb:.0f} MB ceiling", "",
            f"Command: `{command}`", "",
            f"Machine: {os.cpu_count()} CPUs, shared; load average before {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}, "
            f"after {' '.join(f'{v:.2f}' for v in os.getloadavg())}.", "",
            "Peak MB: the command's peak resident memory (getrusage of the ended process; interpreter and imports "
            "included).  CPU s: user + system of the command.", "", table, ""]))
    return 0


def _row(r: dict, ceiling: float) -> str:
    if "peak_mb" not in r:
        return r.get("said", "?")
    within = "within" if r["peak_mb"] <= ceiling else "ABOVE"
    return (f"exit {r['exit']}  wall {r['wall']:7.1f} s  cpu {r['cpu']:7.1f} s  peak {r['peak_mb']:6.0f} MB "
            f"({within} {ceiling:.0f} MB)  {r['said'][:120]}")


if __name__ == "__main__":
    sys.exit(main())
