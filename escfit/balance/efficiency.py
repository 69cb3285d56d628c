"""Escapement efficiency from force directions, drop and a work integral.

The clock-repair text (seed 004) rates an escapement by following the escape-wheel tooth's
force through two changes of direction:

* ``Fe``: the force of the tooth, along the direction the tooth moves;
* ``Fi``: the part of it the impulse face can take, along the face's normal.  A smooth face
  carries no tangential force, so ``Fi = Fe * cos(a)`` with ``a`` the angle from ``Fe`` to
  the normal (the text's angle FeFi);
* ``Fp``: the part of ``Fi`` that turns the pallet, along the direction the pallet's face
  moves.  With ``b`` the angle from ``Fe`` to that direction (FeFp, 90 deg for a Graham
  pallet on a square layout), ``Fp = Fi * cos(b - a)``.

So the *transmitted fraction* is ``cos(a) * cos(b - a)``.  It is largest when ``Fi`` lies
half way between ``Fe`` and ``Fp`` (``a = b/2``), where it equals ``cos(b/2)**2 =
(1 + cos b) / 2``: 50 % for ``b = 90 deg``.  This is a design index in the text's sense,
not an energy efficiency: a smooth contact loses no work, it only trades force for travel.

Friction (left out by the text).  While the tooth slides along the face, dry friction adds
a tangential force ``mu * N`` on the pallet, in the direction the tooth slides relative to
the face.  For ``0 < a < b`` the tooth slides towards the ``Fe`` side, so friction pulls the
pallet *against* its motion: the resultant on the pallet is the normal force turned by the
friction angle ``rho = atan(mu)`` away from ``Fp``, and

    Fp / Fe = cos(a) * cos(b - a + rho) / cos(rho).

The optimum moves to ``a = (b + rho) / 2`` and the best fraction becomes
``(1 + cos(b + rho)) / (2 cos rho)``.  Where ``b - a + rho >= 90 deg`` the face cannot
drive the pallet at all (it locks) and the fraction is 0.  Separately,
:func:`contact_work_efficiency` gives the true energy efficiency of the sliding contact
(input work of the tooth versus work received by the pallet), which is 1 without friction.

Angles are in radians throughout; fractions are dimensionless.
"""

from __future__ import annotations

import math
from typing import Callable, Literal

import numpy as np
from scipy import integrate

from ..core.errors import SceneError, SolverError

__all__ = [
    "friction_angle",
    "impulse_fraction",
    "transmitted_fraction",
    "best_impulse_angle",
    "max_fraction",
    "drop_work_index",
    "work_index",
    "brocot_fraction",
    "brocot_work_index",
    "contact_work_efficiency",
]


def friction_angle(mu: float) -> float:
    """Friction angle ``atan(mu)`` in rad (``mu >= 0``)."""
    if not mu >= 0:
        raise SceneError(f"friction coefficient mu must be zero or positive, got mu = {mu!r}")
    return math.atan(mu)


def impulse_fraction(fe_fi):
    """``Fi / Fe = cos(a)``: the part of the tooth force along the face normal.

    Parameters
    ----------
    fe_fi
        Angle ``a`` from the tooth force ``Fe`` to the face normal ``Fi``, rad, in
        ``[0, pi/2]``.
    """
    return np.cos(np.asarray(fe_fi, dtype=float))


def transmitted_fraction(fe_fi, fe_fp, mu: float = 0.0):
    """Fraction ``Fp / Fe`` of the tooth force that reaches the pallet.

    Parameters
    ----------
    fe_fi
        Angle ``a`` from ``Fe`` to the impulse-face normal ``Fi``, rad.
    fe_fp
        Angle ``b`` from ``Fe`` to the pallet's direction of motion ``Fp``, rad (``a <= b``
        so that ``Fi`` lies between ``Fe`` and ``Fp``).
    mu
        Sliding friction coefficient on the impulse face (0: the text's smooth face).

    Returns
    -------
    float or ndarray
        ``cos(a) * cos(b - a + rho) / cos(rho)`` with ``rho = atan(mu)``, clipped at 0
        where friction locks the face.
    """
    a = np.asarray(fe_fi, dtype=float)
    b = np.asarray(fe_fp, dtype=float)
    rho = friction_angle(mu)
    out = np.cos(a) * np.maximum(np.cos(b - a + rho), 0.0) / math.cos(rho)
    out = np.where(b - a + rho >= math.pi / 2, 0.0, out)
    return out if out.ndim else float(out)


def best_impulse_angle(fe_fp: float, mu: float = 0.0) -> float:
    """Angle FeFi (rad) that maximises :func:`transmitted_fraction`: ``(b + rho) / 2``."""
    return 0.5 * (fe_fp + friction_angle(mu))


def max_fraction(fe_fp: float, mu: float = 0.0) -> float:
    """Largest transmitted fraction for a given FeFp: ``(1 + cos(b + rho)) / (2 cos rho)``."""
    rho = friction_angle(mu)
    return (1.0 + math.cos(fe_fp + rho)) / (2.0 * math.cos(rho))


