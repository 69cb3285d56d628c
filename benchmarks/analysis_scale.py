"""How the analysis of a sampled free decay scales with the record's length.

Run from a checkout:  python benchmarks/analysis_scale.py [--rows 1e5,1e6] [--baseline PATH] [--init]

Synthetic decays (a small-angle pendulum with viscous and Coulomb damping, the exact solution
half swing by half swing, sampled at ``--rate`` Hz with Gaussian reading noise ``--noise`` rad)
of each length in ``--rows`` are written as ``time_s,theta_rad`` CSV files to a temporary
folder, the damping scaled to the length so that every record is one whole decay (amplitude
0.3 rad falling to some 0.07 rad).  For each length, each phase runs in a fresh worker process
(so that its peak resident memory is its own):

* ``read``: :func:`escfit.balance.family.read_data` on the CSV (as ``escfit fit`` reads it);
* ``analysis``: :func:`escfit.analysis.recordings.turning_points.reduce_series` (``strict=False``)
  on the samples, loaded from a ``.npy`` copy: the whole record analysis up to the fit's
  inputs, the call ``escfit fit`` and ``escfit init`` make (init makes it twice);
* ``init`` (with ``--init``): ``escfit init FILE --pendulum`` as a command, under
  ``/usr/bin/time -v`` for its peak resident memory.

Each phase reports wall and CPU seconds and the process's peak resident memory (MB, imports
included; ``rss0`` is the resident memory after the imports).  Workers run under an address
space limit (``--memory-limit`` MB, default 3000) so that a runaway phase ends in a
MemoryError instead of exhausting a shared machine; ``--baseline PATH`` runs the same workers
with ``PYTHONPATH=PATH`` and prints the ratio.  Nothing is asserted: figures are printed and,
with ``--out FILE``, written as JSON.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PERIOD = 0.2  # s: 10^4 turning points per 10^6 samples at 1 kHz
AMPLITUDE = 0.3  # rad at release


def decay(rows: int, rate: float, noise: float, period: float = PERIOD, seed: int = 1):
    """Times (s) and noisy angles (rad) of a viscous + Coulomb decay released at rest from ``AMPLITUDE``.

    ``theta'' + 2 gamma theta' + omega0^2 theta = -R sign(theta')``: each half swing is a damped
    harmonic motion about ``-R sign(theta') / omega0^2``; viscous damping alone takes a third
    of the amplitude over the record, Coulomb friction another 0.03 rad.
    """
    import numpy as np

    t = np.arange(rows) / rate
    duration = rows / rate
    omega0 = 2 * math.pi / period
    gamma = math.log(3.0) / duration
    omega1 = math.sqrt(omega0**2 - gamma**2)
    half = math.pi / omega1
    n_half = int(math.ceil(duration / half)) + 1
    shift = 0.03 / (2 * n_half) * 1.0  # R / omega0^2, rad: the Coulomb loss per half swing is twice that
    shrink = math.exp(-gamma * half)
    # amplitude about the origin at the start of each half swing, and the side it starts on
    start = np.empty(n_half)
    a = AMPLITUDE
    for k in range(n_half):  # a few thousand half swings: cheap
        start[k] = a
        c = shift if a > 0 else -shift  # moving towards the centre: the friction centre is on the start side
        a = c - (a - c) * shrink
        if abs(a) <= shift:  # static friction holds it
            start[k + 1:] = a
            break
    k = np.minimum((t / half).astype(np.int64), n_half - 1)
    tau = t - k * half
    a0 = start[k]
    c = np.where(a0 > 0, shift, -shift)
    theta = c + (a0 - c) * np.exp(-gamma * tau) * (np.cos(omega1 * tau) + gamma / omega1 * np.sin(omega1 * tau))
    rng = np.random.default_rng(seed)
    return t, theta + noise * rng.standard_normal(rows)


def write_record(folder: Path, rows: int, rate: float, noise: float) -> Path:
    """The CSV (and a .npy copy of its columns) of a ``rows``-long decay; written once per folder."""
    import numpy as np

    path = folder / f"decay_{rows}.csv"
    if not path.is_file():
        t, x = decay(rows, rate, noise)
        with open(path, "w") as f:
            f.write(f"# synthetic decay: {rows} rows at {rate:g} Hz, noise {noise:g} rad\n")
            np.savetxt(f, np.column_stack([t, x]), fmt=["%.6f", "%.6f"], delimiter=",", header="time_s,theta_rad",
                       comments="")
        np.save(folder / f"decay_{rows}.npy", np.vstack([t, np.round(x, 6)]))
    return path


# -- worker: one phase in this process ------------------------------------------------------------
def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def worker(phase: str, path: Path, limit_mb: float) -> dict:
    import numpy as np

    from escfit.balance.family import read_data
    from escfit.analysis.recordings.timeseries import TimeSeries
    from escfit.analysis.recordings.turning_points import reduce_series

    import scipy.stats  # noqa: F401  (imported by the analysis; its cost is not the phase's)

    out = {"phase": phase, "rss0": _rss_mb()}
    if limit_mb > 0:
        limit = int(limit_mb * 2**20)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    if phase == "analysis":
        t, x = np.load(path.with_suffix(".npy"))
        series = TimeSeries(t, x, math.nan, str(path), "", {})
    wall, cpu = time.perf_counter(), time.process_time()
    try:
        if phase == "read":
            data = read_data(path)
            out["samples"] = int(np.asarray(data.time).size)
        else:
            tp = reduce_series(series, strict=False)
            out.update(turning_points=int(tp.count), period=tp.period, offset=tp.offset,
                       offset_rate=tp.offset_rate, offset_rate_stderr=tp.offset_rate_stderr)
    except MemoryError:
        out["error"] = "MemoryError"
    except Exception as exc:  # reported, not raised: the other phases still run
        out["error"] = f"{type(exc).__name__}: {str(exc)[:200]}"
    out["wall"] = time.perf_counter() - wall
    out["cpu"] = time.process_time() - cpu
    out["peak"] = _peak_mb()
    return out


def run_worker(phase: str, path: Path, code: Path, limit_mb: float) -> dict:
    env = {**os.environ, "PYTHONPATH": str(code), "ESCFIT_QUIET_COMPILE": "1"}
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", phase, str(path), "--memory-limit", str(limit_mb)]
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=code)
    if res.returncode != 0:
        return {"phase": phase, "error": f"exit {res.returncode}: {res.stderr.strip().splitlines()[-1:]}"}
    return json.loads(res.stdout.strip().splitlines()[-1])


def run_init(path: Path, code: Path, limit_mb: float) -> dict:
    """``escfit init FILE --pendulum`` under /usr/bin/time -v: wall, CPU and peak memory, and its exit code."""
    env = {**os.environ, "PYTHONPATH": str(code), "ESCFIT_QUIET_COMPILE": "1"}
    with tempfile.TemporaryDirectory() as tmp:
        limit = f"ulimit -v {int(limit_mb * 1024)}; " if limit_mb > 0 else ""
        cmd = (f"{limit}/usr/bin/time -v {sys.executable} -m escfit init {path} --pendulum "
               f"--out {Path(tmp) / 'scene.toml'}")
        res = subprocess.run(["bash", "-c", cmd], env=env, capture_output=True, text=True, cwd=tmp)
    fields = {}
    for line in res.stderr.splitlines():
        key, _, value = line.strip().rpartition(": ")
        fields[key] = value
    user = float(fields.get("User time (seconds)", "nan"))
    system = float(fields.get("System time (seconds)", "nan"))
    elapsed = fields.get("Elapsed (wall clock) time (h:mm:ss or m:ss)", "nan")
    parts = [float(p) for p in elapsed.split(":")] if elapsed != "nan" else [math.nan]
    wall = sum(p * 60**i for i, p in enumerate(reversed(parts)))
    out = {"phase": "init", "wall": wall, "cpu": user + system,
           "peak": float(fields.get("Maximum resident set size (kbytes)", "nan")) / 1024.0,
           "exit": res.returncode}
    if res.returncode != 0:
        tail = [ln for ln in res.stderr.splitlines() if ln.strip() and not ln.startswith("\t")]
        out["error"] = (tail[-1] if tail else "")[:200]
    return out


def measure(code: Path, paths: dict, phases: list[str], limit_mb: float) -> list[dict]:
    rows = []
    for n, path in paths.items():
        for phase in phases:
            r = run_init(path, code, limit_mb) if phase == "init" else run_worker(phase, path, code, limit_mb)
            r["rows"] = n
            rows.append(r)
            print(f"  {str(code):<28} {n:>10} {phase:<9} {_show(r)}", flush=True)
    return rows


def _show(r: dict) -> str:
    if "wall" not in r:
        return r.get("error", "?")
    text = f"wall {r['wall']:8.2f} s  cpu {r['cpu']:8.2f} s  peak {r['peak']:7.0f} MB"
    if "rss0" in r:
        text += f" (after imports {r['rss0']:.0f})"
    if "turning_points" in r:
        text += f"  {r['turning_points']} turning points"
    if r.get("error"):
        text += f"  [{r['error']}]"
    return text


def table(current: list[dict], baseline: list[dict] | None) -> str:
    """Markdown table of the phases; with a baseline, its figures and the CPU-time ratio (wall
    times on a shared machine follow its load more than the code)."""
    extra = " baseline wall s | baseline CPU s | baseline peak MB | CPU ratio |" if baseline else ""
    lines = ["| rows | phase | wall s | CPU s | peak MB |" + extra,
             "|---:|---|---:|---:|---:|" + ("---:|---:|---:|---:|" if baseline else "")]
    before = {(r["rows"], r["phase"]): r for r in (baseline or [])}
    for r in current:
        cells = [f"{r['rows']:,}", r["phase"], *(f"{r[k]:.2f}" if k in r else "-" for k in ("wall", "cpu")),
                 f"{r['peak']:.0f}" if "peak" in r else "-"]
        if r.get("error"):
            cells[1] += f" ({r['error'][:60]})"
        if baseline:
            b = before.get((r["rows"], r["phase"]), {})
            bc = f"{b['cpu']:.2f}" if "cpu" in b else "-"
            if b.get("error"):
                bc += f" ({b['error'][:40]})"
            ratio = f"{b['cpu'] / r['cpu']:.1f}x" if "cpu" in b and "cpu" in r and not b.get("error") else "-"
            cells += [f"{b['wall']:.2f}" if "wall" in b else "-", bc, f"{b['peak']:.0f}" if "peak" in b else "-", ratio]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _uptime() -> str:
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    except OSError:
        return "load average " + " ".join(f"{v:.2f}" for v in os.getloadavg())


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--rows", default="1e5,1e6", help="comma-separated record lengths (rows)")
    p.add_argument("--rate", type=float, default=1000.0, help="sampling rate, Hz")
    p.add_argument("--noise", type=float, default=1e-3, help="reading noise, rad")
    p.add_argument("--phases", default="read,analysis", help="read, analysis, init (comma-separated)")
    p.add_argument("--init", action="store_true", help="add the whole `escfit init FILE --pendulum` command")
    p.add_argument("--baseline", type=Path, default=None, help="another checkout (its folder holds escfit/)")
    p.add_argument("--memory-limit", type=float, default=3000.0, help="address space limit per worker, MB (0: none)")
    p.add_argument("--folder", type=Path, default=None, help="where the records are written (default: a temp folder)")
    p.add_argument("--out", type=Path, default=None, help="write the figures as JSON here")
    p.add_argument("--md", type=Path, default=None, help="write the command, the load and the table as Markdown here")
    p.add_argument("--worker", nargs=2, metavar=("PHASE", "FILE"), help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:
        print(json.dumps(worker(args.worker[0], Path(args.worker[1]), args.memory_limit)))
        return 0
    folder = args.folder or Path(tempfile.gettempdir()) / "escfit-analysis-scale"
    folder.mkdir(parents=True, exist_ok=True)
    phases = args.phases.split(",") + (["init"] if args.init and "init" not in args.phases else [])
    paths = {}
    for text in args.rows.split(","):
        n = int(float(text))
        clock = time.perf_counter()
        paths[n] = write_record(folder, n, args.rate, args.noise)
        print(f"record of {n} rows: {paths[n]} ({paths[n].stat().st_size / 2**20:.0f} MB, "
              f"{time.perf_counter() - clock:.1f} s to make)", flush=True)
    load = os.getloadavg()
    uptime_before = _uptime()
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} CPUs")
    current = measure(ROOT, paths, phases, args.memory_limit)
    baseline = measure(args.baseline.resolve(), paths, phases, args.memory_limit) if args.baseline else None
    text = table(current, baseline)
    print()
    print(text)
    if args.md:
        command = "python benchmarks/analysis_scale.py " + " ".join(sys.argv[1:] if argv is None else argv)
        args.md.write_text("\n".join([
            "# Analysis of a sampled decay against its length", "",
            f"Command: `{command}`", "",
            f"Machine: {os.cpu_count()} CPUs, shared; `uptime` before: {uptime_before}; after: {_uptime()}.", "",
            f"Records: {args.rate:g} Hz, noise {args.noise:g} rad, period {PERIOD} s (10^4 turning points per "
            "10^6 rows).  Peak MB: the process's peak resident memory, imports included.", "",
            text, ""]))
    if args.out:
        args.out.write_text(json.dumps({"rows": list(paths), "rate_hz": args.rate, "noise_rad": args.noise,
                                        "load_average": load, "load_average_after": os.getloadavg(),
                                        "current": current, "baseline": baseline}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
