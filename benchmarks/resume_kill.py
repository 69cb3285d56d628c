"""Kill an emcee fit at random moments with SIGKILL, resume it, and compare with an uninterrupted run.

For each trial the CLI fit ``escfit fit fits/monday_unit4.toml`` (frequent checkpoint saves so
that kills land between saves, during saves and during the least-squares start) is started
and killed with ``kill -9``, then continued with ``--resume`` (or started again when it died
before its first save) until it finishes.  The run length is fixed (``--steps N``) or set by
convergence (``--steps auto``, capped by ``--max-steps``); ``--length mixed`` alternates the two,
each compared with its own uninterrupted reference.  The trials take turns between three kinds
of kill moment (``--mode mixed``; or one kind for all):

* ``random``: a uniformly random delay within the length of an uninterrupted run;
* ``checkpoint``: while a checkpoint save is under way (its temporary ``.fit.h5.emcee.*.part``
  exists: inside the HDF5 write or before its rename), after a random number of earlier saves;
* ``final``: while the results file is being written (its temporary ``.fit.h5.*.part`` exists:
  inside the write or before the final rename).

The last two are found by polling the output folder every 0.2 ms.  Checked per trial:

* the draw count of the results file is exactly the requested one (an automatic run: exactly
  the uninterrupted run's);
* every posterior draw is bit-identical to the uninterrupted run with the same seed;
* the results file is whole: it loads, and every checksummed variable reads back (a corrupt
  final file would fail its Fletcher-32 checks);
* nothing is left in the output folder but the results file (no checkpoint, no ``.part``, no
  lock).

Usage (from the repository root)::

    python benchmarks/resume_kill.py [--trials 24] [--mode mixed] [--length mixed] [--steps 1500]
        [--max-steps 6000] [--seed 0] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RECIPE = ROOT / "fits" / "monday_unit4.toml"


def _cmd(out: Path, steps: int | str, every: float, *extra: str, max_steps: int = 6000) -> list[str]:
    length = ["--steps", str(steps)] + (["--max-steps", str(max_steps)] if steps == "auto" else [])
    return [sys.executable, "-c", "from escfit.cli.main import main; main()", "fit", str(RECIPE), "--out", str(out),
            *length, "--walkers", "32", "--seed", "5", "--checkpoint-every", str(every), "--quiet", *extra]


def _whole(path: Path) -> bool:
    """Whether the results file reads back completely (every variable of every group, checksums
    verified by HDF5 on the way)."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            def visit(_name, obj):
                if isinstance(obj, h5py.Dataset):
                    obj[()]
            f.visititems(visit)
        return True
    except (OSError, ValueError, KeyError):
        return False


def _draws(path: Path) -> dict[str, np.ndarray]:
    from escfit.results import load_fit

    res = load_fit(path)
    post = res.group("posterior")
    return {n: post[n].values for n in res.parameter_names}


def _saved_steps(ck: Path) -> int:
    import h5py

    try:
        with h5py.File(ck, "r") as f:
            return int(f["chain"].shape[0])
    except (OSError, KeyError):
        return -1


def _kill_during(proc: subprocess.Popen, folder: Path, kind: str, skip: int, limit: float) -> tuple[bool, float, str]:
    """Kill ``proc`` while a temporary file of ``kind`` ("checkpoint" or "final") is present.

    ``skip`` saves are let through first.  Returns whether it was killed inside such a write,
    the time of the kill (s after the start) and the temporary file seen.
    """
    t0 = time.perf_counter()
    seen: set[str] = set()
    while proc.poll() is None and time.perf_counter() - t0 < limit:
        for name in os.listdir(folder):
            if not name.endswith(".part"):
                continue
            is_ck = name.startswith(".fit.h5.emcee.")
            if (kind == "checkpoint") != is_ck or (kind == "final" and not name.startswith(".fit.h5.")):
                continue
            if name in seen:
                continue
            seen.add(name)
            if len(seen) > skip:
                os.kill(proc.pid, signal.SIGKILL)
                return True, time.perf_counter() - t0, name
        time.sleep(0.0002)
    return False, time.perf_counter() - t0, ""