def drop_work_index(fraction: float, impulse_angle: float, drop_angle: float) -> float:
    """Work index when part of the wheel's travel is lost to drop.

    With a fraction that is constant along the impulse (a straight Graham face), the work
    index is that fraction times the share of the wheel's travel that still pushes the
    pallet: ``fraction * (impulse_angle - drop_angle) / impulse_angle``.  The index of the
    ideal pallet without drop is the fraction itself (distance index 1).

    Parameters
    ----------
    fraction
        Transmitted fraction during impulse (e.g. 0.5).
    impulse_angle
        Wheel rotation available for impulse without drop (any angle unit; e.g. 6 deg for a
        30-tooth wheel).
    drop_angle
        Part of it lost to drop (same unit), ``0 <= drop < impulse``.
    """
    if not (impulse_angle > 0 and 0 <= drop_angle < impulse_angle):
        raise SceneError(f"need impulse_angle > 0 and 0 <= drop_angle < impulse_angle, got "
                         f"drop_angle = {drop_angle!r}, impulse_angle = {impulse_angle!r}")
    return fraction * (impulse_angle - drop_angle) / impulse_angle


def work_index(fraction: Callable[[np.ndarray], np.ndarray], *, lower: float = 0.0, upper: float = 1.0,
               parts: int = 10_000, method: Literal["simpson", "quad"] = "simpson") -> float:
    """Work index: the transmitted fraction integrated over the impulse's progress.

    Parameters
    ----------
    fraction
        Transmitted fraction as a function of the progress index ``t`` (vectorised).
    lower, upper
        Progress interval (the distance index of the text runs from 0 to 1).
    parts
        Number of equal parts for Simpson's rule (must be even).
    method
        ``"simpson"`` (composite Simpson's rule, as in the text) or ``"quad"`` (adaptive
        Gauss-Kronrod, scipy).
    """
    if method == "quad":
        value, _ = integrate.quad(lambda t: float(fraction(np.array(t))), lower, upper, limit=200)
        return float(value)
    if method != "simpson":
        raise SolverError(f"method must be 'simpson' or 'quad', got method = {method!r}")
    if parts < 2 or parts % 2:
        raise SolverError(f"Simpson's rule needs an even number of parts >= 2, got parts = {parts!r}")
    t = np.linspace(lower, upper, parts + 1)
    return float(integrate.simpson(fraction(t), x=t))


def brocot_fraction(t, mu: float = 0.0):
    """Transmitted fraction of a round (Brocot) pallet along its impulse.

    On a half-round pallet the face normal turns from ``Fe`` (start of impulse) to ``Fp``
    (end) with ``b = 90 deg``.  For a normal at angle ``phi`` the force diagram puts the tip
    of ``Fi`` on the circle whose diameter is ``Fe`` (Thales): its component along ``Fe`` is
    ``cos(phi)**2`` and along ``Fp`` it is ``cos(phi) * sin(phi)``.  The progress index is
    taken as how far that tip has moved along ``Fe``, ``t = sin(phi)**2`` (0 to 1); the
    fraction traced against it is then the semicircle ``sqrt(t (1 - t))``.  That choice of
    index is an assumption (the text's formulas are not printed); it is the one that
    reproduces the printed work index 0.3927.

    Parameters
    ----------
    t
        Progress index in ``[0, 1]``.
    mu
        Friction coefficient on the pallet face (see :func:`transmitted_fraction`).
    """
    t = np.clip(np.asarray(t, dtype=float), 0.0, 1.0)
    phi = np.arcsin(np.sqrt(t))
    return transmitted_fraction(phi, math.pi / 2, mu)


def brocot_work_index(mu: float = 0.0, *, parts: int = 10_000,
                      method: Literal["simpson", "quad"] = "simpson") -> float:
    """Work index of the Brocot pallet (``pi/8 = 0.3927`` without friction)."""
    return work_index(lambda t: brocot_fraction(t, mu), parts=parts, method=method)


def contact_work_efficiency(fe_fi, fe_fp, mu: float):
    """Energy efficiency of the sliding tooth-on-face contact (virtual work).

    The tooth moves along ``Fe`` and the face along ``Fp``; the contact keeps their normal
    velocities equal.  The wheel's torque fixes the component of the contact force along
    ``Fe``; friction tilts that force by ``rho`` as above.  The ratio of the pallet's
    received work to the tooth's input work is

        eta = cos(a) cos(b - a + rho) / (cos(a - rho) cos(b - a)),

    1 without friction and 0 where the face locks.

    Parameters
    ----------
    fe_fi, fe_fp
        Angles ``a`` and ``b`` as in :func:`transmitted_fraction`, rad.
    mu
        Friction coefficient on the face.
    """
    a = np.asarray(fe_fi, dtype=float)
    b = np.asarray(fe_fp, dtype=float)
    rho = friction_angle(mu)
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = np.cos(a) * np.cos(b - a + rho) / (np.cos(a - rho) * np.cos(b - a))
    eta = np.where(b - a + rho >= math.pi / 2, 0.0, np.clip(eta, 0.0, 1.0))
    return eta if eta.ndim else float(eta)
