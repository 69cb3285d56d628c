"""Fitting: least squares (lmfit) and posterior sampling (emcee) of balance-wheel curves."""

from __future__ import annotations

import datetime as _dt
import math
from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import FitError
from ..recordings import UnitCurve
from ..results import SCHEMA_VERSION, FitResult, clean_attrs, dependency_versions, write_fit
from ..scene import load_scene
from .identifiability import (correlation_warnings, monday_k, phase_mode_warning, profile, ridge_warnings,
                              sloppy_directions)
from .misfit import misfit_report
from .lsq import LeastSquaresResult, least_squares
from .mcmc import McmcResult, run_emcee
from .problem import FitProblem

__all__ = ["fit", "make_problem", "FitProblem", "least_squares", "run_emcee", "profile", "LeastSquaresResult",
           "McmcResult"]

PP_DRAWS = 400  # posterior-predictive evaluations stored per fit


def fit(scene, data, *, method: str = "leastsq", out: str | Path | None = None, force: bool = False, seed: int = 0,
        walkers: int = 32, steps: int = 2000, burn: int | None = None, n_starts: int = 8, resume: bool = False,
        progress: bool = False, solver: str | None = None, solver_options: dict | None = None,
        checkpoint: str | Path | None = None, unit: str | None = None, fmt: str | None = None,
        notch_deg: float | None = None, predictive_draws: int = PP_DRAWS, recording: dict | None = None,
        moves: str = "stretch") -> FitResult:
    """Fit a balance scene to a recording.

    Parameters
    ----------
    scene
        Scene object or path; its ``vary = true`` parameters are estimated.
    data
        A recording (see :func:`make_problem`) or the path of a recording file.
    method
        ``"leastsq"`` (lmfit, multistart) or ``"emcee"`` (least squares, then MCMC).
    out
        Results file (HDF5); written atomically, never replacing a file without ``force``.
    seed, walkers, steps, burn, n_starts, progress
        Sampler and optimiser settings (``burn`` defaults to half the steps).
    resume
        Continue an interrupted emcee run from its checkpoint.
    checkpoint
        emcee backend file (default ``<out>.emcee`` when ``out`` is given).
    unit
        Fit only this unit of a multi-unit recording.
    fmt, notch_deg
        Recording format (detected when ``None``) and the notch angle of notch counts, deg.
    solver
        Forward solver (default: the scene's).
    recording
        ``[recording]`` options overriding the scene's (see :func:`make_problem`).
    moves
        emcee's proposal: ``"stretch"`` or ``"de"`` (see :func:`~escfit.fitting.mcmc.run_emcee`).
    predictive_draws
        Posterior draws (spread evenly over walkers and steps) at which the expected readings
        and the pointwise log-likelihood (for PSIS-LOO) are stored.

    Returns
    -------
    FitResult
        Also written to ``out`` when given.
    """
    from ..atomic import refuse_existing

    if method not in ("leastsq", "emcee"):
        raise FitError(f"method must be 'leastsq' or 'emcee', got {method!r}")
    if predictive_draws < 1:
        raise FitError(f"predictive_draws must be at least 1, got {predictive_draws}")
    if out is not None:
        refuse_existing(out, force)
        if not Path(out).parent.exists():
            raise FitError("output directory does not exist", str(Path(out).parent))
    sc = load_scene(scene) if not hasattr(scene, "model") else scene
    problem = make_problem(sc, data, solver=solver, solver_options=solver_options, unit=unit, fmt=fmt,
                           notch_deg=notch_deg, recording=recording)
    started = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    lsq = least_squares(problem, n_starts=n_starts, seed=seed)
    mc = None
    if method == "emcee":
        if checkpoint is None and out is not None:
            checkpoint = str(out) + ".emcee"
        if checkpoint is not None and Path(checkpoint).exists() and not resume and not force:
            raise FitError("an interrupted run's checkpoint exists; pass --resume to continue it or --force to restart",
                           str(checkpoint))
        mc = run_emcee(problem, lsq, walkers=walkers, steps=steps, burn=burn, seed=seed, checkpoint=checkpoint,
                       resume=resume, progress=progress, moves=moves)
    result = FitResult(_tree(problem, lsq, mc, method=method, seed=seed, started=started,
                             predictive_draws=predictive_draws))
    if out is not None:
        write_fit(result, out, force=force)
        if checkpoint is not None and Path(checkpoint).exists():
            Path(checkpoint).unlink()
    return result


