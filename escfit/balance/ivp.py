"""scipy ``solve_ivp`` with located events, for comparison with the compiled solvers.

Each segment of frozen regime is one ``solve_ivp`` call whose terminal events are the next
window edge (rising) and the turning point (velocity falling through zero); scipy's event
conventions stay inside this module.

In the swing frame ``x = s*theta`` a region of the swing has constants ``(w2, xc)`` (see
:mod:`escfit.balance.regions`) and the right-hand side is the shared
:func:`escfit.balance.torque.acceleration` (``-C v - w2 (x - xc)`` for a spring, ``sin x`` for a
pendulum, plus every smooth torque an effect defines): this module has no code of any effect.
The segments' dense outputs make the run's dense solution (:class:`IvpSolution`).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import ellipk

from ..core.errors import SolverError
from ..core.kernels import kernel
from ..core.status import Status
from .regions import region_at, swing_edges
from .segment import creep_horizon, creeps_to_rest
from .solution import DenseSolution
from .system import System
from .torque import acceleration
from .trajectory import Trajectory

__all__ = ["solve_ivp_events", "IvpSolution"]

# A turning point found beyond the next edge by less than GRAZE times the step tolerance is a
# grazing turn at the edge (the integration's own drift, e.g. an undamped balance released at
# the banking angle), not a missed crossing.
GRAZE = 100.0


@kernel
def _acc(ks, w2, xc, x, v):
    """:func:`escfit.balance.torque.acceleration` of record ``ks[0]`` (an array of one reaches a
    compiled function fastest)."""
    return acceleration(x, v, w2, xc, ks[0])


@kernel
def _region(ks, x, s, edges, n_edges):
    return region_at(x, s, edges, n_edges, ks[0])


@kernel
def _edges(ks, s, edges):
    return swing_edges(s, ks[0], edges)


def solve_ivp_events(system: System, n_swings: int, *, method: str = "DOP853", rtol: float = 1e-10,
                     atol: float = 1e-12, max_segments: int | None = None, dense: bool = False,
                     t_end: float = math.inf) -> Trajectory:
    """Integrate with scipy's adaptive methods (RK45, DOP853, Radau, ...) and events.

    Parameters
    ----------
    method, rtol, atol
        Passed to :func:`scipy.integrate.solve_ivp`.
    max_segments
        Segment budget (default ``64*n_swings + 1000``).
    dense
        Keep the segments' dense outputs as the dense solution.
    t_end
        End the run with the first half swing ending at or after this time (s), if it comes first.
    """
    if method not in ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA"):
        raise SolverError(f"unknown solve_ivp method {method!r}")
    ks = system.k
    k = ks[0]
    theta0, c, bank, rest = float(k["theta0"]), float(k["c"]), float(k["bank"]), float(k["restitution"])
    hold = float(k["r_static"] - k["r"])
    nseg = int(max_segments or 64 * n_swings + 1000)
    s = 1.0 if theta0 < 0 else -1.0
    x, v, t, t_last = s * theta0, 0.0, 0.0, 0.0
    amp, tturn, hp, tm, bk = [], [], [], [], []
    edges = np.empty(2 * int(k["n_windows"]) + int(k["n_pieces"]))
    n_edges = _edges(ks, s, edges)
    status, nsteps, n_seg, at_start = Status.OK, 0, 0, True
    pieces = []  # (t0, t1, s, swing, OdeSolution) of every segment, for the dense solution
    pend = system.restoring == "pendulum"
    # no event within this long a segment: a creep to rest, on the horizon every solver uses
    # (segment.creep_horizon) so that they agree on when a balance has stopped
    horizon = 0.0
    if pend:  # a pendulum's half swing lasts 2 K(sin^2(A/2)) / omega0, long near A = pi
        horizon = 4.0 * float(ellipk(math.sin(0.5 * theta0) ** 2)) / system.omega0
    scale = -1.0
    while len(amp) < n_swings:
        if n_seg >= nseg:
            status = Status.MAX_SEGMENTS
            break
        j, w2, xc = _region(ks, x, s, edges, n_edges)
        if at_start and v <= 0.0 and _acc(ks, w2, xc, x, 0.0) <= max(hold, 0.0):
            status = Status.STOPPED  # the net acceleration at rest cannot overcome static friction
            break
        xb = edges[j] if j < n_edges else math.inf
        if scale < 0.0:  # the run's scale: the release's offset from its rest position (rad)
            scale = math.hypot(_acc(ks, w2, xc, x, 0.0), v * math.sqrt(w2)) / w2

        def rhs(_t, y, w2=w2, xc=xc):
            return (y[1], _acc(ks, w2, xc, y[0], y[1]))

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
                        dense_output=dense or math.isfinite(xb))
        nsteps += int(sol.t.size)
        n_seg += 1
        hit = [i for i, te in enumerate(sol.t_events) if te.size]
        if not hit:
            status = Status.STOPPED  # creeps to rest within the horizon without an event
            break
        i = min(hit, key=lambda i: sol.t_events[i][0])
        if events[i] is over_top:
            status = Status.OVER_THE_TOP
            t += float(sol.t_events[i][0])
            x = math.pi
            break
        te = float(sol.t_events[i][0])
        ye = sol.y_events[i][0]
        is_edge = events[i] is edge
        if not is_edge and float(ye[0]) - xb > GRAZE * (atol + rtol * abs(xb)):
            te, ye = _missed_edge(sol, xb, te)
            is_edge = True
        if dense:
            pieces.append((t, t + te, s, len(amp), sol.sol))
        t += te
        at_start = False
        if is_edge:
            x, v = xb, max(float(ye[1]), 0.0)
            is_bank = j == n_edges - 1 and math.isfinite(bank)
            if not is_bank:
                continue
        else:
            x, v, is_bank = float(ye[0]), 0.0, False
            a_end, a_start = _acc(ks, w2, xc, x, 0.0), _acc(ks, w2, xc, y0[0], 0.0)
            if creeps_to_rest(a_end / w2, math.hypot(a_start, y0[1] * math.sqrt(w2)) / w2, scale):
                status = Status.STOPPED  # a turn on the rest position to within rounding: a creep to rest
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
        n_edges = _edges(ks, s, edges)
        if t >= t_end:
            break
    if status == Status.OK and any(bk):
        status = Status.BANKED
    traj = Trajectory(np.array(amp), np.array(tturn), np.array(hp), np.array(tm), np.array(bk, bool), status,
                      system.omega0, "ivp", {"method": method, "rtol": rtol, "atol": atol}, n_seg, nsteps,
                      (t, s * x, s * v))
    if dense:
        traj.dense = IvpSolution(pieces, traj)
    return traj


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
    t_lo = float(sol.t[-2]) if sol.t.size >= 2 else 0.0
    f = lambda tt: float(sol.sol(tt)[0]) - xb  # noqa: E731
    if not f(t_lo) < 0.0:  # the edge lies at the start of the step: a crossing at its start
        return t_lo, sol.sol(t_lo)
    tx = brentq(f, t_lo, t_turn, xtol=1e-16, rtol=4.0 * np.finfo(float).eps, maxiter=200)
    return float(tx), sol.sol(tx)


class IvpSolution(DenseSolution):
    """The dense solution of the scipy adapter: each segment's own dense output (scipy's
    interpolant of the method, e.g. DOP853's seventh-order one)."""

    def __init__(self, pieces: list, trajectory: Trajectory):
        self.pieces = pieces
        self.trajectory = trajectory
        self._starts = np.array([p[0] for p in pieces], float)

    def state(self, t):
        times = np.asarray(t, dtype=float)
        flat = times.reshape(-1)
        theta, omega = np.empty(flat.size), np.empty(flat.size)
        end = self.pieces[-1][1] if self.pieces else -math.inf
        beyond = self._beyond()
        idx = np.searchsorted(self._starts, flat, side="right") - 1
        for q, (tq, i) in enumerate(zip(flat, idx)):
            if not tq <= end or i < 0:
                theta[q], omega[q] = beyond if not tq <= end else (math.nan, math.nan)
                continue
            t0, t1, s, _, ode = self.pieces[i]
            x, v = ode(min(tq, t1) - t0)
            theta[q], omega[q] = s * x, s * v
        if times.ndim == 0:
            return theta[0], omega[0]
        return theta.reshape(times.shape), omega.reshape(times.shape)

    def crossings(self, swing, level, offset: float = 0.0) -> np.ndarray:
        swing = np.asarray(swing, dtype=np.int64).reshape(-1)
        level = np.broadcast_to(np.asarray(level, float), swing.shape)
        by_swing: dict[int, list] = {}
        for p in self.pieces:
            by_swing.setdefault(p[3] + 1, []).append(p)
        out = np.full(swing.size, math.nan)
        for q, (m, x_base) in enumerate(zip(swing, level)):
            pieces = by_swing.get(int(m))
            if not pieces:
                continue
            s = pieces[0][2]
            x = x_base + s * offset
            out[q] = _crossing(pieces, x)
        return out

    def knots(self) -> np.ndarray:
        if not self.pieces:
            return np.zeros(1)
        return np.append(self._starts, self.pieces[-1][1])


def _crossing(pieces: list, x: float) -> float:
    """Time at which the swing-frame angle of one half swing's ``pieces`` rises to ``x`` (clamped)."""
    t0, _, _, _, ode = pieces[0]
    if x <= float(ode(0.0)[0]):
        return t0
    for t0, t1, _, _, ode in pieces:
        tau = t1 - t0
        if x <= float(ode(tau)[0]):
            f = lambda u: float(ode(u)[0]) - x  # noqa: E731
            return t0 + brentq(f, 0.0, tau, xtol=1e-16, rtol=4.0 * np.finfo(float).eps, maxiter=200)
    return pieces[-1][1]
