"""Compiled adaptive Dormand-Prince 8(5,3) with located events, for springs and pendulums.

The piecewise structure is that of :mod:`escfit.balance.exact`: a half swing moving in
direction ``s`` is integrated in the swing frame ``x = s*theta`` (the balance runs from
``x = -A`` towards ``+A``), split into segments of frozen regime ended by a window edge, the
banking pins or the turning point ``v = 0``.  Inside a region with constants ``(w2, xc)``
(:mod:`escfit.balance.regions`; ``w2*xc`` gathers Coulomb friction, the windows and the
hairspring offset) the equation is that of :func:`escfit.balance.acceleration.acceleration`::

    x'' = -C x' - w2 (x - xc) + smooth terms          spring
    x'' = -C x' - w2 (sin x - xc) + smooth terms      pendulum (w2 = omega0**2)

with the smooth torques of every effect that has one (air drag, a stiffening spring); this
module has no code of any effect.

Steps are those of scipy's ``DOP853`` (same coefficient tables, error norm and step-size
controller), with separate absolute tolerances for theta and omega.  An event inside an
accepted step is located by Newton iteration on the step map itself -- re-stepping from the
step start with the trial length, the derivative being the velocity (edges) or the
acceleration (turning points) at the trial end -- started from a Hermite-cubic guess and kept
inside a sign bracket.  Once the Newton correction is below 1e-6 of the motion's time scale
it is applied by a third-order Taylor expansion of the state (the equation gives the
derivatives), whose remainder lies below rounding, instead of one more step.  Events thus
add no error of their own beyond the integrator's local error.

With ``dense=True`` the kernel keeps every accepted step (its start state and length) as a row
of the dense solution (:class:`escfit.balance.solution.RowSolution`), which evaluates the motion
anywhere by a step of the partial length: theta(t), theta'(t) and level crossings to the
integrator's own accuracy.  A run may also end at a time (``t_end``) instead of a number of
half swings, as sampling a waveform asks.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.errors import SolverError
from ..core.kernels import kernel
from ..core.status import Status
from .dop853_tables import tables as _coefficients
from .kernel_records import ROWS_FULL, columns, half_swings, run_options, with_rows
from .segment import creep_horizon
from .solution import ROW_DOP853, RowSolution, write_row
from .steps import N_STAGES, dop853_step
from .system import System
from .acceleration import acceleration, jerk
from .trajectory import Trajectory
from .walker import EDGE, END, FAILED, REST, TURN, Segment, compile_walk

__all__ = ["solve_dop853", "run_dop853", "advance_dop853"]

_E3 = np.ascontiguousarray(_coefficients.E3)
_E5 = np.ascontiguousarray(_coefficients.E5)
_SAFETY, _MIN_FACTOR, _MAX_FACTOR = 0.9, 0.2, 10.0
_EXPONENT = -1.0 / 8.0  # the error estimate is of order 7 (scipy: -1/(error_estimator_order + 1))
_OVER_THE_TOP, _UNDERFLOW, _BUDGET = int(Status.OVER_THE_TOP), int(Status.STEP_UNDERFLOW), int(Status.STEP_BUDGET)


@kernel
def _error_norm(state, state1, h, stages, tol):
    """scipy's DOP853 error norm of the last step (< 1: accept); ``tol = (rtol, atol_x, atol_v)``."""
    x, v = state
    x1, v1 = state1
    kx, kv = stages
    rtol, atol_x, atol_v = tol
    e5x = e5v = e3x = e3v = 0.0
    for j in range(N_STAGES + 1):
        e5x += _E5[j] * kx[j]
        e5v += _E5[j] * kv[j]
        e3x += _E3[j] * kx[j]
        e3v += _E3[j] * kv[j]
    sx = atol_x + rtol * max(abs(x), abs(x1))
    sv = atol_v + rtol * max(abs(v), abs(v1))
    e5 = (e5x / sx) ** 2 + (e5v / sv) ** 2
    e3 = (e3x / sx) ** 2 + (e3v / sv) ** 2
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * 2.0)


