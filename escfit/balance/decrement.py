"""The decrement per half swing against the amplitude: which damping law a free decay shows.

Over one half swing of a lightly damped oscillator the amplitude falls by

================  ==========================  =======================================
law               torque per inertia          decrement per half swing (linear spring)
================  ==========================  =======================================
Coulomb (dry)     ``-R sgn(theta')``          ``2 R / omega0**2``, constant
viscous           ``-C theta'``               ``pi C A / (2 omega0)``, proportional to A
quadratic drag    ``-D |theta'| theta'``      ``4 D A**2 / 3``, proportional to A**2
================  ==========================  =======================================

Derivation (first order in the damping): along the undamped half swing ``theta = A cos(omega0
t)``, ``0 <= t <= pi/omega0``, each torque does work ``W`` per unit inertia, and the energy
``E = omega0**2 A**2 / 2`` changes by ``dE/dA * dA = omega0**2 A dA``, so ``dA = W /
(omega0**2 A)``.  Coulomb: ``W = R * 2A``.  Viscous: ``W = C * int theta'**2 dt = C pi
omega0 A**2 / 2``.  Drag: ``W = D * int |theta'|**3 dt = D omega0**3 A**3 * 4/(3 omega0)``.
Evaluated at the mean amplitude of the half swing, the neglected terms nearly cancel: on a
linear spring viscous damping and Coulomb friction add *exactly*, ``2 tanh(pi C/(4 omega1)) A
+ 2R/omega0**2`` (``omega1 = sqrt(omega0**2 - C**2/4)``; this is what :func:`law_parts` draws,
``pi C A/(2 omega0)`` to first order), and drag is off by about ``0.3 (D A)**2`` relative.

A gravity pendulum (``omega0**2 sin(theta)``) uses the same energy balance with the exact
undamped swing, ``E = omega0**2 (1 - cos A)``, ``dE/dA = omega0**2 sin A`` and ``theta'**2 =
2 omega0**2 (cos theta - cos A)``: Coulomb ``2 R A / (omega0**2 sin A)``, viscous ``8 C [E(m) -
(1 - m) K(m)] / (omega0 sin A)`` with ``m = sin(A/2)**2`` (complete elliptic integrals), drag
``4 D (sin A - A cos A) / sin A``; each reduces to the table at small A.

A **stiffening spring** (``[effects.stiffening] k3``: restoring ``omega0**2 (theta + k3
theta**3)``, added to a spring's or a pendulum's) dissipates nothing, so it has no part of its
own; it changes every law's part through the same energy balance.  The energy at amplitude A
gains ``omega0**2 k3 A**4 / 4``, so ``dE/dA`` gains ``omega0**2 k3 A**3``, and the speed along
the swing grows, ``theta'**2 = 2 (V(A) - V(theta))``.  On a linear spring with a cubic term:
Coulomb ``2 R / (omega0**2 (1 + k3 A**2))`` (exact at the half swing's mean amplitude to second
order: the energy equation of a constant friction torque gives ``A_n - A_{n+1} = 2R / (omega0**2
(1 + k3 (A_n**2 + A_{n+1}**2)/2))``), drag ``D (4 A**2/3 + 4 k3 A**4/5) / (1 + k3 A**2)``
(``int (A**4 - theta**4) dtheta = 8 A**5/5``), viscous ``C int |theta'| dtheta / (dE/dA)``
by Gauss-Legendre quadrature (an elliptic integral; ``theta = A sin(phi)`` makes the integrand
smooth).  A stiffer spring stores more energy at the same amplitude, so each loss takes less
amplitude: at ``k3 A**2 = 0.3`` Coulomb friction's decrement is 23 % smaller than on the linear
spring, viscous damping's 16 % and drag's 9 % smaller.

An escapement window of constant torque per inertia ``X`` (impulse drives, unlocking opposes)
over the swing-frame angles ``[lo, hi)`` does work ``+-X |[lo, hi) & [-A, A]|``, a gain
``-W/(omega0**2 A)`` that falls like 1/A: the shape that makes an escapement's amplitude
settle.  In Monday's phase convention a window at phase offsets ``[lo, hi)`` spans ``A (sin hi
- sin lo)`` of the swing, so its part is a constant, about ``-+X (sin hi - sin lo)/omega0**2``,
which no decay can tell from Coulomb friction's constant; the motion is then linear with
phase-locked forcing, and :func:`law_parts` gives their joint constant exactly from the
one-cycle map (:func:`escfit.balance.monday.charts.cycle_offset`).

Measured decrements (:func:`from_readings`, :func:`from_turns`, :func:`binned`) come from amplitudes
read at turning points: :mod:`escfit.analysis.decrements`, re-exported here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..analysis.decrements import Decrements, binned, from_readings, from_turns  # noqa: F401 - re-exported

__all__ = ["Decrements", "Window", "Swing", "swing_of", "from_readings", "from_turns", "law_parts", "losses",
           "loss_symbols", "binned", "LAWS"]

#: parts that belong to no single dissipative effect: key -> (name, shape)
OTHER_PARTS = {"escapement": ("escapement (impulse minus unlocking)", "falls like 1/A"),
               "constant": ("Coulomb friction + escapement", "constant")}


def losses() -> dict:
    """The registered effects that take a part of the decrement (they declare ``LOSS``), in the
    registry's order: key -> effect class."""
    from .effects import EFFECTS

    return {key: cls for key, cls in EFFECTS.items() if getattr(cls, "LOSS", None) is not None}


