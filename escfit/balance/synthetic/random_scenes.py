"""Random balance scenes for comparing solvers, one line per physical effect.

A scene is drawn on a scale (natural frequency ``w0``, release angle ``a0`` and the spring's
acceleration there, ``unit = w0**2 * a0``) and then each effect of :data:`EFFECTS` is added
with its probability by its own generator, which returns the effect's TOML tables.  Adding an
effect to the comparison is one entry::

    EFFECTS["drag"] = Effect(0.3, lambda rng, s: f"[effects.drag]\\nD = {s.w0 / s.a0 * rng.uniform(0, 0.1)!r}\\n")

Damping is drawn so that a fixed share of scenes lies near critical damping
(``C = 2 w0 (1 + d)`` with ``|d|`` from 1e-12 to 1e-3, both signs), where solvers have
disagreed on whether the balance creeps to rest or turns once more.

The generator is deterministic for a given :class:`numpy.random.Generator` state; the scenes
are TOML text, loaded with :func:`escfit.load_scene`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

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


def _num(x: float) -> str:
    return repr(float(x))


def near_critical_damping(rng: np.random.Generator, s: Scale) -> float:
    """C within 1e-12 to 1e-3 (relative, either side) of critical damping 2 w0."""
    d = 10.0 ** rng.uniform(-12, -3) * rng.choice([-1.0, 1.0])
    return 2.0 * s.w0 * (1.0 + d)


def _viscous(rng: np.random.Generator, s: Scale) -> str:
    kind = rng.uniform()
    if kind < 0.25:
        c = near_critical_damping(rng, s)
    elif kind < 0.85:
        c = s.w0 * rng.uniform(0.0, 0.3)
    else:
        c = s.w0 * rng.uniform(0.3, 6.0)
    return f"[effects.viscous]\nC = {_num(c)}\n"


def _coulomb(rng: np.random.Generator, s: Scale) -> str:
    """Sliding friction R; in a third of the scenes static friction R_static up to 3 R above it."""
    r = s.unit * 10.0 ** rng.uniform(-4, math.log10(0.3))
    static = f"R_static = {_num(r * rng.uniform(1.0, 3.0))}\n" if rng.uniform() < 1.0 / 3.0 else ""
    return f"[effects.coulomb]\nR = {_num(r)}\n{static}"


def _window(lo: float, hi: float, kind: str, x: float, swings: str = "both") -> str:
    return (f'[[effects.escapement]]\nkind = "{kind}"\nfrom = {_num(lo)}\nto = {_num(hi)}\nX = {_num(x)}\n'
            f'swings = "{swings}"\n')


def _escapement(rng: np.random.Generator, s: Scale) -> str:
    """A lever escapement's unlocking and impulse windows, both sides of the swing frame."""
    lift = s.a0 * rng.uniform(0.05, 0.4)
    unlock = lift * rng.uniform(1.2, 2.0)
    out = _window(-lift, lift, "impulse", s.unit * rng.uniform(0.2, 8.0))
    if rng.uniform() < 0.7:
        out += _window(-unlock, -lift, "unlock", s.unit * rng.uniform(0.0, 0.5))
    return out


def _hairspring(rng: np.random.Generator, s: Scale) -> str:
    """A piecewise-linear spring of three pieces, the central one of frequency ``w0``."""
    b1, b2 = s.a0 * rng.uniform(-1.2, -0.1), s.a0 * rng.uniform(0.1, 1.2)
    w = [s.w0 * rng.uniform(0.7, 1.4), s.w0, s.w0 * rng.uniform(0.7, 1.4)]
    return f"[effects.hairspring]\nangles = [{_num(b1)}, {_num(b2)}]\nomega0 = [{', '.join(map(_num, w))}]\n"


def _banking(rng: np.random.Generator, s: Scale) -> str:
    angle = s.a0 * rng.uniform(1.0, 1.4)
    return f"[effects.banking]\nangle = {_num(angle)}\nrestitution = {_num(rng.choice([0.0, 0.3, 0.7, 1.0]))}\n"


def _drag(rng: np.random.Generator, s: Scale) -> str:
    """Quadratic drag taking up to about 13 % of the amplitude off a half swing (``4 D A / 3``)."""
    return f"[effects.drag]\nD = {_num(rng.uniform(0.0, 0.1) / s.a0)}\n"


def _stiffening(rng: np.random.Generator, s: Scale) -> str:
    """A cubic stiffening up to doubling the spring's pull at the release angle."""
    return f"[effects.stiffening]\nk3 = {_num(rng.uniform(0.0, 1.0) / (s.a0 * s.a0))}\n"


def _viscous_drift(rng: np.random.Generator, s: Scale) -> str:
    """Damping that grows by up to 5 % a cycle as the envelope decays."""
    r1, r2 = rng.uniform(0.0, 0.05), rng.uniform(0.0, 0.05)
    return f"[effects.viscous_drift]\nthresholds = [0.5, 0.1]\nrates = [{_num(r1)}, {_num(r2)}, 0.0]\n"


# name -> Effect; the order is the order of the tables in the scene
EFFECTS: dict[str, Effect] = {
    "viscous": Effect(0.9, _viscous),
    "coulomb": Effect(0.7, _coulomb),
    "escapement": Effect(0.5, _escapement),
    "hairspring": Effect(0.25, _hairspring),
    "banking": Effect(0.2, _banking),
}

#: Every registered effect (:data:`escfit.balance.effects.EFFECTS`), the smooth ones and the
#: damping drift too: scenes drawn from these need an integrator (drag, stiffening) or the closed
#: form (drift) for some of them, and the solvers that cannot run one refuse it.
ALL_EFFECTS: dict[str, Effect] = {**EFFECTS, "viscous_drift": Effect(0.1, _viscous_drift),
                                  "stiffening": Effect(0.2, _stiffening), "drag": Effect(0.25, _drag)}


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
        head = f"[oscillator]\ntheta0 = {_num(s.a0 * rng.choice([1.0, -1.0]))}\n"
    else:
        head = f"[oscillator]\nomega0 = {_num(s.w0)}\ntheta0 = {_num(s.a0 * rng.choice([1.0, -1.0]))}\n"
    text = f'model = "balance"\nswitching = "angle"\n{head}[run]\nswings = {int(swings)}\n{body}'
    return text, chosen
