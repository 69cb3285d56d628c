"""A fit's answer in plain sentences, for a physics class or a watchmaker's bench.

The sentences open every report and ``escfit summary``; the technical tables follow them.  Each
number is the median over the fit's draws (the posterior's, or the least-squares normal
approximation's, :func:`escfit.report.quantities.parameter_draws`) with its 95 % interval in
words, "between 1.1 and 1.3 % (95 %)".

Free decay (a pendulum, a Pohl wheel, a balance without escapement), at the release amplitude
``A`` (per unit inertia; small damping, each loss over one half swing):

=====================================  ===================================
viscous damping C                      ``A (1 - exp(-pi C / (2 omega_d)))``, ``omega_d = sqrt(omega0**2 - C**2/4)``
Coulomb (pivot) friction R             ``2 R / omega0**2``
quadratic air drag D                   ``4 D A**2 / 3``
=====================================  ===================================

The swing loses ``2 (sum of the three) / A`` of its amplitude each period; each term's share
of the sum says where the loss goes, and ``Q = pi / (that fraction)`` (``omega0 / C`` for
viscous damping alone).  A minute holds ``60 omega0 / pi`` half swings.

Escapement-driven balance: the impulse windows give ``X * w`` per half swing (rad^2/s^2 per
unit inertia, ``w`` the part of the window inside ``[-A, A]``), friction takes ``2 R A`` and
viscous damping ``(pi / 2) C omega0 A**2`` in the same half swing; the sentences give those as
shares of the impulse, the friction torque ``R I`` in N m when the scene gives the inertia
``I``, and the amplitude friction would take in a minute without the escapement.

Geneva, verge and friction-rig fits: the friction coefficients ``mu`` in words.
"""

from __future__ import annotations

import math
import re
import tomllib

import numpy as np

from ..core.display import RAD_TO_DEG
from .quantities import inertia_of, parameter_draws

__all__ = ["plain_summary", "interval_words", "sig"]

HALF_SWINGS_PER_MINUTE = 60.0 / math.pi  # times omega0


def sig(x: float, digits: int = 2) -> str:
    """``x`` to ``digits`` significant figures, without an exponent for everyday sizes."""
    if not math.isfinite(x):
        return "∞" if x > 0 else ("−∞" if x < 0 else "nan")
    if x == 0:
        return "0"
    decimals = max(0, digits - 1 - int(math.floor(math.log10(abs(x)))))
    if abs(x) >= 1e6 or abs(x) < 1e-4:
        return f"{x:.{digits - 1}e}"
    return f"{round(x, decimals):.{decimals}f}"


def _quantiles(values) -> tuple[float, float, float]:
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if not v.size:
        return math.nan, math.nan, math.nan
    lo, med, hi = np.quantile(v, [0.025, 0.5, 0.975])
    return float(med), float(lo), float(hi)


def interval_words(values, unit: str = "", digits: int = 2) -> str:
    """``"1.2 % (between 1.1 and 1.3 %, 95 %)"``: the median and 95 % interval of ``values``."""
    med, lo, hi = _quantiles(values)
    u = f" {unit}" if unit else ""
    if not math.isfinite(med):
        return "not determined"
    while digits < 4 and len({sig(lo, digits), sig(med, digits), sig(hi, digits)}) < 3 and lo < med < hi:
        digits += 1  # a narrow interval: enough figures to tell its ends from the median
    return f"{sig(med, digits)}{u} (between {sig(lo, digits)} and {sig(hi, digits)}{u}, 95 %)"


def _scene(res) -> dict:
    try:
        return tomllib.loads(res.attrs.get("scene", "") or "")
    except tomllib.TOMLDecodeError:
        return {}


def plain_summary(res) -> list[str]:
    """A few sentences saying what the fit found, in everyday words and units.

    Parameters
    ----------
    res : escfit.results.FitResult

    Returns
    -------
    list of str
        Sentences (empty when the fit's family has nothing to say in words).
    """
    if res.verdict == "not determined":
        return ["The fit did not determine the parameters, so there is no plain answer yet: the first warning below "
                "says which edit of the scene to make."]
    model = res.attrs.get("model", "balance")
    draws = parameter_draws(res)
    if model == "balance":
        return _balance(res, draws)
    return _coefficients(draws)


def _coefficients(draws: dict) -> list[str]:
    """Friction coefficients (``*.mu``) of a Geneva, verge or friction-rig fit, in words."""
    out = []
    for name, values in draws.items():
        if name.split(".")[-1].startswith("mu") and np.ptp(values) > 0:
            where = name.split(".")[0]
            out.append(f"The friction coefficient μ ({where}) is {interval_words(values)}: the sliding surfaces "
                       f"resist with {sig(_quantiles(values)[0] * 100)} % of the force pressing them together.")
    return out


