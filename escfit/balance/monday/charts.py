"""Monday's design charts, computed instead of read by eye.

In Monday's phase convention the balance is a linear system driven by forcing locked to
the phase of the motion, so one cycle maps the state ``s = (theta, theta')`` at phase 0 to
``lambda * s + b`` with ``lambda = exp(-pi*C/omega1)`` (the free motion over a full period
is a pure decay) and ``b`` the response to the cycle's forcing from rest.  Hence every unit
curve is geometric, ``theta_k = theta_ss + (theta_0 - theta_ss) * lambda**k`` with
``theta_ss = b_theta/(1 - lambda)``, and ``theta_ss`` is a linear combination of the forcing
magnitudes.  The coefficients of that combination are all the charts need:

- the *graph factor* ``K/K_R``: a Coulomb ``R`` acting all cycle versus the reference impulse
  of +-0.2786896 rad (Monday read 3.65; it is 3.636);
- the *conversion charts* (his Figs. 10 and 11): the Coulomb ``R`` equivalent to an unlock
  pulse ``X2`` or impulse ``X3`` over a given window;
- *K* of a scene: its steady state expressed as the reference impulse ``X3/omega0**2`` giving
  the same steady state (his sample problem: 0.2037, not the 0.214 read graphically);
- the *amplitude factor* versus ``C/omega0`` (his Fig. 12): the steady state for a fixed K
  relative to that at a reference ``C/omega0``.

All functions work in units of ``omega0 = 1`` (forcing as ``X/omega0**2``, damping as
``C/omega0``), which is how Monday's charts are drawn.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...core.errors import SceneError
from ...core.kernels import plain_python
from ..segment import propagate as _propagate_kernel

# A handful of closed-form pieces per call, from Python: the kernel as plain Python gives the
# same numbers without loading numba's compiled code (0.4 s of a report that needs no other).
propagate = plain_python(_propagate_kernel)

__all__ = [
    "REFERENCE_POWER_ANGLE", "Pulse", "cycle_offset", "steady_state", "graph_factor",
    "equivalent_r", "k_value", "unit_curve", "amplitude_factor",
]

REFERENCE_POWER_ANGLE = 0.2786896  # rad, the +-window of Monday's computed unit curves


@dataclass(frozen=True)
class Pulse:
    """A phase-locked forcing pulse, applied symmetrically on both half cycles.

    Attributes
    ----------
    lo, hi
        Phase offsets (rad) from the zero crossing at mid half cycle, ``lo < hi``.
    magnitude
        ``X/omega0**2`` (dimensionless in omega0 units); positive drives the motion,
        negative opposes it (unlock).  A Coulomb friction ``R`` is the pulse
        ``(-pi/2, pi/2, -R/omega0**2)``.
    """

    lo: float
    hi: float
    magnitude: float


def _lambda(c: float) -> float:
    return math.exp(-math.pi * c / math.sqrt(1.0 - c * c / 4.0))


def cycle_offset(c: float, pulses: Sequence[Pulse]) -> float:
    """theta after one cycle from rest at zero (``b_theta``), in omega0 units.

    The sign is that of theta for a release at positive theta (a driving pulse gives a
    positive offset).

    Parameters
    ----------
    c
        ``C/omega0`` (must be below 2).
    pulses
        The forcing; each pulse acts on both half cycles in the swing frame.
    """
    if not 0.0 <= c < 2.0:
        raise SceneError(f"c = C/omega0 must lie in [0, 2) (underdamped), got c = {c!r}")
    h = 0.5 * c
    w1 = math.sqrt(1.0 - h * h)
    cuts = sorted({0.0, math.pi, *[math.pi / 2 + p.lo for p in pulses], *[math.pi / 2 + p.hi for p in pulses]})
    x, v = 0.0, 0.0
    for _half in range(2):
        for a, b in zip(cuts, cuts[1:]):
            mid = 0.5 * (a + b) - math.pi / 2
            force = sum(p.magnitude for p in pulses if p.lo <= mid < p.hi)
            y, v = propagate(x - force, v, (b - a) / w1, h, 1.0)
            x = force + y
        x, v = -x, -v  # next half cycle in its own swing frame
    return -x  # swing frame of the first half cycle is x = -theta


def steady_state(c: float, pulses: Sequence[Pulse]) -> float:
    """Steady per-cycle amplitude ``theta_ss`` (units of the pulses' magnitudes, rad)."""
    return cycle_offset(c, pulses) / (1.0 - _lambda(c))


def _reference(c: float, alpha: float = REFERENCE_POWER_ANGLE) -> float:
    return steady_state(c, [Pulse(-alpha, alpha, 1.0)])


# Ratios of steady states are ratios of one-cycle offsets (the 1/(1 - lambda) cancels), which
# keeps them finite at C = 0.
def _offset_per_r(c: float) -> float:
    return -cycle_offset(c, [Pulse(-math.pi / 2, math.pi / 2, -1.0)])


def graph_factor(c: float, alpha: float = REFERENCE_POWER_ANGLE) -> float:
    """K/K_R: steady-state effect of a unit Coulomb R over that of a unit reference impulse."""
    return _offset_per_r(c) / cycle_offset(c, [Pulse(-alpha, alpha, 1.0)])


def equivalent_r(c: float, x_over_w0sq: float, lo: float, hi: float) -> float:
    """Coulomb ``R/omega0**2`` with the same steady-state effect as a pulse (Figs. 10, 11).

    ``x_over_w0sq`` is the pulse's size; the sign of the answer is that of the effect
    (an unlock of size 0.549 over (-0.6, -0.3) is equivalent to R/omega0**2 = 0.074).
    """
    return x_over_w0sq * cycle_offset(c, [Pulse(lo, hi, 1.0)]) / _offset_per_r(c)


def k_value(c: float, pulses: Sequence[Pulse], alpha: float = REFERENCE_POWER_ANGLE) -> float:
    """Monday's combined K: the reference impulse X3/omega0**2 giving the same steady state."""
    return cycle_offset(c, pulses) / cycle_offset(c, [Pulse(-alpha, alpha, 1.0)])


def unit_curve(c: float, k: float, theta0: float = 6.28, cycles: int = 40,
               alpha: float = REFERENCE_POWER_ANGLE) -> np.ndarray:
    """Computed unit curve: per-cycle amplitude for cycles 0..cycles (rad)."""
    lam = _lambda(c)
    ss = k * _reference(c, alpha)
    return ss + (theta0 - ss) * lam ** np.arange(cycles + 1)


def amplitude_factor(c: float, reference_c: float = 0.05, alpha: float = REFERENCE_POWER_ANGLE) -> float:
    """Steady amplitude at ``C/omega0 = c`` relative to ``reference_c`` for the same K (Fig. 12)."""
    return _reference(c, alpha) / _reference(reference_c, alpha)
