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
:class:`SpeedTrace`, :class:`TerminalSpeeds`
    Geneva recordings (:mod:`escfit.geneva.data`: readers and writer of their CSV files);
    :func:`synthetic_trace` simulates one.
:class:`GenevaProblem`
    Scene + recording -> the fit problem :mod:`escfit.inference` runs (``escfit fit``).
"""

from __future__ import annotations

from .data import SpeedTrace, TerminalSpeeds, read_speed_trace, read_terminal_speeds, write_speed_trace
from .geometry import COMPAT_MODES, Geometry
from .problem import GenevaProblem
from .scene import GenevaScene, parse
from .simulate import Prediction, forward, json_summary, simulate
from .synthetic import synthetic_trace
from .terminal import TerminalCycle, terminal_cycle

__all__ = [
    "parse", "simulate", "json_summary", "forward", "GenevaScene", "Geometry", "Prediction", "TerminalCycle",
    "terminal_cycle", "COMPAT_MODES", "SpeedTrace", "TerminalSpeeds", "read_speed_trace", "read_terminal_speeds",
    "write_speed_trace", "synthetic_trace", "GenevaProblem",
]