def _reference(tmp: Path, name: str, steps, args) -> tuple[dict, float, int]:
    """Two uninterrupted runs (their draws must be identical): the draws, the faster time, the steps."""
    times, draws = [], []
    for k in range(2):
        ref = tmp / f"{name}{k}" / "fit.h5"
        ref.parent.mkdir()
        t0 = time.perf_counter()
        subprocess.run(_cmd(ref, steps, args.every, max_steps=args.max_steps), check=True, capture_output=True)
        times.append(time.perf_counter() - t0)
        draws.append(_draws(ref))
    assert all(np.array_equal(draws[0][n], draws[1][n]) for n in draws[0]), f"two uninterrupted {name} runs differ"
    from escfit.results import load_fit

    total = int(load_fit(tmp / f"{name}0" / "fit.h5").attrs["steps"])
    print(f"uninterrupted {name} runs: {times[0]:.1f} s and {times[1]:.1f} s (identical draws), {total} steps")
    return draws[0], 0.9 * min(times), total


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=24)
    ap.add_argument("--mode", choices=["mixed", "random", "checkpoint", "final"], default="mixed")
    ap.add_argument("--length", choices=["mixed", "fixed", "auto"], default="mixed",
                    help="run length: --steps N, --steps auto (until converged), or trials alternating the two")
    ap.add_argument("--steps", type=int, default=1500, help="steps of a fixed-length run")
    ap.add_argument("--max-steps", type=int, default=6000, help="cap of an automatic run")
    ap.add_argument("--every", type=float, default=0.5, help="checkpoint interval, s")
    ap.add_argument("--seed", type=int, default=0, help="seeds the kill times")
    ap.add_argument("--json", default=None, help="write the trials as JSON here (refused if it exists, unless --force)")
    ap.add_argument("--force", action="store_true")
    args = ap.parse_args(argv)
    if args.json and Path(args.json).exists() and not args.force:
        ap.error(f"{args.json} exists; pass --force to replace it")
    rng = random.Random(args.seed)
    rows = []
    lengths = ["fixed", "auto"] if args.length == "mixed" else [args.length]
    with tempfile.TemporaryDirectory(prefix="escfit-kill-") as tmp:
        tmp = Path(tmp)
        refs = {name: _reference(tmp, name, args.steps if name == "fixed" else "auto", args) for name in lengths}
        print(f"kills drawn uniformly in [0.5, 0.9 x the faster reference] s; load average {os.getloadavg()}")
        for trial in range(args.trials):
            length = lengths[trial % len(lengths)]
            reference, t_ref, total = refs[length]
            steps = args.steps if length == "fixed" else "auto"
            folder = tmp / f"trial{trial}"
            folder.mkdir()
            out, ck = folder / "fit.h5", folder / "fit.h5.emcee"
            mode = args.mode if args.mode != "mixed" else ("random", "checkpoint", "final")[(trial // len(lengths)) % 3]
            cmd = _cmd(out, steps, args.every, max_steps=args.max_steps)
            proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            seen = ""
            if mode == "random":
                delay = rng.uniform(0.5, t_ref)
                time.sleep(delay)
                killed = proc.poll() is None
                if killed:
                    os.kill(proc.pid, signal.SIGKILL)
            else:
                skip = rng.randrange(0, 8) if mode == "checkpoint" else 0
                killed, delay, seen = _kill_during(proc, folder, mode, skip, 3 * t_ref + 30)
            proc.wait()
            saved = _saved_steps(ck) if ck.exists() else 0
            runs = 0
            while not out.exists() and runs < 5:
                extra = ("--resume",) if ck.exists() else ()
                r = subprocess.run(_cmd(out, steps, args.every, *extra, max_steps=args.max_steps), capture_output=True,
                                   text=True)
                runs += 1
                if r.returncode != 0 and not out.exists():
                    print(f"trial {trial}: resume failed: {r.stdout[-300:]} {r.stderr[-300:]}")
                    break
            whole = out.exists() and _whole(out)
            got = _draws(out) if whole else {}
            same = bool(got) and all(np.array_equal(got[n], reference[n]) for n in reference)
            from escfit.results import load_fit

            steps_done = int(load_fit(out).attrs["steps"]) if whole else 0
            count = int(next(iter(got.values())).shape[1]) if got else 0
            stray = sorted(p.name for p in folder.iterdir() if p.name != "fit.h5")
            rows.append({"trial": trial, "length": length, "mode": mode, "inside": seen, "kill_after_s": round(delay, 2),
                         "killed": killed, "steps_saved": saved, "steps": steps_done, "exact_steps": steps_done == total,
                         "draws_per_walker": count, "whole_file": whole, "identical": same, "stray_files": stray})
            print(f"trial {trial:2d} ({length}, {mode}{': inside ' + seen if seen else ''}): kill after {delay:5.2f} s "
                  f"({'killed' if killed else 'had finished'}), checkpoint held {saved:5d} steps; resumed -> {steps_done} "
                  f"steps ({'as asked' if steps_done == total else 'NOT ' + str(total)}), {count} draws per walker, "
                  f"whole file: {whole}, identical to the uninterrupted run: {same}, stray files: {stray or 'none'}")
    ok = all(r["identical"] and r["whole_file"] and r["exact_steps"] and not r["stray_files"] for r in rows)
    for length in lengths:
        for mode in ("random", "checkpoint", "final"):
            sub = [r for r in rows if r["mode"] == mode and r["length"] == length]
            if sub:
                print(f"  {length} length, {mode}: {len(sub)} trials, {sum(r['killed'] for r in sub)} killed, "
                      f"{sum(r['identical'] for r in sub)} identical, {sum(r['exact_steps'] for r in sub)} of the asked "
                      f"length, {sum(not r['stray_files'] for r in sub)} clean")
    print(f"{sum(r['killed'] for r in rows)}/{len(rows)} killed, {sum(r['identical'] for r in rows)}/{len(rows)} "
          f"identical, {sum(r['whole_file'] for r in rows)}/{len(rows)} whole, "
          f"{sum(not r['stray_files'] for r in rows)}/{len(rows)} clean; all good: {ok}")
    record = {"steps": args.steps, "max_steps": args.max_steps, "references": {k: v[2] for k, v in refs.items()},
              "trials": rows, "all_ok": ok}
    if args.json:
        Path(args.json).write_text(json.dumps(record, indent=1))
    return record


if __name__ == "__main__":
    main()
