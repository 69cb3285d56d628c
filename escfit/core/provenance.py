"""Versions of escfit and its dependencies, recorded with every result."""

from __future__ import annotations

__all__ = ["dependency_versions"]

PACKAGES = ("escfit", "numpy", "scipy", "numba", "emcee", "xarray", "h5netcdf", "arviz", "pint")


def dependency_versions() -> dict[str, str]:
    """Installed version of escfit and each dependency (``"unknown"`` when not installed)."""
    import importlib.metadata as md

    out = {}
    for pkg in PACKAGES:
        try:
            out[pkg] = md.version(pkg)
        except md.PackageNotFoundError:  # pragma: no cover
            out[pkg] = "unknown"
    return out
