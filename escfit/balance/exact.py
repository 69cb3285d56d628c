"""Exact piecewise solver for the balance wheel (numba-compiled kernel).

The run is split into segments in which every coefficient is constant: the viscous
coefficient, the stiffness of the current hairspring piece, the Coulomb torque (whose sign
is fixed within a half swing) and the escapement windows the balance is in.  Each segment
is solved in closed form (:mod:`escfit.balance.segment`); window edges are located by a
safeguarded root solve on that closed form and turning points analytically, so the only
error is floating-point rounding.  With angle switching the closed form at a turning point is
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

Status codes (see :data:`STATUS_NAMES`)
---------------------------------------
0 ok, 1 stopped (friction holds the balance at rest, or it creeps to rest without a further
turning point), 2 banked (the run completed but hit the banking pins), 3 max_segments
(pathological input: segment budget exhausted), 4 phase_breakdown (phase switching: a half
cycle ended on the side it started, so Monday's phase convention no longer describes the
motion).
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..core.kernels import kernel
from .segment import creeps_to_rest, cross_time, propagate, turn_time

__all__ = ["run_angle", "run_phase", "run_angle_many", "run_phase_many", "STATUS_NAMES"]

STATUS_NAMES = ("ok", "stopped", "banked", "max_segments", "phase_breakdown")
N_LOG = 9  # fields of a segment-log row: t0, tau, s, x0, v0, xc, w2, h, swing


@kernel
def _drift_factor(integral_c, th, rate):
    """Growth factor of C after a cycle, from the envelope exp(-int C dt / 2)."""
    env = math.exp(-0.5 * integral_c)
    for i in range(th.shape[0]):
        if env > th[i]:
            return 1.0 + rate[i]
    return 1.0 + rate[th.shape[0]]


@kernel
def _applies(wdir, s):
    return wdir == 0 or wdir == s


@kernel
def _region_coefficients(j, s, edges, n_edges, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, r):
    """``(w2, xc)`` of region ``j``: between edges ``j-1`` and ``j`` of a swing in direction ``s``."""
    if j == 0:
        mid = edges[0] - 1.0 if n_edges > 0 else 0.0
    elif j == n_edges:
        mid = edges[n_edges - 1] + 1.0
    else:
        mid = 0.5 * (edges[j - 1] + edges[j])
    force = -r
    for k in range(w_lo.shape[0]):
        if _applies(w_dir[k], s) and w_lo[k] <= mid < w_hi[k]:
            force += w_x[k]
    theta_mid = s * mid
    i = 0
    while i < sp_bp.shape[0] and sp_bp[i] <= theta_mid:
        i += 1
    w2 = sp_w2[i]
    xc = (force - s * sp_off[i]) / w2
    return w2, xc


@kernel
def _region(x, s, edges, n_edges, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, r):
    """Index of the next edge above ``x`` and the region's (w2, xc)."""
    j = 0
    while j < n_edges and edges[j] <= x:
        j += 1
    w2, xc = _region_coefficients(j, s, edges, n_edges, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, r)
    return j, w2, xc


@kernel
def _swing_edges(s, bank, sp_bp, w_lo, w_hi, w_dir, edges):
    """Sorted distinct switch points of a swing in the swing frame, banking last."""
    n = 0
    for k in range(w_lo.shape[0]):
        if _applies(w_dir[k], s):
            edges[n] = w_lo[k]
            edges[n + 1] = w_hi[k]
            n += 2
    for i in range(sp_bp.shape[0]):
        edges[n] = s * sp_bp[i]
        n += 1
    for i in range(1, n):  # insertion sort: a handful of values, no allocation
        v = edges[i]
        k = i - 1
        while k >= 0 and edges[k] > v:
            edges[k + 1] = edges[k]
            k -= 1
        edges[k + 1] = v
    m = 0
    for i in range(n):
        v = edges[i]
        if v < bank and (m == 0 or v > edges[m - 1]):
            edges[m] = v
            m += 1
    if math.isfinite(bank):
        edges[m] = bank
        m += 1
    return m


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
def region_tables(bank, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, r):
    """Switch points and region coefficients of both swing directions (row 0: s = +1, row 1: s = -1).

    They are fixed for a run, so solvers tabulate them once.  Returns ``(edges, n_edges, w2, xc)``:
    the edges of each direction in order, how many, and each region's stiffness and centre.
    """
    n_max = 2 * w_lo.shape[0] + sp_bp.shape[0] + 1
    edge_tab = np.empty((2, n_max))
    n_edge_tab = np.zeros(2, np.int64)
    w2_tab = np.empty((2, n_max + 1))
    xc_tab = np.empty((2, n_max + 1))
    for d in range(2):
        sd = 1.0 if d == 0 else -1.0
        n_edge_tab[d] = _swing_edges(sd, bank, sp_bp, w_lo, w_hi, w_dir, edge_tab[d])
        for j in range(n_edge_tab[d] + 1):
            w2_tab[d, j], xc_tab[d, j] = _region_coefficients(j, sd, edge_tab[d], n_edge_tab[d], sp_bp, sp_w2,
                                                              sp_off, w_lo, w_hi, w_x, w_dir, r)
    return edge_tab, n_edge_tab, w2_tab, xc_tab


