"""The space emcee moves in: the problem's parameters, or the coordinates it declares for sampling.

A problem whose :attr:`~escfit.likelihood.problem.ProblemBase.sampler_coordinates` is set
(:mod:`escfit.likelihood.coordinates`) is sampled in those coordinates u, with the density
``log p(x(u)) + log|det dx/du|`` so that the draws mapped back to x follow the posterior
exactly.  :func:`sampler_space` gives the object :mod:`escfit.inference.mcmc` works through:
the sampler's log density, and the maps between the sampler's draws and what users see (x and
the x-space log posterior).  Without declared coordinates it is :data:`IDENTITY`, whose maps
return their arguments untouched, so such runs draw bit for bit what they drew before.
"""

from __future__ import annotations

import math

import numpy as np

from ..likelihood.coordinates import SamplerCoordinates
from ..likelihood.problem import Problem

__all__ = ["SamplerSpace", "Transformed", "IDENTITY", "sampler_space"]


class SamplerSpace:
    """The problem's own parameters (no declared coordinates)."""

    name = "identity"
    transformed = False

    def to_problem(self, u: np.ndarray) -> np.ndarray:
        return u

    def to_sampler(self, x: np.ndarray) -> np.ndarray:
        return x

    def problem_log_prob(self, u: np.ndarray, lp: np.ndarray) -> np.ndarray:
        """The problem's log posterior at draws ``u`` whose sampler log density is ``lp``."""
        return lp


IDENTITY = SamplerSpace()


class Transformed(SamplerSpace):
    """Sampling in a problem's declared coordinates.

    Parameters
    ----------
    problem
        Its :meth:`~escfit.likelihood.problem.Problem.log_prob_many` is evaluated at x(u).
    coords
        The bijection (:class:`~escfit.likelihood.coordinates.SamplerCoordinates`).
    """

    transformed = True

    def __init__(self, problem: Problem, coords: SamplerCoordinates) -> None:
        self.problem, self.coords = problem, coords
        self.name = str(coords.name)

    def to_problem(self, u: np.ndarray) -> np.ndarray:
        return self.coords.to_problem(u)

    def to_sampler(self, x: np.ndarray) -> np.ndarray:
        return self.coords.to_sampler(x)

    def problem_log_prob(self, u: np.ndarray, lp: np.ndarray) -> np.ndarray:
        """``lp - log|det dx/du|``; -inf stays -inf."""
        lp = np.asarray(lp, float)
        with np.errstate(invalid="ignore"):
            return np.where(np.isfinite(lp), lp - self.coords.log_jacobian(u), -math.inf)

    def log_prob_many(self, u: np.ndarray) -> np.ndarray:
        """The sampler's log density at each row of ``u``, shape ``(sets, ndim)`` -> ``(sets,)``.

        Rows whose x falls outside the transform's domain (rounding of tanh near +-1, overflow
        of the scale) or whose log posterior is not finite give -inf, never NaN.
        """
        u = np.atleast_2d(np.asarray(u, float))
        finite = np.isfinite(u).all(axis=1)
        with np.errstate(over="ignore", invalid="ignore"):
            x = self.coords.to_problem(u if finite.all() else np.where(finite[:, None], u, 0.0))
        usable = finite & self.coords.in_domain(x) & np.isfinite(x).all(axis=1)
        if usable.all():  # the usual case: every row, no gathering
            lp = np.asarray(self.problem.log_prob_many(x), float) + self.coords.log_jacobian(u)
            return np.where(np.isfinite(lp), lp, -math.inf)
        out = np.full(u.shape[0], -math.inf)
        rows = np.flatnonzero(usable)
        if rows.size == 0:
            return out
        lp = np.asarray(self.problem.log_prob_many(x[rows]), float)
        lp = lp + self.coords.log_jacobian(u[rows])
        out[rows] = np.where(np.isfinite(lp), lp, -math.inf)
        return out


def sampler_space(problem: Problem) -> SamplerSpace:
    """The space a sampler of ``problem`` moves in: its declared coordinates, or :data:`IDENTITY`."""
    coords = getattr(problem, "sampler_coordinates", None)
    return IDENTITY if coords is None else Transformed(problem, coords)
