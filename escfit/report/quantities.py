"""Quantities people quote, derived from a saved balance or pendulum fit.

Each is computed at every posterior draw (a least-squares fit: at draws of the normal
approximation of its parameters, clipped to their bounds), and shown as the median and 95 %
interval of those values, in the units people read.  Held parameters enter at their values.
Formulas (per unit inertia; ``omega_d = sqrt(omega0**2 - C**2/4)``; exact for a linear
restoring torque, small-swing values for a gravity pendulum):

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

import numpy as np

from ..core.display import RAD_TO_DEG, format_row, load_unit
from .params import held_values

__all__ = ["derived_rows", "parameter_draws", "inertia_of", "half_swing_loss"]

N_DRAWS = 4000


def half_swing_loss(amplitude, omega0, c, r):
    """Amplitude lost in one half swing from ``amplitude`` (rad) by a linear oscillator with viscous rate
    ``c`` (1/s) and Coulomb term ``r`` (rad/s^2): ``A (1 - q) + (1 + q) R / omega0**2``,
    ``q = exp(-pi C / (2 omega_d))`` (arrays broadcast; see the module docstring)."""
    wd = np.sqrt(np.maximum(np.asarray(omega0, float) ** 2 - np.asarray(c, float) ** 2 / 4, 1e-300))
    q = np.exp(-math.pi * np.asarray(c, float) / (2 * wd))
    return np.asarray(amplitude, float) * (1 - q) + (1 + q) * np.asarray(r, float) / np.asarray(omega0, float) ** 2


def inertia_of(res) -> float | None:
    """The scene's ``[oscillator] inertia`` (kg m^2), if it gives one."""
    from ..core.units import to_canonical

    try:
        osc = tomllib.loads(res.attrs.get("scene", "") or "").get("oscillator", {})
        return float(to_canonical(osc["inertia"], "inertia", "[oscillator].inertia")) if "inertia" in osc else None
    except Exception:  # noqa: BLE001 - a scene the report cannot read: no torques in N m
        return None


def parameter_draws(res, rng: np.random.Generator | None = None) -> dict[str, np.ndarray]:
    """Draws of every parameter (canonical units): the posterior's, else the least-squares normal
    approximation clipped to the bounds; held parameters as constants."""
    post, lsq = res.group("posterior"), res.group("least_squares")
    out: dict[str, np.ndarray] = {}
    if post is not None:
        for name in res.parameter_names:
            if name in post:
                out[name] = np.asarray(post[name].values, float).ravel()
    elif lsq is not None:
        rng = rng or np.random.default_rng(0)
        names = list(map(str, lsq["parameter"].values))
        value = lsq["value"].values.astype(float)
        se = np.nan_to_num(lsq["stderr"].values.astype(float), nan=0.0)
        corr = np.nan_to_num(lsq["correlation"].values.astype(float), nan=0.0)
        np.fill_diagonal(corr, 1.0)
        cov = corr * np.outer(se, se)
        z = rng.multivariate_normal(np.zeros(len(names)), cov, size=N_DRAWS, method="eigh", check_valid="ignore")
        draws = value + z
        lo = lsq["min"].values.astype(float) if "min" in lsq else np.full(len(names), -np.inf)
        hi = lsq["max"].values.astype(float) if "max" in lsq else np.full(len(names), np.inf)
        draws = np.clip(draws, lo, hi)
        out = {n: draws[:, i] for i, n in enumerate(names)}
    size = max((v.size for v in out.values()), default=1)
    for name, value in held_values(res).items():
        out.setdefault(name, np.full(size, value))
    return out


def _linear(res) -> bool:
    """Whether the fit's scene is a linear oscillator (amplitudes in m, R in m/s^2)."""
    try:
        return tomllib.loads(res.attrs.get("scene", "") or "").get("oscillator", {}).get("coordinate") == "linear"
    except tomllib.TOMLDecodeError:
        return False


def _restoring(res) -> str:
    try:
        return str(tomllib.loads(res.attrs.get("scene", "") or "").get("oscillator", {}).get("restoring", "spring"))
    except tomllib.TOMLDecodeError:
        return "spring"


