"""The three balance models a fleet study compares, written as scene files for one rig.

- ``phase``: Monday's programs (forcing switched at fixed phases of each half cycle);
- ``phase_drift``: the same with his damping drift of Fig. 18 (C grows by 3 %, 1.5 %, 0.5 %
  per cycle while the envelope exp(-int C dt / 2) is above 0.15, 0.03, 0.005);
- ``angle``: the escapement acting at balance angles, banking at the release angle.

All three share one parameterisation, so their fits can be compared reading for reading:
``viscous.C`` (1/s), ``coulomb.R`` (rad/s^2 at the reference load), ``escapement[2].X``
(impulse, rad/s^2 at the reference load; the unlock window is tied to it by ``eps``) and
``fit.kappa`` (growth of R per gram of load), with escapement torques proportional to the load
(the ``[fit.loads]`` table, ``friction = "linear"``).  The reading jitter
``observation.sigma`` (rad) is a nuisance parameter of every fit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["MODELS", "Rig", "POPULATION_PARAMS", "SHORT", "DRIFT_THRESHOLDS", "DRIFT_RATES", "generating_scene",
           "fit_scene", "PRIORS", "START", "load_rule", "kappa_for"]

MODELS = ("phase", "phase_drift", "angle")

#: The parameters a population model describes (log-normal across units).
POPULATION_PARAMS = ("viscous.C", "coulomb.R", "escapement[2].X")
SHORT = {"viscous.C": "C", "coulomb.R": "R", "escapement[2].X": "X", "fit.kappa": "kappa",
         "observation.sigma": "sigma"}

# Monday's Fig. 18 drift: bands of the envelope and the growth of C per cycle in each band.
DRIFT_THRESHOLDS = (0.15, 0.03, 0.005)
DRIFT_RATES = (0.03, 0.015, 0.005, 0.0)

#: Per-unit priors of the fit scenes: broad enough for both the phase and the angle regime
#: (Monday's phase-convention R and X are ten times the angle-convention ones).
PRIORS = {
    "viscous.C": (0.05, 10.0, "loguniform(0.05, 10)"),
    "coulomb.R": (1.0, 1.0e4, "loguniform(1, 10000)"),
    "escapement[2].X": (100.0, 1.0e5, "loguniform(100, 100000)"),
    "fit.kappa": (0.0, 20.0, None),
    "observation.sigma": (0.003, 0.5, "loguniform(0.003, 0.5)"),
}

#: Start values of each model's fit (least squares starts there and at a Latin hypercube).
START = {
    "phase": {"viscous.C": 1.4, "coulomb.R": 1040.0, "escapement[2].X": 4119.0, "fit.kappa": 3.1},
    "phase_drift": {"viscous.C": 1.2, "coulomb.R": 1040.0, "escapement[2].X": 4119.0, "fit.kappa": 3.1},
    "angle": {"viscous.C": 0.5, "coulomb.R": 40.0, "escapement[2].X": 400.0, "fit.kappa": 0.03},
}


@dataclass(frozen=True)
class Rig:
    """Monday's test fixture and escapement geometry, and how it was read.

    Attributes
    ----------
    omega0
        Natural frequency (rad/s), known from the recorder's time marks.
    theta0
        Release angle (rad): the unit is released from the banking pin.
    unlock, impulse
        Unlock window (from, to) and half power angle (rad): unlock from ``-unlock[0]`` to
        ``-unlock[1]``, impulse over ``+-impulse``.
    eps
        Unlock torque as a fraction of the impulse torque (S = eps*M); the fixture's ratio.
    loads
        Fixture loads (g); escapement torques are proportional to the load.
    reference
        Load (g) at which R and X are quoted.
    every, swings
        Read every ``every``-th half swing (4 = every second cycle) up to ``swings``.
    notch_deg
        Notch angle of the balance (deg); readings are whole notches.
    """

    omega0: float = 15.9
    theta0: float = 6.28
    unlock: tuple[float, float] = (0.633, 0.278)
    impulse: float = 0.278
    eps: float = 0.1151
    loads: tuple[float, ...] = (330.66, 661.32, 991.98)
    reference: float = 330.66
    every: int = 4
    swings: int = 32
    notch_deg: float = 6.0

    def as_dict(self) -> dict:
        return {"omega0": self.omega0, "theta0": self.theta0, "unlock": list(self.unlock), "impulse": self.impulse,
                "eps": self.eps, "loads": list(self.loads), "reference": self.reference, "every": self.every,
                "swings": self.swings, "notch_deg": self.notch_deg}

    @classmethod
    def from_dict(cls, d: dict) -> "Rig":
        d = dict(d)
        d["unlock"] = tuple(d["unlock"])
        d["loads"] = tuple(d["loads"])
        return cls(**d)


def _check_model(model: str) -> None:
    if model not in MODELS:
        from ..core.errors import SceneError

        raise SceneError(f"model must be one of {list(MODELS)}, got {model!r}")


def _body(rig: Rig, model: str, c: str, r: str, x: str, kappa: str, sigma: str) -> str:
    switching = "angle" if model == "angle" else "phase"
    lines = [
        'model = "balance"',
        f'switching = "{switching}"',
        "",
        "[oscillator]",
        f"omega0 = {rig.omega0!r}",
        f"theta0 = {rig.theta0!r}",
        "",
        "[run]",
        f"swings = {rig.swings}",
        "",
        "[effects.viscous]",
        f"C = {c}",
        "",
    ]
    if model == "phase_drift":
        lines += ["[effects.viscous_drift]", f"thresholds = {list(DRIFT_THRESHOLDS)!r}",
                  f"rates = {list(DRIFT_RATES)!r}", ""]
    lines += [
        "[effects.coulomb]",
        f"R = {r}",
        "",
        "[[effects.escapement]]",
        'kind = "unlock"',
        f"from = {-rig.unlock[0]!r}",
        f"to = {-rig.unlock[1]!r}",
        f"eps = {rig.eps!r}",
        "",
        "[[effects.escapement]]",
        'kind = "impulse"',
        f"from = {-rig.impulse!r}",
        f"to = {rig.impulse!r}",
        f"X = {x}",
        "",
    ]
    if model == "angle":
        lines += ["[effects.banking]", f"angle = {rig.theta0!r}", ""]
    lines += [
        "[observation]",
        'model = "notches"',
        f"notch_deg = {rig.notch_deg!r}",
        f"sigma = {sigma}",
        "",
        "[fit.loads]",
        f"reference = {rig.reference!r}",
        'friction = "linear"',
        f"kappa = {kappa}",
    ]
    return "\n".join(lines) + "\n"


def generating_scene(rig: Rig, model: str, truth: dict[str, float], *, header: str = "") -> str:
    """Scene text with a unit's true values (nothing free): what generated its recordings.

    Parameters
    ----------
    truth
        ``viscous.C``, ``coulomb.R``, ``escapement[2].X``, ``fit.kappa`` and
        ``observation.sigma`` in canonical units.
    header
        Comment lines put at the top (without ``#``).
    """
    _check_model(model)
    head = "".join(f"# {line}\n" for line in header.splitlines())
    return head + _body(rig, model, repr(float(truth["viscous.C"])), repr(float(truth["coulomb.R"])),
                        repr(float(truth["escapement[2].X"])), repr(float(truth["fit.kappa"])),
                        repr(float(truth["observation.sigma"])))


def _free(name: str, value: float) -> str:
    lo, hi, prior = PRIORS[name]
    text = f"{{ value = {float(value)!r}, vary = true, min = {lo!r}, max = {hi!r}"
    return text + (f', prior = "{prior}" }}' if prior else " }")


def fit_scene(rig: Rig, model: str, *, start: dict[str, float] | None = None) -> str:
    """Scene text of ``model`` with C, R, X, kappa and the reading jitter free.

    Priors are :data:`PRIORS` (log-uniform for C, R, X, so a log-normal population density
    reweights them by a Gaussian in log space); start values default to :data:`START`.
    """
    _check_model(model)
    s = {**START[model], "observation.sigma": 0.03, **(start or {})}
    title = {"phase": "Monday's phase model", "phase_drift": "Monday's phase model with his damping drift (Fig. 18)",
             "angle": "escapement at balance angles"}[model]
    head = (f"# Fleet-study fit scene: {title}.\n# Written by escfit.study.scenes.fit_scene; C, R, X, kappa and the "
            "reading jitter are free.\n")
    return head + _body(rig, model, *(_free(n, s[n]) for n in ("viscous.C", "coulomb.R", "escapement[2].X",
                                                              "fit.kappa", "observation.sigma")))


def load_rule(values: dict[str, float], load: float, reference: float) -> dict[str, float]:
    """Values at ``load``: X in proportion to the load, R linear in it (``[fit.loads]`` linear)."""
    out = dict(values)
    out["escapement[2].X"] = values["escapement[2].X"] * load / reference
    out["coulomb.R"] = values["coulomb.R"] + values["fit.kappa"] * (load - reference)
    return out


def kappa_for(growth: float, r_ref: float, reference: float) -> float:
    """kappa (rad/s^2 per g) for R growing by ``growth`` times its reference value per reference load."""
    return growth * r_ref / reference if math.isfinite(growth) else 0.0
