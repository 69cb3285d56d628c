"""Artefact suite: synthetic free decays with one real-world artefact each, put through what a new
user runs, scored against the generator's truth.

For every class of :mod:`tests.artefacts.make` and every seed the record is written to a temporary
folder and run exactly as a new user would::

    escfit init FILE --pendulum
    escfit fit FILE --scene FILE.toml --out r.h5

with the code under test (``--code PATH`` puts PATH first on PYTHONPATH; default: the installed
escfit).  The records themselves are made by this process (its own escfit's forward simulator), so
every code under test sees the same files.  Each run is classified (tests/artefacts/score.py,
shared with tests/test_artefacts.py):

RIGHT
    exit 0, omega0 within 0.5 % of the truth, C and R each within the larger of 3 standard errors
    and the class's relative floor (15 %; 30 % for the wobble), and the window right (below).
WRONG-WINDOW
    the estimates are right but the window the fit used is not the true free window.
WRONG-SILENT
    exit 0 with an estimate outside its tolerance: the worst outcome (a number, no refusal).
REFUSED-WITH-REASON / REFUSED-OTHER
    exit 2 with a message that matches / does not match the reason the truth expects.
NOT-DETERMINED
    exit 3 (the fit says the data do not determine the parameters).
ERROR
    any other exit, a crash or a timeout.

The tolerances (omega0 0.5 %; C and R the larger of 3 standard errors and 15 %) and the window
rule are justified in tests/artefacts/score.py.

``--false-push N`` runs only the record analysis (``escfit init`` in process, which writes the
analysis' notes into the starter scene) on N clean decays with a 1-3 % slow amplitude wobble and
0.1-1 % noise, and counts how often it claims the record is not a free decay (a push or pull).

Usage::

    python benchmarks/artefact_suite.py --code /work/baseline --seeds 0 1 --out benchmarks/results/artefact_suite.md
    python benchmarks/artefact_suite.py --code /work/baseline --false-push 200
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.artefacts import CLASSES, make  # noqa: E402
from tests.artefacts.make import Pendulum, angle_csv, draw, free_record, grid  # noqa: E402
from tests.artefacts.score import ACCEPTS, PUSH_NOTE, classify, estimates_right, read_result  # noqa: E402

def environment(code: str | None) -> dict:
    env = dict(os.environ)
    if code:
        env["PYTHONPATH"] = str(Path(code).resolve())
    return env


def run_cli(args: list[str], cwd: Path, env: dict, timeout: float) -> tuple[int, str]:
    try:
        p = subprocess.run([sys.executable, "-m", "escfit", *args], cwd=cwd, env=env, capture_output=True,
                           text=True, timeout=timeout)
        return p.returncode, p.stdout + p.stderr
    except subprocess.TimeoutExpired:
        return -1, f"timeout after {timeout:.0f} s"


def one(name: str, seed: int, env: dict, timeout: float, periods: int | None) -> dict:
    art = make(name, seed, periods=periods)
    t0 = time.time()
    with tempfile.TemporaryDirectory(prefix=f"artefact_{name}_") as tmp:
        tmp = Path(tmp)
        data = tmp / f"{name}_{seed}.csv"
        data.write_text(art.csv)
        code, text = run_cli(["init", data.name, "--pendulum"], tmp, env, timeout)
        r, stage = None, "init"
        if code == 0:
            stage = "fit"
            scene = data.with_suffix(".toml").name
            code, text = run_cli(["fit", data.name, "--scene", scene, "--out", "r.h5"], tmp, env, timeout)
            if code == 0:
                try:
                    r = read_result(tmp / "r.h5")
                except Exception as exc:  # a file the reader cannot read is the code's failure
                    code, text = -1, f"unreadable result: {exc}"
    outcome = classify(art.truth, code, text, r)
    row = {"name": name, "seed": seed, "outcome": outcome, "exit": code, "stage": stage,
           "ok": ACCEPTS.get(outcome) in art.truth.accept, "truth": art.truth, "seconds": time.time() - t0,
           "message": _last_line(text) if r is None else "", "result": r}
    if r is not None:
        row["errors"] = estimates_right(art.truth, r)[1]
    return row


def _last_line(text: str) -> str:
    lines = [ln for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1][:200] if lines else ""


def _pct(errors: dict, key: str) -> str:
    """A relative error in per cent, or "n.d." where the fit marks it not determined (not judged)."""
    return f"{100 * errors[key]:+.1f}" if key in errors else "n.d."


def _fmt_row(row: dict) -> str:
    tr, r = row["truth"], row["result"]
    true_w = f"[{tr.t_free_start:.2f}, {tr.t_free_end:.1f}]"
    if r is None:
        return (f"| {row['name']} | {row['seed']} | {'/'.join(tr.accept)} | **{row['outcome']}** | "
                f"{'yes' if row['ok'] else 'NO'} | {true_w} | - | - | - | - | {row['message'].replace('|', '/')} |")
    e = row["errors"]
    ref = "?" if r["ref"] is None else f"{r['ref']:.2f}"
    push = next((n for n in r["notes"] if PUSH_NOTE.search(n)), "")
    return (f"| {row['name']} | {row['seed']} | {'/'.join(tr.accept)} | **{row['outcome']}** | "
            f"{'yes' if row['ok'] else 'NO'} | {true_w} | {ref} [{r['t_first']:.2f}, {r['t_last']:.1f}] | "
            f"{100 * e['omega0']:+.3f} | {_pct(e, 'C')} | {_pct(e, 'R')} | "
            f"{push[:120].replace('|', '/')} |")


def table(rows: list[dict], label: str) -> str:
    head = ("| class | seed | expected | outcome | ok | true free window (s) | fit: release [first, last] (s) "
            "| omega0 err % | C err % | R err % | note / message |\n|" + "---|" * 11)
    counts: dict[str, int] = {}
    for row in rows:
        counts[row["outcome"]] = counts.get(row["outcome"], 0) + 1
    passed = sum(row["ok"] for row in rows)
    lines = [f"## {label}", "", f"{passed} of {len(rows)} runs reach an accepted verdict; outcomes: "
             + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())), "", head]
    lines += [_fmt_row(row) for row in rows]
    lines += ["", "What each class expects:", ""]
    seen = set()
    for row in rows:
        if row["name"] not in seen:
            seen.add(row["name"])
            lines.append(f"- **{row['name']}**: {row['truth'].expect}")
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------- false pushes

WORKER = r"""
import json, sys
from pathlib import Path
from click.testing import CliRunner
from escfit.cli.main import cli
out = []
for f in sys.argv[1:]:
    toml = Path(f).with_suffix(".toml")
    r = CliRunner().invoke(cli, ["init", f, "--pendulum", "--force", "--out", str(toml)])
    head = "".join(ln for ln in toml.read_text().splitlines(True) if ln.startswith("#")) if toml.exists() else ""
    out.append({"file": f, "exit": r.exit_code, "text": r.output + head})
