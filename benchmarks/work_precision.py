"""Work-precision benchmark of the balance solvers.

Two cases: the Theory of Horology 3-2 watch balance released at 300 deg (one half swing,
``datasets/scenes/horology_rk4_case.toml``) and a Monday-like unit over 120 half swings
(``datasets/scenes/monday_unit_angle_fit.toml``).  For each solver and setting the error of
the half periods T/2 and of the amplitudes (largest over the swings) is measured against a
reference computed with mpmath at 40 significant digits, together with the CPU time per
half swing.  Methods: the exact piecewise solver (one call per run, and the batch path over
many parameter sets); RK4 with located events at h = 1e-5 ... 1e-8 s; naive RK4 that steps
over the switches; scipy ``solve_ivp`` RK45, DOP853 and Radau with located events at
rtol = 1e-3 ... 1e-12 (atol = 1e-3 * rtol).

Run:  escfit bench [--quick] [--json] [--plot FILE]
      python benchmarks/work_precision.py [--quick] [--json] [--plot FILE]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np

import escfit
from escfit.balance import System
from escfit.balance.system import Structure
from escfit.balance.batch import solve_batch
from escfit.balance.solvers import solve_system

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "datasets" / "scenes"
TARGET_T_ERROR = 1e-12  # s: "equal or better accuracy" for the speed ratio against solve_ivp
# The smallest RK4 step on the 120-swing case: h = 1e-8 s would take 2.4e9 steps (about ten
# times the 1e-7 run, over half a minute per run) and RK4 is already at round-off there.
RK4_H_FLOOR_LONG = 1e-7


@dataclass(frozen=True)
class Case:
    key: str
    title: str
    scene: str
    swings: int


CASES = (
    Case("horology", "Theory of Horology 3-2, half swing at 300 deg", "horology_rk4_case.toml", 1),
    Case("monday120", "Monday-like unit, 120 half swings", "monday_unit_angle_fit.toml", 120),
)


@dataclass
class Record:
    """One method at one setting on one case (``--json`` prints these)."""

    case: str
    method: str
    setting: str
    error_half_period_s: float | None
    error_amplitude_rad: float | None
    us_per_swing: float
    clock: str  # "cpu" (process time of one thread) or "wall" (parallel batch)
    status: str
    swings: int
    note: str = ""


# -- the reference ---------------------------------------------------------------------------

def reference(sys: System, n_swings: int, digits: int = 40) -> tuple[list, list]:
    """Half periods and amplitudes of the model to ``digits`` significant digits.

    The sequence of regions (which window edge ends each segment, or a turning point) is
    taken from the exact solver's segment log, a discrete decision far from any edge in
    these cases; every time and state is then recomputed in mpmath from the scene's
    parameters, so rounding in the float64 kernel does not reach the reference.  Only what
    the two benchmark scenes need: linear hairspring, underdamped, no banking impact.
    """
    import mpmath as mp

    tr = solve_system(sys, n_swings, "exact", dense=True)
    if tr.status not in ("ok", "banked") or tr.banked.any() or sys.field("n_pieces") > 1 or \
            len(tr.amplitude) != n_swings:
        raise RuntimeError("the reference handles unbanked runs with a linear hairspring only")
    log = tr.dense.segments
    with mp.workdps(digits):
        w2 = mp.mpf(sys.omega0) ** 2
        h = mp.mpf(sys.field("c")) / 2
        wd = mp.sqrt(w2 - h * h)
        s = 1 if sys.theta0 < 0 else -1
        x, v, t, t_last = s * mp.mpf(sys.theta0), mp.mpf(0), mp.mpf(0), mp.mpf(0)
        half, amp = [], []
        for k, row in enumerate(log):
            swing = int(row[8])
            ends_swing = k + 1 == len(log) or int(log[k + 1, 8]) != swing
            xc = _centre(sys, s, float(row[3]), None if ends_swing else float(log[k + 1, 3])) / w2
            y0 = x - xc

            def y_at(tau, y0=y0, v0=v):
                e = mp.exp(-h * tau)
                return e * (y0 * mp.cos(wd * tau) + (v0 + h * y0) * mp.sin(wd * tau) / wd)

            def v_at(tau, y0=y0, v0=v):
                e = mp.exp(-h * tau)
                return e * (v0 * mp.cos(wd * tau) - (h * v0 + w2 * y0) * mp.sin(wd * tau) / wd)

            if ends_swing:
                q = h * v + w2 * y0
                tau = mp.atan2(v * wd, q) / wd
                x, v = xc + y_at(tau), mp.mpf(0)
            else:
                target = mp.mpf(float(log[k + 1, 3])) - xc
                tau = mp.findroot(lambda u: y_at(u) - target, mp.mpf(float(row[1])))
                x, v = target + xc, v_at(tau)
            t += tau
            if ends_swing:
                half.append(t - t_last)
                amp.append(abs(x))
                t_last = t
                s, x = -s, -x
    return half, amp


def _centre(sys: System, s: int, x0: float, x_end: float | None):
    """Net constant acceleration (rad/s^2, swing frame) of the region a segment runs in."""
    import mpmath as mp

    w_lo, w_hi, w_x, w_dir = (sys.field(n) for n in ("w_lo", "w_hi", "w_x", "w_dir"))
    edges = sorted({e for lo, hi, d in zip(w_lo, w_hi, w_dir) if d in (0, s) for e in (lo, hi)})
    above = [e for e in edges if e > x0]
    mid = 0.5 * (x0 + above[0]) if above else x0 + 1.0
    if x_end is not None:
        mid = 0.5 * (x0 + x_end)
    force = -mp.mpf(sys.field("r"))
    for lo, hi, xx, d in zip(w_lo, w_hi, w_x, w_dir):
        if d in (0, s) and lo <= mid < hi:
            force += mp.mpf(xx)
    return force


def _errors(half_period, amplitude, ref_half, ref_amp) -> tuple[float | None, float | None]:
    import mpmath as mp

    if len(half_period) != len(ref_half):
        return None, None
    with mp.workdps(40):
        e_t = max(abs(mp.mpf(float(a)) - b) for a, b in zip(half_period, ref_half))
        e_a = max(abs(mp.mpf(float(a)) - b) for a, b in zip(amplitude, ref_amp))
    return float(e_t), float(e_a)


# -- timing ----------------------------------------------------------------------------------

def cpu_seconds(fn: Callable[[], object], min_time: float) -> float:
    """CPU seconds of one call of ``fn`` (repeated until ``min_time`` has been spent)."""
    total, reps = 0.0, 0
    while reps == 0 or total < min_time:
        t0 = time.process_time()
        fn()
        total += time.process_time() - t0
        reps += 1
    return total / reps


def wall_seconds(fn: Callable[[], object], min_time: float) -> float:
    """Best-of wall seconds of one call of ``fn`` (for the multithreaded batch)."""
    best, spent = math.inf, 0.0
    while spent < min_time or best == math.inf:
        t0 = time.perf_counter()
        fn()
        dt = time.perf_counter() - t0
        best, spent = min(best, dt), spent + dt
    return best


# -- the settings ----------------------------------------------------------------------------

def settings(case: Case, quick: bool) -> list[tuple[str, str, dict]]:
    """(method, setting, solver options) to run on a case."""
    hs = [1e-5, 1e-6] if quick else [1e-5, 1e-6, 1e-7, 1e-8]
    if case.swings > 1:
        hs = [h for h in hs if h >= RK4_H_FLOOR_LONG]
    rtols = {"RK45": [1e-3, 1e-6, 1e-9], "DOP853": [1e-3, 1e-6, 1e-9, 1e-10, 1e-12], "Radau": [1e-3, 1e-6]} if quick \
        else {m: [10.0**-k for k in range(3, 13)] for m in ("RK45", "DOP853", "Radau")}
    out = [("exact", "-", {"solver": "exact"})]
    for h in hs:
        out.append(("rk4", f"h={h:g} s", {"solver": "rk4", "h": h}))
    for h in hs:
        out.append(("rk4 naive", f"h={h:g} s", {"solver": "rk4", "h": h, "locate_events": False}))
    for method, rt in rtols.items():
        for r in rt:
            opts = {"solver": "ivp", "method": method, "rtol": r, "atol": 1e-3 * r}
            out.append((f"ivp {method}", f"rtol={r:g}", opts))
    return out


def run_case(case: Case, *, quick: bool = False, batch_sets: int = 1024,
             progress: Callable[[str], None] = lambda s: None) -> list[Record]:
    scene = escfit.load_scene(SCENES / case.scene)
    sys = scene.build()
    ref_half, ref_amp = reference(sys, case.swings)
    min_time = 0.02 if quick else 0.3
    records = []
    for method, setting, opts in settings(case, quick):
        opts = dict(opts)
        solver = opts.pop("solver")
        run_sys, note = sys, ""
        if method == "rk4 naive" and "impacts" in sys.needs:
            # naive RK4 cannot model banking; the reference run never reaches the pins
            k = sys.k.copy()
            k["bank"] = math.inf
            run_sys = replace(sys, k=k, structure=Structure(tuple(e for e in sys.effects if e.key != "banking"),
                                                            sys.restoring, sys.switching))
            note = "banking removed (never reached)"
        solve_system(run_sys, 1, solver, **opts)  # compile / warm up on one swing
        last = {}

        def one(run_sys=run_sys, solver=solver, opts=opts):
            last["tr"] = solve_system(run_sys, case.swings, solver, **opts)

        sec = cpu_seconds(one, min_time)
        tr = last["tr"]
        e_t, e_a = _errors(tr.half_period, tr.amplitude, ref_half, ref_amp)
        records.append(Record(case.key, method, setting, e_t, e_a, 1e6 * sec / case.swings, "cpu", tr.status,
                              case.swings, note))
        progress(f"{case.key:10s} {method:11s} {setting:12s} T/2 err {_fmt(e_t)}  {records[-1].us_per_swing:10.2f} us")
    if case.swings > 1 and not quick:
        for method in ("rk4", "rk4 naive"):
            done = next(r for r in records if r.method == method and r.setting == f"h={RK4_H_FLOOR_LONG:g} s")
            scale = RK4_H_FLOOR_LONG / 1e-8
            us = scale * done.us_per_swing
            records.append(Record(case.key, method, "h=1e-08 s", None, None, us, "estimate", "not run", case.swings,
                                  f"{us * case.swings / 1e6:.0f} s per run (10x h={RK4_H_FLOOR_LONG:g}); "
                                  "RK4 is at round-off already"))
    # the exact solver on many parameter sets per call (here copies of the case's own)
    stack = System.stack([sys] * batch_sets)
    solve_batch(stack, case.swings)
    keep = {}

    def many():
        keep["b"] = solve_batch(stack, case.swings)

    sec = wall_seconds(many, min_time)
    b = keep["b"]
    e_t, e_a = _errors(b.half_period[0], b.amplitude[0], ref_half, ref_amp)
    threads = _threads()
    records.append(Record(case.key, "exact batch", f"{batch_sets} sets, {threads} threads", e_t, e_a,
                          1e6 * sec / (batch_sets * case.swings), "wall", str(b.status[0]), case.swings))
    progress(f"{case.key:10s} exact batch  T/2 err {_fmt(e_t)}  {records[-1].us_per_swing:10.3f} us (wall)")
    return records


def batch_throughput(n_sets: int = 2048, swings: int = 120, seed: int = 0, min_time: float = 0.5) -> dict:
    """Wall and CPU time per half swing per parameter set of the batch path.

    Parameter sets are spread +-30 % around the Monday-like scene's C, R and X, as a
    sampler's walkers would be.
    """
    scene = escfit.load_scene(SCENES / "monday_unit_angle_fit.toml")
    rng = np.random.default_rng(seed)
    base = {n: scene.params[n].value for n in ("viscous.C", "coulomb.R", "escapement[2].X")}
    systems = [scene.build({k: v * rng.uniform(0.7, 1.3) for k, v in base.items()}) for _ in range(n_sets)]
    stack = System.stack(systems)
    solve_batch(stack, swings)
    wall = wall_seconds(lambda: solve_batch(stack, swings), min_time)
    cpu = cpu_seconds(lambda: solve_batch(stack, swings), min_time)
    one = cpu_seconds(lambda: solve_batch(stack, swings, threads=1), min_time)
    return {"sets": n_sets, "swings": swings, "threads": _threads(),
            "us_per_swing_per_set_wall": 1e6 * wall / (n_sets * swings),
            "us_per_swing_per_set_cpu": 1e6 * cpu / (n_sets * swings),
            "us_per_swing_per_set_one_thread": 1e6 * one / (n_sets * swings)}


def _threads() -> int:
    import numba

    return int(numba.get_num_threads())


# -- summaries -------------------------------------------------------------------------------

def _fmt(x: float | None) -> str:
    return "        -" if x is None else f"{x:9.2e}"


def table(records: list[Record]) -> str:
    lines = []
    for case in CASES:
        rows = [r for r in records if r.case == case.key]
        if not rows:
            continue
        lines += [f"{case.title} ({case.swings} half swing{'s' * (case.swings > 1)})",
                  f"  {'method':12s} {'setting':22s} {'T/2 error (s)':>13s} {'amp. error (rad)':>16s} "
                  f"{'us/swing':>11s} {'clock':>5s}  status"]
        for r in sorted(rows, key=lambda r: list(dict.fromkeys(x.method for x in rows)).index(r.method)):
            lines.append(f"  {r.method:12s} {r.setting:22s} {_fmt(r.error_half_period_s):>13s} "
                         f"{_fmt(r.error_amplitude_rad):>16s} {r.us_per_swing:11.3f} {r.clock:>5s}  {r.status}"
                         + (f"  ({r.note})" if r.note else ""))
        lines.append("")
    return "\n".join(lines)


def markdown(records: list[Record]) -> str:
    """The docs tables: one per case, errors and time per half swing."""
    out = []
    for case in CASES:
        rows = [r for r in records if r.case == case.key]
        if not rows:
            continue
        out += [f"**{case.title}**", "",
                "| method | setting | T/2 error (s) | amplitude error (rad) | us per half swing |",
                "|---|---|---:|---:|---:|"]
        order = list(dict.fromkeys(r.method for r in rows))
        for r in sorted(rows, key=lambda r: order.index(r.method)):
            e_t = "-" if r.error_half_period_s is None else f"{r.error_half_period_s:.1e}"
            e_a = "-" if r.error_amplitude_rad is None else f"{r.error_amplitude_rad:.1e}"
            us = f"{r.us_per_swing:,.0f}" if r.us_per_swing >= 100 else f"{r.us_per_swing:.3g}"
            us += {"wall": " (wall)", "estimate": " (estimate, not run)"}.get(r.clock, "")
            out.append(f"| {r.method} | {r.setting} | {e_t} | {e_a} | {us} |")
        out.append("")
    return "\n".join(out)


def speed_ratios(records: list[Record]) -> list[dict]:
    """Exact solver against the cheapest solve_ivp setting with T/2 error <= 1e-12 s."""
    out = []
    for case in CASES:
        rows = [r for r in records if r.case == case.key]
        if not rows:
            continue
        ivp = [r for r in rows if r.method.startswith("ivp") and r.error_half_period_s is not None
               and r.error_half_period_s <= TARGET_T_ERROR]
        if not ivp:
            out.append({"case": case.key, "ivp": None})
            continue
        best = min(ivp, key=lambda r: r.us_per_swing)
        for exact in (r for r in rows if r.method in ("exact", "exact batch") and r.error_half_period_s is not None):
            out.append({"case": case.key, "exact": exact.method, "exact_setting": exact.setting,
                        "exact_us": exact.us_per_swing, "exact_error_s": exact.error_half_period_s,
                        "ivp": f"{best.method} {best.setting}", "ivp_us": best.us_per_swing,
                        "ivp_error_s": best.error_half_period_s, "ratio": best.us_per_swing / exact.us_per_swing})
    return out


def plot(records: list[Record], path: str | Path, fmt: str | None = None) -> None:
    """Log-log T/2 error against time per half swing, one panel per case (``fmt``: png, svg, pdf)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    styles = {"exact": ("k", "*"), "exact batch": ("k", "P"), "rk4": ("tab:blue", "o"), "rk4 naive": ("tab:cyan", "v"),
              "ivp RK45": ("tab:orange", "s"), "ivp DOP853": ("tab:red", "D"), "ivp Radau": ("tab:green", "^")}
    cases = [c for c in CASES if any(r.case == c.key for r in records)]
    fig, axes = plt.subplots(1, len(cases), figsize=(6.2 * len(cases), 5.0), squeeze=False)
    floor = 1e-18
    for ax, case in zip(axes[0], cases):
        for method, (color, marker) in styles.items():
            rows = [r for r in records
                    if r.case == case.key and r.method == method and r.error_half_period_s is not None]
            if not rows:
                continue
            x = [r.us_per_swing for r in rows]
            y = [max(r.error_half_period_s, floor) for r in rows]
            ax.plot(x, y, color=color, marker=marker, lw=1, ms=6, label=method)
            for r, xi, yi in zip(rows, x, y):
                if r.setting != "-" and "sets" not in r.setting:
                    ax.annotate(r.setting.split("=")[1].replace(" s", ""), (xi, yi), fontsize=6,
                                xytext=(3, 2), textcoords="offset points", color=color)
        ax.axhline(TARGET_T_ERROR, color="0.6", ls=":", lw=1)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("time per half swing (us; cpu, batch: wall)")
        ax.set_ylabel("largest error of T/2 (s)")
        ax.set_title(f"{case.title}\n({case.swings} half swing{'s' * (case.swings > 1)}; errors below "
                     f"{floor:g} s drawn at {floor:g})", fontsize=9)
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=7, loc="center left")
    fig.tight_layout()
    fig.savefig(path, dpi=130, format=fmt or (Path(path).suffix.lstrip('.') or 'png'))
    plt.close(fig)


