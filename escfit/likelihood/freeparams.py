"""The free-parameter vector of a fit: names, priors, bounds, and values with ties resolved.

Shared by every fit problem (unit curves, passage times, timegrapher readings): the sampler
and the optimiser see a plain vector in :attr:`FreeParameters.names` order; the forward model
sees all parameters by name (:meth:`FreeParameters.values`).
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from ..core.errors import FitError
from ..core.params import ParamSet
from .prior_block import PriorBlock
from .priors import Prior, prior_of

__all__ = ["FreeParameters"]


class FreeParameters:
    """Mixin holding the parameters of a fit problem.

    Attributes
    ----------
    params
        All parameters (scene, load rule, observation).
    names
        Names of the free parameters, in vector order.
    priors
        Prior of each free parameter (:func:`~escfit.likelihood.priors.prior_of`), truncated
        to the parameter's bounds.  A free parameter with an infinite bound and no prior
        string gets the improper flat prior: balance fits allow it (e.g. ``fit.kappa``, free
        and unbounded by default), the data make the posterior proper.
    """

    def _set_free(self, params: ParamSet, where: str) -> None:
        """Take ``params``; refuse a fit with nothing free (``where`` names the scene)."""
        free = params.free()
        if not free:
            raise FitError("no free parameters: mark some with { value = ..., vary = true }", where)
        self.params = params
        self.names = [p.name for p in free]
        self.priors: list[Prior] = [prior_of(p, f"{where} [{p.name}]", allow_improper=True) for p in free]
        self._base = params.values()
        self._ties = [(p.name, p.tie) for p in params if p.tie is not None]

    @property
    def initial(self) -> np.ndarray:
        """The scene's values of the free parameters."""
        return np.array([self.params[n].value for n in self.names])

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the free parameters (each prior's support)."""
        return np.array([p.lo for p in self.priors]), np.array([p.hi for p in self.priors])

    def values(self, vec: np.ndarray | Mapping[str, float]) -> dict[str, float]:
        """All parameter values by name for a free-parameter vector (ties resolved)."""
        vals = dict(self._base)
        if isinstance(vec, Mapping):
            vals.update(vec)
        else:
            vals.update(zip(self.names, map(float, vec)))
        for name, (other, factor) in self._ties:
            vals[name] = factor * vals[other]
        return vals

    def values_many(self, vecs: np.ndarray) -> dict[str, float | np.ndarray]:
        """:meth:`values` of every row of ``vecs`` (sets, ndim) at once: free parameters (and
        those tied to them) as arrays of shape (sets,), the rest as numbers."""
        vecs = np.atleast_2d(np.asarray(vecs, float))
        vals: dict = dict(self._base)
        vals.update({n: vecs[:, i].copy() for i, n in enumerate(self.names)})
        for name, (other, factor) in self._ties:
            vals[name] = factor * vals[other]
        return vals

    def log_prior_many(self, vecs: np.ndarray) -> np.ndarray:
        """:meth:`log_prior` of every row of ``vecs`` (sets, ndim), the same sums in the same order."""
        vecs = np.atleast_2d(np.asarray(vecs, float))
        block = self.__dict__.get("_prior_block")
        if block is None or len(block.priors) != len(self.priors) or any(
                a is not b for a, b in zip(block.priors, self.priors)):
            self.__dict__["_prior_block"] = block = PriorBlock(self.priors)
        return block.log_density(vecs)

    def log_prob_many(self, vecs: np.ndarray) -> np.ndarray:
        """Log posterior of each row of ``vecs``, shape ``(sets, ndim)`` -> ``(sets,)``.

        The same numbers as :meth:`log_prob` row by row and the same failure counts.  Priors are
        evaluated on the whole array; the likelihood of the rows inside the priors comes from
        the problem's ``_log_likelihood_many(vecs)`` when it sets ``vectorized`` (one batch
        computation for the ensemble, with its own fallback to :meth:`log_likelihood` for sets
        the batch cannot finish), else from ``log_likelihood`` one row at a time.
        """
        vecs = np.atleast_2d(np.asarray(vecs, float))
        lp = self.log_prior_many(vecs)
        inside = np.isfinite(lp)
        vectorized = getattr(self, "vectorized", False)
        if vectorized and inside.all():  # the usual case: every row, no gathering
            return lp + self._log_likelihood_many(vecs)
        out = np.full(vecs.shape[0], -math.inf)
        rows = np.flatnonzero(inside)
        if rows.size == 0:
            return out
        if vectorized:
            out[rows] = lp[rows] + self._log_likelihood_many(vecs[rows])
        else:
            out[rows] = lp[rows] + np.array([self.log_likelihood(self.values(vecs[i])) for i in rows])
        return out

    def log_prior(self, vec: np.ndarray) -> float:
        """Sum of the free parameters' log prior densities (``-inf`` outside the bounds).

        The very sums of :meth:`log_prior_many` (one row), so a sampler's one-set and
        whole-ensemble paths agree to the last bit."""
        return float(self.log_prior_many(np.asarray(vec, float)[None, :])[0])

    def log_prob(self, vec: np.ndarray) -> float:
        """Log posterior (up to a constant); ``-inf`` outside the prior or on failure.

        The problem supplies ``log_likelihood(values)``, which returns ``-inf`` (with the
        reason counted) when the forward model fails.
        """
        lp = self.log_prior(vec)
        if not math.isfinite(lp):
            return -math.inf
        return lp + self.log_likelihood(self.values(vec))
