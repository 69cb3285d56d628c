"""The log-likelihood of a least-squares fit at its optimum, for information criteria.

Least squares minimises the standardised residuals, which is the maximum of a Gaussian
likelihood.  To compare fits of the same readings by AICc or BIC, the results file needs
that maximum in absolute terms (normalising constants included, so that fits whose scenes
start the noise scale at different values compare fairly), the number of parameters it was
maximised over, and what the likelihood is.  :func:`information_attrs` computes them once,
at fit time, from the problem's own pointwise log-likelihood:

* the structural parameters stay at the least-squares optimum;
* a noise scale the fit profiled (``observation.sigma`` free) is set to the value that
  maximises the summed pointwise log-likelihood there (a one-dimensional search in log
  sigma; for Gaussian readings this is ``sigma * sqrt(chisqr / n)``), and counts as a
  parameter; a scale fixed by the scene does not count;
* a free AR(1) ``rho``, which least squares estimates from the residuals of a first fit with
  white noise, is set with the noise scale to the pair that maximises the log-likelihood at the
  optimum, and counts.  Kept at the first fit's estimate, it would differ from fit to fit of the
  same readings (each model's white-noise residuals are correlated differently), and a law that
  nests another could score a lower likelihood than it; maximised, every fit is scored at the
  best noise model for its residuals.  A Student-t ``nu``, which least squares holds at its
  starting value, stays there and does not count.

For Gaussian readings (amplitudes, times, independent or AR(1) samples) the number is the
maximised likelihood.  For readings whose likelihood is not Gaussian (notch intervals,
whole-step samples, Student-t noise) least squares maximises a Gaussian approximation, so
the stored value is the model's own likelihood at that optimum: a lower bound of its maximum,
close to it when the approximation is good.  :data:`EXACT_KEY` records which.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

__all__ = ["information_attrs", "aicc", "bic", "akaike_weights", "stored_criteria", "EXACT_KEY"]

#: attribute saying whether ``loglike`` is the maximum (1) or the likelihood at the Gaussian optimum (0)
EXACT_KEY = "loglike_maximised"

SIGMA = "observation.sigma"
RHO = "observation.rho"


def aicc(loglike: float, k: int, n: int) -> float:
    """Akaike's criterion with the small-sample correction: ``-2 logL + 2k + 2k(k+1)/(n-k-1)``.

    Returns ``inf`` when ``n <= k + 1`` (the correction is undefined: too few readings).
    """
    if n - k - 1 <= 0:
        return math.inf
    return -2.0 * loglike + 2.0 * k + 2.0 * k * (k + 1) / (n - k - 1)


def bic(loglike: float, k: int, n: int) -> float:
    """Schwarz's Bayesian information criterion: ``-2 logL + k ln n``."""
    return -2.0 * loglike + k * math.log(n)


def stored_criteria(attrs: Mapping[str, Any], n: int) -> dict[str, float] | None:
    """AICc and BIC of a saved least-squares fit, from what :func:`information_attrs` stored.

    The one computation behind both ``escfit compare`` and the report's fit statistics, so the
    two always print the same numbers.

    Parameters
    ----------
    attrs
        The ``least_squares`` group's attributes (``loglike``, ``n_params``).
    n
        Number of readings the likelihood sums over.

    Returns
    -------
    dict or None
        ``loglike``, ``n_params``, ``aicc``, ``bic``; ``None`` when the file stores no
        log-likelihood (written by an older escfit) or the model failed at the optimum.
    """
    if "loglike" not in attrs or "n_params" not in attrs:
        return None
    ll, k = float(attrs["loglike"]), int(attrs["n_params"])
    if not math.isfinite(ll):
        return None
    return {"loglike": ll, "n_params": k, "aicc": aicc(ll, k, n), "bic": bic(ll, k, n)}


def akaike_weights(values: np.ndarray) -> np.ndarray:
    """Weights ``exp(-delta/2)`` normalised over the fits (``delta`` from the smallest value)."""
    v = np.asarray(values, float)
    w = np.exp(-0.5 * (v - np.min(v)))
    return w / w.sum()


