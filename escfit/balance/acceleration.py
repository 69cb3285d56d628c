"""The swing-frame acceleration every integrating solver integrates, built from the record.

Inside a region of a half swing (:mod:`escfit.balance.regions`) with constants ``(w2, xc)``
the balance's angular acceleration in the swing frame ``x = s*theta`` (``v = s*theta'``) is::

    x'' = -C v - w2 (x - xc)          + smooth terms       (spring)
    x'' = -C v - w2 (sin x - xc)      + smooth terms       (pendulum, w2 = omega0**2)

The piecewise-linear part -- viscous damping, the hairspring piece, sliding Coulomb friction and
the escapement windows -- comes from the region; the smooth terms are the torques with no closed
form, each defined by its effect module (its ``torque(x, v, k)``: acceleration and its partial
derivatives by ``x`` and ``v``) and added up in :func:`smooth_terms`.  A smooth effect absent from
a scene has its record slots at their defaults, which make its term zero.  dop853, rk4 and the
scipy adapter call only :func:`acceleration` and :func:`jerk`: they carry no code of any effect.
"""

from __future__ import annotations

import math

from ..core.kernels import kernel
from .effects import drag, stiffening

__all__ = ["acceleration", "jerk", "smooth_terms"]


@kernel(inline="always")
def smooth_terms(x, v, k):
    """Swing-frame acceleration of every smooth effect (rad/s^2) and its derivatives by x and v."""
    a, a_x, a_v = stiffening.torque(x, v, k)
    d, d_x, d_v = drag.torque(x, v, k)
    return a + d, a_x + d_x, a_v + d_v


@kernel(inline="always")
def acceleration(x, v, w2, xc, k):
    """Swing-frame angular acceleration (rad/s^2) at angle ``x`` (rad) and velocity ``v`` (rad/s).

    Parameters
    ----------
    x, v : float
        State in the swing frame of the current half swing.
    w2, xc : float
        The region's stiffness (1/s^2) and centre (rad).
    k : record
        The coefficient record (:mod:`escfit.balance.kernel_records`).
    """
    if k.pendulum:
        a = -k.c * v - w2 * (math.sin(x) - xc)
    else:
        a = -k.c * v - w2 * (x - xc)
    if k.smooth:  # skipped, not computed as zeros, in scenes without a smooth torque
        smooth, _, _ = smooth_terms(x, v, k)
        a += smooth
    return a


@kernel(inline="always")
def jerk(x, v, a, w2, k):
    """Time derivative (rad/s^3) of :func:`acceleration` along the motion, at acceleration ``a``."""
    stiffness = w2 * (math.cos(x) if k.pendulum else 1.0)
    if not k.smooth:
        return -k.c * a - stiffness * v
    _, a_x, a_v = smooth_terms(x, v, k)
    return (a_v - k.c) * a + (a_x - stiffness) * v
