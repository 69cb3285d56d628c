"""A balance wheel's or pendulum's fit in plain sentences (:meth:`BalanceFamily.plain`).

Free decay (a pendulum, a Pohl wheel, a balance without escapement), at the release amplitude
``A``: each dissipative effect of the fit (the effects that declare a ``LOSS``) takes its part
of the amplitude over one half swing, ``effect.decrement(value, swing)`` on the undamped half
swing of the scene's restoring law (:func:`escfit.balance.decrement.swing_of`: a pendulum's
elliptic integrals, a stiffening spring's quadrature), first order in the damping; on a linear
spring these are

=====================================  ===================================
viscous damping C                      ``2 tanh(pi C / (4 omega_d)) A``, ``omega_d = sqrt(omega0**2 - C**2/4)``
Coulomb (pivot) friction R             ``2 R / omega0**2``
quadratic air drag D                   ``4 D A**2 / 3``
=====================================  ===================================

and on a pendulum friction's part is ``2 R A / (omega0**2 sin A)`` (7 % more than the spring's
at 37 deg).  Each effect is named as its ``LOSS`` says in plain words ("friction in the
pivot (R)").  The swing loses ``2 (sum of the parts) / A`` of its amplitude each period; each
part's share of the sum says where the loss goes, and ``Q = pi / (that fraction)``
(``omega0 / C`` for viscous damping alone).  The amplitude halves in
``ln 2 / -ln(1 - fraction)`` periods.  A minute holds ``60 omega0 / pi`` half swings; the
amplitude lost in it follows the decay down through them (the parts at each amplitude on the
way) and is given when most draws still swing after the minute (a balance's figure).  Where
the first-order loss of a half swing exceeds :data:`~escfit.balance.plain_decay.MODEL_ABOVE`
(2 %) of the amplitude, the first period's loss, the loss of the period from about half the
amplitude and the halving time come from runs of the fitted scene itself
(:mod:`escfit.balance.plain_decay`); without a scene to run, beyond :data:`STRONG` these
figures do not hold (a strong air drag gave "113 % per period"), and the sentence says so
instead of giving them.  Another least-squares optimum nearly as good as the best (the results'
``other_optimum``) is named in a last sentence.

Escapement-driven balance: the impulse windows give ``X * w`` per half swing (rad^2/s^2 per
unit inertia, ``w`` the part of the window inside ``[-A, A]``), friction takes ``2 R A`` and
viscous damping ``(pi / 2) C omega0 A**2`` in the same half swing; the sentences give those as
shares of the impulse at the amplitude a timegrapher read (else the release), the friction
torque ``R I`` in N m when the scene gives the inertia ``I``.
"""

from __future__ import annotations

import json
import math
import re
import tomllib
from typing import Any, Mapping

import numpy as np

from ..analysis.decrement_law import LAW_DRIFTS, LAW_REFUTED
from ..analysis.start_dependence import LOSS_MOVES
from ..core.display import RAD_TO_DEG, to_display
from ..core.names import plain_name
from ..core.plainwords import interval_words, join_words, quantiles, share_words, sig
from .decrement import losses, swing_of
from .plain_decay import MODEL_ABOVE, model_decay
from .derived import inertia_of

__all__ = ["plain_sentences"]

HALF_SWINGS_PER_MINUTE = 60.0 / math.pi  # times omega0

#: the largest fraction of the amplitude one step of the minute's decay takes off
MINUTE_STEP = 0.02

#: steps of the minute's decay at most (a thousandth of the amplitude left counts as stopped)
MAX_MINUTE_STEPS = 400

#: draws whose decay over the minute is followed at most
MINUTE_DRAWS = 1000

#: a first-order loss per half swing above this share of the amplitude is beyond the small-damping
#: rule (a quadratic drag's 4 D A^2 / 3 then overstates the loss of a half swing by a third or more)
STRONG = 0.2


def _scene(attrs: Mapping[str, Any]) -> dict:
    try:
        return tomllib.loads(attrs.get("scene", "") or "")
    except tomllib.TOMLDecodeError:
        return {}


def _json_list(attrs: Mapping[str, Any], key: str) -> list[str]:
    """The list of strings a results attribute holds as JSON (empty when absent or not a list)."""
    try:
        items = json.loads(attrs.get(key, "[]") or "[]")
    except (TypeError, ValueError):
        return []
    return [str(n) for n in items] if isinstance(items, list) else []


