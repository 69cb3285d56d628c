"""scipy ``solve_ivp`` with located events, for comparison with the compiled solvers.

Each segment of frozen regime is one ``solve_ivp`` call whose terminal events are the next
window edge (rising) and the turning point (velocity falling through zero); scipy's event
conventions stay inside this module.

In the swing frame ``x = s*theta`` a region of the swing has constants ``(w2, xc)`` (see
:mod:`escfit.balance.regions`) and the right-hand side is the shared
:func:`escfit.balance.acceleration.acceleration` (``-C v - w2 (x - xc)`` for a spring, ``sin x`` for a
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
from .kernel_records import columns, half_swings, run_options
from .segment import creep_horizon
from .solution import DenseSolution
from .system import System
from .acceleration import acceleration
from .trajectory import Trajectory
from .walker import EDGE, FAILED, REST, TURN, Segment, compile_walk

__all__ = ["solve_ivp_events", "advance_ivp", "IvpSolution"]

# A turning point found beyond the next edge by less than GRAZE times the step tolerance is a
# grazing turn at the edge (the integration's own drift, e.g. an undamped balance released at
# the banking angle), not a missed crossing.
GRAZE = 100.0


@kernel
def _acc(ks, w2, xc, x, v):
    """:func:`escfit.balance.acceleration.acceleration` of record ``ks[0]`` (an array of one reaches a
    compiled function fastest)."""
    return acceleration(x, v, w2, xc, ks[0])


#: scipy methods, by their index in ``run.mode``
METHODS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")


def _scratch(k) -> tuple:
    """The record as an array of one (which reaches a compiled function fastest) and the extra
    horizon of a pendulum, whose half swing lasts ``2 K(sin^2(A/2)) / omega0``, long near pi."""
    ks = np.array([k], dtype=k.dtype)
    extra = 0.0
    if k.pendulum:
        extra = 4.0 * float(ellipk(math.sin(0.5 * float(k.theta0)) ** 2)) / float(k.omega0)
    return ks, extra


def advance_ivp(k, run, start, region, work, rows, n_rows) -> Segment:
    """One region of a half swing by one :func:`scipy.integrate.solve_ivp` call: the walk's step
    (:mod:`escfit.balance.walker`), run as plain Python.

    Terminal events: the edge ahead (rising), the turning point (velocity falling through zero)
    and, for a pendulum, ``x = pi``; no event within the horizon (every solver's
    :func:`~escfit.balance.segment.creep_horizon`, plus a pendulum's longest half swing) is a
    creep to rest.  With ``run.dense`` the call's dense output is appended to ``rows`` as
    ``(t0, t1, s, swing, OdeSolution)``.
    """
    t0, x, v, s, swing, _ = start
    w2, xc, xb, _ = region
    ks, extra = work
    rtol, atol = float(run.rtol), float(run.atol_x)
    a_rest = _acc(ks, w2, xc, x, 0.0)
    motion = math.hypot(a_rest, v * math.sqrt(w2)) / w2

    def rhs(_t, y):
        return (y[1], _acc(ks, w2, xc, y[0], y[1]))

    def edge(_t, y):
        return y[0] - xb

    def turn(_t, y):
        return y[1]

    def over_top(_t, y):
        return y[0] - math.pi

    edge.terminal, edge.direction = True, 1.0
    turn.terminal, turn.direction = True, -1.0
    over_top.terminal, over_top.direction = True, 1.0
    events = [turn] if not math.isfinite(xb) else [edge, turn]
    if k.pendulum:
        events.append(over_top)
    y0 = [x, v]
    if v == 0.0:  # start from rest: nudge past the trivial root of the turning event
        y0[1] = 1e-300
    sol = solve_ivp(rhs, (0.0, extra + creep_horizon(float(k.c), w2)), y0, method=METHODS[int(run.mode)], rtol=rtol,
                    atol=atol, events=events, dense_output=bool(run.dense) or math.isfinite(xb))
    steps = int(sol.t.size)
    hit = [i for i, te in enumerate(sol.t_events) if te.size]
    if not hit:  # creeps to rest within the horizon without an event
        return Segment(REST, float(sol.t[-1]), float(sol.y[0, -1]), float(sol.y[1, -1]), 0.0, x, motion, 0, steps,
                       n_rows)
    i = min(hit, key=lambda i: sol.t_events[i][0])
    te = float(sol.t_events[i][0])
    ye = sol.y_events[i][0]
    if events[i] is over_top:
        return Segment(FAILED, te, math.pi, float(ye[1]), 0.0, x, motion, int(Status.OVER_THE_TOP), steps, n_rows)
    is_edge = events[i] is edge
    if not is_edge and float(ye[0]) - xb > GRAZE * (atol + rtol * abs(xb)):
        te, ye = _missed_edge(sol, xb, te)
        is_edge = True
    if run.dense:
        rows.append((t0, t0 + te, s, swing, sol.sol))
        n_rows += 1
    if is_edge:
        return Segment(EDGE, te, xb, float(ye[1]), 0.0, xb, motion, 0, steps, n_rows)
    x_turn = float(ye[0])
    a_turn = _acc(ks, w2, xc, x_turn, 0.0)  # the turn's offset from the rest position is -a/w2
    return Segment(TURN, te, x_turn, 0.0, a_turn / w2, x_turn + a_turn / w2, motion, 0, steps, n_rows)


#: The walk of :mod:`escfit.balance.walker` as plain Python, with :func:`advance_ivp`.
_walk_ivp = compile_walk(advance_ivp, _scratch, "ivp", python=True)


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
    if method not in METHODS:
        raise SolverError(f"unknown solve_ivp method {method!r}")
    nseg = int(max_segments or 64 * n_swings + 1000)
    run = run_options(n_swings, max_segments=nseg, t_end=t_end, dense=dense, rtol=rtol, atol_x=atol,
                      mode=METHODS.index(method)).view(np.recarray)[0]
    out = half_swings(n_swings).view(np.recarray)
    pieces: list = []  # (t0, t1, s, swing, OdeSolution) of every region, for the dense solution
    res = _walk_ivp(system.k.view(np.recarray)[0], run, out, pieces)
    traj = Trajectory(*columns(out.view(np.ndarray), int(res.n_done)), Status(int(res.status)), system.omega0, "ivp",
                      {"method": method, "rtol": rtol, "atol": atol}, int(res.n_seg), int(res.steps),
                      (float(res.t), float(res.theta), float(res.omega)))
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