def loss_symbols(effects) -> tuple[tuple[str, str], ...]:
    """``(parameter, symbol)`` of the dissipative effects among ``effects`` (keys such as
    ``"viscous"``), in the registry's order: ``(("viscous.C", "C"), ("coulomb.R", "R"))``."""
    return tuple((cls.LOSS.parameter, cls.LOSS.symbol) for key, cls in losses().items() if key in effects)


#: the parts drawn, in order: key -> (name, shape); every dissipative effect's, then the others
LAWS = {**{key: (cls.LOSS.name, cls.LOSS.shape) for key, cls in losses().items()}, **OTHER_PARTS}


@dataclass(frozen=True)
class Window:
    """An escapement window for :func:`law_parts`: ``sign`` +1 impulse / -1 unlocking, ``x`` its
    torque per inertia (rad/s^2), ``lo``, ``hi`` its limits (rad; phase offsets with phase
    switching) and ``share`` the fraction of half swings it acts on (1, or 1/2 for one direction)."""

    sign: float
    x: float
    lo: float
    hi: float
    share: float = 1.0


@dataclass(frozen=True)
class Swing:
    """The undamped half swings of the given amplitudes, over which each loss does its work.

    A loss whose torque per inertia does work ``W`` along the swing takes ``W / gain`` off it
    (first order in the damping; see the module docstring).

    Attributes
    ----------
    amplitude
        Amplitudes ``A`` (rad, or m on a linear oscillator).
    omega0
        Natural frequency (rad/s).
    gain
        ``dE/dA``, the energy per inertia's slope at ``A``.
    speed, speed2
        ``int |theta'| dtheta`` and ``int theta'**2 dtheta`` over the half swing (the works of
        torques ``theta'**0 sgn(theta')`` ... per unit coefficient: viscous, drag).
    linear_spring
        Whether the restoring torque is ``omega0**2 theta`` (no pendulum, no stiffening): viscous
        damping then has its exact form (:meth:`viscous`).
    """

    amplitude: np.ndarray
    omega0: float
    gain: np.ndarray
    speed: np.ndarray
    speed2: np.ndarray
    linear_spring: bool

    @property
    def path(self) -> np.ndarray:
        """``int dtheta = 2 A``: the work of a constant torque (Coulomb friction) per unit."""
        return 2.0 * self.amplitude

    def viscous(self, C: float) -> np.ndarray:
        """Viscous damping's part: exact on a linear spring (:func:`_viscous_spring`), else ``C speed / gain``."""
        if self.linear_spring:
            return _viscous_spring(self.amplitude, C, self.omega0)
        return C * self.speed / self.gain


def swing_of(amplitude, omega0, *, k3=0.0, restoring: str = "spring") -> Swing:
    """The undamped half swings of amplitudes ``amplitude`` (rad, or m), for the losses' parts.

    ``omega0`` (rad/s) and ``k3`` (1/rad^2, ``[effects.stiffening]``) may be numbers or arrays
    of ``amplitude``'s shape (one value per posterior draw); ``restoring`` is ``"spring"`` or
    ``"pendulum"``.  Each dissipative effect's ``decrement(value, swing)`` then gives its part.
    """
    a = np.asarray(amplitude, float)
    return _swing(a, np.asarray(omega0, float) if np.ndim(omega0) else float(omega0),
                  np.asarray(k3, float) if np.ndim(k3) else float(k3), restoring)