def make_problem(scene, data, *, solver: str | None = None, solver_options: dict | None = None,
                 unit: str | None = None, fmt: str | None = None, notch_deg: float | None = None,
                 recording: dict | None = None):
    """The fit problem of a balance scene and a recording of any supported format.

    Parameters
    ----------
    scene
        Balance scene (object or path).
    data
        A :class:`~escfit.recordings.UnitCurve` (amplitudes or notch counts per swing), a
        :class:`~escfit.recordings.pulses.PulseTrain` (photo-cell passage times), a
        :class:`~escfit.recordings.timegrapher.TimegrapherRecording`, a
        :class:`~escfit.recordings.timeseries.TimeSeries` (a sampled angle: turning points or
        the whole waveform are fitted, see :mod:`escfit.fitting.recorded`), or the path of a
        file holding one of them, including raw tables and MATLAB files.
    solver, solver_options
        Forward solver (default: the scene's, see :func:`escfit.balance.default_solver`);
        passage-time and timegrapher fits need the exact solver's log.
    unit
        Keep only this unit of a multi-unit unit-curve file.
    fmt
        ``"unit-curve"``, ``"pulses"``, ``"timegrapher"``, ``"timeseries"`` or ``"raw"``
        (a raw table or ``.mat`` file read with the scene's ``[recording]`` options); detected
        from the file's content when ``None``.
    notch_deg
        Notch angle of notch counts (deg) when the file does not say.
    recording
        ``[recording]`` options overriding the scene's key by key (the command line's).

    Returns
    -------
    FitProblem, WaveformProblem or RecordingProblem
    """
    from ..balance import default_solver
    from ..recordings.pulses import PulseTrain
    from ..recordings.timegrapher import TimegrapherRecording
    from ..recordings.timeseries import TimeSeries
    from .recorded import problem_from_series

    sc = load_scene(scene) if not hasattr(scene, "model") else scene
    solver = solver or default_solver(sc)
    spec = _recording_spec(sc, recording)
    if isinstance(data, (str, Path)):
        data = _read_data(data, spec, fmt, notch_deg)
    options = dict(solver_options or {})
    if unit is not None and not isinstance(data, UnitCurve):
        raise FitError("--unit selects a unit of a unit-curve file; this recording holds one unit",
                       getattr(data, "source", None))
    if isinstance(data, TimeSeries):
        readings = spec.readings if spec is not None else "samples"
        problem = problem_from_series(sc, data, solver=solver, solver_options=options, readings=readings)
        problem.notes += _override_notes(sc, recording)
        if data.meta.get("angle_unit_assumed"):
            problem.data_warnings = list(getattr(problem, "data_warnings", [])) + [
                "the recording gives no angle unit and radians were assumed: if the angles are in another unit "
                "(deg, encoder counts, a sensor's volts, a position in mm) set [recording] angle_unit and scale"]
        return problem
    if math.isnan(sc.params["oscillator.theta0"].value):
        raise FitError("the scene leaves theta0 out, which only a sampled recording (a time series) can supply; "
                       "give [oscillator] theta0", sc.where)
    if isinstance(data, UnitCurve):
        if unit is not None:
            rows = np.flatnonzero(data.unit == unit)
            if not rows.size:
                raise FitError(f"no readings of unit {unit!r}; units in the file: {sorted(set(data.unit))}",
                               data.source)
            data = data.select(rows)
        return FitProblem(sc, data, solver, options)
    if isinstance(data, PulseTrain):
        from .pulse_problem import PulseFitProblem

        return PulseFitProblem(sc, data, solver, options)
    if isinstance(data, TimegrapherRecording):
        from .timegrapher_problem import TimegrapherFitProblem

        return TimegrapherFitProblem(sc, data, solver, options)
    raise FitError(f"cannot fit data of type {type(data).__name__}; give a recording or a file path")


def _recording_spec(scene, overrides: dict | None):
    """The scene's ``[recording]`` options with command-line overrides, or ``None`` if neither."""
    from ..recordings.recording_spec import merge_spec, recording_spec_from_table

    table = scene.extra.get("recording")
    given = {k: v for k, v in (overrides or {}).items() if v is not None}
    if table is None and not given:
        return None
    spec = recording_spec_from_table(table or {}, f"{scene.where}")
    return merge_spec(spec, **given) if given else spec


