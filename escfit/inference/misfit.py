"""Misfit diagnostics: structure in the residuals that the noise model does not explain.

A fit can converge and still be wrong.  Three patterns show up on real recordings, each with
a physical reading:

- **alternating branches**: turning points on the two sides of the swing sit on two
  separate residual curves.  The centre of oscillation is offset from the scale's zero, or
  moves during the record (a drifting centre opens or closes the branches).
- **runs**: residuals keep one sign for many readings in a row (a Wald-Wolfowitz runs test
  on the signs).  The model misses a systematic trend: a wrong damping law, a missing
  effect, a misnumbered swing.
- **correlated neighbours**: lag-1 autocorrelation of the residuals in reading order.  The
  noise is not independent (smoothing in the sensor, a tracker following the wrong point)
  or the model misses structure; intervals computed as if it were white are too narrow.

Each check returns plain sentences for the results' ``warnings`` and numbers for the
``misfit`` attributes.  Thresholds are chosen for a false alarm well below 1 % on white noise.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["misfit_report"]

BRANCH_Z = 4.0  # |mean difference| / standard error above which two branches are flagged
RUNS_Z = -4.0  # runs-test z below which runs are flagged (too few runs)
LAG1_MAX = 0.5  # lag-1 autocorrelation above which neighbours are flagged
MIN_READINGS = 8


def _branches(r: np.ndarray, swing: np.ndarray, unit: str) -> tuple[dict, list[str]]:
    even, odd = r[swing % 2 == 0], r[swing % 2 == 1]
    if even.size < 3 or odd.size < 3:
        return {}, []
    diff = float(np.mean(even) - np.mean(odd))
    se = math.sqrt(np.var(even, ddof=1) / even.size + np.var(odd, ddof=1) / odd.size)
    z = diff / se if se > 0 else (math.inf if diff else 0.0)
    scatter = float(np.std(np.concatenate([even - np.mean(even), odd - np.mean(odd)]), ddof=2))
    info = {"branch_difference": diff, "branch_z": z, "branch_scatter": scatter}
    if abs(z) < BRANCH_Z:
        return info, []
    ratio = abs(diff) / scatter if scatter > 0 else math.inf
    return info, [f"residuals of even and odd half swings form two branches {abs(diff):.3g} {unit} apart ({ratio:.1f} "
                  "times the scatter about each): the centre of oscillation is offset from the scale's zero or drifts; "
                  "free observation.offset (and observation.offset_rate for a drift)"]


def _runs(r: np.ndarray) -> tuple[dict, list[str]]:
    s = np.sign(r[r != 0])
    n_pos, n_neg = int(np.sum(s > 0)), int(np.sum(s < 0))
    n = n_pos + n_neg
    if n_pos < 2 or n_neg < 2:
        return {"runs": 1, "runs_expected": math.nan, "runs_z": -math.inf}, [
            f"all {n} residuals but {min(n_pos, n_neg)} have one sign: the model misses the data systematically"]
    runs = 1 + int(np.count_nonzero(s[1:] != s[:-1]))
    mean = 1.0 + 2.0 * n_pos * n_neg / n
    var = (mean - 1.0) * (mean - 2.0) / (n - 1.0)
    z = (runs - mean) / math.sqrt(var) if var > 0 else 0.0
    info = {"runs": runs, "runs_expected": mean, "runs_z": z}
    if z >= RUNS_Z:
        return info, []
    return info, [f"residuals come in long runs of one sign ({runs} runs where {mean:.0f} are expected from independent "
                  "noise): the model misses a systematic trend (damping law, a missing effect, or swings compared "
                  "with the wrong model swing)"]


def _lag1(r: np.ndarray, innovations: bool) -> tuple[dict, list[str]]:
    x = r - np.mean(r)
    den = float(x @ x)
    rho = float(x[1:] @ x[:-1]) / den if den > 0 else 0.0
    info = {"lag1_autocorrelation": rho}
    if rho <= LAG1_MAX:
        return info, []
    if innovations:
        return info, [f"the correlated-noise model leaves its innovations correlated too (lag-1 {rho:.2f}): the "
                      "residuals are structure the model misses, not noise of the AR(1) kind"]
    return info, [f"neighbouring residuals are correlated (lag-1 autocorrelation {rho:.2f}): the reading noise is not "
                  "independent or the model misses structure; intervals computed for independent noise are too narrow "
                  "([observation] noise = \"ar1\" models correlated noise in waveform fits)"]


def misfit_report(residual: np.ndarray, swing: np.ndarray | None, curve: np.ndarray | None, *, unit: str = "rad",
                  branches: bool = True, innovations: bool = False) -> tuple[dict, list[str]]:
    """Check residuals (observed minus expected, in reading order) for structure.

    Parameters
    ----------
    residual
        Observed minus expected reading of every data point.
    swing
        Half-swing number of each reading (for the branch check), or ``None``.
    curve
        Curve label of each reading: each curve is checked on its own (``None``: one curve).
    unit
        Unit of the residuals, for the messages.
    branches
        Whether readings alternate sides (turning points); off for waveform samples.
    innovations
        The residuals are the innovations of a correlated-noise model (AR(1)), not readings.

    Returns
    -------
    (dict, list of str)
        Figures by name (per curve when there are several: ``"<label>: <name>"``) and warnings.
    """
    r = np.asarray(residual, float)
    labels = np.zeros(r.size, dtype=object) if curve is None else np.asarray(curve, dtype=object)
    figures: dict = {}
    warnings: list[str] = []
    several = len(set(labels.tolist())) > 1
    for label in dict.fromkeys(labels.tolist()):
        rows = np.flatnonzero(labels == label)
        rr = r[rows]
        ok = np.isfinite(rr)
        if np.count_nonzero(ok) < MIN_READINGS:
            continue
        rr = rr[ok]
        checks = [_runs(rr), _lag1(rr, innovations)]
        if branches and swing is not None:
            checks.insert(0, _branches(rr, np.asarray(swing)[rows][ok], unit))
        prefix = f"{label}: " if several else ""
        for info, msgs in checks:
            figures.update({prefix + k: v for k, v in info.items()})
            warnings += [prefix + m for m in msgs]
    return figures, warnings
