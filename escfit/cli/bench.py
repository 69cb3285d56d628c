"""``escfit bench``: how fast and how accurate the balance solvers are, on this machine.

Runs the scripts of ``benchmarks/`` in a source checkout: the work-precision study of
``benchmarks/work_precision.py`` (error of T/2 and amplitudes against a 40-digit reference
versus CPU time per half swing, for the exact solver, RK4 with and without event location
and scipy's solve_ivp), the throughput of the batch path, and the time of a 4-parameter
posterior (``benchmarks/posterior_speed.py``).  Prints a table and the three speed ratios
that docs/performance.md quotes, or with ``--json`` one record per method and setting.

The records and the plot go to a new folder ``bench-YYYYmmdd-HHMMSS/`` of the current
directory (``work_precision.json``, ``work_precision.png``), or where ``--out-dir``,
``--plot`` or ``--json-out`` say; existing files are replaced only with ``--force``, so a
run never overwrites the results kept in ``benchmarks/results/`` unless told to.
"""

from __future__ import annotations

import importlib.util
import json
import os
import sys
import time
from dataclasses import asdict
from datetime import datetime
from pathlib import Path

import click

__all__ = ["bench"]

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"
JSON_NAME, PLOT_NAME = "work_precision.json", "work_precision.png"


def new_run_folder(parent: str | Path = ".", *, now: datetime | None = None) -> Path:
    """A folder ``bench-YYYYmmdd-HHMMSS`` under ``parent`` that did not exist (``-2``, ``-3``, ...
    appended when one of that second does); not created."""
    stamp = (now or datetime.now()).strftime("%Y%m%d-%H%M%S")
    base = Path(parent) / f"bench-{stamp}"
    folder, k = base, 1
    while folder.exists():
        k += 1
        folder = base.with_name(f"{base.name}-{k}")
    return folder


def output_paths(out_dir: str | None, plot_path: str | None, json_path: str | None, *,
                 plot: bool = True) -> tuple[Path | None, Path | None, Path | None]:
    """Where ``escfit bench`` writes: ``(folder to create, plot file, JSON file)``.

    Explicit ``--plot`` / ``--json-out`` files are used as given (and nothing else is
    written); otherwise both go to ``out_dir``, by default a new :func:`new_run_folder`.
    ``plot`` false (no matplotlib) leaves the default plot out.
    """
    if plot_path or json_path:
        return None, Path(plot_path) if plot_path else None, Path(json_path) if json_path else None
    folder = Path(out_dir) if out_dir else new_run_folder()
    return folder, folder / PLOT_NAME if plot else None, folder / JSON_NAME


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
@click.option("--out-dir", type=click.Path(file_okay=False), default=None, metavar="DIR",
              help=f"Write {JSON_NAME} and {PLOT_NAME} into DIR (default: a new bench-YYYYmmdd-HHMMSS/ here; "
                   "not used with --plot or --json-out).")
@click.option("--force", is_flag=True, help="Replace existing output files.")
@click.option("--posterior/--no-posterior", default=True, show_default=True,
              help="Also time the 4-parameter posterior (32 walkers x 5000 steps, 120 swings; cold numba cache).")
def bench(quick, as_json, plot_path, json_path, out_dir, force, posterior):
    """Work-precision benchmark of the balance solvers and the speed targets.

    Results go to a new folder bench-YYYYmmdd-HHMMSS/ of the current directory unless
    --out-dir, --plot or --json-out name another place; files are never replaced without
    --force.
    """
    from ..core.atomic import atomic_path, refuse_existing

    has_matplotlib = importlib.util.find_spec("matplotlib") is not None
    folder, plot_path, json_path = output_paths(out_dir, plot_path, json_path, plot=has_matplotlib)
    for path in (plot_path, json_path):
        if path:
            refuse_existing(path, force)
            if folder is None and not path.parent.is_dir():  # refused now, not after the run
                from ..core.errors import ResultsError

                raise ResultsError("output directory does not exist", str(path.parent))
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
    if folder is not None:
        folder.mkdir(parents=True, exist_ok=True)
    if plot_path:
        with atomic_path(plot_path, force=force) as tmp:
            wp.plot([r for r in records if r.case in ("horology", "monday120") and r.error_half_period_s is not None],
                    tmp, Path(plot_path).suffix.lstrip(".") or "png")
    text = json.dumps([asdict(r) for r in records], indent=1)
    if json_path:
        with atomic_path(json_path, force=force) as tmp:
            Path(tmp).write_text(text + "\n")
    for path in (json_path, plot_path):
        if path:
            click.echo(f"wrote {path}", err=True)
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