def derived_rows(res) -> tuple[list[str], list[list[str]], str]:
    """Header, rows and a closing sentence of the derived-quantities table (empty for other families).

    Rows: ``[quantity, unit, median, 95 % interval, formula]``.
    """
    if res.attrs.get("model", "balance") != "balance":
        return [], [], ""
    draws = parameter_draws(res)
    if "oscillator.omega0" not in draws:
        return [], [], ""
    w0 = draws["oscillator.omega0"]
    c = draws.get("viscous.C", np.zeros_like(w0))
    wd = np.sqrt(np.maximum(w0 ** 2 - c ** 2 / 4, 1e-300))
    loads_in = load_unit(json.loads(res.attrs.get("meanings", "{}") or "{}"))
    rs = {n: v for n, v in draws.items() if n == "coulomb.R" or n.startswith("coulomb.R[")}
    rows: list[list[str]] = []

    def add(label, unit, values, formula):
        v = np.asarray(values, float)
        v = v[~np.isnan(v)]
        if not v.size:
            return
        lo, med, hi = np.quantile(v, [0.025, 0.5, 0.975])
        finite = np.isfinite([lo, med, hi])
        if not finite[1]:
            return
        text, ends = format_row(med, (lo, hi), (hi - lo) if finite.all() else None)
        ends = [e if f else "∞" for e, f in zip(ends, finite[[0, 2]])]
        rows.append([label, unit, text, f"[{ends[0]}, {ends[1]}]", formula])

    small = " (small swings)" if _restoring(res) == "pendulum" else ""
    k, unit = (1.0, "m") if _linear(res) else (RAD_TO_DEG, "deg")  # amplitudes as people read them
    if np.any(c > 0):
        with np.errstate(divide="ignore"):
            add("quality factor Q (viscous damping alone)", "", np.where(c > 0, w0 / c, np.inf), "ω0 / C")
        add("logarithmic decrement per period Λ (viscous)", "", math.pi * c / wd, "π C / ωd")
    has_escapement = any(n.startswith("escapement[") for n in draws)
    # with an escapement the impulse gives the amplitude back: say it is what friction alone would take
    taken = "amplitude Coulomb friction alone would take per half swing" if has_escapement else \
        "amplitude lost per half swing to Coulomb friction"
    for name, r in rs.items():
        at = _at_load(name, loads_in)
        add(f"{taken}{at}{small}", unit, 2 * r / w0 ** 2 * k, "2 R / ω0²")
    a0 = draws.get("oscillator.theta0")
    if a0 is not None and not has_escapement:
        amp = np.abs(a0)
        for name, r in (rs or {"": np.zeros_like(w0)}).items():
            at = _at_load(name, loads_in)
            loss = half_swing_loss(amp, w0, c, r)
            add(f"amplitude lost in the first half swing, from {np.median(amp) * k:.3g} {unit}{at}{small}",
                unit, loss * k, "A (1 − r) + (1 + r) R / ω0², r = exp(−π C / 2ωd)")
    inertia = inertia_of(res)
    if inertia is not None:
        for name, r in rs.items():
            add(f"Coulomb friction torque{_at_load(name, loads_in)}", "N m", r * inertia, "R I")
        for name, x in draws.items():
            found = re.fullmatch(r"escapement\[(\d+)\]\.X", name)
            if found:
                add(f"escapement torque of window {found.group(1)}", "N m", x * inertia, "X I")
        if "viscous.C" in draws:
            add("viscous coefficient c", "N m s", c * inertia, "C I")
    if inertia is not None:
        note = f"Torques from the scene's moment of inertia I = {inertia:.4g} kg m²."
    else:
        note = ("The model is per unit mass: R is a friction force per mass (m/s² in the table above)." if _linear(res)
                else "The scene gives no moment of inertia, so torques stay per unit inertia (rad/s² in the table above).")
    how = ("posterior draws" if res.group("posterior") is not None
           else "the least-squares estimate's normal approximation")
    note += f" Medians and 95 % intervals over {how}; held parameters at their values."
    head = ["quantity", "unit", "median", "95% interval", "formula"]
    return head, rows, note


def _at_load(name: str, loads_in: str) -> str:
    found = re.search(r"\[load=([^\]]+)\]", name)
    return f" at {found.group(1)} {loads_in}".rstrip() if found else ""
