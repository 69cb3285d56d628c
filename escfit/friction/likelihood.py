"""Observation model, priors and log posterior of one rig session.

Each reading ``i`` gives ``dw_i = g(mu_i, w_i; k, d) + e_i`` where ``g`` is the rig statics
(:func:`escfit.friction.rig.predicted_dw`), ``mu_i`` follows the scene's friction law, the
geometry ``(k, d)`` is the *same* for every reading of the session, and the reading errors
``e_i ~ Normal(0, sigma)`` are independent, ``sigma`` being the reading noise
``observation.sigma`` (N).  Measured geometry enters through normal priors
centred on the measured values: the shared geometry error is a nuisance parameter that
moves all readings together, so it does not average out with more readings.

The functions here are vectorised over parameter sets: ``theta`` has shape
``(n_sets, n_free)`` so that emcee can evaluate a whole ensemble in one call.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import FitError
from .readers import Readings
from .rig import mu_law, predicted_dw
from .scene import SIGMA, RigScene

__all__ = ["SessionModel", "build_model"]


@dataclass(frozen=True)
class SessionModel:
    """The log posterior of one session, with the free parameters in a fixed order.

    Attributes
    ----------
    scene, readings
        What the model was built from.
    names
        Free parameter names (the columns of ``theta``).
    fixed
        Values of every parameter, used where a name is not free.
    """

    scene: RigScene
    readings: Readings
    names: tuple[str, ...]
    fixed: dict[str, float]

    @property
    def ndim(self) -> int:
        return len(self.names)

    def unpack(self, theta) -> dict[str, np.ndarray]:
        """All parameter values for each row of ``theta`` (shape ``(n_sets,)`` each)."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        out = {n: np.full(theta.shape[0], v) for n, v in self.fixed.items()}
        for j, n in enumerate(self.names):
            out[n] = theta[:, j]
        return out

    def mu(self, values: dict[str, np.ndarray]) -> np.ndarray:
        """Friction coefficient of each reading, shape ``(n_sets, n_readings)``."""
        r = self.readings
        speed = r.speed if r.speed is not None else np.zeros_like(r.load)
        return mu_law(
            values["friction.mu"][:, None], r.load[None, :], speed[None, :],
            mu_w=values["friction.mu_w"][:, None] if "friction.mu_w" in values else 0.0,
            mu_v=values["friction.mu_v"][:, None] if "friction.mu_v" in values else 0.0,
            load_ref=self.scene.load_ref, speed_ref=self.scene.speed_ref,
        )

    def _predicted(self, v: dict[str, np.ndarray]) -> np.ndarray:
        mu = self.mu(v)
        dw = predicted_dw(self.readings.load[None, :], mu, v["rig.k"][:, None], v["rig.d"][:, None],
                          self.scene.load_at)
        return np.where(mu >= 0, dw, np.nan)

    def predict(self, theta) -> np.ndarray:
        """Predicted ``dw`` (N), shape ``(n_sets, n_readings)``; NaN where impossible."""
        return self._predicted(self.unpack(theta))

    def _log_prior(self, theta: np.ndarray, v: dict[str, np.ndarray]) -> np.ndarray:
        out = np.zeros(theta.shape[0])
        for j, n in enumerate(self.names):
            out = out + self.scene.priors[n].logpdf(theta[:, j])
        return np.where(v["rig.d"] < v["rig.k"], out, -np.inf)

    def log_prior(self, theta) -> np.ndarray:
        """Sum of the explicit priors, ``-inf`` outside any support or for ``d >= k``."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        return self._log_prior(theta, self.unpack(theta))

    def _pointwise(self, v: dict[str, np.ndarray]) -> np.ndarray:
        sd = v[SIGMA][:, None]
        resid = (self.readings.dw[None, :] - self._predicted(v)) / sd
        ll = -0.5 * resid**2 - np.log(sd) - 0.5 * np.log(2 * np.pi)
        return np.where(np.isfinite(ll), ll, -np.inf)

    def pointwise_loglik(self, theta) -> np.ndarray:
        """Log likelihood of each reading, shape ``(n_sets, n_readings)``."""
        return self._pointwise(self.unpack(theta))

    def log_prob_parts(self, theta) -> tuple[np.ndarray, np.ndarray]:
        """Log prior and log likelihood of each row of ``theta`` (the likelihood ``-inf`` where the
        model fails, ``nan`` where the prior already excludes the row), one unpacking for both."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        v = self.unpack(theta)
        lp = self._log_prior(theta, v)
        ok = np.isfinite(lp)
        ll = np.full(lp.shape, np.nan)
        if np.any(ok):
            part = self._pointwise({n: a[ok] for n, a in v.items()}).sum(axis=1)
            ll[ok] = np.where(np.isfinite(part), part, -np.inf)
        return lp, ll

    def log_prob(self, theta) -> np.ndarray:
        """Log posterior (up to a constant) of each row of ``theta``; ``-inf`` when invalid."""
        lp, ll = self.log_prob_parts(theta)
        ok = np.isfinite(lp)
        out = np.full(lp.shape, -np.inf)
        out[ok] = lp[ok] + ll[ok]
        return out


def build_model(scene: RigScene, readings: Readings) -> SessionModel:
    """Check that a scene and a session fit together and build the session model.

    Raises
    ------
    FitError
        No readings, several materials in one session, a speed law without a speed column,
        or no free parameter.
    """
    where = readings.where
    if len(readings) == 0:
        raise FitError("the session has no readings", where)
    mats = readings.materials()
    if len(mats) > 1:
        raise FitError(
            f"one session must hold one material, found {mats}; select one (the fit's material option, or "
            f"Readings.only(...))", where
        )
    if "speed" in scene.laws and readings.speed is None:
        raise FitError(
            "the scene has a speed law (friction.mu_v) but the readings have no speed_<unit> column", where
        )
    names = tuple(scene.free_names())
    if not names:
        raise FitError("nothing to fit: no parameter varies or carries an sd", scene.where)
    fixed = scene.params.values()
    return SessionModel(scene=scene, readings=readings, names=names, fixed=fixed)
