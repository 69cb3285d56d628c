"""The half-swing walk, written once; each solver supplies only how to cross one region.

A run is a sequence of half swings.  A half swing moving in direction ``s`` (+1 when theta
increases) is walked in the swing frame ``x = s*theta``, from ``x = -A`` towards ``+A``,
through the regions of :mod:`escfit.balance.regions` (constant piecewise-linear torques between
window edges, hairspring break angles and the banking angle).  This module holds the only loop
over them, the way diffrax's ``diffeqsolve`` holds the only loop over steps:

- **region walk**: which region holds the state, its stiffness ``w2``, centre ``xc`` and the
  edge ahead ``xb``;
- **stop rule**: at rest at the start of a half swing, the balance stays at rest when the net
  acceleration there does not exceed the static friction beyond the sliding one (status
  ``stopped``); at rest on an edge later in a half swing, it turns there (a graze);
- **one region**: the solver's ``advance`` carries the state to the first event in the region
  and returns a :class:`Segment`;
- **creep to rest**: a turning point that overshoots its rest position by no more than
  :func:`escfit.balance.segment.creeps_to_rest` allows, or no event at all within the solver's
  horizon, ends the motion (status ``stopped``);
- **banking impact**: an edge crossing on the last edge (the banking angle) ends the half swing
  and starts the next one with ``restitution`` times the impact velocity;
- **end of a half swing**: the per-half-swing record (:data:`escfit.balance.kernel_records.HALF_SWING`),
  the damping drift (C grows after each full cycle), the direction flip and the end time;
- **status**: ``ok``, ``stopped``, ``banked``, ``max_segments`` or the solver's own failure.

A solver is an ``advance`` and a ``scratch`` function (:func:`compile_walk`):

``scratch(k)``
    Whatever the solver keeps from one region to the next (stage arrays, the step size), made
    once per run from the coefficient record ``k``.
``advance(k, run, start, region, work, rows, n_rows) -> Segment``
    ``start = (t, x, v, s, swing, steps)``: time (s), swing-frame state (rad, rad/s; ``v >= 0``),
    direction, half swings done and integration steps used so far; ``region = (w2, xc, xb, c)``:
    stiffness (1/s^2), centre (rad), the edge ahead (rad; ``inf`` for none) and the viscous
    coefficient now in force (1/s; the damping drift changes it); ``work`` is the scratch;
    ``rows`` the dense solution's rows (filled from row ``n_rows`` when ``run.dense``).

:func:`compile_walk` compiles one copy of the walk per solver with that solver's ``advance``
bound in, so the compiled loop calls it directly (no function pointer, nothing to look up per
region) and each copy keeps its own on-disk cache; with ``python=True`` the same loop runs as
plain Python, which is how the scipy adapter (:mod:`escfit.balance.ivp`) walks with
``solve_ivp`` as its ``advance``.  A new switch, impact or stop law is one edit here.
"""

from __future__ import annotations

import inspect
import math
import types
from pathlib import Path
from typing import Callable, NamedTuple

from ..core.kernels import kernel, module_sources
from ..core.status import Status
from .regions import region_tables
from .segment import creeps_to_rest
from .acceleration import acceleration

__all__ = ["Segment", "Walk", "EDGE", "TURN", "REST", "END", "FAILED", "compile_walk"]

#: What ended a region (:attr:`Segment.event`): the edge ahead, a turning point, a creep to rest
#: without a turning point (no event within the solver's horizon), the run's end time reached
#: inside the region (integrators sampling up to a time), or a failure (:attr:`Segment.status`).
EDGE, TURN, REST, END, FAILED = 0, 1, 2, 3, 4

_STOPPED, _BANKED, _MAX_SEGMENTS = int(Status.STOPPED), int(Status.BANKED), int(Status.MAX_SEGMENTS)


