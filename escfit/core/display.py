"""Numbers as people read them: stored values and units -> values and unit labels for display.

Results files and JSON keep escfit's canonical units (angles in rad, torques per inertia in
1/s**2); tables and figures show what a horologist thinks in.  One small table of rules,
:data:`RULES`, says how: the first rule whose stored unit and parameter name match gives the
display unit label and the factor applied to the value(s).

=============================  ==============  ==========================  ===============
stored unit                    parameter name  display label               factor
=============================  ==============  ==========================  ===============
``rad``                        any             ``deg``                     180/pi
``rad/s``                      ``*_rate``      ``deg/s``                   180/pi
``1/s**2``                     any             ``rad/s^2``                 1
``1/s``                        ``*omega0``     ``rad/s``                   1
``""`` (dimensionless)         any             ``dimensionless``           1
``N``                          any             ``gf``                      1000/g0
``1/N``                        any             ``1/gf``                    g0/1000
``s/m``                        any             ``s/ft``                    0.3048
``m``                          ``rig.*``       ``in``                      1/0.0254
``N*m``                        ``geneva.*``    ``lbf in``                  1/(4.448 * 0.0254)
anything else                  any             the unit, ``**`` -> ``^``   1
=============================  ==============  ==========================  ===============

Forces (only the friction rig's readings and noise are in N), the rig's geometry and its friction
laws' slopes read in the rig's own units (gram-force, inches, ft/s), as its figures and Monday's
session do; Geneva torques in the lbf in of Meyer's tables.

Torques per inertia (R, X) are angular accelerations, so their ``1/s**2`` reads ``rad/s^2``;
omega0 is an angular frequency (``rad/s``) while the viscous rate C stays ``1/s``.  A rate in
rad/s that is a speed of rotation (a spin, a measured speed) stays in rad/s; only slow angle
drifts (``*_rate``) read in deg/s.

Loads: balance fits of several loads name parameters ``coulomb.R[load=330.66]`` and curves
``unit3 load 330.66``; the load's unit is stated in the parameter's meaning ("... at load
330.66 g"), which :func:`load_unit` reads so that :func:`display_name` prints
``coulomb.R[load=330.66 g]`` and :func:`curve_label` ``unit3, 330.66 g``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

__all__ = ["RULES", "DisplayRule", "to_display", "display_unit", "display_name", "curve_label", "load_unit",
           "format_value", "format_row", "FIXED_RANGE"]

FIXED_RANGE = (1e-3, 1e6)  # magnitudes written as plain decimals; outside, in powers of ten

RAD_TO_DEG = 180.0 / math.pi
G0 = 9.80665  # m/s^2: one gram-force is G0/1000 newton
FT = 0.3048  # m per foot
INCH = 0.0254  # m per inch
LBF = 4.4482216152605  # N per pound-force


@dataclass(frozen=True)
class DisplayRule:
    """One conversion: ``stored`` unit (and a test on the parameter name) -> ``label`` and ``factor``."""

    stored: str
    label: str
    factor: float = 1.0
    applies: Callable[[str], bool] = lambda name: True
    why: str = ""


RULES: tuple[DisplayRule, ...] = (
    DisplayRule("rad", "deg", RAD_TO_DEG, why="angles (amplitudes, lift angle, notch angle, offsets, noise)"),
    DisplayRule("rad/s", "deg/s", RAD_TO_DEG, applies=lambda n: n.endswith("_rate"), why="slow drift of an angle"),
    DisplayRule("1/s**2", "rad/s^2", why="torque per inertia is an angular acceleration"),
    DisplayRule("1/s", "rad/s", applies=lambda n: n.split(".")[-1].startswith("omega"), why="angular frequency"),
    DisplayRule("", "dimensionless", why="a ratio (friction coefficients, restitution, Q)"),
    # the friction rig reads in gram-force, inches and ft/s (Monday's rig): its table does too
    DisplayRule("N", "gf", 1000.0 / G0, why="force on the friction rig (its weights are grams)"),
    DisplayRule("1/N", "1/gf", G0 / 1000.0, why="change of mu per gram-force of load"),
    DisplayRule("s/m", "s/ft", FT, why="change of mu per ft/s of sliding speed"),
    DisplayRule("m", "in", 1.0 / INCH, applies=lambda n: n.startswith("rig."), why="rig geometry (inches)"),
    # Meyer's Geneva torques are in lbf*inch
    DisplayRule("N*m", "lbf in", 1.0 / (LBF * INCH), applies=lambda n: n.startswith("geneva."),
                why="driving torque, in the source's lbf in"),
    # Meyer's and Lowen and Tepper's reports are in inches, pounds-force and seconds
    DisplayRule("kg*m**2", "lbf in s^2", 1.0 / (LBF * INCH), applies=lambda n: n.startswith(("geneva.", "verge.")),
                why="inertia, in the sources' lbf in s^2"),
    DisplayRule("m", "in", 1.0 / INCH, applies=lambda n: n.startswith("verge."), why="verge geometry (inches)"),
    DisplayRule("kg", "lbf s^2/in", INCH / LBF, applies=lambda n: n.startswith("verge."), why="verge masses"),
    DisplayRule("rad/s", "rpm", 30.0 / math.pi, applies=lambda n: n == "verge.spin", why="fuze spin, in rpm"),
)


def _rule(unit: str, name: str) -> DisplayRule | None:
    for rule in RULES:
        if rule.stored == unit and rule.applies(name):
            return rule
    return None


def display_unit(unit: str | None, name: str = "") -> str:
    """The display label of a stored unit (e.g. ``"1/s**2"`` -> ``"rad/s^2"``, ``"rad"`` -> ``"deg"``)."""
    unit = (unit or "").strip()
    rule = _rule(unit, name)
    return rule.label if rule else unit.replace("**", "^").replace("*", " ")


def to_display(values, unit: str | None, name: str = ""):
    """Value(s) in a stored unit -> (value(s) in the display unit, display unit label).

    Parameters
    ----------
    values
        A number, ``None`` or an array of numbers, in ``unit``.  Interval ends convert the same
        way: every rule is a positive factor, so the order of interval ends is kept.
    unit
        The stored (canonical) unit, e.g. ``"rad"``, ``"1/s**2"``; ``None`` or ``""`` for a
        dimensionless quantity.
    name
        The parameter name (some rules apply only to e.g. ``*.omega0``).

    Returns
    -------
    tuple
        ``(converted, label)``: ``converted`` has the type of ``values`` (float, array, or
        ``None`` unchanged); ``label`` is the display unit, e.g. ``"deg"``.

    Examples
    --------
    >>> to_display(math.pi, "rad", "observation.lift_angle")
    (180.0, 'deg')
    >>> to_display(981.4, "1/s**2", "coulomb.R")
    (981.4, 'rad/s^2')
    """
    unit = (unit or "").strip()
    rule = _rule(unit, name)
    factor = rule.factor if rule else 1.0
    label = rule.label if rule else unit.replace("**", "^").replace("*", " ")
    if values is None:
        return None, label
    if isinstance(values, (list, tuple, np.ndarray)):
        return np.asarray(values, dtype=float) * factor, label
    return float(values) * factor, label


_LOAD_NAME = re.compile(r"^(?P<base>.*)\[load=(?P<load>[^\]]+)\]$")
_LOAD_MEANING = re.compile(r"at load\s+[-+0-9.eE]+\s+(?P<unit>[A-Za-z_/*]+)")
_LOAD_CURVE = re.compile(r"^(?P<head>.*?)\s*\bload\s+(?P<load>[-+0-9.eE]+)$")


def load_unit(meanings: Mapping[str, str]) -> str:
    """The unit of the fixture loads, read from the parameters' meanings (``""`` if none says)."""
    for text in meanings.values():
        found = _LOAD_MEANING.search(str(text))
        if found:
            return found.group("unit")
    return ""


