"""Compiled fixed-step RK4 integration of one motion phase, with located events.

One call advances coupled or free motion until the phase ends.  Inside a step every
friction sign is frozen ("mode"); a step whose end state implies another mode is cut back
by bisection to the point where the mode changes, so no right-hand side is ever evaluated
across a discontinuity.  Phase-ending events (tooth leaves the face tip, contact force
vanishes, tooth meets a face, tooth misses a face, cut-off angle reached) are located by
the Illinois variant of regula falsi on the step length, re-integrating from the step's
start, so their time is found to a small fraction of a step.

State vector ``y = (phi, phidot, psi, psidot)``; in coupled motion the last two follow
from the kinematics and are overwritten after every step.  ``off`` is the cumulative
angle offset: ``phi_total = phi + off`` (it changes only when ``phi`` is re-referenced at
a side change).

Mode vector ``m`` (float64[11]): ``tooth pairs n1, n2, s1, s2, s4, s5, train direction,
train held by friction (0/1), verge held by friction (0/1)``, and the branches (+1/-1)
of the pivot-friction share of the rotor and verge inertias (speeding up / slowing down).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.kernels import kernel
from .coefficients import mesh_phase
from .dynamics import coupled_eval, coupled_signs, free_eval, free_train, free_verge, side_alpha
from .kinematics import contact_sensing, coupled_kinematics

__all__ = [
    "integrate_phase", "initial_mode", "phase_start_events", "COUPLED", "FREE", "REASONS", "N_COLS",
    "COLUMNS",
]

COUPLED = 0
FREE = 1

# phase-ending reasons
R_TIP, R_SEPARATION, R_ARMED, R_CONTACT, R_MISS, R_STALL, R_TMAX, R_BUFFER, R_BAD, R_CHATTER = range(10)
REASONS = ("tip", "separation", "armed", "contact", "miss", "stall", "t_max", "buffer_full", "bad_state", "chatter")

# columns of the trajectory buffer
COLUMNS = ("time", "phi", "phidot", "psi", "psidot", "phi_total", "regime", "side", "phiddot", "psiddot",
           "F23", "F12", "PN", "train_direction")
N_COLS = len(COLUMNS)

M_N1, M_N2, M_S1, M_S2, M_S4, M_S5, M_DIR, M_TSTUCK, M_VSTUCK, M_IROT, M_IVER = range(11)

# running maxima: F23, F12, PN (coupled), FF23, FF12 (free); then the count of train
# reversals (speed passing through zero)
MX_F23, MX_F12, MX_PN, MX_FF23, MX_FF12, MX_REV = range(6)


@kernel
def _sgn(x):
    return 1.0 if x >= 0.0 else -1.0


@kernel
def _deriv(k, regime, side, phi, phid, psi, psid, off, m):
    """Derivatives, forces and phase-event values at one state (mode frozen).

    Returns ``(dphi, dphid, dpsi, dpsid, f23, f12, pn, ev0, ev1)``: in coupled motion
    ``ev0 = side * g`` (contact position, > 0 on the face) and ``ev1 = pn``; in free motion
    ``ev0 = side * f`` (gap, > 0 open) and ``ev1 = side * g'`` (>= 0 while the tooth faces
    the working surface).
    """
    phi_total = phi + off
    if regime == COUPLED:
        phidd, psi_k, psid_k, psidd, f23, f12, pn, pnv, g, ok1, ok2 = coupled_eval(
            k, side, phi, phid, phi_total, m[M_N1], m[M_N2], m[M_S1], m[M_S2], m[M_S4], m[M_S5], m[M_DIR], m[M_IROT],
            m[M_IVER])
        return phid, phidd, psid_k, psidd, f23, f12, pn, side * g, pn
    phidd, psidd, f23, f12, ok1, ok2 = free_eval(k, side, phid, psi, psid, phi_total, m[M_N1], m[M_N2], m[M_S1], m[M_S2], m[M_S5],
                                                 m[M_DIR], m[M_TSTUCK] > 0.5, m[M_VSTUCK] > 0.5, m[M_IROT],
                                                 m[M_IVER])
    f, gp = contact_sensing(k.a, k.b, k.c, side_alpha(k, side), phi, psi)
    return phid, phidd, psid, psidd, f23, f12, 0.0, side * f, side * gp


@kernel
def _rk4(k, regime, side, y0, off, m, h, d1):
    """One RK4 step of length ``h`` from ``y0`` given the first-stage derivative ``d1``."""
    p0, v0, q0, w0 = y0[0], y0[1], y0[2], y0[3]
    a1, b1, c1, e1 = d1[0], d1[1], d1[2], d1[3]
    r = _deriv(k, regime, side, p0 + 0.5 * h * a1, v0 + 0.5 * h * b1, q0 + 0.5 * h * c1, w0 + 0.5 * h * e1, off, m)
    a2, b2, c2, e2 = r[0], r[1], r[2], r[3]
    r = _deriv(k, regime, side, p0 + 0.5 * h * a2, v0 + 0.5 * h * b2, q0 + 0.5 * h * c2, w0 + 0.5 * h * e2, off, m)
    a3, b3, c3, e3 = r[0], r[1], r[2], r[3]
    r = _deriv(k, regime, side, p0 + h * a3, v0 + h * b3, q0 + h * c3, w0 + h * e3, off, m)
    a4, b4, c4, e4 = r[0], r[1], r[2], r[3]
    out = np.empty(4)
    out[0] = p0 + h / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)
    out[1] = v0 + h / 6.0 * (b1 + 2 * b2 + 2 * b3 + b4)
    out[2] = q0 + h / 6.0 * (c1 + 2 * c2 + 2 * c3 + c4)
    out[3] = w0 + h / 6.0 * (e1 + 2 * e2 + 2 * e3 + e4)
    if regime == COUPLED:
        # the verge follows the wheel exactly
        psi, g, u, v, aa, ab, ac, ad = coupled_kinematics(k.a, k.b, k.c, side_alpha(k, side), out[0])
        out[2] = psi
        out[3] = u * out[1]
    if m[M_TSTUCK] > 0.5:
        out[0] = p0
        out[1] = 0.0
    if m[M_VSTUCK] > 0.5:
        out[2] = q0
        out[3] = 0.0
    return out


@kernel
def _mode_at(k, regime, side, y, off, m):
    """The mode implied by state ``y`` (speeds exactly zero keep the current direction)."""
    out = m.copy()
    phi_total = y[0] + off
    n1, n2, s1, s2 = mesh_phase(k, phi_total)
    out[M_N1] = n1
    out[M_N2] = n2
    out[M_S1] = s1
    out[M_S2] = s2
    if m[M_TSTUCK] < 0.5 and y[1] != 0.0:
        out[M_DIR] = _sgn(y[1])
    if regime == COUPLED:
        s4, s5 = coupled_signs(k, side, y[0], y[1], out[M_DIR])
        out[M_S4] = s4
        out[M_S5] = s5
        r = coupled_eval(k, side, y[0], y[1], phi_total, n1, n2, s1, s2, s4, s5, out[M_DIR], 0.0, 0.0)
        out[M_IROT] = r[9]
        out[M_IVER] = r[10]
    else:
        out[M_S4] = 1.0
        if m[M_VSTUCK] < 0.5 and y[3] != 0.0:
            out[M_S5] = _sgn(y[3])
        r = free_eval(k, side, y[1], y[2], y[3], phi_total, n1, n2, s1, s2, out[M_S5], out[M_DIR], m[M_TSTUCK] > 0.5,
                      m[M_VSTUCK] > 0.5, 0.0, 0.0)
        out[M_IROT] = r[4]
        out[M_IVER] = r[5]
    return out


@kernel
def _same_mode(a, b):
    for i in (M_N1, M_N2, M_S1, M_S2, M_S4, M_S5, M_DIR, M_IROT, M_IVER):
        if a[i] != b[i]:
            return False
    return True


@kernel
def _train_start_direction(k, regime, side, y, off, m):
    """Direction (+1/-1) the train starts to move from rest, or 0 if friction holds it."""
    phi_total = y[0] + off
    for d in (1.0, -1.0):
        if regime == COUPLED:
            s4, s5 = coupled_signs(k, side, y[0], 0.0, d)
            acc = coupled_eval(k, side, y[0], 0.0, phi_total, m[M_N1], m[M_N2], m[M_S1], m[M_S2], s4, s5, d, 0.0,
                               0.0)[0]
        else:
            acc = free_train(k, 0.0, phi_total, m[M_N1], m[M_N2], m[M_S1], m[M_S2], d, False, 0.0)[0]
        if acc * d > 0.0:
            return d
    return 0.0


@kernel
def _verge_start_direction(k, side, y):
    """Direction the free verge starts to move from rest, or 0 if pivot friction holds it."""
    for d in (1.0, -1.0):
        if free_verge(k, side, y[2], 0.0, d, 0.0)[0] * d > 0.0:
            return d
    return 0.0


@kernel
def initial_mode(k, regime, side, y, off, direction):
    """Mode at the start of a phase; bodies at rest get their friction direction from a stick test.

    ``direction`` is the train direction carried over from the previous phase.  May set
    ``y[1]`` / ``y[3]`` to zero exactly.  Returns the mode vector; a coupled train that
    friction holds at rest is reported through ``m[M_TSTUCK] = 1``.
    """
    m = np.zeros(11)
    m[M_DIR] = direction
    m[M_S4] = 1.0
    m[M_S5] = 1.0
    m = _mode_at(k, regime, side, y, off, m)
    if y[1] == 0.0:
        d = _train_start_direction(k, regime, side, y, off, m)
        if d == 0.0:
            m[M_TSTUCK] = 1.0
        else:
            m[M_DIR] = d
    if regime == FREE and y[3] == 0.0:
        d = _verge_start_direction(k, side, y)
        if d == 0.0:
            m[M_VSTUCK] = 1.0
        else:
            m[M_S5] = d
    if regime == COUPLED:
        s4, s5 = coupled_signs(k, side, y[0], y[1], m[M_DIR])
        m[M_S4] = s4
        m[M_S5] = s5
    return m


@kernel
def phase_start_events(k, regime, side, y, off, m):
    """Event values ``(ev0, ev1)`` at a phase start (see :func:`_deriv`)."""
    r = _deriv(k, regime, side, y[0], y[1], y[2], y[3], off, m)
    return r[7], r[8]


@kernel
def _events(k, regime, side, y, off, m):
    r = _deriv(k, regime, side, y[0], y[1], y[2], y[3], off, m)
    return r[7], r[8], k.phi_cut - (y[0] + off)


@kernel
def _fires(regime, e0, e1, e2, armed):
    """Which phase-ending event a state satisfies (-1 if none), in priority order."""
    if e2 <= 0.0:
        return R_ARMED
    if regime == COUPLED:
        if e0 <= 0.0:
            return R_TIP
        if e1 <= 0.0:
            return R_SEPARATION
        return -1
    if armed and e0 <= 0.0 and e1 >= 0.0:
        return R_CONTACT
    if e1 < 0.0:
        # past the face tip: whether or not the tooth is beyond the face line, there is
        # no face left to hit
        return R_MISS
    return -1


@kernel
def _record(buf, n, t, y, off, regime, side, r, m):
    buf[n, 0] = t
    buf[n, 1] = y[0]
    buf[n, 2] = y[1]
    buf[n, 3] = y[2]
    buf[n, 4] = y[3]
    buf[n, 5] = y[0] + off
    buf[n, 6] = regime
    buf[n, 7] = side
    buf[n, 8] = r[1]
    buf[n, 9] = r[3]
    buf[n, 10] = r[4]
    buf[n, 11] = r[5]
    buf[n, 12] = r[6]
    buf[n, 13] = m[M_DIR]


@kernel
def _track_max(mx, regime, r):
    if regime == COUPLED:
        if r[4] > mx[MX_F23]:
            mx[MX_F23] = r[4]
        if r[5] > mx[MX_F12]:
            mx[MX_F12] = r[5]
        if r[6] > mx[MX_PN]:
            mx[MX_PN] = r[6]
    else:
        if r[4] > mx[MX_FF23]:
            mx[MX_FF23] = r[4]
        if r[5] > mx[MX_FF12]:
            mx[MX_FF12] = r[5]


@kernel
def _locate_events(k, regime, side, y, off, m, d1, hs, vals0, vals1, armed, tol_h):
    """Smallest step length at which one of the phase events fires (``hs`` if none is found).

    Each event function that went from positive to non-positive over the step (negative,
    for the free-motion "facing" function) is solved for its zero by the Illinois method;
    the returned length lies just past the zero.  The event's side condition (the tooth
    facing the working surface at a contact) is checked there, so a crossing that is not
    an event is skipped.
    """
    best = hs
    for i in range(3):
        if regime == FREE and i == 0 and not armed:
            continue
        if regime == FREE and i == 1:
            if not (vals0[i] >= 0.0 > vals1[i]):
                continue
        elif not (vals0[i] > 0.0 and vals1[i] <= 0.0):
            continue
        lo, hi = 0.0, hs
        flo, fhi = vals0[i], vals1[i]
        kept = 0
        for it in range(200):
            if hi - lo <= tol_h:
                break
            mid = (lo * fhi - hi * flo) / (fhi - flo)
            if not (lo < mid < hi):
                mid = 0.5 * (lo + hi)
            ym = _rk4(k, regime, side, y, off, m, mid, d1)
            fm = _events(k, regime, side, ym, off, m)[i]
            if fm > 0.0 or (regime == FREE and i == 1 and fm == 0.0):
                lo, flo = mid, fm
                if kept == -1:
                    fhi *= 0.5
                kept = -1
            else:
                hi, fhi = mid, fm
                if kept == 1:
                    flo *= 0.5
                kept = 1
        if hi < best:
            ye = _rk4(k, regime, side, y, off, m, hi, d1)
            ee = _events(k, regime, side, ye, off, m)
            if _fires(regime, ee[0], ee[1], ee[2], armed) >= 0:
                best = hi
    return best


@kernel
def integrate_phase(k, regime, side, y, t, off, m, armed, h, t_max, buf, n, record, mx, max_mode_changes):
    """Advance one motion phase until it ends.

    Parameters
    ----------
    k : Constants
    regime : int
        ``COUPLED`` or ``FREE``.
    side : float
        +1 entrance, -1 exit.
    y : float64[4]
        State at the start; overwritten with the state at the end.
    t : float
        Start time (s).
    off : float
        ``phi_total - phi`` (rad), constant during the phase.
    m : float64[8]
        Mode at the start (see :func:`initial_mode`); updated in place.
    armed : bool
        Free motion only: whether a contact can be detected (False right after the faces
        separated, until a positive gap has opened).
    h : float
        Step length (s).
    t_max : float
        Time limit (s).
    buf : float64[:, N_COLS]
        Trajectory buffer; rows from ``n`` on are written when ``record``.
    n : int
        Next free row of ``buf``.
    record : bool
        Whether to store the trajectory (maxima are tracked either way).
    mx : float64[6]
        Running force maxima and the count of train reversals, updated in place.
    max_mode_changes : int
        Guard against chattering: at most this many mode changes in one phase.

    Returns
    -------
    reason : int
        Index into :data:`REASONS`.
    t : float
        Time at the end of the phase (s).
    n : int
        Next free row of ``buf``.
    armed : bool
        The free-motion contact flag at the end (to resume after a full buffer).
    """
    cap = buf.shape[0]
    changes = 0
    tol_h = 1e-10 * h
    if m[M_TSTUCK] > 0.5 and (regime == COUPLED or m[M_VSTUCK] > 0.5):
        return R_STALL, t, n, armed
    while True:
        d1 = _deriv(k, regime, side, y[0], y[1], y[2], y[3], off, m)
        if not (math.isfinite(d1[1]) and math.isfinite(d1[3])):
            return R_BAD, t, n, armed
        _track_max(mx, regime, d1)
        if record:
            if n >= cap:
                return R_BUFFER, t, n, armed
            _record(buf, n, t, y, off, regime, side, d1, m)
            n += 1
        e0, e1, e2 = d1[7], d1[8], k.phi_cut - (y[0] + off)
        if regime == FREE and not armed and e0 > 0.0:
            armed = True
        hit = _fires(regime, e0, e1, e2, armed)
        if hit >= 0:
            return hit, t, n, armed
        if t >= t_max:
            return R_TMAX, t, n, armed
        hs = min(h, t_max - t)
        y1 = _rk4(k, regime, side, y, off, m, hs, d1)
        if not (math.isfinite(y1[0]) and math.isfinite(y1[1]) and math.isfinite(y1[2])):
            # Typically the coupled kinematics has no solution past this point; find
            # where by bisection and stop there.
            lo, hi = 0.0, hs
            while hi - lo > tol_h:
                mid = 0.5 * (lo + hi)
                ym = _rk4(k, regime, side, y, off, m, mid, d1)
                if math.isfinite(ym[0]) and math.isfinite(ym[1]) and math.isfinite(ym[2]):
                    lo = mid
                else:
                    hi = mid
            if lo > 0.0:
                y[:] = _rk4(k, regime, side, y, off, m, lo, d1)
            return R_BAD, t + lo, n, armed
        f0, f1, f2 = _events(k, regime, side, y1, off, m)
        hit = _fires(regime, f0, f1, f2, armed)
        m1 = _mode_at(k, regime, side, y1, off, m)
        mode_change = not _same_mode(m1, m)
        if hit < 0 and not mode_change:
            y[:] = y1
            t += hs
            continue
        # Earliest mode change: bisection on the step length.
        h_mode = hs + 1.0
        if mode_change:
            # Stopping within 1e-7 of a step past the switch leaves an error of that
            # order times the jump of the right-hand side: far below the RK4 error.
            lo, hi = 0.0, hs
            while hi - lo > 1e3 * tol_h:
                mid = 0.5 * (lo + hi)
                ym = _rk4(k, regime, side, y, off, m, mid, d1)
                if _same_mode(_mode_at(k, regime, side, ym, off, m), m):
                    lo = mid
                else:
                    hi = mid
            h_mode = hi
        # Earliest phase event: regula falsi (Illinois) on each event function that
        # crossed zero during the step.
        h_ev = hs + 1.0
        if hit >= 0:
            h_ev = _locate_events(k, regime, side, y, off, m, d1, hs, (e0, e1, e2), (f0, f1, f2), armed, tol_h)
        if h_ev <= h_mode and h_ev <= hs:
            y[:] = _rk4(k, regime, side, y, off, m, h_ev, d1)
            t += h_ev
            continue  # the next pass records this state and reports the event
        if mode_change:
            changes += 1
            if changes > max_mode_changes:
                return R_CHATTER, t, n, armed
            y[:] = _rk4(k, regime, side, y, off, m, h_mode, d1)
            t += h_mode
            new = _mode_at(k, regime, side, y, off, m)
            if new[M_DIR] != m[M_DIR]:
                # the train's speed passed through zero: does it reverse or stick?
                y[1] = 0.0
                if regime == COUPLED:
                    y[3] = 0.0
                d = _train_start_direction(k, regime, side, y, off, new)
                if d == 0.0:
                    if regime == COUPLED:
                        m[:] = new
                        m[M_TSTUCK] = 1.0
                        return R_STALL, t, n, armed
                    new[M_TSTUCK] = 1.0
                    new[M_DIR] = m[M_DIR]
                else:
                    if d != m[M_DIR]:
                        mx[MX_REV] += 1.0
                    new[M_DIR] = d
                if regime == COUPLED:
                    s4, s5 = coupled_signs(k, side, y[0], 0.0, new[M_DIR])
                    new[M_S4] = s4
                    new[M_S5] = s5
            if regime == FREE and new[M_S5] != m[M_S5] and new[M_VSTUCK] < 0.5:
                y[3] = 0.0
                d = _verge_start_direction(k, side, y)
                if d == 0.0:
                    new[M_VSTUCK] = 1.0
                else:
                    new[M_S5] = d
            m[:] = new
            if regime == FREE and m[M_TSTUCK] > 0.5 and m[M_VSTUCK] > 0.5:
                return R_STALL, t, n, armed
            continue
