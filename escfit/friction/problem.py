"""The friction rig's fit problem: one session on the one inference layer (:mod:`escfit.inference`).

:class:`RigProblem` implements :class:`~escfit.likelihood.problem.Problem` on top of the
session model (:class:`~escfit.friction.likelihood.SessionModel`), which stays the forward and
observation layer:

* forward model: ``dw_i = mu_i w_i / r(k, d)`` (or the calibration form), ``r = a/d``, with
  ``mu_i`` from the scene's friction law; closed form, no solver;
* observation model: independent normal reading errors of standard deviation
  ``observation.sigma`` (N), known (the scene's ``[observation]`` ``sigma`` or ``resolution``)
  or free (no ``[observation]``: least squares profiles it, the sampler samples it);
* priors: the scene's, explicit for every sampled parameter (normal for measured geometry).

The geometry priors are what makes this a posterior rather than a fit: the shared error of
``k`` and ``d`` moves every reading of the session together, so it never averages out, and
least squares (:func:`escfit.inference.lsq.least_squares`) adds the normal priors' residuals
``(k - k_measured)/sd_k`` itself.  When the noise scale is free it is re-estimated until it
agrees with the reading residuals over ``readings - parameters no Gaussian prior pins``
degrees of freedom.

:meth:`RigProblem.log_prob_many` is the session model's whole-array log posterior, so emcee
evaluates an ensemble in one call (:attr:`RigProblem.vectorized`); :meth:`RigProblem.log_prob`
is its one-row case, giving the same numbers.  A parameter point where the friction law gives
``mu < 0`` at some reading, or where friction out-levers the load (calibration form), has log
probability ``-inf`` (least squares: residual 1e6) and the reason is counted in
:attr:`RigProblem.failures`.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any, Mapping

import numpy as np
from scipy import stats

from ..likelihood.problem import FAIL_RESIDUAL, ProblemBase
from .likelihood import SessionModel, build_model
from .readers import Readings
from .rig import mu_from_reading
from .scene import SIGMA, RigScene

__all__ = ["RigProblem", "LAW", "FAIL_RESIDUAL", "LEVER_RATIO"]

LAW = ("friction.mu", "friction.mu_w", "friction.mu_v")
LEVER_RATIO = "rig.lever_ratio"
_GEOMETRY = "no real geometry (d >= k: the stylus cannot reach the disc)"
_NEG_MU = "the friction law gives mu < 0 at some reading"
_OUT_LEVER = "friction out-levers the load at some reading (calibration form, mu >= a/d)"
_SCATTER_P = 1e-3  # two-sided chi-square probability below which the stated reading noise is doubted


class RigProblem(ProblemBase):
    """One rig session (one material, one stylus set-up) and its scene, prepared once.

    Parameters
    ----------
    scene
        A ``friction_rig`` scene (:func:`escfit.friction.scene.parse`).
    readings
        The session's readings (one material).
    sha256
        SHA-256 of the readings file's bytes (``""`` for readings built in memory).
    material
        The material selected from a file holding several (recorded in the notes).

    Raises
    ------
    FitError
        No readings, several materials, a speed law without a speed column, or nothing to fit
        (see :func:`escfit.friction.likelihood.build_model`).
    """

    family = "friction_rig"
    reading_units = "N"
    vectorized = True
    misfit_options: dict = {}
    lsq_options: dict = {}

    DERIVED = {LEVER_RATIO: ("", "lever ratio a/d = sqrt(k^2/d^2 - 1) of the rig (derived)")}

    def __init__(self, scene: RigScene, readings: Readings, *, sha256: str = "", material: str | None = None):
        self.scene = scene
        self.readings = readings
        self.model: SessionModel = build_model(scene, readings)
        self.names = list(self.model.names)
        self.priors = [scene.priors[n] for n in self.names]
        self.failures: Counter = Counter()
        self.sha256 = sha256
        self.material = material
        self.params = scene.params
        self.notes = [scene.noise_note]
        if material is not None:
            self.notes.append(f"kept the {len(readings)} readings of material {material!r} from {readings.where}")
        self.data_warnings: list[str] = []
        self._initial = self._start()
        self._base = dict(self.model.fixed)
        self._base.update(zip(self.names, map(float, self._initial)))

    # -- parameters ---------------------------------------------------------------------------

    def _start(self) -> np.ndarray:
        """The scene's values, with mu started from the readings at the nominal geometry and an
        estimated reading noise from the readings' spread (both inside the bounds)."""
        start = dict(self.model.fixed)
        r = self.readings
        if "friction.mu" in self.names:
            mu_each = mu_from_reading(r.load, r.dw, start["rig.k"], start["rig.d"], self.scene.load_at)
            mu0 = float(np.median(mu_each))
            if math.isfinite(mu0):
                start["friction.mu"] = mu0
        if SIGMA in self.names and self.scene.noise_route == "estimated":
            spread = float(np.std(r.dw))
            start[SIGMA] = spread if spread > 0 else max(float(np.mean(r.dw)) * 1e-3, 1e-9)
        x = np.array([start[n] for n in self.names], float)
        lo, hi = self.bounds
        return np.clip(x, lo, hi)

    @property
    def initial(self) -> np.ndarray:
        return self._initial.copy()

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return np.array([p.lo for p in self.priors]), np.array([p.hi for p in self.priors])

    def values(self, vec: np.ndarray | Mapping[str, float]) -> dict[str, float]:
        vals = dict(self._base)
        if isinstance(vec, Mapping):
            vals.update({k: float(v) for k, v in vec.items()})
        else:
            vals.update(zip(self.names, map(float, np.asarray(vec, float).ravel())))
        return vals

    def _theta(self, values: Mapping[str, float]) -> np.ndarray:
        return np.array([[values[n] for n in self.names]], float)

    # -- readings -----------------------------------------------------------------------------

    @property
    def observed(self) -> np.ndarray:
        return self.readings.dw

    @property
    def n_data(self) -> int:
        return len(self.readings)

    def expected(self, values: Mapping[str, float]) -> np.ndarray:
        """Noise-free ``dw`` (N) of each reading; NaN where the law or the geometry fails."""
        return self.model.predict(self._theta(values))[0]

    def residuals(self, values: Mapping[str, float]) -> np.ndarray:
        """``(dw - expected) / sigma`` per reading; 1e6 where the model fails (reason counted)."""
        r = (self.readings.dw - self.expected(values)) / values[SIGMA]
        if not np.all(np.isfinite(r)):
            self._count_failures(self._theta(values))
            r = np.where(np.isfinite(r), r, FAIL_RESIDUAL)
        return r

    def loglike_pointwise(self, values: Mapping[str, float]) -> np.ndarray:
        return self.model.pointwise_loglik(self._theta(values))[0]

    # -- log posterior ------------------------------------------------------------------------

    def log_prior(self, vec: np.ndarray) -> float:
        return float(self.model.log_prior(np.asarray(vec, float)[None, :])[0])

    def log_likelihood(self, values: Mapping[str, float]) -> float:
        theta = self._theta(values)
        ll = float(self.model.pointwise_loglik(theta).sum())
        if not math.isfinite(ll):
            self._count_failures(theta)
            return -math.inf
        return ll

    def log_prob(self, vec: np.ndarray) -> float:
        """The one-row case of :meth:`log_prob_many` (the same numbers)."""
        return float(self.log_prob_many(np.asarray(vec, float)[None, :])[0])

    def log_prob_many(self, vecs: np.ndarray) -> np.ndarray:
        """Log posterior (up to a constant) of each row of ``vecs``, in one whole-array pass."""
        theta = np.atleast_2d(np.asarray(vecs, float))
        lp, ll = self.model.log_prob_parts(theta)
        ok = np.isfinite(lp)
        failed = ok & ~np.isfinite(ll)
        if np.any(failed):
            self._count_failures(theta[failed])
        out = np.full(lp.shape, -np.inf)
        good = ok & ~failed
        out[good] = lp[good] + ll[good]
        return out

    def _count_failures(self, theta: np.ndarray) -> None:
        """Count why these parameter rows give no finite likelihood."""
        v = self.model.unpack(theta)
        geometry = ~((v["rig.d"] > 0) & (v["rig.k"] > v["rig.d"]))
        neg = np.any(self.model.mu(v) < 0, axis=1) & ~geometry
        for reason, rows in ((_GEOMETRY, geometry), (_NEG_MU, neg), (_OUT_LEVER, ~geometry & ~neg)):
            if np.any(rows):
                self.failures[reason] += int(np.sum(rows))

    # -- what the results record --------------------------------------------------------------

    def obs_coords(self) -> dict[str, Any]:
        r = self.readings
        label = np.array(r.material if r.material is not None else [""] * len(r), dtype=str)
        long_name = ("normal load w while sliding" if self.scene.load_at == "reading"
                     else "calibration load w (normal load while sliding w + dw)")
        coords: dict[str, Any] = {"obs": np.arange(len(r)), "curve": ("obs", label),
                                  "x": ("obs", r.load, {"units": "N", "long_name": long_name})}
        if r.speed is not None:
            coords["speed"] = ("obs", r.speed, {"units": "m/s", "long_name": "sliding speed"})
        return coords

    def provenance(self) -> dict[str, Any]:
        sc = self.scene
        return {"scene": sc.text, "scene_file": sc.where, "data_file": self.readings.where,
                "data_sha256": self.sha256, "data_kind": "rig-readings", "solver": "closed_form",
                "solver_options": {}, "load_at": sc.load_at, "load_ref_N": sc.load_ref, "speed_ref_m_s": sc.speed_ref,
                "material": self.material or "", "priors": {n: p.describe() for n, p in zip(self.names, self.priors)}}

    def derived(self, values: Mapping[str, float]) -> dict[str, float]:
        """The lever ratio ``a/d`` through which the geometry enters every reading."""
        k, d = values["rig.k"], values["rig.d"]
        return {LEVER_RATIO: math.sqrt((k / d) ** 2 - 1.0) if 0 < d < k else math.nan}  # rig.lever_ratio, scalar

    def checks_at_best_fit(self, best: Mapping[str, float]) -> tuple[dict, list[str]]:
        """With a known reading noise: is the readings' scatter about the best fit consistent with it?

        ``chi2 = sum(residual^2)`` over ``readings - friction-law parameters`` degrees of
        freedom (the geometry only scales the readings, it absorbs no scatter) is compared with
        its chi-square distribution; a two-sided probability below 1e-3 is warned.
        """
        if SIGMA in self.names:
            return {}, []
        r = np.asarray(self.residuals(best), float)
        dof = self.n_data - sum(n in self.names for n in LAW)
        if dof < 1 or not np.all(np.abs(r) < FAIL_RESIDUAL):
            return {}, []
        chi2 = float(r @ r)
        ratio = math.sqrt(chi2 / dof)
        p = 2.0 * min(stats.chi2.cdf(chi2, dof), stats.chi2.sf(chi2, dof))
        warnings = []
        if p < _SCATTER_P:
            how = "more" if ratio > 1 else "less"
            warnings.append(
                f"the readings scatter {ratio:.2f} times the stated reading noise observation.sigma = "
                f"{best[SIGMA]:.4g} N ({how} than it allows, chi-square probability {p:.1e}): the intervals assume "
                "the stated noise; check the resolution and calibration in [observation], or leave sigma free")
        return {"reading_scatter_over_sigma": ratio}, warnings