@kernel
def _initial_step(state, regime, tol):
    """scipy's ``select_initial_step`` for the 2-d state (s)."""
    x, v, a = state
    w2, xc, k = regime
    rtol, atol_x, atol_v = tol
    sx = atol_x + abs(x) * rtol
    sv = atol_v + abs(v) * rtol
    d0 = math.sqrt(((x / sx) ** 2 + (v / sv) ** 2) / 2.0)
    d1 = math.sqrt(((v / sx) ** 2 + (a / sv) ** 2) / 2.0)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    x1 = x + h0 * v
    v1 = v + h0 * a
    a1 = acceleration(x1, v1, w2, xc, k)
    d2 = math.sqrt((((v1 - v) / sx) ** 2 + ((a1 - a) / sv) ** 2) / 2.0) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100.0 * h0, h1)


@kernel
def _locate(state, regime, event, end, stages):
    """Event inside a step: ``x`` rises to ``target`` or ``v`` falls to 0.

    Parameters
    ----------
    state : tuple
        ``(x, v, a)`` at the step start.
    regime : tuple
        ``(w2, xc, k)``.
    event : tuple
        ``(which, target)``: 0 for the edge ``x = target``, 1 for the turning point ``v = 0``.
    end : tuple
        ``(hi, x_hi, v_hi, a_hi)``: a time within the step at which ``g = x - target`` (or
        ``-v``) is ``>= 0``, and the state there.
    stages : tuple
        Scratch ``(kx, kv)``.

    Returns ``(tau, x, v, a)`` at the located time, evaluated by a step of that length.
    """
    x, v, a = state
    w2, xc, k = regime
    which, target = event
    hi, x_hi, v_hi, a_hi = end
    lo = 0.0
    g_lo = x - target if which == 0 else -v
    g_hi = x_hi - target if which == 0 else -v_hi
    if g_lo >= 0.0:  # from rest (v = 0, accelerating): move lo off the trivial root
        lo = hi
        for _ in range(200):
            lo *= 0.5
            _, vl, _ = dop853_step(state, lo, regime, stages)
            if vl > 0.0:
                g_lo = -vl
                break
        if g_lo >= 0.0:
            return hi, x_hi, v_hi, a_hi
    # Hermite cubic of g on [0, hi] in u = tau/hi: a guess within the step's own accuracy
    if which == 0:
        p0, d0, p1, d1 = x - target, v * hi, g_hi, v_hi * hi
    else:
        p0, d0, p1, d1 = -v, -a * hi, g_hi, -a_hi * hi
    u_lo = lo / hi
    u_hi = 1.0
    u = (u_lo * g_hi - g_lo) / (g_hi - g_lo) if g_hi > g_lo else 0.5 * (u_lo + 1.0)
    for _ in range(8):
        u2 = u * u
        u3 = u2 * u
        p = (2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * d0 + (-2 * u3 + 3 * u2) * p1 + (u3 - u2) * d1
        dp = (6 * u2 - 6 * u) * p0 + (3 * u2 - 4 * u + 1) * d0 + (-6 * u2 + 6 * u) * p1 + (3 * u2 - 2 * u) * d1
        if p < 0.0:
            u_lo = u
        else:
            u_hi = u
        new = u - p / dp if dp > 0.0 else 0.5 * (u_lo + u_hi)
        if not (u_lo < new < u_hi):
            new = 0.5 * (u_lo + u_hi)
        if abs(new - u) <= 1e-15:
            break
        u = new
    tau = min(max(u * hi, lo), hi)
    noise = 4.5e-16 * ((abs(x) + abs(target)) if which == 0 else (abs(v) + abs(v_hi) + abs(a) * hi))
    rate = math.sqrt(w2) + k.c  # inverse time scale of the motion
    xe, ve, ae = x_hi, v_hi, a_hi
    for _ in range(60):
        xe, ve, ae = dop853_step(state, tau, regime, stages)
        g = xe - target if which == 0 else -ve
        dg = ve if which == 0 else -ae
        if g == 0.0 or abs(g) <= noise:
            return tau, xe, ve, ae
        if g < 0.0:
            lo = tau
        else:
            hi = tau
        new = 0.5 * (lo + hi)
        if dg > 0.0:
            step = g / dg
            # a correction below rounding means convergence (as in segment.cross_time)
            if abs(step) <= 4e-16 * tau:
                return tau, xe, ve, ae
            if lo < tau - step < hi:
                new = tau - step
                if abs(step) * rate <= 1e-6:
                    # so short a correction is finished by a Taylor expansion of the state at
                    # tau (the ODE gives the derivatives): its remainder, of order
                    # (rate*step)**3, lies below rounding, and a re-step is saved
                    jk = jerk(xe, ve, ae, w2, k)
                    xn = xe - step * (ve - step * (0.5 * ae - step * jk / 6.0))
                    vn = ve - step * (ae - 0.5 * step * jk)
                    return new, xn, vn, acceleration(xn, vn, w2, xc, k)
        if hi - lo <= 4e-16 * hi:
            break
        tau = new
    xe, ve, ae = dop853_step(state, tau, regime, stages)
    return tau, xe, ve, ae


@kernel
def _dop853_scratch(k):
    """The stage arrays and what carries from one region to the next: the step size (s; -1 before
    the first step) and whether the last step was rejected."""
    return np.empty(N_STAGES + 1), np.empty(N_STAGES + 1), np.array([-1.0, 0.0])


@kernel
def advance_dop853(k, run, start, region, work, rows, n_rows):
    """One region of a half swing by adaptive DOP853 steps: the walk's step
    (:mod:`escfit.balance.walker`).

    Steps until one passes the edge ahead or a turning point, which :func:`_locate` then places
    on the step map.  Ends early (``REST``) when no event comes within
    :func:`~escfit.balance.segment.creep_horizon`, (``END``) at the first accepted step reaching
    ``run.t_end``, or fails: step budget, step size below rounding, a pendulum over the top, no
    room for a dense row.  With ``run.dense`` each accepted step is a row (t0, tau, s, x0, v0,
    xc, w2, a0, swing).
    """
    t0, x, v, s, swing, steps0 = start
    w2, xc, xb, _ = region
    x_seg, v_seg = x, v
    kx, kv, memory = work
    stages = (kx, kv)
    tol = (run.rtol, run.atol_x, run.atol_v)
    record = run.dense != 0
    pend = k.pendulum != 0
    regime = (w2, xc, k)
    h = memory[0]
    rejected = memory[1] != 0.0
    a = acceleration(x, v, w2, xc, k)
    if h < 0.0:
        h = _initial_step((x, v, a), regime, tol)
    # no turning point within many time constants: creeping to rest (overdamped)
    horizon = creep_horizon(k.c, w2)
    budget = run.max_steps - steps0
    t_seg = 0.0
    n_steps = 0
    event = -1
    fail = 0
    tau = 0.0
    xe, ve = x, v
    while True:
        if n_steps >= budget:
            fail = _BUDGET
            break
        if t_seg > horizon:
            event = REST
            break
        h_try = h
        x1, v1, a1 = dop853_step((x, v, a), h_try, regime, stages)
        n_steps += 1
        err = _error_norm((x, v), (x1, v1), h_try, stages, tol)
        if not err < 1.0:  # also NaN
            h = h_try * max(_MIN_FACTOR, _SAFETY * err**_EXPONENT) if math.isfinite(err) else 0.5 * h_try
            rejected = True
            if h <= 1e-15 * (t0 + t_seg + h_try):
                fail = _UNDERFLOW
                break
            continue
        factor = _MAX_FACTOR if err == 0.0 else min(_MAX_FACTOR, _SAFETY * err**_EXPONENT)
        if rejected:
            factor = min(1.0, factor)
        rejected = False
        h_next = h_try * factor
        if v1 <= 0.0:
            tau, xe, ve, ae = _locate((x, v, a), regime, (1, 0.0), (h_try, x1, v1, a1), stages)
            event = TURN
            if xe > xb:  # passed the edge before turning within this step
                tau, xe, ve, ae = _locate((x, v, a), regime, (0, xb), (tau, xe, ve, ae), stages)
                event = EDGE
        elif x1 >= xb:
            tau, xe, ve, ae = _locate((x, v, a), regime, (0, xb), (h_try, x1, v1, a1), stages)
            event = EDGE
        h = h_next
        if pend and (xe if event >= 0 else x1) >= math.pi:
            event = -1
            fail = _OVER_THE_TOP
            break
        if record:
            if n_rows >= rows.shape[0]:
                event = -1
                fail = ROWS_FULL
                break
            write_row(rows, n_rows, (t0 + t_seg, tau if event >= 0 else h_try, s, x, v), (xc, w2), a, swing)
            n_rows += 1
        if event >= 0:
            break
        x, v, a = x1, v1, a1
        t_seg += h_try
        if t0 + t_seg >= run.t_end:
            event = END
            break
    memory[0] = h
    memory[1] = 1.0 if rejected else 0.0
    motion = 0.0  # read by the walk at a turn and in the run's first region only
    if event == TURN or steps0 == 0:
        motion = math.sqrt(acceleration(x_seg, 0.0, w2, xc, k) ** 2 + w2 * v_seg * v_seg) / w2
    if fail != 0:
        return Segment(FAILED, t_seg, x, v, 0.0, x, motion, fail, n_steps, n_rows)
    if event == EDGE:
        return Segment(event, t_seg + tau, xe, ve, 0.0, xe, motion, 0, n_steps, n_rows)
    if event == TURN:
        a_rest = acceleration(xe, 0.0, w2, xc, k)  # the turn's offset from the rest position is -a/w2
        return Segment(event, t_seg + tau, xe, ve, a_rest / w2, xe + a_rest / w2, motion, 0, n_steps, n_rows)
    return Segment(event, t_seg, x, v, 0.0, x, motion, 0, n_steps, n_rows)


#: Integrate half swings (angle switching) from ``k.theta0, k.v0`` with DOP853: the walk of
#: :mod:`escfit.balance.walker` with :func:`advance_dop853`, ``run_dop853(k, run, out, rows) ->
#: Walk``; ``run`` holds the budgets ``max_segments`` and ``max_steps``, ``t_end``, ``rtol``,
#: ``atol_x`` (rad), ``atol_v`` (rad/s) and ``dense``.
run_dop853 = compile_walk(advance_dop853, _dop853_scratch, "dop853")


@kernel
def run_one(ks, runs, out, rows):
    """:func:`run_dop853` on ``ks[0]`` with options ``runs[0]`` (the front end's single call)."""
    return run_dop853(ks[0], runs[0], out, rows)


def solve_dop853(system: System, n_swings: int, *, rtol: float = 1e-10, atol: float | None = None,
                 max_segments: int | None = None, max_steps: int | None = None, dense: bool = False,
                 t_end: float = math.inf) -> Trajectory:
    """Integrate with the compiled DOP853 and located events (spring or pendulum, any smooth torque).

    Parameters
    ----------
    system
        One parameter set (:class:`~escfit.balance.system.System`).
    n_swings
        Half swings wanted.
    rtol
        Relative tolerance of the local error of each step, as in
        :func:`scipy.integrate.solve_ivp`.
    atol
        Absolute tolerance of theta (rad); default ``1e-2 * rtol * |theta0|`` (1e-12 rad for a
        release at 1 rad).  That of omega is ``atol`` times the highest natural frequency.
    max_segments
        Segment budget (default ``64*n_swings + 1000``).
    max_steps
        Step budget (default ``10_000*n_swings + 100_000``).
    dense
        Keep the dense solution (:attr:`Trajectory.dense`).
    t_end
        End the run at the first accepted step reaching this time (s), if it comes first.
    """
    k = system.k
    theta0 = float(k["theta0"][0])
    if atol is None:
        atol = 1e-2 * rtol * abs(theta0) or 1e-12
    if not (1e-15 <= rtol < 1.0 and atol > 0.0 and math.isfinite(atol)):
        raise SolverError(f"dop853 needs 1e-15 <= rtol < 1 and atol > 0, got rtol={rtol!r}, atol={atol!r}")
    pieces = int(k["n_pieces"][0])
    atol_v = atol * math.sqrt(float(np.max(k["sp_w2"][0, :pieces])))
    nseg = int(max_segments or 64 * n_swings + 1000)
    nsteps = int(max_steps or 10_000 * n_swings + 100_000)
    options = {"rtol": rtol, "atol": atol, "max_segments": nseg, "max_steps": nsteps}
    run = run_options(n_swings, max_segments=nseg, max_steps=nsteps, t_end=t_end, dense=dense, rtol=rtol,
                      atol_x=atol, atol_v=atol_v)
    out = half_swings(n_swings)
    # room for ~64 steps per half swing; more is made when a run needs it
    res, rows = with_rows(lambda buf: run_one(k, run, out, buf), 64 * min(n_swings, 10_000) + 256, 9, dense)
    traj = Trajectory(*columns(out, res.n_done), Status(res.status), system.omega0, "dop853", options, res.n_seg,
                      res.steps, (res.t, res.theta, res.omega))
    if dense:
        traj.dense = RowSolution(rows[:res.rows].copy(), ROW_DOP853, k, traj)
    return traj

