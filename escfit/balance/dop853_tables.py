"""The Dormand-Prince 8(5,3) coefficient tables, read from scipy without importing scipy.integrate.

escfit's DOP853 steps (:mod:`escfit.balance.steps`, :mod:`escfit.balance.dop853`) use the
coefficients scipy's ``solve_ivp`` uses, from ``scipy/integrate/_ivp/dop853_coefficients.py``.
Importing that module the usual way runs ``scipy.integrate``'s package import first, which loads
its quadrature, ODE and boundary-value solvers and with them ``scipy.optimize`` and
``scipy.sparse``: 0.3-0.4 CPU s for ``escfit init``, ``report`` and ``simulate``, which never call
scipy's integrators.  The file holds numpy arrays only, so it is loaded here on its own, under a
private module name.  Where it is not a plain file (a zipped or frozen install) the usual import
is used.

``tables`` is that module: ``N_STAGES``, ``A``, ``B``, ``C``, ``E3``, ``E5``, ...
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import scipy

__all__ = ["tables"]

_NAME = "escfit.balance._scipy_dop853_coefficients"


def _load() -> ModuleType:
    path = Path(scipy.__file__).parent / "integrate" / "_ivp" / "dop853_coefficients.py"
    spec = importlib.util.spec_from_file_location(_NAME, path) if path.is_file() else None
    if spec is None or spec.loader is None:
        from scipy.integrate._ivp import dop853_coefficients

        return dop853_coefficients
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


tables = _load()
