"""The Geneva escapement as a timing device (after H. W. Meyer, 1973).

A pin wheel (driver) under a constant spring torque turns a slotted wheel (follower); with
``m = 2n/(n - 2)`` pins one pin is always engaged, and pin-slot friction makes the driver
settle to a periodic terminal motion.  See ``docs/geneva.md`` for the derivation.

Public API
----------
:func:`parse`
    ``model = "geneva"`` TOML document -> :class:`GenevaScene`.
:func:`simulate`
    Scene -> :class:`xarray.Dataset` (time histories, per-engagement extremes, terminal
    velocity, period, rise time, status).
:func:`json_summary`
    Dataset -> plain dict for ``escfit simulate --json``.
:func:`forward`
    Pure parameter-values -> :class:`Prediction` function used by fits.
"""

from __future__ import annotations

from .geometry import COMPAT_MODES, Geometry
from .scene import GenevaScene, parse
from .simulate import Prediction, forward, json_summary, simulate
from .terminal import TerminalCycle, terminal_cycle

__all__ = [
    "parse", "simulate", "json_summary", "forward", "GenevaScene", "Geometry", "Prediction", "TerminalCycle",
    "terminal_cycle", "COMPAT_MODES",
]
