"""Fixed geometry of the fuze body, gear train and verge, computed once per parameter set.

Everything here is in the report's unit system: inch, pound-force, second, radian
(masses in lbf*s^2/in, moments of inertia in in*lbf*s^2).  The numbers are packed into
one :class:`Constants` named tuple that the compiled dynamics receive.

Fuze-body angles (all measured in the body-fixed frame, counter-clockwise positive):

* ``gamma2, gamma3, gamma4`` -- polar angles (about the spin axis) of the pivots of gear
  set 2, the escape wheel and the pallet, taking the rotor pivot as angle 0.  In
  configuration 2 the train winds clockwise, so they are negative.
* ``beta1, beta2, beta3`` -- directions of the centre lines rotor->pinion 2,
  gear 2->pinion 3 and escape wheel->pallet, used to resolve mesh and pivot forces.
* ``gamma_pp`` -- angle from the pallet frame's x' axis (pallet pivot -> escape-wheel
  pivot) to the outward radial direction of the pallet pivot; the centrifugal load on the
  pallet pivot points along it.
"""

from __future__ import annotations

import math
from typing import Mapping, NamedTuple

from ..core.errors import SceneError

__all__ = ["Constants", "FuzeAngles", "fuze_angles", "build_constants", "mesh_limits"]


class Constants(NamedTuple):
    """Everything the compiled model needs, in inch-lbf-second-radian units."""

    # verge and escape wheel
    a: float  # pallet pivot to escape-wheel pivot, in
    b: float  # escape-wheel tip radius, in
    c: float  # pallet radius to the face tips, in
    alpha_en: float  # entrance face angle, rad
    alpha_ex: float  # exit face angle, rad
    lam: float  # angle between entrance and exit pallet radii, rad
    pitch: float  # escape-wheel tooth pitch 2*pi/N, rad
    nt: float  # teeth spanned by the verge
    erest: float  # coefficient of restitution
    # bodies
    m1: float
    mp: float
    i1: float
    i2: float
    i3: float
    ip: float
    rc1: float  # rotor centre-of-mass offset, in
    rcp: float  # pallet centre-of-mass offset, in
    rhop: float  # pallet pivot radius, in
    rho1: float
    rho2: float
    rho3: float
    r1: float  # rotor pivot distance from the spin axis, in
    r4: float  # pallet pivot distance from the spin axis, in
    # operating point
    omega: float  # |spin|, rad/s
    mu: float  # |gear-train friction coefficient|
    mu1: float  # escapement (pallet face and pallet pivot) friction coefficient
    phi1c: float  # rotor angle at the start, rad
    psic0: float  # pallet eccentricity angle, rad
    phi_cut: float  # cumulative escape-wheel angle at which gearing ends, rad
    capture_speed: float  # post-impact relative normal speed below which the bodies stay together, in/s
    # gear train
    n31: float  # rotor speed / escape-wheel speed (positive)
    n32: float  # gear-2 speed / escape-wheel speed (negative)
    t2: float  # centrifugal force on gear set 2, lbf
    t3: float  # centrifugal force on the escape wheel, lbf
    gamma2: float
    gamma3: float
    beta1: float
    beta2: float
    beta3: float
    gamma_pp: float
    theta1: float
    theta2: float
    caprb1: float
    caprb2: float
    rb2: float
    rb3: float
    d1: float  # length of line of action, mesh 1, in
    d2: float  # length of line of action, mesh 2, in
    al1_in: float  # roll angle of gear 1 at first contact, rad
    al1_range: float  # roll-angle span of one tooth contact, mesh 1, rad
    al1_start: float  # roll angle at phi_T = 0, mesh 1, rad
    al2_in: float
    al2_range: float
    al2_start: float
    istot: float  # train inertia referred to the escape wheel, in*lbf*s^2


class FuzeAngles(NamedTuple):
    """Fuze-body angles in radians (see the module docstring)."""

    gamma2: float
    gamma3p: float
    gamma3: float
    gamma4p: float
    gamma4: float
    delta2: float
    delta3: float
    delta4: float
    beta1: float
    beta2: float
    beta3: float
    gamma_pp: float


def _acos_checked(x: float, what: str, where: str) -> float:
    if not -1.0 <= x <= 1.0:
        raise SceneError(
            f"the pivot distances cannot form the triangle for {what} (cosine {x:.4f} is outside [-1, 1]); "
            "check r1..r4, a and the pitch radii",
            where,
        )
    return math.acos(x)


