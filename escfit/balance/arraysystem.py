"""Many parameter sets assembled in one pass: the scene's effects applied to arrays.

:meth:`BalanceScene.system` builds one :class:`~escfit.balance.effects.base.SystemBuilder`
from a mapping of parameter values.  Every effect's ``apply`` is plain arithmetic on those
values, so handing it arrays (one entry per parameter set) builds all sets at once; this
module lays the result out as the :class:`~escfit.balance.batch.SystemStack` the batch
kernels take.  A sampler asks for 16-32 sets per call, thousands of times: one array pass
replaces as many Python builds and the per-set stacking.

The numbers are those of building each set alone (the same operations on the same values,
elementwise); ``tests/test_batch.py`` checks the posterior against the one-at-a-time path.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from .batch import SystemStack
from .solvers import check_capability

__all__ = ["stack_from_values"]


def _column(x, n: int) -> np.ndarray:
    """``x`` (a number or an array of ``n``) as a float array of shape (n,)."""
    if isinstance(x, np.ndarray) and x.shape == (n,) and x.dtype == np.float64:
        return x
    if np.ndim(x) == 0:
        return np.full(n, float(x))
    return np.array(np.broadcast_to(np.asarray(x, float), (n,)))


def _spring_offsets(bp: np.ndarray, w2: np.ndarray) -> np.ndarray:
    """Offsets of a continuous piecewise-linear restoring torque, for many sets.

    ``w2`` has shape (n, pieces); as :meth:`SystemBuilder.spring_arrays`, row by row.
    """
    off = np.zeros_like(w2)
    zero_piece = int(np.searchsorted(bp, 0.0, side="right"))
    for i in range(zero_piece + 1, w2.shape[1]):  # pieces above zero
        b = bp[i - 1]
        off[:, i] = (w2[:, i - 1] * b + off[:, i - 1]) - w2[:, i] * b
    for i in range(zero_piece - 1, -1, -1):  # pieces below zero
        b = bp[i]
        off[:, i] = (w2[:, i + 1] * b + off[:, i + 1]) - w2[:, i] * b
    return off


def stack_from_values(scene, values: Mapping[str, float | np.ndarray], n: int) -> SystemStack:
    """The systems of ``n`` parameter sets, built in one pass.

    Parameters
    ----------
    scene
        A :class:`~escfit.balance.scene.BalanceScene` with a spring (the exact kernels).
    values
        Every parameter by name (ties resolved), each a number shared by all sets or an
        array of shape (n,).
    n
        Number of sets.

    Raises
    ------
    SolverError
        For a pendulum scene (the exact kernels handle a spring only).
    """
    sys = scene.system(values)
    check_capability("exact", "angle", sys.restoring)
    if sys.spring_w2:
        bp = np.asarray(sys.spring_breaks, float)
        w2 = np.stack([_column(w, n) for w in sys.spring_w2], axis=1)
        off = _spring_offsets(bp, w2)
    else:
        bp = np.zeros(0)
        w2 = (_column(sys.omega0, n) ** 2)[:, None]
        off = np.zeros((n, 1))
    windows = len(sys.w_lo)
    w_x = np.stack([_column(x, n) for x in sys.w_x], axis=1) if windows else np.zeros((n, 0))
    return SystemStack(_column(sys.theta0, n), _column(sys.c, n), _column(sys.r, n), _column(sys.restitution, n),
                       _column(sys.omega0, n), w2, off, w_x, bp, np.asarray(sys.w_lo, float),
                       np.asarray(sys.w_hi, float), np.asarray(sys.w_dir, np.int64), float(sys.bank),
                       np.asarray(sys.drift_thresholds, float), np.asarray(sys.drift_rates, float))
