"""One family of exceptions for everything escfit refuses or cannot do.

Every error names where the problem is (file, line, key) and the offending value, so a
user can fix the input without reading code.  Each class also subclasses the matching
built-in exception so generic ``except ValueError`` handlers keep working.
"""

from __future__ import annotations

import importlib
import re
from types import ModuleType

__all__ = [
    "EscfitError",
    "SceneError",
    "DataError",
    "UnitError",
    "SolverError",
    "FitError",
    "ResultsError",
    "MissingDependency",
    "require",
]


class EscfitError(Exception):
    """Base class of all escfit errors.

    Parameters
    ----------
    message
        What is wrong, in one line.
    where
        The file, and optionally ``file:line`` or ``file [key]``, the problem was found in.
    """

    def __init__(self, message: str, where: str | None = None):
        self.message = message
        self.where = where
        text = f"{where}: {message}" if where else message
        # a file or column name holding a line break would break the one-line message (and could
        # forge a second line): control characters are shown escaped
        super().__init__(_CONTROL.sub(lambda m: repr(m.group())[1:-1], text))


_CONTROL = re.compile(r"[\x00-\x08\x0a-\x1f\x7f\x85\u2028\u2029]")


class SceneError(EscfitError, ValueError):
    """A scene file is malformed, incomplete or physically impossible."""


class UnitError(SceneError):
    """A quantity carries a unit of the wrong dimension or one pint does not know."""


class DataError(EscfitError, ValueError):
    """A data file (recording, table) is malformed or inconsistent with the scene."""


class SolverError(EscfitError, RuntimeError):
    """A solver was asked for something it cannot do (refused before any work)."""


class FitError(EscfitError, RuntimeError):
    """A fit could not be set up or did not produce a usable result."""


class ResultsError(EscfitError, OSError):
    """A results file cannot be written (exists, no --force) or read (wrong schema)."""


class MissingDependency(EscfitError, ImportError):
    """An optional dependency is not installed; the message names the extra that installs it.

    Parameters
    ----------
    module
        The module that could not be imported, e.g. ``"dask"``.
    extra
        The escfit extra that installs it, e.g. ``"study"``.
    purpose
        What needs it, e.g. ``"fit-many"``: the message reads
        ``"fit-many needs dask (pip install 'escfit[study]')"``.
    """

    def __init__(self, module: str, extra: str, purpose: str):
        self.module = module
        self.extra = extra
        self.purpose = purpose
        super().__init__(f"{purpose} needs {module} (pip install 'escfit[{extra}]')")
        self.name = module  # ImportError's attribute: the module that is missing


def require(module: str, extra: str, purpose: str) -> ModuleType:
    """Import and return ``module``; raise :class:`MissingDependency` naming ``extra`` if absent.

    >>> dask = require("dask", "study", "fit-many")  # doctest: +SKIP

    Only a missing module (``ImportError``, including one raised while importing the module's
    own dependencies) is turned into :class:`MissingDependency`; the original error is kept as
    ``__cause__``.
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingDependency(module, extra, purpose) from exc
