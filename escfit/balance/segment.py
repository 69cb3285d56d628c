"""Closed-form motion inside one segment of constant coefficients.

Inside a segment the swing-frame coordinate ``x`` obeys::

    x'' + C x' + w2 (x - xc) = 0

so ``y = x - xc`` is a damped oscillation (or an over-/critically damped creep) about the
shifted centre ``xc``.  With ``h = C/2`` the state after a time ``tau`` is::

    y(tau) = Ec y0 + Es (v0 + h y0)
    v(tau) = Ec v0 - Es (h v0 + w2 y0)

where ``Ec = exp(-h tau) c(tau)`` and ``Es = exp(-h tau) s(tau)`` with ``c, s`` =
``cos(wd tau), sin(wd tau)/wd`` (underdamped), ``1, tau`` (critical) or
``cosh(k tau), sinh(k tau)/k`` (overdamped).  The forms are written so that none of them
cancels catastrophically near critical damping or overflows for strong overdamping.

All functions are numba-compiled and also run as plain Python with NUMBA_DISABLE_JIT=1.
"""

from __future__ import annotations

import math

from ..core.kernels import kernel

__all__ = ["propagate", "turn_time", "cross_time", "CREEP_OVERSHOOT", "creep_horizon", "creeps_to_rest"]

#: A turning point whose overshoot past the segment's rest position is below this fraction of the
#: motion's size is not a swing: the balance has crept to rest (see :func:`creeps_to_rest`).
CREEP_OVERSHOOT = 1e-9


@kernel(inline="always")
def creeps_to_rest(overshoot, motion, scale):
    """Whether a turning point ends the motion: the one status rule of every solver.

    A turn whose overshoot past its segment's rest position is below :data:`CREEP_OVERSHOOT`
    of the motion is not a swing but a creep to rest (status ``stopped``).  The motion is
    the larger of its size in the segment, ``sqrt(y0**2 + v0**2 / w2)`` at the segment's
    start (a damping ratio above about 0.989 gives such a turn: the next swing would be a
    billionth of this one, and near critical damping the "turn" comes thousands of seconds
    later), and the run's scale, the release's offset from its rest position: a swing
    decayed below a billionth of the release (a damping ratio of 0.95 gets there in a few
    half swings) is rest too.  Measured against the run's scale, the rule asks of a solver
    only an accuracy of about 1e-12 of the release, which dop853 and rk4 deliver; against
    the local motion alone it asked for accuracy far below their absolute tolerances, and
    the exact solver went on to swings of 1e-26 of the release where they had stopped.

    Parameters
    ----------
    overshoot, motion, scale : float
        In rad: the turn's offset from the rest position, the motion in the segment and the
        run's scale.
    """
    return abs(overshoot) <= CREEP_OVERSHOOT * max(motion, scale)


@kernel(inline="always")
def creep_horizon(c, w2):
    """Time (s) after which a segment without an event is a creep to rest.

    64 undamped half periods plus 64 viscous time constants ``c/w2``: any turning point later
    than this overshoots its rest position by less than :data:`CREEP_OVERSHOOT` of the motion.
    """
    return 64.0 * (math.pi / math.sqrt(w2) + c / w2)


@kernel(inline="always")
def _ec_es(tau, h, w2):
    d = w2 - h * h
    if d > 0.0:
        wd = math.sqrt(d)
        e = math.exp(-h * tau)
        return e * math.cos(wd * tau), e * math.sin(wd * tau) / wd
    if d == 0.0:
        e = math.exp(-h * tau)
        return e, e * tau
    k = math.sqrt(-d)
    kt = k * tau
    if kt < 1.0:
        e = math.exp(-h * tau)
        return e * math.cosh(kt), e * math.sinh(kt) / k
    a = math.exp((k - h) * tau)
    b = math.exp(-(k + h) * tau)
    return 0.5 * (a + b), 0.5 * (a - b) / k


