"""Prior distributions of fit parameters, written in scene files as strings.

One grammar serves every model family (balance, friction rig, Geneva, verge).

Forms
-----
``uniform(a, b)``
    Flat between ``a < b``.
``loguniform(a, b)``
    Flat in ``log x`` between ``0 < a < b`` (scale-free).
``normal(mu, sd)``
    Gaussian, ``sd > 0``.
``halfnormal(sd)``
    ``|N(0, sd)|``, on ``x >= 0``.
``lognormal(mu, sigma)``
    ``log(x / u) ~ normal(mu, sigma)`` with ``u`` one canonical unit of the parameter: ``mu``
    and ``sigma`` are dimensionless numbers (a log of the value in the canonical unit, and a
    spread in e-folds) and take no unit.  ``exp(mu)`` is the median.

Every argument of the first four forms is either a bare number, taken in the parameter's
canonical unit, or a number followed by a unit, converted to that unit:
``"normal(0, 0.02 / gf)"`` for a parameter in 1/N, ``"loguniform(1e-6 N, 1e-2 N)"``,
``"normal(1.2, 2 deg)"`` for an angle in rad.  Units are read by a small bounded grammar
(unit names, ``*``, ``/``, parentheses and one- or two-digit integer powers of a unit name,
at most 40 characters) before pint sees them, because pint evaluates arithmetic and
``9**9**9`` would never return.

Truncation
----------
Every prior is truncated to the parameter's ``[min, max]`` and renormalised there, so
:meth:`Prior.logpdf` is a proper log density on :attr:`Prior.lo`, :attr:`Prior.hi` (needed by
Savage-Dickey Bayes factors).  The log of the mass inside the bounds is computed once from
closed-form cdfs (or survival functions in the upper tail,
:mod:`escfit.likelihood.distributions`).  A prior with no mass inside the
bounds, or with impossible or non-finite arguments, is refused with a :class:`SceneError`.

Parameters without a prior string
---------------------------------
:func:`prior_of` gives a parameter without a ``prior`` a uniform prior on its bounds.  When a
bound is infinite no proper default exists: by default that is refused (give min and max or
a proper prior), but balance fits (and the study reweighting that re-reads their scenes) pass
``allow_improper=True`` and keep an *improper flat* prior (kind ``"flat"``): log density 0 on
the bounds, ``-inf`` outside, no sampling.  Balance scenes rely on it for parameters such as
``fit.kappa`` (free, unbounded by default) or a user's free offset without bounds; their
posteriors are proper through the likelihood.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from ..core.errors import SceneError
from .distributions import distribution
from ..core.params import Param
from ..core.units import COMMON_UNITS, MAX_UNIT_TEXT, registry, safe_unit_text

__all__ = ["Prior", "parse_prior", "prior_of", "FORMS", "uniform", "loguniform", "normal", "halfnormal",
           "lognormal", "flat"]

#: prior form -> its arguments, for messages
FORMS = {"uniform": "a, b", "loguniform": "a, b", "normal": "mu, sd", "halfnormal": "sd",
         "lognormal": "mu, sigma"}
_ARITY = {k: len(v.split(",")) for k, v in FORMS.items()}
_LOG_2PI_HALF = 0.5 * math.log(2.0 * math.pi)
_MAX_SPEC = 200

_SPEC = re.compile(r"^\s*([A-Za-z_]+)\s*\((.*)\)\s*$", re.S)
_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)")
_NONFINITE = re.compile(r"\s*[-+]?(?:nan|inf|infinity)\s*$", re.I)


@dataclass(frozen=True)
class Prior:
    """A one-dimensional prior truncated to ``[lower, upper]`` and renormalised there.

    Attributes
    ----------
    kind
        ``"uniform"``, ``"loguniform"``, ``"normal"``, ``"halfnormal"``, ``"lognormal"``, or
        ``"flat"`` (improper, see :func:`flat`).
    args
        The form's arguments in the canonical unit (lognormal: dimensionless ``mu, sigma`` of
        ``log x``; flat: none).
    lower, upper
        Truncation bounds (the parameter's min and max, may be infinite).

    Raises
    ------
    SceneError
        Unknown kind, wrong number of arguments, impossible or non-finite arguments, NaN
        bounds, or no mass inside the bounds.
    """

    kind: str
    args: tuple[float, ...]
    lower: float = -math.inf
    upper: float = math.inf
    _log_mass: float = field(init=False, repr=False, compare=False, default=0.0)
    _upper_tail: bool = field(init=False, repr=False, compare=False, default=False)

    def __post_init__(self):
        object.__setattr__(self, "args", tuple(float(a) for a in self.args))
        object.__setattr__(self, "lower", float(self.lower))
        object.__setattr__(self, "upper", float(self.upper))
        problem = _problem(self.kind, self.args, self.lower, self.upper)
        if problem:
            raise SceneError(problem)
        lo, hi = self.support
        if not lo < hi:
            raise SceneError(f"no mass inside the bounds [{self.lower:g}, {self.upper:g}]")
        if self.kind == "flat":
            return
        dist = self._dist()
        upper_tail = bool(dist.cdf(lo) > 0.5)
        if upper_tail:
            a, b = float(dist.logsf(lo)), float(dist.logsf(hi))
        else:
            a, b = float(dist.logcdf(hi)), float(dist.logcdf(lo))
        log_mass = a + math.log1p(-math.exp(b - a)) if a > b else -math.inf
        if not (math.isfinite(log_mass) and math.exp(log_mass) > 0):
            raise SceneError(f"no mass inside the bounds [{self.lower:g}, {self.upper:g}]")
        object.__setattr__(self, "_log_mass", log_mass)
        object.__setattr__(self, "_upper_tail", upper_tail)

    # -- support -----------------------------------------------------------------------------
    @property
    def lo(self) -> float:
        """Lower end of the support after truncation (the optimisers' lower bound)."""
        return self.support[0]

    @property
    def hi(self) -> float:
        """Upper end of the support after truncation (the optimisers' upper bound)."""
        return self.support[1]

    @property
    def support(self) -> tuple[float, float]:
        """``(lo, hi)``: the form's natural support intersected with ``[lower, upper]``."""
        lo, hi = self.lower, self.upper
        if self.kind in ("uniform", "loguniform"):
            lo, hi = max(lo, self.args[0]), min(hi, self.args[1])
        elif self.kind in ("halfnormal", "lognormal"):
            lo = max(lo, 0.0)
        return lo, hi

    @property
    def family(self) -> str:
        """Alias of :attr:`kind` (the friction code's former name)."""
        return self.kind

    @property
    def proper(self) -> bool:
        """False for the improper flat prior (an infinite bound and no prior string)."""
        return self.kind != "flat"

    @property
    def log_mass(self) -> float:
        """Log of the untruncated form's mass inside ``[lo, hi]`` (0 for flat)."""
        return self._log_mass

    def _dist(self):
        if self.kind == "flat":
            raise SceneError("an improper flat prior has no distribution")
        return distribution(self.kind, tuple(self.args))

    # -- densities -----------------------------------------------------------------------------
    def logpdf(self, x):
        """Log density normalised on ``[lo, hi]``, ``-inf`` outside; vectorised.

        A scalar gives a float, an array an array of the same shape.  The improper flat prior
        gives 0 inside its bounds.
        """
        scalar = np.ndim(x) == 0
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            res = self.logpdf_array(np.asarray(x, dtype=float))
        return float(res) if scalar else res

    def logpdf_array(self, x: np.ndarray) -> np.ndarray:
        """:meth:`logpdf` of a float array, without the floating-point warning guard (the
        caller sets ``np.errstate``); for loops that evaluate many priors per call."""
        a = self.args
        if self.kind == "uniform":
            out = np.full(x.shape, -math.log(a[1] - a[0]))
        elif self.kind == "loguniform":
            out = -np.log(x) - math.log(math.log(a[1] / a[0]))
        elif self.kind == "normal":
            z = (x - a[0]) / a[1]
            out = -0.5 * z * z - math.log(a[1]) - _LOG_2PI_HALF
        elif self.kind == "halfnormal":
            z = x / a[0]
            out = -0.5 * z * z - math.log(a[0]) + 0.5 * math.log(2.0 / math.pi)
        elif self.kind == "lognormal":
            lx = np.log(x)
            z = (lx - a[0]) / a[1]
            out = -0.5 * z * z - lx - math.log(a[1]) - _LOG_2PI_HALF
        else:
            out = np.zeros(x.shape)
        lo, hi = self.support
        return np.where((x >= lo) & (x <= hi), out - self._log_mass, -np.inf)

    def pdf(self, x):
        """Density, see :meth:`logpdf`."""
        out = np.exp(self.logpdf(x))
        return float(out) if np.ndim(out) == 0 else out

    def cdf(self, x):
        """Cumulative distribution of the truncated prior; vectorised."""
        if not self.proper:
            raise SceneError("an improper flat prior has no cdf")
        scalar = np.ndim(x) == 0
        lo, hi = self.support
        x = np.clip(np.asarray(x, dtype=float), lo, hi)
        dist = self._dist()
        if self._upper_tail:
            out = (dist.sf(lo) - dist.sf(x)) / math.exp(self._log_mass)
        else:
            out = (dist.cdf(x) - dist.cdf(lo)) / math.exp(self._log_mass)
        out = np.clip(out, 0.0, 1.0)
        return float(out) if scalar else out

    # -- sampling ------------------------------------------------------------------------------
    def ppf(self, u) -> np.ndarray:
        """Inverse of the truncated cdf at probabilities ``u`` in [0, 1] (vectorised).

        Used to spread optimiser start points over the prior (a Latin hypercube in ``u``).

        Raises
        ------
        SceneError
            For the improper flat prior.
        """
        if not self.proper:
            raise SceneError(f"an improper flat prior on [{self.lo:g}, {self.hi:g}] has no quantiles")
        u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
        lo, hi = self.support
        dist = self._dist()
        if self._upper_tail:
            x = dist.isf(dist.sf(lo) + u * (dist.sf(hi) - dist.sf(lo)))
        else:
            x = dist.ppf(dist.cdf(lo) + u * (dist.cdf(hi) - dist.cdf(lo)))
        return np.clip(np.asarray(x, dtype=float), lo, hi)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` draws from the truncated prior, by inverse cdf on ``[cdf(lo), cdf(hi)]``.

        In the upper tail the survival function is inverted instead, so draws stay exact
        far from the mode.

        Raises
        ------
        SceneError
            For the improper flat prior.
        """
        if not self.proper:
            raise SceneError(f"cannot draw from an improper flat prior on [{self.lo:g}, {self.hi:g}]; "
                             "give finite min and max or a proper prior")
        lo, hi = self.support
        dist = self._dist()
        if self._upper_tail:
            x = dist.isf(rng.uniform(dist.sf(hi), dist.sf(lo), int(n)))
        else:
            x = dist.ppf(rng.uniform(dist.cdf(lo), dist.cdf(hi), int(n)))
        return np.clip(np.asarray(x, dtype=float), lo, hi)

    def describe(self) -> str:
        """Readable form with canonical-unit arguments and the support, e.g.
        ``"normal(0, 0.01) on [-inf, inf]"``."""
        lo, hi = self.support
        if not self.proper:
            return f"flat on [{lo:.6g}, {hi:.6g}] (improper)"
        inner = ", ".join(f"{a:.6g}" for a in self.args)
        return f"{self.kind}({inner}) on [{lo:.6g}, {hi:.6g}]"


# A normal prior narrower than 1e-10 of its centre (or than 1e-150 absolutely, whose square
# underflows) pins the parameter below what double precision resolves in a fit: least squares
# meets a singular curvature (numpy's eigenvalue routine failed on normal(0.05, 1e-300))
SPREAD_RESOLUTION = 1e-10
SPREAD_FLOOR = 1e-150


def _problem(kind: str, args: tuple[float, ...], lower: float, upper: float) -> str | None:
    """What makes a prior impossible, or ``None``."""
    if kind == "flat":
        if args:
            return "a flat prior takes no arguments"
    elif kind not in _ARITY:
        return f"unknown prior {kind!r}; forms: " + ", ".join(f"{k}({v})" for k, v in FORMS.items())
    elif len(args) != _ARITY[kind]:
        return f"{kind}({FORMS[kind]}) takes {_ARITY[kind]} argument(s), got {len(args)}"
    if not all(math.isfinite(a) for a in args):
        return "arguments must be finite numbers, got " + ", ".join(f"{a:g}" for a in args)
    if math.isnan(lower) or math.isnan(upper):
        return "the bounds must be numbers, not NaN"
    if kind in ("uniform", "loguniform") and not args[0] < args[1]:
        return f"{kind} needs a < b, got a = {args[0]:g}, b = {args[1]:g}"
    if kind == "loguniform" and not args[0] > 0:
        return f"loguniform needs a positive lower end, got {args[0]:g}"
    if kind in ("normal", "halfnormal", "lognormal") and not args[-1] > 0:
        return f"the spread of {kind} must be positive, got {args[-1]:g}"
    if kind in ("normal", "halfnormal") and not args[-1] >= max(SPREAD_FLOOR, SPREAD_RESOLUTION * abs(args[0])):
        centre = f" of its centre {args[0]:g}" if kind == "normal" and args[0] else ""
        return (f"the spread {args[-1]:g} of {kind} is below the resolution{centre} (at least "
                f"{max(SPREAD_FLOOR, SPREAD_RESOLUTION * abs(args[0])):g}): such a prior fixes the parameter; "
                "give it as value with vary = false instead")
    if kind == "lognormal" and not args[-1] >= SPREAD_RESOLUTION:
        return (f"the spread sigma = {args[-1]:g} of lognormal is below {SPREAD_RESOLUTION:g}: such a prior fixes the "
                "parameter; give it as value with vary = false instead")
    if kind == "lognormal" and not abs(args[0]) < 700:
        return f"lognormal mu is the log of the median; {args[0]:g} is out of range"
    return None


# -- constructors -------------------------------------------------------------------------------
def uniform(lower: float, upper: float) -> Prior:
    """Flat prior between finite bounds."""
    return Prior("uniform", (lower, upper), lower, upper)


def loguniform(lower: float, upper: float) -> Prior:
    """Prior flat in the logarithm (scale-free), between positive bounds."""
    return Prior("loguniform", (lower, upper), lower, upper)


def normal(mean: float, sd: float, lower: float = -math.inf, upper: float = math.inf) -> Prior:
    """Normal prior, truncated to ``[lower, upper]``."""
    return Prior("normal", (mean, sd), lower, upper)


def halfnormal(sd: float, lower: float = 0.0, upper: float = math.inf) -> Prior:
    """Half-normal prior on ``x >= 0``, truncated to ``[lower, upper]``."""
    return Prior("halfnormal", (sd,), lower, upper)


def lognormal(mu: float, sigma: float, lower: float = 0.0, upper: float = math.inf) -> Prior:
    """``log x ~ normal(mu, sigma)`` (x in the canonical unit), truncated to ``[lower, upper]``."""
    return Prior("lognormal", (mu, sigma), lower, upper)


def flat(lower: float, upper: float) -> Prior:
    """Improper flat prior (log density 0) on bounds of which at least one may be infinite."""
    return Prior("flat", (), lower, upper)


# -- parsing ------------------------------------------------------------------------------------
def parse_prior(spec: str, *, unit: str, where: str, lower: float = -math.inf,
                upper: float = math.inf) -> Prior:
    """Read a prior string, converting its arguments to ``unit``, truncated to the bounds.

    Parameters
    ----------
    spec
        E.g. ``"normal(0, 0.005 s/ft)"``; bare numbers are taken in ``unit``.
    unit
        Canonical unit of the parameter (pint syntax, ``""`` for dimensionless).
    where
        ``"file [key]"`` for messages.
    lower, upper
        The parameter's bounds; the prior is truncated to them and renormalised.

    Raises
    ------
    SceneError
        Unknown form, wrong number of arguments, an argument that is not a number (with an
        optional unit of the parameter's dimension), impossible or non-finite arguments, or
        no mass inside the bounds.
    """
    if not isinstance(spec, str):
        raise SceneError(f"a prior is a string such as 'normal(0, 1)', got {spec!r}", where)
    if len(spec) > _MAX_SPEC:
        raise SceneError(f"prior {spec[:40]!r}... is longer than {_MAX_SPEC} characters", where)
    m = _SPEC.match(spec)
    if not m or m.group(1).lower() not in _ARITY:
        raise SceneError(f"cannot read prior {spec!r}; forms: " + ", ".join(f"{k}({v})" for k, v in FORMS.items()),
                         where)
    kind, body = m.group(1).lower(), m.group(2)
    parts = [p.strip() for p in body.split(",")] if body.strip() else []
    if len(parts) != _ARITY[kind]:
        raise SceneError(f"prior {spec!r}: {kind}({FORMS[kind]}) takes {_ARITY[kind]} argument(s), "
                         f"got {len(parts)}", where)
    args = tuple(_argument(p, unit, kind, spec, where) for p in parts)
    try:
        return Prior(kind, args, lower, upper)
    except SceneError as exc:
        extra = f" ({unit or 'dimensionless'})" if "bounds [" in exc.message else ""
        raise SceneError(f"prior {spec!r}: {exc.message}{extra}", where) from None


def prior_of(param: Param, where: str = "", *, allow_improper: bool = False) -> Prior:
    """The prior of a parameter: its ``prior`` string, else uniform on its bounds.

    Parameters
    ----------
    param
        The parameter (its ``prior``, ``unit``, ``min``, ``max`` are used).
    where
        ``"file [key]"`` for messages (default: the parameter's name).
    allow_improper
        With no prior string and an infinite bound, return the improper :func:`flat` prior
        instead of refusing (balance fits, whose posteriors are proper through the data).

    Raises
    ------
    SceneError
        A bad prior string (see :func:`parse_prior`), or no prior string and an infinite bound
        when ``allow_improper`` is false.
    """
    w = where or param.name
    if param.prior is not None:
        return parse_prior(param.prior, unit=param.unit, where=w, lower=param.min, upper=param.max)
    if math.isfinite(param.min) and math.isfinite(param.max):
        if not param.min < param.max:
            raise SceneError(f"{param.name} varies but its range [{param.min:g}, {param.max:g}] is a point; "
                             "widen min and max or fix it", w)
        return uniform(param.min, param.max)
    if allow_improper:
        try:
            return flat(param.min, param.max)
        except SceneError as exc:
            raise SceneError(f"{param.name}: {exc.message}", w) from None
    raise SceneError(f"{param.name} varies but has no prior and its range [{param.min:g}, {param.max:g}] is open; "
                     "give min and max or a proper prior such as 'normal(0, 1)'", w)


def _argument(text: str, unit: str, kind: str, spec: str, where: str) -> float:
    """One argument: a number, optionally followed by a unit (converted to ``unit``)."""
    how = "write a number, optionally followed by a unit (e.g. '0.02 / gf', '2 deg', '1e-6 N')"
    if _NONFINITE.match(text):
        raise SceneError(f"prior {spec!r}: argument {text!r} is not finite", where)
    m = _NUMBER.match(text)
    if not m or len(text) > MAX_UNIT_TEXT + 30:
        raise SceneError(f"prior {spec!r}: cannot read argument {text!r}; {how}", where)
    value = float(m.group(1))
    rest = text[m.end():].strip()
    if not math.isfinite(value):
        raise SceneError(f"prior {spec!r}: argument {text!r} is not finite", where)
    if not rest:
        return value
    if kind == "lognormal":
        raise SceneError(f"prior {spec!r}: lognormal(mu, sigma) takes plain numbers (mu and sigma of the log of "
                         f"the value in {unit or 'its dimensionless unit'}), not {text!r}", where)
    if not safe_unit_text(rest):
        raise SceneError(f"prior {spec!r}: cannot read argument {text!r}; {how}; a unit is names, * / ( ) and "
                         f"integer powers of a name, at most {MAX_UNIT_TEXT} characters", where)
    given, wanted = COMMON_UNITS.get(rest), COMMON_UNITS.get(unit)
    if given is not None and wanted is not None and given[0] == wanted[0]:  # deg for rad, ms for s: no pint
        return value * given[1] / wanted[1]
    from pint import DimensionalityError

    units = ("1 " + rest) if rest[0] == "/" else rest.lstrip("*").strip()
    try:
        factor = registry().Quantity(1.0, registry().parse_units(units))
    except Exception:  # pint raises several types for unknown names and bad syntax
        raise SceneError(f"prior {spec!r}: unknown unit {rest!r} in argument {text!r}", where) from None
    try:
        out = value * float(factor.to(_target(unit)).magnitude)
    except DimensionalityError:
        raise SceneError(f"prior {spec!r}: argument {text!r} is not in units of {unit or 'dimensionless'}",
                         where) from None
    except SceneError as exc:
        raise SceneError(f"prior {spec!r}: {exc.message}", where) from None
    if not math.isfinite(out):
        raise SceneError(f"prior {spec!r}: argument {text!r} is not finite", where)
    return out


@lru_cache(maxsize=None)
def _target(unit: str):
    try:
        return registry().parse_units(unit) if unit else registry().dimensionless
    except Exception:
        raise SceneError(f"the parameter's unit {unit!r} is not a unit pint knows") from None
