"""Quantities with units, parsed with pint and converted to escfit's canonical units.

Scene files may give any number either as a bare value in the canonical unit or as a
string with a unit, e.g. ``"300 deg"`` or ``"2.73e-7 N*m"``.  Angles are dimensionless in
pint (rad), so an angle given as a length is refused by dimensional analysis.

A bare angle is read as radians.  Readers of balance-wheel and pendulum angles pass
``bare_limit=BARE_ANGLE_LIMIT`` so that a bare number no such oscillator can reach (more than
two turns, most likely degrees written without their unit) is refused instead of simulated;
a value written with its unit is always taken as written.
"""

from __future__ import annotations

import math
import os
import re
from functools import lru_cache
from typing import Any

import pint

from .errors import UnitError

__all__ = ["ureg", "COUNT_WORDS", "UnsafeUnitText", "to_canonical", "CANONICAL", "safe_unit_text", "quantity", "MAX_UNIT_TEXT", "BARE_ANGLE_LIMIT",
           "check_bare_angle"]

class UnsafeUnitText(pint.errors.PintError, ValueError):
    """Text pint was asked to parse that is not a number and a unit of :func:`safe_unit_text`'s grammar."""


class _GuardedRegistry(pint.UnitRegistry):
    """pint's registry, refusing to evaluate text outside a bounded grammar once it is built.

    pint parses a unit string as arithmetic, so ``"9**9**9 rad"`` (in a scene) or a column
    header ``load_g**9**9**9`` would compute a number with hundreds of millions of digits: the
    process hangs in one C call that no signal interrupts.  Every parse of text (``Quantity(str)``,
    ``Unit(str)``, ``parse_units``, ``parse_expression``) comes through these two methods, so
    after construction they accept only an optional number followed by a unit of names,
    ``* / ( )`` and small integer powers (:func:`safe_unit_text`), and raise
    :class:`UnsafeUnitText` otherwise (callers already report pint's errors as one line).
    """

    _guarded = False

    def _check(self, text):
        if not self._guarded or not isinstance(text, str):
            return
        m = _PREFIX.match(text)
        rest = text[m.end():].strip() if m else text.strip()
        numbers = _PREFIX_NUMBER.findall(m.group(0)) if m else []
        if (rest and not safe_unit_text(rest)) or not all(math.isfinite(float(x)) for x in numbers):
            raise UnsafeUnitText(f"{text[:60]!r} is not a number and a unit (a number or a fraction such as pi/2, "
                                 "then names, * / ( ) and powers up to two digits)")

    def parse_expression(self, input_string, *args, **kwargs):
        self._check(input_string)
        return super().parse_expression(input_string, *args, **kwargs)

    __call__ = parse_expression  # ureg("...") is parse_expression; the base class binds its own

    def parse_units(self, input_string, *args, **kwargs):
        self._check(input_string)
        return super().parse_units(input_string, *args, **kwargs)

    def parse_units_as_container(self, input_string, *args, **kwargs):
        # what Unit(str), Quantity.to(str) and m_as(str) evaluate text with
        self._check(input_string)
        return super().parse_units_as_container(input_string, *args, **kwargs)


def _registry() -> _GuardedRegistry:
    """pint's registry, its parsed definitions kept in pint's cache folder between processes.

    Parsing pint's definition files takes about 0.2 s of every command's start; pint keeps the
    parsed result in the user's cache folder (``platformdirs``' cache path for "pint") and reuses
    it while the definition files are unchanged.  ``ESCFIT_UNIT_CACHE=0`` turns that off; a
    cache that cannot be read or written (a read-only home, a file another process is still
    writing) falls back to parsing, with the same registry.
    """
    if os.environ.get("ESCFIT_UNIT_CACHE", "1") != "0":
        try:
            return _GuardedRegistry(cache_folder=":auto:")
        except Exception:  # noqa: BLE001 - any failure of the cache: parse the definitions instead
            pass
    return _GuardedRegistry()


ureg = _registry()
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
    "speed": "m/s",  # a linear oscillator's drift of its centre
    "acceleration": "m/s**2",  # a linear oscillator's Coulomb friction per mass
    "inverse_length": "1/m",  # a linear oscillator's quadratic drag per mass
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


# Largest bare angle (rad) a balance wheel or pendulum reading accepts: two turns.  Balance
# amplitudes stay below one turn (banking near 330 deg), so a larger bare number is almost
# certainly degrees written without their unit.
BARE_ANGLE_LIMIT = 4 * math.pi


