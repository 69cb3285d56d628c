"""Rotor-driven safing-and-arming mechanism with a straight-sided verge runaway escapement.

After G. G. Lowen and F. R. Tepper, ARLCD-TR-82013 (1982): a spin-driven eccentric rotor
drives a two-pass involute gear train whose escape wheel is governed by a verge.  The
motion alternates between coupled motion (tooth sliding on a verge face), free motion and
impacts; the mechanism arms when the cumulative escape-wheel angle reaches the cut-off
angle.  See ``docs/verge.md`` for the model and the notes on the report.

Public API
----------
:func:`parse`
    ``model = "verge"`` TOML document -> :class:`VergeScene`.
:func:`simulate`
    Scene -> :class:`xarray.Dataset` (time history, regimes, contact forces and their
    maxima, time and turns to arm, status).
:func:`json_summary`
    Dataset -> plain dict for ``escfit simulate --json``.
:func:`forward`
    Pure (scene, parameter values) -> :class:`Prediction` used by fits.
:class:`TurnsData`, :func:`read_turns_csv`, :func:`synthetic_turns`
    Turns-to-arm readings (:mod:`escfit.verge.data`, :mod:`escfit.verge.synthetic`).
:class:`TurnsProblem`
    Friction coefficients from turns-to-arm: the fit problem that ``escfit fit`` (one
    inference layer, :mod:`escfit.inference`) solves; registered as
    :data:`escfit.verge.family.FAMILY`.
"""

from __future__ import annotations

from .probe import coupled_state, free_state, impact
from .scene import VergeScene, parse
from .simulate import Prediction, forward, json_summary, run, simulate

# the fit side (data, problem, synthetic readings) is imported lazily: simulating needs none of it
_LAZY = {"TurnsData": "data", "read_turns_csv": "data", "TurnsProblem": "problem", "FIT_STEP": "problem",
         "synthetic_turns": "synthetic"}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "parse", "simulate", "json_summary", "forward", "run", "Prediction", "VergeScene", "coupled_state",
    "free_state", "impact", "TurnsData", "read_turns_csv", "TurnsProblem", "FIT_STEP", "synthetic_turns",
]
