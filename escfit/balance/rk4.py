"""Fixed-step classical Runge-Kutta (RK4), as the seed documents integrated the balance.

Two modes show what event handling is worth:

- ``locate_events=True`` (default): inside a segment the regime (friction sign, windows,
  hairspring piece) is frozen; a step that crosses a window edge or a turning point is
  cut back to the event, located by regula falsi on the RK4 step itself, so the method
  keeps its fourth order.
- ``locate_events=False``: the naive integrator evaluates the discontinuous right-hand side
  at every stage and steps straight over switches; turning points are only interpolated for
  the output.  Its error is first order in ``h`` whenever a switch falls inside a step.

Both modes integrate :func:`escfit.balance.acceleration.acceleration`, so they handle a spring, a
pendulum and every smooth torque an effect defines, with no code of any effect here.  With
``dense=True`` the located mode keeps a row every 64 steps and at every event; the dense
solution (:class:`escfit.balance.solution.RowSolution`) re-steps from the row, which reproduces
the run's own steps.  The naive mode keeps none: it steps over the switches, so its motion
between steps is not a solution of any one regime (``dense`` is refused there).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.errors import SolverError
from ..core.kernels import kernel
from ..core.status import Status
from .kernel_records import ROWS_FULL, columns, half_swings, run_options, with_rows
from .regions import region_at, swing_edges
from .segment import creep_horizon
from .solution import ROW_RK4, RowSolution, write_row
from .steps import rk4_step
from .system import System
from .acceleration import acceleration
from .trajectory import Trajectory
from .walker import EDGE, END, FAILED, REST, TURN, Segment, Walk, compile_walk

__all__ = ["solve_rk4"]

_STOPPED, _BANKED, _MAX_SEGMENTS = int(Status.STOPPED), int(Status.BANKED), int(Status.MAX_SEGMENTS)
_OVER_THE_TOP = int(Status.OVER_THE_TOP)
ROW_STEPS = 64  # whole steps per row of the dense solution


@kernel
def _locate(x, v, dt, regime, event):
    """Partial step in (0, dt] at which x reaches ``target`` (``event = (0, target)``) or v reaches 0
    (``event = (1, 0.0)``), by regula falsi (Illinois) on the RK4 step itself."""
    which, target = event
    lo = 0.0
    hi = dt
    if which == 1 and v <= 0.0:  # starting from rest: move lo off the trivial root
        lo = dt
        for _ in range(80):
            lo *= 0.5
            _, vl = rk4_step(x, v, lo, regime)
            if vl > 0.0:
                break
    xl, vl = rk4_step(x, v, lo, regime) if lo > 0.0 else (x, v)
    xh, vh = rk4_step(x, v, hi, regime)
    gl = xl - target if which == 0 else -vl
    gh = xh - target if which == 0 else -vh
    side = 0
    tau = hi
    for _ in range(100):
        tau = (lo * gh - hi * gl) / (gh - gl) if gh != gl else 0.5 * (lo + hi)
        if not (lo < tau < hi):
            tau = 0.5 * (lo + hi)
        xm, vm = rk4_step(x, v, tau, regime)
        gm = xm - target if which == 0 else -vm
        if gm == 0.0 or hi - lo <= 1e-15 * dt:
            break
        if gm < 0.0:
            lo, gl = tau, gm
            if side == -1:
                gh *= 0.5
            side = -1
        else:
            hi, gh = tau, gm
            if side == 1:
                gl *= 0.5
            side = 1
    return tau


@kernel
def _row(rows, n_rows, state, where, regime):
    """Write dense row ``n_rows`` starting at ``state = (t0, x, v)``; ``where = (s, swing, h)``.
    Returns whether there was room."""
    if n_rows >= rows.shape[0]:
        return False
    t0, x, v = state
    s, swing, h = where
    w2, xc, _ = regime
    write_row(rows, n_rows, (t0, 0.0, s, x, v), (xc, w2), h, swing)
    rows[n_rows, 9] = 0.0
    return True


@kernel
def _rk4_scratch(k):
    """Fixed steps keep nothing from one region to the next."""
    return 0


@kernel
def advance_rk4(k, run, start, region, work, rows, n_rows):
    """One region of a half swing by fixed RK4 steps of ``run.h``: the walk's step
    (:mod:`escfit.balance.walker`).

    A step that passes the edge ahead or a turning point is cut back to the event, located by
    regula falsi on the step map (:func:`_locate`).  Ends early (``REST``) when no event comes
    within :func:`~escfit.balance.segment.creep_horizon`, (``END``) at the first step reaching
    ``run.t_end``, or fails: the step budget (status ``max_segments``), a pendulum over the top,
    no room for a dense row.  With ``run.dense`` a row is kept at the region's start and every
    :data:`ROW_STEPS` steps.
    """
    t0, x, v, s, swing, steps0 = start
    w2, xc, xb, _ = region
    regime = (w2, xc, k)
    h = run.h
    record = run.dense != 0
    pend = k.pendulum != 0
    budget = run.max_steps - steps0
    motion = math.sqrt(acceleration(x, 0.0, w2, xc, k) ** 2 + w2 * v * v) / w2
    horizon = creep_horizon(k.c, w2)
    n = 0  # whole steps
    taken = 0  # steps tried, the cut-back one included
    event = -1
    fail = 0
    t = t0
    row_start = 0
    if record:
        if not _row(rows, n_rows, (t0, x, v), (s, swing, h), regime):
            return Segment(FAILED, 0.0, x, v, 0.0, x, motion, ROWS_FULL, 0, n_rows)
        n_rows += 1
    while True:
        if taken >= budget:
            fail = _MAX_SEGMENTS
            break
        if n * h > horizon:
            event = REST  # no event within many time constants: creeping to rest
            break
        xn, vn = rk4_step(x, v, h, regime)
        taken += 1
        if pend and xn >= math.pi:
            fail = _OVER_THE_TOP
            break
        hit_edge = xn >= xb
        hit_turn = vn <= 0.0
        if hit_edge or hit_turn:
            te = _locate(x, v, h, regime, (0, xb)) if hit_edge else math.inf
            tt = _locate(x, v, h, regime, (1, 0.0)) if hit_turn else math.inf
            tau = min(te, tt)
            x, v = rk4_step(x, v, tau, regime)
            if te <= tt:
                x = xb
                event = EDGE
            else:
                v = 0.0
                event = TURN
            t = t0 + n * h + tau
            if record:
                rows[n_rows - 1, 1] = t - rows[n_rows - 1, 0]
                rows[n_rows - 1, 9] = n - row_start
            break
        x, v = xn, vn
        n += 1
        t = t0 + n * h
        if record and n - row_start == ROW_STEPS:
            rows[n_rows - 1, 1] = t - rows[n_rows - 1, 0]
            rows[n_rows - 1, 9] = ROW_STEPS
            if not _row(rows, n_rows, (t, x, v), (s, swing, h), regime):
                fail = ROWS_FULL
                break
            n_rows += 1
            row_start = n
        if t >= run.t_end:
            event = END
            break
    if record and event != EDGE and event != TURN:
        rows[n_rows - 1, 1] = t - rows[n_rows - 1, 0]
        rows[n_rows - 1, 9] = n - row_start
    if fail != 0:
        return Segment(FAILED, t - t0, x, v, 0.0, x, motion, fail, taken, n_rows)
    a_rest = acceleration(x, 0.0, w2, xc, k)  # a turn's offset from the rest position is -a/w2
    return Segment(event, t - t0, x, v, a_rest / w2, x + a_rest / w2, motion, 0, taken, n_rows)


#: Fixed steps with events located on the step map: the walk of :mod:`escfit.balance.walker` with
#: :func:`advance_rk4`, ``_run_located(k, run, out, rows) -> Walk``.
_run_located = compile_walk(advance_rk4, _rk4_scratch, "rk4")


@kernel(inline="always")
def _accel(th, om, s_prev, k, tables):
    """Balance-frame acceleration in the regime of the direction of ``om`` (``s_prev`` at rest):
    the naive stepping's right-hand side, discontinuous at every switch.  ``tables`` holds the
    switch points of both directions, ``(edges_plus, n_plus, edges_minus, n_minus)``."""
    s = s_prev if om == 0.0 else math.copysign(1.0, om)
    edges_p, n_p, edges_m, n_m = tables
    x = s * th
    if s > 0.0:
        _, w2, xc = region_at(x, s, edges_p, n_p, k)
    else:
        _, w2, xc = region_at(x, s, edges_m, n_m, k)
    return s * acceleration(x, s * om, w2, xc, k)


@kernel
def _run_naive(k, run, out):
    """Steps over every switch; friction and window sign follow the sign of the stage velocity."""
    theta0 = k.theta0
    hold = max(k.r_static - k.r, 0.0)
    h = run.h
    max_steps = run.max_steps
    th = theta0
    om = 0.0
    s_prev = 1.0 if theta0 < 0.0 else -1.0
    edges_p = np.empty(2 * k.n_windows + k.n_pieces)
    edges_m = np.empty(2 * k.n_windows + k.n_pieces)
    tables = (edges_p, swing_edges(1.0, k, edges_p), edges_m, swing_edges(-1.0, k, edges_m))
    t_last = 0.0
    n_done = 0
    status = 0
    n = 0
    soft = k.sp_w2[0]
    for i in range(k.n_pieces):
        soft = min(soft, k.sp_w2[i])
    horizon = creep_horizon(k.c, soft)  # the softest piece: the longest horizon, never a stop too early
    while n_done < run.n_swings:
        if n >= max_steps:
            status = _MAX_SEGMENTS
            break
        if n * h - t_last > horizon:
            status = _STOPPED  # no turning point within many time constants: creeping to rest
            break
        a1 = _accel(th, om, s_prev, k, tables)
        o2 = om + 0.5 * h * a1
        a2 = _accel(th + 0.5 * h * om, o2, s_prev, k, tables)
        o3 = om + 0.5 * h * a2
        a3 = _accel(th + 0.5 * h * o2, o3, s_prev, k, tables)
        o4 = om + h * a3
        a4 = _accel(th + h * o3, o4, s_prev, k, tables)
        thn = th + h / 6.0 * (om + 2.0 * o2 + 2.0 * o3 + o4)
        omn = om + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        n += 1
        if omn * s_prev < 0.0 or omn == 0.0:
            # velocity changed sign in this step: interpolate the turning point (cubic Hermite)
            d0 = om * h
            d1 = omn * h
            p = 3.0 * (thn - th)
            # derivative of the Hermite cubic in u: A u^2 + B u + C0
            qa = 3.0 * (d0 + d1) - 2.0 * p
            qb = 2.0 * p - 4.0 * d0 - 2.0 * d1
            qc = d0
            if abs(qa) > 1e-300:
                disc = max(qb * qb - 4.0 * qa * qc, 0.0)
                u1 = (-qb + math.sqrt(disc)) / (2.0 * qa)
                u2 = (-qb - math.sqrt(disc)) / (2.0 * qa)
                u = u1 if 0.0 <= u1 <= 1.0 else u2
            else:
                u = -qc / qb if qb != 0.0 else 1.0
            u = min(max(u, 0.0), 1.0)
            h00 = 2 * u**3 - 3 * u**2 + 1
            h10 = u**3 - 2 * u**2 + u
            h01 = -2 * u**3 + 3 * u**2
            h11 = u**3 - u**2
            th_turn = h00 * th + h10 * d0 + h01 * thn + h11 * d1
            t_turn = (n - 1 + u) * h
            rec = out[n_done]
            rec.amplitude = abs(th_turn)
            rec.theta_turn = th_turn
            rec.half_period = t_turn - t_last
            rec.time = t_turn
            rec.banked = 0
            t_last = t_turn
            n_done += 1
            s_new = -s_prev
            a_rest = _accel(th_turn, 0.0, s_new, k, tables)
            if a_rest * s_new <= hold:
                status = _STOPPED
                th = th_turn
                om = 0.0
                break
            s_prev = s_new
        th, om = thn, omn
    return Walk(n_done, status, 0, n, n * h, th, om, 0)


@kernel
def _run_one(ks, runs, out, rows):
    """The front end's single call: located (``rows`` returned) or naive (no rows)."""
    run = runs[0]
    if run.mode == 1:
        return _run_naive(ks[0], run, out)
    return _run_located(ks[0], run, out, rows)


