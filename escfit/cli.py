"""The ``escfit`` command line.

Exit status: 0 on success, 2 on bad input or usage (one line naming the file, key or value),
1 on an internal error.  Output files are written atomically and never replaced without
``--force``.
"""

from __future__ import annotations

import json
import sys
import traceback
from pathlib import Path

import click

from . import __version__
from .errors import EscfitError

__all__ = ["main", "cli"]


class _Group(click.Group):
    """Maps escfit's errors to exit status 2 and anything unexpected to 1."""

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except EscfitError as exc:
            click.echo(f"escfit: error: {exc}", err=True)
            ctx.exit(2)
        except (click.exceptions.Exit, click.ClickException, click.exceptions.Abort):
            raise
        except Exception as exc:  # noqa: BLE001 - the last line of defence of a CLI
            click.echo(f"escfit: internal error: {type(exc).__name__}: {exc}", err=True)
            if "--debug" in sys.argv:
                traceback.print_exc()
            ctx.exit(1)


@click.group(cls=_Group)
@click.version_option(__version__, prog_name="escfit")
def cli() -> None:
    """Identify the physical parameters of mechanical timekeeping oscillators."""


@cli.command()
@click.argument("scene", type=click.Path(dir_okay=False))
@click.option("--solver", type=click.Choice(["exact", "rk4", "ivp"]), default=None, help="Balance solver (default exact).")
@click.option("--swings", type=click.IntRange(1), default=None, help="Half swings (overrides the scene).")
@click.option("--h", "step", type=float, default=None, help="RK4 step size, s.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object with the results.")
@click.option("--out", type=click.Path(dir_okay=False), default=None, help="Write the dataset to FILE.nc (HDF5).")
@click.option("--force", is_flag=True, help="Replace an existing --out file.")
def simulate(scene, solver, swings, step, as_json, out, force):
    """Simulate SCENE (a TOML scene file)."""
    from .atomic import atomic_path, refuse_existing
    from .scene import load_scene, model_module

    if out:
        refuse_existing(out, force)
    sc = load_scene(scene)
    module = model_module(sc.model)
    options = {}
    if swings is not None:
        options["swings"] = swings
    if step is not None:
        options["h"] = step
    ds = module.simulate(sc, solver, **options) if solver else module.simulate(sc, **options)
    if out:
        with atomic_path(out, force=force) as tmp:
            ds.to_netcdf(tmp, engine="h5netcdf")
    if as_json:
        click.echo(json.dumps(module.json_summary(ds)))
    else:
        click.echo(_describe(ds, sc))


@cli.command()
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default="charts", show_default=True,
              help="Directory for the CSV and PNG files.")
@click.option("--c-over-omega0", "c0", type=click.FloatRange(0.0, 1.99), default=0.05, show_default=True,
              help="Damping ratio at which the conversion charts are drawn.")
@click.option("--no-png", is_flag=True, help="CSV only (no matplotlib needed).")
@click.option("--force", is_flag=True, help="Replace existing files.")
def charts(out_dir, c0, no_png, force):
    """Regenerate Monday's charts by computation: unit curves, conversion charts, factors."""
    from .charts import graph_factor
    from .charts_files import write_charts

    files = write_charts(out_dir, c_over_w0=c0, force=force, png=not no_png)
    for f in files:
        click.echo(str(f))
    click.echo(f"graph factor K/K_R at C/omega0 = {c0:g}: {graph_factor(c0):.4f}")


def _describe(ds, sc) -> str:
    lines = [f"{Path(sc.where).name}: model {sc.model}, status {ds.attrs.get('status')}"]
    if "amplitude" in ds and ds.sizes.get("swing", 0):
        a = ds["amplitude"].values
        lines.append(f"  {a.size} half swings; amplitude {a[0]:.6g} -> {a[-1]:.6g} rad; "
                     f"last half period {ds['half_period'].values[-1]:.10g} s, rate {ds['rate'].values[-1]:.4f} s/day")
    return "\n".join(lines)


def main() -> None:
    """Console-script entry point."""
    cli(prog_name="escfit")


if __name__ == "__main__":
    main()
