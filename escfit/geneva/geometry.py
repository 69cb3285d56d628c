"""Slot-and-pin geometry of the Geneva escapement and the coefficients of its motion.

A multi-pin driver turns a slotted follower; one pin is always in a slot.  With the pin
circle radius ``r`` and the centre distance ``c``, entry and exit are tangent to the slot
centre line (no impact) only when ``c = a*r`` with ``a = 1/sin(pi/n)`` and the number of
pins is ``m = 2n/(n - 2)``: 6 pins for 3 slots, 4 for 4, 3 for 6.

Angles and signs
----------------
``x``
    Driver angle of the engaged pin measured from the line of centres, rad, positive in the
    sense the spring drives the driver.  A pin engages on ``-theta_e <= x <= theta_e`` with
    ``theta_e = pi/m``; the follower is at rest at both ends.
``phi``
    Follower angle of the engaged slot from the line of centres, rad, positive in the sense
    the follower is driven (the follower turns opposite to the driver, like a gear).
    ``tan(phi) = sin(x)/(a - cos(x))``, and ``-pi/n <= phi <= pi/n`` over an engagement.

The radius ``r`` cancels from every equation: only ``a`` (that is, ``n``) matters.

Coefficients
------------
Dividing Lagrange's equation by the follower inertia ``I_f`` gives, for forward motion
(driver speed ``w >= 0``, acceleration ``alpha``),

    A*alpha + B*w**2 + |C*w**2 + D*alpha| = E

with (``L = 1 + a**2 - 2*a*cos(x)``, ``h = a*cos(x) - 1``, ``rho = I_d/I_f``)

    A = rho + (h/L)**2                      effective inertia / I_f
    B = a*(1 - a**2)*sin(x)*h / L**3        = g*dg/dx (velocity-squared coupling)
    C = mu*a**2*(1 - a**2)*sin(x)**2 / L**3 pin-slot friction, velocity part
    D = mu*a*sin(x)*h / L**2                pin-slot friction, acceleration part
    E = K / I_f

where ``g = h/L = dphi/dx`` is the follower-to-driver speed ratio.  The derivation is in
``docs/geneva.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.kernels import kernel
from ..core.errors import SceneError

__all__ = ["Geometry", "COMPAT_MODES", "coefficients", "speed_ratio", "speed_ratio_slope", "follower_angle"]

COMPAT_MODES = ("none", "meyer1973")
ALLOWED_SLOTS = (3, 4, 6)


@dataclass(frozen=True)
class Geometry:
    """Structure of one Geneva escapement (no parameter values).

    Parameters
    ----------
    slots
        Number of follower slots ``n`` (3, 4 or 6).
    compat
        ``"none"``: each pin engages over ``2*pi/m`` of driver rotation, as the geometry
        requires.  ``"meyer1973"``: every mechanism is given a 90 deg engagement starting at
        ``-pi/m``, reproducing the ``X = MOD(THETA, 1.5708) + X0`` card of Meyer's (1973)
        MIMIC program, which his published three- and six-pin tables were computed with.
    """

    slots: int
    compat: str = "none"

    def __post_init__(self) -> None:
        if isinstance(self.slots, bool) or self.slots not in ALLOWED_SLOTS:
            raise SceneError(f"slots must be one of {ALLOWED_SLOTS}, got {self.slots!r}", "geneva geometry")
        if self.compat not in COMPAT_MODES:
            raise SceneError(f"compat must be one of {COMPAT_MODES}, got {self.compat!r}", "geneva geometry")

    @property
    def pins(self) -> int:
        """Number of driver pins ``m = 2n/(n - 2)``."""
        return 2 * self.slots // (self.slots - 2)

    @property
    def a(self) -> float:
        """Centre distance over pin-circle radius, ``1/sin(pi/n)``."""
        return 1.0 / math.sin(math.pi / self.slots)

    @property
    def half_engagement(self) -> float:
        """Driver half-angle of a geometric engagement ``theta_e = pi/m``, rad."""
        return math.pi / self.pins

    @property
    def follower_half_angle(self) -> float:
        """Follower half-angle of an engagement ``pi/n``, rad."""
        return math.pi / self.slots

    @property
    def x_start(self) -> float:
        """Local driver angle at which a pin enters its slot, rad (``-pi/m``)."""
        return -self.half_engagement

    @property
    def span(self) -> float:
        """Driver rotation per engagement, rad (``2*pi/m``; ``pi/2`` under meyer1973)."""
        return math.pi / 2 if self.compat == "meyer1973" else 2 * self.half_engagement

    @property
    def x_end(self) -> float:
        """Local driver angle at which the pin hands over to the next one, rad."""
        return self.x_start + self.span

    @property
    def follower_step(self) -> float:
        """Follower rotation per engagement, rad (``2*pi/n``)."""
        return 2 * math.pi / self.slots

    def local_angle(self, theta: np.ndarray | float) -> np.ndarray | float:
        """Local angle ``x`` of the engaged pin for a driver angle ``theta`` from first entry."""
        return np.mod(theta, self.span) + self.x_start

    def engagement_index(self, theta: np.ndarray | float) -> np.ndarray | int:
        """Zero-based index of the engagement a driver angle ``theta`` lies in."""
        if isinstance(theta, np.ndarray):
            return np.floor_divide(theta, self.span).astype(int)
        return int(theta // self.span)


@kernel
def coefficients(x: float, a: float, rho: float, mu: float) -> tuple[float, float, float, float]:
    """Coefficients ``(A, B, C, D)`` of the equation of motion at local angle ``x``.

    See the module docstring; all are per unit follower inertia (dimensionless, rad^-1).
    """
    s = math.sin(x)
    c = math.cos(x)
    h = a * c - 1.0
    big_l = 1.0 + a * a - 2.0 * a * c
    g = h / big_l
    l3 = big_l * big_l * big_l
    k = a * (1.0 - a * a) * s / l3
    return rho + g * g, k * h, mu * a * s * k, mu * a * s * h / (big_l * big_l)


def speed_ratio(x: np.ndarray | float, a: float) -> np.ndarray | float:
    """Follower over driver speed ``g = dphi/dx = (a cos x - 1)/(1 + a^2 - 2 a cos x)``."""
    c = np.cos(x)
    return (a * c - 1.0) / (1.0 + a * a - 2.0 * a * c)


def speed_ratio_slope(x: np.ndarray | float, a: float) -> np.ndarray | float:
    """``dg/dx = a (1 - a^2) sin x / (1 + a^2 - 2 a cos x)^2``, rad^-1."""
    return a * (1.0 - a * a) * np.sin(x) / (1.0 + a * a - 2.0 * a * np.cos(x)) ** 2


def follower_angle(x: np.ndarray | float, a: float) -> np.ndarray | float:
    """Follower slot angle ``phi = atan2(sin x, a - cos x)``, rad (0 on the line of centres)."""
    return np.arctan2(np.sin(x), a - np.cos(x))
