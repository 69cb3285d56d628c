"""The regime automaton: coupled motion, free motion and impacts until the rotor is armed.

Cycle of a normal run (the M739 at 30,000 rpm does nothing else)::

    entrance-coupled --tooth leaves face tip--> free (exit side) --contact--> impact
    --> exit-coupled --tooth leaves face tip--> free (entrance side) --contact--> impact --> ...

Other transitions: the contact force vanishes in coupled motion (free motion on the same
side), the tooth passes a face tip without touching it in free motion (free motion on the
other side), a separating or grazing contact, and bodies held at rest by friction.

Re-referencing at a side change: ``phi`` always describes the tooth engaged with the
active face, so passing from the entrance to the exit face moves the reference
``nt`` teeth forward (``phi += nt * pitch``) and from exit to entrance ``nt + 1`` teeth
back; ``psi`` is measured to the active face tip, which sits ``lambda`` behind the other
tip (``psi += 2 pi - lambda`` entrance -> exit).  The cumulative angle ``phi_total`` is
unaffected.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.status import Status
from .dynamics import side_alpha
from .geometry import Constants
from .impact import impact_map, normal_speeds
from .integrator import (
    COUPLED, FREE, M_DIR, N_COLS, R_ARMED, R_BAD, R_BUFFER, R_CHATTER, R_CONTACT, R_MISS,
    R_SEPARATION, R_STALL, R_TIP, R_TMAX, REASONS, initial_mode, integrate_phase,
)
from .kinematics import coupled_kinematics

__all__ = ["RunResult", "run_rk4", "run_hybrid", "side_change", "impact_decision", "DEFAULT_STEP", "IMPACT_FIELDS"]

#: default RK4 step in radians of fuze-body spin (the step in seconds is this / omega,
#: so runs at any spin rate take the same number of steps)
DEFAULT_STEP = 0.01

IMPACT_FIELDS = ("time", "side", "phi", "psi", "phidot_before", "psidot_before", "phidot_after",
                 "psidot_after", "closing_speed")

_FAILED = Status.FAILED.label  # the word every family's solvers use for a failed model


@dataclass(frozen=True)
class RunResult:
    """Outcome of one simulated arming run (report units: in, lbf, s, rad).

    Attributes
    ----------
    status : str
        ``"armed"`` (the cumulative wheel angle reached ``phi_cut``), ``"not_armed"``
        (stalled by friction, or the time limit came first) or ``"failed"`` (the model
        left its domain or chattered between regimes).
    reason : str
        Finer cause: ``armed``, ``stalled``, ``time_limit``, ``phase_limit``,
        ``bad_state``, ``chatter``.
    message : str
        One readable sentence.
    time_to_arm : float
        Time at which ``phi_total`` reached ``phi_cut`` (s); NaN unless armed.
    t_end, phi_total_end : float
        Time (s) and cumulative wheel angle (rad) where the run stopped.
    maxima : dict
        Largest contact forces (lbf): ``F23``, ``F12``, ``PN`` in coupled motion and
        ``FF23``, ``FF12`` in free motion (impact forces excluded).
    trajectory : numpy.ndarray or None
        Rows of :data:`escfit.verge.integrator.COLUMNS` (None when not recorded).
    impacts : numpy.ndarray
        One row per impact, columns :data:`IMPACT_FIELDS`.
    phases : list of tuple
        ``(t_start, t_end, regime, side, reason)`` for every phase.
    reversals : int
        Number of times the gear train changed direction (at impacts or through zero speed).
    """

    status: str
    reason: str
    message: str
    time_to_arm: float
    t_end: float
    phi_total_end: float
    maxima: dict
    trajectory: np.ndarray | None
    impacts: np.ndarray
    phases: list = field(default_factory=list)
    reversals: int = 0


def side_change(k: Constants, side: float, y: np.ndarray, off: float) -> tuple[float, float]:
    """Re-reference ``y`` in place for the other face; returns ``(new_side, new_off)``."""
    if side > 0:
        shift = k.nt * k.pitch
        y[2] += 2 * math.pi - k.lam
    else:
        shift = -(k.nt + 1.0) * k.pitch
        y[2] -= 2 * math.pi - k.lam
    y[0] += shift
    return -side, off - shift


def impact_decision(k: Constants, side: float, y: np.ndarray) -> tuple[int, bool, float]:
    """Decide what a contact found in free motion leads to; applies any impact to ``y``.

    Returns
    -------
    regime : int
        ``COUPLED`` or ``FREE`` for the next phase.
    impacted : bool
        Whether an impact took place (speeds in ``y`` changed).
    closing : float
        Normal closing speed of the contact before it (in/s, > 0 when approaching).
    """
    alpha = side_alpha(k, side)
    vs, vp, _aa, _ad = normal_speeds(k, alpha, y[0], y[2], y[1], y[3])
    closing = side * (vs - vp)
    if closing < 0.0:
        # the bodies already separate (the contact was found a rounding error late)
        return FREE, False, closing
    if closing == 0.0:
        # grazing contact: the tooth settles on the face without an impulse
        return COUPLED, False, closing
    phid_f, psid_f = impact_map(k, alpha, y[0], y[2], y[1], y[3], k.erest)
    y[1], y[3] = phid_f, psid_f
    vs_f, vp_f, _aa, _ad = normal_speeds(k, alpha, y[0], y[2], phid_f, psid_f)
    if abs(vp_f - vs_f) < k.capture_speed:
        return COUPLED, True, closing
    return FREE, True, closing


def _kinematic_verge(k: Constants, side: float, y: np.ndarray) -> bool:
    psi, g, u, *_ = coupled_kinematics(k.a, k.b, k.c, side_alpha(k, side), y[0])
    if not math.isfinite(psi):
        return False
    y[2], y[3] = psi, u * y[1]
    return True


def run_rk4(
    k: Constants,
    *,
    phi_start: float,
    step: float = DEFAULT_STEP,
    t_max: float,
    record: bool = True,
    max_phases: int = 200_000,
    max_mode_changes: int = 100_000,
) -> RunResult:
    """Simulate from rest on the entrance face with the compiled fixed-step RK4 integrator.

    Parameters
    ----------
    k : Constants
        Mechanism and operating point (report units).
    phi_start : float
        Escape-wheel angle at the start, on the entrance face (rad); ``phi_total = 0`` there.
    step : float
        RK4 step as an angle of fuze spin (rad); the time step is ``step / omega``.
    t_max : float
        Time limit (s).
    record : bool
        Keep the trajectory (False is faster and is what the fitting code uses).
    max_phases : int
        Limit on the number of motion phases (a guard against endless regime switching).
    max_mode_changes : int
        Limit on friction-sign changes within one phase.
    """
    h = step / k.omega

    def phase(regime, side, y, t, off, m, armed, buf, n, mx):
        while True:
            code, t, n, armed = integrate_phase(k, regime, side, y, t, off, m, armed, h, t_max, buf, n, record, mx,
                                                max_mode_changes)
            if code != R_BUFFER:
                return code, t, n, armed, buf
            buf = np.concatenate([buf, np.empty((buf.shape[0], N_COLS))])

    cap = max(4096, int(min(t_max / h, 2e6) * 1.05) + 1024) if record else 1
    return run_hybrid(k, phase, phi_start=phi_start, t_max=t_max, record=record, max_phases=max_phases,
                      capacity=cap)


def run_hybrid(k: Constants, phase, *, phi_start: float, t_max: float, record: bool, max_phases: int,
               capacity: int) -> RunResult:
    """The regime automaton, driving any phase integrator.

    ``phase(regime, side, y, t, off, m, armed, buf, n, mx)`` must advance one phase in
    place and return ``(reason_code, t, n, armed, buf)`` like
    :func:`escfit.verge.integrator.integrate_phase`.
    """
    y = np.array([phi_start, 0.0, 0.0, 0.0])
    off = -phi_start
    side, regime, t = 1.0, COUPLED, 0.0
    if not _kinematic_verge(k, side, y):
        return _finish(_FAILED, "bad_state", "the tooth cannot touch the entrance face at phi_start", k, t, y, off,
                       None, 0, [], [], np.zeros(6), 0)
    buf = np.empty((capacity, N_COLS))
    n = 0
    mx = np.zeros(6)
    impacts: list[tuple] = []
    phases: list[tuple] = []
    direction = 1.0
    idle = 0
    reversals = 0
    armed_gap = False
    while True:
        if len(phases) >= max_phases:
            return _finish("not_armed", "phase_limit", f"stopped after {max_phases} motion phases", k, t, y, off,
                           buf[:n] if record else None, n, impacts, phases, mx, reversals)
        m = initial_mode(k, regime, side, y, off, direction)
        if regime == FREE:
            armed_gap = False
        t0 = t
        code, t, n, armed_gap, buf = phase(regime, side, y, t, off, m, armed_gap, buf, n, mx)
        direction = m[M_DIR]
        phases.append((t0, t, regime, side, REASONS[code]))
        idle = idle + 1 if t == t0 else 0
        trace = buf[:n] if record else None
        if idle > 50:
            return _finish(_FAILED, "chatter", "regime switching without progress in time (chattering contact)",
                           k, t, y, off, trace, n, impacts, phases, mx, reversals)
        if code == R_ARMED:
            return _finish("armed", "armed", "the escape wheel reached the cut-off angle", k, t, y, off, trace, n,
                           impacts, phases, mx, reversals)
        if code == R_STALL:
            return _finish("not_armed", "stalled",
                           "friction holds the mechanism at rest: the driving torque cannot overcome it", k, t, y,
                           off, trace, n, impacts, phases, mx, reversals)
        if code == R_TMAX:
            return _finish("not_armed", "time_limit", f"not armed within the time limit of {t_max:.6g} s", k, t, y,
                           off, trace, n, impacts, phases, mx, reversals)
        if code in (R_BAD, R_CHATTER):
            what = ("the state left the model's domain (no contact geometry or non-finite values)"
                    if code == R_BAD else "too many friction-sign changes in one phase (chattering)")
            return _finish(_FAILED, REASONS[code], what, k, t, y, off, trace, n, impacts, phases, mx, reversals)
        if code == R_TIP:
            side, off = side_change(k, side, y, off)
            regime = FREE
        elif code == R_SEPARATION:
            regime = FREE
        elif code == R_MISS:
            side, off = side_change(k, side, y, off)
            regime = FREE
        elif code == R_CONTACT:
            before = (y[1], y[3])
            regime, impacted, closing = impact_decision(k, side, y)
            if impacted:
                impacts.append((t, side, y[0], y[2], before[0], before[1], y[1], y[3], closing))
                if before[0] * y[1] < 0.0:
                    reversals += 1
            if regime == COUPLED and not _kinematic_verge(k, side, y):
                return _finish(_FAILED, "bad_state", "contact found where the coupled kinematics has no solution",
                               k, t, y, off, trace, n, impacts, phases, mx, reversals)


def _finish(status, reason, message, k, t, y, off, trace, n, impacts, phases, mx, reversals) -> RunResult:
    maxima = {"F23": mx[0], "F12": mx[1], "PN": mx[2], "FF23": mx[3], "FF12": mx[4]}
    reversals += int(mx[5])
    imp = np.array(impacts, dtype=float).reshape(-1, len(IMPACT_FIELDS))
    return RunResult(
        status=status, reason=reason, message=message,
        time_to_arm=t if status == "armed" else math.nan,
        t_end=t, phi_total_end=y[0] + off, maxima=maxima,
        trajectory=None if trace is None else trace.copy(), impacts=imp, phases=phases, reversals=reversals,
    )
