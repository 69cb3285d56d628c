"""The first period and the halving time of a fitted free decay, from runs of the model itself.

The plain sentences (:mod:`escfit.balance.plain`) split the loss of a half swing into each
effect's part to first order in the damping.  Where that first-order loss exceeds
:data:`MODEL_ABOVE` of the amplitude, its error (of the order of the loss itself) shows in the
printed figures: a pendulum released at 146 deg with Q = 28 at small amplitude loses 22 % of
its amplitude in its first period, where the first-order sum says 36 % and a linear spring's
formulas 11 %.  There the loss of the first period and the time the amplitude takes to halve
are read from runs of the scene's own solver, one per posterior draw (at most
:data:`MODEL_DRAWS` draws, evenly spaced), each from the release at rest.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

__all__ = ["ModelDecay", "model_decay", "MODEL_ABOVE", "MODEL_DRAWS", "MODEL_SWINGS"]

#: a first-order loss per half swing above this share of the amplitude is read from the model's runs
MODEL_ABOVE = 0.02
#: posterior draws run (evenly spaced through the draws)
MODEL_DRAWS = 200
#: half swings run at most to find where the amplitude halves
MODEL_SWINGS = 400


@dataclass(frozen=True)
class ModelDecay:
    """The model's own decay at the draws run.

    Attributes
    ----------
    first_period : ndarray
        Share of the release amplitude lost by the end of the first period (0-1); a swing that
        stops sooner counts from its rest angle.
    halving : ndarray
        Seconds from the release until a turning point's amplitude is half the release's
        (interpolated linearly between turning points); NaN where it does not within
        :data:`MODEL_SWINGS` half swings or stops first.
    at_half : ndarray
        Share of the amplitude lost in the period that starts at the first turning point at or
        below half the release's amplitude (NaN where there is none, or the swing stops in it);
        ``half_amplitude`` that turning point's amplitude (rad, or m).
    """

    first_period: np.ndarray
    halving: np.ndarray
    at_half: np.ndarray
    half_amplitude: np.ndarray


def _draw_values(scene, draws: Mapping[str, Any], load: str, i: int) -> dict[str, float]:
    """The scene's parameters at draw ``i`` (a load's own where it has one, else the scene's value)."""
    out = {}
    for name, param in scene.params.params.items():
        value = draws.get(name + load, draws.get(name))
        arr = np.asarray(param.value if value is None else value, float)
        out[name] = float(arr.flat[i] if arr.ndim else arr)
    return out


def _one(scene, values: dict[str, float], swings: int) -> tuple[float, float, float, float]:
    """(share lost in the first period, halving time in s, share lost in the period from the first
    turn at half the amplitude, that turn's amplitude) of one run from the release."""
    from .solvers import solve_system

    a0 = abs(values["oscillator.theta0"])
    tr = solve_system(scene.system(values), swings)
    amp = np.asarray(tr.amplitude, float)
    times = np.asarray(tr.time, float)
    rest = abs(float(tr.final[1])) if tr.status == "stopped" and np.isfinite(tr.final[1]) else np.nan
    a2 = amp[1] if amp.size >= 2 else rest
    below = np.flatnonzero(amp <= 0.5 * a0)
    halving = at_half = half_amp = np.nan
    if below.size:
        k = int(below[0])
        a_prev, t_prev = (a0, 0.0) if k == 0 else (amp[k - 1], times[k - 1])
        halving = t_prev + (a_prev - 0.5 * a0) / (a_prev - amp[k]) * (times[k] - t_prev)
        if k + 2 < amp.size:
            at_half, half_amp = 1.0 - amp[k + 2] / amp[k], amp[k]
    return 1.0 - a2 / a0, halving, at_half, half_amp


def model_decay(scene_text: str, draws: Mapping[str, Any], load: str = "", *, share: float) -> ModelDecay | None:
    """The first period's loss and the halving time of the fitted scene, per draw run.

    Parameters
    ----------
    scene_text
        The fit's scene (TOML text, as the results keep it).
    draws
        Every parameter at every draw (canonical units; held ones constant or absent: the
        scene's value).
    load
        A load's suffix (``"[load=2]"``): its per-load parameters are used.
    share
        The first-order loss of the first half swing as a share of the amplitude: the runs go
        ``1.5 / share`` half swings (an exponential decay halves in ``ln 2 / share``, a drag's
        ``A**2`` decay in ``1 / share``), at most :data:`MODEL_SWINGS`.

    Returns
    -------
    ModelDecay or None
        None when the scene cannot be read or run (the sentences then say what they can
        without it).
    """
    from ..core.errors import EscfitError
    from ..core.scene import load_scene

    try:
        scene = load_scene("scene.toml", text=scene_text)
        n = max((np.size(v) for v in draws.values()), default=1)
        picks = np.unique(np.linspace(0, n - 1, min(n, MODEL_DRAWS)).round().astype(int))
        swings = int(min(MODEL_SWINGS, np.ceil(1.5 / max(share, 1e-9)) + 4))
        runs = [_one(scene, _draw_values(scene, draws, load, int(i)), swings) for i in picks]
    except (EscfitError, ValueError, ArithmeticError, KeyError, AttributeError):
        return None
    return ModelDecay(*(np.array(x, float) for x in zip(*runs)))
