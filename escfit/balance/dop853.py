"""Compiled adaptive Dormand-Prince 8(5,3) with located events, for springs and pendulums.

The piecewise structure is that of :mod:`escfit.balance.exact`: a half swing moving in
direction ``s`` is integrated in the swing frame ``x = s*theta`` (the balance runs from
``x = -A`` towards ``+A``), split into segments of frozen regime ended by a window edge, the
banking pins or the turning point ``v = 0``.  Inside a region with constants ``(w2, xc)``
(:func:`escfit.balance.exact._region_coefficients`; ``w2*xc`` gathers Coulomb friction, the
windows and the hairspring offset) the equation is::

    x'' = -C x' - w2 (x - xc)          spring
    x'' = -C x' - w2 (sin x - xc)      pendulum (w2 = omega0**2)

Steps are those of scipy's ``DOP853`` (same coefficient tables, error norm and step-size
controller), with separate absolute tolerances for theta and omega.  An event inside an
accepted step is located by Newton iteration on the step map itself -- re-stepping from the
step start with the trial length, the derivative being the velocity (edges) or the
acceleration (turning points) at the trial end -- started from a Hermite-cubic guess and kept
inside a sign bracket.  Once the Newton correction is below 1e-6 of the motion's time scale
it is applied by a third-order Taylor expansion of the state (the equation gives the
derivatives), whose remainder lies below rounding, instead of one more step.  Events thus
add no error of their own beyond the integrator's local error.

The kernel also samples theta at requested times (steps are clipped to land on them); see
:mod:`escfit.balance.waveform`.  Like :mod:`escfit.balance.rk4` it compiles functions of
:mod:`escfit.balance.exact` into its kernels; their cache (:func:`escfit.core.kernels.kernel`)
is keyed on that file too, so an edit there recompiles them.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate._ivp import dop853_coefficients as _coefficients

from ..core.errors import SolverError
from ..core.kernels import kernel
from .effects.base import SystemBuilder
from .exact import region_tables
from .segment import creep_horizon, creeps_to_rest
from .solvers import OVER_THE_TOP, STEP_BUDGET, STEP_UNDERFLOW, _check_system, static_args, status_of
from .trajectory import Trajectory

__all__ = ["solve_dop853", "run_dop853", "kernel_inputs"]

_N = _coefficients.N_STAGES  # 12 stages, plus the first-same-as-last evaluation at the step end
_A = np.ascontiguousarray(_coefficients.A[:_N, :_N])
_B = np.ascontiguousarray(_coefficients.B)
_E3 = np.ascontiguousarray(_coefficients.E3)
_E5 = np.ascontiguousarray(_coefficients.E5)
_SAFETY, _MIN_FACTOR, _MAX_FACTOR = 0.9, 0.2, 10.0
_EXPONENT = -1.0 / 8.0  # the error estimate is of order 7 (scipy: -1/(error_estimator_order + 1))
_STOPPED, _MAX_SEGMENTS = 1, 3


@kernel(inline="always")
def _acc(x, v, c, w2, xc, pend):
    """Swing-frame acceleration (rad/s^2) of the frozen regime."""
    if pend:
        return -c * v - w2 * (math.sin(x) - xc)
    return -c * v - w2 * (x - xc)


@kernel
def _rk_step(x, v, a, h, c, w2, xc, pend, kx, kv):
    """One DOP853 step of length ``h`` from ``(x, v)`` with acceleration ``a``; stages in kx, kv."""
    kx[0] = v
    kv[0] = a
    for i in range(1, _N):
        dx = 0.0
        dv = 0.0
        for j in range(i):
            dx += _A[i, j] * kx[j]
            dv += _A[i, j] * kv[j]
        vs = v + h * dv
        kx[i] = vs
        kv[i] = _acc(x + h * dx, vs, c, w2, xc, pend)
    sx = 0.0
    sv = 0.0
    for j in range(_N):
        sx += _B[j] * kx[j]
        sv += _B[j] * kv[j]
    x1 = x + h * sx
    v1 = v + h * sv
    a1 = _acc(x1, v1, c, w2, xc, pend)
    kx[_N] = v1
    kv[_N] = a1
    return x1, v1, a1


@kernel
def _error_norm(x, v, x1, v1, h, kx, kv, rtol, atol_x, atol_v):
    """scipy's DOP853 error norm of the last step (< 1: accept)."""
    e5x = e5v = e3x = e3v = 0.0
    for j in range(_N + 1):
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
def _initial_step(x, v, a, c, w2, xc, pend, rtol, atol_x, atol_v):
    """scipy's ``select_initial_step`` for the 2-d state (s)."""
    sx = atol_x + abs(x) * rtol
    sv = atol_v + abs(v) * rtol
    d0 = math.sqrt(((x / sx) ** 2 + (v / sv) ** 2) / 2.0)
    d1 = math.sqrt(((v / sx) ** 2 + (a / sv) ** 2) / 2.0)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    x1 = x + h0 * v
    v1 = v + h0 * a
    a1 = _acc(x1, v1, c, w2, xc, pend)
    d2 = math.sqrt((((v1 - v) / sx) ** 2 + ((a1 - a) / sv) ** 2) / 2.0) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100.0 * h0, h1)


