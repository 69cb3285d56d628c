"""``escfit summary``: the parameter table of a fit, or the per-unit table of a fleet summary.

Text for people (display units: degrees, rad/s^2), ``--json`` and ``--csv`` for programs (the
files' units: rad, 1/s**2).
"""

from __future__ import annotations

import json

import click


__all__ = ["summary", "print_summary", "json_safe"]


def print_summary(result) -> None:
    from ..report import parameter_table
    from ..report.plain import plain_summary

    a = result.attrs
    # not determined: the NOT DETERMINED line below says so in its place
    plain = plain_summary(result) if getattr(result, "verdict", "") != "not determined" else []
    for sentence in plain:
        click.echo(sentence)
    if plain:
        click.echo("")
    if "steps" in a and "walkers" in a:
        how = "fixed length"
        if a.get("steps_mode") == "auto":
            how = ("stopped when converged, " if int(a.get("converged", 0)) else "stopped at the cap, NOT converged, ") \
                + str(a.get("convergence", ""))
        click.echo(f"emcee: {a['walkers']} walkers x {a['steps']} steps, first {a['burn']} discarded ({how})")
    if getattr(result, "verdict", "") == "not determined":
        click.echo("NOT DETERMINED: the values below are not a best fit of this record (see the first warning)")
    head, rows = parameter_table(result)
    widths = [max([len(h)] + [len(r[i]) for r in rows]) for i, h in enumerate(head)]
    click.echo("  ".join(h.ljust(w) for h, w in zip(head, widths)))
    for r in rows:
        click.echo("  ".join(c.ljust(w) for c, w in zip(r, widths)))
    from ..core.display import display_text, load_unit

    loads_in = load_unit(json.loads(a.get("meanings", "{}") or "{}"))
    for n in result.notes:
        click.echo(f"note: {n}")
    for w in result.warnings:
        click.echo(f"warning: {display_text(w, loads_in)}")


@click.command()
@click.argument("results", type=click.Path())
@click.option("--json", "as_json", is_flag=True, help="Print the parameter table as JSON.")
@click.option("--csv", "as_csv", is_flag=True,
              help="Print the table as CSV on stdout (redirect it to a file: escfit summary FIT.h5 --csv > fit.csv).")
def summary(results, as_json, as_csv):
    """Print the parameter table of a saved fit, or the per-unit table of a fleet.

    RESULTS is a results file of `escfit fit`, or the summary.nc (or the results directory)
    of `escfit fit-many`: one row per unit with its status and each parameter's estimate
    and 95 % interval.

    CSV columns of a fit: parameter, unit, estimate, estimate_kind (median or best fit),
    lo68, hi68, lo95, hi95, rhat, ess_bulk (empty when absent).  Of a fleet: unit, status,
    then <parameter>, <parameter>_lo95, <parameter>_hi95 per parameter, and error.
    """
    if as_json and as_csv:
        raise click.UsageError("--json and --csv are alternatives: give one")
    from ..study.fleet_table import is_fleet_summary

    if is_fleet_summary(results):
        _fleet_summary(results, as_json, as_csv)
        return
    from ..results import load_fit

    res = load_fit(results)
    if as_json:
        a = res.attrs
        from ..report.plain import plain_summary

        click.echo(json.dumps(json_safe({"plain": plain_summary(res), "parameters": res.summary(),
                                         "warnings": res.warnings, "notes": res.notes,
                               "misfit": res.misfit,
                               "model": a.get("model", "balance"), "method": a.get("method"),
                               "data_file": a.get("data_file"),
                               "schema_version": a.get("schema_version")})))
    elif as_csv:
        _echo_csv(*_fit_csv(res.summary()))
    else:
        print_summary(res)


FIT_CSV_COLUMNS = ("unit", "estimate", "estimate_kind", "lo68", "hi68", "lo95", "hi95", "rhat", "ess_bulk")


def _fit_csv(rows: dict[str, dict]) -> tuple[list[str], list[list[str]]]:
    """A fit's parameter table for CSV; rows without ``estimate`` (older files) give their median."""
    head = ["parameter", *FIT_CSV_COLUMNS]
    out = []
    for name, r in rows.items():
        r = dict(r)
        if r.get("estimate") is None:
            r["estimate"] = r.get("median", r.get("best_fit"))
            r.setdefault("estimate_kind", "median" if "median" in r else "best fit")
        out.append([name, *(_csv_cell(r.get(k)) for k in FIT_CSV_COLUMNS)])
    return head, out


def _csv_cell(value) -> str:
    """Numbers at full precision, nothing for a missing or non-finite value."""
    import math as _math

    if value is None or (isinstance(value, float) and not _math.isfinite(value)):
        return ""
    return repr(float(value)) if isinstance(value, float) else str(value)


def _echo_csv(head: list[str], rows: list[list[str]]) -> None:
    import csv
    import io

    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(head)
    writer.writerows(rows)
    click.echo(buf.getvalue(), nl=False)


def _fleet_summary(path: str, as_json: bool, as_csv: bool) -> None:
    """``escfit summary`` of a fleet summary: the per-unit table."""
    from ..study.fleet_table import fleet_csv, fleet_table, read_fleet_summary

    ds = read_fleet_summary(path)
    if as_csv:
        _echo_csv(*fleet_csv(ds))
        return
    if as_json:
        head, rows = fleet_csv(ds)
        units = [dict(zip(head, r)) for r in rows]
        for u in units:
            for k, v in u.items():
                if k not in ("unit", "status", "error"):
                    u[k] = float(v) if v != "" else None
        click.echo(json.dumps(json_safe({"units": units, "schema_version": ds.attrs.get("schema_version"),
                                          "model": ds.attrs.get("model"), "method": ds.attrs.get("method")})))
        return
    head, rows = fleet_table(ds)
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(head)]
    click.echo("  ".join(h.ljust(w) for h, w in zip(head, widths)).rstrip())
    for r in rows:
        click.echo("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip())
    n_failed = int(ds.attrs.get("n_failed", 0))
    click.echo(f"{int(ds.sizes['unit'])} unit(s), {n_failed} failed; estimate [95 % interval] per parameter")


def json_safe(obj):
    """Replace non-finite floats by None so the output is valid JSON."""
    import math as _math

    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, float) and not _math.isfinite(obj):
        return None
    return obj