def _swing(a: np.ndarray, omega0, k3, restoring: str) -> Swing:
    w2 = omega0 * omega0
    if np.any(k3):
        gain = w2 * ((np.sin(a) if restoring == "pendulum" else a) + k3 * a**3)
        swing_v, swing_v2 = _stiffened_swing(a, omega0, k3, restoring)
        return Swing(a, omega0, gain, swing_v, swing_v2, False)
    if restoring == "pendulum":
        from scipy.special import ellipe, ellipk

        m = np.sin(a / 2) ** 2
        swing_v = 8.0 * omega0 * (ellipe(m) - (1.0 - m) * ellipk(m))  # int |theta'| dtheta over a half swing
        swing_v2 = 4.0 * w2 * (np.sin(a) - a * np.cos(a))  # int theta'^2 dtheta
        return Swing(a, omega0, w2 * np.sin(a), swing_v, swing_v2, False)
    return Swing(a, omega0, w2 * a, math.pi / 2 * omega0 * a * a, 4.0 / 3.0 * w2 * a**3, True)


def law_parts(amplitude, *, omega0: float, k3: float = 0.0, windows: tuple[Window, ...] = (),
              restoring: str = "spring", switching: str = "angle", **coefficients: float) -> dict:
    """Each law's decrement per half swing at ``amplitude`` (rad), first order in the damping.

    Parameters
    ----------
    amplitude
        Amplitudes (rad, > 0).
    omega0
        Natural frequency (rad/s).
    k3
        Cubic stiffening of the restoring torque (1/rad^2, ``[effects.stiffening]``): no part of
        its own, it changes the others (see the module docstring).
    windows
        Escapement windows.
    restoring
        ``"spring"`` (``omega0**2 theta``) or ``"pendulum"`` (``omega0**2 sin theta``).
    switching
        ``"angle"`` or ``"phase"`` (Monday's convention: Coulomb friction and the windows then
        give one constant, returned as ``"constant"``).
    **coefficients
        Each dissipative effect's coefficient by its symbol (:func:`losses`: ``C`` viscous, 1/s;
        ``R`` Coulomb, rad/s^2; ``D`` quadratic drag, 1/rad; any effect registered with a
        ``LOSS``); absent ones are zero.

    Returns
    -------
    dict
        Law key (see :data:`LAWS`) -> decrement array (rad per half swing), only for the laws
        with a non-zero coefficient.
    """
    parts = losses()
    unknown = sorted(set(coefficients) - {cls.LOSS.symbol for cls in parts.values()})
    if unknown:
        raise TypeError(f"law_parts: no dissipative effect has the symbol(s) {unknown}")
    a = np.asarray(amplitude, float)
    if restoring not in ("spring", "pendulum"):
        raise ValueError(f"restoring must be 'spring' or 'pendulum', got {restoring!r}")
    if k3 and switching == "phase":
        raise ValueError("a stiffening spring has no phase-convention decrement (its half period varies)")
    swing = _swing(a, omega0, k3, restoring)
    out = {}
    for key, cls in parts.items():
        value = coefficients.get(cls.LOSS.symbol, 0.0)
        if value and not (switching == "phase" and cls.LOSS.phase_constant):
            out[key] = cls.decrement(value, swing)
    if switching == "phase":
        R = coefficients.get("R", 0.0)
        if R or windows:
            out["constant"] = np.full(a.shape, _phase_constant(omega0, coefficients.get("C", 0.0), R, windows))
        return _ordered(out)
    if windows:
        work = sum(w.sign * w.x * w.share * np.clip(np.minimum(w.hi, a) - np.maximum(w.lo, -a), 0.0, None)
                   for w in windows)
        out["escapement"] = -work / swing.gain
    return _ordered(out)


#: Gauss-Legendre nodes and weights on [-1, 1] for the stiffened swing's integrals (phi = pi/2 * node)
_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(48)


