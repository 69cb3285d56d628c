"""HDF5 (netCDF-4) output built in memory, with checksums, then written atomically.

Why in memory: HDF5 writes a file in many small pieces and closes it from a destructor.  When
the disk fills up half-way, h5py reports the failure from that destructor (and in some
versions the interpreter crashes at exit), leaving a half-written temporary behind.  Building
the file's image in memory first and writing it with one plain ``write`` turns a full disk into
one ordinary ``OSError`` that is reported as one line, and the temporary is removed.

Why checksums: every numeric data variable with at least one dimension is stored with HDF5's
Fletcher-32 filter, so a flipped byte in the data is an error on reading rather than a silently
changed number.  Files stay readable by xarray, ArviZ, h5py and netCDF-4 tools, which all apply
the filter transparently.  (0-d variables cannot be chunked, hence cannot carry the filter;
text variables are left as they are.)
"""

from __future__ import annotations

import errno
import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .atomic import atomic_path
from .errors import ResultsError

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["checksum_encoding", "netcdf_image", "xarray_image", "write_netcdf", "write_bytes"]


def checksum_encoding(ds: xr.Dataset) -> dict[str, dict]:
    """Per-variable encoding asking for Fletcher-32 checksums where HDF5 allows them."""
    enc: dict[str, dict] = {}
    for name, var in {**ds.data_vars, **ds.coords}.items():
        if var.ndim >= 1 and var.size > 0 and np.issubdtype(var.dtype, np.number):
            enc[str(name)] = {"fletcher32": True}
    return enc


def netcdf_image(obj: xr.Dataset | xr.DataTree, *, checksums: bool = True) -> bytes:
    """The bytes of ``obj`` written as a netCDF-4/HDF5 file: by h5netcdf directly when every
    variable is of a kind :mod:`escfit.core.h5direct` writes (numbers, flags, text), else by
    xarray's h5netcdf engine (:func:`xarray_image`); both read back as the same objects."""
    from .h5direct import image, supported

    if supported(obj):
        return image(obj, checksums=checksums)
    return xarray_image(obj, checksums=checksums)


def xarray_image(obj: xr.Dataset | xr.DataTree, *, checksums: bool = True) -> bytes:
    """The bytes of ``obj`` written as a netCDF-4/HDF5 file by xarray's ``to_netcdf`` (h5netcdf engine)."""
    import xarray as xr

    if hasattr(obj, "to_xarray") and not isinstance(obj, (xr.Dataset, xr.DataTree)):  # a plain Group or Tree
        obj = obj.to_xarray()
    if isinstance(obj, xr.DataTree):
        encoding = {node.path: checksum_encoding(node.to_dataset(inherit=False)) for node in obj.subtree} \
            if checksums else None
        encoding = {k: v for k, v in (encoding or {}).items() if v} or None
        return bytes(obj.to_netcdf(engine="h5netcdf", encoding=encoding))
    return bytes(obj.to_netcdf(engine="h5netcdf", encoding=checksum_encoding(obj) if checksums else None))


def write_bytes(image: bytes, path: str | Path, *, force: bool = False) -> Path:
    """Write ``image`` to ``path`` atomically; a full disk or an I/O error is one :class:`ResultsError`.

    Nothing is left behind on failure: the temporary is removed, and an existing ``path`` is
    replaced only with ``force`` and only once the new file is complete on disk.
    """
    target = Path(path)
    try:
        with atomic_path(target, force=force) as tmp:
            with open(tmp, "wb") as fh:
                fh.write(image)
                fh.flush()
                os.fsync(fh.fileno())
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            raise ResultsError(f"the disk is full: {len(image) / 1e6:.2g} MB could not be written; nothing was "
                               "written", str(target)) from None
        raise ResultsError(f"cannot write ({exc.strerror or exc}); nothing was written", str(target)) from None
    return target


def write_netcdf(obj: xr.Dataset | xr.DataTree, path: str | Path, *, force: bool = False) -> Path:
    """:func:`netcdf_image` of ``obj`` written to ``path`` by :func:`write_bytes`."""
    return write_bytes(netcdf_image(obj), path, force=force)
