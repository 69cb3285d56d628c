"""Quantities people quote, derived from a balance or pendulum fit's parameter draws.

The report (:mod:`escfit.report.quantities`) computes each at every posterior draw (a
least-squares fit: at draws of the normal approximation of its parameters, clipped to their
bounds) and shows its median and 95 % interval.  Formulas (per unit inertia;
``omega_d = sqrt(omega0**2 - C**2/4)``; exact for a linear restoring torque, small-swing values
for a gravity pendulum):

=========================================  ==============================================
quality factor (viscous damping alone)     ``Q = omega0 / C``
logarithmic decrement per period (viscous) ``Lambda = pi C / omega_d``
amplitude lost per half swing to friction  ``2 R / omega0**2`` (Coulomb: the same at every amplitude)
amplitude lost per half swing at ``A``     ``A (1 - r) + (1 + r) R / omega0**2``, ``r = exp(-pi C / (2 omega_d))``
Coulomb friction torque                    ``R I`` (N m), with the scene's inertia ``I``
escapement torque                          ``X I`` (N m)
viscous coefficient                        ``c = C I`` (N m s)
=========================================  ==============================================

The amplitude lost per half swing at ``A`` is the exact map of a linear oscillator with viscous
and Coulomb damping over one half swing (the Coulomb term shifts the centre by ``R/omega0**2``
against the motion); it is quoted at the release amplitude and only when no escapement
drives the swing.
"""

from __future__ import annotations

import json
import math
import re
import tomllib
from typing import Any, Mapping

import numpy as np

from ..core.display import RAD_TO_DEG, load_unit

__all__ = ["derived_quantities", "half_swing_loss", "inertia_of"]


def half_swing_loss(amplitude, omega0, c, r):
    """Amplitude lost in one half swing from ``amplitude`` (rad) by a linear oscillator with viscous rate
    ``c`` (1/s) and Coulomb term ``r`` (rad/s^2): ``A (1 - q) + (1 + q) R / omega0**2``,
    ``q = exp(-pi C / (2 omega_d))`` (arrays broadcast; see the module docstring)."""
    wd = np.sqrt(np.maximum(np.asarray(omega0, float) ** 2 - np.asarray(c, float) ** 2 / 4, 1e-300))
    q = np.exp(-math.pi * np.asarray(c, float) / (2 * wd))
    return np.asarray(amplitude, float) * (1 - q) + (1 + q) * np.asarray(r, float) / np.asarray(omega0, float) ** 2


def _oscillator(attrs: Mapping[str, Any]) -> dict:
    """The ``[oscillator]`` table of a fit's scene text (empty when it cannot be read)."""
    try:
        return tomllib.loads(attrs.get("scene", "") or "").get("oscillator", {})
    except tomllib.TOMLDecodeError:
        return {}


def inertia_of(attrs: Mapping[str, Any]) -> float | None:
    """The scene's ``[oscillator] inertia`` (kg m^2), if it gives one."""
    from ..core.units import to_canonical

    try:
        osc = _oscillator(attrs)
        return float(to_canonical(osc["inertia"], "inertia", "[oscillator].inertia")) if "inertia" in osc else None
    except Exception:  # noqa: BLE001 - a scene the report cannot read: no torques in N m
        return None


def model_title(attrs: Mapping[str, Any]) -> str:
    """The model in plain words: a linear oscillator, a gravity pendulum or a balance wheel."""
    osc = _oscillator(attrs)
    if osc.get("coordinate") == "linear":
        return "Linear oscillator (mass on a spring) model"
    return "Gravity pendulum model" if osc.get("restoring") == "pendulum" else "Balance wheel (spring) model"


