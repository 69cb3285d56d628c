"""emcee proposals that mix on the narrow, strongly coupled posteriors of decay fits.

A decay fit's posterior is typically a thin ridge (C against R along a unit curve, a noise
scale against its correlation): emcee's stretch and differential-evolution moves are affine
invariant, so a straight ridge costs them nothing in principle, but each step still moves a
walker by about the distance between two others, and the integrated autocorrelation time stays
at 20-30 steps on the quick start's five parameters.  Most such posteriors are close to a
(skewed) multivariate normal, and then a walker can jump to an almost independent point in
one step: :class:`EnsembleTMove` proposes from a Student-t whose centre and scatter are those
of the other half of the ensemble, and accepts with the independence Metropolis-Hastings ratio.

Validity: emcee updates one half of the ensemble while the other (the complement) stays fixed,
so a proposal built from the complement alone is a fixed proposal density for that half-step,
and the ratio ``pi(y) q(x) / (pi(x) q(y))`` leaves the posterior invariant (Hastings 1970;
this is emcee's own construction for its KDE move, with a parametric density instead of a
kernel estimate, so it costs microseconds instead of milliseconds).  A half-step whose
complement cannot fix a covariance (fewer walkers than dimensions plus two, or a degenerate
spread) uses the differential-evolution proposal instead, a choice that depends on the
complement only and so keeps the half-step valid.  With many parameters for the walkers the
ensemble is split into more than two parts (:func:`complement_splits`), so that the complement
holds at least three walkers per dimension.  The heavy tails (5 degrees of freedom) keep
far-out regions reachable; the mixture with differential evolution (:func:`de_t_moves`) keeps
the ensemble mixing when the posterior is far from normal.
"""

from __future__ import annotations

import math

import numpy as np

from .emcee_import import emcee

__all__ = ["EnsembleTMove", "ArrayDEMove", "de_t_moves", "complement_splits"]


class ArrayAcceptance:
    """emcee's red-blue update (``RedBlueMove.propose``) with its per-walker work done on arrays.

    The same random numbers are drawn in the same order (the split's shuffle, the proposal's
    draws, then one uniform per walker of the sub-ensemble, in walker order), the proposal sees
    the same sub-ensemble and complement (the other sub-ensembles one after another, each in
    walker order) and the acceptance test is the same arithmetic, ``factor + new - old >
    log(u)``: the draws are those of emcee's own loop (``tests/test_moves.py`` compares the
    chains).  What goes is Python work per walker and per sub-ensemble (a boolean mask per
    sub-ensemble for each of the others, a loop over the walkers).  Mixed in before the emcee
    move it modifies.
    """

    def propose(self, model, state):
        nwalkers, ndim = state.coords.shape
        if nwalkers < 2 * ndim and not self.live_dangerously:
            raise RuntimeError(f"{nwalkers} walkers for {ndim} parameters: a red-blue move needs at least twice as "
                               "many walkers as parameters")
        self.setup(state.coords)
        accepted = np.zeros(nwalkers, dtype=bool)
        inds = np.arange(nwalkers) % self.nsplits
        if self.randomize_split:
            model.random.shuffle(inds)
        order = np.argsort(inds, kind="stable")  # the walkers of split 0, then 1, ..., each in walker order
        ends = np.cumsum(np.bincount(inds, minlength=self.nsplits))
        for split in range(self.nsplits):
            a, b = (ends[split - 1] if split else 0), ends[split]
            members = order[a:b]
            q, factors = self.get_proposal(state.coords[members], [state.coords[np.concatenate((order[:a], order[b:]))]],
                                           model.random)
            new_log_probs, new_blobs = model.compute_log_prob_fn(q)
            accepted[members] = factors + new_log_probs - state.log_prob[members] > np.log(
                model.random.rand(members.size))
            state = self.update(state, emcee.State(q, log_prob=new_log_probs, blobs=new_blobs), accepted,
                                inds == split)
        return state, accepted


class ArrayDEMove(ArrayAcceptance, emcee.moves.DEMove):
    """emcee's differential-evolution move with :class:`ArrayAcceptance`'s update: the same draws."""


