"""The Geneva fit problem: scene + recording -> likelihood and residuals for :mod:`escfit.inference`.

Layers, each explicit:

* forward model (:meth:`GenevaProblem.predict`): parameter values -> expected readings.
  A speed trace is the driver speed from release at rest, by
  :func:`escfit.geneva.simulate.forward` (rk4, step ``dt = 1e-3`` in units of
  ``sqrt(I_f/K)``: ~1e-7 relative error, twice as cheap as the simulator's default).
  Terminal speeds use the exact scaling of the equation of motion, whose one time scale is
  ``sqrt(I_f/K)``: every terminal speed is proportional to ``sqrt(K/I_f)``, so one terminal
  cycle (:func:`escfit.geneva.terminal.terminal_cycle`) per parameter point serves all
  torques, each multiplied by an optional common factor ``geneva.torque_scale`` on the
  nominal torques (the scene's ``[fit] torque_scale``);
* observation model: every reading is the expectation plus independent Gaussian noise of
  standard deviation ``observation.sigma`` (rad/s), declared in the scene's ``[observation]``
  table (``sigma = 0.5`` fixed, or ``sigma = { value = 1, vary = true, prior =
  "loguniform(0.01, 100)" }`` free: least squares then profiles it and the sampler samples
  it); when the scene gives no ``[observation]`` and the data carry an ``sd`` column, that
  sd is the known noise of each reading;
* priors: from the scene's parameter tables (``prior = "..."``, ``min``, ``max``); a free
  parameter needs a proper prior (finite bounds or a prior string).

A forward run that fails (the pin locks, no terminal velocity) gives ``-inf`` log
probability, or residuals of 1e6 in least squares, and the reason is counted in
:attr:`GenevaProblem.failures`.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any, Mapping

import numpy as np

from ..core.errors import EscfitError, FitError, SceneError
from ..core.params import ParamSet, read_param
from ..core.scene import check_keys
from ..likelihood.freeparams import FreeParameters
from ..likelihood.priors import prior_of
from ..likelihood.problem import FAIL_RESIDUAL, ProblemBase
from .data import SpeedTrace, TerminalSpeeds
from .engines import ENGINES
from .simulate import forward
from .terminal import terminal_cycle

__all__ = ["GenevaProblem", "ForwardFailure", "TORQUE_SCALE", "FIT_OPTIONS", "OBSERVATION_KEYS", "FIT_KEYS"]

TORQUE_SCALE = "geneva.torque_scale"
SIGMA = "observation.sigma"
FIT_OPTIONS = {"dt": 1e-3}  # rk4 step in units of sqrt(I_f/K): ~1e-7 relative error, 2x cheaper than simulate's
OBSERVATION_KEYS = {"sigma"}
FIT_KEYS = {"torque_scale", "table_mu"}


class ForwardFailure(FitError):
    """The forward model has no answer at these parameters (``reason``: locked, no_terminal ...)."""

    def __init__(self, reason: str):
        super().__init__(f"the Geneva forward model failed: {reason}")
        self.reason = reason


class GenevaProblem(FreeParameters, ProblemBase):
    """A Geneva fit: scene + speed trace or terminal speeds, prepared once.

    Parameters
    ----------
    scene
        A Geneva scene; parameters with ``vary = true`` are estimated.  Its ``[observation]``
        table gives the reading noise ``sigma``; its ``[fit]`` table (terminal speeds only)
        may give ``torque_scale`` (a parameter: the common factor on the nominal torques) and
        ``table_mu`` (keep only the runs of the file's ``mu`` column equal to it: one run
        family of a whole Meyer table).
    data
        A :class:`~escfit.geneva.data.SpeedTrace` or :class:`~escfit.geneva.data.TerminalSpeeds`.

    Attributes
    ----------
    names, priors
        Free parameters in vector order and the prior of each.
    noise_names
        ``("observation.sigma",)`` when the noise scale is free, else empty.
    failures
        Why evaluations returned ``-inf`` (``"locked"``, ``"no_terminal"`` ...), counted.
    noise_source
        ``"scene"`` (``observation.sigma``) or ``"data"`` (the data's sd column).
    """

    family = "geneva"
    reading_units = "rad/s"
    vectorized = False
    misfit_options: dict = {}

    def __init__(self, scene, data: SpeedTrace | TerminalSpeeds):
        where = getattr(scene, "where", "scene")
        if getattr(scene, "model", None) != "geneva":
            raise FitError(f"a Geneva fit needs a geneva scene, got model {getattr(scene, 'model', None)!r}", where)
        if not isinstance(data, (SpeedTrace, TerminalSpeeds)):
            raise FitError(f"cannot fit data of type {type(data).__name__} with a Geneva scene; give a speed trace or "
                           "terminal speeds (or a file of one)", where)
        self.scene, self.failures = scene, Counter()
        self.notes: list[str] = []
        self.data_warnings: list[str] = []
        self.terminal = isinstance(data, TerminalSpeeds)
        params = ParamSet(dict(scene.params.params))
        fit_table = scene.extra.get("fit", {})
        check_keys(fit_table, FIT_KEYS, f"{where} [fit]")
        if not self.terminal and fit_table:
            raise SceneError(f"[fit] {sorted(fit_table)} appl{'ies' if len(fit_table) == 1 else 'y'} to terminal-speed "
                             "data only; this recording is a speed trace", f"{where} [fit]")
        if self.terminal:
            data = self._select_runs(data, fit_table.get("table_mu"), where)
            if "torque_scale" in fit_table:
                params.add(read_param(fit_table["torque_scale"], name=TORQUE_SCALE, kind="dimensionless", lower=0.0,
                                      lower_open=True, meaning="common factor on the nominal torques of the runs",
                                      where=f"{where} [fit].torque_scale"))
            if scene.params["geneva.torque"].vary:
                raise FitError("terminal-speed data give the torques; free [fit] torque_scale (a common factor on "
                               "them) instead of geneva.torque", f"{where} [geneva].torque")
            self.notes.append("terminal speeds: one terminal cycle per parameter point, scaled by "
                              "sqrt(torque_scale*K/I_f) to every run's torque (exact: the equation of motion has the "
                              "one time scale sqrt(I_f/K)); the scene's geneva.torque is not used")
        self.data = data
        self._set_noise(params, scene, data, where)
        self._set_free(params, where)
        for p, pr in zip(self.params.free(), self.priors):
            if not pr.proper:
                prior_of(p, f"{where} [{p.name}]")  # raises the standard message: no proper prior
        self.data_warnings += self._warnings_of_data()

    # -- setup -------------------------------------------------------------------------------------------
    def _select_runs(self, data: TerminalSpeeds, table_mu, where: str) -> TerminalSpeeds:
        """One run family: rows that share one true mu (``[fit] table_mu`` picks them from a whole table)."""
        if table_mu is not None:
            if isinstance(table_mu, bool) or not isinstance(table_mu, (int, float)) or not table_mu >= 0:
                raise SceneError(f"table_mu must be a non-negative number (the mu column's value), got {table_mu!r}",
                                 f"{where} [fit].table_mu")
            if data.mu is None:
                raise SceneError("table_mu selects runs by the data's mu column, but the file has none",
                                 f"{where} [fit].table_mu")
            rows = np.isclose(data.mu, float(table_mu), rtol=0, atol=1e-9)
            if not rows.any():
                raise SceneError(f"no run has mu = {table_mu!r}; the file's mu values: {sorted(set(data.mu))}",
                                 f"{where} [fit].table_mu")
            self.notes.append(f"kept the {int(rows.sum())} run(s) of {data.source} with mu = {table_mu:g} "
                              f"(of {data.mu.size})")
            return data.select(np.flatnonzero(rows))
        if data.mu is not None and np.unique(data.mu).size > 1:
            values = sorted(set(map(float, data.mu)))
            raise FitError(f"the file holds runs at several mu {values}: a terminal-speed fit estimates one mu from "
                           "runs that share it; select one run family with [fit] table_mu = ... in the scene (or give "
                           "a file of one family)", data.source)
        return data

    def _set_noise(self, params: ParamSet, scene, data, where: str) -> None:
        table = scene.extra.get("observation")
        if table is not None:
            check_keys(table, OBSERVATION_KEYS, f"{where} [observation]", OBSERVATION_KEYS)
            params.add(read_param(table["sigma"], name=SIGMA, kind="angular_frequency", unit="rad/s", lower=0.0,
                                  lower_open=True, meaning="reading noise: standard deviation of each speed reading",
                                  where=f"{where} [observation].sigma"))
            self.noise_source = "scene"
            self._sd = None
            how = "free (profiled from the residuals by least squares; sampled with the other parameters when the method is emcee)" if params[SIGMA].vary else "fixed"
            self.notes.append(f"reading noise: observation.sigma from the scene, {how}"
                              + ("; the data's sd column is not used" if data.sd is not None else ""))
        elif data.sd is not None:
            self.noise_source = "data"
            sd = data.sd if not self.terminal else np.concatenate((data.sd, data.sd))
            self._sd = np.asarray(sd, float)
            self.notes.append("reading noise: the data's sd column, known (the scene gives no [observation] sigma)")
        else:
            raise SceneError("the readings carry no sd column, so the scene must give the reading noise: add "
                             "[observation] sigma, fixed (sigma = \"1 rad/s\") or free (sigma = { value = 1.0, vary = "
                             "true, prior = \"loguniform(0.01, 100)\" }, rad/s)", f"{where} [observation].sigma")

    def _warnings_of_data(self) -> list[str]:
        out = []
        obs = self.observed
        if self.terminal and np.all(obs == np.round(obs)):
            out.append("the terminal speeds are whole numbers (printed rounded): rounding alone scatters every reading "
                       "by up to 0.5 rad/s (sd 0.29 rad/s)")
        if not self.terminal and self.data.time[0] > 0:
            out.append(f"the trace starts at t = {self.data.time[0]:g} s, not at release: the model releases the "
                       "driver at rest at t = 0, so the time column must count from release")
        return out

    # -- the Problem protocol ----------------------------------------------------------------------------
    DERIVED = {"geneva.inertia_ratio": ("", "I_d/I_f, driver over follower inertia (derived)"),
               "geneva.time_scale": ("s", "sqrt(I_f/K), the one time scale of the motion (derived)")}

    @property
    def observed(self) -> np.ndarray:
        d = self.data
        return d.speed if not self.terminal else np.concatenate((d.peak, d.minimum))

    def predict(self, vals: Mapping[str, float]) -> np.ndarray:
        """Expected readings (rad/s) at parameter values ``vals``.

        Raises
        ------
        ForwardFailure
            The pin locks, there is no terminal motion, or the values are not physical.
        """
        return self._run(vals)[0]

    def _run(self, vals: Mapping[str, float]) -> tuple[np.ndarray, Any]:
        """Expected readings and the forward run behind them (trajectory or terminal cycle)."""
        geo = self.scene.geometry
        i_d, i_f, mu = vals["geneva.driver_inertia"], vals["geneva.follower_inertia"], vals["geneva.mu"]
        if not (i_d > 0 and i_f > 0 and mu >= 0 and math.isfinite(i_d + i_f + mu)):
            raise ForwardFailure("non-physical parameters")
        if not self.terminal:
            t = self.data.time
            try:
                pred = forward(geo, vals, duration=float(t[-1]), sample_times=t, solver="rk4", options=FIT_OPTIONS,
                               with_terminal=False)
            except (EscfitError, ValueError, ArithmeticError) as exc:
                raise ForwardFailure(f"forward run refused: {exc}"[:100]) from None
            tr = pred.trajectory
            if tr.end_reason != "duration" or tr.time.size != t.size:
                raise ForwardFailure(tr.end_reason)
            return tr.speed, tr
        term = terminal_cycle(geo, i_d / i_f, mu, 1.0, ENGINES["rk4"], FIT_OPTIONS)
        if term.status != "ok":
            raise ForwardFailure(term.status)
        ts = vals.get(TORQUE_SCALE, 1.0)
        if not ts > 0:
            raise ForwardFailure("non-physical parameters")
        scale = np.sqrt(ts * self.data.torque / i_f)
        return np.concatenate((term.peak_speed * scale, term.min_speed * scale)), term

    def _sd_at(self, vals: Mapping[str, float]) -> np.ndarray | float:
        return self._sd if self._sd is not None else vals[SIGMA]

    def log_likelihood(self, vals: Mapping[str, float]) -> float:
        try:
            pred = self.predict(vals)
        except ForwardFailure as exc:
            self.failures[exc.reason] += 1
            return -math.inf
        sd = self._sd_at(vals)
        r = (self.observed - pred) / sd
        ll = float(-0.5 * r @ r - np.sum(np.log(sd) * np.ones(r.size)) - 0.5 * r.size * math.log(2 * math.pi))
        if not math.isfinite(ll):
            self.failures["non-finite likelihood"] += 1
            return -math.inf
        return ll

    def residuals(self, vals: Mapping[str, float]) -> np.ndarray:
        """(observed - expected)/sd of every reading; 1e6 where the forward model fails."""
        try:
            pred = self.predict(vals)
        except ForwardFailure as exc:
            self.failures[exc.reason] += 1
            return np.full(self.n_data, FAIL_RESIDUAL)
        r = (self.observed - pred) / self._sd_at(vals)
        return np.where(np.isfinite(r), r, FAIL_RESIDUAL)

    def loglike_pointwise(self, vals: Mapping[str, float]) -> np.ndarray:
        """Gaussian log density of each reading; raises :class:`ForwardFailure` when the model fails."""
        sd = self._sd_at(vals)
        r = (self.observed - self.predict(vals)) / sd
        return -0.5 * r * r - np.log(sd) - 0.5 * math.log(2 * math.pi)

    def expected(self, vals: Mapping[str, float]) -> np.ndarray:
        return self.predict(vals)

    def obs_coords(self) -> dict[str, Any]:
        n = self.n_data
        if not self.terminal:
            return {"obs": np.arange(n), "curve": ("obs", np.array(["speed"] * n, dtype=str)),
                    "x": ("obs", self.data.time, {"units": "s", "long_name": "time since release from rest"})}
        k = self.data.torque.size
        return {"obs": np.arange(n), "curve": ("obs", np.array(["peak"] * k + ["minimum"] * k, dtype=str)),
                "x": ("obs", np.concatenate((self.data.torque, self.data.torque)),
                      {"units": "N*m", "long_name": "nominal spring torque K of the run"})}

    def provenance(self) -> dict[str, Any]:
        return {"scene": self.scene.text, "scene_file": self.scene.where, "data_file": self.data.source,
                "data_sha256": self.data.sha256, "data_kind": self.data.kind, "solver": "rk4",
                "solver_options": dict(FIT_OPTIONS), "noise_source": self.noise_source}

    def derived(self, values: Mapping[str, float]) -> dict[str, float]:
        """``I_d/I_f`` when an inertia is free; ``sqrt(I_f/K)`` (speed traces) when ``I_f`` or ``K`` is free."""
        free = set(self.names)
        out = {}
        if free & {"geneva.driver_inertia", "geneva.follower_inertia"}:
            out["geneva.inertia_ratio"] = values["geneva.driver_inertia"] / values["geneva.follower_inertia"]
        if not self.terminal and free & {"geneva.follower_inertia", "geneva.torque"}:
            out["geneva.time_scale"] = math.sqrt(values["geneva.follower_inertia"] / values["geneva.torque"])
        return out

    def checks_at_best_fit(self, best: Mapping[str, float]) -> tuple[dict, list[str]]:
        """Engagements a trace covers (speed traces) or the terminal contraction (terminal speeds)."""
        try:
            _, run = self._run(best)
        except ForwardFailure:
            return {}, []
        if not self.terminal:
            return {"engagements_in_trace": int(run.eng_start.size)}, []
        warnings = [] if run.contraction < 0.98 else [
            f"at the best fit the driver approaches its terminal motion by a factor {run.contraction:.3f} per "
            "engagement: runs shorter than a few hundred engagements had not reached the terminal speeds fitted"]
        return {"terminal_contraction": float(run.contraction)}, warnings
