"""escfit's fit problems as lmfit sees them: ``lmfit.Parameters``, a residual and a ``Minimizer``.

Every family's :class:`~escfit.likelihood.problem.Problem` (balance wheel and pendulum with
each observation model, friction rig, Geneva, verge) maps onto lmfit the same way:

* each free parameter is an ``lmfit.Parameter`` with the scene's value, bounds and
  ``vary=True``; the noise parameters least squares does not fit (``observation.sigma``,
  ``observation.rho``) are ``vary=False`` at their values; the scene's fixed parameters follow
  with ``vary=False`` and its ties (``S = eps * M``) as lmfit expressions;
* lmfit names must be Python identifiers, so ``viscous.C`` is ``viscous__C`` and
  ``coulomb.R[load=330.66]`` is ``coulomb__R_load_330_66_``; each parameter's ``user_data``
  holds its escfit ``name``, ``unit`` (canonical, as every value here), ``meaning`` and ``role``
  (``free``, ``noise``, ``fixed`` or ``tied``);
* the residual is the vector escfit's own least squares minimises: the readings' standardised
  residuals and one row per Gaussian prior of a fitted parameter
  (:func:`~escfit.likelihood.problem.stacked_residuals`), so any lmfit method minimises the same
  cost and ``lmfit.conf_interval`` profiles it.

lmfit is imported here only, and only when one of these functions runs.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from ..core.errors import FitError, ResultsError
from ..core.params import safe_name
from ..likelihood.problem import Problem
from ..likelihood.problem import stacked_residuals

if TYPE_CHECKING:
    import lmfit

__all__ = ["LmfitProblem", "to_lmfit", "lmfit_problem", "lmfit_key", "parameters_from_results", "import_lmfit"]


def import_lmfit():
    """The lmfit module, or a :class:`~escfit.core.errors.FitError` saying how to install it."""
    try:
        import lmfit
    except ImportError:
        raise FitError("lmfit is not installed (a dependency of escfit): pip install lmfit") from None
    return lmfit


def lmfit_key(name: str) -> str:
    """The lmfit (Python identifier) name of an escfit parameter name.

    ``viscous.C`` -> ``viscous__C``, ``escapement[2].X`` -> ``escapement_2__X``,
    ``coulomb.R[load=330.66]`` -> ``coulomb__R_load_330_66_``.
    """
    key = re.sub(r"\W", "_", safe_name(name))
    return key if key[:1].isalpha() else f"p_{key}"


def _mapping(values) -> dict[str, float]:
    """Values by escfit name from a mapping by escfit name or from ``lmfit.Parameters``."""
    if values is None:
        return {}
    out = {}
    for key, v in dict(values).items():
        meta = getattr(v, "user_data", None)
        name = meta.get("name", key) if isinstance(meta, dict) else key
        out[name] = float(getattr(v, "value", v))
    return out


@dataclass
class LmfitProblem:
    """An escfit problem handed to lmfit.

    Attributes
    ----------
    problem : Problem
        The escfit fit problem (any family).
    params : lmfit.Parameters
        Its parameters (see the module's description), at the scene's values or those given.
    keys : dict
        escfit name -> lmfit name of every parameter in ``params``.
    """

    problem: Problem
    params: Any
    keys: dict[str, str] = field(default_factory=dict)

    @property
    def fitted(self) -> list[str]:
        """The escfit names least squares fits (free parameters except the noise ones)."""
        noise = set(self.problem.noise_names)
        return [n for n in self.problem.names if n not in noise]

    def values(self, params=None) -> dict[str, float]:
        """Every parameter's value by escfit name, the free ones read from ``params``."""
        params = self.params if params is None else params
        return self.problem.values({n: float(params[self.keys[n]].value) for n in self.problem.names})

    def residual(self, params) -> np.ndarray:
        """The residual vector lmfit minimises: standardised readings, then Gaussian prior rows.

        Its sum of squares is the cost of escfit's least squares (``chisqr`` plus the priors'
        ``-2 log p``); a failed model run gives large finite values.
        """
        problem = self.problem
        vals = self.values(params)
        r = np.asarray(problem.residuals(vals), float)[:problem.n_data]
        fitted = self.fitted
        priors = [problem.priors[problem.names.index(n)] for n in fitted]
        return stacked_residuals(r, priors, np.array([vals[n] for n in fitted], float))

    def log_prob(self, params) -> float:
        """The log posterior (escfit's :meth:`Problem.log_prob`) at ``params``, for lmfit's emcee
        with ``float_behavior="posterior"``; ``-inf`` outside the priors or when the model fails."""
        vals = self.values(params)
        return float(self.problem.log_prob(np.array([vals[n] for n in self.problem.names], float)))

    def minimizer(self, **kws) -> "lmfit.Minimizer":
        """An ``lmfit.Minimizer`` of :meth:`residual` over :attr:`params` (``kws`` go to it),
        whose ``leastsq`` (and so ``lmfit.conf_interval``'s refits) holds a parameter on a bound
        the cost falls through (:mod:`escfit.inference.lmfit_bounds`)."""
        from .lmfit_bounds import bound_aware_minimizer

        return bound_aware_minimizer(import_lmfit())(self.residual, self.params, **kws)


def lmfit_problem(problem: Problem, values: Mapping[str, float] | Any = None) -> LmfitProblem:
    """:class:`LmfitProblem` of a prepared problem, at the scene's values or at ``values``.

    Parameters
    ----------
    problem
        Any family's fit problem.
    values
        Values by escfit name, or ``lmfit.Parameters`` (e.g. from :func:`parameters_from_results`),
        replacing the scene's starting values (noise parameters included).
    """
    lmfit = import_lmfit()
    given = _mapping(values)
    unknown = sorted(set(given) - set(problem.names) - {p.name for p in problem.params})
    if unknown:
        raise FitError(f"values for {unknown}: not parameters of this {problem.family} problem "
                       f"(its free parameters: {list(problem.names)})")
    start = dict(zip(problem.names, (float(v) for v in problem.initial)))
    start.update({n: v for n, v in given.items() if n in problem.names})
    every = problem.values(start)
    units, meanings = dict(problem.units), dict(problem.meanings)
    noise = set(problem.noise_names)
    lo, hi = (np.asarray(b, float) for b in problem.bounds)
    params = lmfit.Parameters()
    keys: dict[str, str] = {}

    def add(name: str, role: str, **kw) -> None:
        key = lmfit_key(name)
        if key in params:
            raise FitError(f"two parameters map to the lmfit name {key!r}: {keys and [n for n, k in keys.items() if k == key]} "
                           f"and {name!r}")
        keys[name] = key
        params.add(key, **kw)
        params[key].user_data = {"name": name, "unit": units.get(name, ""), "meaning": meanings.get(name, ""),
                                 "role": role}

    for i, name in enumerate(problem.names):
        role = "noise" if name in noise else "free"
        value = float(np.clip(start[name], lo[i], hi[i]))
        add(name, role, value=value, min=lo[i], max=hi[i], vary=role == "free")
    declared = [p for p in problem.params if p.name not in keys]
    for p in (q for q in declared if q.tie is None):
        add(p.name, "fixed", value=float(given.get(p.name, every.get(p.name, p.value))), vary=False)
    for p in (q for q in declared if q.tie is not None):
        other, factor = p.tie
        if other in keys:
            add(p.name, "tied", expr=f"{float(factor)!r} * {keys[other]}")
        else:
            add(p.name, "fixed", value=float(every.get(p.name, p.value)), vary=False)
    return LmfitProblem(problem, params, keys)


def to_lmfit(scene, data, *, values=None, **options) -> tuple["lmfit.Parameters", "lmfit.Minimizer"]:
    """A scene and a recording as lmfit's ``Parameters`` and a ready ``Minimizer``.

    Parameters
    ----------
    scene
        Scene object or path (any model family).
    data
        Recording object or path.
    values
        Starting values by escfit name or ``lmfit.Parameters`` (see :func:`lmfit_problem`).
    **options
        The family's problem options (see :func:`escfit.inference.fit`).

    Returns
    -------
    (lmfit.Parameters, lmfit.Minimizer)
        ``minimizer.minimize(method=...)`` fits; ``lmfit.conf_interval(minimizer, result)``
        profiles.  The :class:`LmfitProblem` behind them is ``minimizer.userfcn.__self__``.

    Examples
    --------
    >>> params, mini = escfit.to_lmfit("scene.toml", "decay.csv")      # doctest: +SKIP
    >>> result = mini.minimize(method="least_squares")                 # doctest: +SKIP
    >>> ci = lmfit.conf_interval(mini, result, p_names=["viscous__C"])  # doctest: +SKIP
    """
    from .registry import make_problem

    lp = lmfit_problem(make_problem(scene, data, **options), values)
    return lp.params, lp.minimizer()


def _json(value):
    """An attribute of a results file: JSON text (dicts and lists are stored so) or the value."""
    import json

    return json.loads(value) if isinstance(value, str) and value[:1] in "[{" else value


def parameters_from_results(source) -> "lmfit.Parameters":
    """A saved fit as ``lmfit.Parameters``: best fit, standard errors and correlations.

    Parameters
    ----------
    source
        A results file path or a :class:`~escfit.results.FitResult`.

    Returns
    -------
    lmfit.Parameters
        The fitted parameters (``vary=True``, the scene's bounds, ``stderr`` and ``correl`` from
        the least-squares curvature; ``stderr`` is None where it is undefined), the profiled noise
        scale ``observation.sigma`` and the held parameters (``vary=False``), each with
        ``user_data`` as in :func:`lmfit_problem`.
    """
    from ..results import FitResult, load_fit

    lmfit = import_lmfit()
    res = source if isinstance(source, FitResult) else load_fit(Path(source))
    lsq = res.group("least_squares")
    if lsq is None:
        raise ResultsError("no least_squares group: not a fit's results", str(source))
    attrs = {k: _json(v) for k, v in res.attrs.items() if k in ("units", "meanings", "parameters", "held")}
    units, meanings = dict(attrs.get("units", {})), dict(attrs.get("meanings", {}))
    params = lmfit.Parameters()
    names = [str(n) for n in lsq["parameter"].values]

    def add(name: str, role: str, value: float, **kw) -> None:
        key = lmfit_key(name)
        params.add(key, value=value, **kw)
        params[key].user_data = {"name": name, "unit": units.get(name, ""), "meaning": meanings.get(name, ""),
                                 "role": role}

    for i, name in enumerate(names):
        add(name, "free", float(lsq["value"].values[i]), min=float(lsq["min"].values[i]),
            max=float(lsq["max"].values[i]), vary=True)
        se = float(lsq["stderr"].values[i])
        params[lmfit_key(name)].stderr = se if math.isfinite(se) else None
    corr = np.asarray(lsq["correlation"].values, float)
    for i, a in enumerate(names):
        params[lmfit_key(a)].correl = {lmfit_key(b): float(corr[i, j]) for j, b in enumerate(names)
                                       if j != i and math.isfinite(corr[i, j])} or None
    sigma = float(lsq.attrs.get("sigma_hat", math.nan))
    if "observation.sigma" in attrs.get("parameters", []) and math.isfinite(sigma):
        add("observation.sigma", "noise", sigma, vary=False)
    for name, value in dict(attrs.get("held", {})).items():
        if lmfit_key(name) not in params:
            add(name, "fixed", float(value), vary=False)
    return params