print(json.dumps(out))
"""


def wobbly_decay(seed: int) -> str:
    """A clean free decay with a slow 1-3 % amplitude wobble (10-30 swings) and 0.1-1 % noise."""
    p: Pendulum = draw(10_000 + seed)
    t = grid(p, p.duration)
    depth = p.rng.uniform(0.01, 0.03)
    swings = p.rng.uniform(10.0, 30.0)
    mod = 1.0 + depth * np.sin(2 * math.pi * t / (swings * p.period) + p.rng.uniform(0, 2 * math.pi))
    return angle_csv(t, mod * free_record(p, 0.0, p.a0, t) + p.sigma * p.rng.standard_normal(t.size))


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score 95 % interval of a binomial proportion k/n."""
    if n == 0:
        return 0.0, 1.0
    ph = k / n
    den = 1 + z * z / n
    mid = (ph + z * z / (2 * n)) / den
    half = z * math.sqrt(ph * (1 - ph) / n + z * z / (4 * n * n)) / den
    return max(0.0, mid - half), min(1.0, mid + half)


def false_push(n: int, env: dict, timeout: float) -> str:
    with tempfile.TemporaryDirectory(prefix="false_push_") as tmp:
        files = []
        for i in range(n):
            f = Path(tmp) / f"decay_{i}.csv"
            f.write_text(wobbly_decay(i))
            files.append(str(f))
        p = subprocess.run([sys.executable, "-c", WORKER, *files], env=env, capture_output=True, text=True,
                           timeout=timeout * max(1, n // 10))
        if p.returncode:
            raise SystemExit(p.stderr[-2000:])
        runs = json.loads(p.stdout.strip().splitlines()[-1])
    claims = [r for r in runs if PUSH_NOTE.search(r["text"])]
    errors = [r for r in runs if r["exit"] != 0]
    lo, hi = wilson(len(claims), n)
    lines = [f"false pushes: {len(claims)} of {n} clean decays with a 1-3 % wobble claimed not free "
             f"(rate {len(claims) / n:.3f}, 95 % interval [{lo:.3f}, {hi:.3f}]); {len(errors)} refused by init"]
    for r in claims[:5]:
        lines.append("  e.g. " + Path(r["file"]).name + ": " + next(ln for ln in r["text"].splitlines()
                                                                   if PUSH_NOTE.search(ln)).strip()[:200])
    for r in errors[:3]:
        lines.append("  refused: " + Path(r["file"]).name + ": " + _last_line(r["text"]))
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--code", help="folder put first on PYTHONPATH for the escfit under test (default: installed)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    ap.add_argument("--classes", nargs="+", default=list(CLASSES), choices=list(CLASSES))
    ap.add_argument("--periods", type=int, help="override the drawn record length (periods)")
    ap.add_argument("--timeout", type=float, default=600.0, help="per command, s")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", type=Path, help="write the table (markdown) here")
    ap.add_argument("--label", default=None)
    ap.add_argument("--false-push", type=int, metavar="N", help="only count false push claims on N clean decays")
    args = ap.parse_args(argv)
    env = environment(args.code)
    label = args.label or f"code: {args.code or 'installed escfit'}"
    if args.false_push:
        text = false_push(args.false_push, env, args.timeout)
        print(text)
        if args.out:
            with args.out.open("a") as f:
                f.write(f"\n### False pushes ({label})\n\n```\n{text}\n```\n")
        return
    jobs = [(name, seed) for name in args.classes for seed in args.seeds]
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        rows = []
        for row in pool.map(lambda j: one(*j, env, args.timeout, args.periods), jobs):
            print(f"{row['name']:>20} seed {row['seed']}: {row['outcome']:<20} ok={row['ok']} "
                  f"({row['seconds']:.0f} s) {row['message'][:100]}", flush=True)
            rows.append(row)
    text = table(rows, label)
    print(text)
    if args.out:
        raw = [{**{k: v for k, v in row.items() if k != "truth"}, "truth": asdict(row["truth"])} for row in rows]
        args.out.with_suffix(".json").write_text(json.dumps(raw, indent=1, default=float))
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(f"# Artefact suite\n\nCommand: `python benchmarks/artefact_suite.py "
                            f"{' '.join(sys.argv[1:] if argv is None else argv)}`\n\n" + text)


if __name__ == "__main__":
    main()
