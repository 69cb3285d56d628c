"""Prior distributions, written in scene files as strings.

Supported forms (numbers in the parameter's canonical unit):

- ``uniform(a, b)``, ``loguniform(a, b)`` (``0 < a < b``)
- ``normal(mu, sd)``, ``halfnormal(sd)`` (on ``[0, inf)``)
- ``lognormal(mu, sigma)`` (``log(x) ~ normal(mu, sigma)``)

A parameter without a prior gets a uniform prior between its bounds.  Bounds are always
enforced: outside them the log prior is ``-inf``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..params import Param

__all__ = ["Prior", "parse_prior"]

_FORM = re.compile(r"^\s*([a-z_]+)\s*\(([^()]*)\)\s*$")
_ARITY = {"uniform": 2, "loguniform": 2, "normal": 2, "halfnormal": 1, "lognormal": 2}


@dataclass(frozen=True)
class Prior:
    """A univariate prior with bounds ``lo, hi``."""

    kind: str
    args: tuple[float, ...]
    lo: float
    hi: float

    def logpdf(self, x: float) -> float:
        if not (self.lo <= x <= self.hi):
            return -math.inf
        k, a = self.kind, self.args
        if k == "uniform":
            return -math.log(a[1] - a[0]) if math.isfinite(a[1] - a[0]) else 0.0
        if k == "loguniform":
            return -math.log(x) - math.log(math.log(a[1] / a[0])) if x > 0 else -math.inf
        if k == "normal":
            z = (x - a[0]) / a[1]
            return -0.5 * z * z - math.log(a[1] * math.sqrt(2 * math.pi))
        if k == "halfnormal":
            z = x / a[0]
            return -0.5 * z * z + math.log(2 / (a[0] * math.sqrt(2 * math.pi))) if x >= 0 else -math.inf
        if x <= 0:
            return -math.inf
        z = (math.log(x) - a[0]) / a[1]
        return -0.5 * z * z - math.log(x * a[1] * math.sqrt(2 * math.pi))

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """Draws from the prior restricted to the bounds (rejection, used for start points)."""
        k, a = self.kind, self.args
        out = np.empty(0)
        for _ in range(100):
            if k == "uniform":
                x = rng.uniform(a[0], a[1], n)
            elif k == "loguniform":
                x = np.exp(rng.uniform(math.log(a[0]), math.log(a[1]), n))
            elif k == "normal":
                x = rng.normal(a[0], a[1], n)
            elif k == "halfnormal":
                x = np.abs(rng.normal(0, a[0], n))
            else:
                x = rng.lognormal(a[0], a[1], n)
            out = np.concatenate([out, x[(x >= self.lo) & (x <= self.hi)]])
            if out.size >= n:
                return out[:n]
        raise SceneError(f"prior {self} puts almost no mass inside its bounds [{self.lo:g}, {self.hi:g}]")


def parse_prior(p: Param, where: str = "") -> Prior:
    """The prior of parameter ``p`` (its ``prior`` string, or uniform on its bounds)."""
    w = where or p.name
    if p.prior is None:
        return Prior("uniform", (p.min, p.max), p.min, p.max)
    m = _FORM.match(p.prior)
    if not m or m.group(1) not in _ARITY:
        raise SceneError(f"cannot read prior {p.prior!r}; forms: " + ", ".join(f"{k}(...)" for k in _ARITY), w)
    kind = m.group(1)
    try:
        args = tuple(float(t) for t in m.group(2).split(","))
    except ValueError:
        raise SceneError(f"prior {p.prior!r} has a non-numeric argument", w) from None
    if len(args) != _ARITY[kind]:
        raise SceneError(f"prior {kind} takes {_ARITY[kind]} argument(s), got {p.prior!r}", w)
    bad = ((kind in ("uniform", "loguniform") and not args[0] < args[1])
           or (kind == "loguniform" and not args[0] > 0)
           or (kind in ("normal", "lognormal") and not args[1] > 0)
           or (kind == "halfnormal" and not args[0] > 0))
    if bad:
        raise SceneError(f"prior {p.prior!r} has impossible arguments", w)
    lo, hi = p.min, p.max
    if kind in ("uniform", "loguniform"):
        lo, hi = max(lo, args[0]), min(hi, args[1])
    if kind in ("loguniform", "lognormal", "halfnormal"):
        lo = max(lo, 0.0)
    if not lo < hi:
        raise SceneError(f"prior {p.prior!r} and bounds [{p.min:g}, {p.max:g}] leave no room", w)
    return Prior(kind, args, lo, hi)
