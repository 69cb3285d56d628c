"""The ``escfit`` command line (see :mod:`escfit.cli.main`)."""

from .main import cli, main

__all__ = ["cli", "main"]
