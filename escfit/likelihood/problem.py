"""What a fit needs from a model family: the :class:`Problem` protocol.

One inference layer (:mod:`escfit.inference`) serves every mechanism.  It sees a fit only
through a :class:`Problem`: a free-parameter vector with priors and bounds, a log posterior,
standardised residuals for least squares, and the readings with their coordinates.  A model
family (balance wheel and pendulum, friction rig, Geneva escapement, verge escapement)
supplies the problem from a scene and a recording through its entry in the family registry
(:class:`escfit.core.family.Family`), found by the scene's ``model =`` name.

Sign and unit conventions are the family's; every number crossing this interface is in the
parameter's canonical unit (``units``) or the readings' unit (``reading_units``).
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any, Mapping, Protocol, runtime_checkable

import numpy as np

from .priors import Prior

__all__ = ["Problem", "ProblemBase", "gaussian_prior_residuals", "FAIL_RESIDUAL"]

#: standardised residual standing for a reading the model could not predict (a failed run)
FAIL_RESIDUAL = 1e6


@runtime_checkable
class Problem(Protocol):
    """A fit problem: scene + recording + observation model, prepared once.

    Attributes
    ----------
    family : str
        The model family (``"balance"``, ``"friction_rig"``, ``"geneva"``, ``"verge"``).
    names : list[str]
        Free parameters, in vector order.
    priors : list[Prior]
        Prior of each free parameter (its support gives the bounds).
    noise_names : tuple[str, ...]
        Free parameters that least squares holds at their starting values instead of
        fitting (noise scales: the fit profiles them out, the sampler samples them).
    units, meanings : dict[str, str]
        Canonical unit and one-line meaning of every parameter by name (free, fixed and
        derived).
    reading_units : str
        Unit of :attr:`observed` (``"rad"``, ``"s"``, ``"N"``, ``"rad/s"``, ``"turns"`` ...).
    failures : collections.Counter
        Why evaluations returned ``-inf`` (or a large residual), counted.
    vectorized : bool
        Whether :meth:`log_prob_many` is a whole-array path worth calling for a whole
        ensemble (it must give the same numbers as :meth:`log_prob` row by row).
    notes, data_warnings : list[str]
        What was done to the recording before fitting, and what the data themselves
        make doubtful; both are stored with the results.
    """

    family: str
    names: list[str]
    priors: list[Prior]
    noise_names: tuple[str, ...]
    units: dict[str, str]
    meanings: dict[str, str]
    reading_units: str
    failures: Counter
    vectorized: bool
    notes: list[str]
    data_warnings: list[str]

    @property
    def initial(self) -> np.ndarray: ...

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]: ...

    @property
    def observed(self) -> np.ndarray: ...

    @property
    def n_data(self) -> int: ...

    def values(self, vec: np.ndarray | Mapping[str, float]) -> dict[str, float]:
        """Every parameter's value by name for a free-parameter vector (or partial mapping)."""

    def log_prior(self, vec: np.ndarray) -> float: ...

    def log_prob(self, vec: np.ndarray) -> float:
        """Log posterior up to a constant; ``-inf`` outside the prior or when the model fails."""

    def log_prob_many(self, vecs: np.ndarray) -> np.ndarray:
        """:meth:`log_prob` of each row of ``vecs`` (shape ``(sets, ndim)``)."""

    def residuals(self, values: Mapping[str, float]) -> np.ndarray:
        """Standardised residuals of the readings (finite; large on failure)."""

    def loglike_pointwise(self, values: Mapping[str, float]) -> np.ndarray:
        """Log-likelihood of each reading (for PSIS-LOO); may raise when the model fails."""

    def expected(self, values: Mapping[str, float]) -> np.ndarray:
        """Noise-free expected readings, in :attr:`reading_units`."""

    def obs_coords(self) -> dict[str, Any]:
        """Coordinates of the readings: ``obs`` plus ``curve`` (a label per reading) and any
        of ``x`` (the quantity readings are plotted against, with ``units`` and
        ``long_name`` attributes), ``swing``, ``load``, ``time``."""

    def provenance(self) -> dict[str, Any]:
        """``scene`` (text), ``scene_file``, ``data_file``, ``data_sha256``, ``data_kind``,
        ``solver``, ``solver_options`` and anything else the family records."""

    def derived(self, values: Mapping[str, float]) -> dict[str, float]:
        """Quantities computed from the parameters and stored with the posterior."""

    def checks_at_best_fit(self, best: Mapping[str, float]) -> tuple[dict, list[str]]:
        """Family-specific misfit figures and warnings at the least-squares optimum."""

    def checks_of_posterior(self, chain: np.ndarray) -> list[str]:
        """Family-specific warnings from posterior draws, shape ``(walkers, draws, ndim)``."""

    def consistency(self, values: Mapping[str, float]) -> list:
        """What the recording measures directly about parameters, at ``values``
        (:class:`~escfit.likelihood.consistency.Implied`; empty when it measures nothing)."""

    def holding(self, name: str, value: float) -> "Problem":
        """A copy of the problem with a parameter it holds fixed (one it chose to hold, such as
        an omega0 taken from the measured period) at ``value``; the problem itself never changes."""


