"""``escfit bench``: how fast and how accurate the balance solvers are, on this machine.

Runs the scripts of ``benchmarks/`` in a source checkout: the work-precision study of
``benchmarks/work_precision.py`` (error of T/2 and amplitudes against a 40-digit reference
versus CPU time per half swing, for the exact solver, RK4 with and without event location
and scipy's solve_ivp), the throughput of the batch path, and the time of a 4-parameter
posterior (``benchmarks/posterior_speed.py``).  Prints a table and the three speed ratios
that docs/performance.md quotes, or with ``--json`` one record per method and setting.
"""

from __future__ import annotations

import importlib.util
import json
import os
import sys
import time
from dataclasses import asdict
from pathlib import Path

import click

__all__ = ["bench"]

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"


def _load(name: str):
    path = BENCHMARKS / f"{name}.py"
    if not path.is_file():
        raise click.ClickException(f"escfit bench runs {path}, which exists only in a source checkout of escfit")
    spec = importlib.util.spec_from_file_location(f"escfit_benchmarks_{name}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the file executes
    spec.loader.exec_module(module)
    return module


@click.command()
@click.option("--quick", is_flag=True, help="Fewer settings, short timings and a 200-step posterior (smoke test).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON record per method and setting.")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False), default=None,
              help="Write the work-precision plot (log-log T/2 error vs time per swing) to FILE.png.")
@click.option("--json-out", "json_path", type=click.Path(dir_okay=False), default=None,
              help="Also write the JSON records to FILE (the table is still printed).")
@click.option("--force", is_flag=True, help="Replace existing --plot and --json-out files.")
@click.option("--posterior/--no-posterior", default=True, show_default=True,
              help="Also time the 4-parameter posterior (32 walkers x 5000 steps, 120 swings; cold numba cache).")
def bench(quick, as_json, plot_path, json_path, force, posterior):
    """Work-precision benchmark of the balance solvers and the speed targets."""
    from ..core.atomic import atomic_path, refuse_existing

    for path in (plot_path, json_path):
        if path:
            refuse_existing(path, force)
    try:
        import mpmath  # noqa: F401  (the 40-digit reference of the work-precision study)
    except ModuleNotFoundError:
        raise click.ClickException("escfit bench needs mpmath for its reference solution: "
                                   "pip install 'escfit[bench]'") from None
    wp = _load("work_precision")
    say = (lambda s: None) if as_json else (lambda s: click.echo(s, err=True))
    started = time.perf_counter()
    records = wp.run(quick=quick, progress=say)
    through = wp.batch_throughput(n_sets=256 if quick else 2048, min_time=0.1 if quick else 0.5)
    setting = f"{through['sets']} perturbed sets, {through['threads']} threads"
    records.append(wp.Record("monday120", "exact batch", setting, None, None, through["us_per_swing_per_set_wall"],
                             "wall", "ok", through["swings"], f"cpu {through['us_per_swing_per_set_cpu']:.3f} us, one thread "
                             f"{through['us_per_swing_per_set_one_thread']:.3f} us"))
    post = None
    if posterior:
        ps = _load("posterior_speed")
        post = ps.run(32, 200) if quick else ps.run_cold(32, 5000)
        note = (f"{post['seconds_process_wall']:.1f} s for the process, empty numba cache" if post.get("cold_cache")
                else f"{post['seconds_sampling']:.1f} s sampling, warm numba cache")
        records.append(wp.Record("posterior", "emcee, vectorised exact", f"{post['walkers']} walkers x {post['steps']} "
                                 f"steps, {post['swings']} swings", None, None, post["us_per_swing"], "wall", "ok",
                                 post["swings"], note))
    if plot_path:
        with atomic_path(plot_path, force=force) as tmp:
            wp.plot([r for r in records if r.case in ("horology", "monday120") and r.error_half_period_s is not None],
                    tmp, Path(plot_path).suffix.lstrip(".") or "png")
    text = json.dumps([asdict(r) for r in records], indent=1)
    if json_path:
        with atomic_path(json_path, force=force) as tmp:
            Path(tmp).write_text(text + "\n")
    if as_json:
        click.echo(text)
        return
    click.echo(wp.table([r for r in records if r.case != "posterior"]))
    click.echo(_targets(wp, records, through, post, time.perf_counter() - started))


def _targets(wp, records, through: dict, post: dict | None, elapsed: float) -> str:
    lines = [f"Speed targets (one run, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the end, "
             f"{elapsed:.0f} s):"]
    for r in wp.speed_ratios(records):
        if r.get("ivp") is None:
            lines.append(f"  {r['case']}: no solve_ivp setting reached a T/2 error of {wp.TARGET_T_ERROR:g} s")
            continue
        lines.append(f"  {r['case']:10s} {r['exact']} ({r['exact_setting']}) {r['exact_us']:.3f} us/swing, "
                     f"T/2 error {r['exact_error_s']:.1e} s  vs  {r['ivp']} {r['ivp_us']:.0f} us/swing, "
                     f"T/2 error {r['ivp_error_s']:.1e} s:  {r['ratio']:.0f}x")
    lines.append(f"  batch: {through['us_per_swing_per_set_wall']:.3f} us per half swing per parameter set "
                 f"({through['sets']} sets x {through['swings']} swings, {through['threads']} threads, wall; "
                 f"one thread {through['us_per_swing_per_set_one_thread']:.3f} us)")
    if post is not None and post.get("cold_cache"):
        lines.append(f"  posterior: {post['walkers']} walkers x {post['steps']} steps x {post['swings']} swings, "
                     f"{len(post['parameters'])} parameters: {post['seconds_process_wall']:.1f} s for the whole "
                     "process, "
                     f"imports and compilation into an empty numba cache included ({post['seconds_compile']:.1f} s "
                     f"compiling the batch kernel, {post['seconds_sampling']:.1f} s sampling)")
    elif post is not None:
        lines.append(f"  posterior: {post['walkers']} walkers x {post['steps']} steps x {post['swings']} swings, "
                     f"{len(post['parameters'])} parameters: {post['seconds_sampling']:.1f} s sampling in this process "
                     f"(warm numba cache; the full run times 5000 steps in a fresh process with an empty cache)")
    return "\n".join(lines)
