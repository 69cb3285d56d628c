"""Rank-normalised split R-hat and bulk and tail effective sample sizes, in numpy alone.

The convergence figures of Vehtari, Gelman, Simpson, Carpenter and Buerkner (2021), "Rank-
normalization, folding, and localization: an improved R-hat for assessing convergence of
MCMC", Bayesian Analysis 16(2), with each walker of an ensemble taken as a chain:

* **split R-hat**: every chain cut into halves; the draws of all half-chains replaced by the
  normal scores of their pooled ranks (ties share the mean rank; Blom's offset 3/8); R-hat
  of those scores, and of the scores of the distances from the median (the folded draws, for
  the tails); the larger of the two;
* **bulk ESS**: the effective sample size of the normal scores of the split chains, with the
  autocorrelation summed over Geyer's (1992) initial positive and then monotone sequence
  of pairs of lags;
* **tail ESS**: the smaller of the effective sample sizes of the indicators ``x <= q05`` and
  ``x <= q95`` over the split chains.

These are the figures ArviZ reports (``tests/test_rank_diagnostics.py`` compares them with
``arviz_stats`` to 1e-9).  They are computed here because ArviZ's array functions import
``scipy.signal``, ``scipy.stats`` and xarray: about 0.7 CPU s of every sampler run, against a
few milliseconds for the figures themselves.  The normal quantile is scipy's ``ndtri``
(``scipy.special``, loaded with the least-squares optimiser anyway).
"""

from __future__ import annotations

import numpy as np

__all__ = ["split_rhat", "ess_bulk", "ess_tail"]

BLOM = 3.0 / 8.0  # offset of the normal scores of ranks


def _split(x: np.ndarray) -> np.ndarray:
    """(chains, draws) -> (2 chains, draws // 2): the first and last halves (an odd middle draw left out)."""
    half = x.shape[1] // 2
    return np.concatenate((x[:, :half], x[:, x.shape[1] - half:]), axis=0)


def _normal_scores(x: np.ndarray) -> np.ndarray:
    """Normal quantiles of the pooled ranks of ``x`` (tied values share their mean rank)."""
    from scipy.special import ndtri

    flat = x.ravel()
    order = np.argsort(flat, kind="stable")
    ordered = flat[order]
    first = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])  # where each run of equal values starts
    size = np.diff(np.r_[first, flat.size])
    mean_rank = first + (size + 1) / 2.0  # ranks first+1 .. first+size
    ranks = np.empty(flat.size)
    ranks[order] = np.repeat(mean_rank, size)
    return ndtri((ranks - BLOM) / (flat.size - 2 * BLOM + 1)).reshape(x.shape)


def _rhat(x: np.ndarray) -> float:
    """Gelman-Rubin potential scale reduction of (chains, draws), within-chain variances with ddof 1."""
    n = x.shape[1]
    within = np.mean(np.var(x, axis=1, ddof=1))
    between = n * np.var(np.mean(x, axis=1), ddof=1)
    return float(np.sqrt((between / within + n - 1) / n))


def _autocovariance(x: np.ndarray) -> np.ndarray:
    """Biased autocovariance (divided by the draws) of each chain of (chains, draws), by FFT."""
    n = x.shape[1]
    centred = x - x.mean(axis=1, keepdims=True)
    size = 1 << int(2 * n - 1).bit_length()  # a power of two >= 2n: no wrap-around
    spectrum = np.fft.rfft(centred, n=size, axis=1)
    return np.fft.irfft(spectrum * np.conjugate(spectrum), n=size, axis=1)[:, :n] / n


def _ess(x: np.ndarray) -> float:
    """Effective sample size of (chains, draws), autocorrelations cut by Geyer's initial sequences."""
    chains, n = x.shape
    total = chains * n
    if np.max(x) - np.min(x) < np.finfo(float).resolution:
        return float(total)
    acov = _autocovariance(x)
    within = np.mean(acov[:, 0]) * n / (n - 1.0)
    var_plus = within * (n - 1.0) / n + (np.var(np.mean(x, axis=1), ddof=1) if chains > 1 else 0.0)
    rho = 1.0 - (within - np.mean(acov, axis=0)) / var_plus  # combined autocorrelation at every lag
    rho[0] = 1.0
    kept = np.zeros(n)
    kept[:2] = rho[:2]
    even, odd, t = 1.0, rho[1], 1
    while t < n - 3 and even + odd > 0.0:  # initial positive sequence: pairs of lags while their sum is positive
        even, odd = rho[t + 1], rho[t + 2]
        if even + odd >= 0.0:
            kept[t + 1], kept[t + 2] = even, odd
        t += 2
    last = t - 2
    if even > 0.0:  # the first dropped pair's even lag, when positive
        kept[last + 1] = even
    for t in range(1, last - 1, 2):  # initial monotone sequence: no pair larger than the one before
        if kept[t + 1] + kept[t + 2] > kept[t - 1] + kept[t]:
            kept[t + 1] = kept[t + 2] = (kept[t - 1] + kept[t]) / 2.0
    tau = -1.0 + 2.0 * np.sum(kept[:last + 1]) + np.sum(kept[last + 1:last + 2])
    tau = max(tau, 1.0 / np.log10(total))
    return float("nan") if np.isnan(kept).any() else float(total / tau)


def split_rhat(x: np.ndarray) -> float:
    """Rank-normalised split R-hat of ``x`` (chains, draws): the larger of bulk and folded."""
    split = _split(np.asarray(x, float))
    folded = np.abs(split - np.median(split))
    return max(_rhat(_normal_scores(split)), _rhat(_normal_scores(folded)))


def ess_bulk(x: np.ndarray) -> float:
    """Bulk effective sample size of ``x`` (chains, draws)."""
    return _ess(_normal_scores(_split(np.asarray(x, float))))


def ess_tail(x: np.ndarray, probs: tuple[float, float] = (0.05, 0.95)) -> float:
    """Tail effective sample size of ``x`` (chains, draws): the smaller one of its two quantiles'."""
    x = np.asarray(x, float)
    return min(_ess(_split((x <= np.quantile(x, p)).astype(float))) for p in probs)
