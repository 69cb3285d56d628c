"""Reading a fleet summary (``summary.nc`` of ``escfit fit-many``) as a per-unit table.

One row per unit: its status, then each parameter's estimate and 95 % interval.  The
estimate is the ``estimate`` statistic where the summary has it (the posterior median of
an emcee fit, the best fit of a least-squares one) and the ``median`` of older summaries.
"""

from __future__ import annotations

import math
from pathlib import Path

import xarray as xr

from .names import SUMMARY_FILE, SUMMARY_SCHEMA

__all__ = ["is_fleet_summary", "fleet_summary_path", "read_fleet_summary", "estimates", "fleet_table", "fleet_csv"]


def fleet_summary_path(path: str | Path) -> Path:
    """``path`` itself, or the ``summary.nc`` inside it when it is a directory."""
    p = Path(path)
    return p / SUMMARY_FILE if p.is_dir() else p


def is_fleet_summary(path: str | Path) -> bool:
    """Whether ``path`` (a file, or a ``fit-many`` results directory) holds a fleet summary.

    Only the root attributes are read; unreadable and non-HDF5 files are not summaries.
    """
    import h5py

    p = fleet_summary_path(path)
    if not p.is_file() or not h5py.is_hdf5(p):
        return False
    try:
        with h5py.File(p, "r") as f:
            schema = f.attrs.get("schema_version")
    except OSError:
        return False
    if isinstance(schema, bytes):
        schema = schema.decode()
    return schema == SUMMARY_SCHEMA


def estimates(ds: xr.Dataset) -> xr.DataArray:
    """The (unit, parameter) estimates: ``estimate`` if the summary has it, else ``median``."""
    return ds["estimate"] if "estimate" in ds else ds["median"]


def _fmt(x: float) -> str:
    return "-" if math.isnan(x) else f"{x:.4g}"


def fleet_table(ds: xr.Dataset, *, max_params: int | None = None) -> tuple[list[str], list[list[str]]]:
    """Header and rows (strings) of the per-unit table.

    Parameters
    ----------
    ds
        A fleet summary (:func:`escfit.study.batch.load_summary`).
    max_params
        Show only the first parameters (default all).

    Returns
    -------
    tuple
        ``(head, rows)``: ``unit``, ``status`` and one ``estimate [lo95, hi95]`` cell per
        parameter; ``-`` where a unit has no value.
    """
    params = [str(p) for p in ds["parameter"].values][:max_params]
    est, lo, hi = (a.values for a in (estimates(ds), ds["lo95"], ds["hi95"]))
    rows = []
    for i, unit in enumerate(ds["unit"].values):
        row = [str(unit), str(ds["status"].values[i])]
        for j in range(len(params)):
            m = float(est[i, j])
            row.append("-" if math.isnan(m) else f"{_fmt(m)} [{_fmt(float(lo[i, j]))}, {_fmt(float(hi[i, j]))}]")
        rows.append(row)
    return ["unit", "status", *params], rows


def fleet_csv(ds: xr.Dataset) -> tuple[list[str], list[list]]:
    """Header and rows of the per-unit table as numbers, for CSV.

    Columns: ``unit``, ``status``, then ``<parameter>``, ``<parameter>_lo95`` and
    ``<parameter>_hi95`` for each parameter (empty where a unit has no value), and ``error``.
    """
    params = [str(p) for p in ds["parameter"].values]
    est, lo, hi = (a.values for a in (estimates(ds), ds["lo95"], ds["hi95"]))
    head = ["unit", "status"] + [f"{p}{s}" for p in params for s in ("", "_lo95", "_hi95")] + ["error"]
    rows = []
    for i, unit in enumerate(ds["unit"].values):
        cells: list = [str(unit), str(ds["status"].values[i])]
        for j in range(len(params)):
            cells += [_number(est[i, j]), _number(lo[i, j]), _number(hi[i, j])]
        cells.append(str(ds["error"].values[i]) if "error" in ds else "")
        rows.append(cells)
    return head, rows


def _number(x) -> str:
    x = float(x)
    return "" if math.isnan(x) else repr(x)


def read_fleet_summary(path: str | Path) -> xr.Dataset:
    """:func:`escfit.study.batch.load_summary` of a file or a ``fit-many`` results directory."""
    from .batch import load_summary

    return load_summary(fleet_summary_path(path))
