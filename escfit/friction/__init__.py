"""Sliding friction from Monday's torsion-wire rig (model ``friction_rig``).

Modules, in the order data flows:

``rig``
    Geometry and statics: ``F = dw * sqrt(k**2/d**2 - 1)``, ``mu = F / N``.
``readers``
    Rig readings CSV -> :class:`Readings` (SI units).
``scene``
    ``friction_rig`` scene -> :class:`RigScene` (parameters, explicit priors).
``likelihood``
    Shared-geometry observation model and log posterior of one session (vectorised).
``problem``, ``family``
    :class:`RigProblem` (the session as a :class:`~escfit.likelihood.problem.Problem`) and the
    registry entry :data:`~escfit.friction.family.FAMILY`; fits run through the one inference
    layer, :func:`escfit.inference.fit` (``escfit fit``), into one results schema.
``evidence``
    Bayes factors for the optional friction laws (Savage-Dickey), from a fit's posterior.
``predict``
    :func:`simulate` and :func:`json_summary`.
``synthetic``, ``monday``
    Synthetic sessions, and the sessions reconstructed from Monday's table.
"""

from __future__ import annotations

from .evidence import LawEvidence, compare_laws, savage_dickey
from .predict import json_summary, simulate
from .problem import RigProblem
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
    "RigProblem",
    "LawEvidence",
    "compare_laws",
    "savage_dickey",
]
