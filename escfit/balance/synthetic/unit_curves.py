"""Synthetic recordings: what a recorder would have written for a scene (with known truth).

Each recorder has a matching reader, so every format has a round trip.
"""

from __future__ import annotations

import math

import numpy as np

from .. import BalanceScene, solve
from ...core.errors import SceneError
from ..observation import AmplitudeObservation, NotchObservation
from ..observation.notches import NOTCH_READINGS, notch_count
from ...core.params import Param
from ...analysis.recordings import UnitCurve
from .runs import complete

__all__ = ["record_unit_curve"]


def record_unit_curve(scene: BalanceScene, *, every: int = 4, duration: float | None = None,
                      swings: int | None = None, notch_deg: float | None = None, sigma: float = 0.0,
                      offset: float = 0.0, seed: int = 0, include_release: bool = True,
                      solver: str | None = None, notch_reading: str = "counted") -> UnitCurve:
    """Simulate amplitude readings of a unit curve.

    Parameters
    ----------
    scene
        Balance scene giving the truth.
    every
        Read every n-th half swing (4 = every second cycle, as Monday did).
    duration, swings
        Stop reading after ``duration`` seconds or ``swings`` half swings (default: the
        scene's ``[run] swings``).
    notch_deg
        Quantise to whole notches of this angle (deg); ``None`` for continuous readings.
    sigma
        Reading noise (rad): Gaussian for continuous readings, jitter before quantising.
    offset
        Zero offset of the scale (rad).
    seed
        Seed of the noise generator.
    include_release
        Also record the release amplitude as swing 0.
    solver
        Solver giving the true turning points (default: the scene's, see
        :func:`escfit.balance.default_solver`).
    notch_reading
        How notch readings are taken (with ``notch_deg``): ``"counted"``, the marks passed,
        ``floor(A/notch)``, or ``"nearest"``, the mark nearest the turning point,
        ``floor(A/notch + 1/2)``; see :mod:`escfit.balance.observation.notches`.  Recorded in
        the curve's metadata.
    """
    if every < 1:
        raise SceneError(f"every must be >= 1, got {every}")
    if notch_reading not in NOTCH_READINGS:
        raise SceneError(f"notch_reading must be one of {', '.join(map(repr, NOTCH_READINGS))}, got {notch_reading!r}")
    n = swings or scene.swings
    tr = complete(solve(scene, solver, swings=n), scene)
    k = np.arange(every, tr.amplitude.size + 1, every)
    if duration is not None:
        k = k[tr.time[k - 1] <= duration]
    theta = tr.theta_turn[k - 1]
    if include_release:
        k = np.concatenate([[0], k])
        theta = np.concatenate([[scene.params["oscillator.theta0"].value], theta])
    rng = np.random.default_rng(seed)
    values = {"observation.sigma": max(sigma, 1e-300), "observation.offset": offset}
    dummy = (Param("observation.sigma", sigma), Param("observation.offset", offset))
    if notch_deg is not None:
        obs = NotchObservation(math.radians(notch_deg), dummy, notch_reading)
        y = obs.sample(theta, values, rng) if sigma > 0 else notch_count(obs.expected(theta, values), obs.notch,
                                                                         notch_reading)
        notch, kind = obs.notch, "notches"
    else:
        obs = AmplitudeObservation("gaussian", dummy)
        y = obs.sample(theta, values, rng) if sigma > 0 else obs.expected(theta, values)
        notch, kind = math.nan, "amplitude"
    meta = {"generated_by": "escfit.balance.synthetic.unit_curves.record_unit_curve", "scene": scene.where, "seed": str(seed),
            "every": str(every), "sigma_rad": repr(sigma), "offset_rad": repr(offset)}
    if notch_deg is not None:
        meta["notch_reading"] = notch_reading
    return UnitCurve(k.astype(np.int64), y, kind, notch, unit=np.full(k.size, "", dtype=str), time=None,
                     source=f"<synthetic from {scene.where}>", meta=meta)
