"""When a sampler run is long enough: the criteria of ``--steps auto``.

A run stops when, over the draws kept after burn-in (the last three quarters of the run so far,
:data:`BURN_FRACTION`),

* the rank-normalised split R-hat of every parameter is at most ``RHAT_MAX`` (1.01),
* the bulk and the tail effective sample sizes of every parameter are at least ``ESS_MIN``
  (400), both as ArviZ computes them with each walker taken as a chain (Vehtari et al. 2021;
  :mod:`escfit.inference.rank_diagnostics`),
* and the whole run is longer than ``TAU_FACTOR`` (50) integrated autocorrelation times of
  every parameter (emcee's own criterion; with 32 walkers it also gives an ensemble ESS of
  walkers * steps / (2 tau) >= 800).

:func:`assess` returns these figures; :func:`verdict` says in one line what is still missing.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

__all__ = ["Assessment", "assess", "chain_diagnostics", "default_burn", "RHAT_MAX", "ESS_MIN", "TAU_FACTOR",
           "BURN_FRACTION", "BURN_FAR", "autocorr_time"]

RHAT_MAX = 1.01
ESS_MIN = 400.0
TAU_FACTOR = 50.0
#: the share of a run discarded as burn-in unless ``--burn`` says otherwise, for walkers started at
#: the least-squares optimum: they are in the posterior's bulk after a few autocorrelation times; a
#: run that stops is longer than 50 of them, so a quarter is 12 or more, and split R-hat over the
#: kept draws flags a walker still drifting.  Discarding half cost a third more steps for the same
#: R-hat.  Walkers started elsewhere (no least-squares fit before) discard half (:data:`BURN_FAR`).
BURN_FRACTION = 0.25
BURN_FAR = 0.5


def default_burn(steps: int, fraction: float = BURN_FRACTION) -> int:
    """Steps discarded at the start of a run of ``steps`` when no burn-in is given."""
    return int(steps * fraction)


@dataclass(frozen=True)
class Assessment:
    """Convergence figures of a run (per parameter, in vector order).

    Attributes
    ----------
    steps : int
        Steps of the whole run.
    rhat, ess_bulk, ess_tail : ndarray
        Of the kept draws (after :func:`default_burn`).
    tau : ndarray
        Integrated autocorrelation time (steps) from the whole run.
    complete : bool
        False when only R-hat was computed (:func:`assess` with ``rhat_first``): it already
        failed, and the ESS and tau are NaN.
    """

    steps: int
    rhat: np.ndarray
    ess_bulk: np.ndarray
    ess_tail: np.ndarray
    tau: np.ndarray
    complete: bool = True

    @property
    def converged(self) -> bool:
        return (bool(np.all(self.rhat <= RHAT_MAX)) and bool(np.all(self.ess_bulk >= ESS_MIN))
                and bool(np.all(self.ess_tail >= ESS_MIN)) and bool(np.all(self.steps > TAU_FACTOR * self.tau)))

    def verdict(self) -> str:
        """One line: the worst figure of each criterion against its threshold."""
        worst = lambda a, f: float(f(a)) if a.size else float("nan")  # noqa: E731
        return (f"after {self.steps} steps: max R-hat {worst(self.rhat, np.max):.3f} (<= {RHAT_MAX}), "
                f"min bulk ESS {worst(self.ess_bulk, np.min):.0f}, min tail ESS {worst(self.ess_tail, np.min):.0f} "
                f"(>= {ESS_MIN:.0f}), run / max tau {self.steps / max(worst(self.tau, np.max), 1e-300):.0f} "
                f"(> {TAU_FACTOR:.0f})")


def autocorr_time(chain: np.ndarray) -> np.ndarray:
    """emcee's integrated autocorrelation time per parameter, ``chain`` shaped (steps, walkers, ndim).

    NaN when the run is too short to estimate it (fewer than two steps).
    """
    from .emcee_import import emcee

    if chain.shape[0] < 2:
        return np.full(chain.shape[-1], np.nan)
    logger = logging.getLogger("emcee.autocorr")
    level = logger.level
    logger.setLevel(logging.ERROR)  # short chains are judged by the caller, not logged
    try:
        return np.asarray(emcee.autocorr.integrated_time(chain, quiet=True), float)
    finally:
        logger.setLevel(level)


def chain_diagnostics(kept: np.ndarray, *, rhat_first: bool = False,
                      first: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rank-normalised split R-hat, bulk ESS and tail ESS of each parameter.

    Parameters
    ----------
    kept : ndarray, shape (chains, draws, ndim)
        Draws after burn-in, each walker a chain.
    rhat_first : bool
        Compute R-hat first, parameter by parameter, and stop at the first that fails (above
        ``RHAT_MAX`` or NaN), leaving the other figures NaN: what a look during a run needs to
        decide to go on, usually at a small fraction of the cost.
    first : int, optional
        With ``rhat_first``, the parameter to look at first (the one that failed the last look,
        the likeliest to fail again); the verdict does not depend on the order.

    Returns
    -------
    rhat, ess_bulk, ess_tail : ndarray, shape (ndim,)
        ArviZ's figures (``arviz.rhat`` and ``arviz.ess``), computed by
        :mod:`escfit.inference.rank_diagnostics` without importing ArviZ's dependencies.  The
        tail ESS is that of the 5 % and 95 % quantiles.  NaN for a parameter whose draws never
        move, and for all with fewer than 4 draws per chain.
    """
    from .rank_diagnostics import ess_bulk, ess_tail, split_rhat

    kept = np.asarray(kept, float)
    ndim = kept.shape[-1]
    rhat, bulk, tail = (np.full(ndim, np.nan) for _ in range(3))
    if kept.shape[1] < 4:
        return rhat, bulk, tail
    moving = np.flatnonzero(np.ptp(kept, axis=(0, 1)) > 0)
    if not moving.size:
        return rhat, bulk, tail
    if rhat_first:
        if moving.size < ndim:  # a parameter that never moves fails at once
            return rhat, bulk, tail
        order = list(moving) if first is None or first not in moving else [first] + [i for i in moving if i != first]
        for i in order:
            rhat[i] = split_rhat(kept[:, :, i])
            if not rhat[i] <= RHAT_MAX:
                return rhat, bulk, tail
    else:
        rhat[moving] = [split_rhat(kept[:, :, i]) for i in moving]
    bulk[moving] = [ess_bulk(kept[:, :, i]) for i in moving]
    tail[moving] = [ess_tail(kept[:, :, i]) for i in moving]
    return rhat, bulk, tail


