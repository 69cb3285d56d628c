"""What an HDF5 file declares, checked before any of its arrays is read.

An HDF5 file says how large each of its arrays is; a reader that believes it allocates that
much before reading a byte.  A file of a few kilobytes can declare an array of billions of
numbers whose chunks were never written (HDF5 then returns its fill value for all of them), or
an array whose shape contradicts the dimension it is said to run along.  The readers of
escfit's own files (results files, :mod:`escfit.results`; sampler checkpoints,
:mod:`escfit.inference.checkpoint`) therefore read the file's *layout* first, from its
metadata only (:func:`read_layout`), and check it:

* against the file's size (:func:`check_backed`): together the arrays cannot occupy more bytes
  than the file has, and each must hold the bytes it declares (uncompressed arrays, which is
  all escfit writes) or a bounded multiple of them (compressed arrays, :data:`MAX_RATIO`),
  apart from :data:`UNBACKED_SLACK` bytes in all and from the placeholders netCDF-4 writes for
  dimensions without a coordinate (never read); the memory a reader then needs is bounded by
  the file's size;
* against the dimensions each array is said to run along (:func:`check_dimensions`): every
  axis of an array is a netCDF dimension whose length is that of its dimension scale;
* against what the reader expects (:func:`expect_arrays`, :func:`expect_shape`): the arrays a
  group must hold, and their shapes.

Each refusal is a :class:`~escfit.core.errors.ResultsError` naming the file and the array.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

from .errors import ResultsError

__all__ = ["Array", "Layout", "read_layout", "check_file", "check_backed", "check_dimensions", "expect_arrays", "expect_shape",
           "expect_dims", "MAX_RATIO", "UNBACKED_SLACK"]

# A compressed array may declare at most this many times the bytes it occupies (deflate reaches
# about 1000 on constant data; real posterior draws compress by less than 2)
MAX_RATIO = 64
# Declared bytes not held in the file, over all arrays (empty or tiny arrays left unwritten)
UNBACKED_SLACK = 1 << 20
# How netCDF-4 names a dimension scale that holds no values (a dimension without a coordinate)
NOT_A_VARIABLE = b"This is a netCDF dimension but not a netCDF variable"
# HDF5 filters that do not compress: shuffle (2) and Fletcher-32 checksums (3)
PLAIN_FILTERS = (2, 3)


@dataclass(frozen=True)
class Array:
    """One array (HDF5 dataset) as its metadata declares it.

    Attributes
    ----------
    name : str
        Its path in the file, without the leading ``/`` (``"posterior/rig.k"``).
    shape : tuple of int
    itemsize : int
        Bytes per element in memory (8 for a variable-length string's reference).
    stored : int
        Bytes the file holds for it (after any filter).
    compressed : bool
        Whether a compressing filter is applied.
    dims : tuple
        Per axis, ``(dimension name, its length)`` from the attached dimension scale, or None.
    placeholder : bool
        A netCDF dimension that is no variable: a scale whose values are never written nor
        read (netCDF-4 readers take only its length).
    """

    name: str
    shape: tuple[int, ...]
    itemsize: int
    stored: int
    compressed: bool
    dims: tuple[tuple[str, int] | None, ...]
    placeholder: bool = False

    @property
    def declared(self) -> int:
        """Bytes a reader allocates for it."""
        return math.prod(self.shape) * self.itemsize

    @property
    def dim_names(self) -> tuple[str | None, ...]:
        return tuple(d[0] if d else None for d in self.dims)


@dataclass(frozen=True)
class Layout:
    """A file's arrays (by path) and root attributes, read from its metadata."""

    where: str
    size: int
    arrays: Mapping[str, Array]
    attrs: Mapping[str, Any]
    groups: frozenset[str]


def read_layout(path: str | Path, error: str = "damaged or unreadable file") -> Layout:
    """Read ``path``'s layout (no array data), or refuse a file HDF5 cannot open.

    Parameters
    ----------
    error
        The start of the message for a file HDF5 cannot read.
    """
    import h5py

    where = str(path)
    try:
        size = os.stat(path).st_size
        with h5py.File(path, "r") as f:
            arrays: dict[str, Array] = {}
            groups: set[str] = set()

            def visit(name: str, obj) -> None:
                if isinstance(obj, h5py.Dataset):
                    arrays[name] = _array(name, obj)
                else:
                    groups.add(name)

            f.visititems(visit)
            attrs = {k: _attr(f.attrs, k) for k in f.attrs.keys()}
    except ResultsError:
        raise
    except (OSError, KeyError, ValueError, TypeError, RuntimeError) as exc:
        first = (str(exc).splitlines() or [type(exc).__name__])[0]
        raise ResultsError(f"{error} ({first[:160]})", where) from None
    return Layout(where, size, arrays, attrs, frozenset(groups))


def check_file(path: str | Path, what: str) -> Layout:
    """Read ``path``'s layout and refuse it before any array is read: not HDF5, unreadable,
    arrays that declare more than the file holds, or axes that disagree with their dimensions.

    Parameters
    ----------
    what
        What the file should be ("results file", "fleet summary", ...), for the messages.
    """
    import h5py

    if not h5py.is_hdf5(path):
        raise ResultsError(f"not an HDF5 file: give a {what} written by escfit", str(path))
    layout = read_layout(path, f"damaged or unreadable {what}")
    check_backed(layout)
    check_dimensions(layout)
    return layout


def _attr(attrs, key: str) -> Any:
    """A root attribute as a Python value (text decoded), read on its own."""
    value = attrs[key]
    if isinstance(value, bytes):
        return value.decode("utf-8", errors="replace")
    return value.item() if hasattr(value, "item") and getattr(value, "size", 0) == 1 else value


def _array(name: str, ds) -> Array:
    from h5py import h5ds

    dcpl = ds.id.get_create_plist()
    filters = [dcpl.get_filter(i)[0] for i in range(dcpl.get_nfilters())]
    dims: list[tuple[str, int] | None] = []
    if len(ds.shape) == 1 and h5ds.is_scale(ds.id):  # a dimension's own scale runs along itself
        dims.append((name.rsplit("/", 1)[-1], int(ds.shape[0])))
    for axis in range(len(dims), len(ds.shape)):
        scales = ds.dims[axis]
        if len(scales) == 0:
            dims.append(None)
            continue
        scale = scales[0]
        dims.append((scale.name.rsplit("/", 1)[-1], int(scale.shape[0]) if scale.shape else 0))
    label = ds.attrs.get("NAME", b"") if h5ds.is_scale(ds.id) else b""
    placeholder = (label if isinstance(label, bytes) else str(label).encode()).startswith(NOT_A_VARIABLE)
    return Array(name, tuple(int(n) for n in ds.shape), int(ds.dtype.itemsize), int(ds.id.get_storage_size()),
                 any(code not in PLAIN_FILTERS for code in filters), tuple(dims), placeholder)


def _human(nbytes: float) -> str:
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= scale:
            return f"{nbytes / scale:.3g} {unit}"
    return f"{int(nbytes)} bytes"


def check_backed(layout: Layout) -> None:
    """Refuse arrays that declare more than the file holds (see the module docstring)."""
    stored = sum(a.stored for a in layout.arrays.values())
    if stored > layout.size:
        raise ResultsError(f"damaged file: its arrays say they occupy {_human(stored)}, the file has "
                           f"{_human(layout.size)}", layout.where)
    unbacked = 0
    for a in sorted((a for a in layout.arrays.values() if not a.placeholder), key=lambda a: -a.declared):
        held = a.stored * (MAX_RATIO if a.compressed else 1)
        unbacked += max(0, a.declared - held)
        if unbacked > UNBACKED_SLACK:
            raise ResultsError(f"array {a.name} declares {_shape(a.shape)} values ({_human(a.declared)}) but the "
                               f"file holds {_human(a.stored)} of them: damaged, or not written by escfit; refused "
                               "before reading", layout.where)


def check_dimensions(layout: Layout, names: Iterable[str] | None = None) -> None:
    """Refuse an array (of ``names``, default all) with an axis that is no named dimension or
    whose length differs from its dimension's."""
    for name in layout.arrays if names is None else names:
        a = layout.arrays[name]
        for axis, (n, dim) in enumerate(zip(a.shape, a.dims)):
            if dim is None:
                raise ResultsError(f"array {a.name} has no named dimension along axis {axis} (shape "
                                   f"{_shape(a.shape)}): not a file written by escfit", layout.where)
            if dim[1] != n:
                raise ResultsError(f"array {a.name} has {n} values along {dim[0]!r}, which has {dim[1]}: "
                                   "inconsistent file", layout.where)


def expect_arrays(layout: Layout, group: str, names: Sequence[str], why: str = "") -> None:
    """Refuse a file whose ``group`` lacks one of the arrays ``names``."""
    for name in names:
        if f"{group}/{name}" not in layout.arrays:
            raise ResultsError(f"incomplete file: {group}/{name} is missing{why}", layout.where)


def expect_shape(layout: Layout, name: str, shape: Sequence[int | None], what: str = "") -> None:
    """Refuse array ``name`` unless its shape is ``shape`` (None: any length on that axis)."""
    a = layout.arrays[name]
    if len(a.shape) != len(shape) or any(want is not None and want != n for want, n in zip(shape, a.shape)):
        want = "(" + ", ".join("any" if n is None else str(n) for n in shape) + ")"
        raise ResultsError(f"array {name} has shape {_shape(a.shape)}, expected {want}{what}", layout.where)


def expect_dims(layout: Layout, name: str, dims: Sequence[str]) -> None:
    """Refuse array ``name`` unless it runs along the named dimensions ``dims``, in order."""
    a = layout.arrays[name]
    if a.dim_names != tuple(dims):
        raise ResultsError(f"array {name} runs along {list(a.dim_names)}, expected {list(dims)}", layout.where)


def _shape(shape: tuple[int, ...]) -> str:
    return "(" + ", ".join(str(n) for n in shape) + ("," if len(shape) == 1 else "") + ")"
