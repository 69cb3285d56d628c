"""Optional libraries a command does not use, kept from being imported by the libraries it does.

pint and xarray each import dask as soon as it is installed: pint when it is imported (to let
quantities wrap dask arrays), xarray when it builds its first dataset (to ask whether the data
are dask arrays).  Neither is needed by a command that fits, reports on or compares single
records, yet together they cost about 0.45 CPU s of every such command.  :func:`leave_out`
marks such libraries as not installed for the rest of the process: a ``None`` entry in
``sys.modules``, which makes ``import dask`` raise :class:`ImportError` and
:func:`importlib.util.find_spec` answer ``None``, the two ways libraries look for an optional
dependency.  A library already imported is left as it is.

Only the console command calls it (:func:`escfit.cli.main.main`, the process's entry point), for
the commands listed in :data:`WITHOUT`, before anything else is imported, and the mark stays
until the process ends with the command.  A command run inside another process (a notebook's
or a test's ``CliRunner``) is not touched: xarray remembers whether dask is available once it
has looked, so hiding dask from a process that has used xarray, or unhiding it after xarray
has looked, would leave xarray wrong about it.
"""

from __future__ import annotations

import sys

__all__ = ["WITHOUT", "leave_out", "unused_by"]

#: command -> optional libraries it never uses (``fit-many`` runs its fits on dask, so it is not here)
WITHOUT: dict[str, tuple[str, ...]] = {name: ("dask",) for name in
                                       ("fit", "init", "summary", "report", "compare", "simulate", "examples")}


def leave_out(modules: tuple[str, ...]) -> list[str]:
    """Mark each of ``modules`` that is not imported yet as not installed; return those marked."""
    marked = [name for name in modules if name not in sys.modules]
    for name in marked:
        sys.modules[name] = None  # type: ignore[assignment]
    return marked


def unused_by(argv: list[str]) -> tuple[str, ...]:
    """The libraries the command named in ``argv`` (the arguments after ``escfit``) never uses.

    The command is the first argument that is not an option (escfit's own options before it,
    ``--debug``, ``--version`` and ``--help``, take no value).
    """
    command = next((a for a in argv if not a.startswith("-")), "")
    return WITHOUT.get(command, ())