@kernel
def run_angle(theta0, v0, c0, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir,
              bank, restitution, dr_th, dr_rate, n_swings, max_seg,
              amp, theta_turn, half_period, time, banked, log):
    """Integrate half swings with angle switching (the physical escapement).

    Parameters
    ----------
    theta0, v0 : float
        Initial angle (rad) and angular velocity (rad/s); released at rest when v0 == 0.
    c0 : float
        Initial viscous coefficient C = c/I (1/s).
    r : float
        Coulomb friction torque per inertia R (rad/s^2), >= 0.
    sp_bp, sp_w2, sp_off : ndarray
        Hairspring: breakpoint angles (rad, sorted), stiffness per inertia of each piece
        (1/s^2) and offsets so the restoring acceleration is ``w2[i]*theta + off[i]``.
    w_lo, w_hi, w_x, w_dir : ndarray
        Escapement windows in the swing frame (rad), signed magnitude (rad/s^2, >0
        drives, <0 opposes) and the swings they act on (0 both, +1 positive, -1 negative).
    bank, restitution : float
        Banking angle (rad, inf for none) and coefficient of restitution of the impact.
    dr_th, dr_rate : ndarray
        Damping drift: envelope thresholds (descending) and per-cycle growth rates
        (one more rate than thresholds); all-zero rates disable it.
    n_swings, max_seg : int
        Half swings wanted and the segment budget.
    amp, theta_turn, half_period, time, banked : ndarray
        Outputs per half swing (filled up to the returned count).
    log : ndarray, shape (max_seg, 9) or (0, 9)
        Segment log (t0, tau, s, x0, v0, xc, w2, h, swing) when it has rows.

    Returns
    -------
    n_done, status, n_seg, t, theta, omega : int, int, int, float, float, float
    """
    s = 1.0 if theta0 < 0.0 else -1.0
    if v0 != 0.0:
        s = 1.0 if v0 > 0.0 else -1.0
    x = s * theta0
    v = s * v0
    c = c0
    t = 0.0
    t_swing = 0.0  # duration of the current half swing, summed apart from t to keep its precision
    int_c = 0.0
    status = 0
    n_done = 0
    n_seg = 0
    any_bank = False
    drift = False
    for i in range(dr_rate.shape[0]):
        if dr_rate[i] != 0.0:
            drift = True
    edge_tab, n_edge_tab, w2_tab, xc_tab = region_tables(bank, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, r)
    d = 0 if s > 0.0 else 1
    edges = edge_tab[d]
    n_edges = n_edge_tab[d]
    record = log.shape[0] > 0
    at_start = True
    at_edge = False  # the state sits on edge j after a crossing
    j = 0
    scale = -1.0
    while n_done < n_swings:
        if n_seg >= max_seg:
            status = 3
            break
        if at_edge:
            j += 1  # just crossed edge j: the edges are distinct, so the region above is the next
        else:
            j = 0
            while j < n_edges and edges[j] <= x:
                j += 1
        w2 = w2_tab[d, j]
        xc = xc_tab[d, j]
        y0 = x - xc
        if scale < 0.0:  # the run's scale: the release's offset from its rest position
            scale = math.sqrt(y0 * y0 + v * v / w2)
        h = 0.5 * c
        xb = edges[j] if j < n_edges else math.inf
        grazed = False
        if v <= 0.0 and y0 >= 0.0:
            v = 0.0
            if at_start:
                status = 1  # at rest and the net torque cannot overcome static friction
                break
            grazed = True  # came to rest exactly on an edge: a turning point there
        if record:
            log[n_seg, 0] = t
            log[n_seg, 2] = s
            log[n_seg, 3] = x
            log[n_seg, 4] = v
            log[n_seg, 5] = xc
            log[n_seg, 6] = w2
            log[n_seg, 7] = h
            log[n_seg, 8] = n_done
        crosses = False
        if grazed:
            tau = 0.0
        else:
            if v <= 0.0:
                v = 0.0  # also clears a negative zero, which would flip atan2's branch
            tau_turn = turn_time(y0, v, h, w2)
            x_turn = xc
            # the turning point itself is only needed when it may end the half swing
            crosses = _surely_crosses(y0, v, h, w2, tau_turn, xc, xb)
            creep = not math.isfinite(tau_turn)
            if not crosses:
                if math.isfinite(tau_turn):
                    y_turn, _ = propagate(y0, v, tau_turn, h, w2)
                    x_turn = xc + y_turn
                    # a turn that overshoots the rest position by a negligible amount is a creep
                    creep = creeps_to_rest(y_turn, math.sqrt(y0 * y0 + v * v / w2), scale)
                crosses = x_turn > xb
            if crosses:
                tau, v_new = cross_time(y0, v, h, w2, xb - xc, tau_turn)
                x = xb
                v = max(v_new, 0.0)
            elif not creep:
                tau = tau_turn
                x = x_turn
                v = 0.0
            else:
                # creeps towards the centre without turning (or overshooting it visibly) or reaching
                # another edge
                if record:
                    log[n_seg, 1] = math.inf
                n_seg += 1
                x = xc
                v = 0.0
                t = math.inf
                status = 1
                break
        if record:
            log[n_seg, 1] = tau
        n_seg += 1
        t += tau
        t_swing += tau
        int_c += c * tau
        at_start = False
        is_bank = crosses and j == n_edges - 1 and math.isfinite(bank)
        at_edge = crosses and not is_bank
        if at_edge:
            continue
        # end of a half swing: a turning point or an impact on the banking pins
        amp[n_done] = abs(x)
        theta_turn[n_done] = s * x
        half_period[n_done] = t_swing
        time[n_done] = t
        banked[n_done] = 1 if is_bank else 0
        any_bank = any_bank or is_bank
        t_swing = 0.0
        n_done += 1
        if drift and n_done % 2 == 0:
            c *= _drift_factor(int_c, dr_th, dr_rate)
        s = -s
        x = -x
        v = restitution * v if is_bank else 0.0
        at_start = v == 0.0
        d = 1 - d
        edges = edge_tab[d]
        n_edges = n_edge_tab[d]
    if status == 0 and any_bank:
        status = 2
    return n_done, status, n_seg, t, s * x, s * v


