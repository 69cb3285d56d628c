"""Optional libraries a command does not use, kept from being imported by the libraries it does.

pint and xarray each import dask as soon as it is installed: pint when it is imported (to let
quantities wrap dask arrays), xarray when it builds its first dataset (to ask whether the data
are dask arrays).  Neither is needed by a command that fits, reports on or compares single
records, yet together they cost about 0.45 CPU s of every such command.  :func:`leave_out`
marks such libraries as not installed for the rest of the process: a ``None`` entry in
``sys.modules``, which makes ``import dask`` raise :class:`ImportError` and
:func:`importlib.util.find_spec` answer ``None``, the two ways libraries look for an optional
dependency.  A library already imported is left as it is.

Only the command line calls it, for the commands listed in :data:`WITHOUT`; a notebook or a
program that imports escfit keeps every library it has.
"""

from __future__ import annotations

import sys

__all__ = ["WITHOUT", "leave_out"]

#: command -> optional libraries it never uses (``fit-many`` runs its fits on dask, so it is not here)
WITHOUT: dict[str, tuple[str, ...]] = {name: ("dask",) for name in
                                       ("fit", "init", "summary", "report", "compare", "simulate", "examples")}


def leave_out(modules: tuple[str, ...]) -> list[str]:
    """Mark each of ``modules`` that is not imported yet as not installed; return those marked."""
    marked = [name for name in modules if name not in sys.modules]
    for name in marked:
        sys.modules[name] = None  # type: ignore[assignment]
    return marked
