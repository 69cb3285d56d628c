"""The log prior of a whole free-parameter vector, for many vectors at once.

A sampler evaluates the priors of every walker at every step, several times a step with
many sub-ensembles; one :meth:`~escfit.likelihood.priors.Prior.logpdf_array` call per
parameter costs about ten numpy calls each, more than the arithmetic.  :class:`PriorBlock`
groups the parameters by the form of their prior and evaluates each group on all its columns
at once, with the same element-wise operations in the same order as
:meth:`Prior.logpdf_array`, and adds the columns left to right as a loop over the priors
would: the same numbers to the last bit (``tests/test_prior_block.py`` checks that).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from .priors import _LOG_2PI_HALF, Prior

__all__ = ["PriorBlock"]


class PriorBlock:
    """Log density of a vector of independent truncated priors, row by row.

    Parameters
    ----------
    priors
        One :class:`~escfit.likelihood.priors.Prior` per column, in vector order.
    """

    def __init__(self, priors: Sequence[Prior]) -> None:
        self.priors = tuple(priors)
        self.lo = np.array([p.lo for p in self.priors], float)
        self.hi = np.array([p.hi for p in self.priors], float)
        groups = [self._group(kind) for kind in ("uniform", "flat", "loguniform", "normal", "halfnormal", "lognormal")]
        # the forms whose density inside the bounds is one number per column fill a base row once
        self._base = np.zeros(len(self.priors))
        for kind, cols, consts in groups[:2]:
            self._base[cols] = consts[0]
        self._groups = [g for g in groups[2:] if g[2][0].size]  # forms present

    def _group(self, kind: str) -> tuple[str, np.ndarray | slice, tuple[np.ndarray, ...]]:
        """``(kind, columns, constants)``: the columns with this form and the per-column numbers
        :meth:`Prior.logpdf_array` uses (each a row vector to broadcast over the sets)."""
        cols = [i for i, p in enumerate(self.priors) if p.kind == kind]
        ps = [self.priors[i] for i in cols]
        mass = np.array([p.log_mass for p in ps], float)

        def arg(k):
            return np.array([p.args[k] for p in ps], float)

        if kind == "uniform":  # np.full(-log(b - a)) - log_mass, as one number per column
            consts = (np.array([-math.log(p.args[1] - p.args[0]) for p in ps], float) - mass,)
        elif kind == "flat":
            consts = (np.zeros(len(ps)) - mass,)
        elif kind == "loguniform":
            consts = (np.array([math.log(math.log(p.args[1] / p.args[0])) for p in ps], float), mass)
        elif kind == "normal":
            consts = (arg(0), arg(1), np.array([math.log(p.args[1]) for p in ps], float), mass)
        elif kind == "halfnormal":
            consts = (arg(0), np.array([math.log(p.args[0]) for p in ps], float), mass)
        else:  # lognormal
            consts = (arg(0), arg(1), np.array([math.log(p.args[1]) for p in ps], float), mass)
        idx = np.array(cols, np.intp)
        if cols and cols == list(range(cols[0], cols[-1] + 1)):  # contiguous: a slice reads a view
            return kind, slice(cols[0], cols[-1] + 1), consts
        return kind, idx, consts

    def columns(self, x: np.ndarray) -> np.ndarray:
        """Each prior's log density at each row of ``x`` (sets, ndim), ``-inf`` outside its support;
        the caller sets ``np.errstate``."""
        out = np.repeat(self._base[None, :], x.shape[0], axis=0)
        for kind, cols, c in self._groups:
            v = x[:, cols]
            if kind == "loguniform":
                val = -np.log(v) - c[0] - c[1]
            elif kind == "normal":
                z = (v - c[0]) / c[1]
                val = -0.5 * z * z - c[2] - _LOG_2PI_HALF - c[3]
            elif kind == "halfnormal":
                z = v / c[0]
                val = -0.5 * z * z - c[1] + 0.5 * math.log(2.0 / math.pi) - c[2]
            else:
                lx = np.log(v)
                z = (lx - c[0]) / c[1]
                val = -0.5 * z * z - lx - c[2] - _LOG_2PI_HALF - c[3]
            out[:, cols] = val
        return np.where((x >= self.lo) & (x <= self.hi), out, -np.inf)

    def log_density(self, x: np.ndarray) -> np.ndarray:
        """Sum of the priors' log densities at each row of ``x`` (sets, ndim), added left to
        right (a running sum is sequential, unlike numpy's pairwise ``sum``)."""
        if x.shape[1] == 0:
            return np.zeros(x.shape[0])
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return np.cumsum(self.columns(x), axis=1)[:, -1]
