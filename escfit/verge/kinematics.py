"""Planar kinematics of a straight-sided verge against the escape-wheel tooth tips.

Frame: the x' axis runs from the pallet pivot O_p to the escape-wheel pivot O_s, a
distance ``a`` apart; angles are counter-clockwise.

* ``phi`` -- escape-wheel angle of the engaged tooth tip S, measured at O_s from +x'.
* ``psi`` -- verge angle of the active face tip (V on the entrance side, W on the exit
  side), measured at O_p from +x'.  The tip lies at distance ``c`` from O_p.
* ``alpha`` -- angle of the active working face (``alpha_en`` or ``alpha_ex``); the face
  runs from its tip in the direction ``e = (cos(psi+alpha), sin(psi+alpha))``.
* ``g`` -- position of the contact point along the face, measured from the tip along ``e``
  (in).  While in contact ``g > 0`` on the entrance face and ``g < 0`` on the exit face;
  ``g = 0`` means the tooth is at the face tip and is about to drop off.

Contact requires S on the face line: ``a sin(psi+alpha) - b sin(phi-psi-alpha) - c sin(alpha) = 0``.
The same expression, evaluated for independent ``phi`` and ``psi``, is the signed normal
gap ``f`` used while the bodies move freely, and ``g'`` (the projection of S on the face
direction) tells whether the tooth faces the working surface.
"""

from __future__ import annotations

import math

from ..core.kernels import kernel

__all__ = ["coupled_kinematics", "contact_sensing", "face_position", "sliding_factor"]

TWO_PI = 2.0 * math.pi


@kernel
def coupled_kinematics(a, b, c, alpha, phi):
    """Verge position and its derivatives when the tooth tip slides on the face.

    Parameters
    ----------
    a, b, c : float
        Pivot distance, escape-wheel radius, pallet radius (in).
    alpha : float
        Active face angle (rad).
    phi : float
        Escape-wheel angle (rad).

    Returns
    -------
    psi : float
        Verge angle in [0, 2*pi) (rad); NaN when no contact position exists.
    g : float
        Contact position along the face (in).
    u : float
        d psi / d phi (dimensionless); the verge speed is ``u * phidot``.
    v : float
        d^2 psi / d phi^2; the verge acceleration is ``u * phiddot + v * phidot**2``.
    arm_a, arm_b, arm_c, arm_d : float
        Moment arms A1', B1', C1', D1' (in): normal and tangential arms of the contact
        force about the wheel (A1', B1') and the verge (C1', D1') pivots.
    """
    cap_a = a * math.cos(alpha) + b * math.cos(phi - alpha)
    cap_b = a * math.sin(alpha) - b * math.sin(phi - alpha)
    cap_c = c * math.sin(alpha)
    disc = cap_a * cap_a + cap_b * cap_b - cap_c * cap_c
    if disc < 0.0:
        nan = math.nan
        return nan, nan, nan, nan, nan, nan, nan, nan
    # tan(psi/2) solves (B+C) t^2 - 2 A t + (C-B) = 0; this root is the working branch.
    psi = 2.0 * math.atan2(cap_a - math.sqrt(disc), cap_b + cap_c)
    if psi < 0.0:
        psi += TWO_PI
    x = psi + alpha
    g = (b * math.sin(phi) - c * math.sin(psi)) / math.sin(x)
    p = b * math.cos(phi - x)
    q = a * math.cos(x) + p
    u = p / q
    v = (a * p * p * math.sin(x) - b * (p - q) ** 2 * math.sin(phi - x)) / q**3
    arm_a = b * math.cos(phi - x)
    arm_b = b * math.sin(phi - x)
    arm_c = -c * math.sin(alpha)
    arm_d = c * math.cos(alpha) + g
    return psi, g, u, v, arm_a, arm_b, arm_c, arm_d


@kernel
def face_position(b, c, alpha, phi, psi):
    """Position ``g`` (in) along the face line where it reaches the y' level of S.

    Equals the contact position when S lies on the face (used at impacts, where ``phi``
    and ``psi`` come from free motion).
    """
    return (b * math.sin(phi) - c * math.sin(psi)) / math.sin(psi + alpha)


@kernel
def contact_sensing(a, b, c, alpha, phi, psi):
    """Normal gap ``f`` and tangential position ``g'`` of the tooth tip relative to the face.

    Returns
    -------
    f : float
        Minus the signed distance of S from the face line (in).  On the entrance side a
        positive ``f`` is a gap; on the exit side a negative one.
    gp : float
        Distance of S's projection on the face line from the face tip (in).  The tooth
        faces the working surface when ``gp >= 0`` (entrance) or ``gp <= 0`` (exit).
    """
    x = psi + alpha
    f = a * math.sin(x) - b * math.sin(phi - x) - c * math.sin(alpha)
    gp = a * math.cos(x) + b * math.cos(phi - x) - c * math.cos(alpha)
    return f, gp


@kernel
def sliding_factor(b, c, alpha, phi, psi, u):
    """Sliding speed of the tooth tip relative to the face per unit wheel speed (in/rad).

    In coupled motion the sliding velocity V_S/T equals ``sliding_factor * phidot``; its
    sign fixes the direction of the face friction force.
    """
    return -(b * math.sin(phi - psi - alpha) + u * c * math.sin(alpha))
