"""netCDF-4 images of xarray datasets and trees (or their plain stand-ins) written with h5netcdf directly.

``xarray``'s ``to_netcdf`` asks dask which scheduler is running before it writes anything,
and when dask is installed that imports ``dask.distributed``: about a CPU second of every
``escfit fit``, for a file of a few kilobytes.  This module writes the same layout through
h5netcdf (the engine xarray uses) for the variables escfit's results hold, following xarray's
encoding conventions, so that ``xarray.open_datatree``, ``xarray.open_dataset``, ArviZ and
escfit's own readers read back the identical objects:

* numbers as they are, floating-point ones with ``_FillValue = NaN``; booleans as ``int8``
  with the attribute ``dtype = "bool"``; text as variable-length UTF-8 strings;
* a coordinate that is not a dimension's index is named in the ``coordinates`` attribute of
  every data variable whose dimensions hold its own (of the group when none does);
* a dimension's index variable is its dimension scale.

Anything else (dates, times, complex or object data, a multi-index) is not written here:
:func:`supported` says so and :mod:`escfit.core.h5write` falls back to ``to_netcdf``.
``tests/test_h5direct.py`` compares the files read back with those of ``to_netcdf``.
"""

from __future__ import annotations

import io
from typing import TYPE_CHECKING

import numpy as np

from .plain_tree import Tree

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["supported", "image"]


def _kind(values: np.ndarray) -> str | None:
    """How a variable's values are written: ``"number"``, ``"bool"``, ``"text"`` or None (not here)."""
    if values.dtype.kind in "iuf":
        return "number"
    if values.dtype.kind == "b":
        return "bool"
    if values.dtype.kind == "U":
        return "text"
    return None


def _datasets(obj) -> list[tuple[str, "xr.Dataset"]]:
    """(group path, the group's own dataset) of a tree, or of a dataset as the root group
    (xarray's objects, or :mod:`escfit.core.plain_tree`'s)."""
    if isinstance(obj, Tree):
        return obj.groups()
    if hasattr(obj, "subtree"):
        return [(node.path, node.to_dataset(inherit=False)) for node in obj.subtree]
    return [("/", obj)]


def supported(obj) -> bool:
    """Whether every variable of ``obj`` (a Dataset or a DataTree, or a plain Group or Tree) is of
    a kind this module writes."""
    for _path, ds in _datasets(obj):
        indexes = getattr(ds, "indexes", {})  # a plain group has no (multi-)indexes
        if any(len(index.names) > 1 if hasattr(index, "names") else False for index in indexes.values()):
            return False
        for var in {**ds.coords, **ds.data_vars}.values():
            encoded = getattr(var, "encoding", {}).get("dtype")
            if _kind(np.asarray(var.values)) is None or encoded not in (None, var.values.dtype):
                return False
    return True


def _coordinates_attrs(ds: "xr.Dataset") -> tuple[dict[str, str], str]:
    """The ``coordinates`` attribute of each data variable, and the group's for the coordinates left over."""
    extra = sorted(str(name) for name in ds.coords if name not in ds.dims)
    per_var, used = {}, set()
    for name, var in ds.data_vars.items():
        mine = [c for c in extra if set(ds[c].dims) <= set(var.dims)]
        if mine:
            per_var[str(name)] = " ".join(mine)
            used.update(mine)
    return per_var, " ".join(c for c in extra if c not in used)


def _write_group(group, ds: "xr.Dataset", checksums: bool) -> None:
    for dim, size in ds.sizes.items():
        group.dimensions[str(dim)] = int(size)
    per_var, leftover = _coordinates_attrs(ds)
    names = [n for n in ds.dims if n in ds.coords] + [n for n in ds.coords if n not in ds.dims] + list(ds.data_vars)
    for name in names:
        var = ds[name].variable
        values = np.asarray(var.values)
        kind = _kind(values)
        attrs = dict(var.attrs)
        options: dict = {}
        if kind == "text":
            import h5py

            options["dtype"] = h5py.string_dtype("utf-8")
            values = values.astype(object)
        elif kind == "bool":
            values = values.astype(np.int8)
            attrs["dtype"] = "bool"
        if kind == "number" and values.dtype.kind == "f":
            options["fillvalue"] = values.dtype.type(np.nan)
        if checksums and kind in ("number", "bool") and values.ndim >= 1 and values.size > 0:
            options["fletcher32"] = True
            options["chunks"] = True
        out = group.create_variable(str(name), tuple(str(d) for d in var.dims), data=values, **options)
        if str(name) in per_var:
            attrs["coordinates"] = per_var[str(name)]
        for key, value in attrs.items():
            out.attrs[str(key)] = value
    if leftover:
        group.attrs["coordinates"] = leftover
    for key, value in ds.attrs.items():
        group.attrs[str(key)] = value


def image(obj, *, checksums: bool = True) -> bytes:
    """The bytes of a netCDF-4/HDF5 file holding ``obj`` (a Dataset or a DataTree; see :func:`supported`)."""
    import h5netcdf

    buffer = io.BytesIO()
    with h5netcdf.File(buffer, "w") as root:
        for path, ds in _datasets(obj):
            group = root
            for part in [p for p in path.split("/") if p]:
                group = group.groups[part] if part in group.groups else group.create_group(part)
            _write_group(group, ds, checksums)
    return buffer.getvalue()
