"""Random balance scenes for comparing solvers, one line per physical effect.

A scene is drawn on a scale (natural frequency ``w0``, release angle ``a0`` and the spring's
acceleration there, ``unit = w0**2 * a0``) and then each effect of :data:`EFFECTS` is added
with its probability by the effect's own generator (its ``random(rng, scale)``, in its module),
which returns the effect's TOML tables.  A new effect joins the comparison with one entry of
probability here.

Damping is drawn so that a fixed share of scenes lies near critical damping
(``C = 2 w0 (1 + d)`` with ``|d|`` from 1e-12 to 1e-3, both signs), where solvers have
disagreed on whether the balance creeps to rest or turns once more.

The generator is deterministic for a given :class:`numpy.random.Generator` state; the scenes
are TOML text, loaded with :func:`escfit.load_scene`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..effects.base import toml_number

__all__ = ["Scale", "Effect", "EFFECTS", "ALL_EFFECTS", "random_scene", "near_critical_damping"]


@dataclass(frozen=True)
class Scale:
    """The scales a scene is drawn on.

    Attributes
    ----------
    w0 : float
        Natural frequency of the central spring piece, rad/s.
    a0 : float
        Release amplitude |theta0|, rad.
    unit : float
        Spring acceleration at the release angle, ``w0**2 * a0`` (rad/s^2): the scale of
        friction and escapement torques per inertia.
    """

    w0: float
    a0: float

    @property
    def unit(self) -> float:
        return self.w0 * self.w0 * self.a0


@dataclass(frozen=True)
class Effect:
    """One physical effect of the generator: the probability a scene has it and its tables."""

    probability: float
    tables: Callable[[np.random.Generator, Scale], str]


def near_critical_damping(rng: np.random.Generator, s: Scale) -> float:
    """C within 1e-12 to 1e-3 (relative, either side) of critical damping 2 w0."""
    from ..effects.viscous import near_critical_damping as near

    return near(rng, s.w0)


def _drawn(probabilities: dict[str, float]) -> dict[str, Effect]:
    """The registered effects named, each with its probability and its own generator (``random``)."""
    from ..effects import EFFECTS as REGISTERED

    return {key: Effect(p, REGISTERED[key].random) for key, p in probabilities.items()}


# name -> Effect; the order is the order of the tables in the scene (and of the draws)
EFFECTS: dict[str, Effect] = _drawn({"viscous": 0.9, "coulomb": 0.7, "escapement": 0.5, "hairspring": 0.25,
                                     "banking": 0.2})

#: Every registered effect (:data:`escfit.balance.effects.EFFECTS`), the smooth ones and the
#: damping drift too: scenes drawn from these need an integrator (drag, stiffening) or the closed
#: form (drift) for some of them, and the solvers that cannot run one refuse it.
ALL_EFFECTS: dict[str, Effect] = {**EFFECTS, **_drawn({"viscous_drift": 0.1, "stiffening": 0.2, "drag": 0.25})}


def random_scene(rng: np.random.Generator, *, swings: int = 30, effects: dict[str, Effect] | None = None,
                 angle_scales: tuple[float, ...] = (1e-6, 1e-3, 1.0), time_scales: tuple[float, ...] = (1e-2, 1.0, 1e3)
                 ) -> tuple[str, list[str]]:
    """One random balance scene (angle switching) and the names of the effects it has.

    Parameters
    ----------
    rng
        The generator the scene is drawn with.
    swings
        Half swings to simulate.
    effects
        The effects to draw from (default :data:`EFFECTS`).
    angle_scales, time_scales
        Release amplitudes (rad) and natural frequencies (rad/s, times a factor in [5, 20])
        drawn from: the solvers must agree at every scale.

    Returns
    -------
    text, names
        TOML text of the scene and the effects drawn.
    """
    s = Scale(w0=float(rng.choice(time_scales)) * rng.uniform(5.0, 20.0),
              a0=float(rng.choice(angle_scales)) * rng.uniform(0.05, 3.0))
    chosen = [name for name, e in (effects or EFFECTS).items() if rng.uniform() < e.probability]
    body = "".join((effects or EFFECTS)[name].tables(rng, s) for name in chosen)
    if "hairspring" in chosen:  # the spring's pieces give omega0
        head = f"[oscillator]\ntheta0 = {toml_number(s.a0 * rng.choice([1.0, -1.0]))}\n"
    else:
        head = f"[oscillator]\nomega0 = {toml_number(s.w0)}\ntheta0 = {toml_number(s.a0 * rng.choice([1.0, -1.0]))}\n"
    text = f'model = "balance"\nswitching = "angle"\n{head}[run]\nswings = {int(swings)}\n{body}'
    return text, chosen
