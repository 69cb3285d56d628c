"""The five prior forms' cumulative distributions and their inverses, in closed form.

:class:`~escfit.likelihood.priors.Prior` needs, for its untruncated form, the cdf, the survival
function and their inverses (to renormalise on the bounds and to draw by inverse cdf).  Each is
a one-line formula in the standard normal cdf ``ndtr`` and its inverse ``ndtri`` (or ``erf``,
``erfc`` and their inverses for the half-normal), so scipy.special suffices; ``scipy.stats``,
which the command line would otherwise import for five formulas, costs a second of start-up.
The tests compare every function with scipy.stats (``tests/test_priors.py``).

Conventions as scipy.stats: ``uniform(a, b)`` on [a, b]; ``loguniform(a, b)``; ``normal(mu,
sd)``; ``halfnormal(sd)`` on [0, inf); ``lognormal(mu, sigma)`` of ``log x ~ normal(mu, sigma)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy import special

__all__ = ["Distribution", "distribution"]

_SQRT2 = math.sqrt(2.0)


@dataclass(frozen=True)
class Distribution:
    """``cdf``, ``sf`` (1 - cdf, accurate in the upper tail), ``ppf`` and ``isf`` (their inverses),
    and ``logcdf``/``logsf`` (accurate far in the tails where cdf/sf underflow)."""

    cdf: Callable[[np.ndarray], np.ndarray]
    sf: Callable[[np.ndarray], np.ndarray]
    ppf: Callable[[np.ndarray], np.ndarray]
    isf: Callable[[np.ndarray], np.ndarray]
    logcdf: Callable[[np.ndarray], np.ndarray] | None = None
    logsf: Callable[[np.ndarray], np.ndarray] | None = None

    def __post_init__(self):
        def log_of(f):
            def g(x):
                with np.errstate(divide="ignore"):
                    return np.log(f(x))
            return g
        if self.logcdf is None:
            object.__setattr__(self, "logcdf", log_of(self.cdf))
        if self.logsf is None:
            object.__setattr__(self, "logsf", log_of(self.sf))


def _f(x) -> np.ndarray:
    return np.asarray(x, dtype=float)


def distribution(kind: str, args: tuple[float, ...]) -> Distribution:
    """The untruncated form ``kind`` with arguments ``args`` (canonical units)."""
    if kind == "uniform":
        a, b = args
        w = b - a
        return Distribution(lambda x: np.clip((_f(x) - a) / w, 0.0, 1.0), lambda x: np.clip((b - _f(x)) / w, 0.0, 1.0),
                            lambda u: a + _f(u) * w, lambda u: b - _f(u) * w)
    if kind == "loguniform":
        a, b = args
        span = math.log(b / a)

        def cdf(x):
            x = np.clip(_f(x), a, b)
            return np.log(x / a) / span

        def sf(x):
            x = np.clip(_f(x), a, b)
            return np.log(b / x) / span
        return Distribution(cdf, sf, lambda u: a * np.exp(_f(u) * span), lambda u: b * np.exp(-_f(u) * span))
    if kind == "normal":
        mu, sd = args
        return Distribution(lambda x: special.ndtr((_f(x) - mu) / sd), lambda x: special.ndtr((mu - _f(x)) / sd),
                            lambda u: mu + sd * special.ndtri(_f(u)), lambda u: mu - sd * special.ndtri(_f(u)),
                            lambda x: special.log_ndtr((_f(x) - mu) / sd), lambda x: special.log_ndtr((mu - _f(x)) / sd))
    if kind == "halfnormal":
        (sd,) = args
        scale = sd * _SQRT2

        def logcdf(x):
            y = np.maximum(_f(x), 0.0) / scale
            with np.errstate(divide="ignore"):
                return np.where(y < 1.0, np.log(special.erf(y)), np.log1p(-special.erfc(y)))
        return Distribution(lambda x: special.erf(np.maximum(_f(x), 0.0) / scale),
                            lambda x: special.erfc(np.maximum(_f(x), 0.0) / scale),
                            lambda u: scale * special.erfinv(_f(u)), lambda u: scale * special.erfcinv(_f(u)),
                            logcdf, lambda x: math.log(2.0) + special.log_ndtr(-np.maximum(_f(x), 0.0) / sd))
    if kind == "lognormal":
        mu, s = args

        def z(x):
            x = _f(x)
            with np.errstate(divide="ignore", invalid="ignore"):
                return np.where(x > 0, (np.log(np.where(x > 0, x, 1.0)) - mu) / s, -np.inf)
        return Distribution(lambda x: special.ndtr(z(x)), lambda x: special.ndtr(-z(x)),
                            lambda u: np.exp(mu + s * special.ndtri(_f(u))),
                            lambda u: np.exp(mu - s * special.ndtri(_f(u))),
                            lambda x: special.log_ndtr(z(x)), lambda x: special.log_ndtr(-z(x)))
    raise ValueError(f"no closed form for prior kind {kind!r}")
