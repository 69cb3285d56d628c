"""Friction of a verge S&A mechanism from observed turns-to-arm: the fit problem.

Observation model
-----------------
A reading is one arming test at spin rate ``spin_i`` (rpm); the likelihood is Gaussian in
turns::

    turns_i ~ Normal(T(theta, spin_i), sigma_i)

with ``T`` the simulated turns-to-arm (:func:`escfit.verge.simulate.run`, compiled RK4 at
:data:`FIT_STEP` rad of spin unless the scene's ``[fit] step`` says otherwise).  The noise
``sigma_i`` is the scene's ``observation.sigma`` (turns; fixed, or free with a prior) when
the scene has an ``[observation]`` table with ``sigma``, else the data's ``sd`` column, taken
as known.  A parameter set for which the mechanism does not arm (it stalls, or runs out of
time) or for which the simulation fails has likelihood zero: ``-inf`` log probability and
a residual of 1e6, with the reason counted in :attr:`TurnsProblem.failures`.

Free parameters and their priors come from the scene (``mu = { value = 0.1, vary = true,
min = 0, max = 0.3 }``); ``mu1 = "mu"`` ties the escapement's coefficient to the gear
train's (the report's single "system coefficient of friction").  With both free, turns to
arm measure only a combination of the two (a ridge).

Spin rate
---------
Every load in the model is proportional to ``omega**2``, so with a coefficient of
restitution of zero the turns to arm do not depend on the spin rate (the motion is the
same in fuze revolutions): the forward model then runs once per parameter set and readings
at several spin rates are replicates.  With ``restitution > 0`` the fixed capture speed
after an impact breaks the invariance and each spin rate is simulated.
"""

from __future__ import annotations

import math
from collections import Counter, OrderedDict
from typing import Any, Mapping

import numpy as np

from ..core.errors import EscfitError, FitError, SceneError
from ..core.params import Param, ParamSet, read_param
from ..core.scene import check_keys
from ..core.units import quantity
from ..likelihood.freeparams import FreeParameters
from ..likelihood.problem import FAIL_RESIDUAL, ProblemBase
from .data import FORMAT, TurnsData
from .scene import VergeScene
from .simulate import run

__all__ = ["TurnsProblem", "FIT_STEP", "FAIL_RESIDUAL", "OBSERVATION_KEYS", "FIT_KEYS"]

#: RK4 step (rad of spin) of fits: turns to arm within 1e-7 of the converged value
FIT_STEP = 0.04
OBSERVATION_KEYS = {"sigma"}
FIT_KEYS = {"step"}
SIGMA = "observation.sigma"
_CACHE = 16
_LOG_SQRT_2PI = 0.5 * math.log(2 * math.pi)


def _turns(raw: Any, where: str) -> Any:
    """A number of turns: bare numbers are turns, strings may carry an angle unit ('0.3 turn')."""
    if isinstance(raw, str):
        q = quantity(raw, where)
        try:
            return float(q.magnitude) if q.unitless else float(q.to("turn").magnitude)
        except Exception as exc:  # pint raises several types
            raise SceneError(f"cannot read {raw!r} as a number of turns ({exc})", where) from None
    return raw


def sigma_param(raw: Any, where: str) -> Param:
    """``observation.sigma`` (turns) from the scene's ``[observation] sigma``."""
    w = f"{where} [observation.sigma]"
    if isinstance(raw, Mapping):
        raw = {k: (_turns(v, f"{w}.{k}") if k in ("value", "min", "max") else v) for k, v in raw.items()}
    else:
        raw = _turns(raw, w)
    return read_param(raw, name=SIGMA, kind="dimensionless", unit="turns",
                      meaning="standard deviation of a turns-to-arm reading (reading noise)", where=w, lower=0.0,
                      lower_open=True)