@kernel
def _locate(x, v, a, c, w2, xc, pend, which, target, hi, x_hi, v_hi, a_hi, kx, kv):
    """Event inside a step: ``x`` rises to ``target`` (which=0) or ``v`` falls to 0 (which=1).

    ``g = x - target`` or ``-v`` changes sign on ``(0, hi]`` (``g(hi) >= 0``, state at ``hi``
    given).  Returns ``(tau, x, v, a)`` at the located time, evaluated by a step of that length.
    """
    lo = 0.0
    g_lo = x - target if which == 0 else -v
    g_hi = x_hi - target if which == 0 else -v_hi
    if g_lo >= 0.0:  # from rest (v = 0, accelerating): move lo off the trivial root
        lo = hi
        for _ in range(200):
            lo *= 0.5
            _, vl, _ = _rk_step(x, v, a, lo, c, w2, xc, pend, kx, kv)
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
    rate = math.sqrt(w2) + c  # inverse time scale of the motion
    xe, ve, ae = x_hi, v_hi, a_hi
    for _ in range(60):
        xe, ve, ae = _rk_step(x, v, a, tau, c, w2, xc, pend, kx, kv)
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
                    jerk = -c * ae - w2 * (math.cos(xe) if pend else 1.0) * ve
                    xn = xe - step * (ve - step * (0.5 * ae - step * jerk / 6.0))
                    vn = ve - step * (ae - 0.5 * step * jerk)
                    return new, xn, vn, _acc(xn, vn, c, w2, xc, pend)
        if hi - lo <= 4e-16 * hi:
            break
        tau = new
    xe, ve, ae = _rk_step(x, v, a, tau, c, w2, xc, pend, kx, kv)
    return tau, xe, ve, ae


