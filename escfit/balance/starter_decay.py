"""Starting values and upper bounds of C and R that ``escfit init`` writes, from a record's amplitudes.

A start is not a fit: it puts the optimiser near the answer and the bounds around it.  Each
of C and R alone would explain the whole decay with a value the record gives in closed form
(``c_all``, ``r_all``); the bounds are :data:`BOUND_FACTOR` times those, and the starts split
the decay between them by the map of one half swing to the next that a linear oscillator with
viscous damping and Coulomb friction obeys exactly (:func:`_half_swing_map`).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["decay_estimates", "BOUND_FACTOR"]

BOUND_FACTOR = 3.0  # upper bounds of C and R: this many times the value that alone explains the decay


def decay_estimates(amplitudes: np.ndarray, omega0: float, times: np.ndarray | None = None) -> dict[str, float]:
    """Starts and upper bounds of C (1/s) and R (rad/s^2) from successive half-swing amplitudes.

    Parameters
    ----------
    amplitudes
        Amplitude of successive half swings about the centre (rad), the release first.
    omega0
        Natural frequency, rad/s.
    times
        Their times (s); ``None``: half a period apart.

    Returns
    -------
    dict
        ``C``, ``C_max``, ``R``, ``R_max`` (see the module docstring) and ``decays`` (whether the
        record shows a decay at all).
    """
    a = np.abs(np.asarray(amplitudes, float))
    half = math.pi / omega0
    if a.size < 2 or not (a[0] > a[-1] > 0):
        # no decay to measure: bounds wide enough for a light one
        return {"C": 1e-3 * omega0, "C_max": 0.05 * omega0, "R": 0.0, "R_max": 0.05 * omega0 ** 2 * float(a.max(initial=1)),
                "decays": False}
    n = a.size - 1
    span = float(times[-1] - times[0]) if times is not None and times[-1] > times[0] else n * half
    c_all = 2.0 * math.log(a[0] / a[-1]) / span
    r_all = omega0 ** 2 * (a[0] - a[-1]) / (2.0 * n)
    c0, r0 = 0.5 * c_all, 0.5 * r_all
    if n >= 3:
        slope, intercept = _half_swing_map(a)
        if 0.0 < slope < 1.0:
            wd = math.sqrt(max(omega0 ** 2 - (c_all / 2) ** 2, 0.25 * omega0 ** 2))
            c0 = -2.0 * wd * math.log(slope) / math.pi
            r0 = -intercept * omega0 ** 2 / (1.0 + slope)
    # keep the starts inside the bounds and off zero (a start on a bound stalls some optimisers)
    c0 = min(max(c0, 0.05 * c_all), c_all)
    r0 = min(max(r0, 0.05 * r_all), r_all)
    return {"C": c0, "C_max": BOUND_FACTOR * c_all, "R": r0, "R_max": BOUND_FACTOR * r_all, "decays": True}


def _half_swing_map(a: np.ndarray) -> tuple[float, float]:
    """``(q, i)`` of the map ``a_(k+1) = q a_k + i`` that the amplitudes ``a`` follow best.

    A linear oscillator with viscous damping and Coulomb friction obeys that map exactly, so its
    amplitudes are ``a_k = A q^k + B`` with ``i = B (1 - q)``: fitted to the amplitudes
    themselves (for each ``q`` the best ``A`` and ``B`` by linear least squares, ``q`` by a
    bounded search), not by regressing each amplitude on the one before, where the reading noise
    of both sides biases the slope and so the split between C and R.
    """
    from scipy.optimize import minimize_scalar

    k = np.arange(a.size, dtype=float)

    def misfit(q: float) -> tuple[float, np.ndarray]:
        design = np.stack([q ** k, np.ones_like(k)], axis=1)
        coef, *_ = np.linalg.lstsq(design, a, rcond=None)
        r = a - design @ coef
        return float(r @ r), coef

    best = minimize_scalar(lambda q: misfit(q)[0], bounds=(1e-3, 1.0 - 1e-9), method="bounded",
                           options={"xatol": 1e-10})
    q = float(best.x)
    return q, float(misfit(q)[1][1]) * (1.0 - q)
