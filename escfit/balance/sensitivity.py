"""Forward sensitivities of the DOP853 motion: d theta(t) / d p for every parameter in one run.

A least-squares fit needs the model's derivative by each parameter at every sample.  Forward
differences run the model once per parameter, and an integrator error ``e`` puts an error of
about ``e / 1.5e-8`` into each column, which keeps the integrator's tolerance far tighter than
the readings' noise needs (:mod:`escfit.balance.problems.tolerance`).  Here the derivatives come
from the variational equation, integrated along the run's own steps.

**The equations.**  Inside a region of a half swing the swing-frame state ``(x, v)`` obeys
``x' = v``, ``v' = a(x, v; k)`` (:func:`escfit.balance.acceleration.acceleration`).  Its
sensitivity ``S = (Sx, Sv) = d(x, v)/dp`` at fixed time obeys::

    Sx' = Sv
    Sv' = a_x Sx + a_v Sv + a_p

with ``a_x``, ``a_v`` the partial derivatives (the restoring torque's and each smooth effect's)
and ``a_p = sum over record fields f of (da/df)(df/dp)``: the record's tangent ``dk = dk/dp``
(:func:`record_tangents`) enters as ``-dC v - dw2 g(x) - dR - s d(offset)`` plus the smooth
terms evaluated on ``dk`` -- each smooth effect's torque is linear in its own record fields
(the conformance suite, ``tests/test_conformance.py``, checks that contract for every smooth effect).

**The steps.**  The primal run (:func:`escfit.balance.batch_dop853.dense_run`) keeps every
accepted step as a dense row.  The tangents are carried through those rows by the same DOP853
step applied to the augmented system: for an explicit Runge-Kutta step of fixed length the
derivative of the step map is that step applied to the variational equation, so the tangents are
the derivatives of the computed motion, to the integrator's own accuracy, at whatever tolerance.
The samples inside a row are read from the step's continuous extension, of the augmented system
here as the dense solution's is of the motion (:func:`escfit.balance.steps.dop853_extension`).

**The turning points.**  At a turning point the velocity passes through zero and sliding Coulomb
friction changes sign: the acceleration jumps from ``a-`` to ``a+``.  The turn's time depends on
the parameters (``dtau/dp = -Sv / a-``), and the fixed-time sensitivity jumps by
``(f- - f+) dtau/dp`` (the saltation rule for a state-dependent switch), which in the new half
swing's frame (``x -> -x``) reads::

    Sx+ = -Sx-        Sv+ = (a+ / a-) Sv-

A balance that static friction holds at a turning point has ``a+ = 0``: the velocity's
sensitivity vanishes there and the angle's stays.  The sensitivity of the turn's time itself is
thereby exact: nothing of the Newton iteration that located it is differentiated.

**What is covered.**  Scenes without escapement windows, hairspring break angles, banking pins
or damping drift (:func:`covers`): their only switches are turning points.  A run ending in a
creep to rest is not covered either.  The caller falls back to forward differences for those
(``usable`` 0).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.kernels import kernel
from ..core.status import Status
from .acceleration import acceleration, smooth_terms
from .batch_dop853 import DOP853_SAMPLING, dense_run
from .dop853_tables import tables as _coefficients
from .steps import (A_EXTENDED, N_EXTENDED, N_STAGES, dop853_step, extension_column, extension_stages,
                    extension_value)
from .system import System

__all__ = ["covers", "record_tangents", "sample_sensitivities"]

_B = np.ascontiguousarray(_coefficients.B)
_OK, _STOPPED, _REFUSED = int(Status.OK), int(Status.STOPPED), int(Status.REFUSED)
_SWING = 8  # the dense row's column holding its half swing (escfit.balance.solution)


def covers(system: System) -> bool:
    """Whether every parameter set's only switches are turning points (see the module docstring)."""
    k = system.k
    return bool(np.all(k["n_windows"] == 0) and np.all(k["n_pieces"] == 1) and np.all(np.isinf(k["bank"]))
                and np.all(k["drift_rate"] == 0.0))