def gaussian_prior_residuals(priors, x: np.ndarray) -> np.ndarray:
    """Residuals whose squares add the Gaussian priors' ``-2 log p`` to a least-squares cost.

    ``normal(mu, sd)`` gives ``(x - mu)/sd``, ``halfnormal(sd)`` gives ``x/sd`` and
    ``lognormal(mu, s)`` gives ``(log x - mu)/s``, so least squares finds the maximum of the
    posterior when a prior pins what the data alone cannot (measured geometry, a lift angle).
    Flat priors (``uniform``, ``loguniform``) only bound the search and give no residual.
    """
    out = []
    for pr, v in zip(priors, x):
        a = pr.args
        if pr.kind == "normal":
            out.append((v - a[0]) / a[1])
        elif pr.kind == "halfnormal":
            out.append(v / a[0])
        elif pr.kind == "lognormal":
            out.append((math.log(v) - a[0]) / a[1] if v > 0 else 1e6)
    return np.asarray(out, float)


def stacked_residuals(r: np.ndarray, priors, x: np.ndarray) -> np.ndarray:
    """The readings' residuals ``r`` and the Gaussian priors' ones at ``x``, failures made large and finite."""
    out = np.concatenate([r, gaussian_prior_residuals(priors, x)])
    return np.where(np.isfinite(out), out, FAIL_RESIDUAL)


def gaussian_prior_slopes(priors, x: np.ndarray) -> np.ndarray:
    """Derivatives of :func:`gaussian_prior_residuals` by ``x``: one row per Gaussian prior,
    shape (rows, len(x)), the prior's own parameter's column non-zero."""
    rows = []
    for i, (pr, v) in enumerate(zip(priors, x)):
        if pr.kind not in ("normal", "halfnormal", "lognormal"):
            continue
        row = np.zeros(len(x))
        a = pr.args
        row[i] = 1.0 / a[-1] if pr.kind != "lognormal" else (1.0 / (v * a[1]) if v > 0 else 0.0)
        rows.append(row)
    return np.array(rows, float).reshape(len(rows), len(x))


class ProblemBase:
    """Defaults of the optional parts of :class:`Problem`, for families to inherit.

    A subclass sets the attributes of :class:`Problem` (``params``, a
    :class:`~escfit.core.params.ParamSet`, gives ``units`` and ``meanings``) and implements ``values``,
    ``log_prior``, ``log_likelihood(values)``, ``residuals``, ``loglike_pointwise``,
    ``expected``, ``observed``, ``obs_coords`` and ``provenance``.
    """

    vectorized = False
    #: coordinates emcee samples in (:mod:`escfit.likelihood.coordinates`); None: the parameters themselves
    sampler_coordinates = None
    notes: tuple[str, ...] = ()  # instances set their own lists
    data_warnings: tuple[str, ...] = ()
    #: what a record's analysis adds (a balance problem built from a record; see its RecordFacts)
    measured_period = None
    turning_points = None
    other_modes: tuple = ()
    record_window = None
    given_scene = None
    #: name -> (low, high): where the multistart's Latin hypercube draws a parameter the record has
    #: measured (a frequency's basin), in place of its prior or bounds
    start_spans: dict[str, tuple[float, float]] = {}

    #: derived quantities: name -> (canonical unit, meaning)
    DERIVED: dict[str, tuple[str, str]] = {}

    @property
    def noise_names(self) -> tuple[str, ...]:
        """``observation.sigma`` when it is free: least squares profiles it, emcee samples it."""
        return tuple(n for n in ("observation.sigma",) if n in self.names)

    @property
    def units(self) -> dict[str, str]:
        """Unit of every parameter (``self.params``) and derived quantity (:attr:`DERIVED`)."""
        return {**{p.name: p.unit for p in self.params}, **{k: u for k, (u, _) in self.DERIVED.items()}}

    @property
    def meanings(self) -> dict[str, str]:
        """One-line meaning of every parameter and derived quantity."""
        return {**{p.name: p.meaning for p in self.params}, **{k: m for k, (_, m) in self.DERIVED.items()}}

    def log_prob(self, vec: np.ndarray) -> float:
        lp = self.log_prior(vec)
        if not math.isfinite(lp):
            return -math.inf
        return lp + self.log_likelihood(self.values(vec))

    def log_prob_many(self, vecs: np.ndarray) -> np.ndarray:
        return np.array([self.log_prob(v) for v in np.atleast_2d(np.asarray(vecs, float))])

    def derived(self, values: Mapping[str, float]) -> dict[str, float]:
        return {}

    def checks_at_best_fit(self, best: Mapping[str, float]) -> tuple[dict, list[str]]:
        return {}, []

    def checks_of_posterior(self, chain: np.ndarray) -> list[str]:
        return []

    def consistency(self, values: Mapping[str, float]) -> list:
        return []

    held: tuple[str, ...] = ()  # fixed parameters the problem chose to hold and may move (see hold)

    def holding(self, name: str, value: float) -> "Problem":
        from ..core.errors import FitError

        raise FitError(f"{name} is not a parameter this problem holds")

    @property
    def n_data(self) -> int:
        return int(np.asarray(self.observed).size)