class Segment(NamedTuple):
    """What a solver's ``advance`` returns for one region of a half swing.

    Attributes
    ----------
    event : int
        :data:`EDGE`, :data:`TURN`, :data:`REST`, :data:`END` or :data:`FAILED`.
    tau : float
        Time from the region's start to the event (s); to where the solver stopped for ``REST``,
        ``END`` and ``FAILED`` (``inf`` for a closed-form creep that never turns).
    x, v : float
        Swing-frame angle (rad) and velocity (rad/s) there.
    overshoot : float
        ``TURN``: the turn's offset from the region's rest position (rad), for the creep rule.
    rest : float
        ``TURN``: that rest position (rad, swing frame), where a creep to rest ends.
    motion : float
        The motion's size at the region's start, ``sqrt(y**2 + v**2/w2)`` about the rest
        position (rad): the creep rule's local scale (the first region's is the run's).
    status : int
        ``FAILED``: the :class:`~escfit.core.status.Status` code (or ``ROWS_FULL``).
    steps : int
        Integration steps taken in the region (0 for the closed form).
    rows : int
        Rows of the dense solution filled after the region.
    """

    event: int
    tau: float
    x: float
    v: float
    overshoot: float
    rest: float
    motion: float
    status: int
    steps: int
    rows: int


class Walk(NamedTuple):
    """What a walk returns (besides the half swings written to ``out``).

    Attributes
    ----------
    n_done, status, n_seg, steps : int
        Half swings done, :class:`~escfit.core.status.Status` code, regions crossed and
        integration steps used.
    t, theta, omega : float
        Where the run ended: time (s), angle (rad) and angular velocity (rad/s).
    rows : int
        Rows of the dense solution filled.
    """

    n_done: int
    status: int
    n_seg: int
    steps: int
    t: float
    theta: float
    omega: float
    rows: int


def _walk(k, run, out, rows):
    """Walk half swings from the release ``k.theta0, k.v0`` (see the module docstring).

    Parameters
    ----------
    k : record
        The coefficient record (:data:`escfit.balance.kernel_records.COEFFICIENTS`).
    run : record
        :data:`escfit.balance.kernel_records.RUN`: ``n_swings``, ``max_segments``, ``t_end`` (s; the run
        ends with the first half swing ending at or after it) and what the solver reads.
    out : array of :data:`escfit.balance.kernel_records.HALF_SWING`
        Per-half-swing results, filled while the count is below its length.
    rows : array or list
        The dense solution's rows, the solver's to fill when ``run.dense``.

    Returns
    -------
    Walk
    """
    work = scratch(k)  # noqa: F821 - bound per solver by compile_walk
    theta0 = k.theta0
    v0 = k.v0
    hold = k.r_static - k.r  # static friction beyond the sliding one (rad/s^2)
    bank = k.bank
    restitution = k.restitution
    dr_th = k.drift_th[:k.n_bands]
    dr_rate = k.drift_rate[:k.n_bands + 1]
    n_swings = run.n_swings
    max_seg = run.max_segments
    t_end = run.t_end
    n_out = out.shape[0]
    s = 1.0 if theta0 < 0.0 else -1.0
    if v0 != 0.0:
        s = 1.0 if v0 > 0.0 else -1.0
    x = s * theta0
    v = s * v0
    c = k.c
    t = 0.0
    t_swing = 0.0  # duration of the current half swing, summed apart from t to keep its precision
    int_c = 0.0
    status = 0
    n_done = 0
    n_seg = 0
    steps = 0
    n_rows = 0
    any_bank = False
    drift = False
    for i in range(dr_rate.shape[0]):
        if dr_rate[i] != 0.0:
            drift = True
    edge_tab, n_edge_tab, w2_tab, xc_tab = region_tables(k)
    d = 0 if s > 0.0 else 1
    n_edges = n_edge_tab[d]
    at_start = True
    at_edge = False  # the state sits on edge j after a crossing
    j = 0
    scale = -1.0  # the run's scale: the release's offset from its rest position (rad)
    while n_done < n_swings:
        if n_seg >= max_seg:
            status = _MAX_SEGMENTS
            break
        if at_edge:
            j += 1  # just crossed edge j: the edges are distinct, so the region above is the next
        else:
            j = 0
            while j < n_edges and edge_tab[d, j] <= x:
                j += 1
        w2 = w2_tab[d, j]
        xc = xc_tab[d, j]
        xb = edge_tab[d, j] if j < n_edges else math.inf
        event = TURN
        tau = 0.0
        if v <= 0.0:
            v = 0.0  # also clears a negative zero
            a_rest = acceleration(x, 0.0, w2, xc, k)
            if a_rest <= 0.0 or (at_start and a_rest <= hold):
                if at_start:
                    status = _STOPPED  # at rest, and the net torque cannot overcome static friction
                    break
                n_seg += 1  # came to rest exactly on an edge: a turning point there (a graze)
            else:
                event = -1
        else:
            event = -1
        if event < 0:
            seg = advance(k, run, (t, x, v, s, n_done, steps), (w2, xc, xb, c), work, rows, n_rows)  # noqa: F821
            n_seg += 1
            steps += seg.steps
            n_rows = seg.rows
            if scale < 0.0:
                scale = seg.motion
            event = seg.event
            tau = seg.tau
            if event == TURN and creeps_to_rest(seg.overshoot, seg.motion, scale):
                # the turn lies on the rest position to within the rule: a creep to rest, reached
                # after an infinite time
                x = seg.rest
                v = 0.0
                t = math.inf
                status = _STOPPED
                break
            if event == FAILED or event == REST or event == END:
                t += tau
                x = seg.x
                v = seg.v
                if event == FAILED:
                    status = seg.status
                elif event == REST:
                    status = _STOPPED
                break
            x = seg.x
            v = seg.v
        t += tau
        t_swing += tau
        int_c += c * tau
        at_start = False
        is_bank = event == EDGE and j == n_edges - 1 and math.isfinite(bank)
        if event == EDGE:
            x = xb
            v = max(v, 0.0)
            if not is_bank:
                at_edge = True
                continue
        at_edge = False
        # end of a half swing: a turning point or an impact on the banking pins
        if n_done < n_out:
            rec = out[n_done]
            rec.amplitude = abs(x)
            rec.theta_turn = s * x
            rec.half_period = t_swing
            rec.time = t
            rec.banked = 1 if is_bank else 0
        any_bank = any_bank or is_bank
        t_swing = 0.0
        n_done += 1
        if drift and n_done % 2 == 0:
            c *= drift_factor(int_c, dr_th, dr_rate)
        s = -s
        x = -x
        v = restitution * v if is_bank else 0.0
        at_start = v == 0.0
        d = 1 - d
        n_edges = n_edge_tab[d]
        if t >= t_end:
            break
    if status == 0 and any_bank:
        status = _BANKED
    return Walk(n_done, status, n_seg, steps, t, s * x, s * v, n_rows)


