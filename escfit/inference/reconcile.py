"""A best fit checked against what the recording measures directly, and what the fit determines.

Least squares finds *an* optimum.  When the recording measures a parameter outright (a
sampled decay's period fixes omega0, :meth:`Problem.consistency`), a fit that disagrees with
that measurement is not a best fit of the oscillator that was recorded, however small its
residuals: the first optimum may be a secondary minimum, or the readings may not fix the
parameter at all (turning-point amplitudes never fix omega0).  :func:`reconcile` then

- moves a parameter the problem *holds* (an omega0 taken from the period) to the value the
  model's own period implies and refits (exact for turning-point amplitudes, whose fit is the
  same at any omega0 once C and R scale with it): a new problem holding the new value
  (:meth:`Problem.holding`), returned with the fit, since a problem is never changed once built;
- refits a *free* one from the measured value, and keeps the refit when it agrees;
- otherwise reports the disagreement as unresolved.

:func:`verdict` then says what the fit determines: every structural parameter, some of them
(others have no standard error: a singular curvature), or nothing (no structural parameter
has one, or the fit contradicts the measurement), in one sentence that names what to fix.
The command line exits with status 3 when nothing is determined.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from ..likelihood.consistency import Implied
from .lsq import LeastSquaresResult, least_squares, profiled_scale
from .trf import minimize

__all__ = ["reconcile", "Reconciled", "with_held_uncertainty", "verdict", "NOT_DETERMINED", "PARTLY", "DETERMINED"]

DETERMINED, PARTLY, NOT_DETERMINED = "determined", "partly determined", "not determined"
ROUNDS = 4
HELD_RTOL = 1e-4  # a held parameter is moved until the model's measurement matches the record's this closely


class Reconciled(NamedTuple):
    """What :func:`reconcile` returns.

    Attributes
    ----------
    lsq : LeastSquaresResult
        The fit to report (the refit when one was made and kept).
    notes : list of str
        What was done, as sentences.
    unresolved : list of Implied
        Measurements the reported fit still contradicts.
    problem : Problem
        The problem that fit belongs to: the one given, or a copy holding a held parameter at
        its new value.
    """

    lsq: LeastSquaresResult
    notes: list
    unresolved: list
    problem: Any


def _start(lsq: LeastSquaresResult) -> dict[str, float]:
    return {n: float(lsq.values[n]) for n in lsq.names}


def reconcile(problem, lsq: LeastSquaresResult, *, seed: int = 0, priors_count: bool = False,
              optimizer=minimize) -> Reconciled:
    """Check ``lsq`` against the recording's direct measurements; refit where that settles it.

    Refits run ``optimizer`` from one start (see :func:`~escfit.inference.lsq.least_squares`).
    ``problem`` is not changed: a held parameter moved is held by a copy, returned as
    :attr:`Reconciled.problem` with the fit.
    """
    consistency = getattr(problem, "consistency", None)
    if consistency is None:
        return Reconciled(lsq, [], [], problem)
    notes: list[str] = []
    held = tuple(getattr(problem, "held", ()))
    for _ in range(ROUNDS):
        # a held parameter follows the measurement exactly; a free one must agree within its uncertainty
        bad = [c for c in consistency(lsq.values)
               if (abs(c.fitted - c.implied) > HELD_RTOL * abs(c.implied) if c.name in held else not c.agrees)]
        if not bad:
            return Reconciled(lsq, notes, [], problem)
        c = bad[0]
        if c.name in held:
            problem = problem.holding(c.name, c.implied)
            consistency = problem.consistency
            lsq = least_squares(problem, n_starts=1, seed=seed, start=_start(lsq), priors_count=priors_count,
                                optimizer=optimizer, scale_start=profiled_scale(problem, lsq))
            if not notes or not notes[-1].startswith(f"{c.name} moved"):
                notes.append(f"{c.name} moved from {c.fitted:.6g} to {c.implied:.6g} so that the model's period "
                             f"matches the record's ({c.facts} at the first value)")
            else:
                notes[-1] = notes[-1].replace(notes[-1].split(" to ")[1].split(" so")[0], f"{c.implied:.6g}", 1)
            continue
        if c.name not in lsq.names:
            return Reconciled(lsq, notes, [c], problem)
        i = lsq.names.index(c.name)
        start = _start(lsq)
        start[c.name] = float(np.clip(c.implied, lsq.lower[i], lsq.upper[i]))
        refit = least_squares(problem, n_starts=1, seed=seed, start=start, priors_count=priors_count,
                              optimizer=optimizer, scale_start=profiled_scale(problem, lsq))
        again = [x for x in consistency(refit.values) if x.name == c.name]
        if again and not again[0].agrees:
            return Reconciled(lsq, notes, [c], problem)
        ratio = refit.chisqr / lsq.chisqr if lsq.chisqr > 0 else math.inf
        how = "it also fits the readings better" if ratio <= 1.0 + 1e-9 else \
            f"its residuals are {math.sqrt(ratio):.3g} times the first optimum's, which the measured period rules out"
        notes.append(f"the first optimum put {c.name} at {c.fitted:.6g}, where {c.facts}: refitted from {c.name} = "
                     f"{start[c.name]:.6g}, the measured value; {how}")
        lsq = refit
    bad = [c for c in consistency(lsq.values) if not c.agrees]
    return Reconciled(lsq, notes, bad, problem)


def with_held_uncertainty(problem, lsq: LeastSquaresResult) -> tuple[LeastSquaresResult, list[str]]:
    """Add the uncertainty of the parameters the problem holds to the fitted ones' covariance.

    A held parameter (an omega0 taken from the measured period) is known only as well as that
    measurement; the fitted parameters that scale with it (C with omega0, R with its square)
    inherit that: ``cov += J J^T var(held)`` with ``J`` the derivatives the problem gives
    (:meth:`held_effects`).  Without that, the intervals of C and R from turning points would
    ignore the period's uncertainty, which can exceed their own.
    """
    effects = getattr(problem, "held_effects", None)
    if effects is None or not getattr(problem, "held", ()):
        return lsq, []
    from dataclasses import replace

    from .lsq import bound_flags, interval_table

    se = np.nan_to_num(np.asarray(lsq.stderr, float), nan=np.nan)
    corr = np.asarray(lsq.correlation, float)
    cov = corr * np.outer(se, se)
    notes = []
    for name, held_se, slopes in effects(lsq.values):
        j = np.array([slopes.get(n, 0.0) for n in lsq.names])
        if not np.any(j) or not math.isfinite(held_se):
            continue
        cov = cov + np.outer(j, j) * held_se**2
        grew = [n for n, a, b in zip(lsq.names, se, np.sqrt(np.diag(cov))) if a > 0 and b > 1.001 * a]
        if grew:
            notes.append(f"the standard errors of {', '.join(grew)} include the uncertainty of the held {name} "
                         f"(+- {held_se:.3g})")
    new_se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    new_se = np.where(np.isfinite(se), new_se, np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        new_corr = np.clip(cov / np.outer(new_se, new_se), -1.0, 1.0)
    at_bound = bound_flags(lsq.value, lsq.lower, lsq.upper, new_se)
    out = replace(lsq, stderr=new_se, correlation=new_corr, at_bound=at_bound,
                  intervals=interval_table(lsq.value, new_se, lsq.lower, lsq.upper, at_bound))
    return out, notes


def _start_edit(name: str, implied: float, lsq: LeastSquaresResult) -> str:
    """The scene line that starts ``name`` at the value the record implies, inside its range."""
    from ..core.names import scene_key

    i = lsq.names.index(name)
    lo, hi = min(float(lsq.lower[i]), implied), max(float(lsq.upper[i]), implied)
    return f"{scene_key(name)} = {{ value = {implied:.5g}, vary = true, min = {lo:.5g}, max = {hi:.5g} }}"


def _waveform_hint(problem) -> str:
    """``', or fit every sample ([observation] model = "waveform")'`` unless the scene already does."""
    scene = getattr(problem, "scene", None)
    observation = dict(getattr(scene, "extra", {}).get("observation", {}) or {})
    if observation.get("model") == "waveform" or \
            any(getattr(c, "label", "") == "waveform" for c in getattr(problem, "curves", ())):
        return ""
    return ", or fit every sample ([observation] model = \"waveform\")"


def verdict(problem, lsq: LeastSquaresResult, unresolved: list[Implied], *,
            posterior: bool = False, agreement=None) -> tuple[str, list[str], str]:
    """What the fit determines.

    Parameters
    ----------
    posterior
        A posterior run follows: intervals come from the draws, so a singular least-squares
        curvature alone does not leave a parameter undetermined.
    agreement
        The fit held against the record (:class:`escfit.analysis.agreement.Agreement`) or
        ``None``: a fit that disagrees with the record determines nothing.

    Returns
    -------
    status : str
        :data:`DETERMINED`, :data:`PARTLY` or :data:`NOT_DETERMINED`.
    undetermined : list of str
        Structural parameters (not ``observation.*`` nuisances) the fit does not determine.
    message : str
        One sentence naming what is not determined and what to fix ('' when all is).
    """
    from ..core.names import scene_key

    structural = [n for n in lsq.names if not n.startswith("observation.")] or list(lsq.names)
    if unresolved:
        c = unresolved[0]
        if c.name not in lsq.names:
            return NOT_DETERMINED, structural, (
                f"the parameters are NOT determined: {c.facts}, but the scene fixes {c.name} = {c.fitted:.5g} where "
                f"the record implies {c.implied:.5g}: set it there ({scene_key(c.name)} = {c.implied:.5g}), or let it vary")
        return NOT_DETERMINED, structural, (
            f"the parameters are NOT determined: {c.facts}, and the fit's {c.name} = {c.fitted:.5g} disagrees with "
            f"the {c.implied:.5g} it implies even when refitted from there: the scene does not describe this record "
            f"(check its effects, restoring law, units and ranges): start from the implied value, "
            f"{_start_edit(c.name, c.implied, lsq)}{_waveform_hint(problem)}")
    if agreement is not None and not agreement.agrees:
        return NOT_DETERMINED, structural, agreement.statement()
    split = tuple(getattr(agreement, "undetermined", ()) or ())
    if split:
        names = ", ".join(split)
        return PARTLY, list(split), (f"{names} {'is' if len(split) == 1 else 'are'} not determined by this record "
                                     "(the warnings say why); the other values stand")
    if posterior:
        return DETERMINED, [], ""
    missing = [n for n, e in zip(lsq.names, lsq.stderr) if n in structural and not np.isfinite(e)]
    if not missing:
        return DETERMINED, [], ""
    first = missing[0]
    fix = (f"fix some of them in the scene (e.g. {scene_key(first)} = {float(lsq.values[first]):.5g}, its value "
           "here), give them informative priors (--method emcee), or record what separates them")
    if set(missing) >= set(structural):
        return NOT_DETERMINED, missing, (f"the parameters are NOT determined: the readings fix none of "
                                         f"{', '.join(missing)} (singular curvature, no interval); {fix}")
    return PARTLY, missing, (f"{', '.join(missing)} {'is' if len(missing) == 1 else 'are'} not determined by the "
                             f"readings (singular curvature, no interval); the other values hold only for "
                             f"{'it' if len(missing) == 1 else 'them'} as fitted; {fix}")
