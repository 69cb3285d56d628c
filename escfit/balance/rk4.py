"""Fixed-step classical Runge-Kutta (RK4), as the seed documents integrated the balance.

Two modes show what event handling is worth:

- ``locate_events=True`` (default): inside a segment the regime (friction sign, windows,
  hairspring piece) is frozen; a step that crosses a window edge or a turning point is
  cut back to the event, located by regula falsi on the RK4 step itself, so the method
  keeps its fourth order.
- ``locate_events=False``: the naive integrator evaluates the discontinuous right-hand side
  at every stage and steps straight over switches; turning points are only interpolated for
  the output.  Its error is first order in ``h`` whenever a switch falls inside a step.

Both modes handle a spring and a pendulum (``pend``: restoring acceleration
``w2*sin(theta)`` instead of ``w2*theta + off``).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.errors import SolverError
from ..core.kernels import kernel
from .effects.base import SystemBuilder
from .exact import _applies, _region, _swing_edges
from .segment import creep_horizon, creeps_to_rest
from .solvers import OVER_THE_TOP, static_args, status_of
from .trajectory import Trajectory

__all__ = ["solve_rk4"]


@kernel(inline="always")
def _acc(x, v, c, w2, xc, pend):
    """Swing-frame acceleration: ``-c v - w2 (x - xc)``, or ``-c v - w2 (sin x - xc)`` (pendulum)."""
    if pend:
        return -c * v - w2 * (math.sin(x) - xc)
    return -c * v - w2 * (x - xc)


@kernel(inline="always")
def _step(x, v, dt, c, w2, xc, pend):
    k1x = v
    k1v = _acc(x, v, c, w2, xc, pend)
    x2 = x + 0.5 * dt * k1x
    v2 = v + 0.5 * dt * k1v
    k2x = v2
    k2v = _acc(x2, v2, c, w2, xc, pend)
    x3 = x + 0.5 * dt * k2x
    v3 = v + 0.5 * dt * k2v
    k3x = v3
    k3v = _acc(x3, v3, c, w2, xc, pend)
    x4 = x + dt * k3x
    v4 = v + dt * k3v
    k4x = v4
    k4v = _acc(x4, v4, c, w2, xc, pend)
    return (x + dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x),
            v + dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v))


@kernel
def _locate(x, v, dt, c, w2, xc, pend, which, target):
    """Partial step in (0, dt] at which x reaches target (which=0) or v reaches 0 (which=1)."""
    lo = 0.0
    hi = dt
    if which == 1 and v <= 0.0:  # starting from rest: move lo off the trivial root
        lo = dt
        for _ in range(80):
            lo *= 0.5
            _, vl = _step(x, v, lo, c, w2, xc, pend)
            if vl > 0.0:
                break
    xl, vl = _step(x, v, lo, c, w2, xc, pend) if lo > 0.0 else (x, v)
    xh, vh = _step(x, v, hi, c, w2, xc, pend)
    gl = xl - target if which == 0 else -vl
    gh = xh - target if which == 0 else -vh
    side = 0
    tau = hi
    for _ in range(100):
        tau = (lo * gh - hi * gl) / (gh - gl) if gh != gl else 0.5 * (lo + hi)
        if not (lo < tau < hi):
            tau = 0.5 * (lo + hi)
        xm, vm = _step(x, v, tau, c, w2, xc, pend)
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
def _run_located(theta0, v0, c, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, bank, restitution, pend,
                 n_swings, h, max_steps, amp, theta_turn, half_period, time, banked):
    s = 1.0 if theta0 < 0.0 else -1.0
    x = s * theta0
    v = 0.0
    t = 0.0
    t_last = 0.0
    n_done = 0
    steps = 0
    status = 0
    any_bank = False
    edges = np.empty(2 * w_lo.shape[0] + sp_bp.shape[0] + 1)
    n_edges = _swing_edges(s, bank, sp_bp, w_lo, w_hi, w_dir, edges)
    at_start = True
    scale = -1.0
    while n_done < n_swings:
        j, w2, xc = _region(x, s, edges, n_edges, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, r)
        if at_start and v <= 0.0 and _acc(x, 0.0, c, w2, xc, pend) <= 0.0:
            status = 1
            break
        xb = edges[j] if j < n_edges else math.inf
        t0 = t
        k = 0
        event = -1
        x_seg, v_seg = x, v
        if scale < 0.0:  # the run's scale: the release's offset from its rest position (rad)
            scale = math.sqrt(_acc(x, 0.0, c, w2, xc, pend) ** 2 + w2 * v * v) / w2
        horizon = creep_horizon(c, w2)
        while True:
            if steps >= max_steps:
                status = 3
                break
            if k * h > horizon:
                status = 1  # no event within many time constants: creeping to rest
                break
            xn, vn = _step(x, v, h, c, w2, xc, pend)
            steps += 1
            if pend and xn >= math.pi:
                status = OVER_THE_TOP
                break
            hit_edge = xn >= xb
            hit_turn = vn <= 0.0
            if hit_edge or hit_turn:
                te = _locate(x, v, h, c, w2, xc, pend, 0, xb) if hit_edge else math.inf
                tt = _locate(x, v, h, c, w2, xc, pend, 1, 0.0) if hit_turn else math.inf
                if te <= tt:
                    x, v = _step(x, v, te, c, w2, xc, pend)
                    x = xb
                    t = t0 + k * h + te
                    event = 0
                else:
                    x, v = _step(x, v, tt, c, w2, xc, pend)
                    v = 0.0
                    t = t0 + k * h + tt
                    event = 1
                break
            x, v = xn, vn
            k += 1
            t = t0 + k * h
        if status != 0:
            break
        if event == 1 and creeps_to_rest(_acc(x, 0.0, c, w2, xc, pend) / w2, math.sqrt(
                _acc(x_seg, 0.0, c, w2, xc, pend) ** 2 + w2 * v_seg * v_seg) / w2, scale):
            status = 1  # a turn on the rest position to within rounding: a creep to rest
            break
        at_start = False
        is_bank = event == 0 and j == n_edges - 1 and math.isfinite(bank)
        if event == 0 and not is_bank:
            continue
        amp[n_done] = abs(x)
        theta_turn[n_done] = s * x
        half_period[n_done] = t - t_last
        time[n_done] = t
        banked[n_done] = 1 if is_bank else 0
        any_bank = any_bank or is_bank
        t_last = t
        n_done += 1
        s = -s
        x = -x
        v = restitution * v if is_bank else 0.0
        at_start = v == 0.0
        n_edges = _swing_edges(s, bank, sp_bp, w_lo, w_hi, w_dir, edges)
    if status == 0 and any_bank:
        status = 2
    return n_done, status, steps, t, s * x, s * v


@kernel(inline="always")
def _accel(th, om, s, c, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, pend):
    i = 0
    while i < sp_bp.shape[0] and sp_bp[i] <= th:
        i += 1
    spring = sp_w2[i] * math.sin(th) if pend else sp_w2[i] * th + sp_off[i]
    a = -c * om - spring - s * r
    x = s * th
    for k in range(w_lo.shape[0]):
        if _applies(w_dir[k], s) and w_lo[k] <= x < w_hi[k]:
            a += s * w_x[k]
    return a


@kernel
def _run_naive(theta0, v0, c, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, bank, restitution, pend,
               n_swings, h, max_steps, amp, theta_turn, half_period, time, banked):
    """Steps over every switch; friction and window sign follow the sign of the stage velocity."""
    th = theta0
    om = 0.0
    s_prev = 1.0 if theta0 < 0.0 else -1.0
    t_last = 0.0
    n_done = 0
    status = 0
    k = 0
    horizon = creep_horizon(c, sp_w2.min())  # the softest piece: the longest horizon, never a stop too early
    while n_done < n_swings:
        if k >= max_steps:
            status = 3
            break
        if k * h - t_last > horizon:
            status = 1  # no turning point within many time constants: creeping to rest
            break
        sv = s_prev
        a1 = _accel(th, om, sv if om == 0.0 else math.copysign(1.0, om),
                    c, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, pend)
        o2 = om + 0.5 * h * a1
        a2 = _accel(th + 0.5 * h * om, o2, sv if o2 == 0.0 else math.copysign(1.0, o2),
                    c, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, pend)
        o3 = om + 0.5 * h * a2
        a3 = _accel(th + 0.5 * h * o2, o3, sv if o3 == 0.0 else math.copysign(1.0, o3),
                    c, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, pend)
        o4 = om + h * a3
        a4 = _accel(th + h * o3, o4, sv if o4 == 0.0 else math.copysign(1.0, o4),
                    c, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, pend)
        thn = th + h / 6.0 * (om + 2.0 * o2 + 2.0 * o3 + o4)
        omn = om + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        k += 1
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
            t_turn = (k - 1 + u) * h
            amp[n_done] = abs(th_turn)
            theta_turn[n_done] = th_turn
            half_period[n_done] = t_turn - t_last
            time[n_done] = t_turn
            banked[n_done] = 0
            t_last = t_turn
            n_done += 1
            s_new = -s_prev
            a_rest = _accel(th_turn, 0.0, s_new, c, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, pend)
            if a_rest * s_new <= 0.0:
                status = 1
                th = th_turn
                om = 0.0
                break
            s_prev = s_new
        th, om = thn, omn
    return n_done, status, k, k * h, th, om


def solve_rk4(sys: SystemBuilder, n_swings: int, switching: str, *, h: float = 1e-6,
              locate_events: bool = True, max_steps: int | None = None) -> Trajectory:
    """Integrate with fixed-step RK4.

    Parameters
    ----------
    h
        Step size, s (the Theory of Horology used 1e-7 s).
    locate_events
        Cut steps at switches and turning points (fourth order) or step over them.
    max_steps
        Step budget; default covers half swings up to 50 times the nominal pi/omega0.
    """
    from .solvers import _check_system

    _check_system(sys, switching)
    if not (h > 0 and math.isfinite(h)):
        raise SolverError(f"RK4 step h must be a positive number of seconds, got {h!r}")
    if sys.bank != math.inf and not locate_events:
        raise SolverError("banking needs locate_events=True with rk4")
    if max_steps is None:
        max_steps = int(min(50.0 * n_swings * math.pi / (sys.omega0 * h) + 10_000, 2**62))
    out = (np.empty(n_swings), np.empty(n_swings), np.empty(n_swings), np.empty(n_swings), np.zeros(n_swings, np.int8))
    run = _run_located if locate_events else _run_naive
    pend = sys.restoring == "pendulum"
    n_done, status, steps, t, th, om = run(*static_args(sys, "rk4"), pend, n_swings, float(h), int(max_steps), *out)
    name, message = status_of(status)
    return Trajectory(
        *(a[:n_done].copy() for a in out[:4]), out[4][:n_done].astype(bool), name, sys.omega0,
        "rk4", {"h": h, "locate_events": locate_events, "max_steps": max_steps}, 0, steps, (t, th, om),
        message=message,
    )
