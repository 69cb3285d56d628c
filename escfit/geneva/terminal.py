"""Terminal velocity: the periodic motion the driver settles to, found directly.

Each engagement maps the driver speed at pin entry to the speed at hand-over.  In terms of
``v = w**2/2`` the equation of motion is linear, ``dv/dx = (E - 2*(B + S*C)*v)/(A + S*D)``,
so while the friction sign pattern is unchanged the map is affine, ``v_out = p*v_in + q``.
Without friction ``p = 1`` exactly (kinetic energy grows by the spring's work every
engagement: no terminal velocity); pin friction makes ``p < 1`` and the unique fixed point is
the terminal motion, approached geometrically by a factor ``p`` per engagement.

The fixed point is found by secant iteration on the map (exact for an affine map), with
every map evaluation a full engagement integrated by the run's engine.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .engines import END_COMPLETE, END_LOCKED
from .geometry import Geometry
from .trajectory import Engine, _engine_opts

__all__ = ["TerminalCycle", "terminal_cycle"]

_EMPTY = np.empty(0)


@dataclass(frozen=True)
class TerminalCycle:
    """The periodic (terminal) engagement, SI units.

    Attributes
    ----------
    status
        ``"ok"``, ``"no_terminal"`` (map contraction ``>= 1``: no friction to balance the
        spring) or ``"locked"`` (the pin jams at speeds near the would-be terminal motion).
    entry_speed
        Driver speed at pin entry (= hand-over), rad/s.
    peak_speed, min_speed
        Largest and smallest driver speed in the engagement, rad/s.
    peak_phase, min_phase
        Their times after pin entry, s.
    period
        Duration of one engagement = time between successive speed peaks, s.
    contraction
        ``p = d(v_out)/d(v_in)``, the factor by which the distance of ``w**2/2`` from its
        terminal value shrinks per engagement.
    """

    status: str
    entry_speed: float = math.nan
    peak_speed: float = math.nan
    min_speed: float = math.nan
    peak_phase: float = math.nan
    min_phase: float = math.nan
    period: float = math.nan
    contraction: float = math.nan
    span: float = math.nan

    @property
    def meyer_mean(self) -> float:
        """Meyer's "average terminal velocity", ``(peak + min)/2``, rad/s."""
        return 0.5 * (self.peak_speed + self.min_speed)

    @property
    def mean_speed(self) -> float:
        """Time-averaged driver speed over one engagement, ``span/period``, rad/s."""
        return self.span / self.period


def terminal_cycle(geometry: Geometry, rho: float, mu: float, e: float, engine: Engine,
                   engine_options: dict[str, Any] | None = None, *, w_guess: float | None = None,
                   tol: float = 1e-11, max_iter: int = 40) -> TerminalCycle:
    """Find the terminal engagement of a mechanism.

    Parameters
    ----------
    geometry, rho, mu, e
        Mechanism, ``I_d/I_f``, friction coefficient, ``K/I_f`` (rad/s^2).
    engine, engine_options
        Engagement integrator and its options (as for :func:`escfit.geneva.trajectory.run`).
    w_guess
        Starting guess for the entry speed, rad/s.
    tol
        Relative tolerance on the fixed point of ``v = w**2/2``.
    max_iter
        Secant iterations before giving up (reported as ``"no_terminal"``).
    """
    opts = dict(engine_options or {})
    scale = math.sqrt(e)
    a, x0, x1 = geometry.a, geometry.x_start, geometry.x_end

    def one(v: float):
        w = math.sqrt(2.0 * max(v, 0.0))
        return engine(x0, x1, 0.0, w, 1e4, a, rho, mu, _EMPTY, **_engine_opts(opts, w, geometry.span))

    v_a = 0.5 * (w_guess / scale) ** 2 if w_guess and w_guess > 0 else 1.0
    v_b = 1.25 * v_a
    r_a, r_b = one(v_a), one(v_b)
    for r in (r_a, r_b):
        if r.reason != END_COMPLETE:
            return TerminalCycle("locked" if r.reason == END_LOCKED else "no_terminal", span=geometry.span)
    f_a, f_b = 0.5 * r_a.w ** 2, 0.5 * r_b.w ** 2
    slope = (f_b - f_a) / (v_b - v_a)
    for _ in range(max_iter):
        if not slope < 1.0 - 1e-9:
            return TerminalCycle("no_terminal", contraction=slope, span=geometry.span)
        v_new = (f_b - slope * v_b) / (1.0 - slope)
        if not v_new > 0.0:
            v_new = 0.5 * min(v_a, v_b)
        r_new = one(v_new)
        if r_new.reason != END_COMPLETE:
            return TerminalCycle("locked" if r_new.reason == END_LOCKED else "no_terminal", span=geometry.span)
        f_new = 0.5 * r_new.w ** 2
        if abs(f_new - v_new) <= tol * v_new:
            v_b, r_b = v_new, r_new
            break
        if abs(v_new - v_b) > 1e-7 * v_new:  # keep the chord slope when points get too close
            slope = (f_new - f_b) / (v_new - v_b)
        v_a, f_a, v_b, f_b, r_b = v_b, f_b, v_new, f_new, r_new
    else:
        return TerminalCycle("no_terminal", contraction=slope, span=geometry.span)
    r = r_b
    inv = 1.0 / scale
    return TerminalCycle("ok", entry_speed=math.sqrt(2.0 * v_b) * scale,
                         peak_speed=r.peak_w * scale, min_speed=r.min_w * scale, peak_phase=r.peak_t * inv,
                         min_phase=r.min_t * inv, period=r.t * inv, contraction=slope, span=geometry.span)

