"""Synthetic Geneva recordings with known parameters (for tests, studies and shipped examples)."""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from ..core.errors import FitError
from .data import SpeedTrace
from .simulate import forward

__all__ = ["synthetic_trace"]


def synthetic_trace(scene, *, duration: float, interval: float, sd: float, seed: int = 0,
                    values: Mapping[str, float] | None = None) -> SpeedTrace:
    """A driver-speed trace simulated from a scene with Gaussian noise.

    The speeds come from the accurate solver (scipy DOP853, rtol 1e-11), not the rk4 the
    fits use, so a fit does not meet its own discretisation.

    Parameters
    ----------
    scene
        Geneva scene giving the true values (overridden by ``values``).
    duration, interval
        Trace length and sample spacing, s (samples at ``0, interval, ...``).
    sd
        Noise standard deviation, rad/s (recorded as the trace's known ``sd``).
    seed
        Noise seed.
    values
        Parameter values (SI, by name) replacing the scene's.

    Raises
    ------
    FitError
        The true parameters give a run that ends early (the pin locks).
    """
    vals = dict(scene.params.values())
    vals.update(values or {})
    t = np.arange(int(math.floor(duration / interval + 1e-9)) + 1) * interval
    pred = forward(scene.geometry, vals, duration=float(t[-1]), sample_times=t, solver="dop853", with_terminal=False)
    if pred.trajectory.time.size != t.size:
        raise FitError(f"the true parameters give a run that ends early ({pred.trajectory.end_reason})",
                       scene.where)
    noise = np.random.default_rng(seed).normal(0.0, sd, t.size)
    return SpeedTrace(t, pred.trajectory.speed + noise, sd, f"synthetic trace of {scene.where} (seed {seed})")
