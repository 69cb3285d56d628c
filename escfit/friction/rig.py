"""Geometry and statics of the torsion-wire friction rig.

The rig (Monday 1965, Chapter VI) holds the test pallet at the lower end of a rigid
stylus that hangs from a horizontal torsion wire.  The wire sits at height ``d`` above the
rotating disc and the contact point of the pallet is at distance ``k`` from the wire, so
the contact lies a horizontal distance ``a = sqrt(k**2 - d**2)`` from the point of the disc
directly below the wire.

Taking moments about the wire axis (the wire is perpendicular to the plane that holds the
stylus and the sliding direction):

* the normal load ``w`` (vertical) has lever arm ``a``;
* the friction force ``F`` (horizontal, along the sliding direction) has lever arm ``d``.

The wire twists until its torque balances the sum, and the twist is read with a mirror and
a light beam.  With the disc at rest (calibration) a load ``w_cal`` gives torque
``w_cal * a``.  With the disc turning so that friction opposes the load's moment, a larger
load ``w`` is needed for the *same* beam position: ``w * a - F * d = w_cal * a``.  With
``dw = w - w_cal``::

    F = dw * a / d = dw * sqrt(k**2 / d**2 - 1)
    mu = F / N

where ``N`` is the normal force during the friction reading.  Everything here is SI
(newton, metre, metre per second); the model is linear in ``dw`` so the torsion-wire
stiffness and the optical lever cancel out of ``F``.

Sign convention: ``dw >= 0`` means friction *opposes* the moment of the load (the disc
turns so that the stylus tip is dragged away from below the wire).  Turning the disc the
other way would make ``dw`` negative; the reader refuses such rows so that one file holds
one sense of rotation.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from ..core.errors import SceneError

__all__ = [
    "LOAD_AT",
    "lever_ratio",
    "friction_force",
    "mu_from_reading",
    "predicted_dw",
    "mu_law",
    "load_sd_from_scale",
]

#: Which load the ``load`` column holds.  ``"reading"``: the normal force during the
#: friction reading (Monday's ``w`` in ``F_c = F / w``), so the calibration load is
#: ``w - dw``.  ``"calibration"``: the load that gave the calibration deflection, so the
#: normal force during the reading is ``w + dw``.
LOAD_AT: tuple[str, ...] = ("reading", "calibration")


def lever_ratio(k, d):
    """Ratio ``a / d = sqrt(k**2 / d**2 - 1)`` of the two lever arms about the wire.

    Parameters
    ----------
    k
        Distance from the torsion wire to the contact point, m (> d).
    d
        Height of the torsion wire above the disc surface, m (> 0).

    Returns
    -------
    float or ndarray
        Dimensionless ratio; ``F = dw * lever_ratio(k, d)``.  NaN where ``d >= k`` or
        ``d <= 0`` (no real geometry), so vectorised callers can reject those points.
    """
    k = np.asarray(k, dtype=float)
    d = np.asarray(d, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        ok = (d > 0) & (k > d)
        ratio = np.sqrt(np.where(ok, (k / np.where(d > 0, d, 1.0)) ** 2 - 1.0, np.nan))
    return ratio if ratio.ndim else float(ratio)


def friction_force(dw, k, d):
    """Friction force ``F = dw * sqrt(k**2/d**2 - 1)`` in N from the extra load ``dw`` in N."""
    return np.asarray(dw, dtype=float) * lever_ratio(k, d)


def mu_from_reading(load, dw, k, d, load_at: Literal["reading", "calibration"] = "reading"):
    """Friction coefficient of one reading (or an array of readings).

    Parameters
    ----------
    load
        Load ``w`` in N, meaning set by ``load_at``.
    dw
        Extra load in N needed to reach the calibration deflection while sliding (>= 0).
    k, d
        Rig geometry in m, see :func:`lever_ratio`.
    load_at
        ``"reading"`` (normal force = ``load``) or ``"calibration"`` (normal force =
        ``load + dw``).

    Returns
    -------
    float or ndarray
        ``mu = F / N``, dimensionless.
    """
    load = np.asarray(load, dtype=float)
    dw = np.asarray(dw, dtype=float)
    normal = _normal_force(load, dw, load_at)
    return friction_force(dw, k, d) / normal


def _normal_force(load, dw, load_at):
    if load_at == "reading":
        return load
    if load_at == "calibration":
        return load + dw
    raise SceneError(f"load_at must be one of {LOAD_AT}, got load_at = {load_at!r}")


def predicted_dw(load, mu, k, d, load_at: Literal["reading", "calibration"] = "reading"):
    """Extra load ``dw`` in N the rig needs for a friction coefficient ``mu``.

    The inverse of :func:`mu_from_reading`.  With ``load_at="reading"`` it is
    ``dw = mu * w / r`` with ``r = a / d``; with ``load_at="calibration"`` the normal force
    itself contains ``dw`` and ``dw = mu * w / (r - mu)``, which needs ``mu < r`` (else
    friction would out-lever the load and no finite ``dw`` balances it: NaN is returned).

    Parameters
    ----------
    load
        Load ``w`` in N (meaning set by ``load_at``).
    mu
        Friction coefficient(s), broadcast against ``load``.
    k, d
        Rig geometry in m, broadcast against ``load``.
    """
    r = lever_ratio(k, d)
    load = np.asarray(load, dtype=float)
    mu = np.asarray(mu, dtype=float)
    if load_at == "reading":
        return mu * load / r
    if load_at == "calibration":
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(mu < r, mu * load / (r - mu), np.nan)
    raise SceneError(f"load_at must be one of {LOAD_AT}, got load_at = {load_at!r}")


def mu_law(mu0, load, speed, *, mu_w=0.0, mu_v=0.0, load_ref=0.0, speed_ref=0.0):
    """Friction coefficient under the optional linear laws.

    ``mu = mu0 + mu_w * (w - load_ref) + mu_v * (v - speed_ref)``; with both references at
    zero this is ``mu0 + mu1*w + mu_v*v``.  ``mu0`` is the coefficient at the reference
    load and speed.

    Parameters
    ----------
    mu0
        Coefficient at the reference point, dimensionless.
    load
        Normal load in N.
    speed
        Sliding speed in m/s (ignored when ``mu_v`` is 0; may then be NaN).
    mu_w
        Change of mu per newton of normal load, 1/N.
    mu_v
        Change of mu per m/s of sliding speed, s/m.
    load_ref, speed_ref
        Reference load (N) and speed (m/s) at which ``mu == mu0``.
    """
    out = np.asarray(mu0, dtype=float) + np.asarray(mu_w, dtype=float) * (np.asarray(load) - load_ref)
    if np.any(np.asarray(mu_v) != 0):
        out = out + np.asarray(mu_v, dtype=float) * (np.asarray(speed) - speed_ref)
    return out


def load_sd_from_scale(resolution: float, slope: float, settings: int = 2) -> float:
    """Standard deviation of ``dw`` (N) caused by reading the light spot to ``resolution``.

    The spot is read to the nearest scale mark, i.e. a rounding error uniform over one
    ``resolution`` step (standard deviation ``resolution / sqrt(12)``).  Through the
    calibration slope (spot travel per newton) this is a load error.  A ``dw`` reading
    matches the spot position of a calibration setting, so it carries ``settings``
    independent rounding errors (2 by default: one when calibrating, one when sliding).

    Parameters
    ----------
    resolution
        Smallest readable step of the spot on the scale, m.
    slope
        Spot travel per unit load from the calibration plot, m/N (> 0).
    settings
        Number of independent spot settings that enter one ``dw``.

    Returns
    -------
    float
        Standard deviation of a single ``dw`` reading, N.
    """
    if not (resolution > 0 and slope > 0 and settings >= 1):
        raise SceneError(f"resolution and slope must be positive and settings >= 1, got resolution = "
                         f"{resolution!r}, slope = {slope!r}, settings = {settings!r}")
    return math.sqrt(settings / 12.0) * resolution / slope
