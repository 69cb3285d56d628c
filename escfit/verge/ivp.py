"""Adaptive alternative to the compiled RK4: scipy's DOP853 with terminal events.

This adapter plays the part of the report's own integrator (adaptive Runge-Kutta, friction
signs taken from the state at every evaluation), but locates every phase-ending event by
scipy's root finding on the dense output.  Zero crossings of the train and verge speeds are
terminal events too, so that the stick test decides whether a body reverses or stays at
rest.  It shares the regime automaton (:func:`escfit.verge.hybrid.run_hybrid`) with the RK4
solver, so the two differ only in how each phase is integrated; agreement between them is
a check on both.  It is about 20-50 times slower than the RK4 solver.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from ..core.kernels import kernel
from .coefficients import mesh_phase
from .dynamics import coupled_signs, side_alpha
from .geometry import Constants
from .hybrid import RunResult, run_hybrid
from .impact import normal_speeds
from .kinematics import coupled_kinematics
from .integrator import (
    COUPLED, FREE, M_DIR, M_IROT, M_IVER, M_N1, M_N2, M_S1, M_S2, M_S4, M_S5, M_TSTUCK, M_VSTUCK, MX_REV, N_COLS,
    R_ARMED, R_BAD, R_CONTACT, R_MISS, R_SEPARATION, R_STALL, R_TIP, R_TMAX, _deriv, _record,
    _track_max, _train_start_direction, _verge_start_direction,
)

__all__ = ["run_ivp", "MAX_STEP_SPIN"]

#: largest step, in radians of fuze spin (a beat of the M739 lasts about 0.9 rad)
MAX_STEP_SPIN = 0.02


@kernel
def _state_eval(k, regime, side, y, off, m):
    """Derivatives and event values with the friction signs taken from the state.

    The directions of motion (train direction in ``m``, and the verge's in free motion)
    are kept from ``m``: they change only where a speed passes through zero, which is a
    terminal event.  Everything else -- mesh phases, sliding direction on the face,
    inertia branches -- follows the state at every evaluation, as in the report's program.
    """
    mm = m.copy()
    phi_total = y[0] + off
    n1, n2, s1, s2 = mesh_phase(k, phi_total)
    mm[M_N1] = n1
    mm[M_N2] = n2
    mm[M_S1] = s1
    mm[M_S2] = s2
    mm[M_IROT] = 0.0
    mm[M_IVER] = 0.0
    if regime == COUPLED:
        s4, s5 = coupled_signs(k, side, y[0], 0.0, mm[M_DIR])
        mm[M_S4] = s4
        mm[M_S5] = s5
    return _deriv(k, regime, side, y[0], y[1], y[2], y[3], off, mm), mm


def run_ivp(k: Constants, *, phi_start: float, t_max: float, record: bool = True, rtol: float = 1e-9,
            atol: float = 1e-12, max_phases: int = 200_000) -> RunResult:
    """Simulate from rest with ``scipy.integrate.solve_ivp`` (DOP853) for every phase.

    Parameters as :func:`escfit.verge.hybrid.run_rk4`; ``rtol`` and ``atol`` are the
    solver tolerances (``atol`` applies to angles in rad and speeds in rad/s alike).
    """

    max_step = MAX_STEP_SPIN / k.omega

    def phase(regime, side, y, t, off, m, armed, buf, n, mx):
        state = {"armed": armed}
        while True:
            r, _mm = _state_eval(k, regime, side, y, off, m)
            if not (math.isfinite(r[1]) and math.isfinite(r[3])):
                return R_BAD, t, n, state["armed"], buf
            if regime == FREE and r[7] > 0.0:
                state["armed"] = True
            hit = _ivp_fires(regime, r, k.phi_cut - (y[0] + off), state["armed"], _closing(k, side, y))
            if hit >= 0:
                buf, n = _store(k, regime, side, y, t, off, m, buf, n, mx, record)
                return hit, t, n, state["armed"], buf
            if m[M_TSTUCK] > 0.5 and (regime == COUPLED or m[M_VSTUCK] > 0.5):
                return R_STALL, t, n, state["armed"], buf
            if t >= t_max:
                buf, n = _store(k, regime, side, y, t, off, m, buf, n, mx, record)
                return R_TMAX, t, n, state["armed"], buf

            def rhs(_t, yy):
                d, _ = _state_eval(k, regime, side, yy, off, m)
                return [d[0], d[1], d[2], d[3]] if m[M_TSTUCK] < 0.5 else [0.0, 0.0, d[2], d[3]]

            events = _make_events(k, regime, side, off, m, state["armed"])
            # scipy looks for events only at step ends: a gap that opens and closes again
            # within one (smooth, hence long) step would go unseen, so cap the step
            sol = solve_ivp(rhs, (t, t_max), y.copy(), method="DOP853", rtol=rtol, atol=atol, events=events,
                            dense_output=False, max_step=max_step)
            if sol.status < 0:
                return R_BAD, t, n, state["armed"], buf
            for j in range(sol.t.size - 1):
                yy = sol.y[:, j].copy()
                if regime == COUPLED:
                    _kinematic(k, regime, side, yy, off, m)
                buf, n = _store(k, regime, side, yy, sol.t[j], off, m, buf, n, mx, record)
            which = sorted((te[0], i) for i, te in enumerate(sol.t_events) if te.size)
            t = float(sol.t[-1])
            y[:] = sol.y[:, -1]
            if regime == COUPLED:
                _kinematic(k, regime, side, y, off, m)
            if not which:
                continue  # reached t_max: reported at the top of the loop
            first = which[0][1]
            name = events[first].name
            if name in ("tip", "separation", "contact", "miss", "armed"):
                y[:] = sol.y_events[first][0]
                if regime == COUPLED:
                    _kinematic(k, regime, side, y, off, m)
                code = {"tip": R_TIP, "separation": R_SEPARATION, "contact": R_CONTACT, "miss": R_MISS,
                        "armed": R_ARMED}[name]
                if code == R_CONTACT and _state_eval(k, regime, side, y, off, m)[0][8] < 0.0:
                    code = R_MISS  # the gap closed beyond the face tip
                buf, n = _store(k, regime, side, y, t, off, m, buf, n, mx, record)
                return code, t, n, state["armed"], buf
            if name == "gap_opens":
                state["armed"] = True
            elif name == "train_stops":
                y[1] = 0.0
                if regime == COUPLED:
                    y[3] = 0.0
                d = _train_start_direction(k, regime, side, y, off, _mode_for(k, regime, side, y, off, m))
                if d == 0.0:
                    m[M_TSTUCK] = 1.0
                else:
                    if d != m[M_DIR]:
                        mx[MX_REV] += 1.0
                    m[M_DIR] = d
            elif name == "verge_stops":
                y[3] = 0.0
                d = _verge_start_direction(k, side, y)
                if d == 0.0:
                    m[M_VSTUCK] = 1.0
                else:
                    m[M_S5] = d

    cap = 4096 if record else 1
    return run_hybrid(k, phase, phi_start=phi_start, t_max=t_max, record=record, max_phases=max_phases,
                      capacity=cap)


def _mode_for(k, regime, side, y, off, m):
    return _state_eval(k, regime, side, y, off, m)[1]


def _kinematic(k, regime, side, y, off, m):
    """Put the verge where the coupled kinematics says it is."""
    psi, _g, u, *_ = coupled_kinematics(k.a, k.b, k.c, side_alpha(k, side), y[0])
    y[2], y[3] = psi, u * y[1]


def _closing(k, side, y) -> float:
    """Normal approach speed of tooth and face (in/s, > 0 closing)."""
    vs, vp, _a, _d = normal_speeds(k, side_alpha(k, side), y[0], y[2], y[1], y[3])
    return side * (vs - vp)


def _ivp_fires(regime, r, cut, armed, closing) -> int:
    if cut <= 0.0:
        return R_ARMED
    if regime == COUPLED:
        if r[7] <= 0.0:
            return R_TIP
        if r[8] <= 0.0:
            return R_SEPARATION
        return -1
    # a root located by scipy may leave the gap a rounding error below zero while the
    # bodies separate: only a closing contact counts
    if armed and r[7] <= 0.0 and r[8] >= 0.0 and closing > 0.0:
        return R_CONTACT
    if r[8] < 0.0:
        return R_MISS
    return -1


def _store(k, regime, side, y, t, off, m, buf, n, mx, record):
    r, mm = _state_eval(k, regime, side, y, off, m)
    _track_max(mx, regime, r)
    if record:
        if n >= buf.shape[0]:
            buf = np.concatenate([buf, np.empty((buf.shape[0], N_COLS))])
        _record(buf, n, t, y, off, regime, side, r, mm)
        n += 1
    return buf, n


def _make_events(k, regime, side, off, m, armed):
    def ev(fn, name, direction):
        def f(_t, yy):
            return fn(yy)

        f.terminal = True
        f.direction = direction
        f.name = name
        return f

    def val(i):
        return lambda yy: _state_eval(k, regime, side, yy, off, m)[0][i]

    out = [ev(lambda yy: k.phi_cut - (yy[0] + off), "armed", -1)]
    if regime == COUPLED:
        out += [ev(val(7), "tip", -1), ev(val(8), "separation", -1)]
    else:
        out += [ev(val(7), "contact", -1) if armed else ev(val(7), "gap_opens", 1), ev(val(8), "miss", -1)]
    if m[M_TSTUCK] < 0.5:
        out.append(ev(lambda yy: yy[1], "train_stops", -m[M_DIR]))
    if regime == FREE and m[M_VSTUCK] < 0.5:
        out.append(ev(lambda yy: yy[3], "verge_stops", -m[M_S5]))
    return out
