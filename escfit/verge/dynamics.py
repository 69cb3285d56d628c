"""Equations of motion of the rotor-driven train and the verge in coupled and free motion.

Degrees of freedom: the escape-wheel angle ``phi`` (the rotor and gear 2 follow through
the gear ratios) and, in free motion only, the verge angle ``psi``.  All loads come from
the constant spin ``omega`` of the fuze body (d'Alembert forces in the body frame), so
every force is proportional to ``omega**2``.

The chain of single-body equations used in both regimes (``Phi`` is the rotor angle,
``n31 > 0`` and ``n32 < 0`` the speed ratios):

* rotor:  ``F12 = [-a35 sin Phi - a32 - a33 n31 phi' - a34 (n31 phi')^2 - I_1R n31 phi''] / a31``
* gear 2: ``F23 = [a42 F12 - a43 T2 + I2 n32 phi''] / a44``
* wheel:  ``I3 phi'' = a15 F23 - a16 T3 - a17 Pn``
* verge:  ``a18 Pn = I_PR psi'' + a21 psi'^2 + 2|omega| a20 psi' + omega^2 a19 - m_p r_cp R4 omega^2 sin(gamma_pp - psi - psic)``

F23 is affine in ``phi''``; in coupled motion ``psi' = u phi'`` and
``psi'' = u phi'' + v phi'^2`` make Pn affine in ``phi''`` too, so the wheel equation is
a linear equation for ``phi''``.  In free motion ``Pn = 0`` and the verge equation stands
alone.

Units: inch, lbf, second, radian.  Forces are returned in lbf.
"""

from __future__ import annotations

import math


from ..core.kernels import kernel
from .coefficients import mesh_roll, pallet_coefficients, train_coefficients, wheel_coefficients
from .kinematics import coupled_kinematics, sliding_factor

__all__ = ["coupled_eval", "free_eval", "coupled_signs", "side_alpha", "side_psic"]


@kernel
def side_alpha(k, side):
    """Face angle of the active side (+1 entrance, -1 exit)."""
    return k.alpha_en if side > 0 else k.alpha_ex


@kernel
def side_psic(k, side):
    """Eccentricity angle of the verge in the active side's reference.

    ``psi`` is measured to the active face tip; the exit tip lies ``lambda`` further round,
    so the centre-of-mass direction is ``lambda`` larger in the exit reference.
    """
    return k.psic0 if side > 0 else k.psic0 + k.lam


@kernel
def _sgn(x):
    return 1.0 if x >= 0.0 else -1.0


@kernel
def coupled_signs(k, side, phi, phid, direction):
    """Friction signs for coupled motion at speed ``phid``.

    ``direction`` (+1/-1) is used instead of ``sign(phid)`` so that the signs of an
    impending motion can be evaluated at rest.  Returns ``(s4, s5)``.
    """
    alpha = side_alpha(k, side)
    psi, g, u, v, aa, ab, ac, ad = coupled_kinematics(k.a, k.b, k.c, alpha, phi)
    beta = sliding_factor(k.b, k.c, alpha, phi, psi, u)
    if phid != 0.0:
        s4 = _sgn(beta * phid)
        s5 = _sgn(u * phid)
    else:
        s4 = _sgn(beta * direction)
        s5 = _sgn(u * direction)
    return s4, s5


@kernel
def _mesh_force_affine(k, phid, phi_total, s1, s2, mu, al1, al2, inertia_sign):
    """F23 = f0 + f1 * phi'' and the train coefficients needed for F12."""
    a31, a32, a33, a34, a35, a42, a43, a44, jr = train_coefficients(k, phi_total, s1, s2, mu, al1, al2)
    i1r = max(k.i1 + inertia_sign * jr, 0.0)
    big_phi = k.phi1c + k.n31 * phi_total
    n31 = k.n31
    rot0 = -a35 * math.sin(big_phi) - a32 - a33 * n31 * phid - a34 * n31 * n31 * phid * phid
    f0 = (a42 * rot0 / a31 - a43 * k.t2) / a44
    f1 = (k.i2 * k.n32 - a42 * i1r * n31 / a31) / a44
    return f0, f1, a42, a43, a44