def _undetermined(attrs: Mapping[str, Any]) -> list[str]:
    """The parameters the fit marked as not determined by the record."""
    return _json_list(attrs, "undetermined")


def _warnings(attrs: Mapping[str, Any]) -> list[str]:
    return _json_list(attrs, "warnings")


def _law_refuted(attrs: Mapping[str, Any]) -> bool:
    """Whether the fit's warnings say the record's losses refute its damping law, or that its
    envelope drifts from the model's for want of the right law."""
    return any(w.startswith(LAW_REFUTED) or LAW_DRIFTS in w for w in _warnings(attrs))


def _loss_moves(attrs: Mapping[str, Any]) -> bool:
    """Whether the fit's warnings say the swing's loss changes when the record's first period is left out."""
    return any(LOSS_MOVES in w for w in _warnings(attrs))


def plain_sentences(draws: Mapping[str, Any], attrs: Mapping[str, Any], observed=None) -> list[str]:
    """The sentences of a balance or pendulum fit (see the module docstring).

    Parameters
    ----------
    draws
        Every parameter at every draw (canonical units), held ones constant.
    attrs
        The results' root attributes (the scene text).
    observed
        The results' ``observed_data`` group, or None (timegrapher amplitudes are read from it).
    """
    if "oscillator.omega0" not in draws:
        return []
    scene = _scene(attrs)
    linear = scene.get("oscillator", {}).get("coordinate") == "linear"
    k, unit = (1.0, "m") if linear else (RAD_TO_DEG, "deg")
    w0 = np.asarray(draws["oscillator.omega0"], float)
    zero = np.zeros_like(w0)
    c = np.asarray(draws.get("viscous.C", zero), float)
    rs = {n: np.asarray(v, float) for n, v in draws.items() if n == "coulomb.R" or n.startswith("coulomb.R[")}
    if any(n.startswith("escapement[") for n in draws):
        return _escapement(attrs, draws, scene, observed, w0, c, rs, k, unit) + _other_optimum(attrs)
    if "oscillator.theta0" not in draws:
        return []
    amp = np.abs(np.asarray(draws["oscillator.theta0"], float))
    k3, restoring = draws.get("stiffening.k3", 0.0), scene.get("oscillator", {}).get("restoring", "spring")
    amp, w0 = np.broadcast_arrays(amp, w0)
    swing = swing_of(amp, w0, k3=k3, restoring=restoring)

    def swing_at(a, pick):
        return swing_of(a, w0[pick], k3=np.asarray(k3, float)[pick] if np.ndim(k3) else k3, restoring=restoring)

    out = []
    for load in _loads(draws):
        out += _free_decay(draws, attrs, swing, load, linear=linear, k=k, unit=unit, swing_at=swing_at)
    return out + _other_optimum(attrs)


