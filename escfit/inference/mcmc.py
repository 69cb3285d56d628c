"""Posterior sampling with emcee for every model family, resumable from its HDF5 backend.

Walkers start in a small ball around the least-squares solution; each walker is one ArviZ
``chain``.  A walker position whose forward solve fails has log-probability ``-inf`` (the
reason is counted in ``problem.failures``), which emcee simply rejects.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import emcee
import numpy as np

from ..core.errors import FitError, ResultsError
from ..likelihood.problem import Problem
from .lsq import LeastSquaresResult

__all__ = ["McmcResult", "run_emcee"]


@dataclass
class McmcResult:
    """Draws after burn-in and the run's diagnostics.

    Attributes
    ----------
    chain : ndarray, shape (walkers, draws, ndim)
    log_prob : ndarray, shape (walkers, draws)
    acceptance : ndarray, shape (walkers,)
    tau : ndarray, shape (ndim,)
        Integrated autocorrelation time per parameter (steps), from the whole run.
    steps, burn, walkers, seed : int
    tau_reliable : bool
        Whether the run is longer than 50 autocorrelation times (emcee's criterion).
    """

    names: list[str]
    chain: np.ndarray
    log_prob: np.ndarray
    acceptance: np.ndarray
    tau: np.ndarray
    steps: int
    burn: int
    walkers: int
    seed: int
    tau_reliable: bool
    resumed: bool = False
    failures: dict = field(default_factory=dict)
    moves: str = "stretch"


MOVES = {
    "stretch": lambda: None,
    # differential evolution alone: emcee 3.1.6's snooker move scales its step by sqrt(|s - z|)
    # instead of projecting on the unit vector, so its proposal is not symmetric and it biases
    # the posterior (30 % too narrow alone, 8 % in the usual 80/20 mix, on the friction rig)
    "de": lambda: emcee.moves.DEMove(),
}


def _start(problem: Problem, lsq: LeastSquaresResult | None, walkers: int, rng: np.random.Generator) -> np.ndarray:
    centre = problem.initial.copy()
    scale = np.abs(centre) * 1e-3 + 1e-8
    if lsq is not None:
        for i, n in enumerate(problem.names):
            if n in lsq.names:
                j = lsq.names.index(n)
                centre[i] = lsq.value[j]
                se = lsq.stderr[j]
                scale[i] = 0.1 * se if np.isfinite(se) and se > 0 else abs(centre[i]) * 1e-3 + 1e-8
            elif n == "observation.sigma" and np.isfinite(lsq.sigma_hat) and lsq.sigma_hat > 0:
                centre[i] = lsq.sigma_hat
                scale[i] = 0.05 * lsq.sigma_hat
            elif n in lsq.values and np.isfinite(lsq.values[n]):  # a noise parameter least squares held
                centre[i] = float(lsq.values[n])
                scale[i] = abs(centre[i]) * 1e-2 + 1e-8
    lo, hi = problem.bounds
    span = np.where(np.isfinite(hi - lo), hi - lo, np.inf)
    centre = np.clip(centre, lo + 1e-9 * np.minimum(span, 1.0), hi - 1e-9 * np.minimum(span, 1.0))
    out = np.empty((walkers, centre.size))
    for w in range(walkers):
        for _ in range(200):
            x = centre + scale * rng.standard_normal(centre.size)
            x = np.clip(x, lo, hi)
            if math.isfinite(problem.log_prob(x)):
                out[w] = x
                break
        else:
            raise FitError("could not place the walkers: the log posterior is -inf around the least-squares solution "
                           f"(reasons: {dict(problem.failures)})")
    return out


def run_emcee(problem: Problem, lsq: LeastSquaresResult | None = None, *, walkers: int = 32, steps: int = 2000,
              burn: int | None = None, seed: int = 0, checkpoint: str | Path | None = None, resume: bool = False,
              progress: bool = False, vectorize: bool | None = None, moves: str = "stretch") -> McmcResult:
    """Sample the posterior.

    Parameters
    ----------
    walkers, steps
        Ensemble size (at least twice the number of free parameters) and total steps.
    burn
        Steps discarded at the start (default: half the run).
    seed
        Seeds the start ball and emcee's own generator.
    checkpoint
        emcee HDF5 backend file; the run can be resumed from it after an interruption.
    resume
        Continue the run stored in ``checkpoint`` up to ``steps`` in total.
    progress
        Show emcee's progress bar.
    moves
        ``"stretch"`` (emcee's default affine-invariant stretch move) or ``"de"`` (differential
        evolution), which mixes faster on posteriors with strongly coupled directions such as
        a noise scale and its correlation, and on one-parameter posteriors.
    vectorize
        Evaluate each half-ensemble of proposals in one call of
        :meth:`Problem.log_prob_many` (emcee's ``vectorize=True``).  Default: the problem's
        own declaration :attr:`Problem.vectorized` (a whole-array path that gives the same
        numbers as ``log_prob`` walker by walker, so the draws are identical too).
    """
    ndim = len(problem.names)
    if walkers < 2 * ndim:
        raise FitError(f"emcee needs at least {2 * ndim} walkers for {ndim} free parameters, got {walkers}")
    if steps < 10:
        raise FitError(f"steps must be at least 10, got {steps}")
    burn = steps // 2 if burn is None else int(burn)
    if not 0 <= burn < steps:
        raise FitError(f"burn must lie in [0, steps), got {burn}")
    backend = None
    done = 0
    if checkpoint is not None:
        backend = emcee.backends.HDFBackend(str(checkpoint), name="mcmc")
        if resume:
            if not Path(checkpoint).exists():
                raise ResultsError("nothing to resume: checkpoint file not found", str(checkpoint))
            try:
                done = backend.iteration if backend.initialized else 0
                shape = backend.shape if done else (walkers, ndim)
            except (OSError, KeyError, ValueError) as exc:  # not an emcee checkpoint, or a damaged one
                raise ResultsError(f"cannot resume from this checkpoint ({type(exc).__name__}: {exc}); pass --force "
                                   "to start again", str(checkpoint)) from None
            if shape != (walkers, ndim):
                raise ResultsError(f"checkpoint holds {shape[0]} walkers x {shape[1]} parameters, this fit has "
                                   f"{walkers} x {ndim}; pass --force to start again", str(checkpoint))
        else:
            backend.reset(walkers, ndim)
    if moves not in MOVES:
        raise FitError(f"moves must be one of {sorted(MOVES)}, got {moves!r}")
    chosen = MOVES[moves]()
    if vectorize is None:
        vectorize = bool(getattr(problem, "vectorized", False))
    if vectorize:
        sampler = emcee.EnsembleSampler(walkers, ndim, problem.log_prob_many, vectorize=True, backend=backend,
                                        moves=chosen)
    else:
        sampler = emcee.EnsembleSampler(walkers, ndim, problem.log_prob, backend=backend, moves=chosen)
    rng = np.random.default_rng(seed)
    if done == 0:
        sampler.random_state = np.random.RandomState(seed).get_state()
        start = _start(problem, lsq, walkers, rng)
        sampler.run_mcmc(start, steps, progress=progress)
    elif done < steps:
        sampler.run_mcmc(None, steps - done, progress=progress)
    chain = sampler.get_chain()  # (steps, walkers, ndim)
    lp = sampler.get_log_prob()
    logger = logging.getLogger("emcee.autocorr")
    level = logger.level
    logger.setLevel(logging.ERROR)  # short chains are reported in the results' warnings instead
    try:
        tau = emcee.autocorr.integrated_time(chain, quiet=True) if chain.shape[0] > 1 else np.full(ndim, np.nan)
    finally:
        logger.setLevel(level)
    kept = chain[burn:].transpose(1, 0, 2)
    return McmcResult(list(problem.names), kept, lp[burn:].T, np.asarray(sampler.acceptance_fraction), np.asarray(tau),
                      chain.shape[0], burn, walkers, seed, bool(np.all(chain.shape[0] > 50 * np.asarray(tau))),
                      resumed=done > 0, failures=dict(problem.failures), moves=moves)