@kernel
def run_dop853(theta0, v0, c, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, bank, restitution, pend,
               n_swings, rtol, atol_x, atol_v, max_seg, max_steps, sample_t, sample_theta,
               amp, theta_turn, half_period, time, banked):
    """Integrate half swings (angle switching) from ``theta0, v0``.

    Parameters
    ----------
    theta0, v0, c, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, bank, restitution
        As :func:`escfit.balance.exact.run_angle` (rad, rad/s, 1/s, rad/s^2, 1/s^2).
    pend : bool
        Pendulum: restoring acceleration ``sp_w2[0]*sin(theta)``.
    n_swings, max_seg, max_steps : int
        Half swings wanted, segment and step budgets.
    rtol, atol_x, atol_v : float
        Relative tolerance and absolute tolerances of the local error of theta (rad) and
        omega (rad/s).
    sample_t, sample_theta : ndarray
        Times (s, ascending, >= 0) at which to record theta (rad) and where to put it; when
        non-empty the run ends once they are all recorded.  After a stop theta stays at the
        rest angle; after a failure the remaining samples are NaN.
    amp, theta_turn, half_period, time, banked : ndarray
        Per-half-swing outputs, filled while ``n_done`` is below their length.

    Returns
    -------
    n_done, status, n_seg, n_steps, t, theta, omega : int, int, int, int, float, float, float
        Half swings done, status code (:func:`escfit.balance.solvers.status_of`), segments and
        steps (accepted and rejected) used, and the time (s), angle (rad) and angular velocity
        (rad/s) where the run ended.
    """
    s = 1.0 if theta0 < 0.0 else -1.0
    if v0 != 0.0:
        s = 1.0 if v0 > 0.0 else -1.0
    x = s * theta0
    v = s * v0
    t = 0.0
    t_swing = 0.0  # duration of the current half swing, summed apart from t to keep its precision
    status = 0
    n_done = 0
    n_seg = 0
    n_steps = 0
    any_bank = False
    n_samp = sample_t.shape[0]
    k = 0
    n_out = amp.shape[0]
    kx = np.empty(_N + 1)
    kv = np.empty(_N + 1)
    edge_tab, n_edge_tab, w2_tab, xc_tab = region_tables(bank, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, r)
    d = 0 if s > 0.0 else 1
    h = -1.0
    rejected = False
    at_start = True
    scale = -1.0
    while n_done < n_swings and (n_samp == 0 or k < n_samp):
        if n_seg >= max_seg:
            status = _MAX_SEGMENTS
            break
        n_edges = n_edge_tab[d]
        j = 0
        while j < n_edges and edge_tab[d, j] <= x:
            j += 1
        w2 = w2_tab[d, j]
        xc = xc_tab[d, j]
        xb = edge_tab[d, j] if j < n_edges else math.inf
        n_seg += 1
        event = -1  # 0: edge, 1: turning point
        tau = 0.0
        xe = x
        ve = v
        if v <= 0.0:
            v = 0.0
            a = _acc(x, 0.0, c, w2, xc, pend)
            if a <= 0.0:
                if at_start:
                    status = _STOPPED  # at rest and the net torque cannot overcome static friction
                    break
                event = 1  # came to rest exactly on an edge: a turning point there
        else:
            a = _acc(x, v, c, w2, xc, pend)
        if h < 0.0:
            h = _initial_step(x, v, a, c, w2, xc, pend, rtol, atol_x, atol_v)
        # no turning point within many time constants: creeping to rest (overdamped)
        horizon = creep_horizon(c, w2)
        x_seg, v_seg = x, v
        if scale < 0.0:  # the run's scale: the release's offset from its rest position (rad)
            scale = math.sqrt(_acc(x, 0.0, c, w2, xc, pend) ** 2 + w2 * v * v) / w2
        t_seg = 0.0
        while event < 0:
            while k < n_samp and sample_t[k] <= t:
                sample_theta[k] = s * x
                k += 1
            if n_samp > 0 and k >= n_samp:
                break
            if n_steps >= max_steps:
                status = STEP_BUDGET
                break
            if t_seg > horizon:
                status = _STOPPED
                break
            h_try = h
            clipped = k < n_samp and t + h_try >= sample_t[k]
            if clipped:
                h_try = sample_t[k] - t
            x1, v1, a1 = _rk_step(x, v, a, h_try, c, w2, xc, pend, kx, kv)
            n_steps += 1
            err = _error_norm(x, v, x1, v1, h_try, kx, kv, rtol, atol_x, atol_v)
            if not err < 1.0:  # also NaN
                h = h_try * max(_MIN_FACTOR, _SAFETY * err**_EXPONENT) if math.isfinite(err) else 0.5 * h_try
                rejected = True
                if h <= 1e-15 * (t + h_try):
                    status = STEP_UNDERFLOW
                    break
                continue
            factor = _MAX_FACTOR if err == 0.0 else min(_MAX_FACTOR, _SAFETY * err**_EXPONENT)
            if rejected:
                factor = min(1.0, factor)
            rejected = False
            h_next = h_try * factor
            if clipped:  # a step shortened to land on a sample says nothing about the next one
                h_next = max(h_next, h)
            if v1 <= 0.0:
                tau, xe, ve, ae = _locate(x, v, a, c, w2, xc, pend, 1, 0.0, h_try, x1, v1, a1, kx, kv)
                event = 1
                if xe > xb:  # passed the edge before turning within this step
                    tau, xe, ve, ae = _locate(x, v, a, c, w2, xc, pend, 0, xb, tau, xe, ve, ae, kx, kv)
                    event = 0
            elif x1 >= xb:
                tau, xe, ve, ae = _locate(x, v, a, c, w2, xc, pend, 0, xb, h_try, x1, v1, a1, kx, kv)
                event = 0
            h = h_next
            if pend and (xe if event >= 0 else x1) >= math.pi:
                status = OVER_THE_TOP
                break
            if event >= 0:
                break
            x, v, a = x1, v1, a1
            t = sample_t[k] if clipped else t + h_try
            t_seg += h_try
            t_swing += h_try
        if status != 0 or (n_samp > 0 and k >= n_samp):
            break
        if event == 1 and creeps_to_rest(_acc(xe, 0.0, c, w2, xc, pend) / w2, math.sqrt(
                _acc(x_seg, 0.0, c, w2, xc, pend) ** 2 + w2 * v_seg * v_seg) / w2, scale):
            # the "turn" lies on the rest position to within rounding: a creep to rest, as the
            # exact solver decides it (segment.CREEP_OVERSHOOT), not a swing
            x = xe
            status = _STOPPED
            break
        t += tau
        t_swing += tau
        at_start = False
        is_bank = False
        if event == 0:
            x = xb
            v = max(ve, 0.0)
            is_bank = j == n_edges - 1 and math.isfinite(bank)
            if not is_bank:
                continue
        else:
            x = xe
            v = 0.0
        # end of a half swing: a turning point or an impact on the banking pins
        if n_done < n_out:
            amp[n_done] = abs(x)
            theta_turn[n_done] = s * x
            half_period[n_done] = t_swing
            time[n_done] = t
            banked[n_done] = 1 if is_bank else 0
        any_bank = any_bank or is_bank
        t_swing = 0.0
        n_done += 1
        s = -s
        x = -x
        v = restitution * v if is_bank else 0.0
        at_start = v == 0.0
        d = 1 - d
    rest = s * x if status == _STOPPED else math.nan
    while k < n_samp:
        sample_theta[k] = rest
        k += 1
    if status == 0 and any_bank:
        status = 2
    return n_done, status, n_seg, n_steps, t, s * x, s * v


