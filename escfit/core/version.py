"""The escfit version, recorded in every dataset and results file."""

__version__ = "0.1.0"
