"""The driver's angular acceleration, with the pin-slot friction solved exactly.

The friction torque ``I_f*|C*w**2 + D*alpha|`` depends on the acceleration it helps to
determine, so the equation of motion

    A*alpha + B*w**2 + |C*w**2 + D*alpha| = E

is implicit.  Write ``f = C*w**2 + D*alpha`` (the friction argument; its sign ``S`` is the sign
of the normal force times ``sin(x)``).  Eliminating ``alpha`` gives ``A*f + D*|f| = Q`` with

    Q = D*E + (A*C - B*D)*w**2,

and ``Q/A`` is just the friction argument evaluated with the frictionless acceleration.
When ``A > |D|`` the left side is strictly increasing in ``f``, so exactly one sign is
consistent, ``S = sign(Q)``: the normal force has the sign it would have without friction.
Then

    alpha = (E - (B + S*C)*w**2) / (A + S*D).

When ``|D| >= A`` (friction steep enough to wedge the pin) the left side is a V and either
both signs are consistent (``sign(Q) = sign(D)``: Painleve's non-uniqueness) or neither is
(``sign(Q) = -sign(D)``: the mechanism jams).  In the first case the root with positive
effective inertia ``A + S*D`` is the one continuous with the motion so far and is taken; the
state is flagged :data:`AMBIGUOUS`.  In the second the state is :data:`LOCKED` and no
acceleration exists.  Both are reported by the solvers, never hidden.

The friction is solved at every evaluation, not lagged by one output step as in Meyer's
MIMIC program (its ``OLD2DX`` card).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.kernels import kernel
from .geometry import coefficients

__all__ = ["OK", "AMBIGUOUS", "LOCKED", "acceleration", "acceleration_array", "switch_function", "wedge_margin", "friction_argument"]

OK = 0
AMBIGUOUS = 1
LOCKED = 2


@kernel
def acceleration(x: float, w: float, a: float, rho: float, mu: float, e: float) -> tuple[float, float, int]:
    """Driver acceleration at local angle ``x`` and speed ``w >= 0``.

    Parameters
    ----------
    x
        Local angle of the engaged pin from the line of centres, rad.
    w
        Driver speed, rad/s (forward motion; the friction law assumes ``w >= 0``).
    a
        ``1/sin(pi/n)``.
    rho
        Driver over follower inertia ``I_d/I_f``.
    mu
        Pin-slot friction coefficient.
    e
        Driving torque over follower inertia ``K/I_f``, rad/s^2.

    Returns
    -------
    alpha : float
        Driver angular acceleration, rad/s^2 (0.0 when locked).
    inertia : float
        Effective inertia ``(A + S*D)`` of the chosen branch per unit ``I_f`` (``<= 0``
        when locked).
    code : int
        :data:`OK`, :data:`AMBIGUOUS` or :data:`LOCKED`.
    """
    big_a, big_b, big_c, big_d = coefficients(x, a, rho, mu)
    w2 = w * w
    q = big_d * e + (big_a * big_c - big_b * big_d) * w2
    s = 1.0 if q >= 0.0 else -1.0
    den = big_a + s * big_d
    if den <= 0.0:
        return 0.0, den, LOCKED
    code = AMBIGUOUS if big_a - s * big_d < 0.0 else OK
    return (e - (big_b + s * big_c) * w2) / den, den, code


@kernel
def acceleration_array(x: np.ndarray, w: np.ndarray, a: float, rho: float, mu: float, e: float) -> np.ndarray:
    """:func:`acceleration` over arrays of states (locked states give 0.0), rad/s^2."""
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        out[i] = acceleration(x[i], max(w[i], 0.0), a, rho, mu, e)[0]
    return out


@kernel
def switch_function(x: float, w: float, a: float, rho: float, mu: float, e: float) -> float:
    """``Q = D*E + (A*C - B*D)*w**2``: the friction sign is ``sign(Q)``; ``alpha`` has a kink where ``Q = 0``."""
    big_a, big_b, big_c, big_d = coefficients(x, a, rho, mu)
    return big_d * e + (big_a * big_c - big_b * big_d) * w * w


@kernel
def wedge_margin(x: float, a: float, rho: float, mu: float) -> float:
    """``A - |D|``: negative where friction can wedge the pin (both or neither sign consistent)."""
    big_a, _, _, big_d = coefficients(x, a, rho, mu)
    return big_a - math.fabs(big_d)


@kernel
def friction_argument(x: float, w: float, alpha: float, a: float, rho: float, mu: float) -> float:
    """``C*w**2 + D*alpha``: the pin-slot friction torque over ``I_f`` with its sign, rad/s^2."""
    big_a, big_b, big_c, big_d = coefficients(x, a, rho, mu)
    return big_c * w * w + big_d * alpha


def initial_acceleration(x: float, a: float, rho: float, mu: float, e: float) -> float:
    """Acceleration from rest, ``E/(A + |D|)`` (Meyer's Appendix D), rad/s^2."""
    big_a, _, _, big_d = coefficients(x, a, rho, mu)
    return e / (big_a + math.fabs(big_d))
