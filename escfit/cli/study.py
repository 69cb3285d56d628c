"""``escfit fit-many``: fit every unit of a folder of recordings (any model family), in parallel.

Exit status: 0 when every unit is fitted (or was done before), 3 when some units failed (the
others are fitted and summarised; each failure is printed on stderr), 2 on bad input or when
dask.distributed (the ``study`` extra) is missing or another fit-many is writing into the same
--out folder, 130 when interrupted (Ctrl-C, SIGTERM, SIGHUP or SIGQUIT): the units fitted by then are kept, the
folder's lock is released, and the same command fits the rest.
"""

from __future__ import annotations

import sys

import click

from ..core.interrupts import interrupting_signals
from .main import EXIT_INTERRUPTED, NOTCH_MIN_DEG
from .options import WALKERS_MAX, FiniteFloat, StepsType

__all__ = ["fit_many"]

EXIT_SOME_FAILED = 3


@click.command("fit-many")
@click.argument("data", nargs=-1, required=True, type=click.Path())
@click.option("--scene", "scene_path", required=True, type=click.Path(dir_okay=False),
              help="Scene TOML with the free parameters (the same for every unit); its model = names the family.")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False),
              help="Results directory: <unit>.h5 per unit and summary.nc.")
@click.option("--method", type=click.Choice(["leastsq", "emcee"]), default="leastsq", show_default=True)
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Address of a running dask scheduler (e.g. tcp://10.0.0.5:8786); default: a local cluster.")
@click.option("--workers", type=click.IntRange(0), default=None,
              help="Worker processes of the local cluster (default: CPUs available; 0: in this process).")
@click.option("--seed", type=click.IntRange(0, 2**32 - 1), default=0, show_default=True, help="Batch seed (each unit's seed derives from it).")
@click.option("--walkers", type=click.IntRange(2, WALKERS_MAX), default=None, help="emcee walkers (default: the family's).")
@click.option("--steps", type=StepsType(), default=None,
              help="emcee steps or 'auto' (until converged; default: the family's).")
@click.option("--burn", type=click.IntRange(0), default=None, help="Default: the first quarter of the steps.")
@click.option("--n-starts", type=click.IntRange(1), default=None,
              help="Least-squares start points (default: the family's).")
@click.option("--unit", "units", multiple=True, help="Fit only this unit (repeatable).")
@click.option("--notch-deg", type=FiniteFloat(NOTCH_MIN_DEG, 360.0, high_open=True, unit="deg"), default=None,
              help="Balance unit curves: notch angle for files without a '# notch_deg:' line.")
@click.option("--quiet", is_flag=True, help="No progress lines.")
@click.pass_context
def fit_many(ctx, data, scene_path, out_dir, method, scheduler, workers, seed, walkers, steps, burn, n_starts, units,
             notch_deg, quiet):
    """Fit every unit of DATA... independently with --scene SCENE into --out DIR.

    DATA is a folder of recording files (one unit per file, named after the file; any model
    family), recording files, or balance unit-curve files whose 'unit' column holds several
    units.  Units whose results file exists and loads are skipped, so an interrupted batch is
    finished by running the same command again.
    """
    from ..study.batch import fit_many as run

    try:
        with interrupting_signals():
            res = run(list(data), scene_path, out_dir, method=method, scheduler=scheduler, workers=workers, seed=seed,
                      walkers=walkers, steps=steps, burn=burn, n_starts=n_starts, units=list(units) or None,
                      notch_deg=notch_deg, progress=not quiet)
    except KeyboardInterrupt:
        click.echo(f"escfit fit-many: interrupted; the units fitted so far are saved in {out_dir}: run the same "
                   "command again to fit the others (units with a results file are skipped)", err=True)
        sys.exit(EXIT_INTERRUPTED)
    click.echo(format_summary(res.summary))
    click.echo(f"{len(res.fitted)} fitted, {len(res.skipped)} done before, {len(res.failed)} failed "
               f"in {res.elapsed:.1f} s; summary: {res.out_dir / 'summary.nc'}")
    if res.failed:  # each failure was printed on stderr as it came back
        click.echo(f"escfit fit-many: {len(res.failed)} unit(s) failed: {', '.join(res.failed)}", err=True)
        ctx.exit(EXIT_SOME_FAILED)


def format_summary(ds, *, max_params: int = 4) -> str:
    """A fixed-width table: unit, status and estimate [95 % interval] of the first parameters."""
    from ..study.fleet_table import fleet_table

    head, rows = fleet_table(ds, max_params=max_params)
    widths = [max(len(h), *(len(r[k]) for r in rows)) if rows else len(h) for k, h in enumerate(head)]
    lines = ["  ".join(h.ljust(w) for h, w in zip(head, widths))]
    lines += ["  ".join(c.ljust(w) for c, w in zip(r, widths)) for r in rows]
    more = len(ds["parameter"]) - (len(head) - 2)
    if more > 0:
        lines.append(f"(+{more} more parameter(s) in summary.nc: {', '.join(map(str, ds['parameter'].values[len(head) - 2:]))};"
                     " escfit summary shows them all)")
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(fit_many())
