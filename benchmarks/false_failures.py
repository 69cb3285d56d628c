"""How often would the sampler-based tests fail in another environment?  Run them with shifted seeds.

A fixed seed fixes emcee's draws only while every log-probability is computed to the same last
bit: another numpy, scipy or numba changes a rounding, one accept/reject decision flips and the
chain after it is another chain.  For a sampler-based check a new environment is therefore a
new seed.  This script runs the tests that sample (default: the files below) again and again
with every emcee seed shifted by 1, 2, ..., N (``ESCFIT_TEST_SEED_SHIFT``, see
``tests/conftest.py``) and counts the failures of each test.  With no failure in N runs the
95 % upper bound of a test's false-failure rate is 3/N; a test that fails at all is a test to
fix (a longer run, or a check whose margin is measured: see docs/testing.md).

Usage (from the repository root)::

    python benchmarks/false_failures.py [--shifts 20] [--workers 2] [--select EXPR] [--json out.json] [TEST ...]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# the default suite's tests that draw with emcee and judge the draws
SAMPLING_TESTS = [
    "tests/test_friction_family.py", "tests/test_friction_inference.py", "tests/test_friction_monday.py",
    "tests/test_fit_recovery.py", "tests/test_geneva_family.py", "tests/test_lsq_honest.py",
    "tests/test_readers_pulses.py", "tests/test_readers_timegrapher.py", "tests/test_sampler_coordinates.py",
    "tests/test_sampler_runs.py",
    "tests/test_shared_mu.py", "tests/test_table1.py", "tests/test_verge_family.py", "tests/test_verge_inference.py",
]


def run_once(tests: list[str], shift: int, workers: int, select: str | None = None) -> tuple[dict[str, str], float]:
    """One pytest run with the seeds shifted by ``shift``: outcome per test id, and seconds."""
    with tempfile.TemporaryDirectory() as tmp:
        report = Path(tmp) / "junit.xml"
        env = {**os.environ, "ESCFIT_TEST_SEED_SHIFT": str(shift), "PYTHONPATH": str(ROOT)}
        cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--junitxml={report}", *tests]
        if select:
            cmd += ["-k", select]
        if workers > 1:
            cmd[4:4] = ["-n", str(workers)]
        t0 = time.perf_counter()
        done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        seconds = time.perf_counter() - t0
        outcomes = {}
        if not report.exists():  # pytest itself died: say so, count nothing
            print(f"shift {shift}: no report (exit {done.returncode}): {done.stdout[-500:]} {done.stderr[-500:]}")
            return outcomes, seconds
        for case in ET.parse(report).getroot().iter("testcase"):
            name = f"{case.get('classname', '')}::{case.get('name')}"
            kinds = {child.tag for child in case}
            outcomes[name] = ("failed" if kinds & {"failure", "error"} else "skipped" if "skipped" in kinds
                              else "passed")
    return outcomes, seconds


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tests", nargs="*", default=SAMPLING_TESTS)
    ap.add_argument("--shifts", type=int, default=20, help="runs, with seed shifts 1..N")
    ap.add_argument("--first", type=int, default=1, help="the first shift")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--select", default="not interrupted and not resume",
                    help="pytest -k expression (default: leave out the resume tests, whose draws are compared with "
                         "their own uninterrupted runs, not judged)")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    runs: Counter = Counter()
    failures: Counter = Counter()
    failed_at: dict[str, list[int]] = {}
    for shift in range(args.first, args.first + args.shifts):
        outcomes, seconds = run_once(args.tests, shift, args.workers, args.select)
        bad = sorted(n for n, o in outcomes.items() if o == "failed")
        for name, outcome in outcomes.items():
            if outcome != "skipped":
                runs[name] += 1
            if outcome == "failed":
                failures[name] += 1
                failed_at.setdefault(name, []).append(shift)
        print(f"shift {shift}: {len(outcomes)} tests in {seconds:.0f} s, {len(bad)} failed{': ' if bad else ''}"
              f"{', '.join(bad)}", flush=True)
    n = args.shifts
    print(f"\n{len(runs)} tests x {n} seed shifts: {sum(failures.values())} failures in {sum(runs.values())} runs")
    for name in sorted(failures, key=lambda k: -failures[k]):
        print(f"  {failures[name]:3d}/{runs[name]} {name} (shifts {failed_at[name]})")
    print(f"  every other test: 0/{n}, false-failure rate below {3 / n:.2g} at 95 % confidence")
    record = {"shifts": n, "first": args.first, "runs": dict(runs), "failures": dict(failures), "failed_at": failed_at}
    if args.json:
        Path(args.json).write_text(json.dumps(record, indent=1))
    return record


if __name__ == "__main__":
    main()