def display_name(name: str, loads_in: str = "") -> str:
    """A parameter name for tables and axes, with the load's unit:
    ``coulomb.R[load=330.66]`` -> ``coulomb.R[load=330.66 g]`` (unchanged without a unit)."""
    found = _LOAD_NAME.match(name)
    if not found or not loads_in:
        return name
    return f"{found.group('base')}[load={found.group('load')} {loads_in}]"


def display_text(text: str, loads_in: str = "") -> str:
    """Parameter names inside a sentence (a warning) with the load's unit, as :func:`display_name`."""
    if not loads_in:
        return text
    return re.sub(r"\[load=([-+0-9.eE]+)\]", lambda m: f"[load={m.group(1)} {loads_in}]", text)


def curve_label(label: str, loads_in: str = "") -> str:
    """A curve's legend label: ``unit3 load 330.66`` -> ``unit3, 330.66 g``; others unchanged."""
    found = _LOAD_CURVE.match(str(label))
    if not found:
        return str(label)
    head = found.group("head").strip()
    load = f"{found.group('load')}{' ' + loads_in if loads_in else ''}"
    return f"{head}, {load}" if head and head != "unit" else load


def format_value(value, digits: int = 5) -> str:
    """A number for a table cell: ``digits`` significant figures, ``-`` for None or non-finite."""
    if value is None:
        return "-"
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return str(int(value))
    try:
        v = float(value)
    except (TypeError, ValueError):
        return str(value)
    return f"{v:.{digits}g}" if math.isfinite(v) else "-"


def _step(width: float | None) -> int | None:
    """Power of ten of the last digit shown: two significant digits of the interval's width."""
    if width is None or not math.isfinite(width) or width <= 0:
        return None
    return math.floor(math.log10(width)) - 1


def _fixed(value: float, step: int) -> str:
    return f"{value:.{max(0, -step)}f}" if step < 0 else f"{round(value, -step):.0f}"


def format_row(value, ends=(), width: float | None = None) -> tuple[str, list[str]]:
    """An estimate and its interval ends with the same last digit, set by the interval's width.

    The last digit shown is the second significant digit of ``width`` (default: the spread of
    ``ends``), so an estimate of 2029 with a 95 % interval 11 wide reads ``2029 [2024, 2035]``
    and 2.3493 with an interval 0.21 wide ``2.35 [2.24, 2.45]``.  Magnitudes outside
    :data:`FIXED_RANGE` are written in powers of ten with as many significant digits.  Without
    a width (a held value, an exact one) six significant digits are shown.

    Returns
    -------
    tuple
        ``(value text, [end texts])``; ``-`` for None or non-finite numbers.
    """
    nums = [float(v) for v in (value, *ends) if v is not None and math.isfinite(float(v))]
    finite_ends = [float(e) for e in ends if e is not None and math.isfinite(float(e))]
    if width is None and len(finite_ends) >= 2:
        width = max(finite_ends) - min(finite_ends)
    step = _step(width)
    biggest = max((abs(v) for v in nums), default=0.0)

    def one(v) -> str:
        if v is None or not math.isfinite(float(v)):
            return "-"
        v = float(v)
        if step is None:
            text = f"{v:.6g}"
        elif v == 0.0:
            return "0"
        elif biggest and not FIXED_RANGE[0] <= biggest < FIXED_RANGE[1]:
            text = f"{v:.{max(0, math.floor(math.log10(biggest)) - step)}e}"
        else:
            text = _fixed(v, step)
        return text[1:] if text.startswith("-") and float(text) == 0.0 else text  # no "-0.00"

    return one(value), [one(e) for e in ends]
