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

__all__ = ["ureg", "COUNT_WORDS", "UnsafeUnitText", "to_canonical", "CANONICAL", "safe_unit_text", "quantity",
           "MAX_UNIT_TEXT", "BARE_ANGLE_LIMIT", "check_bare_angle", "angular_frequency", "angular_frequency_factor",
           "ANGULAR_FREQUENCY_UNITS"]

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
# A watch's beat is half a period of its balance: f = bph / 7200 Hz (18000 bph = 2.5 Hz)
ureg.define("beats_per_hour = turn / 7200 / second = bph = vph")

# Canonical unit of each kind of quantity escfit reads.  Per-inertia quantities
# (C, R, X, omega0**2) are the model's working units.
CANONICAL: dict[str, str] = {
    "angle": "rad",
    "time": "s",
    "rate_per_s": "1/s",  # C (viscous per inertia): a rate, not a frequency (Hz, rpm refused)
    # omega0, a spin, an angular velocity: rad/s, stored as "1/s" (rad is dimensionless in
    # pint); read by angular_frequency (Hz is cycles per second, times 2 pi)
    "angular_frequency": "1/s",
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
    "frequency": "1/s",  # cycles or events per second (a sample rate): Hz; an angle per time refused
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
        Key of :data:`CANONICAL` naming the expected dimension.  The three kinds per unit of
        time are read by one rule (see :func:`angular_frequency`): ``"angular_frequency"``
        (rad/s: Hz counts cycles, times 2 pi; rpm, turn/s, bph, deg/s by pint; a bare 1/s is
        rad/s), ``"frequency"`` (Hz, 1/s: an angle per time is refused) and ``"rate_per_s"``
        (1/s, a damping rate: Hz and angles per time are refused).
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
        Unknown unit, wrong dimension, non-finite number, a non-numeric value, a bare
        number beyond ``bare_limit``, or a frequency unit the kind refuses.
    """
    if bare_limit is not None:
        check_bare_angle(value, where, bare_limit)
    if isinstance(value, bool):
        raise UnitError(f"expected a number, got the boolean {value!r}", where)
    if isinstance(value, (int, float)):
        out = float(value)
    elif isinstance(value, str):
        q = _parse(value, where)
        if kind in _PER_TIME_KINDS:
            out = _per_time(q, value, kind, where)
        else:
            try:
                out = float(q.to(_unit(kind)).magnitude)
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


# "15.7 1/s": the safe grammar takes no number inside a unit, so a leading "1/" is read as "/"
_ONE_OVER = re.compile(r"^(\s*[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s+1\s*/(?=\s*[A-Za-z_(])")


def _parse(value: str, where: str) -> Any:
    """pint's reading of ``value`` as a Quantity (dimensionless for a string without a unit)."""
    try:
        q = ureg.Quantity(_ONE_OVER.sub(r"\1 /", value))
    except Exception as exc:  # pint raises several types for bad strings
        raise UnitError(f"cannot read {value!r} as a quantity ({exc})", where) from None
    return q if isinstance(q, pint.Quantity) else ureg.Quantity(float(q))


# --- frequencies: one rule for every key that takes a rate per unit of time ----------------------

#: the units suggested when a value is not an angular frequency
ANGULAR_FREQUENCY_UNITS = "rad/s (or a bare number), Hz, rpm, turn/s or bph"
_PER_TIME_KINDS = frozenset({"angular_frequency", "frequency", "rate_per_s"})
_TIME = ureg.second.dimensionality
_PER_TIME = (1 / ureg.second).dimensionality


def _frequency_kind(q: "pint.Quantity") -> str | None:
    """How the unit of ``q`` counts per unit of time.

    Returns
    -------
    str or None
        ``"cycles"`` (hertz with any prefix: cycles per second), ``"angle"`` (an angle per
        time: rad/s, deg/s, turn/s, cycle/s, rpm, bph), ``"plain"`` (1/s, s^-1, /min: no
        cycle and no angle), ``"mixed"`` (hertz times an angle: ambiguous) or ``None``: not
        one rate per time (another dimension; a dimensionless factor such as percent or
        count; a becquerel; a power of hertz or of an angle).
    """
    if q.dimensionality != _PER_TIME:
        return None
    hertz = angle = 0
    for name, power in q.unit_items():
        if any(unit == "hertz" for _prefix, unit, _suffix in ureg.parse_unit_name(name)):
            hertz += power
            continue
        radians = dict((1 * ureg.get_root_units(name)[1]).unit_items()).get("radian", 0)
        if radians:
            angle += radians * power
        elif ureg.Unit(name).dimensionality != _TIME:
            return None
    if hertz and angle:
        return "mixed"
    if hertz not in (0, 1) or angle not in (0, 1):
        return None
    return "cycles" if hertz else "angle" if angle else "plain"


def _per_time(q: "pint.Quantity", value: Any, kind: str, where: str) -> float:
    """``q`` (read from ``value``) in the canonical unit of a per-time ``kind`` (see :func:`to_canonical`)."""
    how = _frequency_kind(q)
    if how in (None, "mixed"):
        what = {"angular_frequency": f"an angular frequency; give it in {ANGULAR_FREQUENCY_UNITS} (Hz counts "
                                     "cycles: 1 Hz = 2 pi rad/s)",
                "frequency": "a frequency; give it in Hz (e.g. '500 Hz')",
                "rate_per_s": "a rate per second; give it in 1/s (e.g. '0.05/s' or a bare number)"}[kind]
        if q.dimensionality != _PER_TIME:
            raise UnitError(f"{value!r} has dimension {q.dimensionality}, not {what}", where)
        raise UnitError(f"{value!r} is not {what}" + ("; it mixes Hz (cycles) with an angle" if how else ""), where)
    per_second = float(q.to("1/s").magnitude)
    if kind == "angular_frequency":
        return 2 * math.pi * per_second if how == "cycles" else per_second
    if kind == "frequency":
        if how == "angle":
            raise UnitError(f"{value!r} is an angle per time, but this key counts cycles or events per second; "
                            "give it in Hz (e.g. '500 Hz')", where)
        return per_second
    if how != "plain":
        raise UnitError(f"{value!r}: this key is a rate per second (1/s), not a frequency; give it in 1/s "
                        "(e.g. '0.05/s' or a bare number), not in Hz, rpm or rad/s", where)
    return per_second


def angular_frequency(value: Any, where: str) -> float:
    """Read an angular frequency or angular velocity (omega0, a spin, a rate) in rad/s.

    The one rule of escfit for a value per unit of time that turns an angle:

    * a unit counting cycles is multiplied by 2 pi: ``"2.5 Hz"`` (also kHz, mHz) is
      ``2 pi * 2.5`` rad/s;
    * an angle per time is converted by pint: ``"2.5 turn/s"``, ``"2.5 cycles/s"``,
      ``"150 rpm"``, ``"2.5 rps"``, ``"900 deg/s"`` and ``"18000 bph"`` (beats per hour of a
      watch: a beat is half a period, so f = bph/7200 Hz; also ``vph``) are all
      ``2 pi * 2.5`` rad/s;
    * a bare number, and a unit with neither cycles nor an angle (``"15.7 1/s"``,
      ``"15.7 s^-1"``, ``"942 /min"``), is read as rad/s, the physics convention for an
      angular frequency;
    * anything else is refused: another dimension (``"2.5 turn"``, ``"2.5 s"``), a
      dimensionless factor per time (``"5 percent/s"``, ``"5 count/s"``, ``"5 Bq"``), hertz
      mixed with an angle (``"2 rad*Hz"``) or an angle squared per time.

    Parameters
    ----------
    value
        A number (rad/s) or a string ``"<number> <unit>"``.
    where
        ``"file [table].key"`` (or the option) used in error messages.

    Returns
    -------
    float
        The value in rad/s.

    Raises
    ------
    UnitError
        One line naming ``where``, the value and the units to use.
    """
    return to_canonical(value, "angular_frequency", where)


def angular_frequency_factor(unit: str, where: str) -> float:
    """rad/s per one ``unit`` (a column's or an option's unit of angular velocity), by :func:`angular_frequency`.

    ``"rad/s"`` is 1, ``"deg/s"`` pi/180, ``"rpm"`` 2 pi/60, ``"Hz"`` 2 pi, ``"1/s"`` 1.

    Raises
    ------
    UnitError
        ``unit`` is not a unit of the safe grammar (:func:`safe_unit_text`) or not an
        angular frequency.
    """
    text = unit.strip()
    text = text[1:].lstrip() if text.startswith("1") and text[1:].lstrip().startswith("/") else text
    if not text or not safe_unit_text(text):
        raise UnitError(f"{unit!r} is not an angular frequency unit; give {ANGULAR_FREQUENCY_UNITS}", where)
    return angular_frequency(f"1 {text}", where)


MAX_UNIT_TEXT = 40
_UNIT_TOKEN = re.compile(r"(?P<name>[A-Za-z_°µΩ²³]+(?:_\d{1,2})?(?![\w])|%)|(?P<pow>(?:\*\*|\^)\s*-?\d{1,2})(?![\d.])"
                         r"|(?P<op>[*/])|(?P<paren>[()])|(?P<space>\s+)")
_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)")
_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
# A leading number, or a short product or quotient of numbers and pi ("pi/2 rad", "1/4 turn"):
# at most four factors and no powers, so nothing pint computes from it can grow.
_PREFIX = re.compile(rf"\s*(?:{_NUM}|pi)(?:\s*[*/]\s*(?:{_NUM}|pi)(?![A-Za-z_])){{0,3}}(?![\d.eE])")
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
