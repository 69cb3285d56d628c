"""Parameter declarations: the one place a scene's numbers become named parameters.

A scene value is either fixed (a plain number or a string with a unit) or free, written as
a table ``{ value = 0.8, vary = true, min = 0, max = 5, prior = "lognormal(0, 1)" }``.
Every parameter has a stable dotted name such as ``viscous.C``, ``coulomb.R`` or
``escapement[2].X`` (windows are numbered from 1 in file order), its canonical unit and a
one-line meaning.  Values are always stored in the canonical unit.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Mapping

from .errors import SceneError
from .units import CANONICAL, to_canonical

__all__ = ["Param", "ParamSet", "read_param", "safe_name"]

_TABLE_KEYS = {"value", "vary", "min", "max", "prior", "sd"}


@dataclass(frozen=True)
class Param:
    """One scalar model parameter.

    Attributes
    ----------
    name
        Dotted, stable name (``viscous.C``).
    value
        Value in the canonical unit ``unit``.
    unit
        Canonical unit string (pint syntax, ``""`` for dimensionless).
    meaning
        One line saying what the parameter is, with its sign convention.
    vary
        Whether fits estimate it.
    min, max
        Bounds in the canonical unit (``-inf``/``inf`` when open).
    prior
        Prior specification string (see :mod:`escfit.likelihood.priors`), or ``None`` for a
        uniform prior between the bounds.
    tie
        ``(other_name, factor)`` when the value is ``factor * other`` (e.g. the unlock
        torque ``S = eps * M``); a tied parameter never varies by itself.
    sd
        Measurement standard deviation of a measured-but-uncertain input, or ``None``.
    """

    name: str
    value: float
    unit: str = ""
    meaning: str = ""
    vary: bool = False
    min: float = -math.inf
    max: float = math.inf
    prior: str | None = None
    tie: tuple[str, float] | None = None
    sd: float | None = None

    def scaled(self, factor: float) -> "Param":
        """Return a copy with value, bounds and sd multiplied by a positive ``factor``."""
        return replace(
            self,
            value=self.value * factor,
            min=self.min * factor,
            max=self.max * factor,
            sd=None if self.sd is None else self.sd * factor,
        )


def safe_name(name: str) -> str:
    """Map a dotted parameter name to a Python identifier (for lmfit expressions).

    ``escapement[2].X`` -> ``escapement_2__X``; ``viscous.C`` -> ``viscous__C``.
    """
    out = re.sub(r"\[(\d+)\]", r"_\1", name)
    return out.replace(".", "__")


# A free parameter's fitted range may be at most this many times its value wide: least squares
# maps a two-sided range onto a sine, which resolves values near the value only to about
# 3.5e-16 * sqrt(range / value) of themselves (1e-10 at this ratio; with max = 1e200 and a
# value of 0.1 the fit ended at the wrong value, with max = 1e308 at NaN)
WIDEST_RANGE = 1e12


def _check_range_resolvable(value: float, pmin: float, pmax: float, sd: float | None, raw: Mapping, where: str) -> None:
    """Refuse a free parameter whose two-sided range is too wide for a fit to resolve its value."""
    if not (math.isfinite(pmin) and math.isfinite(pmax)):
        return  # an open side is mapped without loss of resolution
    span = pmax - pmin
    nonzero = [abs(b) for b in (pmin, pmax) if b != 0]
    scale = abs(value) if value != 0 else (sd or (min(nonzero) if nonzero else 1.0))
    if not math.isfinite(span) or span > WIDEST_RANGE * scale:
        bound = "max" if abs(pmax) >= abs(pmin) else "min"
        raise SceneError(f"the range [{pmin:g}, {pmax:g}] is more than {WIDEST_RANGE:g} times the value {value:g} wide: "
                         f"a fit cannot resolve the value in it; leave {bound} out for an open range, or give a "
                         "narrower one", f"{where}.{bound}" if bound in raw else where)


def read_param(
    raw: Any,
    *,
    name: str,
    kind: str,
    meaning: str,
    where: str,
    lower: float = -math.inf,
    upper: float = math.inf,
    lower_open: bool = False,
    convert: Callable[[float], float] | None = None,
    unit: str | None = None,
    bare_limit: float | None = None,
) -> Param:
    """Read a fixed or free scene value into a :class:`Param`.

    Parameters
    ----------
    raw
        The TOML value: number, string with unit, or a table with ``value`` and optionally
        ``vary``, ``min``, ``max``, ``prior``, ``sd``.
    name
        The parameter's dotted name.
    kind
        Dimension kind (key of :data:`escfit.core.units.CANONICAL`) the input is read in.
    meaning
        One-line description.
    where
        ``"file [key]"`` for error messages.
    lower, upper
        Physically allowed range in the *output* unit; the value must lie inside
        (strictly above ``lower`` when ``lower_open``).  Declared bounds are clipped to it.
    convert
        Optional increasing map from the input unit to the model unit (e.g. divide a
        torque by the inertia).  Applied to value, bounds and sd.
    unit
        Unit of the converted value when ``convert`` changes it (default: the canonical
        unit of ``kind``).
    bare_limit
        Largest magnitude a bare number (no unit) may have in the canonical unit of ``kind``,
        for the value and the table's ``min``, ``max`` and ``sd``; ``None`` accepts any.
        Balance readers pass :data:`escfit.core.units.BARE_ANGLE_LIMIT` for angles.

    Raises
    ------
    SceneError
        Unknown table keys, non-numeric entries, ``min > max``, value outside bounds or
        outside the physical range.
    UnitError
        A bare number beyond ``bare_limit`` (a subclass of :class:`SceneError`).
    """
    conv = convert or (lambda v: v)

    def canonical(v: Any, at: str) -> float:
        return conv(to_canonical(v, kind, at, bare_limit=bare_limit))

    out_unit = CANONICAL[kind] if unit is None else unit
    if isinstance(raw, Mapping):
        unknown = set(raw) - _TABLE_KEYS
        if unknown:
            raise SceneError(
                f"unknown key(s) {sorted(unknown)} in parameter table; allowed: {sorted(_TABLE_KEYS)}",
                where,
            )
        if "value" not in raw:
            raise SceneError("parameter table needs a 'value'", where)
        value = canonical(raw["value"], f"{where}.value")
        vary = raw.get("vary", False)
        if not isinstance(vary, bool):
            raise SceneError(f"'vary' must be true or false, got {vary!r}", f"{where}.vary")
        pmin = canonical(raw["min"], f"{where}.min") if "min" in raw else lower
        pmax = canonical(raw["max"], f"{where}.max") if "max" in raw else upper
        prior = raw.get("prior")
        if prior is not None and not isinstance(prior, str):
            raise SceneError(f"'prior' must be a string such as 'normal(0, 1)', got {prior!r}", f"{where}.prior")
        sd = canonical(raw["sd"], f"{where}.sd") if "sd" in raw else None
        if sd is not None and not sd > 0:
            raise SceneError(f"'sd' must be positive, got {raw['sd']!r}", f"{where}.sd")
        if pmin > pmax:
            raise SceneError(f"min {raw.get('min')!r} is above max {raw.get('max')!r}", where)
        _check_physical(raw["value"], value, lower, upper, lower_open, meaning or name, where)
        if pmax < lower or pmin > upper:
            raise SceneError(f"min {raw.get('min')!r} and max {raw.get('max')!r} lie outside the physical range "
                             f"{_range(lower, upper, lower_open)} ({_shown_unit(out_unit)}) for {meaning or name}", where)
        pmin, pmax = max(pmin, lower), min(pmax, upper)
        if not (pmin <= value <= pmax):
            raise SceneError(f"value {raw['value']!r} lies outside [{pmin:g}, {pmax:g}] ({_shown_unit(out_unit)})", where)
        if vary:
            _check_range_resolvable(value, pmin, pmax, sd, raw, where)
    else:
        value = canonical(raw, where)
        vary, pmin, pmax, prior, sd = False, lower, upper, None, None
    _check_physical(raw if not isinstance(raw, Mapping) else raw["value"], value, lower, upper, lower_open,
                    meaning or name, where)
    return Param(name, value, out_unit, meaning, vary, pmin, pmax, prior, None, sd)


def _range(lower: float, upper: float, lower_open: bool) -> str:
    return f"{'(' if lower_open else '['}{lower:g}, {upper:g}]"


def _shown_unit(unit: str) -> str:
    """A canonical unit as a reader writes it: an angular frequency's 1/s is rad/s."""
    return {"1/s": "1/s or rad/s", "": "dimensionless"}.get(unit, unit)