@kernel
def _phase_segments(s, w2, w1, r, w_lo, w_hi, w_x, w_dir, pts, seg_xc, seg_tau):
    """Segments of a phase-switched half cycle in direction ``s``; returns their number.

    The half cycle runs from phase 0 to pi; window limits are phase offsets from pi/2.  Fills
    ``seg_xc`` (centre of each segment in the swing frame, rad) and ``seg_tau`` (its
    duration, s, for the damped frequency ``w1``), in order; empty segments are left out.
    """
    half_pi = 0.5 * math.pi
    n = 0
    pts[n] = 0.0
    n += 1
    for k in range(w_lo.shape[0]):
        if _applies(w_dir[k], s):
            pts[n] = half_pi + w_lo[k]
            pts[n + 1] = half_pi + w_hi[k]
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
        force = -r
        for k in range(w_lo.shape[0]):
            if _applies(w_dir[k], s) and w_lo[k] <= mid < w_hi[k]:
                force += w_x[k]
        seg_xc[m_seg] = force / w2
        seg_tau[m_seg] = (hi - lo) / w1
        m_seg += 1
    return m_seg


@kernel
def _phase_sweep(x, v, h, w2, seg_xc, seg_tau, n, forced):
    """State ``(x, v)`` (swing frame, rad and rad/s) after the ``n`` segments of a half cycle.

    With ``forced`` False every centre is taken as 0: the homogeneous (linear) part alone.
    """
    for m in range(n):
        xc = seg_xc[m] if forced else 0.0
        y, v = propagate(x - xc, v, seg_tau[m], h, w2)
        x = xc + y
    return x, v