@kernel
def propagate(y0, v0, tau, h, w2):
    """State ``(y, v)`` a time ``tau`` >= 0 after ``(y0, v0)``.

    Parameters
    ----------
    y0, v0 : float
        Offset from the segment centre (rad) and velocity (rad/s) at the segment start.
    tau : float
        Elapsed time in the segment (s), finite.
    h : float
        Half the viscous coefficient, C/2 (1/s), >= 0.
    w2 : float
        Stiffness per inertia, omega0**2 (1/s^2), > 0.
    """
    ec, es = _ec_es(tau, h, w2)
    return ec * y0 + es * (v0 + h * y0), ec * v0 - es * (h * v0 + w2 * y0)


@kernel
def turn_time(y0, v0, h, w2):
    """First time ``tau > 0`` at which the velocity returns to zero, or ``inf``.

    Assumes the motion starts forward: ``v0 > 0``, or ``v0 == 0`` with ``y0 < 0``
    (the centre lies ahead, so the acceleration is positive).
    """
    q = h * v0 + w2 * y0
    d = w2 - h * h
    if d > 0.0:
        wd = math.sqrt(d)
        return math.atan2(v0 * wd, q) / wd
    if d == 0.0:
        if q > 0.0 and v0 > 0.0:
            return v0 / q
        return math.inf
    k = math.sqrt(-d)
    if q > 0.0 and v0 > 0.0:
        r = k * v0 / q
        if r < 1.0:
            return math.atanh(r) / k
    return math.inf


@kernel
def cross_time(y0, v0, h, w2, target, tau_hi):
    """Time at which ``y`` rises to ``target`` on ``[0, tau_hi]``, and the velocity then.

    ``y`` increases monotonically there (the velocity is positive before the turning
    point), ``y0 < target`` and ``y(tau_hi) >= target``; ``tau_hi`` may be ``inf`` when
    the motion creeps towards a centre beyond ``target`` (overdamped), in which case a
    bracket is found by doubling.  Halley steps on the closed form (the ODE gives the
    second derivative for free), safeguarded by bisection, converge to a few ulps of the
    crossing time.

    Returns
    -------
    tau, v : float
        Crossing time (s) and the velocity there (rad/s), evaluated at that same ``tau``.
    """
    lo = 0.0
    hi = tau_hi
    if not math.isfinite(hi):
        hi = 1.0 / (h + math.sqrt(w2))
        for _ in range(4000):
            y, v = propagate(y0, v0, hi, h, w2)
            if y >= target:
                break
            lo = hi
            hi *= 2.0
    tau = 0.5 * (lo + hi)
    if v0 > 0.0:
        guess = (target - y0) / v0
        if lo < guess < hi:
            tau = guess
    y, v = propagate(y0, v0, tau, h, w2)
    # y is computed to about an ulp of the offsets involved: below that f is rounding noise
    noise = 4.5e-16 * (abs(y0) + abs(target))
    step_before = hi - lo  # safeguard as in Numerical Recipes' rtsafe: bisect when the
    step_last = hi - lo    # step does not at least halve every second iteration
    for _ in range(400):
        f = y - target
        if f == 0.0:
            return tau, v
        if f > 0.0:
            hi = tau
        else:
            lo = tau
        new = 0.5 * (lo + hi)
        if v > 0.0:
            step = f / v
            # A correction below rounding means the iteration has converged; testing this
            # before the bracket matters, because ``tau - step`` then rounds back onto the
            # bracket end just set and would otherwise start a run of bisections.
            if abs(step) <= 4e-16 * tau or abs(f) <= noise:
                return tau, v
            if lo < tau - step < hi and abs(step) <= 0.5 * abs(step_before):
                # Halley refines a Newton step that stays in the bracket (y'' comes free from
                # the equation of motion); where the velocity has decayed to nothing its
                # damping would crawl, which the bracket test excludes
                acc = -2.0 * h * v - w2 * y
                denom = 1.0 - 0.5 * step * acc / v
                new = tau - (step / denom if denom > 0.5 else step)
                if not (lo < new < hi):
                    new = tau - step
        step_before, step_last = step_last, abs(new - tau)
        tau = new
        y, v = propagate(y0, v0, tau, h, w2)
        if hi - lo <= 4e-16 * hi:
            break
    return tau, v
