"""scipy ``solve_ivp`` with located events, for comparison with the exact solver.

Each segment of frozen regime is one ``solve_ivp`` call whose terminal events are the next
window edge (rising) and the turning point (velocity falling through zero); scipy's event
conventions stay inside this module.

In the swing frame ``x = s*theta`` a region of the swing has constants ``(w2, xc)`` (see
:func:`escfit.balance.exact._region`): ``w2*xc`` gathers Coulomb friction, the windows acting
there and the hairspring offset, so the right-hand side is ``-C v - w2 (x - xc)`` for a
spring and ``-C v - w2 (sin x - xc)`` for a pendulum (``w2 = omega0**2``, no offset).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.special import ellipk

from ..core.errors import SolverError
from .effects.base import SystemBuilder
from .exact import _region, _swing_edges
from .segment import creep_horizon, creeps_to_rest
from .solvers import OVER_THE_TOP, _check_system, static_args, status_of
from .trajectory import Trajectory

__all__ = ["solve_ivp_events"]

# A turning point found beyond the next edge by less than GRAZE times the step tolerance is a
# grazing turn at the edge (the integration's own drift, e.g. an undamped balance released at
# the banking angle), not a missed crossing.
GRAZE = 100.0


def solve_ivp_events(sys: SystemBuilder, n_swings: int, switching: str, *, method: str = "DOP853",
                     rtol: float = 1e-10, atol: float = 1e-12, max_segments: int | None = None) -> Trajectory:
    """Integrate with scipy's adaptive methods (RK45, DOP853, Radau, ...) and events.

    Parameters
    ----------
    method, rtol, atol
        Passed to :func:`scipy.integrate.solve_ivp`.
    max_segments
        Segment budget (default ``64*n_swings + 1000``).
    """
    _check_system(sys, switching)
    if method not in ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA"):
        raise SolverError(f"unknown solve_ivp method {method!r}")
    theta0, _, c, r, bp, w2s, off, w_lo, w_hi, w_x, w_dir, bank, rest = static_args(sys, "ivp")
    nseg = int(max_segments or 64 * n_swings + 1000)
    s = 1.0 if theta0 < 0 else -1.0
    x, v, t, t_last = s * theta0, 0.0, 0.0, 0.0
    amp, tturn, hp, tm, bk = [], [], [], [], []
    edges = np.empty(2 * len(w_lo) + len(bp) + 1)
    n_edges = _swing_edges(s, bank, bp, w_lo, w_hi, w_dir, edges)
    status, nsteps, n_seg, at_start = "ok", 0, 0, True
    message = ""
    pend = sys.restoring == "pendulum"
    spring = math.sin if pend else (lambda x: x)
    # no event within this long a segment: a creep to rest, on the horizon every solver uses
    # (segment.creep_horizon) so that they agree on when a balance has stopped
    horizon = 0.0
    if pend:  # a pendulum's half swing lasts 2 K(sin^2(A/2)) / omega0, long near A = pi
        horizon = 4.0 * float(ellipk(math.sin(0.5 * theta0) ** 2)) / sys.omega0
    scale = -1.0
    while len(amp) < n_swings:
        if n_seg >= nseg:
            status = "max_segments"
            break
        j, w2, xc = _region(x, s, edges, n_edges, bp, w2s, off, w_lo, w_hi, w_x, w_dir, r)
        if at_start and v <= 0.0 and spring(x) - xc >= 0.0:
            status = "stopped"  # the net acceleration at rest, -w2 (spring(x) - xc), cannot start it
            break
        xb = edges[j] if j < n_edges else math.inf
        if scale < 0.0:  # the run's scale: the release's offset from its rest position (rad)
            scale = math.hypot(spring(x) - xc, v / math.sqrt(w2))

        def rhs(_t, y, w2=w2, xc=xc):
            return (y[1], -c * y[1] - w2 * (spring(y[0]) - xc))

        def edge(_t, y, xb=xb):
            return y[0] - xb

        def turn(_t, y):
            return y[1]

        def over_top(_t, y):
            return y[0] - math.pi

        edge.terminal, edge.direction = True, 1.0
        turn.terminal, turn.direction = True, -1.0
        over_top.terminal, over_top.direction = True, 1.0
        events = [turn] if not math.isfinite(xb) else [edge, turn]
        if pend:
            events.append(over_top)
        y0 = [x, v if v > 0 else 0.0]
        if y0[1] == 0.0:  # start from rest: nudge past the trivial root of the turning event
            y0[1] = 1e-300
        sol = solve_ivp(rhs, (0.0, horizon + creep_horizon(c, w2)), y0, method=method, rtol=rtol, atol=atol, events=events,
                        dense_output=math.isfinite(xb))
        nsteps += int(sol.t.size)
        n_seg += 1
        hit = [k for k, te in enumerate(sol.t_events) if te.size]
        if not hit:
            status = "stopped"  # creeps to rest within the horizon without an event
            break
        k = min(hit, key=lambda k: sol.t_events[k][0])
        if events[k] is over_top:
            status, message = status_of(OVER_THE_TOP)
            t += float(sol.t_events[k][0])
            x = math.pi
            break
        te = float(sol.t_events[k][0])
        ye = sol.y_events[k][0]
        is_edge = events[k] is edge
        if not is_edge and float(ye[0]) - xb > GRAZE * (atol + rtol * abs(xb)):
            te, ye = _missed_edge(sol, xb, te)
            is_edge = True
        t += te
        at_start = False
        if is_edge:
            x, v = xb, max(float(ye[1]), 0.0)
            is_bank = j == n_edges - 1 and math.isfinite(bank)
            if not is_bank:
                continue
        else:
            x, v, is_bank = float(ye[0]), 0.0, False
            if creeps_to_rest(spring(x) - xc, math.hypot(spring(y0[0]) - xc, y0[1] / math.sqrt(w2)), scale):
                status = "stopped"  # a turn on the rest position to within rounding: a creep to rest
                break
        amp.append(abs(x))
        tturn.append(s * x)
        hp.append(t - t_last)
        tm.append(t)
        bk.append(is_bank)
        t_last = t
        s, x = -s, -x
        v = rest * v if is_bank else 0.0
        at_start = v == 0.0
        n_edges = _swing_edges(s, bank, bp, w_lo, w_hi, w_dir, edges)
    if status == "ok" and any(bk):
        status = "banked"
    return Trajectory(np.array(amp), np.array(tturn), np.array(hp), np.array(tm), np.array(bk, bool), status,
                      sys.omega0, "ivp", {"method": method, "rtol": rtol, "atol": atol}, n_seg, nsteps,
                      (t, s * x, s * v), message=message)



def _missed_edge(sol, xb: float, t_turn: float) -> tuple[float, np.ndarray]:
    """The edge crossing inside the last step when the turning point lies beyond the edge.

    scipy tests event functions for a sign change between the ends of each step only, so a
    swing that passes the edge and turns back within one step shows no crossing of the edge
    and a turning point beyond it, computed with the wrong region's torques.  The crossing
    lies in the last step before the turning point (where ``x`` rises); it is located on the
    step's dense output.

    Returns
    -------
    (t, y)
        Time of the crossing within the segment (s) and the state there.
    """
    from scipy.optimize import brentq

    t_lo = float(sol.t[-2]) if sol.t.size >= 2 else 0.0
    f = lambda tt: float(sol.sol(tt)[0]) - xb  # noqa: E731
    if not f(t_lo) < 0.0:  # the edge lies at the start of the step: a crossing at its start
        return t_lo, sol.sol(t_lo)
    tx = brentq(f, t_lo, t_turn, xtol=1e-16, rtol=4.0 * np.finfo(float).eps, maxiter=200)
    return float(tx), sol.sol(tx)