def _free_decay(draws, attrs, swing, load: str, *, linear: bool, k: float, unit: str, swing_at) -> list[str]:
    """The sentences of a free decay at one load (``""``: the only one); see the module docstring.

    ``swing`` is the undamped half swing at the release amplitude of every draw, ``swing_at(a,
    pick)`` the one at amplitudes ``a`` of the draws ``pick``; ``k`` and ``unit`` turn radians
    (or metres) into the amplitude's display unit."""
    amp, w0 = swing.amplitude, np.asarray(draws["oscillator.omega0"], float)
    parts = [(loss, np.asarray(part, float)) for loss, part in _loss_parts(draws, swing, load)]
    total = sum((part for _, part in parts), np.zeros_like(amp))
    if not np.isfinite(np.median(total)):  # not a swing (beyond critical damping, over the top)
        return []
    share = float(np.median(total / amp))
    start = f"{sig(float(np.median(amp)) * k, 3)} {unit}"
    model = model_decay(attrs.get("scene", "") or "", draws, load, share=share) if share > MODEL_ABOVE else None
    if model is not None and not np.all(np.isfinite(model.first_period)):
        model = None
    if model is None and share > STRONG:  # beyond the small-damping rule the figures below come from
        return [f"The swing{_load_words(load)} loses so much in each half swing (about {sig(100 * share, 2)} % of "
                f"{start} by the small-damping rule these sentences use, which holds for a few per cent) that no loss "
                "per period or halving time is given here: the table gives the fitted values."]
    if model is None:
        per_period = 200 * total / amp  # % of the amplitude each period, to first order
        out = [f"The swing{_load_words(load)} loses {interval_words(per_period, '%')} of its amplitude each period, "
               f"starting from {start}."]
    else:
        per_period = 100 * model.first_period
        out = [f"The swing{_load_words(load)} loses {interval_words(per_period, '%')} of its amplitude in its first "
               f"period, from {start}{_at_half(model, k, unit)} (from runs of the fitted model itself: the "
               "small-damping rule is not precise at this damping)."]
    if _loss_moves(attrs):
        out.append("Fitted again without the record's first period, the swing's loss comes out otherwise (the "
                   "warnings give both figures): that period does not decay freely or by the fitted law, so these "
                   "figures are not determined by this record.")
    elif _law_refuted(attrs):
        out.append("The record's own losses do not follow the fitted damping law (the warnings give the figures): "
                   "these figures are the fitted law's, a compromise over the whole record.")
    out += _split(parts, total, per_period, attrs, linear)
    if model is None:
        halving = math.log(2) / -np.log1p(-np.minimum(per_period / 100, 1 - 1e-12)) * 2 * math.pi / w0
        out.append(f"At that rate the amplitude halves in {interval_words(halving, 's')}.")
    elif np.mean(np.isfinite(model.halving)) >= 0.9:
        out.append(f"The amplitude halves in {interval_words(model.halving[np.isfinite(model.halving)], 's')}.")
    minute = _lost_in_a_minute(draws, swing, load, swing_at) * k
    if np.mean(np.isfinite(minute)) >= 0.5:  # a balance's figure; a pendulum at rest sooner has none
        out.append(f"That is {interval_words(minute[np.isfinite(minute)], unit)} of amplitude lost in the first "
                   "minute.")
    return out


def _lost_in_a_minute(draws, swing, load: str, swing_at) -> np.ndarray:
    """The amplitude lost in the first minute (rad, or m), per draw; NaN where the swing stops sooner.

    The decay is followed half swing by half swing in steps that lose at most
    :data:`MINUTE_STEP` of the amplitude, each step's loss taken at its midpoint amplitude
    (the losses' parts at that amplitude, ``swing_at(amplitude)`` their undamped half swing):
    a viscous decay loses ``A (1 - exp(-30 C))`` in a minute, not the ``30 C A`` its first
    half swing's rate would give over the minute.  At most :data:`MINUTE_DRAWS` draws, evenly
    spaced, are followed.
    """
    pick = np.unique(np.linspace(0, swing.amplitude.size - 1, min(swing.amplitude.size, MINUTE_DRAWS)).astype(int))
    sub = {n: (np.asarray(v, float)[pick] if np.ndim(v) else v) for n, v in draws.items()}
    start = np.asarray(swing.amplitude, float)[pick]
    at = lambda a: swing_at(a, pick)  # noqa: E731 - the undamped half swing of the picked draws
    a, floor = start.copy(), start * 1e-3
    left = np.broadcast_to(np.asarray(swing.omega0, float), swing.amplitude.shape)[pick] * HALF_SWINGS_PER_MINUTE
    for _ in range(MAX_MINUTE_STEPS):
        going = (left > 0) & (a > floor)
        if not going.any():
            break
        loss = _total_loss(sub, at(a), load)
        steps = np.where(going, np.minimum(left, MINUTE_STEP * a / np.maximum(loss, 1e-300)), 0.0)
        mid = np.maximum(a - 0.5 * steps * loss, floor)
        a = np.where(going, np.maximum(a - steps * _total_loss(sub, at(mid), load), 0.0), a)
        left = left - steps
    return np.where((left > 0) | ~np.isfinite(a), np.nan, start - a)


def _total_loss(draws, swing, load: str) -> np.ndarray:
    """The amplitude every loss takes off a half swing together (rad per half swing)."""
    return sum((np.asarray(part, float) for _, part in _loss_parts(draws, swing, load)),
               np.zeros_like(swing.amplitude))


def _at_half(model, k: float, unit: str) -> str:
    """The clause for the period from about half the amplitude, when most runs reach it."""
    ok = np.isfinite(model.at_half)
    if np.mean(ok) < 0.9:
        return ""
    return (f"; from {sig(float(np.median(model.half_amplitude[ok])) * k, 3)} {unit}, about half that, it loses "
            f"{interval_words(100 * model.at_half[ok], '%')} a period")