def information_attrs(problem, lsq) -> dict[str, Any]:
    """``loglike``, ``n_params``, ``noise_model`` and :data:`EXACT_KEY` of a least-squares fit.

    Parameters
    ----------
    problem
        The fit problem (:class:`~escfit.likelihood.problem.Problem`).
    lsq
        Its :class:`~escfit.inference.lsq.LeastSquaresResult`.

    Returns
    -------
    dict
        ``loglike`` is nan when the model cannot be evaluated at the optimum.
    """
    values = dict(lsq.values)
    # least squares estimates a free AR(1) rho from a first fit's residuals: a parameter it varied
    rho_free = RHO in getattr(problem, "names", ())
    k = len(lsq.names) + (1 if lsq.profiled else 0) + (1 if rho_free else 0)
    try:
        if rho_free and RHO in values:
            values.update(_best_noise(problem, values, lsq.profiled and SIGMA in values))
        elif lsq.profiled and SIGMA in values:
            values[SIGMA] = _best_scale(problem, values)
        loglike = float(np.sum(problem.loglike_pointwise(values)))
    except Exception:  # noqa: BLE001 - a model that fails here leaves the criterion undefined, said by nan
        loglike = math.nan
    text, exact = noise_model(problem, values, lsq.profiled, rho_free)
    return {"loglike": loglike if math.isfinite(loglike) else math.nan, "n_params": k, "noise_model": text,
            EXACT_KEY: int(exact)}


def _best_scale(problem, values: Mapping[str, float]) -> float:
    """The noise scale maximising the summed pointwise log-likelihood, others fixed."""
    from scipy.optimize import minimize_scalar

    start = float(values[SIGMA])
    loglike = _noise_loglike(problem, values)

    def cost(log_s: float) -> float:
        ll = loglike({SIGMA: math.exp(log_s)})
        return -ll if math.isfinite(ll) else math.inf

    res = minimize_scalar(cost, bounds=(math.log(start) - 3.0, math.log(start) + 3.0), method="bounded",
                          options={"xatol": 1e-7})
    return math.exp(float(res.x))


def _best_noise(problem, values: Mapping[str, float], scale_free: bool) -> dict[str, float]:
    """AR(1) ``rho`` (and the noise scale if ``scale_free``) maximising the summed pointwise
    log-likelihood, the structural parameters fixed: a search in ``atanh(rho)`` and ``log sigma``."""
    from scipy.optimize import minimize

    x0 = [math.atanh(min(max(float(values[RHO]), -0.99), 0.99))]
    if scale_free:
        x0.append(math.log(float(values[SIGMA])))

    def trial(x) -> dict[str, float]:
        out = {RHO: math.tanh(x[0])}
        if scale_free:
            out[SIGMA] = math.exp(x[1])
        return out

    loglike = _noise_loglike(problem, values)

    def cost(x) -> float:
        ll = loglike(trial(x))
        return -ll if math.isfinite(ll) else math.inf

    res = minimize(cost, x0, method="Nelder-Mead", options={"xatol": 1e-7, "fatol": 1e-9, "maxiter": 2000})
    return trial(res.x) if res.fun <= cost(x0) else trial(x0)


def _noise_loglike(problem, values: Mapping[str, float]):
    """The summed log-likelihood as a function of the noise parameters, the structural ones at
    ``values``: the problem's own (one model run) where it has one, else a model run per call."""
    own = getattr(problem, "noise_loglike", None)
    if callable(own):
        return own(values)
    return lambda noise: float(np.sum(problem.loglike_pointwise({**values, **noise})))


def noise_model(problem, values: Mapping[str, float], profiled: bool, rho_free: bool = False) -> tuple[str, bool]:
    """The likelihood of the readings in words, and whether least squares maximises it exactly."""
    obs = getattr(problem, "observation", None)
    kind = getattr(obs, "kind", "")
    noise = getattr(obs, "noise", "gaussian")
    exact = True
    if kind == "notches":
        text, exact = "notch counts: probability of each count's interval under Gaussian jitter", False
    elif getattr(obs, "quantum", 0.0) > 0.0:
        text, exact = "whole-step samples: probability of each step under Gaussian jitter", False
    elif noise == "student_t":
        text, exact = f"Student-t readings (nu held at {values.get('observation.nu', math.nan):.3g})", False
    elif noise == "ar1":
        rho = values.get(RHO, math.nan)
        text = (f"Gaussian AR(1) samples (rho = {rho:.3g} maximising the likelihood at the optimum, counted)"
                if rho_free else f"Gaussian AR(1) samples (rho fixed at {rho:.3g} by the scene)")
    elif kind == "waveform":
        text = "Gaussian, independent samples"
    else:
        text = "Gaussian, independent readings"
    if SIGMA in values:
        text += "; noise scale profiled (maximum likelihood)" if profiled else "; noise scale fixed by the scene"
    return text, exact