def kernel_inputs(sys: SystemBuilder, switching: str, n_swings: int, *, budget_swings: int | None = None,
                  rtol: float = 1e-10, atol: float | None = None, max_segments: int | None = None,
                  max_steps: int | None = None) -> tuple[tuple, dict]:
    """Arguments of :func:`run_dop853` up to ``max_steps``, and the options in force.

    The default budgets are ``64*n + 1000`` segments and ``10_000*n + 100_000`` steps with
    ``n = budget_swings`` (default ``n_swings``).  ``atol`` (rad) defaults to ``1e-2 * rtol * |theta0|``; the velocity's
    absolute tolerance is ``atol`` times the highest natural frequency, so both carry the
    motion's own scales.
    """
    _check_system(sys, switching)
    args = static_args(sys, "dop853")
    if atol is None:
        atol = 1e-2 * rtol * abs(sys.theta0) or 1e-12
    if not (1e-15 <= rtol < 1.0 and atol > 0.0 and math.isfinite(atol)):
        raise SolverError(f"dop853 needs 1e-15 <= rtol < 1 and atol > 0, got rtol={rtol!r}, atol={atol!r}")
    atol_v = atol * math.sqrt(float(np.max(args[5])))
    n = budget_swings or n_swings
    nseg = int(max_segments or 64 * n + 1000)
    nsteps = int(max_steps or 10_000 * n + 100_000)
    options = {"rtol": rtol, "atol": atol, "max_segments": nseg, "max_steps": nsteps}
    return (*args, sys.restoring == "pendulum", n_swings, float(rtol), float(atol), atol_v, nseg, nsteps), options


def solve_dop853(sys: SystemBuilder, n_swings: int, switching: str, *, rtol: float = 1e-10,
                 atol: float | None = None, max_segments: int | None = None,
                 max_steps: int | None = None) -> Trajectory:
    """Integrate with the compiled DOP853 and located events (spring or pendulum).

    Parameters
    ----------
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
    """
    args, options = kernel_inputs(sys, switching, n_swings, rtol=rtol, atol=atol, max_segments=max_segments,
                                  max_steps=max_steps)
    out = (np.empty(n_swings), np.empty(n_swings), np.empty(n_swings), np.empty(n_swings), np.zeros(n_swings, np.int8))
    empty = np.zeros(0)
    n_done, status, n_seg, steps, t, th, om = run_dop853(*args, empty, empty, *out)
    name, message = status_of(status)
    return Trajectory(
        *(a[:n_done].copy() for a in out[:4]), out[4][:n_done].astype(bool), name, sys.omega0, "dop853", options,
        n_seg, steps, (t, th, om), message=message,
    )