def _split(parts, total, per_period, attrs, linear: bool) -> list[str]:
    """Where the loss goes: each effect's share (largest first) and Q, or that the record cannot split it."""
    every = " (every loss counted; the table's Q is viscous damping's alone)" if len(parts) > 1 else ""
    q = f"Q = {sig(quantiles(math.pi / (per_period / 100))[0])} at this amplitude{every}."
    undetermined = _undetermined(attrs)
    unsplit = [loss.words(linear=linear) for loss, _ in parts if loss.parameter in undetermined]
    if len(unsplit) >= 2:
        return [f"How that loss divides between {join_words(unsplit)} is not determined by this record (the warnings "
                f"say why); {q}"]
    shares = [(part / total, loss.words(linear=linear)) for loss, part in parts if np.nanmedian(part / total) > 0]
    if not shares:
        return []
    words = [f"{share_words(s)} is {name}" for s, name in sorted(shares, key=lambda p: -np.nanmedian(p[0]))]
    return [f"Of that loss, {join_words(words)}; {q}"]


def _other_optimum(attrs: Mapping[str, Any]) -> list[str]:
    """A sentence naming another least-squares optimum nearly as good as the best (the results'
    ``other_optimum``: :mod:`escfit.inference.neighbours`), in its physical parameters."""
    try:
        other = json.loads(attrs.get("other_optimum", "{}") or "{}")
        units = json.loads(attrs.get("units", "{}") or "{}")
    except (TypeError, ValueError):
        return []
    if not isinstance(other, dict) or not isinstance(units, dict):
        return []
    parts = []
    for name, value in other.items():
        if not name.startswith("observation."):  # the scale's zero and noise: no physical figure to give
            shown, unit = to_display(float(value), units.get(name, ""), name)
            parts.append(f"{plain_name(name)} = {sig(shown, 3)} {unit}".rstrip())
    if not parts:
        return []
    return [f"Another fit of this record is nearly as good, with {join_words(parts)}: the ranges above belong to "
            "the best fit alone, and a posterior fit (--method emcee) covers both."]


def _loads(draws: Mapping[str, Any]) -> list[str]:
    """The loads a fit gives a dissipative effect's coefficient per load for (``"[load=2]"`` ...),
    else ``[""]``: one set of sentences per load."""
    params = {cls.LOSS.parameter for cls in losses().values()}
    found = sorted({n[n.index("["):] for n in draws if "[" in n and n[:n.index("[")] in params})
    return found or [""]


def _loss_parts(draws: Mapping[str, Any], swing, load: str) -> list:
    """``(Loss, part)`` of every dissipative effect the fit has (the registry's order): its
    coefficient's draws at ``load`` (or its one value), through the effect's own decrement over
    the undamped half swing ``swing`` (rad per half swing)."""
    out = []
    for cls in losses().values():
        value = draws.get(cls.LOSS.parameter + load, draws.get(cls.LOSS.parameter))
        if value is not None:
            out.append((cls.LOSS, cls.decrement(np.asarray(value, float), swing)))
    return out


