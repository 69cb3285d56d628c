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
``""`` (dimensionless)         any             ``1``                       1
anything else                  any             the unit, ``**`` -> ``^``   1
=============================  ==============  ==========================  ===============

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
           "format_value"]

RAD_TO_DEG = 180.0 / math.pi


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
    DisplayRule("", "1", why="dimensionless"),
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