def assess(chain: np.ndarray, burn: int | None = None, *, rhat_first: bool = False,
           burn_fraction: float = BURN_FRACTION, first: int | None = None) -> Assessment:
    """Convergence figures of ``chain`` (steps, walkers, ndim) with the first ``burn`` steps dropped.

    ``burn`` defaults to ``burn_fraction`` of the run (:func:`default_burn`).  Parameters that
    never move (a chain with zero spread) get R-hat NaN and ESS NaN, which fail the criteria.
    With ``rhat_first``, a run whose R-hat already fails gets an incomplete assessment
    (``complete`` False: ESS, tau and the R-hat not computed NaN, ``first`` the parameter looked
    at first, see :func:`chain_diagnostics`), which says "not converged" exactly as the complete
    one would.
    """
    steps = int(chain.shape[0])
    burn = default_burn(steps, burn_fraction) if burn is None else int(burn)
    kept = np.transpose(chain[burn:], (1, 0, 2))  # (walkers, draws, ndim)
    rhat, bulk, tail = chain_diagnostics(kept, rhat_first=rhat_first, first=first)
    if rhat_first and not np.all(rhat <= RHAT_MAX):
        return Assessment(steps, rhat, bulk, tail, np.full(rhat.size, np.nan), complete=False)
    return Assessment(steps, rhat, bulk, tail, autocorr_time(chain))
