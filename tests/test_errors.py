"""The escfit error family, and the error for a missing optional dependency."""

from __future__ import annotations

import math
import sys

import pytest

from escfit.core.errors import (DataError, EscfitError, FitError, MissingDependency, ResultsError, SceneError,
                                SolverError, UnitError, require)


@pytest.mark.parametrize("cls, builtin", [(SceneError, ValueError), (UnitError, ValueError), (DataError, ValueError),
                                          (SolverError, RuntimeError), (FitError, RuntimeError),
                                          (ResultsError, OSError), (MissingDependency, ImportError)])
def test_every_error_is_an_escfit_error_and_its_builtin(cls, builtin):
    assert issubclass(cls, EscfitError) and issubclass(cls, builtin)


def test_where_prefixes_the_message():
    err = SceneError("omega0 must be positive, got -1.0", "scene.toml [balance].omega0")
    assert str(err) == "scene.toml [balance].omega0: omega0 must be positive, got -1.0"
    assert err.message == "omega0 must be positive, got -1.0" and err.where == "scene.toml [balance].omega0"


def test_require_returns_the_module_when_present():
    assert require("math", "study", "fit-many") is math


def test_require_names_the_extra_when_the_module_is_missing(monkeypatch):
    monkeypatch.setitem(sys.modules, "dask", None)  # makes `import dask` raise ImportError
    with pytest.raises(MissingDependency, match=r"^fit-many needs dask \(pip install 'escfit\[study\]'\)$") as err:
        require("dask", "study", "fit-many")
    exc = err.value
    assert isinstance(exc, EscfitError) and isinstance(exc, ImportError)
    assert (exc.module, exc.extra, exc.purpose, exc.name) == ("dask", "study", "fit-many", "dask")
    assert isinstance(exc.__cause__, ImportError)


def test_require_reports_a_missing_submodule(monkeypatch):
    monkeypatch.setitem(sys.modules, "dask", None)
    monkeypatch.setitem(sys.modules, "dask.distributed", None)
    with pytest.raises(MissingDependency, match=r"needs dask\.distributed \(pip install 'escfit\[study\]'\)"):
        require("dask.distributed", "study", "fit-many --scheduler")