def derived_quantities(draws: Mapping[str, np.ndarray], attrs: Mapping[str, Any]) -> tuple[list, str]:
    """The rows ``(label, unit, values, formula)`` of the module docstring's quantities, and a
    closing sentence; ``([], "")`` without ``oscillator.omega0`` among the draws."""
    if "oscillator.omega0" not in draws:
        return [], ""
    w0 = draws["oscillator.omega0"]
    c = draws.get("viscous.C", np.zeros_like(w0))
    wd = np.sqrt(np.maximum(w0 ** 2 - c ** 2 / 4, 1e-300))
    loads_in = load_unit(json.loads(attrs.get("meanings", "{}") or "{}"))
    rs = {n: v for n, v in draws.items() if n == "coulomb.R" or n.startswith("coulomb.R[")}
    rows: list = []
    add = lambda *row: rows.append(row)  # noqa: E731

    osc = _oscillator(attrs)
    linear = osc.get("coordinate") == "linear"
    small = " (small swings)" if str(osc.get("restoring", "spring")) == "pendulum" else ""
    k, unit = (1.0, "m") if linear else (RAD_TO_DEG, "deg")  # amplitudes as people read them
    open_ = _undetermined(attrs)
    if np.any(c > 0):
        with np.errstate(divide="ignore"):
            add(f"quality factor Q (viscous damping alone){open_('viscous.C')}", "", np.where(c > 0, w0 / c, np.inf),
                "ω0 / C")
        add(f"logarithmic decrement per period Λ (viscous){open_('viscous.C')}", "", math.pi * c / wd, "π C / ωd")
    has_escapement = any(n.startswith("escapement[") for n in draws)
    # with an escapement the impulse gives the amplitude back: say it is what friction alone would take
    taken = "amplitude Coulomb friction alone would take per half swing" if has_escapement else \
        "amplitude lost per half swing to Coulomb friction"
    for name, r in rs.items():
        at = _at_load(name, loads_in)
        add(f"{taken}{at}{small}{open_(name)}", unit, 2 * r / w0 ** 2 * k, "2 R / ω0²")
    a0 = draws.get("oscillator.theta0")
    if a0 is not None and not has_escapement:
        amp = np.abs(a0)
        for name, r in (rs or {"": np.zeros_like(w0)}).items():
            at = _at_load(name, loads_in)
            loss = half_swing_loss(amp, w0, c, r)
            add(f"amplitude lost in the first half swing, from {np.median(amp) * k:.3g} {unit}{at}{small}",
                unit, loss * k, "A (1 − r) + (1 + r) R / ω0², r = exp(−π C / 2ωd)")
    inertia = inertia_of(attrs)
    if inertia is not None:
        for name, r in rs.items():
            add(f"Coulomb friction torque{_at_load(name, loads_in)}{open_(name)}", "N m", r * inertia, "R I")
        for name, x in draws.items():
            found = re.fullmatch(r"escapement\[(\d+)\]\.X", name)
            if found:
                add(f"escapement torque of window {found.group(1)}", "N m", x * inertia, "X I")
        if "viscous.C" in draws:
            add(f"viscous coefficient c{open_('viscous.C')}", "N m s", c * inertia, "C I")
        note = f"Torques from the scene's moment of inertia I = {inertia:.4g} kg m²."
    else:
        note = ("The model is per unit mass: R is a friction force per mass (m/s² in the table above)." if linear
                else "The scene gives no moment of inertia, so torques stay per unit inertia (rad/s² in the table above).")
    return rows, note


def _undetermined(attrs: Mapping[str, Any]):
    """``mark(name)``: what a quantity computed from parameter ``name`` alone adds to its label when
    the fit leaves that parameter not determined (the split of the losses, say: the sum stands)."""
    try:
        names = set(json.loads(attrs.get("undetermined", "[]") or "[]"))
    except (TypeError, ValueError):
        names = set()
    return lambda name: " (not determined by this record)" if name in names else ""


def _at_load(name: str, loads_in: str) -> str:
    found = re.search(r"\[load=([^\]]+)\]", name)
    return f" at {found.group(1)} {loads_in}".rstrip() if found else ""