@kernel
def _phase_map(h, w2, seg_xc, seg_tau, n, out):
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
    out[0], out[2] = _phase_sweep(1.0, 0.0, h, w2, seg_xc, seg_tau, n, False)
    out[1], out[3] = _phase_sweep(0.0, 1.0, h, w2, seg_xc, seg_tau, n, False)
    out[4], out[5] = _phase_sweep(0.0, 0.0, h, w2, seg_xc, seg_tau, n, True)


@kernel
def _phase_tables(c, r, w2, w_lo, w_hi, w_x, w_dir, pts, seg_xc, seg_tau, n_seg_d, maps, t_half):
    """Segments, affine maps (:func:`_phase_map`) and durations of both directions' half cycles
    for viscous coefficient ``c`` (row 0: s = +1, row 1: s = -1)."""
    h = 0.5 * c
    w1 = math.sqrt(w2 - h * h)
    for d in range(2):
        sd = 1.0 if d == 0 else -1.0
        n = _phase_segments(sd, w2, w1, r, w_lo, w_hi, w_x, w_dir, pts, seg_xc[d], seg_tau[d])
        n_seg_d[d] = n
        _phase_map(h, w2, seg_xc[d], seg_tau[d], n, maps[d])
        total = 0.0
        for m in range(n):
            total += seg_tau[d, m]
        t_half[d] = total


@kernel
def _phase_log(x, v, t, n_seg, s, c, w2, seg_xc, seg_tau, n, swing, log):
    """Log the ``n`` segments of a half cycle starting from ``(x, v)`` at time ``t`` (rows from
    ``n_seg`` on, as far as ``log`` reaches; columns as :func:`run_angle` logs them).

    The states are swept segment by segment with the closed form; the half cycle's end state
    itself comes from the affine map, so a run gives the same numbers with a log as without.
    """
    h = 0.5 * c
    for m in range(n):
        if n_seg + m >= log.shape[0]:
            break
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
def run_phase(theta0, c0, r, w2, w_lo, w_hi, w_x, w_dir, dr_th, dr_rate, n_swings,
              amp, theta_turn, half_period, time, banked, log):
    """Integrate half cycles with Monday's phase switching.

    Each half cycle lasts ``pi/omega1`` (``omega1 = sqrt(w2 - C**2/4)``); window limits
    ``w_lo, w_hi`` are phase offsets (rad) from the zero crossing in the middle of the
    half cycle, and the Coulomb sign flips at every half-cycle boundary.  A half swing
    ends at phase ``k*pi`` and its amplitude is ``|theta|`` there (the velocity there is
    not exactly zero when forcing acts).  Requires ``C < 2*sqrt(w2)``.  When a half cycle
    ends on the side it started the run continues, as Monday's programs did, with status
    4 (phase_breakdown) to say the numbers no longer describe a swinging balance.

    The segments of a half cycle depend only on the parameters and the direction, so each
    half cycle is one affine map of the state (:func:`_phase_map`), tabulated per direction
    and again whenever damping drift changes C: four multiply-adds per half swing.  A segment
    log is filled by sweeping each half cycle segment by segment from the same states.

    Returns
    -------
    n_done, status, n_seg, t, theta, omega : as :func:`run_angle`
    """
    s = 1.0 if theta0 < 0.0 else -1.0
    x = s * theta0
    v = 0.0
    c = c0
    t = 0.0
    int_c = 0.0
    status = 0
    n_seg = 0
    n_done = 0
    drift = False
    for i in range(dr_rate.shape[0]):
        if dr_rate[i] != 0.0:
            drift = True
    n_max = 2 * w_lo.shape[0] + 1
    pts = np.empty(n_max + 1)
    seg_xc = np.empty((2, n_max))
    seg_tau = np.empty((2, n_max))
    n_seg_d = np.zeros(2, np.int64)
    maps = np.empty((2, 6))
    t_half = np.empty(2)
    _phase_tables(c, r, w2, w_lo, w_hi, w_x, w_dir, pts, seg_xc, seg_tau, n_seg_d, maps, t_half)
    half = math.pi / math.sqrt(w2 - (0.5 * c) * (0.5 * c))
    record = log.shape[0] > 0
    while n_done < n_swings:
        d = 0 if s > 0.0 else 1
        if record:
            _phase_log(x, v, t, n_seg, s, c, w2, seg_xc[d], seg_tau[d], n_seg_d[d], n_done, log)
        mp = maps[d]
        x, v = mp[0] * x + mp[1] * v + mp[4], mp[2] * x + mp[3] * v + mp[5]
        t += t_half[d]
        int_c += c * t_half[d]
        n_seg += n_seg_d[d]
        amp[n_done] = abs(x)
        theta_turn[n_done] = s * x
        half_period[n_done] = half
        time[n_done] = t
        banked[n_done] = 0
        n_done += 1
        if x <= 0.0:
            status = 4  # keep going, as Monday's programs did, but say so
        if drift and n_done % 2 == 0:
            c_old = c
            c *= _drift_factor(int_c, dr_th, dr_rate)
            if c >= 2.0 * math.sqrt(w2):
                status = 4
                break
            if c != c_old:
                _phase_tables(c, r, w2, w_lo, w_hi, w_x, w_dir, pts, seg_xc, seg_tau, n_seg_d, maps, t_half)
                half = math.pi / math.sqrt(w2 - (0.5 * c) * (0.5 * c))
        s = -s
        x = -x
        v = -v
    return n_done, status, n_seg, t, s * x, s * v