@kernel
def drift_factor(integral_c, th, rate):
    """Growth factor of C after a cycle, from the envelope exp(-int C dt / 2) and the drift's
    thresholds ``th`` and rates ``rate`` (:mod:`escfit.balance.effects.viscous_drift`)."""
    env = math.exp(-0.5 * integral_c)
    for i in range(th.shape[0]):
        if env > th[i]:
            return 1.0 + rate[i]
    return 1.0 + rate[th.shape[0]]


def compile_walk(advance: Callable, scratch: Callable, name: str, *, python: bool = False) -> Callable:
    """The walk with a solver's ``advance`` and ``scratch`` bound in (see the module docstring).

    Parameters
    ----------
    advance, scratch
        The solver's functions: compiled kernels, or plain Python with ``python=True``.
    name
        The solver's name: the compiled copy is ``walk_<name>``, with its own on-disk cache
        keyed on this module, the module defining ``advance`` and everything they import.
    python
        Return the walk as plain Python (``out`` and the records must then allow attribute
        access: ``numpy.recarray`` rows, ``numpy.record``).

    Returns
    -------
    callable
        ``walk(k, run, out, rows) -> Walk``.
    """
    glob = dict(_walk.__globals__)
    glob["advance"] = advance
    glob["scratch"] = scratch
    fn = types.FunctionType(_walk.__code__, glob, f"walk_{name}", _walk.__defaults__, _walk.__closure__)
    fn.__qualname__ = f"walk_{name}"
    fn.__doc__ = _walk.__doc__
    if python:
        return fn
    defining = inspect.getmodule(getattr(advance, "py_func", advance))
    return kernel(fn, sources=module_sources(Path(inspect.getfile(defining)), defining.__name__))
