"""An independent integration of a balance from its coefficient record, for the conformance suite.

Written apart from escfit's solvers (no walker, no regions, no swing frame): the balance-frame
equation ::

    theta'' = -C theta' - restoring(theta) - s R + s * sum(windows acting at s*theta)
              + s * sum(smooth torque(s*theta, s*theta'))

(``s`` the sign of the motion; ``restoring`` the hairspring's pieces ``w2[i] theta + off[i]`` or
a pendulum's ``w2 sin(theta)``; the smooth torques are each effect's own ``torque``, the
definition of its physics) is integrated by scipy's DOP853 at rtol 1e-12 from switch point to
switch point: every window edge, hairspring break angle and the banking angle is a terminal
event, so no step straddles a discontinuity.  At rest the balance moves on only while the
acceleration towards the motion exceeds the static friction beyond the sliding one; at the
pins the velocity is reversed and multiplied by the restitution; the damping drift multiplies
C after every full cycle by ``1 + rate`` of the band the envelope ``exp(-int C dt / 2)`` lies in.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from escfit.balance import acceleration as acceleration_module
from escfit.balance.effects import EFFECTS


def smooth_torques() -> list:
    """Every registered effect's ``torque`` function (the smooth ones)."""
    out = []
    for cls in EFFECTS.values():
        module = __import__(cls.__module__, fromlist=["torque"])
        if hasattr(module, "torque"):
            out.append(module.torque)
    return out


def reference_turns(k, n_swings: int) -> tuple[np.ndarray, str]:
    """Signed turning angles (rad; the banking angle at an impact) and the final status label."""
    torques = smooth_torques()
    c = float(k["c"])
    r, r_static = float(k["r"]), float(k["r_static"])
    n_w = int(k["n_windows"])
    w_lo, w_hi, w_x, w_dir = (np.asarray(k[f])[:n_w] for f in ("w_lo", "w_hi", "w_x", "w_dir"))
    n_p = int(k["n_pieces"])
    bp, w2, off = np.asarray(k["sp_bp"])[:n_p - 1], np.asarray(k["sp_w2"])[:n_p], np.asarray(k["sp_off"])[:n_p]
    pendulum = bool(k["pendulum"])
    bank, restitution = float(k["bank"]), float(k["restitution"])
    n_b = int(k["n_bands"])
    d_th, d_rate = np.asarray(k["drift_th"])[:n_b], np.asarray(k["drift_rate"])[:n_b + 1]
    top = float(np.max(w2))

    def restoring(th):
        if pendulum:
            return w2[0] * math.sin(th)
        i = int(np.searchsorted(bp, th, side="right"))
        return w2[i] * th + off[i]

    def acc(th, om, s, cc):
        x = s * th
        drive = sum(w_x[i] for i in range(n_w) if (w_dir[i] == 0 or w_dir[i] == s) and w_lo[i] <= x < w_hi[i])
        a = -cc * om - restoring(th) + s * (drive - r)
        for f in torques:
            a += s * f(x, s * om, k)[0]
        return a

    th, om = float(k["theta0"]), float(k["v0"])
    s = math.copysign(1.0, om) if om != 0.0 else (1.0 if th < 0.0 else -1.0)
    turns = []
    int_c = 0.0
    status = "ok"
    t_scale = 1.0 / math.sqrt(top)
    while len(turns) < n_swings:
        if om == 0.0:
            a0 = s * acc(th, 0.0, s, c)  # towards the motion, sliding friction included
            if a0 <= max(r_static - r, 0.0):
                status = "stopped"
                break
        edges = sorted({*(e for i in range(n_w) if w_dir[i] in (0, s) for e in (w_lo[i], w_hi[i])),
                        *(s * b for b in bp), *([bank] if math.isfinite(bank) else [])})
        banked = False
        t_swing = 0.0
        while True:  # segments of one half swing, from switch point to switch point
            x = s * th
            ahead = [e for e in edges if e > x + 1e-15 * max(1.0, abs(x))]
            events = []

            def turn(_t, y):
                return s * y[1]
            turn.terminal, turn.direction = True, -1.0
            events.append(turn)
            if ahead:
                e0 = ahead[0]

                def edge(_t, y, e0=e0):
                    return s * y[0] - e0
                edge.terminal, edge.direction = True, 1.0
                events.append(edge)
            om0 = om if om != 0.0 else s * 1e-300
            sol = solve_ivp(lambda _t, y: (y[1], acc(y[0], y[1], s, c)), (0.0, 200.0 * t_scale), [th, om0],
                            method="DOP853", rtol=1e-12, atol=1e-14 * max(abs(th), 1e-300), events=events)
            hits = [(sol.t_events[i][0], i) for i in range(len(events)) if sol.t_events[i].size]
            if not hits:
                return np.array(turns), "stopped"  # creeps to rest
            te, i = min(hits)
            th, om = (float(v) for v in sol.y_events[i][0])
            t_swing += te
            if i == 0:  # turning point
                om = 0.0
                break
            th = s * ahead[0]
            if ahead[0] == bank:
                banked = True
                break
        int_c += c * t_swing
        turns.append(th)
        if banked:
            om = -restitution * om
            status = "banked"
        s = -s
        if n_b and len(turns) % 2 == 0:
            env = math.exp(-0.5 * int_c)
            band = next((i for i in range(n_b) if env > d_th[i]), n_b)
            c *= 1.0 + d_rate[band]
    return np.array(turns), status