@kernel(parallel=True)
def run_angle_many(theta0, c0, r, sp_bp, sp_w2, sp_off, w_lo, w_hi, w_x, w_dir, bank, restitution, dr_th, dr_rate,
                active, n_swings, max_seg, amp, theta_turn, half_period, time, banked, n_done, status, n_seg, final):
    """:func:`run_angle` on each parameter set ``i`` with ``active[i]``, in parallel.

    Per-set inputs are rows of ``theta0, c0, r, restitution`` (n,) and ``sp_w2, sp_off,
    w_x`` (n, .); the structure is shared.  Outputs are rows of ``(n, n_swings)`` arrays
    and ``n_done, status, n_seg`` (n,), ``final`` (n, 3).
    """
    no_log = np.zeros((0, 9))
    for i in prange(theta0.shape[0]):
        if not active[i]:
            continue
        res = run_angle(theta0[i], 0.0, c0[i], r[i], sp_bp, sp_w2[i], sp_off[i], w_lo, w_hi, w_x[i], w_dir, bank,
                        restitution[i], dr_th, dr_rate, n_swings, max_seg, amp[i], theta_turn[i], half_period[i],
                        time[i], banked[i], no_log)
        n_done[i], status[i], n_seg[i] = res[0], res[1], res[2]
        final[i, 0], final[i, 1], final[i, 2] = res[3], res[4], res[5]


@kernel(parallel=True)
def run_phase_many(theta0, c0, r, w2, w_lo, w_hi, w_x, w_dir, dr_th, dr_rate, active, n_swings,
                amp, theta_turn, half_period, time, banked, n_done, status, n_seg, final):
    """:func:`run_phase` on each active parameter set, in parallel (as :func:`run_angle_many`)."""
    no_log = np.zeros((0, 9))
    for i in prange(theta0.shape[0]):
        if not active[i]:
            continue
        res = run_phase(theta0[i], c0[i], r[i], w2[i], w_lo, w_hi, w_x[i], w_dir, dr_th, dr_rate, n_swings,
                        amp[i], theta_turn[i], half_period[i], time[i], banked[i], no_log)
        n_done[i], status[i], n_seg[i] = res[0], res[1], res[2]
        final[i, 0], final[i, 1], final[i, 2] = res[3], res[4], res[5]
