"""What the data do and do not determine: correlations, sloppy directions, profiles.

Two cases matter for balance-wheel curves.  With phase switching (Monday's convention) a
single unit curve is geometric and fixes only ``C/omega0`` and his combined ``K``; Coulomb
``R`` and the escapement magnitudes trade off exactly along ``K = const``.  With angle
switching the impulse gain per swing falls like 1/A while the Coulomb loss is constant and
the viscous loss grows like A, so a decay from overbank fixes C, R and X separately.
"""

from __future__ import annotations

import math

import numpy as np

from ..charts import Pulse, k_value
from .lsq import least_squares
from .problem import FitProblem

__all__ = ["correlation_warnings", "sloppy_directions", "ridge_warnings", "phase_mode_warning", "monday_k", "profile"]


def correlation_warnings(names: list[str], corr: np.ndarray, threshold: float = 0.95) -> list[str]:
    """Messages for parameter pairs whose |correlation| exceeds ``threshold``."""
    out = []
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            r = corr[i, j]
            if np.isfinite(r) and abs(r) > threshold:
                out.append(f"{names[i]} and {names[j]} are correlated (r = {r:+.3f}): the data determine a combination "
                           "of them better than either alone")
    return out


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


def phase_mode_warning(problem: FitProblem) -> list[str]:
    """The structural non-identifiability of Monday's phase convention, when it applies."""
    if problem.scene.switching != "phase" or len(problem.curves) > 1:
        return []
    free = set(problem.names)
    forcing = {n for n in free if n == "coulomb.R" or (n.startswith("escapement[") and n.endswith(".X"))}
    if len(forcing) < 2:
        return []
    return ["phase switching: a single unit curve is exactly geometric and determines only C/omega0 and Monday's "
            f"combined K; {', '.join(sorted(forcing))} trade off exactly along K = const (see the K posterior)"]


def monday_k(problem: FitProblem, vals: dict) -> float:
    """Monday's combined K of a parameter set (phase convention, symmetric windows only)."""
    sys = problem.scene.system(vals)
    w0sq = sys.omega0**2
    pulses = [Pulse(-math.pi / 2, math.pi / 2, -sys.r / w0sq)]
    pulses += [Pulse(lo, hi, x / w0sq) for lo, hi, x, d in zip(sys.w_lo, sys.w_hi, sys.w_x, sys.w_dir) if d == 0]
    return k_value(sys.c / sys.omega0, pulses)


def profile(problem: FitProblem, name: str, grid, *, n_starts: int = 3, seed: int = 0) -> dict:
    """Profile likelihood of ``name``: best chi-square over the other parameters at each grid value.

    Returns a dict with ``grid``, ``chisqr`` and ``delta`` (chi-square above its minimum;
    values below 3.84 form an approximate 95 % interval).
    """
    grid = np.asarray(grid, float)
    chi = np.array([least_squares(problem, n_starts=n_starts, seed=seed, fixed={name: float(g)}).chisqr for g in grid])
    return {"name": name, "grid": grid, "chisqr": chi, "delta": chi - chi.min()}