def record_tangents(records_at, vals: dict, names: list[str], steps: np.ndarray) -> np.ndarray:
    """The coefficient record's derivative by each parameter, by central differences of its assembly.

    Assembling a record is arithmetic on the parameters (no model run); its fields are mostly
    linear in them (C, R, drag D, the release angle), for which the central difference is exact
    to rounding, and otherwise smooth (``omega0**2``, ``k3 omega0**2``: an error of order
    ``step**2``, about 1e-10 relative with the steps used).

    Parameters
    ----------
    records_at
        ``records_at(values, n) -> System``: the scene's assembly (``BalanceScene.system``).
    vals
        Every parameter's value (a complete mapping).
    names
        The parameters to differentiate by.
    steps
        Each one's step (its unit; > 0).

    Returns
    -------
    ndarray of the coefficient record's dtype, shape (len(names),)
        Field ``f`` of entry ``j`` is ``df/d names[j]``; fields that do not change are 0.
    """
    m = len(names)
    batch = {key: np.full(2 * m, float(v)) for key, v in vals.items()}
    for j, name in enumerate(names):
        batch[name][2 * j] += steps[j]
        batch[name][2 * j + 1] -= steps[j]
    k = records_at(batch, 2 * m).k
    out = np.zeros(m, k.dtype)
    for field in k.dtype.names:
        if k.dtype[field].base.kind != "f":
            continue
        hi, lo = k[field][0::2], k[field][1::2]
        shape = (m,) + (1,) * (hi.ndim - 1)
        with np.errstate(invalid="ignore"):
            d = (hi - lo) / (2.0 * np.asarray(steps, float).reshape(shape))
        out[field] = np.where(hi == lo, 0.0, d)
    return out


@kernel(inline="always")
def _partials(x, v, w2, k):
    """``(a_x, a_v)``: the swing-frame acceleration's derivatives by angle (1/s^2) and velocity (1/s)."""
    a_x = -w2 * (math.cos(x) if k.pendulum else 1.0)
    a_v = -k.c
    if k.smooth:
        _, s_x, s_v = smooth_terms(x, v, k)
        a_x += s_x
        a_v += s_v
    return a_x, a_v


@kernel(inline="always")
def _by_record(x, v, s, k, dk):
    """The acceleration's derivative along the record tangent ``dk`` (rad/s^2 per the parameter's unit)."""
    g = math.sin(x) if k.pendulum else x
    da = -dk.c * v - dk.sp_w2[0] * g - dk.r - s * dk.sp_off[0]
    if k.smooth:
        d_smooth, _, _ = smooth_terms(x, v, dk)
        da += d_smooth
    return da


@kernel(inline="always")
def _stage_angle(i, x, h, kx):
    """The angle at stage ``i`` of a step from ``x``: ``x + h sum_j A_ij kx_j`` (its velocity is
    the stage ``kx_i`` itself)."""
    dx = 0.0
    for j in range(i):
        dx += A_EXTENDED[i, j] * kx[j]
    return x + h * dx if i > 0 else x


@kernel(inline="always")
def _tangent_stage(i, xs, vs, h, tangent, regime, stages):
    """Stage ``i`` of every tangent, at the state's stage ``(xs, vs)``, from the tangents' earlier
    stages ``stages = (tx, tv)`` (written into them)."""
    w2, _, s, k, dks = regime
    tx, tv = stages
    a_x, a_v = _partials(xs, vs, w2, k)
    for p in range(tangent.shape[0]):
        sx = 0.0
        sv = 0.0
        for j in range(i):
            sx += A_EXTENDED[i, j] * tx[p, j]
            sv += A_EXTENDED[i, j] * tv[p, j]
        sx = tangent[p, 0] + h * sx
        sv = tangent[p, 1] + h * sv
        tx[p, i] = sv
        tv[p, i] = a_x * sx + a_v * sv + _by_record(xs, vs, s, k, dks[p])


