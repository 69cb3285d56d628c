"""Friction-dependent force coefficients of the verge, escape wheel, gear set 2 and rotor.

Each body's pivot reaction is found from its force balance with Coulomb friction at the
pivot, then replaced by the "conservative" magnitude |F_x| + |F_y| so that the pivot
friction moment (coefficient times pivot radius times that magnitude) always opposes the
rotation.  The coefficients below are those magnitudes per unit of each load (contact
force, centrifugal force, ...), following the numbering A1..A44 of the report so that each
can be traced to its derivation.

Sign conventions
----------------
* ``mu`` is the *signed* gear-train coefficient: ``+|mu|`` while the escape wheel turns
  forward (``phidot > 0``) and ``-|mu|`` while the train runs backwards, which reverses
  every gear-tooth and gear-pivot friction force at once.
* ``mu1`` (pallet face and pallet pivot) is always positive; its direction is carried by
  ``s4`` (sign of the tooth's sliding velocity on the face) and ``s5`` (sign of ``psidot``).
* ``s1``, ``s2`` are +1 while mesh 1 / mesh 2 is in its approach phase (contact between the
  driver's base tangency point and the pitch point), -1 in recess, 0 at the pitch point.
* ``side`` is +1 for the entrance face and -1 for the exit face.
"""

from __future__ import annotations

import math

from ..core.kernels import kernel

__all__ = ["mesh_phase", "mesh_roll", "pallet_coefficients", "wheel_coefficients", "train_coefficients"]


@kernel
def _mesh_progress(k, phi_total):
    """Driver rotation past the first contact of the starting tooth pair, both meshes (rad)."""
    u1 = (k.al1_start - k.al1_in) + k.n31 * phi_total
    u2 = (k.al2_start - k.al2_in) + (-k.n32) * phi_total
    return u1, u2


@kernel
def mesh_phase(k, phi_total):
    """Which tooth pair carries each mesh, and whether it is in approach or recess.

    The driver's roll angle advances with the driver's rotation: the rotor turns ``n31``
    and gear 2 turns ``|n32|`` radians per radian of the escape wheel.  When a contact
    reaches the end of its interval the next tooth pair takes over at its start
    (contact ratio 1), so each pair covers one interval length of driver rotation.

    Returns
    -------
    n1, n2 : float
        Index of the tooth pair in mesh 1 and mesh 2 (0 for the pairs in contact at the
        start; whole numbers stored as floats).
    s1, s2 : float
        +1 while the contact is in approach (roll angle below ``tan(theta)``, the pitch
        point), -1 in recess.
    """
    u1, u2 = _mesh_progress(k, phi_total)
    n1 = math.floor(u1 / k.al1_range)
    n2 = math.floor(u2 / k.al2_range)
    s1 = 1.0 if k.al1_in + (u1 - n1 * k.al1_range) < math.tan(k.theta1) else -1.0
    s2 = 1.0 if k.al2_in + (u2 - n2 * k.al2_range) < math.tan(k.theta2) else -1.0
    return n1, n2, s1, s2


@kernel
def mesh_roll(k, phi_total, n1, n2):
    """Roll angles (rad) of the given tooth pairs of mesh 1 and mesh 2.

    For a fixed pair this is a continuous function of ``phi_total``, so an integration
    step that ends just past a tooth change does not see a jump.
    """
    u1, u2 = _mesh_progress(k, phi_total)
    return k.al1_in + u1 - n1 * k.al1_range, k.al2_in + u2 - n2 * k.al2_range