def _balance(res, draws: dict) -> list[str]:
    if "oscillator.omega0" not in draws:
        return []
    scene = _scene(res)
    linear = scene.get("oscillator", {}).get("coordinate") == "linear"
    k, unit = (1.0, "m") if linear else (RAD_TO_DEG, "deg")
    w0 = draws["oscillator.omega0"]
    zero = np.zeros_like(w0)
    c = draws.get("viscous.C", zero)
    d = draws.get("drag.D", zero)
    rs = {n: v for n, v in draws.items() if n == "coulomb.R" or n.startswith("coulomb.R[")}
    if any(n.startswith("escapement[") for n in draws):
        return _escapement(res, draws, scene, w0, c, rs, k, unit)
    if "oscillator.theta0" not in draws:
        return []
    amp = np.abs(draws["oscillator.theta0"])
    out = []
    for name, r in (rs or {"": zero}).items():
        at = _load_words(name)
        v, f, a = viscous_loss(amp, w0, c), 2 * r / w0 ** 2, 4 * d * amp ** 2 / 3
        total = v + f + a
        per_period = 200 * total / amp  # % of the amplitude each period
        out.append(f"The swing{at} loses {interval_words(per_period, '%')} of its amplitude each period, "
                   f"starting from {sig(float(np.median(amp)) * k, 3)} {unit}.")
        shares = [(share, words) for share, words in (
            (v / total, "viscous damping (C)"), (f / total, "friction in the pivot (R)"),
            (a / total, "air drag (D)")) if np.nanmedian(share) > 0]
        if shares:
            parts = [f"{_share_words(s)} is {words}" for s, words in sorted(shares, key=lambda p: -np.nanmedian(p[0]))]
            out.append(f"Of that loss, {_join(parts)}; Q = {sig(_quantiles(math.pi / (per_period / 100))[0])} "
                       f"at this amplitude.")
        halving = math.log(2) / -np.log1p(-np.minimum(per_period / 100, 1 - 1e-12)) * 2 * math.pi / w0
        out.append(f"At that rate the amplitude halves in {interval_words(halving, 's')}.")
        minute = total * w0 * HALF_SWINGS_PER_MINUTE * k
        if np.median(minute) < np.median(amp) * k:  # a balance's figure; a pendulum at rest sooner has none
            out.append(f"That is {interval_words(minute, unit)} of amplitude lost in the first minute.")
    return out


def viscous_loss(amp, w0, c):
    """Amplitude viscous damping takes from one half swing of amplitude ``amp`` (module docstring)."""
    wd = np.sqrt(np.maximum(w0 ** 2 - c ** 2 / 4, 1e-300))
    return amp * (1 - np.exp(-math.pi * c / (2 * wd)))


def _escapement(res, draws, scene, w0, c, rs, k, unit) -> list[str]:
    """Sentences for a balance driven by an escapement: where the impulse goes, the friction torque."""
    windows = scene.get("effects", {}).get("escapement", [])
    inertia = inertia_of(res)
    amp = _amplitude(res, draws)
    out = []
    for name, r in rs.items():
        at = _load_words(name)
        torque = f", a friction torque of {interval_words(r * inertia, 'N m')}" if inertia is not None else ""
        out.append(f"Friction in the pivot{at} would take {interval_words(2 * r / w0 ** 2 * k, unit)} of amplitude "
                   f"each half swing without the escapement{torque}.")
    if amp is None:
        return out
    given = np.zeros_like(w0)
    for i, window in enumerate(windows, start=1):
        x = draws.get(f"escapement[{i}].X")
        if x is None or window.get("kind") != "impulse":
            continue
        lo, hi = max(float(window.get("from", 0.0)), -amp), min(float(window.get("to", 0.0)), amp)
        given = given + x * max(hi - lo, 0.0)
    if not np.any(given > 0):
        return out
    for name, r in (rs or {"": np.zeros_like(w0)}).items():
        parts = [f"friction in the pivot (R) takes {interval_words(100 * 2 * r * amp / given, '%')}"]
        if np.any(c > 0):
            parts.append(f"viscous damping (C) {interval_words(100 * math.pi / 2 * c * w0 * amp ** 2 / given, '%')}")
        taken = np.median(2 * r * amp / given + math.pi / 2 * c * w0 * amp ** 2 / given)
        verdict = (" Friction outweighs the impulse there, so the amplitude falls." if taken > 1 else
                   " The rest of the impulse goes into the unlocking and a growing swing." if taken < 0.9 else "")
        out.append(f"At {sig(amp * k, 3)} {unit} of amplitude{_load_words(name)}, {_join(parts)} of the energy the "
                   f"escapement's impulse gives each half swing.{verdict}")
    return out


def _amplitude(res, draws) -> float | None:
    """The amplitude the balance runs at: the median timegrapher reading, else the release angle (rad)."""
    obs = res.group("observed_data")
    if obs is not None and "curve" in obs.coords:
        readings = obs["reading"].values[obs["curve"].values == "amplitude"]
        if readings.size and str(obs["reading"].attrs.get("units", "")).startswith("deg"):
            return math.radians(float(np.median(readings)))
    a0 = draws.get("oscillator.theta0")
    return float(np.median(np.abs(a0))) if a0 is not None else None


def _share_words(share) -> str:
    """``"about two thirds (64 %, between 50 and 80 %)"`` for a share of the loss."""
    med, lo, hi = _quantiles(100 * np.asarray(share, float))
    return f"{_fraction_words(med / 100)} ({sig(med)} %, between {sig(lo)} and {sig(hi)} %)"


def _fraction_words(x: float) -> str:
    for value, words in ((0.995, "all"), (0.9, "nearly all"), (0.72, "about three quarters"),
                         (0.6, "about two thirds"), (0.4, "about half"), (0.29, "about a third"),
                         (0.2, "about a quarter"), (0.05, "a small part"), (0.0, "hardly any")):
        if x >= value:
            return words
    return "none"


def _join(parts: list[str]) -> str:
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


def _load_words(name: str) -> str:
    found = re.search(r"\[load=([^\]]+)\]", name)
    return f" at load {found.group(1)}" if found else ""
