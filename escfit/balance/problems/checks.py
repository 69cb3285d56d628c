"""Structural checks of balance-wheel fits: Monday's phase convention, residual structure, end of motion.

Two cases matter for balance-wheel curves.  With phase switching (Monday's convention) a
single unit curve is geometric and fixes only ``C/omega0`` and his combined ``K``; Coulomb
``R`` and the escapement magnitudes trade off exactly along ``K = const``.  With angle
switching the impulse gain per swing falls like 1/A while the Coulomb loss is constant and
the viscous loss grows like A, so a decay from overbank fixes C, R and X separately.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from ..monday.charts import Pulse, k_value

__all__ = ["phase_mode_warning", "monday_k", "end_of_motion"]


def phase_mode_warning(problem) -> list[str]:
    """The structural non-identifiability of Monday's phase convention, when it applies."""
    if problem.scene.switching != "phase" or len(problem.curves) > 1:
        return []
    free = set(problem.names)
    forcing = {n for n in free if n == "coulomb.R" or (n.startswith("escapement[") and n.endswith(".X"))}
    if len(forcing) < 2:
        return []
    return ["phase switching: a single unit curve is exactly geometric and determines only C/omega0 and Monday's "
            f"combined K; {', '.join(sorted(forcing))} trade off exactly along K = const (see the K posterior)"]


def monday_k(problem, vals: Mapping[str, float]) -> float:
    """Monday's combined K of a parameter set (phase convention, symmetric windows only)."""
    sys = problem.scene.system(vals)
    w0sq = sys.omega0**2
    pulses = [Pulse(-math.pi / 2, math.pi / 2, -sys.field("r") / w0sq)]
    windows = zip(sys.field("w_lo"), sys.field("w_hi"), sys.field("w_x"), sys.field("w_dir"))
    pulses += [Pulse(lo, hi, x / w0sq) for lo, hi, x, d in windows if d == 0]
    return k_value(sys.field("c") / sys.omega0, pulses)


def end_of_motion(problem, best: Mapping[str, float]) -> list[str]:
    """Waveform fits: does the model still swing as much as the record over its last period?

    Friction decides when a balance stops; a model whose friction law is wrong comes to rest
    too early or too late, which correlated-noise likelihoods can otherwise absorb.
    """
    t = getattr(problem, "sample_time", None)
    if t is None or getattr(problem, "period", None) is None:
        return []
    last = t >= t[-1] - float(problem.period)
    if np.count_nonzero(last) < 4:
        return []
    y, e = problem.observed[last], problem.expected(best)[last]
    swing_data, swing_model = float(np.ptp(y)), float(np.ptp(e))
    # the range of n noisy samples alone: about 2 sqrt(2 ln n) noise scales (6 for a hundred)
    n = int(np.count_nonzero(last))
    noise = (2.0 * math.sqrt(2.0 * math.log(n)) + 2.0) * float(best.get("observation.sigma", 0.0))
    if swing_data > noise and not 0.5 <= swing_model / swing_data <= 2.0:
        unit = getattr(problem, "reading_units", "rad")
        k, label = (math.degrees(1.0), "deg") if unit == "rad" else (1.0, unit)
        return [f"over the last period of the record the model swings {k * swing_model:.3g} {label} where the "
                f"recording swings {k * swing_data:.3g} {label}: the model's friction ends the motion "
                f"{'too early' if swing_model < swing_data else 'too late'} (a friction law the scene lacks?)"]
    return []
