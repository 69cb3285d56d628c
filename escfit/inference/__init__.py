"""One inference layer for every model family: least squares (scipy), posterior sampling (emcee).

A family supplies a :class:`~escfit.likelihood.problem.Problem` (found by the scene's
``model =`` through :mod:`escfit.inference.registry`); :func:`fit` runs the optimiser and the
sampler on it, checks identifiability, convergence and misfit, and returns one results
schema (:mod:`escfit.results`) that ``escfit summary``, ``report`` and ``fit-many`` read
without knowing the family.
"""

from __future__ import annotations

from .fit import build_tree, fit, fit_problem
from .identifiability import profile
from .lsq import LeastSquaresResult, least_squares
from .registry import family, make_problem

__all__ = ["fit", "fit_problem", "make_problem", "family", "least_squares", "run_emcee", "profile",
           "build_tree", "LeastSquaresResult", "McmcResult"]


def __getattr__(name: str):
    # the sampler pulls in emcee and scipy.stats (seconds): imported on first use
    if name in ("run_emcee", "McmcResult"):
        from . import mcmc

        return getattr(mcmc, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