def _escapement(attrs, draws, scene, observed, w0, c, rs, k, unit) -> list[str]:
    """Sentences for a balance driven by an escapement: the friction torque, where the impulse goes
    and the amplitude at which it makes up for the losses."""
    windows = scene.get("effects", {}).get("escapement", [])
    inertia = inertia_of(attrs)
    amp = _amplitude(draws, observed)
    out = []
    for name, r in rs.items():
        torque = f", a friction torque of {interval_words(r * inertia, 'N m')}" if inertia is not None else ""
        step = 2 * r / w0 ** 2  # rad of amplitude per half swing
        if amp is not None and np.median(step) >= amp:
            out.append(f"Friction in the pivot{_load_words(name)} is strong enough to stop the balance within a half "
                       f"swing from {sig(amp * k, 3)} {unit} without the escapement: it takes "
                       f"{interval_words(step * k, unit)} of amplitude each half swing{torque}.")
        else:
            out.append(f"Friction in the pivot{_load_words(name)} would take {interval_words(step * k, unit)} "
                       f"of amplitude each half swing without the escapement{torque}.")
    if amp is None:
        return out
    given = _impulse(windows, draws, amp, w0)
    if not np.any(given > 0):
        return out
    swing = swing_of(np.full(w0.shape, float(amp)), w0, k3=draws.get("stiffening.k3", 0.0),
                     restoring=scene.get("oscillator", {}).get("restoring", "spring"))
    linear = scene.get("oscillator", {}).get("coordinate") == "linear"
    for load in _loads(draws):
        # each loss's energy per half swing (its part of the amplitude times dE/dA) against the impulse's
        shares = [(loss, np.asarray(part, float) * swing.gain / given) for loss, part in _loss_parts(draws, swing, load)]
        shares = sorted([p for p in shares if np.any(p[1] > 0)], key=lambda p: -np.nanmedian(p[1]))
        parts = [f"{loss.words(linear=linear)}{' takes' if i == 0 else ''} {interval_words(100 * share, '%')}"
                 for i, (loss, share) in enumerate(shares)]
        taken = np.median(sum((share for _, share in shares), np.zeros_like(w0)))
        verdict = (" The losses outweigh the impulse there, so the amplitude falls." if taken > 1 else
                   " The rest of the impulse goes into the unlocking and a growing swing." if taken < 0.9 else "")
        if parts:
            out.append(f"At {sig(amp * k, 3)} {unit} of amplitude{_load_words(load)}, {join_words(parts)} of the "
                       f"energy the escapement's impulse gives each half swing.{verdict}")
        # Monday's phase convention gains and loses constants per half swing: no energy balance in A
        r = np.asarray(draws.get("coulomb.R" + load, draws.get("coulomb.R", np.zeros_like(w0))), float)
        settles = balance_amplitude(windows, draws, w0, c, r) if scene.get("switching") != "phase" else [np.nan]
        if np.all(np.isfinite(settles)) and np.median(settles) > 0:
            out.append(f"The impulse makes up for these losses at an amplitude of {interval_words(settles * k, unit)}"
                       f"{_load_words(load)}: there the balance settles.")
    return out


def _impulse(windows, draws, amp, w0) -> np.ndarray:
    """Energy per unit inertia the impulse windows give each half swing of amplitude ``amp`` (rad):
    ``X`` times the part of each impulse window the swing crosses ((rad/s)^2)."""
    given = np.zeros_like(w0)
    amp = np.asarray(amp, float)
    for i, window in enumerate(windows, start=1):
        x = draws.get(f"escapement[{i}].X")
        if x is None or window.get("kind") != "impulse":
            continue
        lo = np.maximum(float(window.get("from", 0.0)), -amp)
        hi = np.minimum(float(window.get("to", 0.0)), amp)
        given = given + np.asarray(x, float) * np.maximum(hi - lo, 0.0)
    return given


def balance_amplitude(windows, draws, w0, c, r) -> np.ndarray:
    """The amplitude (rad) at which the impulse gives what friction and viscous damping take each
    half swing, ``2 R A + (pi/2) C omega0 A^2 = X w(A)``, per draw (nan where none).

    The impulse's width ``w(A)`` is the part of its windows a swing of amplitude ``A`` crosses, so
    the balance is found by bisection on ``A`` up to a full turn either side (2 pi rad).
    """
    def excess(a):
        return _impulse(windows, draws, a, w0) - 2 * r * a - math.pi / 2 * c * w0 * a ** 2

    lo, hi = np.full_like(w0, 1e-9), np.full_like(w0, 2 * math.pi)
    ok = (excess(lo) > 0) & (excess(hi) < 0)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        up = excess(mid) > 0
        lo, hi = np.where(up, mid, lo), np.where(up, hi, mid)
    return np.where(ok, 0.5 * (lo + hi), np.nan)


def _amplitude(draws, observed) -> float | None:
    """The amplitude the balance runs at: the median timegrapher reading, else the release angle (rad)."""
    if observed is not None and "curve" in observed.coords:
        readings = observed["reading"].values[observed["curve"].values == "amplitude"]
        if readings.size and str(observed["reading"].attrs.get("units", "")).startswith("deg"):
            return math.radians(float(np.median(readings)))
    a0 = draws.get("oscillator.theta0")
    return float(np.median(np.abs(a0))) if a0 is not None else None


def _load_words(name: str) -> str:
    found = re.search(r"\[load=([^\]]+)\]", name)
    return f" at load {found.group(1)}" if found else ""
