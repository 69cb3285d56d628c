"""Independent references for the balance effects' tests: a scipy solve_ivp integration.

The whole balance-frame equation is written out here, apart from escfit's solvers::

    theta'' = -C theta' - omega0**2 (theta + k3 theta**3) - D |theta'| theta' - R sgn(theta')

and integrated with scipy's DOP853 (rtol 1e-13) from turning point to turning point; at each
turning point the static rule decides whether the balance moves on (it stays at rest while
``omega0**2 |theta + k3 theta**3| <= R_static``).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

import escfit

from .conftest import balance_toml


def reference_turns(w0, theta0, n, *, C=0.0, R=0.0, R_static=None, D=0.0, k3=0.0):
    """Signed turning points and their times by solve_ivp; stops where static friction holds."""
    r_static = R if R_static is None else R_static
    turns, times = [], []
    th, t = theta0, 0.0
    for _ in range(n):
        if w0**2 * abs(th + k3 * th**3) <= r_static:
            break
        s = -math.copysign(1.0, th + k3 * th**3)  # moves towards the restoring torque

        def rhs(_t, y, s=s):
            return [y[1], -C * y[1] - w0**2 * (y[0] + k3 * y[0] ** 3) - D * abs(y[1]) * y[1] - R * s]

        def turn(_t, y):
            return y[1]

        turn.terminal, turn.direction = True, -s
        sol = solve_ivp(rhs, (0.0, 100.0 / w0), [th, 0.0], method="DOP853", rtol=1e-13, atol=1e-15,
                        events=turn)
        assert sol.t_events[0].size, "no turning point"
        th, t = float(sol.y_events[0][0][0]), t + float(sol.t_events[0][0])
        turns.append(th)
        times.append(t)
    return np.array(turns), np.array(times)


def scene(w0=10.0, theta0=2.0, swings=12, **effects):
    """A scene with the named effects (``C``, ``R``, ``R_static``, ``k3``, ``D``; canonical units)."""
    eff = ""
    if "C" in effects:
        eff += f"[effects.viscous]\nC = {effects['C']!r}\n"
    if "R" in effects:
        eff += f"[effects.coulomb]\nR = {effects['R']!r}\n"
        if "R_static" in effects:
            eff += f"R_static = {effects['R_static']!r}\n"
    if "k3" in effects:
        eff += f"[effects.stiffening]\nk3 = {effects['k3']!r}\n"
    if "D" in effects:
        eff += f"[effects.drag]\nD = {effects['D']!r}\n"
    return escfit.load_scene("effects.toml", text=balance_toml(omega0=w0, theta0=theta0, swings=swings, effects=eff))
