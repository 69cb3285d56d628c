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
import re
from functools import lru_cache
from typing import TYPE_CHECKING, Any

from .errors import UnitError
from .unit_text import _NUMBER, MAX_UNIT_TEXT, safe_unit_text

if TYPE_CHECKING:
    import pint

__all__ = ["ureg", "registry", "COMMON_UNITS", "COMMON_RATES", "common_factor", "common_convert", "STANDARD_GRAVITY",
           "COUNT_WORDS", "UnsafeUnitText", "to_canonical", "CANONICAL", "safe_unit_text", "quantity", "MAX_UNIT_TEXT", "BARE_ANGLE_LIMIT", "check_bare_angle", "angular_frequency", "angular_frequency_factor",
           "ANGULAR_FREQUENCY_UNITS"]

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


def registry():
    """pint's unit registry (:mod:`escfit.core.unit_registry`), imported on first use."""
    from .unit_registry import ureg

    return ureg


def __getattr__(name: str):
    # ``ureg`` and ``UnsafeUnitText`` live with pint in unit_registry, loaded when first asked for
    if name in ("ureg", "UnsafeUnitText"):
        from . import unit_registry

        return getattr(unit_registry, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: exact factors of the units records and scenes name most, to the canonical unit of a kind:
#: text -> (kind, factor).  Read without pint; ``tests/test_unit_table.py`` holds them against pint.
COMMON_UNITS: dict[str, tuple[str, float]] = {
    **{u: ("angle", 1.0) for u in ("rad", "radian", "radians")},
    **{u: ("angle", math.pi / 180.0) for u in ("deg", "degree", "degrees")},
    **{u: ("time", 1.0) for u in ("s", "second", "seconds")},
    "ms": ("time", 1e-3),
    "min": ("time", 60.0),
    "g": ("mass", 1e-3),
    "kg": ("mass", 1.0),
    "N": ("force", 1.0),
}

#: rates per time read without pint: (text, kind) -> factor to the kind's canonical unit, by
#: :func:`to_canonical`'s rule for rates (Hz counts cycles: 2 pi rad/s for an angular frequency)
COMMON_RATES: dict[tuple[str, str], float] = {
    ("Hz", "frequency"): 1.0,
    ("kHz", "frequency"): 1e3,
    ("Hz", "angular_frequency"): 2.0 * math.pi,
    ("rad/s", "angular_frequency"): 1.0,
    **{("1/s", kind): 1.0 for kind in ("frequency", "angular_frequency", "rate_per_s")},
}

#: standard gravity, m/s^2 (exact by definition): the weight of a mass load
STANDARD_GRAVITY = 9.80665


def common_factor(unit: str, kind: str) -> float | None:
    """The factor of ``unit`` (text, compared exactly after stripping) to the canonical unit of
    ``kind`` from :data:`COMMON_UNITS`, or ``None`` when the table does not hold it for that kind."""
    entry = COMMON_UNITS.get(unit.strip())
    return entry[1] if entry is not None and entry[0] == kind else None


def common_convert(text: str, unit: str) -> float | None:
    """``text`` (a number and a unit, ``"25 g"``) in ``unit`` when both units are in
    :data:`COMMON_UNITS` with the same kind; ``None`` otherwise (then pint reads it)."""
    m = _NUMBER.match(text)
    given, wanted = COMMON_UNITS.get(text[m.end():].strip()) if m else None, COMMON_UNITS.get(unit.strip())
    if given is None or wanted is None or given[0] != wanted[0]:
        return None
    return float(m.group(1)) * given[1] / wanted[1]


@lru_cache(maxsize=None)
def _unit(kind: str) -> "pint.Unit":
    return registry().Unit(CANONICAL[kind])


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
    elif isinstance(value, str) and (common := _common(value, kind)) is not None:
        out = common
    elif isinstance(value, str):
        q = _parse(value, where)
        if kind in _PER_TIME_KINDS:
            out = _per_time(q, value, kind, where)
        else:
            from pint import DimensionalityError

            try:
                out = float(q.to(_unit(kind)).magnitude)
            except DimensionalityError:
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


def _common(value: str, kind: str) -> float | None:
    """``value`` in the canonical unit of ``kind`` when it is a plain number and a unit of
    :data:`COMMON_UNITS` of that kind (``"300 deg"``, ``"0.5 s"``); ``None`` otherwise."""
    m = _NUMBER.match(value)
    if m is None:
        return None
    unit = value[m.end():].strip()
    factor = COMMON_RATES.get((unit, kind)) if kind in _PER_TIME_KINDS else common_factor(unit, kind)
    return None if factor is None else float(m.group(1)) * factor


def _parse(value: str, where: str) -> Any:
    """pint's reading of ``value`` as a Quantity (dimensionless for a string without a unit)."""
    ureg = registry()
    try:
        q = ureg.Quantity(_ONE_OVER.sub(r"\1 /", value))
    except Exception as exc:  # pint raises several types for bad strings
        raise UnitError(f"cannot read {value!r} as a quantity ({exc})", where) from None
    return q if isinstance(q, ureg.Quantity) else ureg.Quantity(float(q))


# --- frequencies: one rule for every key that takes a rate per unit of time ----------------------

#: the units suggested when a value is not an angular frequency
ANGULAR_FREQUENCY_UNITS = "rad/s (or a bare number), Hz, rpm, turn/s or bph"
_PER_TIME_KINDS = frozenset({"angular_frequency", "frequency", "rate_per_s"})


def _time_dimensions():
    """pint's dimensionality of a time and of a rate per time."""
    ureg = registry()
    return ureg.second.dimensionality, (1 / ureg.second).dimensionality


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
    ureg = registry()
    time, per_time = _time_dimensions()
    if q.dimensionality != per_time:
        return None
    hertz = angle = 0
    for name, power in q.unit_items():
        if any(unit == "hertz" for _prefix, unit, _suffix in ureg.parse_unit_name(name)):
            hertz += power
            continue
        radians = dict((1 * ureg.get_root_units(name)[1]).unit_items()).get("radian", 0)
        if radians:
            angle += radians * power
        elif ureg.Unit(name).dimensionality != time:
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
        if q.dimensionality != _time_dimensions()[1]:
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
    ureg = registry()
    if not rest:
        return ureg.Quantity(float(m.group(1)))
    units = ("1 " + rest) if rest[0] == "/" else rest.lstrip("*").strip()
    try:
        return ureg.Quantity(float(m.group(1)), ureg.parse_units(units))
    except Exception:  # pint raises several types for unknown names
        raise UnitError(f"unknown unit {rest!r} in {text!r}", where) from None



#: words a column's unit uses for an encoder's counts (not a pint unit: they need counts per turn)
COUNT_WORDS = frozenset({"count", "counts", "cts", "ticks"})
