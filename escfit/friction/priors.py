"""Explicit prior densities for the rig's parameters.

A prior is written in the scene as a string such as ``"normal(0, 0.02 / gf)"``,
``"uniform(0, 1)"``, ``"halfnormal(0.05)"`` or ``"loguniform(1e-6 N, 1e-2 N)"``.  Each
argument may carry a unit; it is converted to the parameter's canonical unit.  Every prior
is also truncated to the parameter's ``[min, max]`` and renormalised there, so densities
(needed for Savage-Dickey Bayes factors) are proper.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import pint
from scipy import stats

from ..errors import SceneError
from ..units import ureg

__all__ = ["Prior", "parse_prior", "uniform", "normal", "loguniform"]

_SPEC = re.compile(r"^\s*([a-z]+)\s*\((.*)\)\s*$")
_ARITY = {"normal": 2, "uniform": 2, "halfnormal": 1, "loguniform": 2}


@dataclass(frozen=True)
class Prior:
    """A one-dimensional prior truncated to ``[lower, upper]``.

    Attributes
    ----------
    family
        ``"normal"``, ``"uniform"``, ``"halfnormal"`` or ``"loguniform"``.
    args
        Family arguments in the canonical unit (normal: mean, sd; uniform and loguniform:
        low, high; halfnormal: sd, with support ``x >= 0``).
    lower, upper
        Truncation bounds in the canonical unit (may be infinite).
    """

    family: str
    args: tuple[float, ...]
    lower: float = -math.inf
    upper: float = math.inf

    def _dist(self):
        if self.family == "normal":
            return stats.norm(self.args[0], self.args[1])
        if self.family == "halfnormal":
            return stats.halfnorm(0.0, self.args[0])
        if self.family == "uniform":
            return stats.uniform(self.args[0], self.args[1] - self.args[0])
        return stats.loguniform(self.args[0], self.args[1])

    @property
    def support(self) -> tuple[float, float]:
        """Interval where the density is positive."""
        lo, hi = self.lower, self.upper
        if self.family in ("uniform", "loguniform"):
            lo, hi = max(lo, self.args[0]), min(hi, self.args[1])
        elif self.family == "halfnormal":
            lo = max(lo, 0.0)
        return lo, hi

    @cached_property
    def _log_mass(self) -> float:
        lo, hi = self.support
        dist = self._dist()
        return math.log(float(dist.cdf(hi) - dist.cdf(lo)))

    def _mass(self) -> float:
        return math.exp(self._log_mass)

    def logpdf(self, x):
        """Log density (normalised on the support), ``-inf`` outside it; vectorised."""
        x = np.asarray(x, dtype=float)
        lo, hi = self.support
        a = self.args
        if self.family == "normal":
            out = -0.5 * ((x - a[0]) / a[1]) ** 2 - math.log(a[1] * math.sqrt(2 * math.pi))
        elif self.family == "halfnormal":
            out = -0.5 * (x / a[0]) ** 2 + math.log(math.sqrt(2 / math.pi) / a[0])
        elif self.family == "uniform":
            out = np.full(x.shape, -math.log(a[1] - a[0]))
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                out = -np.log(x) - math.log(math.log(a[1] / a[0]))
        inside = (x >= lo) & (x <= hi)
        return np.where(inside, out - self._log_mass, -np.inf)

    def pdf(self, x):
        """Density, see :meth:`logpdf`."""
        return np.exp(self.logpdf(x))

    def describe(self) -> str:
        """Readable form with canonical-unit arguments and truncation."""
        inner = ", ".join(f"{a:.6g}" for a in self.args)
        lo, hi = self.support
        return f"{self.family}({inner}) on [{lo:.6g}, {hi:.6g}]"


def uniform(lower: float, upper: float) -> Prior:
    """Flat prior between finite bounds."""
    return Prior("uniform", (lower, upper), lower, upper)


def normal(mean: float, sd: float, lower: float = -math.inf, upper: float = math.inf) -> Prior:
    """Normal prior, truncated to ``[lower, upper]``."""
    return Prior("normal", (mean, sd), lower, upper)


def loguniform(lower: float, upper: float) -> Prior:
    """Prior flat in the logarithm (scale-free), between positive bounds."""
    return Prior("loguniform", (lower, upper), lower, upper)


def parse_prior(spec: str, *, unit: str, where: str, lower: float = -math.inf,
                upper: float = math.inf) -> Prior:
    """Read a prior string, converting its arguments to ``unit``.

    Parameters
    ----------
    spec
        E.g. ``"normal(0, 0.005 s/ft)"``; bare numbers are taken in ``unit``.
    unit
        Canonical unit of the parameter (pint syntax, ``""`` for dimensionless).
    where
        ``"file [key]"`` for messages.
    lower, upper
        The parameter's bounds; the prior is truncated to them.

    Raises
    ------
    SceneError
        Unknown family, wrong number of arguments, an argument that is not a quantity of
        the parameter's unit, or arguments that give no proper density.
    """
    m = _SPEC.match(spec)
    if not m or m.group(1) not in _ARITY:
        raise SceneError(
            f"cannot read prior {spec!r}; use one of normal(mean, sd), uniform(low, high), "
            f"halfnormal(sd), loguniform(low, high)",
            where,
        )
    family, body = m.group(1), m.group(2)
    parts = [p.strip() for p in body.split(",")] if body.strip() else []
    if len(parts) != _ARITY[family]:
        raise SceneError(f"prior {spec!r}: {family} takes {_ARITY[family]} argument(s), got {len(parts)}", where)
    args = tuple(_argument(p, unit, spec, where) for p in parts)
    if family in ("normal", "halfnormal") and not args[-1] > 0:
        raise SceneError(f"prior {spec!r}: the standard deviation must be positive", where)
    if family in ("uniform", "loguniform") and not args[0] < args[1]:
        raise SceneError(f"prior {spec!r}: low must be below high", where)
    if family == "loguniform" and not args[0] > 0:
        raise SceneError(f"prior {spec!r}: loguniform needs a positive lower end", where)
    prior = Prior(family, args, lower, upper)
    lo, hi = prior.support
    if not lo < hi or not prior._mass() > 0:
        raise SceneError(f"prior {spec!r} has no mass inside the bounds [{lower:g}, {upper:g}]", where)
    return prior


def _argument(text: str, unit: str, spec: str, where: str) -> float:
    try:
        q = ureg.Quantity(text)
    except Exception:  # pint raises several types for malformed input
        raise SceneError(f"prior {spec!r}: cannot read argument {text!r}", where) from None
    if not isinstance(q, pint.Quantity):
        value = float(q)
    elif q.dimensionless and not unit:
        value = float(q.to("").magnitude)
    elif q.unitless:
        value = float(q.magnitude)
    else:
        try:
            value = float(q.to(unit or "").magnitude)
        except pint.DimensionalityError:
            raise SceneError(
                f"prior {spec!r}: argument {text!r} is not in units of {unit or 'dimensionless'}", where
            ) from None
    if not math.isfinite(value):
        raise SceneError(f"prior {spec!r}: argument {text!r} is not finite", where)
    return value