class EnsembleTMove(ArrayAcceptance, emcee.moves.RedBlueMove):
    """Independence proposals from a Student-t fitted to the complementary half-ensemble.

    Parameters
    ----------
    df
        Degrees of freedom of the proposal (> 0; heavier tails than the posterior's keep the
        independence sampler uniformly ergodic where the posterior is close to normal).
    scale
        Factor on the complement's standard deviations.
    """

    def __init__(self, df: float = 5.0, scale: float = 1.0, **kwargs) -> None:
        if not (df > 0 and scale > 0):
            raise ValueError(f"df and scale must be positive, got {df!r}, {scale!r}")
        self.df, self.scale = float(df), float(scale)
        self._de = emcee.moves.DEMove()
        super().__init__(**kwargs)

    def setup(self, coords: np.ndarray) -> None:
        self._de.setup(coords)
        self.nsplits = complement_splits(*coords.shape)

    def get_proposal(self, s: np.ndarray, c: list, random) -> tuple[np.ndarray, np.ndarray]:
        comp = c[0] if len(c) == 1 else np.concatenate(c, axis=0)
        ns, ndim = s.shape
        factor = self._factor(comp, ndim)
        if factor is None:
            return self._de.get_proposal(s, c, random)
        mean, chol = factor
        z = random.randn(ns, ndim)
        w = random.chisquare(self.df, size=(ns, 1)) / self.df
        y = z / np.sqrt(w)  # the proposal's whitened deviation, so no solve is needed at q
        q = mean + y @ chol.T
        return q, self._log_density(self._whiten(s, mean, chol)) - self._log_density(y.T)

    def _factor(self, comp: np.ndarray, ndim: int) -> tuple[np.ndarray, np.ndarray] | None:
        """Mean and Cholesky factor of the proposal's scatter, or None when the complement fixes none."""
        if comp.shape[0] < ndim + 2:
            return None
        mean = np.add.reduce(comp, axis=0) / comp.shape[0]  # ndarray.mean's sum and division, less its wrapping
        dev = comp - mean
        cov = (dev.T @ dev) / (comp.shape[0] - 1) * self.scale**2
        try:
            chol = np.linalg.cholesky(cov)
        except np.linalg.LinAlgError:
            return None
        # sqrt of the largest variance is the largest standard deviation (sqrt is monotone)
        if not (np.isfinite(chol).all() and (chol.diagonal() > 1e-12 * math.sqrt(cov.diagonal().max())).all()):
            return None
        return mean, chol

    @staticmethod
    def _whiten(x: np.ndarray, mean: np.ndarray, chol: np.ndarray) -> np.ndarray:
        """``chol^-1 (x - mean)`` of the rows of ``x``, as columns.  numpy's general solve: at a
        few dimensions scipy's triangular solve costs three times as much in argument checks."""
        return np.linalg.solve(chol, (x - mean).T)

    def _log_density(self, y: np.ndarray) -> np.ndarray:
        """Log density of the proposal at whitened deviations ``y`` (columns), up to a constant
        shared by all of them."""
        return -0.5 * (self.df + y.shape[0]) * np.log1p(np.sum(y * y, axis=0) / self.df)


def complement_splits(walkers: int, ndim: int) -> int:
    """Sub-ensembles of an :class:`EnsembleTMove` step: two, or more when the other half of the
    ensemble would hold fewer than three walkers per dimension.

    The proposal's scatter is estimated from the complement; 16 walkers in 8 dimensions give a
    poor estimate (its smallest eigenvalues a tenth of the truth's), which on the 120-swing
    waveform benchmark halved the acceptance and doubled the autocorrelation time (16 steps
    against 8.5 with four sub-ensembles).  More sub-ensembles update fewer walkers at a time
    against a larger complement; the count depends on the ensemble's shape only, so each
    sub-step stays a valid Metropolis-Hastings update.
    """
    n = 2
    # the complement of the largest sub-ensemble; sub-ensembles keep at least two walkers
    while walkers - -(-walkers // n) < 3 * ndim and walkers // (n + 1) >= 2:
        n += 1
    return n


def de_t_moves(t_weight: float = 0.8) -> list:
    """emcee's move mixture ``"de-t"``: :class:`EnsembleTMove` with weight ``t_weight``,
    differential evolution with the rest (a step uses one of them, drawn with these weights)."""
    if not 0.0 < t_weight < 1.0 or math.isnan(t_weight):
        raise ValueError(f"t_weight must lie in (0, 1), got {t_weight!r}")
    return [(EnsembleTMove(), t_weight), (ArrayDEMove(), 1.0 - t_weight)]