def solve_rk4(system: System, n_swings: int, *, h: float = 1e-6, locate_events: bool = True,
              max_steps: int | None = None, dense: bool = False, t_end: float = math.inf) -> Trajectory:
    """Integrate with fixed-step RK4.

    Parameters
    ----------
    h
        Step size, s (the Theory of Horology used 1e-7 s).
    locate_events
        Cut steps at switches and turning points (fourth order) or step over them.
    max_steps
        Step budget; default covers half swings up to 50 times the nominal pi/omega0.
    dense
        Keep the dense solution (located events only).
    t_end
        End the run at the first step reaching this time (s), if it comes first (located events only).
    """
    if not (h > 0 and math.isfinite(h)):
        raise SolverError(f"RK4 step h must be a positive number of seconds, got {h!r}")
    if not locate_events:
        if "impacts" in system.needs:
            raise SolverError("banking needs locate_events=True with rk4")
        if dense or math.isfinite(t_end):
            raise SolverError("rk4 with locate_events=False steps over the switches and has no dense solution; "
                              "use locate_events=True")
    if max_steps is None:
        max_steps = int(min(50.0 * n_swings * math.pi / (system.omega0 * h) + 10_000, 2**62))
    out = half_swings(n_swings)
    run = run_options(n_swings, max_segments=2**62, max_steps=int(max_steps), t_end=t_end, dense=dense, h=h,
                      mode=0 if locate_events else 1)
    # room for the rows of ~4 regions and 10_000 steps per half swing; more is made when needed
    rows_per_swing = 4 + int(min(math.pi / (system.omega0 * h), 1e7)) // ROW_STEPS
    res, rows = with_rows(lambda buf: _run_one(system.k, run, out, buf), rows_per_swing * min(n_swings, 1000) + 64,
                          10, dense)
    traj = Trajectory(*columns(out, res.n_done), Status(res.status), system.omega0, "rk4",
                      {"h": h, "locate_events": locate_events, "max_steps": max_steps}, 0, res.steps,
                      (res.t, res.theta, res.omega))
    if dense:
        traj.dense = RowSolution(rows[:res.rows].copy(), ROW_RK4, system.k, traj)
    return traj
