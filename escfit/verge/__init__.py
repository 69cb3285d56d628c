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
:mod:`escfit.verge.inference`
    Friction coefficients from observed turns-to-arm (lmfit and emcee).
"""

from __future__ import annotations

from .probe import coupled_state, free_state, impact
from .scene import VergeScene, parse
from .simulate import Prediction, forward, json_summary, run, simulate

__all__ = [
    "parse", "simulate", "json_summary", "forward", "run", "Prediction", "VergeScene", "coupled_state",
    "free_state", "impact",
]
