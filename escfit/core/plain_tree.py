"""A fit's results held as named numpy arrays until a caller asks for xarray.

A results file is a tree of groups (``least_squares``, ``posterior``, ...), each a set of
arrays over named dimensions, with attributes: what :class:`xarray.DataTree` holds.  Importing
xarray, and pandas beneath it, costs about 0.3 CPU s: more than the least-squares fit of a
typical record.  A command that fits, writes the file and prints the table never needs it.

:class:`Group` and :class:`Tree` hold the same content with numpy alone and are built with
xarray's own argument forms; :mod:`escfit.core.h5direct` writes them exactly as it writes
xarray objects, and :meth:`Tree.to_xarray` gives the DataTree when one is wanted (notebooks,
reports, the study).  ``tests/test_plain_tree.py`` checks that both write the same file.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["Variable", "Group", "Tree"]


@dataclass(frozen=True)
class Variable:
    """One array: its dimension names, values and attributes (units, long_name, ...)."""

    dims: tuple[str, ...]
    values: np.ndarray
    attrs: dict[str, Any] = field(default_factory=dict)

    @property
    def variable(self) -> "Variable":
        """Itself (as ``xarray.DataArray.variable``: the array without its coordinates)."""
        return self

    @property
    def shape(self) -> tuple[int, ...]:
        return self.values.shape

    @property
    def size(self) -> int:
        return int(self.values.size)

    @property
    def ndim(self) -> int:
        return self.values.ndim


def _variable(name: str, spec: Any) -> Variable:
    """A variable from xarray's forms: ``(dims, values[, attrs])``, or bare values of the
    dimension coordinate ``name``."""
    if isinstance(spec, tuple):
        dims = (spec[0],) if isinstance(spec[0], str) else tuple(map(str, spec[0]))
        values, attrs = np.asarray(spec[1]), dict(spec[2]) if len(spec) > 2 else {}
    else:
        dims, values, attrs = (name,), np.asarray(spec), {}
    if values.ndim != len(dims):
        raise ValueError(f"{name!r}: {values.ndim}-d values given dimensions {dims}")
    return Variable(dims, values, attrs)


class Group:
    """One group of a results tree: data variables and coordinates over named dimensions.

    Parameters
    ----------
    data_vars, coords
        ``{name: (dims, values[, attrs])}``, as :class:`xarray.Dataset` takes them; a
        coordinate may also be given as bare values along the dimension of its own name.
    attrs
        The group's attributes.

    Raises
    ------
    ValueError
        A dimension given two different lengths, or values whose rank differs from their dimensions'.
    """

    def __init__(self, data_vars: Mapping[str, Any] | None = None, coords: Mapping[str, Any] | None = None,
                 attrs: Mapping[str, Any] | None = None):
        self.coords = {str(k): _variable(str(k), v) for k, v in (coords or {}).items()}
        self.data_vars = {str(k): _variable(str(k), v) for k, v in (data_vars or {}).items()}
        self.attrs = dict(attrs or {})
        self.sizes: dict[str, int] = {}
        for name, var in {**self.data_vars, **self.coords}.items():
            for dim, size in zip(var.dims, var.values.shape):
                if self.sizes.setdefault(dim, size) != size:
                    raise ValueError(f"{name!r}: dimension {dim!r} of length {size}, {self.sizes[dim]} elsewhere")

    @property
    def dims(self) -> tuple[str, ...]:
        return tuple(self.sizes)

    def __contains__(self, name: object) -> bool:
        return name in self.data_vars or name in self.coords

    def __getitem__(self, name: str) -> Variable:
        return self.data_vars[name] if name in self.data_vars else self.coords[name]

    def to_xarray(self) -> "xr.Dataset":
        import xarray as xr

        def spec(var: Variable) -> tuple:
            return var.dims, var.values, var.attrs

        return xr.Dataset({k: spec(v) for k, v in self.data_vars.items()},
                          coords={k: spec(v) for k, v in self.coords.items()}, attrs=self.attrs)


class Tree:
    """A results tree: root attributes and named child groups (one level, as results files have).

    ``children`` maps a group's name to its :class:`Group`; ``attrs`` are the file's attributes.
    """

    def __init__(self, attrs: Mapping[str, Any] | None = None, children: Mapping[str, Group] | None = None):
        self.attrs = dict(attrs or {})
        self.children = dict(children or {})

    def groups(self) -> list[tuple[str, Group]]:
        """``(path, group)`` of the root (a group of attributes only) and of every child."""
        return [("/", Group(attrs=self.attrs))] + [(f"/{name}", g) for name, g in self.children.items()]

    def to_xarray(self) -> "xr.DataTree":
        import xarray as xr

        root = xr.DataTree(dataset=xr.Dataset(attrs=self.attrs))
        for name, group in self.children.items():
            root[name] = xr.DataTree(dataset=group.to_xarray())
        return root