def _stiffened_swing(a: np.ndarray, omega0: float, k3: float, restoring: str) -> tuple[np.ndarray, np.ndarray]:
    """``int |theta'| dtheta`` and ``int theta'**2 dtheta`` over an undamped half swing of
    amplitude ``a`` with the cubic term (rad/s times rad, rad^2/s^2 times rad).

    With ``theta = A sin(phi)``, ``theta'**2 = 2 q(theta) (A**2 - theta**2)`` where ``q = (V(A) -
    V(theta))/(A**2 - theta**2)`` is smooth and positive: ``omega0**2 (1/2 + k3 (A**2 +
    theta**2)/4)`` on a spring, ``omega0**2 (sinc(u) sinc(w)/2 + k3 (A**2 + theta**2)/4)`` on a
    pendulum (``u, w = (A +- theta)/2``, ``sinc(x) = sin(x)/x``: no cancellation at the turns).
    """
    w2 = omega0 * omega0
    phi = 0.5 * math.pi * _NODES
    wts = 0.5 * math.pi * _WEIGHTS
    amp = a[..., None]
    w2n, k3n = np.asarray(w2, float)[..., None], np.asarray(k3, float)[..., None]  # per draw, or numbers
    th = amp * np.sin(phi)
    if restoring == "pendulum":
        u, w = 0.5 * (amp + th), 0.5 * (amp - th)
        base = 0.5 * np.sinc(u / math.pi) * np.sinc(w / math.pi)
    else:
        base = 0.5
    q = w2n * (base + 0.25 * k3n * (amp**2 + th**2))
    cos2 = np.cos(phi) ** 2
    swing_v = a**2 * np.sum(wts * np.sqrt(2.0 * q) * cos2, axis=-1)
    if restoring == "pendulum":  # closed form: 4 w2 (sin A - A cos A) + 4 w2 k3 A**5 / 5
        swing_v2 = 4.0 * w2 * (np.sin(a) - a * np.cos(a)) + 0.8 * w2 * k3 * a**5
    else:
        swing_v2 = w2 * (4.0 / 3.0 * a**3 + 0.8 * k3 * a**5)
    return swing_v, swing_v2


def _viscous_spring(a: np.ndarray, C, omega0) -> np.ndarray:
    """Viscous part on a linear spring at the mean amplitude of the half swing, exactly.

    A half swing multiplies the amplitude about the (friction-shifted) centre by ``l =
    exp(-pi C/(2 omega1))``, so at the half swing's mean amplitude the decrement is ``2 (1 - l)/(1
    + l) A = 2 tanh(pi C/(4 omega1)) A`` plus Coulomb friction's ``2R/omega0**2``: the two add
    exactly.  To first order this is ``pi C A/(2 omega0)``.
    """
    h = 0.5 * np.asarray(C, float)
    w1sq = np.asarray(omega0, float) ** 2 - h * h
    with np.errstate(divide="ignore", invalid="ignore"):
        part = 2.0 * np.tanh(math.pi * C / (4.0 * np.sqrt(np.maximum(w1sq, 0.0)))) * a
    return np.where(w1sq > 0.0, part, np.nan)  # beyond critical damping: not a swing, no decrement


def _phase_constant(omega0: float, C: float, R: float, windows) -> float:
    """Monday's phase convention: the constant of the decrement at mean amplitude, exactly.

    The half-cycle map is affine, ``A' = l A + b_h``, so at the mean amplitude the decrement is
    ``2 tanh(...) A - 2 b_h/(1 + l)``; the one-cycle offset ``b = b_h (1 + l)`` of Coulomb
    friction and the windows together comes from :func:`escfit.balance.monday.charts.cycle_offset`.
    """
    from .monday.charts import Pulse, cycle_offset

    c = C / omega0
    pulses = [Pulse(w.lo, w.hi, w.sign * w.x * w.share / omega0**2) for w in windows]
    if R:
        pulses.append(Pulse(-math.pi / 2, math.pi / 2, -R / omega0**2))
    lam_half = math.exp(-math.pi * c / (2.0 * math.sqrt(1.0 - c * c / 4.0)))
    return -2.0 * cycle_offset(c, pulses) / (1.0 + lam_half) ** 2


def _ordered(parts: dict) -> dict:
    return {k: parts[k] for k in LAWS if k in parts}