def run(*, quick: bool = False, cases: tuple[str, ...] = ("horology", "monday120"),
        progress: Callable[[str], None] = lambda s: None) -> list[Record]:
    records = []
    for case in CASES:
        if case.key in cases:
            records += run_case(case, quick=quick, batch_sets=256 if quick else 2048, progress=progress)
    return records


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer settings, short timings (smoke test)")
    ap.add_argument("--json", action="store_true", help="print the records as JSON")
    ap.add_argument("--plot", default=None, help="write the work-precision plot to this PNG file")
    ap.add_argument("--from-json", default=None, help="render records saved by --json (or escfit bench --json-out)")
    ap.add_argument("--markdown", action="store_true", help="print the docs tables")
    ap.add_argument("--force", action="store_true", help="replace existing output files")
    args = ap.parse_args(argv)
    for out in (args.plot,):  # refused before the run, not after it
        if out and Path(out).exists() and not args.force:
            ap.error(f"{out} exists; pass --force to replace it")
    if args.from_json:
        records = [Record(**r) for r in json.loads(Path(args.from_json).read_text())]
    else:
        records = run(quick=args.quick, progress=lambda s: print(s, file=sys.stderr, flush=True))
    if args.markdown:
        print(markdown([r for r in records if r.case in {c.key for c in CASES}]))
        return 0
    if args.plot:
        plot(records, args.plot)
    if args.json:
        print(json.dumps([asdict(r) for r in records], indent=1))
    else:
        print(table(records))
        for r in speed_ratios(records):
            print(r)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
