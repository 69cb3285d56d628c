"""``escfit compare``: rank fits of the same readings by expected predictive accuracy.

The logic is :func:`escfit.inference.compare.compare_fits`; this module prints it.
"""

from __future__ import annotations

import json

import click

__all__ = ["compare"]


@click.command()
@click.argument("results", nargs=-1, type=click.Path())
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object: the fits best first, each with its file.")
def compare(results, as_json):
    """Rank fits of the same data: PSIS-LOO for posterior (emcee) fits, AICc and BIC for least squares.

    RESULTS are two or more results files of `escfit fit` on the same recording, read the same
    way, all fitted with the same --method.  The table lists them best first with the
    difference to the best: elpd_diff and its standard error dse for posteriors; dAICc,
    Akaike weights and dBIC for least squares (information criteria have no standard error).
    Fits of different data, different observation models or different methods are refused.
    """
    from ..inference.compare import compare_fits
    from .summary import json_safe

    cmp = compare_fits(results)
    if as_json:
        click.echo(json.dumps(json_safe(cmp.to_json())))
        return
    d = cmp.data
    what = ("PSIS-LOO of the posterior fits (higher elpd is better)" if cmp.criterion == "loo"
            else "AICc and BIC of the least-squares fits (lower is better)")
    click.echo(f"{len(cmp.rows)} fits of {d['data_file'] or 'the same data'} ({d['n_readings']} readings, "
               f"{d['data_kind'] or d['model']}, SHA-256 {d['data_sha256'][:12]}...): {what}, best first")
    click.echo(cmp.table())
    for note in cmp.notes:
        click.echo(note if note.startswith("verdict") else f"note: {note}")