def _check_physical(raw: Any, value: float, lower: float, upper: float, lower_open: bool, what: str,
                    where: str) -> None:
    """Refuse a value outside the physical range ``lower``..``upper`` (open below when ``lower_open``)."""
    bad_low = value <= lower if lower_open else value < lower
    if bad_low or value > upper:
        raise SceneError(f"value {raw!r} is outside the physical range {_range(lower, upper, lower_open)} for {what}",
                         where)


@dataclass
class ParamSet:
    """Ordered collection of a scene's parameters, addressed by dotted name."""

    params: dict[str, Param] = field(default_factory=dict)

    def add(self, p: Param) -> None:
        if p.name in self.params:
            raise SceneError(f"parameter {p.name!r} declared twice")
        self.params[p.name] = p

    def __getitem__(self, name: str) -> Param:
        return self.params[name]

    def __contains__(self, name: object) -> bool:
        return name in self.params

    def __iter__(self):
        return iter(self.params.values())

    def __len__(self) -> int:
        return len(self.params)

    def values(self) -> dict[str, float]:
        """Current values with ties resolved, by name."""
        out = {n: p.value for n, p in self.params.items()}
        for n, p in self.params.items():
            if p.tie is not None:
                other, factor = p.tie
                out[n] = factor * out[other]
        return out

    def free(self) -> list[Param]:
        """The parameters a fit estimates, in declaration order."""
        return [p for p in self.params.values() if p.vary and p.tie is None]

    def with_values(self, values: Mapping[str, float]) -> "ParamSet":
        """A copy with some values replaced (ties are re-resolved by :meth:`values`)."""
        new = dict(self.params)
        for n, v in values.items():
            if n not in new:
                raise KeyError(n)
            new[n] = replace(new[n], value=float(v))
        return ParamSet(new)