def fuze_angles(
    *, r1: float, r2: float, r3: float, r4: float, a: float, c1: float, c2: float, configuration: int, where: str
) -> FuzeAngles:
    """Triangle geometry of the pivots on the fuze body.

    Parameters
    ----------
    r1, r2, r3, r4
        Distances of the rotor, gear-2, escape-wheel and pallet pivots from the spin axis.
    a
        Escape-wheel to pallet pivot distance.
    c1, c2
        Centre distances of mesh 1 (rotor/pinion 2) and mesh 2 (gear 2/pinion 3).
    configuration
        1 (train winds counter-clockwise) or 2 (clockwise, the M739 layout).
    where
        Scene location for error messages.

    Returns
    -------
    FuzeAngles
        All angles in radians.
    """
    s6 = 1.0 if configuration == 1 else -1.0
    g2 = s6 * _acos_checked((r1**2 + r2**2 - c1**2) / (2 * r1 * r2), "rotor / gear 2 / spin axis", where)
    g3p = _acos_checked((r2**2 + r3**2 - c2**2) / (2 * r2 * r3), "gear 2 / escape wheel / spin axis", where)
    g3 = g2 + s6 * g3p
    g4p = _acos_checked((r3**2 + r4**2 - a**2) / (2 * r3 * r4), "escape wheel / pallet / spin axis", where)
    g4 = g3 + s6 * g4p
    d2 = _acos_checked((c1**2 + r1**2 - r2**2) / (2 * r1 * c1), "mesh 1 centre line", where)
    d3 = _acos_checked((c2**2 + r2**2 - r3**2) / (2 * r2 * c2), "mesh 2 centre line", where)
    d4 = _acos_checked((a**2 + r3**2 - r4**2) / (2 * a * r3), "escapement centre line", where)
    b1 = math.pi - s6 * d2
    b2 = g2 + math.pi - s6 * d3
    b3 = g3 + math.pi - s6 * d4
    gpp = d4 + g4p if configuration == 1 else 2 * math.pi - d4 - g4p
    return FuzeAngles(g2, g3p, g3, g4p, g4, d2, d3, d4, b1, b2, b3, gpp)


def mesh_limits(base_driver: float, base_driven: float, theta: float, outside_driver: float, outside_driven: float):
    """Roll angles of the driving gear at the first and last point of tooth contact.

    The roll angle is the driver's rotation measured so that ``roll * base_driver`` is the
    distance from the driver's base-circle tangency point to the contact point along the
    line of action.  Contact starts where the driven tooth's tip circle crosses the line
    and ends where the driver's tip circle does.

    Returns
    -------
    (roll_in, roll_fin) : tuple of float, rad
    """
    line = (base_driver + base_driven) * math.tan(theta)
    roll_in = (line - math.sqrt(outside_driven**2 - base_driven**2)) / base_driver
    roll_fin = math.sqrt(outside_driver**2 - base_driver**2) / base_driver
    return roll_in, roll_fin


def build_constants(v: Mapping[str, float], n: Mapping[str, int], where: str) -> Constants:
    """Pack a parameter set (inch-lbf-s-rad values) into :class:`Constants`.

    Parameters
    ----------
    v
        Parameter values by short name (``a``, ``mu``, ``spin`` in rad/s, ...), already in
        the report's units.
    n
        Integer structure: ``n`` (escape-wheel teeth), ``nt``, ``configuration`` and the
        tooth counts ``ng1, ng2, np2, np3``.
    where
        Scene location used in error messages.
    """
    c1 = v["caprp1"] + v["rp2"]
    c2 = v["caprp2"] + v["rp3"]
    ang = fuze_angles(
        r1=v["r1"], r2=v["r2"], r3=v["r3"], r4=v["r4"], a=v["a"], c1=c1, c2=c2,
        configuration=n["configuration"], where=where,
    )
    omega = abs(v["spin"])
    n31 = n["np2"] * n["np3"] / (n["ng1"] * n["ng2"])
    n32 = -n["np3"] / n["ng2"]
    al1_in, al1_fin = mesh_limits(v["caprb1"], v["rb2"], v["theta1"], v["capro1"], v["ro2"])
    al2_in, al2_fin = mesh_limits(v["caprb2"], v["rb3"], v["theta2"], v["capro2"], v["ro3"])
    for name, lo, hi in (("mesh 1", al1_in, al1_fin), ("mesh 2", al2_in, al2_fin)):
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            raise SceneError(
                f"{name}: the tooth contact interval is empty (roll angles {lo:.4g} .. {hi:.4g} rad); "
                "check the base and outside radii", where,
            )
    return Constants(
        a=v["a"], b=v["b"], c=v["c"], alpha_en=v["alphen"], alpha_ex=v["alphex"], lam=v["lambda"],
        pitch=2 * math.pi / n["n"], nt=float(n["nt"]), erest=v["restitution"],
        m1=v["m1"], mp=v["mp"], i1=v["i1"], i2=v["i2"], i3=v["i3"], ip=v["ip"],
        rc1=v["rc1"], rcp=v["rcp"], rhop=v["rhop"], rho1=v["rho1"], rho2=v["rho2"], rho3=v["rho3"],
        r1=v["r1"], r4=v["r4"],
        omega=omega, mu=abs(v["mu"]), mu1=v["mu1"], phi1c=v["phi1c"], psic0=v["psicc"],
        phi_cut=v["phi_cut"], capture_speed=v["capture_speed"],
        n31=n31, n32=n32, t2=v["m2"] * v["r2"] * omega**2, t3=v["m3"] * v["r3"] * omega**2,
        gamma2=ang.gamma2, gamma3=ang.gamma3, beta1=ang.beta1, beta2=ang.beta2, beta3=ang.beta3,
        gamma_pp=ang.gamma_pp, theta1=v["theta1"], theta2=v["theta2"],
        caprb1=v["caprb1"], caprb2=v["caprb2"], rb2=v["rb2"], rb3=v["rb3"],
        d1=(v["caprb1"] + v["rb2"]) * math.tan(v["theta1"]),
        d2=(v["caprb2"] + v["rb3"]) * math.tan(v["theta2"]),
        al1_in=al1_in, al1_range=al1_fin - al1_in, al1_start=al1_in + v["j1"] * (al1_fin - al1_in),
        al2_in=al2_in, al2_range=al2_fin - al2_in, al2_start=al2_in + v["j2"] * (al2_fin - al2_in),
        istot=v["i3"] + v["i2"] * n32**2 + v["i1"] * n31**2,
    )
