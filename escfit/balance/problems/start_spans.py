"""Where a waveform fit's multistart draws what the record itself has measured: its frequency and its decay.

The multistart (:func:`escfit.inference.lsq.least_squares`) tries the scene's start and a Latin
hypercube of others, ranked by cost.  Drawn over a scene's bounds, most of those starts cannot
win, and each costs a full trust-region run that ends in another optimum:

* **Losses the record cannot hold.**  Viscous C up to 1 1/s or friction up to 1 rad/s^2 against a
  record that loses 2 % a period stops the model's swing within a few periods; the model is then
  flat, hardly depends on the frequency or the release, and the fit stays there (two of the
  three refined starts of the 116 s string pendulum, 42 of its 74 model runs).  Neither loss can
  take more than the decay the record shows, which each alone would explain with ``c_all`` or
  ``r_all`` (:func:`~escfit.balance.starter_decay.decay_estimates`), noise aside: C and R are
  drawn from zero to :data:`~escfit.balance.starter_decay.BOUND_FACTOR` times those, as
  ``escfit init`` bounds them.
* **A frequency out of step.**  A model ``d omega`` off drifts ``d omega * T`` out of phase over a
  record of ``T`` seconds.  Fits started well beyond a quarter turn of drift still reach the
  record's frequency as a rule, but not always (one started 35 % off on 60 periods ended a slip
  away): omega0 is drawn within the measured period's value (over viscous damping up to that
  span's) widened by ``pi / (2 T)`` or by
  :data:`~escfit.balance.problems.period.CHECK_SIGMAS` of the period's standard errors,
  whichever is wider.

Only the starts are drawn there: the bounds, the priors and the fit are the scene's.
"""

from __future__ import annotations

import math

import numpy as np

from ..starter_decay import decay_estimates
from .period import CHECK_SIGMAS, MeasuredPeriod, implied_omega0

__all__ = ["start_spans"]


def _loss_spans(tp, omega0: float) -> dict[str, tuple[float, float]]:
    """Zero to BOUND_FACTOR times the C and R that alone explain the turning points' decay."""
    times = np.r_[float(tp.release_time), np.asarray(tp.time, float)]
    amps = np.abs(np.r_[float(tp.release_theta), np.asarray(tp.theta, float)] - tp.centre(times))
    if amps.size < 3 or not np.all(np.isfinite(amps)):
        return {}
    est = decay_estimates(amps, omega0, times)
    if not est["decays"]:
        return {}
    return {"viscous.C": (0.0, est["C_max"]), "coulomb.R": (0.0, est["R_max"])}


def _omega0_span(scene, mp: MeasuredPeriod, span: float, c_max: float) -> tuple[float, float]:
    """The measured period's omega0 (for viscous damping up to ``c_max``) widened by the quarter
    turn ``pi / (2 span)`` or by CHECK_SIGMAS of the period's standard errors."""
    lo, hi = implied_omega0(scene.restoring, mp, 0.0), implied_omega0(scene.restoring, mp, c_max)
    rel = CHECK_SIGMAS * mp.stderr / mp.period if math.isfinite(mp.stderr) else 0.0
    half = max(0.5 * math.pi / span, rel * hi) if span > 0 else 0.5 * hi
    return lo - half, hi + half


def start_spans(scene, mp: MeasuredPeriod | None, tp, span: float) -> dict[str, tuple[float, float]]:
    """Parameter name -> ``(low, high)`` of the multistart's draws, for the free parameters the
    record bounds (see the module docstring); empty when the record measured no period.

    ``span`` is the stretch of record fitted, s.
    """
    if mp is None or tp is None or not (math.isfinite(mp.period) and mp.period > 0):
        return {}
    free = {n for n, p in scene.params.params.items() if p.vary}
    omega0 = implied_omega0(scene.restoring, mp)  # the period's, whatever sets the stiffness
    out = {n: s for n, s in _loss_spans(tp, omega0).items() if n in free}
    if "oscillator.omega0" in free:
        out["oscillator.omega0"] = _omega0_span(scene, mp, span, out.get("viscous.C", (0.0, 0.0))[1])
    return out