class TurnsProblem(FreeParameters, ProblemBase):
    """A verge scene with free parameters + turns-to-arm readings: the posterior's pieces.

    Parameters
    ----------
    scene : VergeScene
        Its ``vary = true`` parameters are estimated, with their priors (``prior = "..."``,
        else uniform on ``[min, max]``); ``[observation] sigma`` gives the reading noise and
        ``[fit] step`` the RK4 step.
    data : TurnsData
    step : float, optional
        RK4 step (rad of spin), overriding the scene's ``[fit] step`` (default :data:`FIT_STEP`).

    Raises
    ------
    SceneError
        Unknown keys in ``[observation]`` or ``[fit]``, no noise (neither ``[observation]
        sigma`` nor an ``sd`` column), a bad step.
    FitError
        Nothing free, a free spin rate (the readings set it), a free parameter without a
        proper prior.
    """

    family = "verge"
    reading_units = "turns"
    vectorized = False
    misfit_options: dict = {}
    lsq_options = {"diff_step": 1e-5}  # turns(mu) is smooth to ~1e-9 turns; 1e-5 keeps differences clean

    def __init__(self, scene: VergeScene, data: TurnsData, *, step: float | None = None):
        if getattr(scene, "model", None) != "verge":
            raise FitError(f"turns-to-arm fits need a verge scene, got model {getattr(scene, 'model', None)!r}",
                           getattr(scene, "where", None))
        if not isinstance(data, TurnsData):
            raise FitError(f"a verge fit reads turns-to-arm data, got {type(data).__name__}", scene.where)
        self.scene, self.data = scene, data
        self.notes: list[str] = []
        self.data_warnings: list[str] = []
        self.failures: Counter = Counter()
        self._cache: OrderedDict = OrderedDict()
        fit_table = scene.extra.get("fit", {})
        check_keys(fit_table, FIT_KEYS, f"{scene.where} [fit]")
        self.step = float(step if step is not None else fit_table.get("step", FIT_STEP))
        if isinstance(fit_table.get("step"), bool) or not (self.step > 0 and math.isfinite(self.step)):
            raise SceneError(f"the RK4 step must be a positive number of radians of spin, got "
                             f"{fit_table.get('step', step)!r}", f"{scene.where} [fit.step]")
        obs = scene.extra.get("observation")
        params = ParamSet(dict(scene.params.params))
        if obs is not None:
            check_keys(obs, OBSERVATION_KEYS, f"{scene.where} [observation]")
        if obs is not None and "sigma" in obs:
            params.add(sigma_param(obs["sigma"], scene.where))
            self.notes.append("reading noise: observation.sigma from the scene's [observation] table"
                              + (", free (sampled; profiled by least squares)" if params[SIGMA].vary else ", fixed")
                              + (" (the data's sd column is not used)" if data.sd is not None else ""))
        elif data.sd is not None:
            self.notes.append("reading noise: the data's sd column, taken as known (the scene gives no "
                              "[observation] sigma)")
        else:
            raise SceneError("the data have no sd column: give the reading noise as [observation] sigma "
                             "(turns; fixed, or { value = ..., vary = true, prior = ... })",
                             f"{scene.where} [observation.sigma]")
        if params["verge.spin"].vary:
            raise FitError("verge.spin cannot be free: each reading sets the spin rate", f"{scene.where} [verge.spin]")
        self._set_free(params, scene.where)
        improper = [n for n, p in zip(self.names, self.priors) if not p.proper]
        if improper:
            raise FitError(f"free parameter(s) {improper} need a proper prior: give min and max or prior = '...'",
                           scene.where)
        self._verge = [p.name for p in scene.params]
        self.restitution_free = "verge.restitution" in self.names
        spins = np.unique(data.spin_rpm)
        if params.values()["verge.restitution"] == 0 and not self.restitution_free and spins.size > 1:
            self.notes.append(f"restitution 0: turns to arm do not depend on the spin rate, so the {spins.size} spin "
                              "rates are replicates and the mechanism is simulated once per parameter set")

    # -- the parts of Problem ------------------------------------------------------------
    @property
    def units(self) -> dict[str, str]:
        # the scene stores the spin rate in rad/s (a frequency kind)
        return {**super().units, "verge.spin": "rad/s"}

    @property
    def observed(self) -> np.ndarray:
        return self.data.turns

    def sigma(self, values: Mapping[str, float]) -> np.ndarray:
        """Standard deviation of each reading (turns)."""
        if SIGMA in self.params:
            return np.full(self.data.n, float(values[SIGMA]))
        return self.data.sd

    # -- forward model -------------------------------------------------------------------
    def predict(self, values: Mapping[str, float]) -> tuple[np.ndarray | None, str]:
        """Simulated turns to arm of each reading, or ``(None, reason)`` when it does not arm.

        Runs are cached by parameter values (the noise does not enter), so the expected
        readings and the pointwise log-likelihood of a draw cost one simulation.  Each failed
        simulation is counted once in :attr:`failures`.
        """
        vals = {n: float(values[n]) for n in self._verge}
        restitution = vals["verge.restitution"]
        spins = np.unique(self.data.spin_rpm) if restitution > 0 else self.data.spin_rpm[:1]
        out = {}
        for rpm in spins:
            turns, reason = self._simulate(vals, float(rpm))
            if turns is None:
                return None, reason
            out[float(rpm)] = turns
        if restitution > 0:
            return np.array([out[float(r)] for r in self.data.spin_rpm]), ""
        return np.full(self.data.n, out[float(spins[0])]), ""

    def _simulate(self, vals: dict[str, float], rpm: float) -> tuple[float | None, str]:
        key = (tuple(vals.values()), rpm)
        hit = self._cache.get(key)
        if hit is not None:
            self._cache.move_to_end(key)
            return hit
        omega = rpm * math.pi / 30
        try:
            res = run(self.scene, dict(vals, **{"verge.spin": omega}), step=self.step, record=False)
            if res.status == "armed":
                out = (res.time_to_arm * omega / (2 * math.pi), "")
            else:
                out = (None, f"{res.status}: {res.reason}")
        except SceneError as exc:  # a value outside the physical range or geometry that cannot close
            out = (None, f"scene refused the values: {exc.message}"[:120])
        except (EscfitError, ValueError, ArithmeticError) as exc:
            out = (None, f"simulation failed: {exc}"[:120])
        if out[0] is not None and not math.isfinite(out[0]):
            out = (None, "non-finite turns to arm")
        if out[0] is None:
            self.failures[out[1]] += 1
        self._cache[key] = out
        if len(self._cache) > _CACHE:
            self._cache.popitem(last=False)
        return out

    # -- likelihood ----------------------------------------------------------------------
    def loglike_pointwise(self, values: Mapping[str, float]) -> np.ndarray:
        """Gaussian log-likelihood of each reading (``-inf`` everywhere when it does not arm)."""
        pred, _reason = self.predict(values)
        if pred is None:
            return np.full(self.data.n, -math.inf)
        s = self.sigma(values)
        z = (self.data.turns - pred) / s
        return -0.5 * z * z - np.log(s) - _LOG_SQRT_2PI

    def log_likelihood(self, values: Mapping[str, float]) -> float:
        ll = float(np.sum(self.loglike_pointwise(values)))
        return ll if math.isfinite(ll) else -math.inf

    def residuals(self, values: Mapping[str, float]) -> np.ndarray:
        """``(observed - simulated) / sigma`` per reading; 1e6 when the mechanism does not arm."""
        pred, _reason = self.predict(values)
        if pred is None:
            return np.full(self.data.n, FAIL_RESIDUAL)
        return (self.data.turns - pred) / self.sigma(values)

    def expected(self, values: Mapping[str, float]) -> np.ndarray:
        """Simulated turns to arm of each reading.

        Raises
        ------
        FitError
            The mechanism does not arm at these values (the reason is in the message).
        """
        pred, reason = self.predict(values)
        if pred is None:
            shown = {n: values[n] for n in self.names}
            raise FitError(f"the mechanism does not arm at {shown} ({reason})", self.scene.where)
        return pred

    # -- records -------------------------------------------------------------------------
    def obs_coords(self) -> dict[str, Any]:
        return {"obs": np.arange(self.data.n), "curve": ("obs", np.array(self.data.labels, dtype=str)),
                "x": ("obs", self.data.spin_rpm, {"units": "rpm", "long_name": "spin rate"})}

    def provenance(self) -> dict[str, Any]:
        return {"scene": self.scene.text, "scene_file": self.scene.where, "data_file": self.data.source,
                "data_sha256": self.data.sha256, "data_kind": FORMAT, "solver": "rk4",
                "solver_options": {"step": self.step}}

    def checks_at_best_fit(self, best: Mapping[str, float]) -> tuple[dict, list[str]]:
        warnings = []
        if "verge.mu" in self.names and "verge.mu1" in self.names:
            warnings.append("verge.mu and verge.mu1 are both free: turns to arm measure a combination of the two "
                            "(a ridge in the posterior); separating them needs other data")
        return {}, warnings