def _override_notes(scene, overrides: dict | None) -> list[str]:
    """Notes for command-line options that replace a different key of the scene's ``[recording]``."""
    table = scene.extra.get("recording") or {}
    given = {k for k, v in (overrides or {}).items() if v is not None}
    notes = [f"--{k.replace('_', '-')} replaces the scene's [recording] {k} = {table[k]!r}"
             for k in sorted(given) if k in table]
    for new, old in (("sample_rate", "time_column"), ("time_column", "sample_rate")):
        if new in given and old in table and old not in given:
            notes.append(f"--{new.replace('_', '-')} replaces the scene's [recording] {old} = {table[old]!r}")
    return notes


def _read_data(path, spec, fmt: str | None, notch_deg: float | None):
    """Read a recording file: a known escfit format, else a raw table or MATLAB file."""
    from ..errors import DataError
    from ..recordings.rawseries import read_raw_series
    from ..recordings.timegrapher import detect_format, read_recording

    if spec is not None or fmt == "raw":
        return read_raw_series(path, spec)
    detected = fmt
    if detected is None:
        try:
            detected = detect_format(path)
        except DataError as exc:
            try:
                return read_raw_series(path, None)
            except DataError as raw_exc:
                if "binary" in exc.message or "empty" in exc.message:
                    raise exc from None
                raise raw_exc from None
    options = {"notch_deg": notch_deg} if notch_deg is not None and detected == "unit-curve" else {}
    return read_recording(path, detected, **options)


def _tree(problem: FitProblem, lsq: LeastSquaresResult, mc: McmcResult | None, *, method: str, seed: int,
          started: str, predictive_draws: int = PP_DRAWS) -> xr.DataTree:
    names = problem.names
    units = {p.name: p.unit for p in problem.params}
    meanings = {p.name: p.meaning for p in problem.params}
    obs_coords = _obs_coords(problem)
    groups: dict[str, xr.Dataset] = {}
    reading_units = getattr(problem, "reading_units", None) or (
        "rad" if problem.data.kind == "amplitude" else "notches")
    groups["observed_data"] = xr.Dataset({"reading": ("obs", problem.observed, {"units": reading_units})},
                                         coords=obs_coords)
    lsq_expected = problem.expected(lsq.values)
    groups["least_squares"] = xr.Dataset(
        {"value": ("parameter", lsq.value), "stderr": ("parameter", lsq.stderr),
         "correlation": (("parameter", "parameter_b"), lsq.correlation),
         "expected": ("obs", lsq_expected, {"units": reading_units, "long_name": "expected reading at the optimum"})},
        coords={"parameter": lsq.names, "parameter_b": lsq.names, **obs_coords},
        attrs=clean_attrs({"chisqr": lsq.chisqr, "redchi": lsq.redchi, "sigma_hat": lsq.sigma_hat, "n_data": lsq.n_data,
                           "aic": lsq.aic(), "bic": lsq.bic(), "success": lsq.success, "message": lsq.message,
                           "n_starts": lsq.n_starts}))
    warnings = (correlation_warnings(lsq.names, lsq.correlation) + ridge_warnings(lsq.names, lsq.correlation)
                + phase_mode_warning(problem))
    misfit, misfit_warnings = _misfit(problem, lsq)
    misfit_warnings = _bound_warnings(problem, lsq) + misfit_warnings
    undefined = [n for n, e in zip(lsq.names, lsq.stderr) if not np.isfinite(e)]
    if undefined:
        warnings.append(f"least-squares standard errors undefined for {undefined} (singular or indefinite "
                        "covariance): the data do not fix them locally; use --method emcee")
    if mc is not None:
        post = {n: (("chain", "draw"), mc.chain[:, :, i], {"units": units.get(n, ""), "long_name": meanings.get(n, "")})
                for i, n in enumerate(names)}
        coords = {"chain": np.arange(mc.walkers), "draw": np.arange(mc.chain.shape[1])}
        if phase_mode_warning(problem):
            flat = mc.chain.reshape(-1, len(names))
            k = np.array([monday_k(problem, problem.values(x)) for x in flat]).reshape(mc.chain.shape[:2])
            post["K"] = (("chain", "draw"), k, {"units": "", "long_name": "Monday's combined K (derived)"})
        groups["posterior"] = xr.Dataset(post, coords=coords)
        groups["sample_stats"] = xr.Dataset({"lp": (("chain", "draw"), mc.log_prob)}, coords=coords)
        groups["diagnostics"] = _diagnostics(groups["posterior"], names, mc)
        groups["posterior_predictive"], groups["log_likelihood"] = _predictive(problem, mc, obs_coords, reading_units,
                                                                             predictive_draws)
        flat = mc.chain.reshape(-1, len(names))
        pc = np.corrcoef(flat.T) if len(names) > 1 else np.ones((1, 1))
        warnings = correlation_warnings(names, pc) + sloppy_directions(names, flat) + phase_mode_warning(problem)
        bad = [n for n in names if float(groups["diagnostics"]["rhat"].sel(parameter=n)) > 1.05]
        if bad:
            warnings.append(f"split R-hat above 1.05 for {bad}: run longer")
        if not mc.tau_reliable:
            warnings.append("the run is shorter than 50 autocorrelation times: intervals are approximate")
        if "observation.rho" in names and not any("nearly a smooth curve" in w for w in misfit_warnings):
            rho = float(np.median(mc.chain[:, :, names.index("observation.rho")]))
            if rho >= 0.95:
                warnings.append(f"the posterior noise correlation is rho = {rho:.3f}: the residuals are nearly a smooth "
                                "curve, structure the model misses rather than reading noise")
    warnings += misfit_warnings + list(getattr(problem, "data_warnings", []))
    attrs = {
        "schema_version": SCHEMA_VERSION, "method": method, "seed": seed, "parameters": names, "units": units,
        "meanings": meanings, "scene": problem.scene.text, "scene_file": problem.scene.where,
        "switching": problem.scene.switching, "data_file": problem.data.source, "data_sha256": problem.data.sha256,
        "data_kind": problem.data.kind, "solver": problem.solver, "solver_options": problem.solver_options,
        "versions": dependency_versions(), "started": started,
        "finished": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "warnings": warnings, "failures": dict(problem.failures), "misfit": misfit,
        "notes": list(getattr(problem, "notes", [])),
    }
    if mc is not None:
        attrs.update(walkers=mc.walkers, steps=mc.steps, burn=mc.burn, resumed=mc.resumed, moves=mc.moves)
    root = xr.DataTree(dataset=xr.Dataset(attrs=clean_attrs(attrs)))
    for name, ds in groups.items():
        root[name] = xr.DataTree(dataset=ds)
    return root


