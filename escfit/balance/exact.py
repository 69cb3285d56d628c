"""Exact piecewise solver for the balance wheel (numba-compiled kernel).

The run is split into segments in which every coefficient is constant: the viscous
coefficient, the stiffness of the current hairspring piece, the Coulomb torque (whose sign
is fixed within a half swing) and the escapement windows the balance is in.  Each segment
is solved in closed form (:mod:`escfit.balance.segment`); window edges are located by a
safeguarded root solve on that closed form and turning points analytically, so the only
error is floating-point rounding.  With angle switching the half swings are walked by the one
loop of :mod:`escfit.balance.walker` (regions, stop rule, banking, creep, drift, status), this
module supplying only the region step :func:`advance_exact`; the closed form at a turning point is
evaluated only when that point may end the half swing (:func:`_surely_crosses`), which
leaves every result bit for bit what it was.  With phase switching every half cycle of a
direction has the same segments, so it is one affine map of the state, tabulated once per
parameter set (and again when damping drift changes C) and iterated with four multiply-adds.

Frames and signs
----------------
A half swing moving in direction ``s`` (+1 when theta increases) is solved in the swing
frame ``x = s*theta`` in which the balance always runs from ``x = -A`` towards ``+A``.  In
that frame Coulomb friction is the constant ``-R``, an unlock window contributes ``-X``
and an impulse window ``+X``.

:func:`run_angle_many` and :func:`run_phase_many` run the same kernels over many parameter
sets in parallel (front end: :mod:`escfit.balance.batch`).  The functions of
:mod:`escfit.balance.segment` are compiled into all of these kernels; their on-disk cache
(:func:`escfit.core.kernels.kernel`) is keyed on that file and on this one, so an edit of
either recompiles them.

Every kernel takes the coefficient record of :mod:`escfit.balance.kernel_records` whole and returns a
:class:`~escfit.balance.walker.Walk` record whose status is a :class:`~escfit.core.status.Status`
code: ``OK``, ``STOPPED`` (friction holds the balance at
rest -- static friction ``r_static`` at the start of a half swing -- or it creeps to rest without
a further turning point), ``BANKED``, ``MAX_SEGMENTS`` or ``PHASE_BREAKDOWN`` (phase switching: a
half cycle ended on the side it started, so Monday's phase convention no longer describes the
motion).
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..core.kernels import kernel
from ..core.status import Status
from .kernel_records import ROWS_FULL
from .regions import applies
from .segment import cross_time, propagate, turn_time
from .solution import write_row
from .walker import EDGE, FAILED, REST, TURN, Segment, Walk, compile_walk, drift_factor

__all__ = ["run_angle", "run_phase", "run_angle_many", "run_phase_many", "run_one", "run_phase_one", "advance_exact",
           "N_LOG"]

N_LOG = 9  # fields of a segment-log row: t0, tau, s, x0, v0, xc, w2, h, swing
_STOPPED, _BANKED, _MAX_SEGMENTS, _BREAKDOWN = (int(Status.STOPPED), int(Status.BANKED), int(Status.MAX_SEGMENTS),
                                               int(Status.PHASE_BREAKDOWN))


@kernel(inline="always")
def _surely_crosses(y0, v0, h, w2, tau_turn, xc, xb):
    """Whether a forward swing certainly passes the edge ``xb`` before its turning point.

    Decides what ``xc + propagate(y0, v0, tau_turn)[0] > xb`` decides, where the answer is
    certain, without evaluating the closed form (exp, cos, sin): ``Q = v**2 + 2*h*y*v +
    w2*y**2`` decays as ``exp(-2*h*tau)`` under the segment's equation and equals
    ``w2*y**2`` at a turning point, where ``y >= 0`` (a forward swing turns where the
    acceleration is not positive), so ``y_turn = sqrt(Q0/w2)*exp(-h*tau_turn) >=
    sqrt(Q0/w2)*p(h*tau_turn)`` with ``p`` the cubic Taylor polynomial of ``exp(-u)`` (a lower
    bound of it).  The test is squared, so it needs no square root.  The margin, 1e-9 of the
    magnitudes involved, is far above the rounding of either evaluation, so ``True`` never
    contradicts the closed form; ``False`` means "evaluate the closed form at the turn".

    Parameters
    ----------
    y0, v0 : float
        Offset from the centre (rad) and velocity (rad/s) at the segment start (swing frame).
    h, w2 : float
        C/2 (1/s) and stiffness per inertia (1/s^2) of the segment.
    tau_turn : float
        Time of the turning point (s) from :func:`~escfit.balance.segment.turn_time`.
    xc, xb : float
        Centre of the segment and the edge ahead (rad, swing frame; ``inf`` for none).
    """
    if not (tau_turn < math.inf and xb < math.inf):
        return False
    margin = 1e-9 * (abs(xc) + abs(xb) + abs(y0) + tau_turn * (abs(v0) + h * abs(y0)))
    need = (xb - xc) + margin  # y_turn must exceed this
    if not need > 0.0:
        return need < 0.0  # y_turn >= 0; False for a NaN
    u = h * tau_turn
    p = 1.0 - u * (1.0 - u * (0.5 - u * (1.0 / 6.0)))
    if not p > 0.0:
        return False
    q0 = v0 * v0 + 2.0 * h * y0 * v0 + w2 * y0 * y0
    return q0 * p * p > need * need * w2


@kernel
def _no_scratch(k):
    """The closed form keeps nothing from one region to the next."""
    return 0


@kernel
def advance_exact(k, run, start, region, work, log, n_rows):
    """One region of a half swing in closed form: the walk's step (:mod:`escfit.balance.walker`).

    The turning point is evaluated only when it may come before the edge ahead
    (:func:`_surely_crosses`); an edge crossing is located by :func:`cross_time` on the closed
    form.  With ``run.dense`` one row (t0, tau, s, x0, v0, xc, w2, h, swing) is logged per
    region; with no room left the region fails with ``ROWS_FULL``.

    Returns
    -------
    Segment
        ``EDGE``, ``TURN`` (with its overshoot past ``xc``, the rest position) or ``REST``: the
        motion creeps towards ``xc`` without turning or reaching the edge (``tau = inf``).
    """
    t, x, v, s, swing, _ = start
    w2, xc, xb, c = region
    h = 0.5 * c
    y0 = x - xc
    motion = math.sqrt(y0 * y0 + v * v / w2)
    record = run.dense != 0
    if record:
        if n_rows >= log.shape[0]:
            return Segment(FAILED, 0.0, x, v, 0.0, xc, motion, ROWS_FULL, 0, n_rows)
        write_row(log, n_rows, (t, 0.0, s, x, v), (xc, w2), h, swing)
    tau_turn = turn_time(y0, v, h, w2)
    x_turn = xc
    y_turn = 0.0
    # the turning point itself is only needed when it may end the half swing
    crosses = _surely_crosses(y0, v, h, w2, tau_turn, xc, xb)
    if not crosses:
        if math.isfinite(tau_turn):
            y_turn, _ = propagate(y0, v, tau_turn, h, w2)
            x_turn = xc + y_turn
        crosses = x_turn > xb
    if crosses:
        tau, v_new = cross_time(y0, v, h, w2, xb - xc, tau_turn)
        seg = Segment(EDGE, tau, xb, v_new, 0.0, xc, motion, 0, 0, n_rows + 1)
    elif math.isfinite(tau_turn):
        seg = Segment(TURN, tau_turn, x_turn, 0.0, y_turn, xc, motion, 0, 0, n_rows + 1)
    else:
        # creeps towards the centre without turning or reaching another edge
        seg = Segment(REST, math.inf, xc, 0.0, 0.0, xc, motion, 0, 0, n_rows + 1)
    if record:
        log[n_rows, 1] = seg.tau
    return seg


#: Integrate half swings with angle switching (the physical escapement): the walk of
#: :mod:`escfit.balance.walker` with the closed form's region step, ``run_angle(k, run, out, log)
#: -> Walk``.  ``log`` has shape (rows, 9) and receives one row per region when ``run.dense``.
run_angle = compile_walk(advance_exact, _no_scratch, "exact")


@kernel
def _phase_segments(s, w1, k, pts, seg_xc, seg_tau):
    """Segments of a phase-switched half cycle in direction ``s``; returns their number.

    The half cycle runs from phase 0 to pi; window limits are phase offsets from pi/2.  Fills
    ``seg_xc`` (centre of each segment in the swing frame, rad) and ``seg_tau`` (its
    duration, s, for the damped frequency ``w1``), in order; empty segments are left out.
    """
    w2 = k.sp_w2[0]
    n_win = k.n_windows
    half_pi = 0.5 * math.pi
    n = 0
    pts[n] = 0.0
    n += 1
    for i in range(n_win):
        if applies(k.w_dir[i], s):
            pts[n] = half_pi + k.w_lo[i]
            pts[n + 1] = half_pi + k.w_hi[i]
            n += 2
    pts[n] = math.pi
    n += 1
    srt = np.sort(pts[:n])
    m_seg = 0
    for m in range(n - 1):
        lo = srt[m]
        hi = srt[m + 1]
        if hi <= lo:
            continue
        mid = 0.5 * (lo + hi) - half_pi
        force = -k.r
        for i in range(n_win):
            if applies(k.w_dir[i], s) and k.w_lo[i] <= mid < k.w_hi[i]:
                force += k.w_x[i]
        seg_xc[m_seg] = force / w2
        seg_tau[m_seg] = (hi - lo) / w1
        m_seg += 1
    return m_seg


@kernel
def _phase_sweep(x, v, h, w2, segments, forced):
    """State ``(x, v)`` (swing frame, rad and rad/s) after the segments ``(xc, tau, n)`` of a half cycle.

    With ``forced`` False every centre is taken as 0: the homogeneous (linear) part alone.
    """
    seg_xc, seg_tau, n = segments
    for m in range(n):
        xc = seg_xc[m] if forced else 0.0
        y, v = propagate(x - xc, v, seg_tau[m], h, w2)
        x = xc + y
    return x, v


@kernel
def _phase_map(h, w2, segments, out):
    """The affine map of a phase-switched half cycle, in the swing frame.

    Every half cycle of a direction has the same segments, so its end state is an affine
    function of its start state: ``x1 = a11*x + a12*v + bx``, ``v1 = a21*x + a22*v + bv``
    (rad, rad/s), written to ``out`` in that order.  In exact arithmetic the linear part is
    ``-q`` times the identity, ``q = exp(-pi*h/w1)`` (half a period of the damped
    oscillation), so a half swing starting at ``x = -A`` ends at ``q*A + bx`` whatever the
    velocity at the boundary (not zero once forcing acts); ``bx`` gathers friction (< 0)
    and the windows.  The 2x2 form, composed from the same closed form segment by segment,
    also carries that velocity, for the final state and the next half cycle.
    """
    out[0], out[2] = _phase_sweep(1.0, 0.0, h, w2, segments, False)
    out[1], out[3] = _phase_sweep(0.0, 1.0, h, w2, segments, False)
    out[4], out[5] = _phase_sweep(0.0, 0.0, h, w2, segments, True)


@kernel
def _phase_tables(c, k, tables):
    """Segments, affine maps (:func:`_phase_map`) and durations of both directions' half cycles
    for viscous coefficient ``c`` (row 0: s = +1, row 1: s = -1), into ``tables`` =
    ``(pts, seg_xc, seg_tau, n_seg_d, maps, t_half)``."""
    pts, seg_xc, seg_tau, n_seg_d, maps, t_half = tables
    w2 = k.sp_w2[0]
    h = 0.5 * c
    w1 = math.sqrt(w2 - h * h)
    for d in range(2):
        sd = 1.0 if d == 0 else -1.0
        n = _phase_segments(sd, w1, k, pts, seg_xc[d], seg_tau[d])
        n_seg_d[d] = n
        _phase_map(h, w2, (seg_xc[d], seg_tau[d], n), maps[d])
        total = 0.0
        for m in range(n):
            total += seg_tau[d, m]
        t_half[d] = total


@kernel
def _phase_log(x, v, t, s, c, w2, segments, where, log):
    """Log the segments ``(xc, tau, n)`` of a half cycle starting from ``(x, v)`` at time ``t``
    in direction ``s``; ``where = (first row, half swing)``.  Columns as :func:`run_angle`
    logs them.

    The states are swept segment by segment with the closed form; the half cycle's end state
    itself comes from the affine map, so a run gives the same numbers with a log as without.
    """
    seg_xc, seg_tau, n = segments
    n_seg, swing = where
    h = 0.5 * c
    for m in range(n):
        xc = seg_xc[m]
        tau = seg_tau[m]
        log[n_seg + m, 0] = t
        log[n_seg + m, 1] = tau
        log[n_seg + m, 2] = s
        log[n_seg + m, 3] = x
        log[n_seg + m, 4] = v
        log[n_seg + m, 5] = xc
        log[n_seg + m, 6] = w2
        log[n_seg + m, 7] = h
        log[n_seg + m, 8] = swing
        y, v = propagate(x - xc, v, tau, h, w2)
        x = xc + y
        t += tau


@kernel
def run_phase(k, run, out, log):
    """Integrate half cycles with Monday's phase switching.

    Each half cycle lasts ``pi/omega1`` (``omega1 = sqrt(w2 - C**2/4)``, ``w2 = k.sp_w2[0]``);
    window limits ``k.w_lo, k.w_hi`` are phase offsets (rad) from the zero crossing in the
    middle of the half cycle, and the Coulomb sign flips at every half-cycle boundary.  A half
    swing ends at phase ``j*pi`` and its amplitude is ``|theta|`` there (the velocity there is
    not exactly zero when forcing acts).  Requires ``C < 2*sqrt(w2)``.  When a half cycle
    ends on the side it started the run continues, as Monday's programs did, with status
    4 (phase_breakdown) to say the numbers no longer describe a swinging balance.

    The segments of a half cycle depend only on the parameters and the direction, so each
    half cycle is one affine map of the state (:func:`_phase_map`), tabulated per direction
    and again whenever damping drift changes C: four multiply-adds per half swing.  A segment
    log is filled by sweeping each half cycle segment by segment from the same states.

    Parameters and returns as :func:`run_angle`.
    """
    theta0 = k.theta0
    w2 = k.sp_w2[0]
    dr_th = k.drift_th[:k.n_bands]
    dr_rate = k.drift_rate[:k.n_bands + 1]
    n_swings = run.n_swings
    t_end = run.t_end
    record = run.dense != 0
    s = 1.0 if theta0 < 0.0 else -1.0
    x = s * theta0
    v = 0.0
    c = k.c
    t = 0.0
    int_c = 0.0
    status = 0
    n_seg = 0
    n_done = 0
    drift = False
    for i in range(dr_rate.shape[0]):
        if dr_rate[i] != 0.0:
            drift = True
    n_max = 2 * k.n_windows + 1
    tables = (np.empty(n_max + 1), np.empty((2, n_max)), np.empty((2, n_max)), np.zeros(2, np.int64),
              np.empty((2, 6)), np.empty(2))
    _, seg_xc, seg_tau, n_seg_d, maps, t_half = tables
    _phase_tables(c, k, tables)
    half = math.pi / math.sqrt(w2 - (0.5 * c) * (0.5 * c))
    while n_done < n_swings:
        d = 0 if s > 0.0 else 1
        if record:
            if n_seg + n_seg_d[d] > log.shape[0]:
                status = ROWS_FULL
                break
            _phase_log(x, v, t, s, c, w2, (seg_xc[d], seg_tau[d], n_seg_d[d]), (n_seg, n_done), log)
        mp = maps[d]
        x, v = mp[0] * x + mp[1] * v + mp[4], mp[2] * x + mp[3] * v + mp[5]
        t += t_half[d]
        int_c += c * t_half[d]
        n_seg += n_seg_d[d]
        rec = out[n_done]
        rec.amplitude = abs(x)
        rec.theta_turn = s * x
        rec.half_period = half
        rec.time = t
        rec.banked = 0
        n_done += 1
        if x <= 0.0:
            status = _BREAKDOWN  # keep going, as Monday's programs did, but say so
        if drift and n_done % 2 == 0:
            c_old = c
            c *= drift_factor(int_c, dr_th, dr_rate)
            if c >= 2.0 * math.sqrt(w2):
                status = _BREAKDOWN
                break
            if c != c_old:
                _phase_tables(c, k, tables)
                half = math.pi / math.sqrt(w2 - (0.5 * c) * (0.5 * c))
        s = -s
        x = -x
        v = -v
        if t >= t_end:
            break
    return Walk(n_done, status, n_seg, 0, t, s * x, s * v, n_seg)


@kernel
def run_one(ks, runs, out, log):
    """:func:`run_angle` on ``ks[0]`` with options ``runs[0]`` (the front end's single call: arrays of
    one record reach a compiled function faster than records)."""
    return run_angle(ks[0], runs[0], out, log)


@kernel
def run_phase_one(ks, runs, out, log):
    """:func:`run_phase` on ``ks[0]`` (the front end's single call)."""
    return run_phase(ks[0], runs[0], out, log)


@kernel(parallel=True)
def run_angle_many(ks, runs, active, out, summary):
    """:func:`run_angle` on each record ``ks[i]`` with ``active[i]``, in parallel.

    ``out`` has shape ``(sets, n_swings)``; ``summary[i]`` receives ``n_done, status, n_seg``
    and the final ``t, theta, omega`` (:data:`escfit.balance.batch.SUMMARY`).
    """
    # (records are indexed inside the parallel loop: numba 0.68 cannot pass one into it)
    for i in prange(ks.shape[0]):
        if not active[i]:
            continue
        res = run_angle(ks[i], runs[0], out[i], np.zeros((0, 9)))
        row = summary[i]
        row.n_done, row.status, row.n_seg = res.n_done, res.status, res.n_seg
        row.t, row.theta, row.omega = res.t, res.theta, res.omega


@kernel(parallel=True)
def run_phase_many(ks, runs, active, out, summary):
    """:func:`run_phase` on each active record, in parallel (as :func:`run_angle_many`)."""
    # (records are indexed inside the parallel loop: numba 0.68 cannot pass one into it)
    for i in prange(ks.shape[0]):
        if not active[i]:
            continue
        res = run_phase(ks[i], runs[0], out[i], np.zeros((0, 9)))
        row = summary[i]
        row.n_done, row.status, row.n_seg = res.n_done, res.status, res.n_seg
        row.t, row.theta, row.omega = res.t, res.theta, res.omega