@kernel
def pallet_coefficients(k, side, psi, psic, alpha, s4, s5, arm_c, arm_d):
    """Pallet (verge) coefficients.

    Parameters
    ----------
    k : Constants
    side : float
        +1 entrance, -1 exit.
    psi, psic, alpha : float
        Verge angle, eccentricity angle of its centre of mass and active face angle (rad).
    s4, s5 : float
        Signs of the sliding velocity on the face and of the verge speed.
    arm_c, arm_d : float
        Moment arms C1' and D1' of the contact (in); pass 0 in free motion.

    Returns
    -------
    a18 : float
        Moment arm (in) of the contact force about the pallet pivot, net of face and
        pivot friction: the verge moment equation reads
        ``a18 * Pn = I_PR psi'' + a21 psi'^2 + 2|omega| a20 psi' + omega^2 a19 - m_p r_cp R4 omega^2 sin(gamma_pp - psi - psic)``.
    a19, a20, a21, a22 : float
        Pivot-friction terms from the centrifugal load (``a19``, in*lbf*s^2), from the
        eccentric mass (``a20``, ``a21 = s5 * a20``) and the inertia correction ``a22``
        (in*lbf*s^2) added to or subtracted from I_p.
    """
    mu1 = k.mu1
    dn1 = 1.0 + mu1 * mu1
    x = psi + alpha
    sx, cx = math.sin(x), math.cos(x)
    if side > 0:
        a1 = abs(-mu1 * (s4 + s5) * sx - (1.0 - s4 * s5 * mu1 * mu1) * cx) / dn1
        a5 = abs(mu1 * (s4 + s5) * cx + (1.0 - s4 * s5 * mu1 * mu1) * sx) / dn1
    else:
        a1 = abs(mu1 * (s5 - s4) * sx + (1.0 + s4 * s5 * mu1 * mu1) * cx) / dn1
        a5 = abs(mu1 * (s5 - s4) * cx - (1.0 + s4 * s5 * mu1 * mu1) * sx) / dn1
    pe = psi + psic
    spe, cpe = math.sin(pe), math.cos(pe)
    sg, cg = math.sin(k.gamma_pp), math.cos(k.gamma_pp)
    a2 = k.mp * abs(k.r4 * (sg - mu1 * s5 * cg) + k.rcp * (spe - mu1 * s5 * cpe)) / dn1
    a6 = k.mp * abs(-k.r4 * (cg + mu1 * s5 * sg) - k.rcp * (cpe + mu1 * s5 * spe)) / dn1
    a3 = k.mp * k.rcp * abs(spe - mu1 * s5 * cpe) / dn1
    a4 = k.mp * k.rcp * abs(cpe + mu1 * s5 * spe) / dn1
    a7 = a4
    a8 = a3
    a18 = side * arm_d - mu1 * s4 * arm_c - k.rhop * mu1 * s5 * (a1 + a5)
    a19 = k.rhop * mu1 * s5 * (a2 + a6)
    a20 = k.rhop * mu1 * (a3 + a7)
    a21 = s5 * a20
    a22 = k.rhop * mu1 * (a4 + a8)
    return a18, a19, a20, a21, a22


@kernel
def wheel_coefficients(k, side, psi, alpha, s2, s4, mu, al2, arm_a, arm_b):
    """Escape-wheel coefficients: ``I3 phi'' = a15 F23 - a16 T3 - a17 Pn``.

    Parameters
    ----------
    mu : float
        Signed gear-train friction coefficient.
    al2 : float
        Roll angle of mesh 2 (rad).
    arm_a, arm_b : float
        Moment arms A1', B1' of the contact (in); pass 0 in free motion.

    Returns
    -------
    a15 : float
        Effective arm of the mesh force F23 on the wheel (in).
    a16 : float
        Pivot-friction arm of the centrifugal force T3 (in).
    a17 : float
        Effective arm of the pallet contact force (in).
    """
    mu1 = k.mu1
    dn = 1.0 + mu * mu
    y = psi + alpha + k.beta3
    sy, cy = math.sin(y), math.cos(y)
    if side > 0:
        a9 = abs((mu1 * s4 + mu) * sy + (1.0 - mu * mu1 * s4) * cy) / dn
        a12 = abs((1.0 - mu * mu1 * s4) * sy - (mu1 * s4 + mu) * cy) / dn
    else:
        a9 = abs((mu1 * s4 - mu) * sy - (1.0 + mu * mu1 * s4) * cy) / dn
        a12 = abs(-(1.0 + mu * mu1 * s4) * sy + (mu - mu1 * s4) * cy) / dn
    u = k.beta2 + k.theta2
    su, cu = math.sin(u), math.cos(u)
    a10 = abs(-mu * (1.0 - s2) * su - (1.0 + mu * mu * s2) * cu) / dn
    a13 = abs(-(1.0 + mu * mu * s2) * su + mu * (1.0 - s2) * cu) / dn
    a11 = abs(math.sin(k.gamma3) - mu * math.cos(k.gamma3)) / dn
    a14 = abs(math.cos(k.gamma3) + mu * math.sin(k.gamma3)) / dn
    a15 = k.rb3 - mu * (s2 * (k.d2 - al2 * k.caprb2) + k.rho3 * (a10 + a13))
    a16 = mu * k.rho3 * (a11 + a14)
    a17 = side * arm_a - mu1 * s4 * arm_b + mu * k.rho3 * (a9 + a12)
    return a15, a16, a17


