"""What the data do and do not determine: correlations, ridges, parameters on a bound, profiles.

These checks read only a fit's numbers (names, correlations, draws), so they serve every
model family; a family adds its own structural checks through
:meth:`~escfit.likelihood.problem.Problem.checks_at_best_fit`.
"""

from __future__ import annotations

import math

import numpy as np

from ..likelihood.problem import Problem
from ..core.names import scene_key
from .lsq import LeastSquaresResult, least_squares

__all__ = ["correlation_warnings", "sloppy_directions", "ridge_warnings", "bound_warnings", "profile"]


def correlation_warnings(names: list[str], corr: np.ndarray, threshold: float = 0.95) -> list[str]:
    """Messages for parameter pairs whose |correlation| exceeds ``threshold``.

    One message per pair for up to two pairs; beyond that one message listing them all (the
    corner plot shows them; six near-identical sentences hide the other warnings).
    """
    pairs = []
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            r = corr[i, j]
            if np.isfinite(r) and abs(r) > threshold:
                pairs.append((names[i], names[j], float(r)))
    if len(pairs) <= 2:
        return [f"{a} and {b} are correlated (r = {r:+.3f}): the data determine a combination of them better than "
                "either alone" for a, b, r in pairs]
    listed = ", ".join(f"{a} with {b} ({r:+.3f})" for a, b, r in pairs)
    return [f"{len(pairs)} parameter pairs are correlated beyond |r| = {threshold:g}: {listed}; the data determine "
            "combinations of them better than the parameters alone"]


def sloppy_directions(names: list[str], samples: np.ndarray, ratio: float = 30.0) -> list[str]:
    """Report a posterior ridge: a combination far better determined than the parameters.

    ``samples`` has shape (n, ndim).  Each parameter is standardised (in log scale when it is
    positive); if the smallest principal spread is ``ratio`` times below the largest, the
    parameters move together along the largest direction and the data fix mainly the
    combination along the smallest one.
    """
    x = np.asarray(samples, float)
    if x.shape[1] < 2:
        return []
    z = np.where(np.all(x > 0, axis=0), np.log(np.abs(x) + 1e-300), x)
    z = (z - z.mean(axis=0)) / (z.std(axis=0) + 1e-300)
    return ridge_warnings(names, np.cov(z.T), ratio, "posterior")


def ridge_warnings(names: list[str], corr: np.ndarray, ratio: float = 30.0, what: str = "least-squares fit") -> list[str]:
    """The ridge test of :func:`sloppy_directions` on a correlation matrix of the parameters.

    Standardising (and taking logs, to first order) leaves correlations unchanged, so the
    least-squares correlation matrix gives the same principal spreads as posterior samples.
    """
    c = np.asarray(corr, float)
    if c.shape[0] < 2 or not np.all(np.isfinite(c)):
        return []
    w, v = np.linalg.eigh(0.5 * (c + c.T))
    w = np.maximum(w, 1e-300)
    spread = math.sqrt(w[-1] / w[0])
    if spread < ratio:
        return []

    def combo(vec):
        return " ".join(f"{c:+.2f}*{n}" for c, n in zip(vec, names) if abs(c) > 0.2)

    return [f"the {what} is a ridge (principal spreads differ {spread:.0f}-fold): the parameters move together along "
            f"[{combo(v[:, -1])}] while the data fix mainly [{combo(v[:, 0])}] (standardised, log scale for positive "
            "parameters)"]


def bound_warnings(problem: Problem | None, lsq: LeastSquaresResult) -> list[str]:
    """One warning per parameter whose best fit sits on a bound of the scene's range.

    Reads the flags least squares stored (:attr:`LeastSquaresResult.at_bound`, see
    :func:`~escfit.inference.lsq.bound_flags`), so the warnings, the stored ``at_bound``
    variable and the one-sided intervals always agree.  ``problem`` is not needed (kept for
    callers that pass it).
    """
    out = []
    for i, name in enumerate(lsq.names):
        flag = int(lsq.at_bound[i])
        if flag == 0:
            continue
        edge = float(lsq.lower[i] if flag < 0 else lsq.upper[i])
        which = "lower" if flag < 0 else "upper"
        lo95, hi95 = float(lsq.intervals["lo95"][i]), float(lsq.intervals["hi95"][i])
        side = f"[{edge:g}, {hi95:.4g}]" if flag < 0 else f"[{lo95:.4g}, {edge:g}]"
        one_sided = f"; its least-squares interval is one-sided, 95 % {side}"
        if flag < 0 and edge == 0.0:
            why = ": the data find no evidence for it (an upper limit is what they give)"
        else:
            why = f": the data want it beyond the scene's range; {widen_edit(name, lsq, i, flag)}, or check the units"
        out.append(f"{name} ends on its {which} bound {edge:g}{why}{one_sided}")
    return out


def widen_edit(name: str, lsq: LeastSquaresResult, i: int, flag: int) -> str:
    """The scene line that widens parameter ``i``'s range past the bound it ended on.

    The range is doubled on that side (by its own width; a bound at zero on the upper side is
    not crossed into negative values), written as a free parameter table at the parameter's key,
    which the scene may not contain yet (the release angle and instant are set from the record
    when it does not).  Values are in the results' units (rad, s, 1/s ...), as the scene reads
    bare numbers.
    """
    lo, hi, value = float(lsq.lower[i]), float(lsq.upper[i]), float(lsq.value[i])
    width = hi - lo if math.isfinite(hi - lo) and hi > lo else max(abs(value), 1.0)
    if flag < 0:
        lo = lo - width if lo < 0 or lo - width >= 0 else 0.0
    else:
        hi = hi + width
    return (f"widen the range: set {scene_key(name)} = {{ value = {value:.6g}, vary = true, min = {lo:.6g}, "
            f"max = {hi:.6g} }} in the scene")


def profile(problem: Problem, name: str, grid, *, n_starts: int = 3, seed: int = 0) -> dict:
    """Profile likelihood of ``name``: best chi-square over the other parameters at each grid value.

    Returns a dict with ``grid``, ``chisqr`` and ``delta`` (chi-square above its minimum;
    values below 3.84 form an approximate 95 % interval).
    """
    grid = np.asarray(grid, float)
    chi = np.array([least_squares(problem, n_starts=n_starts, seed=seed, fixed={name: float(g)}).chisqr for g in grid])
    return {"name": name, "grid": grid, "chisqr": chi, "delta": chi - chi.min()}