@kernel
def _consistent(speed, acc):
    return 1.0 if speed * acc >= 0.0 else -1.0


@kernel
def coupled_eval(k, side, phi, phid, phi_total, n1, n2, s1, s2, s4, s5, mus, rot_branch, verge_branch):
    """Escape-wheel acceleration and contact forces in coupled motion.

    Parameters
    ----------
    k : Constants
    side : float
        +1 entrance face, -1 exit face.
    phi, phid : float
        Escape-wheel angle (rad, in the active side's reference) and speed (rad/s).
    phi_total : float
        Cumulative escape-wheel angle (rad), which fixes the rotor angle and mesh phases.
    n1, n2 : float
        Tooth pairs in contact in mesh 1 and 2 (see :func:`escfit.verge.coefficients.mesh_phase`).
    s1, s2, s4, s5 : float
        Friction signs (see :mod:`escfit.verge.coefficients`).
    mus : float
        Direction of the gear train (+1 forward), the sign given to ``mu``.
    rot_branch, verge_branch : float
        Branch of the pivot-friction share of the rotor and verge inertias: +1 while the
        body speeds up (``speed * acceleration >= 0``), -1 while it slows down, 0 to pick
        the branch consistent with the resulting acceleration.

    Returns
    -------
    phidd : float
        Escape-wheel acceleration (rad/s^2).
    psi, psid, psidd : float
        Verge angle, speed, acceleration from the kinematics.
    f23, f12 : float
        Normal tooth forces in mesh 2 and mesh 1 (lbf).
    pn : float
        Normal contact force tooth/verge from the wheel equation (lbf).
    pn_verge : float
        The same force from the verge equation (lbf); equal to ``pn`` (a check).
    g : float
        Contact position along the face (in).
    rot_ok, verge_ok : float
        The branches consistent with ``phidd`` (+1/-1).
    """
    alpha = side_alpha(k, side)
    psic = side_psic(k, side)
    psi, g, u, v, aa, ab, ac, ad = coupled_kinematics(k.a, k.b, k.c, alpha, phi)
    mu = k.mu * mus
    al1, al2 = mesh_roll(k, phi_total, n1, n2)
    a15, a16, a17 = wheel_coefficients(k, side, psi, alpha, s2, s4, mu, al2, aa, ab)
    a18, a19, a20, a21, a22 = pallet_coefficients(k, side, psi, psic, alpha, s4, s5, ac, ad)
    om = k.omega
    psid = u * phid
    ecc = k.mp * k.rcp * k.r4 * om * om * math.sin(k.gamma_pp - psi - psic)
    p0_rest = (a21 * psid * psid + 2.0 * om * a20 * psid + om * om * a19 - ecc) / a18
    rot_sign = rot_branch if rot_branch != 0.0 else 1.0
    pal_sign = verge_branch if verge_branch != 0.0 else 1.0
    phidd = 0.0
    f0 = f1 = a42 = a43 = a44 = ipr = 0.0
    for attempt in range(2):
        f0, f1, a42, a43, a44 = _mesh_force_affine(k, phid, phi_total, s1, s2, mu, al1, al2, rot_sign)
        ipr = max(k.ip + pal_sign * a22, 0.0)
        p1 = ipr * u / a18
        p0 = p0_rest + ipr * v * phid * phid / a18
        phidd = (a15 * f0 - a16 * k.t3 - a17 * p0) / (k.i3 - a15 * f1 + a17 * p1)
        want_rot = _consistent(phid, phidd) if rot_branch == 0.0 else rot_sign
        want_pal = _consistent(psid, u * phidd + v * phid * phid) if verge_branch == 0.0 else pal_sign
        if want_rot == rot_sign and want_pal == pal_sign:
            break
        rot_sign = want_rot
        pal_sign = want_pal
    psidd = u * phidd + v * phid * phid
    f23 = f0 + f1 * phidd
    f12 = (f23 * a44 + k.t2 * a43 - k.i2 * k.n32 * phidd) / a42
    pn = (-k.i3 * phidd + f23 * a15 - k.t3 * a16) / a17
    pn_verge = (ipr * psidd + a21 * psid * psid + 2.0 * om * a20 * psid + om * om * a19 - ecc) / a18
    return (phidd, psi, psid, psidd, f23, f12, pn, pn_verge, g,
            _consistent(phid, phidd), _consistent(psid, psidd))


