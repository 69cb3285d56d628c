"""The fit problem: scene + recording + observation model -> likelihood and residuals.

Data flow is one way: parameter vector -> values by name -> balance system per curve (load)
-> exact solver -> signed turning points at the recorded swings -> observation model ->
log-likelihood.  A failed solve or a non-finite number becomes ``-inf`` (or large residuals)
and the reason is counted in :attr:`FitProblem.failures`, never an exception.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from .. import BalanceScene
from ...core.errors import EscfitError, FitError
from ...core.status import LABELS, Status
from ..observation import observation_from_table
from ...core.params import ParamSet
from ...analysis.recordings import UnitCurve
from ...core.scene import check_keys
from ...likelihood.freeparams import FreeParameters
from ...likelihood.problem import FAIL_RESIDUAL
from .common import BalanceProblem
from .facts import RecordFacts
from .loads import LoadRule

__all__ = ["FitProblem", "Curve"]

# status codes of a batch run that the one-at-a-time path must redo: refused, failed, out of segments
_UNFINISHED = np.array([LABELS[Status(i)][0] in ("failed", "max_segments") for i in range(len(Status))])



def _column(x, n: int) -> np.ndarray:
    """``x`` (a number or an array of ``n``) as a float array of shape (n,)."""
    if isinstance(x, np.ndarray) and x.shape == (n,) and x.dtype == np.float64:
        return x
    if np.ndim(x) == 0:
        return np.full(n, float(x))
    return np.array(np.broadcast_to(np.asarray(x, float), (n,)))


def _at_recorded_swings(curve: "Curve", theta0: float, theta_turn: np.ndarray, rest: float = 0.0) -> np.ndarray:
    """Signed angle ending each recorded half swing (swing 0: the release angle).

    Swings after the balance stopped read its rest angle ``rest`` (rad): it stays where it
    stopped, inside friction's dead band, not at the centre.
    """
    turns = np.concatenate([[theta0], theta_turn])
    k = curve.swing
    inside = k <= theta_turn.size
    theta = np.full(k.size, float(rest))
    theta[inside] = turns[k[inside]]
    return theta


def rest_angle(code, final_theta):
    """Signed rest angle (rad) of runs that ended: where a stopped run rests, 0 for any other end.

    A run stopped by friction rests where its last half swing left it (``final``'s angle);
    reading 0 there instead would make the readings jump when a change of the parameters adds
    or removes the last half swing before the stop, and the least-squares cost with them.
    """
    code = np.asarray(code)
    theta = np.where(code == int(Status.STOPPED), np.asarray(final_theta, float), 0.0)
    return np.where(np.isfinite(theta), theta, 0.0)


def read_through_rest(turns: np.ndarray, n_done: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """``turns`` (sets, 1 + swings) with every swing after a set's last read as its rest angle,
    so that all swings are read (the observation kernels read a swing past ``n_done`` as 0)."""
    after = np.arange(turns.shape[1])[None, :] > np.asarray(n_done)[:, None]
    return np.where(after, np.asarray(rest, float)[:, None], turns)


@dataclass(frozen=True)
class Curve:
    """One decay curve of the recording (a unit at one load)."""

    label: str
    load: float  # in the data's load unit; nan when none
    swing: np.ndarray
    y: np.ndarray
    time: np.ndarray | None = None  # reading times since release, s (for a drifting offset)


@dataclass
class FitProblem(FreeParameters, BalanceProblem):
    """Everything a fit needs, prepared once.

    Parameters
    ----------
    scene
        A balance scene; its free parameters (``vary = true``) are estimated.
    data
        The recording (one unit; several loads allowed).
    solver, solver_options
        Forward solver and its options (default: the scene's, see
        :func:`escfit.balance.default_solver`).
    facts
        What the analysis of a sampled record found (:class:`~escfit.balance.problems.facts.RecordFacts`).

    Attributes
    ----------
    params
        Scene, load-rule and observation parameters together.
    names
        Names of the free parameters, in vector order.
    priors
        Prior of each free parameter.
    failures
        Counter of the reasons evaluations returned ``-inf``.
    """

    scene: BalanceScene
    data: UnitCurve
    solver: str | None = None
    solver_options: dict = field(default_factory=dict)
    facts: RecordFacts | None = None  # what the record's analysis found (problems built from a record)
    readings_in_branches = True  # a unit curve's per-load curves (see BalanceProblem.misfit_options)

    def __post_init__(self) -> None:
        if self.scene.model != "balance":
            raise FitError(f"fitting unit curves needs a balance scene, got model {self.scene.model!r}", self.scene.where)
        units = sorted(set(map(str, self.data.unit)))
        if len(units) > 1:
            raise FitError(f"the recording holds several units {units}; fit one at a time (select with --unit)",
                           self.data.source)
        fit_table = self.scene.extra.get("fit", {})
        check_keys(fit_table, {"loads"}, f"{self.scene.where} [fit]")
        self.observation = observation_from_table(self.scene.extra.get("observation"), self.scene.where,
                                                  self.data.kind, self.data.notch)
        params = ParamSet(dict(self.scene.params.params))
        for p in self.observation.params:
            params.add(p)
        times = self.data.time
        self.curves = [Curve(f"{u or 'unit'} load {ld:g}" if not math.isnan(ld) else (u or "curve"), ld,
                             self.data.swing[rows], self.data.value[rows], None if times is None else times[rows])
                       for (u, ld), rows in self.data.groups()]
        drift = params["observation.offset_rate"]
        if (drift.vary or drift.value != 0.0) and times is None:
            raise FitError("observation.offset_rate (a drifting centre) needs the time of every reading; the "
                           "recording has no time column", self.data.source)
        self._check_release(params)
        self.load_rule = LoadRule.read(fit_table.get("loads"), self.scene, self.data, self.curves, params)
        self._set_free(params, self.scene.where)
        self.failures: Counter = Counter()
        from ..solvers import check_scene, default_solver

        self.solver = self.solver or default_solver(self.scene)
        # a solver with a batch path runs a whole ensemble in one parallel call (log_prob_many)
        self.vectorized = check_scene(self.scene, self.solver, self.solver_options).batch
        if self.facts is not None:
            self.facts.give(self)

    def _check_release(self, params: ParamSet) -> None:
        """Refuse a fixed release angle that the recording's release reading contradicts.

        Swing 0 is the release: its reading is the release amplitude itself.  When the scene
        fixes ``theta0`` and that reading differs from it by more than a quarter (and more than
        two notches of a notch recording), scene and data describe different runs (a release at
        0 rad against readings at 6.28 rad, a bare 300 meant as degrees), and no fit of C, R or X
        can mean anything.
        """
        theta0 = params["oscillator.theta0"]
        if theta0.vary:
            return
        a0 = abs(theta0.value)
        notches = self.data.kind == "notches"
        for c in self.curves:
            k = np.flatnonzero(c.swing == 0)
            if not k.size:
                continue
            reading = float(c.y[k[0]]) * (self.data.notch if notches else 1.0)
            tol = max(0.25 * max(a0, abs(reading)), 2.0 * self.data.notch if notches else 0.0)
            if abs(a0 - abs(reading)) > tol:
                raise FitError(f"the scene releases the balance at {math.degrees(a0):.4g} deg ({a0:.4g} rad) but the "
                               f"release reading (swing 0) of {c.label} is {math.degrees(abs(reading)):.4g} deg: scene "
                               "and recording describe different runs (fix theta0, or let it vary)", self.data.source)

    # -- forward model -----------------------------------------------------------------
    def predict(self, vals: Mapping[str, float]) -> list[np.ndarray]:
        """Amplitude towards the nominal side at each recorded swing, per curve (rad).

        With angle switching this is the signed turning-point angle theta (the observation
        model reads ``|theta - offset|``); with phase switching it is theta measured towards
        the side the half cycle should end on (:meth:`sides`), negative when Monday's
        convention breaks down, so the likelihood has no fold at zero.

        Raises
        ------
        EscfitError
            When the solver refuses the parameters or runs out of segments.
        """
        out = [_at_recorded_swings(curve, *self._solve_curve(vals, curve)) for curve in self.curves]
        return [self._nominal(t, c) for t, c in zip(out, self.curves)]

    def _solve_curve(self, vals: Mapping[str, float], curve: Curve) -> tuple[float, np.ndarray, float]:
        """Release angle, signed turning points and rest angle (rad; see :func:`rest_angle`) of one
        curve's run, to its last recorded swing."""
        sys = self.scene.system(self.load_rule.apply(vals, curve.load))
        n = int(curve.swing.max())
        if n <= 0:
            return sys.theta0, np.zeros(0), 0.0
        from ..solvers import solve_system

        tr = solve_system(sys, n, self.solver, **self.solver_options)
        if tr.status == "max_segments":
            raise FitError("solver ran out of segments")
        return sys.theta0, tr.theta_turn, float(rest_angle(tr.code, tr.final[1]))

    def _nominal(self, theta: np.ndarray, curve: Curve) -> np.ndarray:
        side = self.sides(curve)
        return theta if side is None else side * theta

    def sides(self, curve: Curve) -> np.ndarray | None:
        """Phase switching: nominal side (+1/-1) of the end of each recorded swing; else None."""
        if self.scene.switching != "phase":
            return None
        sign0 = 1.0 if self.params["oscillator.theta0"].value >= 0 else -1.0
        return sign0 * np.where(curve.swing % 2 == 0, 1.0, -1.0)

    # -- likelihood --------------------------------------------------------------------
    def log_likelihood(self, vals: Mapping[str, float]) -> float:
        compiled = self._compiled_model() is not None
        try:
            if compiled:  # the kernel the whole-array path uses, on one set: the same numbers
                runs = [self._solve_curve(vals, c) for c in self.curves]
            else:
                pred = self.predict(vals)
        except (EscfitError, ValueError, ArithmeticError) as exc:
            self.failures[f"solve failed: {exc}"[:120]] += 1
            return -math.inf
        if compiled:
            n = max(int(c.swing.max()) for c in self.curves)
            turns = np.full((len(self.curves), 1, 1 + n), np.nan)
            n_done = np.zeros((len(self.curves), 1), np.int64)
            for i, (theta0, theta_turn, rest) in enumerate(runs):
                turns[i, 0, 0] = theta0
                turns[i, 0, 1:1 + theta_turn.size] = theta_turn
                turns[i, 0, 1 + theta_turn.size:] = rest
                n_done[i, 0] = n
            ll = float(self._loglike_compiled(turns, n_done, vals, 1)[0])
        else:
            ll = sum(self.observation.loglike(p, c.y, vals, self.sides(c), c.time) for p, c in zip(pred, self.curves))
        if not math.isfinite(ll):
            self.failures["non-finite likelihood"] += 1
            return -math.inf
        return ll

    # -- many parameter vectors at once ------------------------------------------------
    def _log_likelihood_many(self, vecs: np.ndarray) -> np.ndarray:
        """Log-likelihood of every row (inside the priors) as one array computation.

        Values and the load rule on arrays, the coefficient records of every set assembled in
        one pass (``scene.system(values, n)``), the forward runs in one call of
        :func:`escfit.balance.batch.solve_batch` and the observation model on a (sets,
        readings) array; sets the batch refuses or cannot finish go through
        :meth:`log_likelihood` one at a time, which records why.
        """
        n_sets = vecs.shape[0]
        vals = self.values_many(vecs)
        scalar = np.zeros(n_sets, bool)  # sets handed to the one-at-a-time path (refusals, failures)
        total = np.zeros(n_sets)
        try:
            turns, n_done, failed = self._solve_all_curves(vals, n_sets)
        except (EscfitError, ValueError, ArithmeticError):
            turns, scalar[:] = None, True
        if turns is not None and self._compiled_model() is not None:
            scalar |= failed.any(axis=0)
            total = self._loglike_compiled(turns, n_done, vals, n_sets)
        elif turns is not None:
            lay = self._layout()
            columns = {k: (v[:, None] if isinstance(v, np.ndarray) else v) for k, v in vals.items()}
            scalar |= failed.any(axis=0)
            # every reading of every curve at once: (sets, readings), curve after curve
            inside = lay["swing"][:, None] <= n_done[lay["curve"], :]
            # C order, so each row is summed exactly as log_likelihood sums a curve
            readings = np.ascontiguousarray(np.where(inside, turns[lay["curve"], :, lay["swing"]], 0.0).T)
            pred = readings if lay["side"] is None else lay["side"] * readings  # as _nominal
            with np.errstate(all="ignore"):
                ll = self.observation.loglike_pointwise(pred, lay["y"], columns, lay["side"], lay["time"])
            ll = np.broadcast_to(ll, pred.shape)
            for a, b in lay["slices"]:  # summed curve by curve, as log_likelihood does
                total = total + np.sum(ll[:, a:b], axis=1)
        bad = ~np.isfinite(total) & ~scalar
        if bad.any():
            self.failures["non-finite likelihood"] += int(bad.sum())
        ll = np.where(bad, -math.inf, total)
        for i in np.flatnonzero(scalar):
            # the one-at-a-time path records the same failure reason as log_prob would
            ll[i] = self.log_likelihood(self.values(vecs[i]))
        return ll

    def _compiled_model(self) -> int | None:
        """The compiled observation kernel's model code for this problem's readings, or None
        (Student-t amplitudes go through the observation model's numpy code)."""
        if "_model_code" in self.__dict__:
            return self.__dict__["_model_code"]
        self.__dict__["_model_code"] = code = self._model_code_of(self.observation)
        return code

    @staticmethod
    def _model_code_of(observation) -> int | None:
        from ..observation.amplitude import AmplitudeObservation
        from ..observation.compiled import GAUSSIAN, NOTCHES
        from ..observation.notches import NotchObservation

        if isinstance(observation, NotchObservation):
            return NOTCHES
        if isinstance(observation, AmplitudeObservation) and observation.noise == "gaussian":
            return GAUSSIAN
        return None

    def _readings(self) -> np.ndarray:
        """Every reading as a :data:`~escfit.balance.observation.compiled.READING` record (computed once)."""
        rec = self.__dict__.get("_readings_cache")
        if rec is None:
            from ..observation.compiled import READING
            from ..observation.notches import NotchObservation

            lay = self._layout()
            rec = np.zeros(lay["y"].size, READING)
            rec["curve"], rec["swing"] = lay["curve"], lay["swing"]
            rec["side"] = 0.0 if lay["side"] is None else lay["side"]
            rec["time"] = 0.0 if lay["time"] is None else lay["time"]
            if isinstance(self.observation, NotchObservation):
                rec["lo"], rec["hi"] = self.observation.interval(lay["y"])
            else:
                rec["lo"] = lay["y"]
            self.__dict__["_readings_cache"] = rec
        return rec

    def _loglike_compiled(self, turns: np.ndarray, n_done: np.ndarray, vals: Mapping, n_sets: int) -> np.ndarray:
        """Log-likelihood of each set from its turning points, by the compiled observation kernel."""
        from ..observation.compiled import SET, loglike_sets

        sets = np.empty(n_sets, SET)
        sets["sigma"] = vals["observation.sigma"]
        sets["offset"] = vals["observation.offset"]
        sets["rate"] = vals.get("observation.offset_rate", 0.0)
        out = np.empty(n_sets)
        loglike_sets(turns, np.ascontiguousarray(n_done, np.int64), self._readings(), sets, self._compiled_model(),
                     out)
        return out

    def _layout(self) -> dict:
        """Where each reading comes from, for the whole-array path (computed once).

        ``curve`` and ``swing`` index the turning points of :meth:`_solve_all_curves` (swing 0
        is the release); ``y``, ``side`` and ``time`` are the readings, their nominal sides and
        times, concatenated curve after curve; ``slices`` delimit the curves.
        """
        lay = self.__dict__.get("_layout_cache")
        if lay is None:
            sizes = [c.y.size for c in self.curves]
            ends = np.cumsum(sizes)
            sides = [self.sides(c) for c in self.curves]
            times = [c.time for c in self.curves]
            lay = {"curve": np.repeat(np.arange(len(self.curves)), sizes),
                   "swing": np.concatenate([c.swing for c in self.curves]).astype(np.int64),
                   "y": np.concatenate([c.y for c in self.curves]),
                   "side": None if sides[0] is None else np.concatenate(sides),
                   "time": None if any(t is None for t in times) else np.concatenate(times),
                   "slices": [(int(e - n), int(e)) for e, n in zip(ends, sizes)]}
            self.__dict__["_layout_cache"] = lay
        return lay

    def _solve_all_curves(self, vals: Mapping, n_sets: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Turning points of every set at every curve's load, in one batch call.

        The sets of all curves (loads) share one structure, so they are stacked curve after
        curve and run to the longest curve's last recorded swing (a set's turning points do not
        depend on how many swings are asked for; extra ones are simply not read).

        Returns
        -------
        turns : ndarray, shape (curves, sets, 1 + swings)
            Release angle then the signed turning points; after a stopped set's last one, its
            rest angle (:func:`read_through_rest`).
        n_done : ndarray, shape (curves, sets)
            The swings to read of each set: all of them (a stopped set's rest included).
        failed : ndarray of bool, shape (curves, sets)
            Refused by the batch or out of segments (to be evaluated one at a time).
        """
        from ..batch import solve_batch

        n_curves = len(self.curves)
        per_curve = [self.load_rule.apply(vals, c.load) for c in self.curves]
        keys = self.__dict__.get("_merge_keys")
        if keys is None:  # the values that are arrays or differ between loads: fixed by the fit's structure
            keys = [k for k in per_curve[0]
                    if any(isinstance(cv[k], np.ndarray) or cv[k] != per_curve[0][k] for cv in per_curve)]
            self.__dict__["_merge_keys"] = keys
        merged = dict(per_curve[0])
        fixed = self.__dict__.setdefault("_merged_fixed", {})  # load-dependent constants, per ensemble size
        for k in keys:
            parts = [cv[k] for cv in per_curve]
            if not any(isinstance(p, np.ndarray) for p in parts):  # no free parameter in it: the same every call
                if (k, n_sets) not in fixed:
                    fixed[(k, n_sets)] = np.repeat(np.asarray(parts, float), n_sets)
                merged[k] = fixed[(k, n_sets)]
            else:
                merged[k] = np.concatenate([_column(p, n_sets) for p in parts])
        stack = self.scene.system(merged, n_sets * n_curves)
        n = max(int(c.swing.max()) for c in self.curves)
        turns = np.full((n_sets * n_curves, 1 + n), np.nan)
        turns[:, 0] = stack.k["theta0"]
        if n > 0:
            batch = solve_batch(stack, n, throw=False, max_segments=self.solver_options.get("max_segments"))
            turns[:, 1:] = batch.theta_turn
            turns = read_through_rest(turns, batch.n_done, rest_angle(batch.code, batch.final[:, 1]))
            n_done, failed = np.full_like(batch.n_done, n), _UNFINISHED[batch.code]
            if self.solver_options.get("max_segments") is None:
                # the one-set default budget grows with the swings asked for (64 n + 1000): a set that
                # used more segments than the shortest curve's budget goes the one-at-a-time way,
                # where a curve that runs out of segments is a failure
                shortest = min(int(c.swing.max()) for c in self.curves)
                failed |= batch.n_segments > 64 * shortest + 1000
        else:
            n_done, failed = np.zeros(n_sets * n_curves, int), np.zeros(n_sets * n_curves, bool)
        shape = (n_curves, n_sets)
        return turns.reshape(*shape, 1 + n), n_done.reshape(shape), failed.reshape(shape)

    def predictive_many(self, vecs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`expected` and :meth:`loglike_pointwise` of every row of ``vecs`` (sets, ndim),
        each of shape (sets, readings), from one batch run of every set at every load.

        Rows the batch does not finish go through the one-set methods; a row whose solve fails
        there reads NaN and -inf, counted under "posterior predictive solve failed".
        """
        vecs = np.atleast_2d(np.asarray(vecs, float))
        n_sets = vecs.shape[0]
        exp = np.full((n_sets, self.n_data), np.nan)
        ll = np.full((n_sets, self.n_data), -np.inf)
        redo = np.ones(n_sets, bool)
        vals = self.values_many(vecs)
        try:
            turns, n_done, failed = self._solve_all_curves(vals, n_sets)
        except (EscfitError, ValueError, ArithmeticError):
            turns = None
        if turns is not None:
            lay = self._layout()
            columns = {k: (v[:, None] if isinstance(v, np.ndarray) else v) for k, v in vals.items()}
            inside = lay["swing"][:, None] <= n_done[lay["curve"], :]
            pred = np.where(inside, turns[lay["curve"], :, lay["swing"]], 0.0).T
            pred = pred if lay["side"] is None else lay["side"] * pred  # as _nominal
            with np.errstate(all="ignore"):
                e = self.observation.expected(pred, columns, lay["side"], lay["time"])
                lp = self.observation.loglike_pointwise(pred, lay["y"], columns, lay["side"], lay["time"])
            redo = failed.any(axis=0)
            exp[~redo], ll[~redo] = np.broadcast_to(e, exp.shape)[~redo], np.broadcast_to(lp, ll.shape)[~redo]
        for i in np.flatnonzero(redo):
            one = self.values(vecs[i])
            try:
                exp[i], ll[i] = self.expected(one), self.loglike_pointwise(one)
            except Exception:  # noqa: BLE001 - as the posterior predictive's loop: a failed draw stays NaN / -inf
                self.failures["posterior predictive solve failed"] += 1
        return exp, ll

    def residuals(self, vals: Mapping[str, float]) -> np.ndarray:
        """Standardised residuals of all readings (large values on failure)."""
        n = sum(c.y.size for c in self.curves)
        try:
            pred = self.predict(vals)
        except (EscfitError, ValueError, ArithmeticError) as exc:
            self.failures[f"solve failed: {exc}"[:120]] += 1
            return np.full(n, FAIL_RESIDUAL)
        r = np.concatenate([self.observation.residuals(p, c.y, vals, self.sides(c), c.time)
                            for p, c in zip(pred, self.curves)])
        return np.where(np.isfinite(r), r, FAIL_RESIDUAL)

    def loglike_pointwise(self, vals: Mapping[str, float]) -> np.ndarray:
        """Log-likelihood of each reading (for PSIS-LOO); raises when the solve fails."""
        return np.concatenate([self.observation.loglike_pointwise(p, c.y, vals, self.sides(c), c.time)
                               for p, c in zip(self.predict(vals), self.curves)])

    # -- what Monday's phase convention leaves determined at several loads ---------------
    def checks_at_best_fit(self, best: Mapping[str, float]) -> tuple[dict, list[str]]:
        figures, warnings = super().checks_at_best_fit(best)
        notch_figures, notch_warnings = self._notch_convention_check(best)
        return {**figures, **notch_figures}, self.phase_loads_warning() + warnings + notch_warnings

    def _notch_convention_check(self, best: Mapping[str, float]) -> tuple[dict, list[str]]:
        """Notch counts: do the readings look like the other reading convention?

        See :func:`escfit.balance.observation.notch_convention.notch_reading_report`; the
        release readings are anchors when the release angle is not fitted.
        """
        from ..observation.notch_convention import notch_reading_report
        from ..observation.notches import NotchObservation

        obs = self.observation
        sigma = best.get("observation.sigma")
        if not isinstance(obs, NotchObservation) or not sigma or not np.isfinite(sigma):
            return {}, []
        try:
            position = obs.interval_position(self.expected(best), self.observed)
        except (EscfitError, ValueError, ArithmeticError):
            return {}, []
        swing = np.concatenate([c.swing for c in self.curves])
        curve = np.concatenate([np.full(c.y.size, k) for k, c in enumerate(self.curves)])
        anchor = swing == 0 if "oscillator.theta0" not in self.names else None
        return notch_reading_report(position, reading=obs.reading, jitter=float(sigma) / obs.notch, anchor=anchor,
                                    curve=curve)

    def checks_of_posterior(self, chain: np.ndarray) -> list[str]:
        return self.phase_loads_warning() + super().checks_of_posterior(chain)

    def phase_loads_warning(self) -> list[str]:
        """The phase convention's non-identifiability in a joint fit of several loads.

        With phase switching every unit curve is exactly geometric: it fixes ``C/omega0`` and
        Monday's combined ``K`` at its load, and ``K`` is linear in the forcing magnitudes
        (Coulomb ``R``, the escapement ``X``, the load rule's ``fit.kappa``/``fit.mu``).  The
        loads therefore determine at most as many forcing combinations as the rank of
        ``dK(load)/d(forcing)``; when that rank is below the number of free forcing
        parameters, they trade off exactly along ``K(load) = const`` (correlations of +-1,
        unbounded least-squares intervals).  The rank is computed at the scene's values (a
        structural property: it does not depend on them).
        """
        cached = self.__dict__.get("_phase_loads_warning")
        if cached is None:
            cached = self.__dict__["_phase_loads_warning"] = self._phase_loads_check()
        return list(cached)

    def _phase_loads_check(self) -> list[str]:
        if self.scene.switching != "phase" or len(self.curves) < 2:
            return []
        forcing = [n for n in self.names if n == "coulomb.R" or n.startswith("coulomb.R[load=")
                   or (n.startswith("escapement[") and n.endswith(".X")) or n in ("fit.kappa", "fit.mu")]
        if not forcing:
            return []
        from .checks import monday_k

        base = self.values(self.initial)
        loads = sorted({c.load for c in self.curves})
        try:
            k0 = np.array([monday_k(self, self.load_rule.apply(base, ld)) for ld in loads])
            cols = []
            for name in forcing:
                step = 1e-3 * max(abs(float(base[name])), 1.0)  # K is linear in the magnitudes: any step
                moved = {**base, name: float(base[name]) + step}
                k1 = np.array([monday_k(self, self.load_rule.apply(moved, ld)) for ld in loads])
                cols.append((k1 - k0) / step)
        except (EscfitError, ValueError, ArithmeticError):  # K undefined here (overdamped): no statement
            return []
        m = np.array(cols).T
        norms = np.linalg.norm(m, axis=0)
        s = np.linalg.svd(m / np.where(norms > 0, norms, 1.0), compute_uv=False) if m.size else np.zeros(0)
        rank = int(np.sum(s > 1e-8 * max(float(s.max()) if s.size else 0.0, 1e-300))) if np.any(norms > 0) else 0
        if rank >= len(forcing):
            return []
        return [f"phase switching at {len(loads)} loads: each unit curve is exactly geometric and determines only "
                f"C/omega0 and Monday's combined K at its load, so the loads fix {rank} combination(s) of the "
                f"{len(forcing)} free forcing parameters {', '.join(forcing)}; these trade off exactly along "
                "K(load) = const (correlations of +-1, unbounded intervals; see the K per load): fix some of them "
                "(e.g. the escapement magnitudes from the fixture gains) or record with angle switching"]

    def derived(self, values: Mapping[str, float]) -> dict[str, float]:
        """Monday's combined K: at each load when the phase convention leaves only those determined."""
        if not self.phase_loads_warning():
            return super().derived(values)
        from .checks import monday_k

        return {f"K[load={ld:g}]": monday_k(self, self.load_rule.apply(values, ld))
                for ld in sorted({c.load for c in self.curves})}

    @property
    def units(self) -> dict[str, str]:
        out = dict(super().units)
        if self.phase_loads_warning():
            out.update({f"K[load={c.load:g}]": "" for c in self.curves})
        return out

    @property
    def meanings(self) -> dict[str, str]:
        out = dict(super().meanings)
        if self.phase_loads_warning():
            out.update({f"K[load={c.load:g}]": f"Monday's combined K at load {c.load:g} (derived)"
                        for c in self.curves})
        return out

    def expected(self, vals: Mapping[str, float]) -> np.ndarray:
        """Noise-free expected readings (rad) of all data points, concatenated."""
        return np.concatenate([self.observation.expected(p, vals, self.sides(c), c.time)
                               for p, c in zip(self.predict(vals), self.curves)])
