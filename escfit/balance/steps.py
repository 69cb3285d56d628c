"""One step of the integrators, as pure functions of the state: DOP853 and classical RK4.

A step of length ``h`` from the state ``(x, v)`` (swing frame, rad and rad/s) in a region with
constants ``regime = (w2, xc, k)`` (see :mod:`escfit.balance.acceleration`) is a smooth map of ``h``:
the solvers locate events by iterating on it, and the dense solutions of the integrating solvers
(:mod:`escfit.balance.solution`) evaluate the motion between two stored states by a step of the
partial length, which carries the integrator's own accuracy there.
"""

from __future__ import annotations

import numpy as np

from ..core.kernels import kernel
from .acceleration import acceleration
from .dop853_tables import tables as _coefficients

__all__ = ["dop853_step", "dop853_extension", "extension_stages", "stage", "extension_column", "extension_value",
           "extension_at", "rk4_step", "N_STAGES", "N_EXTENDED", "stage_arrays"]

N_STAGES = _coefficients.N_STAGES  # 12 stages, plus the first-same-as-last evaluation at the step end
N_EXTENDED = _coefficients.N_STAGES_EXTENDED  # and three more for the continuous extension
A_EXTENDED = np.ascontiguousarray(_coefficients.A)  # every stage's row, the extension's three included
_B = np.ascontiguousarray(_coefficients.B)
_D = np.ascontiguousarray(_coefficients.D)


def stage_arrays() -> tuple[np.ndarray, np.ndarray]:
    """Scratch arrays for the DOP853 stages of ``x`` and ``v``."""
    return np.empty(N_STAGES + 1), np.empty(N_STAGES + 1)


@kernel
def dop853_step(state, h, regime, stages):
    """One DOP853 step (scipy's coefficient tables) of length ``h`` (s).

    Parameters
    ----------
    state : tuple
        ``(x, v, a)``: angle, velocity and acceleration at the step start (swing frame).
    regime : tuple
        ``(w2, xc, k)``: the region's stiffness and centre and the coefficient record.
    stages : tuple
        ``(kx, kv)``: arrays of length ``N_STAGES + 1`` that receive the stages (the error
        estimate reads them).

    Returns
    -------
    x, v, a : float
        State and acceleration at the step end.
    """
    x, v, a = state
    w2, xc, k = regime
    kx, kv = stages
    kx[0] = v
    kv[0] = a
    for i in range(1, N_STAGES):
        stage(i, state, h, regime, stages)
    sx = 0.0
    sv = 0.0
    for j in range(N_STAGES):
        sx += _B[j] * kx[j]
        sv += _B[j] * kv[j]
    x1 = x + h * sx
    v1 = v + h * sv
    a1 = acceleration(x1, v1, w2, xc, k)
    kx[N_STAGES] = v1
    kv[N_STAGES] = a1
    return x1, v1, a1


@kernel
def dop853_extension(state, h, regime, stages, coef):
    """The step of length ``h`` and its continuous extension: the state anywhere inside the step.

    DOP853's dense output (Hairer, Norsett and Wanner, *Solving Ordinary Differential Equations I*,
    section II.6; the coefficients are scipy's): three more stages after the step give a
    polynomial of degree 7 in ``r = u/h`` that matches the state and its derivative at both ends
    and carries the step's order of accuracy inside it, read by :func:`extension_at`.

    Parameters
    ----------
    state, h, regime
        As :func:`dop853_step`.
    stages : tuple
        ``(kx, kv)`` of length :data:`N_EXTENDED` at least.
    coef : ndarray, shape (7, 2)
        Receives the polynomial's coefficients for ``x`` (column 0) and ``v`` (column 1).
    """
    x, v, _ = state
    kx, kv = stages
    x1, v1, _ = dop853_step(state, h, regime, stages)
    extension_stages(state, h, regime, stages)
    extension_column(coef, 0, x1 - x, kx, h)
    extension_column(coef, 1, v1 - v, kv, h)


@kernel
def extension_stages(state, h, regime, stages):
    """The continuous extension's three extra stages, after :func:`dop853_step` filled ``stages``."""
    for i in range(N_STAGES + 1, N_EXTENDED):
        stage(i, state, h, regime, stages)


@kernel(inline="always")
def stage(i, state, h, regime, stages):
    """Stage ``i`` of a step from ``state``, from the stages before it: its state
    ``(x + h sum_j A_ij kx_j, v + h sum_j A_ij kv_j)`` and the field there, into ``stages``.
    Returns the stage's state ``(x, v)``."""
    x, v, _ = state
    w2, xc, k = regime
    kx, kv = stages
    dx = 0.0
    dv = 0.0
    for j in range(i):
        dx += A_EXTENDED[i, j] * kx[j]
        dv += A_EXTENDED[i, j] * kv[j]
    xs = x + h * dx
    vs = v + h * dv
    kx[i] = vs
    kv[i] = acceleration(xs, vs, w2, xc, k)
    return xs, vs


@kernel(inline="always")
def extension_column(coef, col, d, ks, h):
    """Column ``col`` of the continuous extension from the step's change ``d`` and stages ``ks``."""
    coef[0, col] = d
    coef[1, col] = h * ks[0] - d
    coef[2, col] = 2.0 * d - h * (ks[N_STAGES] + ks[0])
    for r in range(4):
        acc = 0.0
        for j in range(N_EXTENDED):
            acc += _D[r, j] * ks[j]
        coef[3 + r, col] = h * acc


@kernel(inline="always")
def extension_value(coef, col, y0, r):
    """Component ``col`` of the state at the fraction ``r`` (0 to 1) of a step from its value
    ``y0`` there, by the continuous extension's coefficients ``coef`` (column ``col``)."""
    p = coef[5, col] + r * coef[6, col]
    p = coef[4, col] + (1.0 - r) * p
    p = coef[3, col] + r * p
    p = coef[2, col] + (1.0 - r) * p
    p = coef[1, col] + r * p
    p = coef[0, col] + (1.0 - r) * p
    return y0 + r * p


@kernel(inline="always")
def extension_at(coef, x, v, r):
    """State ``(x, v)`` at the fraction ``r`` (0 to 1) of a step from ``(x, v)``, by the continuous
    extension ``coef`` of :func:`dop853_extension`."""
    return extension_value(coef, 0, x, r), extension_value(coef, 1, v, r)


@kernel(inline="always")
def rk4_step(x, v, dt, regime):
    """One classical Runge-Kutta step of length ``dt`` (s) from ``(x, v)``; ``regime = (w2, xc, k)``."""
    w2, xc, k = regime
    k1x = v
    k1v = acceleration(x, v, w2, xc, k)
    x2 = x + 0.5 * dt * k1x
    v2 = v + 0.5 * dt * k1v
    k2x = v2
    k2v = acceleration(x2, v2, w2, xc, k)
    x3 = x + 0.5 * dt * k2x
    v3 = v + 0.5 * dt * k2v
    k3x = v3
    k3v = acceleration(x3, v3, w2, xc, k)
    x4 = x + dt * k3x
    v4 = v + dt * k3v
    k4x = v4
    k4v = acceleration(x4, v4, w2, xc, k)
    return (x + dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x),
            v + dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v))