@kernel
def _tangent_step(state, tangent, h, regime, work):
    """One DOP853 step of length ``h`` (s) of the state and its tangents.

    The state's step is :func:`~escfit.balance.steps.dop853_step` itself (the same numbers as the
    run's); the tangents' stages are evaluated at its stages' states.

    Parameters
    ----------
    state : tuple
        ``(x, v, a)`` at the step start (swing frame).
    tangent : ndarray, shape (m, 2)
        ``(Sx, Sv)`` of each parameter at the step start.
    regime : tuple
        ``(w2, xc, s, k, dks)``: the region, the direction, the record and its tangents.
    work : tuple
        ``(kx, kv, tx, tv, out)``: stage arrays (``N_STAGES + 1``; tangents ``(m, N_STAGES + 1)``)
        and the tangents at the step end, shape (m, 2), written here.

    Returns
    -------
    x, v, a : float
        State and acceleration at the step end.
    """
    x, v, _ = state
    w2, xc, _, k, _ = regime
    kx, kv, tx, tv, out = work
    x1, v1, a1 = dop853_step(state, h, (w2, xc, k), (kx, kv))  # the primal step, its stages kept
    m = tangent.shape[0]
    for i in range(N_STAGES):
        _tangent_stage(i, _stage_angle(i, x, h, kx), kx[i] if i > 0 else v, h, tangent, regime, (tx, tv))
    for p in range(m):
        sx = 0.0
        sv = 0.0
        for j in range(N_STAGES):
            sx += _B[j] * tx[p, j]
            sv += _B[j] * tv[p, j]
        out[p, 0] = tangent[p, 0] + h * sx
        out[p, 1] = tangent[p, 1] + h * sv
    return x1, v1, a1


@kernel
def _tangent_extension(state, tangent, h, regime, work, coef, tcoef):
    """The step of the state and its tangents, and the continuous extension of both.

    As :func:`~escfit.balance.steps.dop853_extension` for the state: ``coef`` (7, 2) receives the
    state's polynomial, ``tcoef`` (7, m, 2) each tangent's, from the same three extra stages of the
    augmented system (``work``'s stage arrays of length :data:`~escfit.balance.steps.N_EXTENDED`).
    """
    x, v, _ = state
    w2, xc, _, k, _ = regime
    kx, kv, tx, tv, out = work
    m = tangent.shape[0]
    x1, v1, _ = _tangent_step(state, tangent, h, regime, work)
    # the last stage is the derivative at the step end (the stage weights of row 12 are the step's)
    _tangent_stage(N_STAGES, x1, v1, h, tangent, regime, (tx, tv))
    extension_stages(state, h, (w2, xc, k), (kx, kv))
    for i in range(N_STAGES + 1, N_EXTENDED):
        _tangent_stage(i, _stage_angle(i, x, h, kx), kx[i], h, tangent, regime, (tx, tv))
    extension_column(coef, 0, x1 - x, kx, h)
    extension_column(coef, 1, v1 - v, kv, h)
    for p in range(m):
        extension_column(tcoef[:, p, :], 0, out[p, 0] - tangent[p, 0], tx[p], h)
        extension_column(tcoef[:, p, :], 1, out[p, 1] - tangent[p, 1], tv[p], h)
    return x1, v1


