"""Instantaneous impact of an escape-wheel tooth on a verge face.

During the impact only the normal contact impulse ``J`` acts (the friction impulse and
all finite forces are neglected).  Taking ``A = A1'`` and ``D = D1'`` as the arms of the
contact normal about the wheel and verge pivots, the normal speeds of the two contact
points are ``VS = A * phidot`` (tooth) and ``VP = D * psidot`` (face).  Then

* the impulse changes both angular momenta in a fixed ratio:
  ``I_S D (phidot_f - phidot_i) + I_p A (psidot_f - psidot_i) = 0``, where ``I_S`` is the
  whole train's inertia referred to the escape wheel (the meshes pass the impulse on);
* Newton's law of restitution: ``VP_f - VS_f = -e (VP_i - VS_i)``.

With ``e = 0`` the two contact points leave the impact with the same normal speed and
stay together (coupled motion); with ``e > 0`` they separate.
"""

from __future__ import annotations

import math


from ..core.kernels import kernel
from .kinematics import face_position

__all__ = ["impact_map", "normal_speeds"]


@kernel
def normal_speeds(k, alpha, phi, psi, phid, psid):
    """Normal speeds of the tooth tip and of the face at the contact point (in/s).

    Returns ``(vs, vp, arm_a, arm_d)``: tooth speed ``A1' * phid``, face speed
    ``D1' * psid`` and the two arms (in).
    """
    g = face_position(k.b, k.c, alpha, phi, psi)
    arm_a = k.b * math.cos(phi - psi - alpha)
    arm_d = k.c * math.cos(alpha) + g
    return arm_a * phid, arm_d * psid, arm_a, arm_d


@kernel
def impact_map(k, alpha, phi, psi, phid, psid, erest):
    """Post-impact speeds of the escape wheel and the verge.

    Parameters
    ----------
    k : Constants
        Provides ``istot`` (train inertia referred to the escape wheel), ``ip`` and the
        verge geometry.
    alpha : float
        Face angle of the side being hit (rad).
    phi, psi : float
        Angles at the instant of contact (rad).
    phid, psid : float
        Speeds just before the impact (rad/s).
    erest : float
        Coefficient of restitution, 0 (plastic) .. 1 (elastic).

    Returns
    -------
    phid_f, psid_f : float
        Speeds just after the impact (rad/s).
    """
    vs, vp, arm_a, arm_d = normal_speeds(k, alpha, phi, psi, phid, psid)
    ip, ist = k.ip, k.istot
    phid_f = (ip * arm_a * arm_d * psid * (1.0 + erest) + phid * (ist * arm_d**2 - erest * ip * arm_a**2)) / (
        ip * arm_a**2 + ist * arm_d**2
    )
    psid_f = (arm_a * phid_f - erest * (arm_d * psid - arm_a * phid)) / arm_d
    return phid_f, psid_f