def check_bare_angle(value: Any, where: str, limit: float = BARE_ANGLE_LIMIT) -> None:
    """Refuse a bare number (read as radians) whose magnitude exceeds ``limit`` rad.

    Strings with a unit pass unchecked: ``"300 deg"`` and even ``"300 rad"`` are taken as
    written.

    Raises
    ------
    UnitError
        ``value`` is a bare int or float with ``|value| > limit``; the message gives the
        value in turns and suggests writing the unit.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return
    if not math.isfinite(value) or abs(value) <= limit:  # (non-finite values are refused by to_canonical)
        return
    text = f"{value:g}" if isinstance(value, float) else str(value)
    turns = abs(value) / (2 * math.pi)
    raise UnitError(f'bare number {text} is read as radians ({turns:.1f} turns); did you mean "{text} deg"? '
                    f'write the unit to be explicit (or "{text} rad")', where)


def to_canonical(value: Any, kind: str, where: str, *, bare_limit: float | None = None) -> float:
    """Convert a scene value to a float in the canonical unit of ``kind``.

    Parameters
    ----------
    value
        A number (already canonical) or a string ``"<number> <unit>"``.
    kind
        Key of :data:`CANONICAL` naming the expected dimension.
    where
        ``"file [key]"`` used in error messages.
    bare_limit
        Largest magnitude a *bare* number may have (in the canonical unit); ``None`` (the
        default) accepts any.  Balance readers pass :data:`BARE_ANGLE_LIMIT` for angles.

    Returns
    -------
    float
        The value in the canonical unit.

    Raises
    ------
    UnitError
        Unknown unit, wrong dimension, non-finite number, a non-numeric value or a bare
        number beyond ``bare_limit``.
    """
    if bare_limit is not None:
        check_bare_angle(value, where, bare_limit)
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


MAX_UNIT_TEXT = 40
_UNIT_TOKEN = re.compile(r"(?P<name>[A-Za-z_°µΩ²³]+(?:_\d{1,2})?(?![\w])|%)|(?P<pow>(?:\*\*|\^)\s*-?\d{1,2})(?![\d.])"
                         r"|(?P<op>[*/])|(?P<paren>[()])|(?P<space>\s+)")
_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)")
_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
# A leading number, or a short product or quotient of numbers and pi ("pi/2 rad", "1/4 turn"):
# at most four factors and no powers, so nothing pint computes from it can grow.
_PREFIX = re.compile(rf"\s*(?:{_NUM}|pi)(?:\s*[*/]\s*(?:{_NUM}|pi)(?![A-Za-z_])){{0,3}}(?![A-Za-z_\d.])")
_PREFIX_NUMBER = re.compile(_NUM)


def safe_unit_text(text: str) -> bool:
    """Whether ``text`` (what follows an argument's number) is a unit pint may evaluate safely.

    Tokens: unit names (ASCII letters, ``_``, ``°``, ``µ``, ``Ω``, optionally ending in ``_``
    and one or two digits such as ``g_0``), ``%``, ``*``, ``/``, parentheses (depth at most 2),
    spaces and a power ``**n`` / ``^n`` (``n`` one or two digits, optionally negative) directly
    after a name.  No other numbers, so nothing pint evaluates can grow: ``9**9**9`` is refused.
    """
    if len(text) > MAX_UNIT_TEXT:
        return False
    pos, prev, depth = 0, "start", 0
    while pos < len(text):
        m = _UNIT_TOKEN.match(text, pos)
        if not m:
            return False
        pos = m.end()
        tok = m.lastgroup
        if tok == "space":
            continue
        if tok == "pow" and prev != "name":
            return False
        if tok == "op" and prev == "op":
            return False
        if tok == "paren":
            depth += 1 if m.group() == "(" else -1
            if not 0 <= depth <= 2:
                return False
            tok = m.group()
        prev = tok
    return depth == 0 and prev not in ("op", "(")


def quantity(text: str, where: str) -> "pint.Quantity":
    """A number followed by an optional unit, read without letting pint evaluate arithmetic.

    Raises
    ------
    UnitError
        Anything but a finite number and a unit of :func:`safe_unit_text`'s grammar.
    """
    m = _NUMBER.match(text)
    rest = text[m.end():].strip() if m else ""
    if not m or not math.isfinite(float(m.group(1))) or (rest and not safe_unit_text(rest)):
        raise UnitError(f"cannot read {text!r}: write a number and a unit, e.g. '0.3 turn' or '2 deg'", where)
    if not rest:
        return ureg.Quantity(float(m.group(1)))
    units = ("1 " + rest) if rest[0] == "/" else rest.lstrip("*").strip()
    try:
        return ureg.Quantity(float(m.group(1)), ureg.parse_units(units))
    except Exception:  # pint raises several types for unknown names
        raise UnitError(f"unknown unit {rest!r} in {text!r}", where) from None


ureg._guarded = True  # after the module's own definitions (see _GuardedRegistry)

#: words a column's unit uses for an encoder's counts (not a pint unit: they need counts per turn)
COUNT_WORDS = frozenset({"count", "counts", "cts", "ticks"})
