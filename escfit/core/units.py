"""Quantities with units, parsed with pint and converted to escfit's canonical units.

Scene files may give any number either as a bare value in the canonical unit or as a
string with a unit, e.g. ``"300 deg"`` or ``"2.73e-7 N*m"``.  Angles are dimensionless in
pint (rad), so an angle given as a length is refused by dimensional analysis.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

import pint

from .errors import UnitError

__all__ = ["ureg", "to_canonical", "CANONICAL"]

ureg = pint.UnitRegistry()
ureg.define("gf = gram * g_0 = gram_force")  # gram-force, as in Monday's fixture data

# Canonical unit of each kind of quantity escfit reads.  Per-inertia quantities
# (C, R, X, omega0**2) are the model's working units.
CANONICAL: dict[str, str] = {
    "angle": "rad",
    "time": "s",
    "rate_per_s": "1/s",  # C (viscous per inertia), omega0 (rad/s)
    "angular_acceleration": "1/s**2",  # R, X: torque per inertia, rad/s^2
    "inertia": "kg*m**2",
    "torque": "N*m",
    "stiffness": "N*m",  # per radian; rad is dimensionless
    "damping": "N*m*s",  # per rad/s
    "length": "m",
    "mass": "kg",
    "force": "N",
    "dimensionless": "",
    "frequency": "1/s",
}


def _article(kind: str) -> str:
    words = kind.replace("_", " ")
    return ("an " if words[0] in "aeiou" else "a ") + words


@lru_cache(maxsize=None)
def _unit(kind: str) -> pint.Unit:
    return ureg.Unit(CANONICAL[kind])


def to_canonical(value: Any, kind: str, where: str) -> float:
    """Convert a scene value to a float in the canonical unit of ``kind``.

    Parameters
    ----------
    value
        A number (already canonical) or a string ``"<number> <unit>"``.
    kind
        Key of :data:`CANONICAL` naming the expected dimension.
    where
        ``"file [key]"`` used in error messages.

    Returns
    -------
    float
        The value in the canonical unit.

    Raises
    ------
    UnitError
        Unknown unit, wrong dimension, non-finite number or a non-numeric value.
    """
    if isinstance(value, bool):
        raise UnitError(f"expected a number, got the boolean {value!r}", where)
    if isinstance(value, (int, float)):
        out = float(value)
    elif isinstance(value, str):
        try:
            q = ureg.Quantity(value)
        except Exception as exc:  # pint raises several types for bad strings
            raise UnitError(f"cannot read {value!r} as a quantity ({exc})", where) from None
        target = _unit(kind)
        if not isinstance(q, pint.Quantity):
            q = ureg.Quantity(float(q))
        try:
            out = float(q.to(target).magnitude)
        except pint.DimensionalityError:
            expect = CANONICAL[kind] or "dimensionless"
            raise UnitError(
                f"{value!r} has dimension {q.dimensionality}, expected {_article(kind)} "
                f"(e.g. in {expect})",
                where,
            ) from None
    else:
        raise UnitError(f"expected a number or a string with a unit, got {value!r}", where)
    if not math.isfinite(out):
        raise UnitError(f"value {value!r} is not finite", where)
    return out