@kernel
def free_train(k, phid, phi_total, n1, n2, s1, s2, mus, hold, rot_branch):
    """Escape-wheel acceleration and mesh forces with the verge out of contact.

    With ``hold`` the train is held at rest by friction: the acceleration is zero and the
    forces are those that keep it there.  ``rot_branch`` as in :func:`coupled_eval`.

    Returns ``(phidd, f23, f12, rot_ok)`` in rad/s^2 and lbf.
    """
    mu = k.mu * mus
    al1, al2 = mesh_roll(k, phi_total, n1, n2)
    a15, a16, _a17 = wheel_coefficients(k, 1.0, 0.0, 0.0, s2, 1.0, mu, al2, 0.0, 0.0)
    phidd = 0.0
    f0 = f1 = a42 = a43 = a44 = 0.0
    rot_sign = rot_branch if rot_branch != 0.0 else 1.0
    for attempt in range(2):
        f0, f1, a42, a43, a44 = _mesh_force_affine(k, phid, phi_total, s1, s2, mu, al1, al2, rot_sign)
        if hold:
            break
        phidd = (a15 * f0 - a16 * k.t3) / (k.i3 - a15 * f1)
        want = _consistent(phid, phidd) if rot_branch == 0.0 else rot_sign
        if want == rot_sign:
            break
        rot_sign = want
    f23 = f0 + f1 * phidd
    f12 = (f23 * a44 + k.t2 * a43 - k.i2 * k.n32 * phidd) / a42
    return phidd, f23, f12, _consistent(phid, phidd)


@kernel
def free_verge(k, side, psi, psid, s5, verge_branch):
    """Verge acceleration out of contact: pivot friction and eccentric mass only.

    Returns ``(psidd, verge_ok)``: rad/s^2 and the consistent inertia branch.
    """
    psic = side_psic(k, side)
    _a18, a19, a20, a21, a22 = pallet_coefficients(k, side, psi, psic, side_alpha(k, side), 1.0, s5, 0.0, 0.0)
    om = k.omega
    ecc = k.mp * k.rcp * k.r4 * om * om * math.sin(k.gamma_pp - psi - psic)
    rhs = -a21 * psid * psid - 2.0 * om * a20 * psid - om * om * a19 + ecc
    branch = verge_branch if verge_branch != 0.0 else 1.0
    ipr = max(k.ip + branch * a22, 0.0)
    psidd = rhs / ipr if ipr > 0.0 else 0.0
    if verge_branch == 0.0 and psid * psidd < 0.0:
        ipr = max(k.ip - a22, 0.0)
        psidd = rhs / ipr if ipr > 0.0 else 0.0
    return psidd, _consistent(psid, psidd)


@kernel
def free_eval(k, side, phid, psi, psid, phi_total, n1, n2, s1, s2, s5, mus, train_stuck, verge_stuck, rot_branch,
              verge_branch):
    """Accelerations and mesh forces in free motion.

    A body flagged as stuck (Coulomb friction holding it at rest) has zero acceleration.
    Branch arguments as in :func:`coupled_eval`.

    Returns
    -------
    phidd, psidd : float
        Accelerations (rad/s^2).
    f23, f12 : float
        Mesh forces FF23, FF12 (lbf).
    rot_ok, verge_ok : float
        Consistent inertia branches.
    """
    phidd, f23, f12, rot_ok = free_train(k, phid, phi_total, n1, n2, s1, s2, mus, train_stuck, rot_branch)
    if verge_stuck:
        psidd, verge_ok = 0.0, 1.0
    else:
        psidd, verge_ok = free_verge(k, side, psi, psid, s5, verge_branch)
    return phidd, psidd, f23, f12, rot_ok, verge_ok