@kernel
def train_coefficients(k, phi_total, s1, s2, mu, al1, al2):
    """Rotor and gear-set-2 coefficients.

    Rotor (driver of mesh 1), with ``Phi = phi1c + n31 * phi_total`` its angle:
    ``I_1R n31 phi'' = -a35 sin(Phi) - a32 - a33 n31 phi' - a34 (n31 phi')^2 - a31 F12``.
    Gear set 2: ``I2 n32 phi'' = a44 F23 + a43 T2 - a42 F12``.

    Returns
    -------
    a31, a32, a33, a34, a35, a42, a43, a44 : float
        As in the equations above (a35 = m1 R1 r_c1 omega^2 is the centrifugal drive).
    rotor_pivot_inertia : float
        ``|mu| rho1 (A26 + A30)`` (in*lbf*s^2), added to or subtracted from I1 depending on
        whether the rotor speeds up or slows down.
    """
    dn = 1.0 + mu * mu
    om = k.omega
    w = k.beta1 - k.theta1
    sw, cw = math.sin(w), math.cos(w)
    big_phi = k.phi1c + k.n31 * phi_total
    sp, cp = math.sin(big_phi), math.cos(big_phi)
    a23 = abs((1.0 - mu * mu * s1) * sw - mu * (1.0 + s1) * cw) / dn
    a27 = abs(mu * (1.0 + s1) * sw + (1.0 - mu * mu * s1) * cw) / dn
    a24 = k.m1 * abs(k.r1 + k.rc1 * (cp + mu * sp)) / dn
    a28 = k.m1 * abs(mu * k.r1 + k.rc1 * (mu * cp - sp)) / dn
    a25 = k.m1 * k.rc1 * abs(cp + mu * sp) / dn
    a29 = k.m1 * k.rc1 * abs(mu * cp - sp) / dn
    a26 = k.m1 * k.rc1 * abs(sp - mu * cp) / dn
    a30 = k.m1 * k.rc1 * abs(mu * sp + cp) / dn
    a31 = k.caprb1 - mu * s1 * al1 * k.caprb1 + mu * k.rho1 * (a23 + a27)
    a32 = mu * k.rho1 * om * om * (a24 + a28)
    a33 = 2.0 * abs(mu) * k.rho1 * om * (a25 + a29)
    a34 = mu * k.rho1 * (a25 + a29)
    a35 = k.m1 * k.r1 * k.rc1 * om * om
    u = k.beta2 + k.theta2
    su, cu = math.sin(u), math.cos(u)
    a36 = abs((1.0 - mu * mu * s2) * su + mu * (1.0 + s2) * cu) / dn
    a39 = abs(mu * (1.0 + s2) * su - (1.0 - mu * mu * s2) * cu) / dn
    a37 = abs((1.0 + mu * mu * s1) * sw + mu * (1.0 - s1) * cw) / dn
    a40 = abs(mu * (1.0 - s1) * sw - (1.0 + mu * mu * s1) * cw) / dn
    a38 = abs(math.cos(k.gamma2) - mu * math.sin(k.gamma2)) / dn
    a41 = abs(mu * math.cos(k.gamma2) + math.sin(k.gamma2)) / dn
    a42 = k.rb2 - mu * (s1 * (k.d1 - al1 * k.caprb1) + k.rho2 * (a37 + a40))
    a43 = mu * k.rho2 * (a38 + a41)
    a44 = k.caprb2 - mu * (s2 * al2 * k.caprb2 - k.rho2 * (a36 + a39))
    return a31, a32, a33, a34, a35, a42, a43, a44, abs(mu) * k.rho1 * (a26 + a30)