@kernel
def _sensitivities(k, dks, spec, t, out, tangents):
    """Run one set (:func:`escfit.balance.batch_dop853.dense_run`) and carry its tangents.

    ``out`` (3, times): theta (rad), omega (rad/s), theta'' (rad/s^2) at each time; ``tangents``
    (2, m, times): d theta / dp and d omega / dp.  Returns the run's status, or -1 when the run
    is not covered (a creep to rest, a grazing turn, times beyond a run that did not stop).
    """
    ran, res, rows, reached = dense_run(k, spec, t)
    if not ran:
        return _REFUSED
    status = res.status
    if not (status == _STOPPED or (status == _OK and reached)):
        return status
    m = dks.shape[0]
    work = (np.empty(N_EXTENDED), np.empty(N_EXTENDED), np.empty((m, N_EXTENDED)), np.empty((m, N_EXTENDED)),
            np.empty((m, 2)))
    coef = np.empty((7, 2))
    tcoef = np.empty((7, m, 2))
    tangent = np.zeros((m, 2))
    s0 = rows[0, 2] if rows.shape[0] > 0 else 1.0
    for p in range(m):  # the release: theta0 and v0 are record fields too
        tangent[p, 0] = s0 * dks[p].theta0
        tangent[p, 1] = s0 * dks[p].v0
    n_rows = rows.shape[0]
    n_t = t.shape[0]
    q = 0
    for i in range(n_rows):
        s = rows[i, 2]
        state = (rows[i, 3], rows[i, 4], rows[i, 7])
        regime = (rows[i, 6], rows[i, 5], s, k, dks)
        end = rows[i, 0] + rows[i, 1]
        last = i + 1 == n_rows
        extended = False
        x_end = v_end = 0.0
        while q < n_t and (t[q] < rows[i + 1, 0] if not last else t[q] <= end):
            if not extended:  # the step's continuous extension serves every time inside it
                x_end, v_end = _tangent_extension(state, tangent, rows[i, 1], regime, work, coef, tcoef)
                extended = True
            r = min(max((t[q] - rows[i, 0]) / rows[i, 1], 0.0), 1.0) if rows[i, 1] > 0.0 else 0.0
            x = extension_value(coef, 0, state[0], r)
            v = extension_value(coef, 1, state[1], r)
            out[0, q] = s * x
            out[1, q] = s * v
            out[2, q] = s * acceleration(x, v, rows[i, 6], rows[i, 5], k)
            for p in range(m):
                tangents[0, p, q] = s * extension_value(tcoef[:, p, :], 0, tangent[p, 0], r)
                tangents[1, p, q] = s * extension_value(tcoef[:, p, :], 1, tangent[p, 1], r)
            q += 1
        if last and q == n_t:
            break
        if extended:  # the step to the row's end is the one the extension made
            x, v = x_end, v_end
            a = acceleration(x, v, rows[i, 6], rows[i, 5], k)
        else:
            x, v, a = _tangent_step(state, tangent, rows[i, 1], regime, work)
        step_end = work[4]
        if not last and rows[i + 1, _SWING] == rows[i, _SWING]:
            tangent[:, :] = step_end  # the next step of the same region starts where this one ended
            continue
        # a turning point: the next row starts the next half swing, or the run stopped there
        if not a < 0.0:
            return -1  # a graze: the turn's time is not a smooth function of the parameters
        if not last:
            a_next = rows[i + 1, 7]
            for p in range(m):
                tangent[p, 0] = -step_end[p, 0]
                tangent[p, 1] = a_next / a * step_end[p, 1]
            continue
        if status != _STOPPED or abs(res.theta - s * x) > 1e-9 * (abs(x) + 1e-3):
            return -1  # stopped by a creep to rest, or samples beyond a run that did not stop
        while q < n_t:  # held by static friction at this turning point
            out[0, q] = res.theta
            out[1, q] = 0.0
            out[2, q] = 0.0
            for p in range(m):
                tangents[0, p, q] = s * step_end[p, 0]
                tangents[1, p, q] = 0.0
            q += 1
    if q < n_t:
        return -1
    return status


@kernel
def _sensitivities_one(ks, dks, spec, t, out, tangents):
    """:func:`_sensitivities` on ``ks[0]`` (the front end's single call)."""
    return _sensitivities(ks[0], dks, spec[0], t, out, tangents)


def sample_sensitivities(system: System, times: np.ndarray, tangents: np.ndarray, *, rtol: float = 1e-10,
                         atol: float | None = None, max_segments: int | None = None, max_steps: int | None = None,
                         max_swings: int = 10_000_000) -> tuple[np.ndarray | None, np.ndarray | None, int]:
    """The motion and its parameter sensitivities at ``times`` (s since the release), by solver dop853.

    Parameters
    ----------
    system
        One parameter set (a scene's assembly), covered by :func:`covers`.
    times
        Sample times (s since the release, ascending, the first >= 0).
    tangents
        The record's derivative by each parameter (:func:`record_tangents`).
    rtol, atol, max_segments, max_steps, max_swings
        The dop853 run's options, as :func:`~escfit.balance.batch_dop853.sample_batch_dop853`
        takes them: the run is that of the waveform's samples, step for step.

    Returns
    -------
    motion : ndarray, shape (3, times), or None
        theta (rad), theta' (rad/s) and theta'' (rad/s^2).
    sensitivity : ndarray, shape (2, parameters, times), or None
        d theta / dp and d theta' / dp (per the parameter's unit).
    status : int
        The run's :class:`~escfit.core.status.Status` code; -1: the run is not covered (both
        arrays None then, as for a status other than ok or stopped).
    """
    times = np.ascontiguousarray(times, float)
    spec = np.zeros(1, DOP853_SAMPLING)
    spec[0] = (0, int(max_segments or 0), int(max_steps or 0), int(max_swings), float(rtol),
               math.nan if atol is None else float(atol))
    m = tangents.shape[0]
    motion = np.full((3, times.size), np.nan)
    sens = np.full((2, m, times.size), np.nan)
    status = int(_sensitivities_one(system.k, np.ascontiguousarray(tangents), spec, times, motion, sens))
    if status not in (_OK, _STOPPED):
        return None, None, status
    return motion, sens, status
