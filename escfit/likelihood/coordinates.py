"""Sampler coordinates: a bijection between a problem's parameter vector x and the vector u a sampler moves.

A posterior that lies on a curved ridge in x mixes slowly under emcee's moves, which are
affine invariant but not invariant under bending.  A problem may declare coordinates in which
the ridge is nearly straight (:attr:`~escfit.likelihood.problem.ProblemBase.sampler_coordinates`);
the sampler then draws u from the density

    log p_u(u) = log p(x(u)) + log |det dx/du|

and every draw is mapped back to x before anyone sees it (chains, convergence checks,
summaries, reports).  The default, no declared coordinates, leaves the sampler in x.

:class:`AR1Coordinates` is the one in use: AR(1) reading noise with marginal scale ``sigma``
and lag-1 correlation ``rho`` has innovations of scale ``s_e = sigma * sqrt(1 - rho**2)``.  The
data fix ``s_e`` and ``rho`` almost independently, so in (sigma, rho) the posterior follows the
curve ``sigma = s_e / sqrt(1 - rho**2)``, steep near rho = 1.  In

    u1 = log(sigma * sqrt(1 - rho**2))     (log innovation scale)
    u2 = atanh(rho)

it is close to a normal ellipse; the inverse is ``rho = tanh(u2)``, ``sigma = exp(u1) cosh(u2)``
and ``log|det dx/du| = log(sigma) + log(1 - rho**2) = u1 - log cosh(u2)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["SamplerCoordinates", "AR1Coordinates", "log_cosh"]


@runtime_checkable
class SamplerCoordinates(Protocol):
    """A bijection between a problem's parameter vectors x and the sampler's u, row-wise.

    Attributes
    ----------
    name : str
        Recorded in the sampler's checkpoint: a run resumes only in the coordinates it was drawn in.
    """

    name: str

    def in_domain(self, x: np.ndarray) -> np.ndarray:
        """Boolean per row of ``x``: whether the transform is defined there."""

    def to_sampler(self, x: np.ndarray) -> np.ndarray:
        """u of each row of ``x`` (NaN where :meth:`in_domain` is false)."""

    def to_problem(self, u: np.ndarray) -> np.ndarray:
        """x of each row of ``u``."""

    def log_jacobian(self, u: np.ndarray) -> np.ndarray:
        """``log|det dx/du|`` of each row of ``u``."""


def log_cosh(z: np.ndarray) -> np.ndarray:
    """``log(cosh(z))`` without overflow: ``|z| + log1p(exp(-2|z|)) - log 2``."""
    a = np.abs(z)
    return a + np.log1p(np.exp(-2.0 * a)) - math.log(2.0)


@dataclass(frozen=True)
class AR1Coordinates:
    """Log innovation scale and atanh of the correlation in place of an AR(1) noise's (sigma, rho).

    Parameters
    ----------
    sigma, rho
        Positions of the marginal noise scale (> 0, the readings' unit) and of the lag-1
        correlation (in (-1, 1)) in the problem's parameter vector; every other component is
        sampled as it is.

    All methods take and return arrays of shape ``(rows, ndim)`` (or ``(ndim,)``).
    """

    sigma: int
    rho: int

    @property
    def name(self) -> str:
        """What a checkpoint records: the kind and the two positions (a run resumes only in its own coordinates)."""
        return f"ar1(sigma={self.sigma},rho={self.rho})"

    def in_domain(self, x: np.ndarray) -> np.ndarray:
        """Rows of ``x`` the transform is defined at: finite, sigma > 0 and |rho| < 1."""
        x = np.asarray(x, float)
        s, r = x[..., self.sigma], x[..., self.rho]
        return np.isfinite(s) & (s > 0.0) & np.isfinite(r) & (np.abs(r) < 1.0)

    def to_sampler(self, x: np.ndarray) -> np.ndarray:
        """u of each row of ``x``; rows outside :meth:`in_domain` give NaN in the two noise components."""
        x = np.asarray(x, float)
        u = x.copy()
        ok = self.in_domain(x)
        s = np.where(ok, x[..., self.sigma], 1.0)
        r = np.where(ok, x[..., self.rho], 0.0)
        u[..., self.sigma] = np.where(ok, np.log(s) + 0.5 * np.log1p(-r * r), np.nan)
        u[..., self.rho] = np.where(ok, np.arctanh(r), np.nan)
        return u

    def to_problem(self, u: np.ndarray) -> np.ndarray:
        """x of each row of ``u`` (any finite u maps into the domain, up to rounding of tanh near +-1)."""
        u = np.asarray(u, float)
        x = u.copy()
        with np.errstate(over="ignore"):
            x[..., self.sigma] = np.exp(u[..., self.sigma] + log_cosh(u[..., self.rho]))
        x[..., self.rho] = np.tanh(u[..., self.rho])
        return x

    def log_jacobian(self, u: np.ndarray) -> np.ndarray:
        """``log|det dx/du|`` of each row of ``u``: ``u1 - log cosh(u2)`` (finite for any finite u)."""
        u = np.asarray(u, float)
        return u[..., self.sigma] - log_cosh(u[..., self.rho])
