"""Sliding friction from Monday's torsion-wire rig (model ``friction_rig``).

Modules, in the order data flows:

``rig``
    Geometry and statics: ``F = dw * sqrt(k**2/d**2 - 1)``, ``mu = F / N``.
``readers``
    Rig readings CSV -> :class:`Readings` (SI units).
``scene``
    ``friction_rig`` scene -> :class:`RigScene` (parameters, explicit priors).
``likelihood``
    Shared-geometry observation model and log posterior of one session.
``inference``
    lmfit least squares and emcee posterior (:class:`arviz.InferenceData`).
``evidence``
    Bayes factors for the optional friction laws (Savage-Dickey).
``predict``
    :func:`simulate` and :func:`json_summary`.
``synthetic``, ``monday``
    Synthetic sessions, and the sessions reconstructed from Monday's table.
"""

from __future__ import annotations

from .evidence import LawEvidence, compare_laws, savage_dickey
from .inference import LeastSquaresFit, fit_least_squares, sample_posterior
from .predict import json_summary, simulate
from .readers import Readings, parse_readings, read_readings, write_readings
from .rig import friction_force, lever_ratio, mu_from_reading, predicted_dw
from .scene import RigScene, parse

__all__ = [
    "parse",
    "simulate",
    "json_summary",
    "RigScene",
    "Readings",
    "read_readings",
    "parse_readings",
    "write_readings",
    "lever_ratio",
    "friction_force",
    "mu_from_reading",
    "predicted_dw",
    "LeastSquaresFit",
    "fit_least_squares",
    "sample_posterior",
    "LawEvidence",
    "compare_laws",
    "savage_dickey",
]
