"""Forward-difference Jacobians whose model runs are one batch call.

scipy's trust-region method differentiates the residuals by forward differences ("2-point"),
one model run per parameter, each a separate Python call.  A problem that evaluates many
parameter sets in one compiled call (``residuals_many``, e.g. the waveform problem with the
exact or dop853 solver) can run all of them at once; :func:`forward_steps` takes the steps the
way scipy's "2-point" rule is documented, so the Jacobian, and with it the fit, is the one
``jac="2-point"`` gives:

* the step of parameter ``i`` is ``h_i = r * s_i * max(1, |x_i|)`` with ``r = sqrt(eps)`` of
  float64 and ``s_i = +1`` for ``x_i >= 0``, ``-1`` otherwise (or, with a relative step ``r``
  given, ``r * s_i * |x_i|``, falling back to the default where that step vanishes);
* a step that would leave the bounds is taken in the other direction when that one stays
  inside; when neither does, it goes towards the farther bound, as far as that bound;
* the divisor is the step actually taken, ``(x_i + h_i) - x_i``, exactly representable.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

__all__ = ["forward_steps", "batch_jacobian"]

#: the relative step of a forward difference: the square root of float64's machine epsilon
REL_STEP = float(np.sqrt(np.finfo(float).eps))


def forward_steps(x: np.ndarray, lower: np.ndarray, upper: np.ndarray, rel_step: float | None = None) -> np.ndarray:
    """Forward-difference step of each parameter (its unit), kept inside the bounds.

    Parameters
    ----------
    x
        The point differentiated at (inside ``lower <= x <= upper``).
    lower, upper
        Bounds (``-inf``/``inf`` when open).
    rel_step
        Relative step (scipy's ``diff_step``); ``None``: ``sqrt(eps)`` times ``max(1, |x|)``.

    Returns
    -------
    ndarray
        Signed steps ``h``; ``x + h`` stays inside the bounds.
    """
    x, lower, upper = (np.asarray(a, float) for a in (x, lower, upper))
    sign = np.where(x >= 0, 1.0, -1.0)
    default = REL_STEP * sign * np.maximum(1.0, np.abs(x))
    if rel_step is None:
        h = default
    else:
        h = rel_step * sign * np.abs(x)
        h = np.where((x + h) - x == 0, default, h)
    to_lower, to_upper = x - lower, upper - x
    outside = (x + h < lower) | (x + h > upper)
    reversible = np.abs(h) <= np.maximum(to_lower, to_upper)
    h = np.where(outside & reversible, -h, h)
    # neither direction fits (a range narrower than the step): as far as the farther bound
    h = np.where(~reversible & (to_upper >= to_lower), to_upper, h)
    return np.where(~reversible & (to_upper < to_lower), -to_lower, h)


def batch_jacobian(residual_rows: Callable[[np.ndarray], np.ndarray], x: np.ndarray, lower: np.ndarray,
                   upper: np.ndarray, *, f0: np.ndarray | None = None, rel_step: float | None = None) -> np.ndarray:
    """Forward-difference Jacobian of a residual vector, every point evaluated in one call.

    Parameters
    ----------
    residual_rows
        Maps points, shape (m, k), to their residual vectors, shape (m, n).
    x
        Where to differentiate, shape (k,).
    lower, upper
        Bounds of ``x``.
    f0
        The residuals at ``x`` if already known (then only the ``k`` stepped points are evaluated).
    rel_step
        As in :func:`forward_steps`.

    Returns
    -------
    ndarray, shape (n, k)
        ``J[:, i] = (f(x + dx_i e_i) - f(x)) / dx_i`` with ``dx_i`` the step actually taken.
    """
    x = np.asarray(x, float)
    h = forward_steps(x, lower, upper, rel_step)
    points = np.repeat(x[None, :], x.size, axis=0)
    points[np.diag_indices(x.size)] += h
    dx = np.diag(points) - x  # the step each point really takes (representable)
    if f0 is None:
        rows = residual_rows(np.vstack([x[None, :], points]))
        f0, stepped = rows[0], rows[1:]
    else:
        stepped = residual_rows(points)
    return ((stepped - np.asarray(f0, float)[None, :]) / dx[:, None]).T
