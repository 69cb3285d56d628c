"""Simulated turns-to-arm readings at known parameter values, for recovery tests."""

from __future__ import annotations

import math
from typing import Mapping, Sequence

import numpy as np

from ..core.errors import FitError
from .data import TurnsData
from .problem import FIT_STEP
from .scene import VergeScene
from .simulate import forward

__all__ = ["synthetic_turns"]


def synthetic_turns(scene: VergeScene, truth: Mapping[str, float], spins_rpm: Sequence[float], sd: float, *,
                    seed: int, step: float = FIT_STEP) -> TurnsData:
    """One reading ``turns_to_arm + Normal(0, sd)`` per spin rate, at the true parameter values.

    Parameters
    ----------
    scene : VergeScene
        Everything not in ``truth`` is the scene's (ties such as ``mu1 = "mu"`` follow the
        true value of the parameter they are tied to).
    truth : mapping
        True values by dotted name (``{"verge.mu": 0.12}``).
    spins_rpm : sequence of float
        Spin rate of each reading (rpm).
    sd : float
        Standard deviation of the noise (turns); stored as the readings' ``sd``.
    seed : int
        Seeds the noise.
    step : float
        RK4 step of the simulation (rad of spin).

    Raises
    ------
    FitError
        The mechanism does not arm at the true values.
    """
    vals = dict(scene.params.values())
    vals.update(truth)
    for p in scene.params:
        if p.tie is not None and p.name not in truth:
            vals[p.name] = p.tie[1] * vals[p.tie[0]]
    rng = np.random.default_rng(seed)
    turns = []
    for rpm in spins_rpm:
        p = forward(scene, dict(vals, **{"verge.spin": rpm * math.pi / 30}), step=step)
        if p.status != "armed":
            raise FitError(f"the true parameters {dict(truth)} do not arm at {rpm} rpm ({p.status})", "truth")
        turns.append(p.turns_to_arm + rng.normal(0.0, sd))
    n = len(turns)
    return TurnsData(np.asarray(spins_rpm, float), np.array(turns), np.full(n, float(sd)),
                     tuple(f"{rpm:g} rpm" for rpm in spins_rpm),
                     f"synthetic: truth {dict(truth)}, sd {sd} turns, seed {seed}")