def _misfit(problem, lsq: LeastSquaresResult) -> tuple[dict, list[str]]:
    """Residual structure at the least-squares optimum (see :mod:`escfit.fitting.misfit`).

    Readings and expectations in one unit (angles, times) give residuals in that unit; notch
    counts are compared through the standardised residuals.
    """
    coords = _obs_coords(problem)
    n = problem.n_data
    if getattr(problem.data, "kind", "") == "notches" or getattr(problem.observation, "noise", "") == "ar1":
        # notch counts, and correlated noise (whose innovations should be white): standardised residuals
        resid, unit = problem.residuals(lsq.values)[:n], "noise scales"
    else:
        resid, unit = problem.observed - problem.expected(lsq.values), getattr(problem, "reading_units", "rad")
    is_turns = isinstance(problem, FitProblem)
    ar1 = getattr(problem.observation, "noise", "") == "ar1"
    figures, warnings = misfit_report(resid, coords["swing"][1] if is_turns else None, coords["curve"][1], unit=unit,
                                      branches=is_turns, innovations=ar1)
    warnings += _end_of_motion(problem, lsq)
    rho = lsq.values.get("observation.rho", 0.0)
    if rho >= 0.95:
        warnings.append(f"the residuals are nearly a smooth curve (noise correlation rho = {rho:.2f} between "
                        "neighbouring samples): that is structure the model misses rather than reading noise; the "
                        "intervals describe the best fit of an incomplete model")
    return figures, warnings


