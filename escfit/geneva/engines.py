"""Integrators for one pin engagement, all with the same interface.

An engine integrates the driver from local angle ``x0`` (speed ``w0`` at time ``t0``) until
the pin reaches ``x_end`` (hand-over), the time ``t_stop`` or a lock, whichever is first.  It
samples the motion at the requested times and reports the extreme driver speeds of the
engagement, located between steps (not read off the sample grid).

Engines work in the model's scaled units: torque over follower inertia ``E = 1``, so time is
in units of ``sqrt(I_f/K)`` and speed in units of ``sqrt(K/I_f)``.  The caller scales.

Engines
-------
``rk4``
    Classical fourth-order Runge-Kutta with a fixed step, compiled with numba; the hand-over
    step is shortened so the engagement ends on ``x_end`` (cubic Hermite crossing estimate).
``dop853``
    scipy's ``solve_ivp(method="DOP853")`` with tight tolerances; the hand-over, locks and
    speed extrema are located as events.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from ..core.kernels import kernel
from .dynamics import AMBIGUOUS, LOCKED, acceleration, acceleration_array, switch_function, wedge_margin

__all__ = ["EngagementResult", "rk4_engagement", "dop853_engagement", "ENGINES",
           "END_COMPLETE", "END_TIME", "END_LOCKED"]

END_COMPLETE = 0
END_TIME = 1
END_LOCKED = 2


@dataclass(frozen=True)
class EngagementResult:
    """What one engine call returns (scaled units).

    Attributes
    ----------
    reason
        :data:`END_COMPLETE` (hand-over reached), :data:`END_TIME` or :data:`END_LOCKED`.
    t, x, w, alpha
        State where integration ended (``x`` may overshoot ``x_end`` by round-off only).
    peak_w, peak_t, min_w, min_t
        Largest and smallest driver speed within the engagement and when.
    ambiguous_t
        First time both friction signs were consistent, or NaN.
    n_steps
        Integration steps taken.
    n_samples
        How many of the requested sample times (a prefix) were filled.
    samp_x, samp_w, samp_alpha
        Local angle, speed and acceleration at those sample times.
    """

    reason: int
    t: float
    x: float
    w: float
    alpha: float
    peak_w: float
    peak_t: float
    min_w: float
    min_t: float
    ambiguous_t: float
    n_steps: int
    n_samples: int
    samp_x: np.ndarray
    samp_w: np.ndarray
    samp_alpha: np.ndarray


# ----------------------------------------------------------------------------- rk4


@kernel
def _hermite(p0: float, d0: float, p1: float, d1: float, h: float, s: float) -> float:
    s2 = s * s
    s3 = s2 * s
    return ((2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * h * d0
            + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * h * d1)


@kernel
def _rk4_step(x, w, al, h, a, rho, mu):
    # returns x1, w1, al1, worst code seen in the stages
    worst = 0
    k2x = w + 0.5 * h * al
    al2, _, c2 = acceleration(x + 0.5 * h * w, k2x, a, rho, mu, 1.0)
    k3x = w + 0.5 * h * al2
    al3, _, c3 = acceleration(x + 0.5 * h * k2x, k3x, a, rho, mu, 1.0)
    k4x = w + h * al3
    al4, _, c4 = acceleration(x + h * k3x, k4x, a, rho, mu, 1.0)
    worst = max(c2, max(c3, c4))
    x1 = x + h / 6.0 * (w + 2.0 * k2x + 2.0 * k3x + k4x)
    w1 = w + h / 6.0 * (al + 2.0 * al2 + 2.0 * al3 + al4)
    if worst == LOCKED or not (w1 >= 0.0):
        return x1, w1, 0.0, LOCKED
    al1, _, c1 = acceleration(x1, w1, a, rho, mu, 1.0)
    return x1, w1, al1, max(worst, c1)


@kernel
def _rk4_kernel(x0, x_end, t0, w0, t_stop, dt, a, rho, mu, samp_t, samp_x, samp_w, samp_al):
    nan = math.nan
    t = t0
    x = x0
    w = w0
    al, _, code = acceleration(x, w, a, rho, mu, 1.0)
    n = samp_t.shape[0]
    j = 0
    if code == LOCKED:
        return END_LOCKED, t, x, w, al, w, t, w, t, nan, 0, 0
    amb = t if code == AMBIGUOUS else nan
    peak_w = w
    peak_t = t
    min_w = w
    min_t = t
    while j < n and samp_t[j] <= t:
        samp_x[j] = x
        samp_w[j] = w
        samp_al[j] = al
        j += 1
    steps = 0
    while True:
        h = dt
        at_stop = False
        if t + h >= t_stop:
            h = t_stop - t
            at_stop = True
        if h <= 0.0:
            return END_TIME, t, x, w, al, peak_w, peak_t, min_w, min_t, amb, steps, j
        x1, w1, al1, c = _rk4_step(x, w, al, h, a, rho, mu)
        crossed = False
        if c != LOCKED and x1 >= x_end:
            lo = 0.0
            hi = 1.0
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if _hermite(x, w, x1, w1, h, mid) < x_end:
                    lo = mid
                else:
                    hi = mid
            h = hi * h
            x1, w1, al1, c = _rk4_step(x, w, al, h, a, rho, mu)
            for _ in range(4):  # Newton on the step length: land on x_end to round-off
                if c == LOCKED or w1 <= 0.0 or abs(x1 - x_end) <= 1e-15 * (1.0 + abs(x_end)):
                    break
                h = h + (x_end - x1) / w1
                x1, w1, al1, c = _rk4_step(x, w, al, h, a, rho, mu)
            crossed = True
            at_stop = False
        elif c != LOCKED and mu > 0.0:
            # split the step where the friction sign flips: alpha has a kink there, and a
            # kink inside a step would cost RK4 two orders of accuracy
            q0 = switch_function(x, w, a, rho, mu, 1.0)
            if (q0 > 0.0) != (switch_function(x1, w1, a, rho, mu, 1.0) > 0.0):
                lo = 0.0
                hi = 1.0
                for _ in range(50):
                    mid = 0.5 * (lo + hi)
                    qm = switch_function(_hermite(x, w, x1, w1, h, mid), _hermite(w, al, w1, al1, h, mid),
                                         a, rho, mu, 1.0)
                    if (qm > 0.0) == (q0 > 0.0):
                        lo = mid
                    else:
                        hi = mid
                if hi > 1e-6 and hi < 1.0 - 1e-6:
                    h = hi * h
                    x1, w1, al1, c = _rk4_step(x, w, al, h, a, rho, mu)
                    at_stop = False
        steps += 1
        if c == LOCKED:
            return END_LOCKED, t, x, w, al, peak_w, peak_t, min_w, min_t, amb, steps, j
        if c == AMBIGUOUS and amb != amb:
            amb = t
        t1 = t + h
        while j < n and samp_t[j] <= t1:
            s = (samp_t[j] - t) / h
            xs = _hermite(x, w, x1, w1, h, s)
            ws = _hermite(w, al, w1, al1, h, s)
            samp_x[j] = xs
            samp_w[j] = ws
            samp_al[j] = acceleration(xs, ws, a, rho, mu, 1.0)[0]
            j += 1
        # extrema of the cubic speed interpolant inside the step: roots of dw/ds
        qa = 6.0 * w + 3.0 * h * al - 6.0 * w1 + 3.0 * h * al1
        qb = -6.0 * w - 4.0 * h * al + 6.0 * w1 - 2.0 * h * al1
        qc = h * al
        roots = (nan, nan)
        if abs(qa) > 1e-300:
            disc = qb * qb - 4.0 * qa * qc
            if disc >= 0.0:
                sq = math.sqrt(disc)
                roots = ((-qb - sq) / (2.0 * qa), (-qb + sq) / (2.0 * qa))
        elif abs(qb) > 1e-300:
            roots = (-qc / qb, nan)
        for r in roots:
            if r > 0.0 and r < 1.0:
                wr = _hermite(w, al, w1, al1, h, r)
                if wr > peak_w:
                    peak_w = wr
                    peak_t = t + r * h
                if wr < min_w:
                    min_w = wr
                    min_t = t + r * h
        if w1 > peak_w:
            peak_w = w1
            peak_t = t1
        if w1 < min_w:
            min_w = w1
            min_t = t1
        t = t1
        x = x1
        w = w1
        al = al1
        if crossed:
            return END_COMPLETE, t, x, w, al, peak_w, peak_t, min_w, min_t, amb, steps, j
        if at_stop:
            return END_TIME, t, x, w, al, peak_w, peak_t, min_w, min_t, amb, steps, j


def rk4_engagement(x0: float, x_end: float, t0: float, w0: float, t_stop: float, a: float, rho: float,
                   mu: float, samp_t: np.ndarray, *, dt: float) -> EngagementResult:
    """Integrate one engagement with fixed-step RK4 (scaled units, see module docstring).

    Parameters
    ----------
    x0, x_end
        Local driver angle at the start and at hand-over, rad.
    t0, w0
        Start time and driver speed (scaled).
    t_stop
        Latest time to integrate to (scaled).
    a, rho, mu
        Geometry ratio ``1/sin(pi/n)``, inertia ratio ``I_d/I_f``, friction coefficient.
    samp_t
        Increasing sample times (scaled); a prefix inside the engagement is filled.
    dt
        Step (scaled time).
    """
    samp_t = np.ascontiguousarray(samp_t, dtype=float)
    sx = np.empty_like(samp_t)
    sw = np.empty_like(samp_t)
    sa = np.empty_like(samp_t)
    out = _rk4_kernel(float(x0), float(x_end), float(t0), float(w0), float(t_stop), float(dt),
                      float(a), float(rho), float(mu), samp_t, sx, sw, sa)
    n = int(out[11])
    return EngagementResult(int(out[0]), *map(float, out[1:10]), int(out[10]), n, sx[:n], sw[:n], sa[:n])


# -------------------------------------------------------------------------- dop853


def dop853_engagement(x0: float, x_end: float, t0: float, w0: float, t_stop: float, a: float, rho: float,
                      mu: float, samp_t: np.ndarray, *, rtol: float = 1e-11, atol: float = 1e-12,
                      max_step: float = 0.05) -> EngagementResult:
    """Integrate one engagement with scipy's DOP853 and located events (scaled units).

    Parameters are those of :func:`rk4_engagement`; ``rtol``, ``atol`` and ``max_step``
    (scaled time) go to :func:`scipy.integrate.solve_ivp`.
    """
    nan = math.nan

    def rhs(t, y):
        return (y[1], acceleration(y[0], max(y[1], 0.0), a, rho, mu, 1.0)[0])

    def ev_end(t, y):
        return y[0] - x_end

    ev_end.terminal, ev_end.direction = True, 1.0

    def ev_lock(t, y):
        return acceleration(y[0], max(y[1], 0.0), a, rho, mu, 1.0)[1]

    ev_lock.terminal, ev_lock.direction = True, -1.0

    def ev_stop(t, y):
        return y[1]

    ev_stop.terminal, ev_stop.direction = True, -1.0

    def ev_turn(t, y):
        return acceleration(y[0], max(y[1], 0.0), a, rho, mu, 1.0)[0]

    def ev_wedge(t, y):
        return wedge_margin(y[0], a, rho, mu)

    ev_wedge.direction = -1.0

    samp_t = np.asarray(samp_t, dtype=float)
    al0, _, code0 = acceleration(x0, w0, a, rho, mu, 1.0)
    if code0 == LOCKED or t_stop <= t0:
        n0 = int(np.searchsorted(samp_t, t0, side="right"))
        reason = END_LOCKED if code0 == LOCKED else END_TIME
        return EngagementResult(reason, t0, x0, w0, al0, w0, t0, w0, t0, nan, 0, n0,
                                np.full(n0, x0), np.full(n0, w0), np.full(n0, al0))
    sol = solve_ivp(rhs, (t0, t_stop), [x0, w0], method="DOP853", rtol=rtol, atol=atol, max_step=max_step,
                    dense_output=True, events=(ev_end, ev_lock, ev_stop, ev_turn, ev_wedge))
    t_end = float(sol.t[-1])
    x_fin, w_fin = float(sol.y[0, -1]), float(sol.y[1, -1])
    if sol.t_events[0].size:
        reason = END_COMPLETE
    elif sol.t_events[1].size or sol.t_events[2].size or sol.status == -1:
        reason = END_LOCKED
    else:
        reason = END_TIME
    al_fin, _, _ = acceleration(x_fin, max(w_fin, 0.0), a, rho, mu, 1.0)
    # candidate extrema: start, end and located turning points
    cand_t = np.concatenate(([t0, t_end], sol.t_events[3]))
    cand_w = np.concatenate(([w0, w_fin], sol.y_events[3][:, 1] if sol.t_events[3].size else []))
    i_max, i_min = int(np.argmax(cand_w)), int(np.argmin(cand_w))
    n = int(np.searchsorted(samp_t, t_end, side="right"))
    ts = samp_t[:n]
    inside = ts >= t0
    ys = np.empty((2, n))
    ys[:, ~inside] = np.array([[x0], [w0]])
    if inside.any():
        ys[:, inside] = sol.sol(ts[inside])
    alphas = acceleration_array(ys[0].copy(), ys[1].copy(), a, rho, mu, 1.0)
    if wedge_margin(x0, a, rho, mu) < 0.0:
        amb = t0
    elif sol.t_events[4].size:
        amb = float(sol.t_events[4][0])
    else:
        amb = nan
    return EngagementResult(reason, t_end, x_fin, w_fin, float(al_fin), float(cand_w[i_max]), float(cand_t[i_max]),
                            float(cand_w[i_min]), float(cand_t[i_min]), amb, int(sol.t.size - 1), n,
                            ys[0].copy(), ys[1].copy(), alphas)


ENGINES = {"rk4": rk4_engagement, "dop853": dop853_engagement}
