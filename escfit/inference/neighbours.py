"""Other least-squares optima near the best one, found by refits from the intervals' ends.

The stored intervals come from the cost's curvature at the best fit (the delta method).  Where
the cost has a second local minimum a few standard errors away that is nearly as low, a
parameter's 95 % range reaches it and those intervals miss it.  One real case: a Pohl wheel
read at every turning point comes to rest within the record; above the best C the model's last
small swings pass the scale's displaced zero, where an amplitude reading folds, and a second
optimum 2.5 standard errors up in C and 3.2 down in R costs only 0.1 more in chi-square
(``notebooks/04_lmfit.py``).  The ranked multistart, whose starts are spread over the whole
prior range, did not find it; refits from 2.5 standard errors out fell back to the best fit,
from 3 they reached it.

:func:`nearby_optima` looks at the cost along each parameter's profile direction (its
covariance column: the way the other parameters follow it to first order) at 2, 3 and 4
standard errors on either side, one model run each.  Where the cost rose by less than half of
what the curvature at the best fit predicts, a refit starts from there; an end more than
:data:`APART` standard errors from the best in some parameter is another optimum, reported when
its cost is within the 95 % level of one parameter's profile.  An end with a lower cost is a
better optimum the multistart missed; the caller adopts it.  The scan costs ``6 k`` model runs
(``k`` free parameters) and a refit only where the cost dips; it runs for the final stage of a
least-squares fit of up to :data:`MAX_READINGS` readings.  A sampler (``--method emcee``)
explores the whole posterior in any case.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Nearby", "look_nearby", "nearby_optima", "nearby_warning", "SCAN", "DIP", "APART", "MAX_READINGS", "LEVEL_95"]

#: where along a profile direction the cost is looked at, in standard errors
SCAN = (2.0, 3.0, 4.0)
#: a refit starts where the cost rose by less than this fraction of the curvature's prediction
DIP = 0.5
#: how far from the best fit an end must lie to be another optimum, in standard errors
APART = 1.5
#: the largest fit (readings) checked
MAX_READINGS = 1000
#: chi-square quantile of one degree of freedom at 95 % (the profile interval's rise)
LEVEL_95 = 3.841458820694124


@dataclass(frozen=True)
class Nearby:
    """An optimum found by a refit from the best fit's interval end.

    Attributes
    ----------
    x : ndarray
        Its parameters (the fit's units).
    rise : float
        Its cost above the best fit's (negative: a better optimum), in the fit's cost units.
    apart : ndarray
        ``|x - best| / stderr`` of every parameter.
    optimum : object
        The optimiser's result there (an :class:`~escfit.inference.trf.Optimum`).
    """

    x: np.ndarray
    rise: float
    apart: np.ndarray
    optimum: object


def nearby_optima(refit, cost, best, cov: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                  scale: float = 1.0) -> list[Nearby]:
    """Optima reached by refits from ``best.x`` moved along each profile direction.

    Along parameter ``i``'s profile direction the cost rises by ``s**2 * scale`` at ``s``
    standard errors where the model is linear.  The cost is looked at :data:`SCAN` standard
    errors out on either side (one model run each); a refit starts only where the cost rose by
    less than :data:`DIP` of that (another well, or a flat floor), from the point that rose least.

    Parameters
    ----------
    refit
        ``refit(x0) -> Optimum``: the fit's own least squares from ``x0`` (same residual, bounds
        and options).
    cost
        ``cost(x) -> float``: the fit's cost (sum of squared residuals) at ``x``.
    best
        The best fit's :class:`~escfit.inference.trf.Optimum`.
    cov
        Its covariance (the fit's units; NaN where undetermined: no check then).
    lo, hi
        The bounds.
    scale
        The covariance's scale (the reduced chi-square when the noise scale is profiled, else 1).

    Returns
    -------
    list of Nearby
        Distinct ends more than :data:`APART` standard errors from the best, lowest cost first.
    """
    se = np.sqrt(np.diag(cov)) if cov.size else np.zeros(0)
    if not (se.size and np.all(np.isfinite(cov)) and np.all(se > 0)):
        return []
    found: list[Nearby] = []
    for i in range(se.size):
        step = cov[:, i] / se[i]  # one standard error of parameter i, the others following it
        for sign in (-1.0, 1.0):
            ratio, start = min(((cost(x) - best.chisqr) / (s * s * scale), tuple(x)) for s in SCAN
                               for x in [np.clip(best.x + sign * s * step, lo, hi)])
            if not ratio < DIP:
                continue
            try:
                end = refit(np.array(start))
            except (ValueError, FloatingPointError):
                continue
            apart = np.abs(end.x - best.x) / se
            if apart.max() <= APART or any(np.max(np.abs(end.x - f.x) / se) <= APART for f in found):
                continue
            found.append(Nearby(end.x.copy(), float(end.chisqr - best.chisqr), apart, end))
    return sorted(found, key=lambda f: f.rise)


def nearby_warning(nearby: Nearby, names: list[str], level: float) -> str | None:
    """The warning for another optimum within ``level`` (the cost's 95 % rise), else ``None``."""
    if not nearby.rise <= level:
        return None
    moved = [j for j in range(len(names)) if nearby.apart[j] > APART]
    where = ", ".join(f"{names[j]} = {nearby.x[j]:.4g}" for j in moved)
    away = " and ".join(f"{nearby.apart[j]:.1f}" for j in moved)
    return (f"least squares found a second optimum nearly as good as the best: {where} ({away} standard errors "
            f"from the best fit), its chi-square only {nearby.rise:.3g} higher where a 95 % interval allows "
            f"{level:.3g}; the intervals describe the best optimum's neighbourhood and miss the other; the "
            "posterior (--method emcee) covers both")


def look_nearby(refit, cost, best, cov: np.ndarray, bounds, scale: float, names: list[str]):
    """The best fit after looking for another optimum near it, what that says, and where it is.

    Returns ``(best, warnings, other)``: ``best`` unchanged with a warning naming another optimum
    within the 95 % level (``LEVEL_95 * scale``) and ``other`` its values of the parameters that
    moved (by name, the fit's units), or a better optimum the multistart missed, adopted, with a
    warning and ``other`` empty; see :func:`nearby_optima` for the arguments.
    """
    found = nearby_optima(refit, cost, best, cov, *bounds, scale)
    if found and found[0].rise < -1e-9 * best.chisqr:
        return found[0].optimum, [
            f"a refit from the first optimum's interval end found a lower one ({-found[0].rise:.3g} less in "
            "chi-square), which is the result: the multistart missed it, so others may exist; --method emcee "
            "explores the whole posterior"], {}
    said = [w for f in found[:1] if (w := nearby_warning(f, names, LEVEL_95 * scale))]
    other = {names[j]: float(found[0].x[j]) for j in range(len(names)) if found[0].apart[j] > APART} if said else {}
    return best, said, other
