"""Instantaneous quantities at a given state, for checks against printed program output.

These evaluate the same compiled functions the integrator uses, at a state the caller
chooses (angles in rad, speeds in rad/s; forces returned in lbf, lengths in inches).
"""

from __future__ import annotations

import math
from typing import Mapping

from ..core.errors import SceneError
from .coefficients import mesh_phase
from .dynamics import coupled_eval, coupled_signs, free_eval
from .impact import impact_map, normal_speeds
from .scene import VergeScene

__all__ = ["coupled_state", "free_state", "impact"]


def _side(side: str) -> float:
    if side not in ("entrance", "exit"):
        raise SceneError(f"side must be 'entrance' or 'exit', got side = {side!r}")
    return 1.0 if side == "entrance" else -1.0


def coupled_state(scene: VergeScene, phi: float, phidot: float = 0.0, phi_total: float = 0.0, *,
                  side: str = "entrance", at_rest_signs: str = "listing") -> Mapping[str, float]:
    """Acceleration and contact forces in coupled motion at one state.

    Parameters
    ----------
    phi, phidot, phi_total
        Escape-wheel angle (rad, active side's reference), speed (rad/s) and cumulative
        angle (rad; fixes rotor angle and mesh phases).
    side
        ``"entrance"`` or ``"exit"``.
    at_rest_signs
        How friction signs are chosen when ``phidot == 0``: ``"listing"`` takes +1 for a
        zero sliding speed and a zero verge speed, as the report's program does (this is
        what its first printed line used); ``"motion"`` takes the signs of the motion that
        is about to start forwards, as the integrator does.

    Returns
    -------
    dict
        ``phiddot`` (rad/s^2), ``psi`` (rad), ``psidot`` (rad/s), ``psiddot``, ``g`` (in),
        ``F23``, ``F12``, ``PN``, ``PNPSI`` (lbf).
    """
    k = scene.constants()
    s = _side(side)
    n1, n2, s1, s2 = mesh_phase(k, phi_total)
    if phidot == 0.0 and at_rest_signs == "listing":
        s4 = s5 = 1.0
    elif at_rest_signs in ("listing", "motion"):
        s4, s5 = coupled_signs(k, s, phi, phidot, 1.0)
    else:
        raise SceneError(f"at_rest_signs must be 'listing' or 'motion', got at_rest_signs = {at_rest_signs!r}")
    mus = 1.0 if phidot >= 0 else -1.0
    r = coupled_eval(k, s, phi, phidot, phi_total, n1, n2, s1, s2, s4, s5, mus, 0.0, 0.0)
    phidd, psi, psid, psidd, f23, f12, pn, pnv, g = r[:9]
    return {"phiddot": phidd, "psi": psi, "psidot": psid, "psiddot": psidd, "g": g, "F23": f23, "F12": f12,
            "PN": pn, "PNPSI": pnv}


def free_state(scene: VergeScene, phi: float, phidot: float, psi: float, psidot: float, phi_total: float, *,
               side: str = "exit") -> Mapping[str, float]:
    """Accelerations and mesh forces in free motion at one state.

    Returns ``phiddot``, ``psiddot`` (rad/s^2), ``FF23``, ``FF12`` (lbf).
    """
    k = scene.constants()
    s = _side(side)
    n1, n2, s1, s2 = mesh_phase(k, phi_total)
    s5 = 1.0 if psidot >= 0 else -1.0
    mus = 1.0 if phidot >= 0 else -1.0
    phidd, psidd, f23, f12, _ok1, _ok2 = free_eval(k, s, phidot, psi, psidot, phi_total, n1, n2, s1, s2, s5, mus, False,
                                                   False, 0.0, 0.0)
    return {"phiddot": phidd, "psiddot": psidd, "FF23": f23, "FF12": f12}


def impact(scene: VergeScene, phi: float, psi: float, phidot: float, psidot: float, *,
           side: str = "exit", restitution: float | None = None) -> Mapping[str, float]:
    """Apply the impact law to a pre-impact state.

    Returns the speeds after impact (``phidot``, ``psidot``, rad/s) and the normal speeds
    of tooth and face before (``VS``, ``VP``) and after (``VS_after``, ``VP_after``), in/s.
    """
    k = scene.constants()
    s = _side(side)
    alpha = k.alpha_en if s > 0 else k.alpha_ex
    e = k.erest if restitution is None else float(restitution)
    if not 0.0 <= e <= 1.0 or math.isnan(e):
        raise SceneError(f"restitution must lie in [0, 1], got restitution = {restitution!r}")
    vs, vp, _a, _d = normal_speeds(k, alpha, phi, psi, phidot, psidot)
    pf, qf = impact_map(k, alpha, phi, psi, phidot, psidot, e)
    vs_f, vp_f, _a, _d = normal_speeds(k, alpha, phi, psi, pf, qf)
    return {"phidot": pf, "psidot": qf, "VS": vs, "VP": vp, "VS_after": vs_f, "VP_after": vp_f}