def _end_of_motion(problem, lsq: LeastSquaresResult) -> list[str]:
    """Waveform fits: does the model still swing as much as the record over its last period?

    Friction decides when a balance stops; a model whose friction law is wrong comes to rest
    too early or too late, which correlated-noise likelihoods can otherwise absorb.
    """
    from .waveform_problem import WaveformProblem

    if not isinstance(problem, WaveformProblem):
        return []
    t = problem.sample_time
    last = t >= t[-1] - float(problem.period)
    if np.count_nonzero(last) < 4:
        return []
    y, e = problem.observed[last], problem.expected(lsq.values)[last]
    swing_data, swing_model = float(np.ptp(y)), float(np.ptp(e))
    noise = 4.0 * float(lsq.values.get("observation.sigma", 0.0))
    if swing_data > noise and not 0.5 <= swing_model / swing_data <= 2.0:
        return [f"over the last period of the record the model swings {math.degrees(swing_model):.3g} deg where the "
                f"recording swings {math.degrees(swing_data):.3g} deg: the model's friction ends the motion "
                f"{'too early' if swing_model < swing_data else 'too late'} (a friction law the scene lacks?)"]
    return []


def _bound_warnings(problem, lsq: LeastSquaresResult) -> list[str]:
    """Parameters whose best fit sits on a bound of the scene's range."""
    lo, hi = problem.bounds
    out = []
    for i, name in enumerate(problem.names):
        if name not in lsq.names:
            continue
        v = float(lsq.value[lsq.names.index(name)])
        span = hi[i] - lo[i] if np.isfinite(hi[i] - lo[i]) else max(abs(v), 1.0)
        for edge, which in ((lo[i], "lower"), (hi[i], "upper")):
            if np.isfinite(edge) and abs(v - edge) <= 1e-6 * span:
                zero = which == "lower" and edge == 0.0
                out.append(f"{name} ends on its {which} bound {edge:g}" + (
                    ": the data find no evidence for it (an upper limit is what they give)" if zero else
                    ": the data want it beyond the scene's range; widen the range or check the units"))
    return out


def _obs_coords(problem: FitProblem) -> dict:
    swing = np.concatenate([c.swing for c in problem.curves])
    curve = np.concatenate([[c.label] * c.swing.size for c in problem.curves])
    load = np.concatenate([[c.load] * c.swing.size for c in problem.curves])
    coords = {"obs": np.arange(swing.size), "swing": ("obs", swing), "curve": ("obs", curve.astype(str)),
              "load": ("obs", load)}
    times = [getattr(c, "time", None) for c in problem.curves]
    if all(t is not None for t in times):
        coords["time"] = ("obs", np.concatenate(times), {"units": "s"})
    return coords


def _diagnostics(post: xr.Dataset, names: list[str], mc: McmcResult) -> xr.Dataset:
    import arviz as az

    sub = post[names]
    rhat = az.rhat(sub)
    ess_b = az.ess(sub, method="bulk")
    ess_t = az.ess(sub, method="tail")
    return xr.Dataset(
        {"rhat": ("parameter", [float(rhat[n]) for n in names]),
         "ess_bulk": ("parameter", [float(ess_b[n]) for n in names]),
         "ess_tail": ("parameter", [float(ess_t[n]) for n in names]),
         "tau": ("parameter", mc.tau), "acceptance": ("chain", mc.acceptance)},
        coords={"parameter": names, "chain": np.arange(mc.walkers)},
        attrs={"tau_reliable": int(mc.tau_reliable)})


def _predictive(problem: FitProblem, mc: McmcResult, obs_coords: dict, reading_units: str,
                draws: int) -> tuple[xr.Dataset, xr.Dataset]:
    """Expected readings and pointwise log-likelihood for a thinned set of draws."""
    per_chain = max(1, draws // mc.walkers)
    idx = np.unique(np.linspace(0, mc.chain.shape[1] - 1, per_chain).astype(int))
    exp = np.full((mc.walkers, idx.size, problem.n_data), np.nan)
    ll = np.full_like(exp, -np.inf)
    for w in range(mc.walkers):
        for j, d in enumerate(idx):
            vals = problem.values(mc.chain[w, d])
            try:
                exp[w, j] = problem.expected(vals)
                ll[w, j] = problem.loglike_pointwise(vals)
            except Exception:  # noqa: BLE001 - a failed draw stays NaN / -inf
                problem.failures["posterior predictive solve failed"] += 1
    coords = {"chain": np.arange(mc.walkers), "draw": idx, **obs_coords}
    return (xr.Dataset({"expected": (("chain", "draw", "obs"), exp, {"units": reading_units})}, coords=coords),
            xr.Dataset({"reading": (("chain", "draw", "obs"), ll)}, coords=coords,
                       attrs={"note": "pointwise log-likelihood on the thinned draws of posterior_predictive"}))
