"""The Jacobian of least squares' residual vector: the problem's sensitivities, else batched differences.

The vector :func:`escfit.inference.lsq.least_squares` minimises is the readings' standardised
residuals divided by the current noise scale, then one row per Gaussian prior.  Its Jacobian is:

* the problem's own where it has one (``has_sensitivities`` true and ``residual_jacobian(values,
  names)``, e.g. a waveform fit
  differentiated by the integrator's forward sensitivities,
  :mod:`escfit.balance.problems.waveform_jacobian`), with the prior rows' slopes
  (:func:`~escfit.likelihood.problem.gaussian_prior_slopes`);
* else, and wherever the problem returns None (a point its sensitivities do not cover), scipy's
  "2-point" forward differences with every stepped point in one ``residuals_many`` call
  (:func:`~escfit.inference.fdjac.batch_jacobian`), the base point's residuals reused from the
  evaluation scipy just made there.

Which way each Jacobian was made is counted in the problem's ``jacobians`` (when it keeps one),
for the results to state.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from ..likelihood.problem import gaussian_prior_slopes, stacked_residuals
from .fdjac import batch_jacobian

__all__ = ["LeastSquaresJacobian"]


@dataclass
class LeastSquaresJacobian:
    """``jac(x)`` for scipy's trust-region method (see the module docstring).

    Attributes
    ----------
    problem
        The fit problem.
    names
        The fitted parameters, in ``x``'s order.
    fixed
        Parameters held at given values.
    priors
        The fitted parameters' priors.
    scale
        A one-element list: the noise scale the readings' residuals are divided by (it changes
        while the fit settles it).
    last
        The residual function's latest evaluation (``x``, ``scale``, ``out``).
    bounds
        ``(lower, upper)`` of ``x``.
    rel_step
        scipy's ``diff_step`` for the forward differences (None: its default).
    """

    problem: object
    names: list
    fixed: dict
    priors: list
    scale: list
    last: dict
    bounds: tuple
    rel_step: float | None = None

    def __post_init__(self) -> None:
        base = self.problem.values(dict(self.fixed))
        self._full = np.array([base[nm] for nm in self.problem.names], float)
        self._cols = [self.problem.names.index(nm) for nm in self.names]
        self._n = self.problem.n_data
        has = getattr(self.problem, "has_sensitivities", False)
        self._exact = getattr(self.problem, "residual_jacobian", None) if has else None
        self._counts = getattr(self.problem, "jacobians", Counter())

    def __call__(self, x: np.ndarray) -> np.ndarray:
        if self._exact is not None:
            vals = self.problem.values({**self.fixed, **dict(zip(self.names, (float(v) for v in x)))})
            jac = self._exact(vals, self.names)
            if jac is not None:
                self._counts["sensitivities"] += 1
                return np.vstack([np.asarray(jac, float)[:self._n] / self.scale[0],
                                  gaussian_prior_slopes(self.priors, x)])
        self._counts["forward differences"] += 1
        last = self.last
        seen = "x" in last and last["scale"] == self.scale[0] and np.array_equal(last["x"], x)
        lo, hi = self.bounds
        return batch_jacobian(self._rows, x, lo, hi, f0=last["out"] if seen else None, rel_step=self.rel_step)

    def _rows(self, points: np.ndarray) -> np.ndarray:
        """The residual vectors of many points in one ``residuals_many`` call."""
        vecs = np.repeat(self._full[None, :], points.shape[0], axis=0)
        vecs[:, self._cols] = points
        r = np.asarray(self.problem.residuals_many(vecs), float)[:, :self._n] / self.scale[0]
        return np.array([stacked_residuals(ri, self.priors, p) for ri, p in zip(r, points)])
