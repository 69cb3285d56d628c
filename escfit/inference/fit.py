"""One fit for every model family: least squares, then optionally emcee, into one results schema.

``fit(scene, data)`` looks the family up from the scene's ``model =``, builds its
:class:`~escfit.likelihood.problem.Problem`, runs :func:`~escfit.inference.lsq.least_squares`
(and :func:`~escfit.inference.mcmc.run_emcee`), checks what the data determine and how well
the model fits, and returns a :class:`~escfit.results.FitResult` laid out as ArviZ expects
(see :mod:`escfit.results`).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..core.errors import FitError
from ..core.limits import check_sampler_size
from ..core.provenance import dependency_versions
from ..core.scene import load_scene
from ..core.timings import phase
from ..likelihood.problem import Problem
from .information import information_attrs
from .identifiability import bound_warnings, correlation_warnings, ridge_warnings, sloppy_directions
from .lmfit_path import check_method
from .lsq import LeastSquaresResult, least_squares
from .misfit import misfit_report
from .reconcile import reconcile, verdict, with_held_uncertainty
from .registry import family
from .trf import minimize

if TYPE_CHECKING:
    from ..core.plain_tree import Group, Tree
    from ..results import FitResult
    from .mcmc import McmcResult

__all__ = ["fit", "fit_problem", "build_tree"]

GENERIC_DEFAULTS = {"walkers": 32, "steps": "auto", "max_steps": 20000, "burn": None, "n_starts": 8,
                    "n_refine": None, "predictive_draws": 400, "moves": "stretch"}

# xarray, the results schema and the sampler (emcee, scipy.stats) are imported where they are
# used: a least-squares fit reaches its first model evaluation without them.  The three
# functions below stand for theirs at module level (tests and benchmarks replace them here).


def run_emcee(*args, **kwargs):
    """:func:`escfit.inference.mcmc.run_emcee`, imported on first use."""
    from .mcmc import run_emcee as run

    return run(*args, **kwargs)


def resumable(*args, **kwargs):
    """:func:`escfit.inference.mcmc.resumable`, imported on first use."""
    from .mcmc import resumable as check

    return check(*args, **kwargs)


def write_fit(*args, **kwargs):
    """:func:`escfit.results.write_fit`, imported on first use."""
    from ..results import write_fit as write

    return write(*args, **kwargs)


def fit(scene, data, *, method: str = "leastsq", out: str | Path | None = None, force: bool = False, seed: int = 0,
        walkers: int | None = None, steps: int | str | None = None, burn: int | None = None,
        n_starts: int | None = None, resume: bool = False, progress: bool = False,
        checkpoint: str | Path | None = None, predictive_draws: int | None = None, moves: str | None = None,
        max_steps: int | None = None, checkpoint_every: float = 10.0, title: str | None = None,
        **options) -> FitResult:
    """Fit a scene of any model family to a recording.

    Parameters
    ----------
    scene
        Scene object or path; ``model =`` names the family and its ``vary = true``
        parameters are estimated.
    data
        A recording object of the family, or the path of a recording file.
    method
        ``"leastsq"`` (scipy trust-region, multistart), ``"emcee"`` (least squares, then MCMC) or
        ``"lmfit:NAME"``: least squares with lmfit's minimiser ``NAME`` in place of scipy's trust
        region (``leastsq``, ``least_squares``, ``nelder``, ``differential_evolution`` ...; see
        :mod:`escfit.inference.lmfit_path`), the results in the same layout, the method recorded.
    out
        Results file (HDF5); written atomically and never replacing a file without ``force``.
        Refused before any work when it or its checkpoint is the data or scene file, or when
        its folder is missing or not writable.
    seed, walkers, steps, burn, n_starts, progress
        Sampler and optimiser settings (``seed`` in [0, 2**32 - 1]); ``None`` takes the family's default
        (``fit_defaults``; ``burn`` defaults to the first quarter of the run: the walkers start at the
        least-squares optimum).  ``steps = "auto"`` samples until converged (see
        :func:`~escfit.inference.mcmc.run_emcee`), at most ``max_steps``.
    resume
        Continue an interrupted emcee run from its checkpoint.
    checkpoint
        Sampler checkpoint (default ``<out>.emcee`` when ``out`` is given).
    checkpoint_every
        Seconds between checkpoint saves (a kill loses at most the steps since the last one).
    predictive_draws
        Posterior draws at which the expected readings and the pointwise log-likelihood
        (for PSIS-LOO) are stored.
    moves
        emcee's proposal: ``"stretch"``, ``"de"`` or ``"de-t"`` (see :func:`~escfit.inference.mcmc.run_emcee`);
        ``None`` takes the family's default.
    title
        A title for reports (a fit recipe's ``title``), kept in the results' attributes.
    **options
        The family's problem options, refused when unknown: balance ``solver``,
        ``solver_options``, ``unit``, ``fmt``, ``notch_deg``, ``recording``; friction rig
        ``material``; Geneva ``fmt``; verge ``step`` (see each family's ``problem``).

    Returns
    -------
    FitResult
        Also written to ``out`` when given.
    """
    from ..core.atomic import check_output_folder, refuse_clobbering_inputs, refuse_existing
    from ..core.inputs import check_input_file
    from ..core.outlock import output_lock

    check_method(method)
    if resume and method != "emcee":
        raise FitError("--resume continues an interrupted emcee run; a least-squares fit has nothing to resume "
                       "(use --method emcee, or leave out --resume)")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**32:
        raise FitError(f"seed must be a whole number in [0, 2**32 - 1], got {seed!r}")
    if checkpoint is None and out is not None and method == "emcee":
        checkpoint = str(out) + ".emcee"
    if out is not None:
        paths = lambda x: x if isinstance(x, (str, Path)) else None  # noqa: E731 - objects are not files
        refuse_clobbering_inputs({"out": out, "checkpoint": checkpoint if method == "emcee" else None},
                                 {"data": paths(data), "scene": paths(scene)})
        refuse_existing(out, force)
        check_output_folder(out, "out")
    if isinstance(data, (str, Path)):
        check_input_file(data, "data")
    with output_lock(out) if out is not None else contextlib.nullcontext():  # one run per results file
        if method == "emcee" and checkpoint is not None:
            _check_checkpoint(checkpoint, resume=resume, force=force)
        with phase("scene"):
            sc = load_scene(scene) if not hasattr(scene, "model") else scene
        fam = family(sc.model)
        defaults = {**GENERIC_DEFAULTS, **dict(getattr(fam, "fit_defaults", {}))}
        pick = lambda value, key: defaults[key] if value is None else value  # noqa: E731
        with phase("record"):  # reading and analysing the recording, building the problem
            problem = fam.problem(sc, data, **options)
        if out is not None:
            _remove_stale_temporaries(out, checkpoint)
        if method == "emcee" and checkpoint is not None and force and not resume:
            Path(checkpoint).unlink(missing_ok=True)  # a forced fresh run must not leave the old run resumable
        return fit_problem(problem, method=method, out=out, force=force, seed=seed, walkers=pick(walkers, "walkers"),
                           steps=pick(steps, "steps"), burn=pick(burn, "burn"), n_starts=pick(n_starts, "n_starts"),
                           n_refine=defaults["n_refine"], resume=resume, progress=progress, checkpoint=checkpoint,
                           predictive_draws=pick(predictive_draws, "predictive_draws"), moves=pick(moves, "moves"),
                           max_steps=pick(max_steps, "max_steps"), checkpoint_every=checkpoint_every, title=title,
                           fit_options=options)


def fit_problem(problem: Problem, *, method: str = "leastsq", out: str | Path | None = None, force: bool = False,
                seed: int = 0, walkers: int = 32, steps: int | str = "auto", burn: int | None = None,
                n_starts: int = 8, n_refine: int | None = None, resume: bool = False, progress: bool = False,
                checkpoint: str | Path | None = None, predictive_draws: int = 400,
                moves: str = "stretch", max_steps: int = 20000, checkpoint_every: float = 10.0,
                title: str | None = None, fit_options: dict | None = None) -> FitResult:
    """:func:`fit` of a prepared problem (any family).

    ``fit_options`` are the options the problem was built with; with the problem's provenance
    they identify the run, so that a checkpoint resumes only its own run.  The result's
    ``timings`` attribute holds the seconds spent in each phase (least squares, sampling,
    checkpoint saves, diagnostics and predictive draws, writing).
    """
    if predictive_draws < 1:
        raise FitError(f"predictive_draws must be at least 1, got {predictive_draws}")
    if method == "emcee":  # too large a run is refused before any work
        check_sampler_size(walkers, max_steps if steps == "auto" else int(steps), len(problem.names))
    if method == "emcee" and resume:  # a checkpoint of another run is refused before any work
        if checkpoint is None:
            raise FitError("resume needs the checkpoint of the run to continue (give out or checkpoint)")
        resumable(problem, checkpoint, walkers=walkers, moves=moves, seed=seed,
                  target=None if steps == "auto" else steps, provenance=problem.provenance(), fit_options=fit_options)
    started = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    clock = time.perf_counter()
    optimizer, lmfit_name = minimize, check_method(method)
    if lmfit_name is not None:
        from .lmfit_path import GLOBAL, lmfit_optimizer

        optimizer = lmfit_optimizer(problem, lmfit_name, seed=seed)
        if lmfit_name in GLOBAL:  # a global search covers the box itself: one run, not one per start
            n_starts, n_refine = 1, 1
    with phase("least squares"):
        lsq = least_squares(problem, n_starts=n_starts, n_refine=n_refine, seed=seed, priors_count=method == "emcee",
                            optimizer=optimizer, nearby=method != "emcee")
        lsq, fixes, unresolved, problem = reconcile(problem, lsq, seed=seed, priors_count=method == "emcee",
                                                    optimizer=optimizer)
        lsq, more = with_held_uncertainty(problem, lsq)
    fixes += more + list(getattr(optimizer, "notes", []))
    if method == "emcee" and getattr(problem, "held", ()):
        fixes.append(f"the posterior holds {', '.join(problem.held)} where the recording's own measurement puts it; "
                     "its uncertainty is in the least-squares intervals but not in the posterior's")
    timings = {"least_squares_s": time.perf_counter() - clock}
    clock = time.perf_counter()
    model = getattr(getattr(problem, "scene", None), "model", None)  # the fit held against the record itself
    with phase("agreement"):
        agreement = family(model).agreement(problem, lsq, _refit, seed=seed) if isinstance(model, str) else None
    if agreement is not None:
        timings["agreement_s"] = time.perf_counter() - clock
    mc = None
    if method == "emcee":
        with phase("sampling"):
            mc = run_emcee(problem, lsq, walkers=walkers, steps=steps, burn=burn, seed=seed, checkpoint=checkpoint,
                           resume=resume, progress=progress, moves=moves, max_steps=max_steps,
                           checkpoint_every=checkpoint_every, provenance=problem.provenance(), fit_options=fit_options)
        timings.update(mc.timings)
    clock = time.perf_counter()
    with phase("results"):  # diagnostics and the results tree; xarray only once there is a result
        from ..results import FitResult, clean_attrs

        tree = build_tree(problem, lsq, mc, method=method, seed=seed, started=started,
                          predictive_draws=predictive_draws, fixes=fixes, unresolved=unresolved, agreement=agreement)
    timings["diagnostics_s"] = time.perf_counter() - clock
    tree.attrs.update(clean_attrs({"timings": {k: round(float(v), 4) for k, v in timings.items()}}))
    if title:
        tree.attrs["title"] = str(title)
    result = FitResult(tree)
    if out is not None:
        clock = time.perf_counter()
        with phase("write"):
            write_fit(result, out, force=force)
        if checkpoint is not None and Path(checkpoint).exists():
            Path(checkpoint).unlink()
        timings["write_s"] = time.perf_counter() - clock
    result.timings = timings
    return result


def _check_checkpoint(checkpoint: str | Path, *, resume: bool, force: bool) -> None:
    """Before any work: a fresh run refuses a checkpoint it would lose (unless ``force``), and
    ``resume`` refuses a missing or unreadable one, naming ``--force`` as the way to start again.

    A run refused before sampling never writes a checkpoint (the sampler saves its first one
    after its first steps), so a refusal cannot leave one behind to block the next run.
    """
    from ..core.errors import ResultsError
    from .checkpoint import FORMAT

    from ..core.atomic import refuse_existing

    path = Path(checkpoint)
    refuse_existing(path, force=True)  # a device, FIFO, socket or link there is never replaced
    if not resume:
        if path.exists() and not force:
            raise FitError("an interrupted run's checkpoint exists; pass --resume to continue it or --force to "
                           "restart", str(checkpoint))
        return
    if not path.exists():
        raise ResultsError("nothing to resume: checkpoint file not found; run without --resume", str(checkpoint))
    import h5py

    try:
        with h5py.File(path, "r") as f:
            kind = f.attrs.get("format")
    except (OSError, ValueError) as exc:  # garbage, truncated or unreadable
        raise ResultsError(f"cannot resume from this checkpoint ({type(exc).__name__}: {exc}); pass --force to "
                           "start again", str(checkpoint)) from None
    if kind != FORMAT:
        raise ResultsError("not an escfit sampler checkpoint (written by another program or an older version); "
                           "pass --force to start again", str(checkpoint))


def _remove_stale_temporaries(out: str | Path, checkpoint: str | Path | None) -> None:
    """Delete what an earlier run of this output killed mid-write left: its hidden ``.part`` files.

    Only this run's own names are touched (``.<out name>.*.part`` and ``.<checkpoint name>.*.part``
    beside them, written by :func:`escfit.core.atomic.atomic_path` and the checkpoint saver).
    """
    for target in filter(None, (out, checkpoint)):
        target = Path(target)
        for stale in target.parent.glob(f".{target.name}.*.part"):
            if stale.name.count(".emcee.") == target.name.count(".emcee"):  # not the other file's temporaries
                stale.unlink(missing_ok=True)


def build_tree(problem: Problem, lsq: LeastSquaresResult, mc: McmcResult | None, *, method: str, seed: int,
               started: str, predictive_draws: int = 400, fixes: list[str] | None = None,
               unresolved: list | None = None, agreement=None) -> Tree:
    """The results tree of a fit (groups and attributes of :mod:`escfit.results`), as plain arrays:
    a :class:`~escfit.core.plain_tree.Tree`, whose ``to_xarray()`` gives the ``xarray.DataTree``.

    ``fixes`` and ``unresolved`` come from :func:`~escfit.inference.reconcile.reconcile`: what was
    refitted to agree with the recording's direct measurements, and what still disagrees;
    ``agreement`` is the problem's check of the fit against the record
    (:class:`escfit.analysis.agreement.Agreement`), or ``None``.
    """
    from ..core.plain_tree import Group, Tree
    from ..results import SCHEMA_VERSION, clean_attrs

    names = list(problem.names)
    units, meanings = dict(problem.units), dict(problem.meanings)
    obs_coords = problem.obs_coords()
    reading_units = problem.reading_units
    groups: dict[str, Group] = {}
    groups["observed_data"] = Group({"reading": ("obs", problem.observed, {"units": reading_units})},
                                         coords=obs_coords)
    bounded = {key: ("parameter", np.asarray(lsq.intervals[key], float),
                     {"long_name": f"{key[2:]} % interval inside the bounds ({'lower' if key[:2] == 'lo' else 'upper'} "
                                   "end), delta method in log/logit coordinates"})
               for key in ("lo68", "hi68", "lo95", "hi95")}
    groups["least_squares"] = Group(
        {"value": ("parameter", lsq.value), "stderr": ("parameter", lsq.stderr),
         "correlation": (("parameter", "parameter_b"), lsq.correlation),
         **bounded,
         "min": ("parameter", np.asarray(lsq.lower, float), {"long_name": "lower bound of the scene's range"}),
         "max": ("parameter", np.asarray(lsq.upper, float), {"long_name": "upper bound of the scene's range"}),
         "at_bound": ("parameter", np.asarray(lsq.at_bound, np.int8),
                      {"long_name": "estimate on its lower (-1) or upper (+1) bound, else 0"}),
         "expected": ("obs", problem.expected(lsq.values),
                      {"units": reading_units, "long_name": "expected reading at the optimum"})},
        coords={"parameter": lsq.names, "parameter_b": lsq.names, **obs_coords},
        attrs=clean_attrs({"chisqr": lsq.chisqr, "redchi": lsq.redchi, "sigma_hat": lsq.sigma_hat,
                           "n_data": lsq.n_data, **information_attrs(problem, lsq),
                           "success": lsq.success,
                           "message": lsq.message, "n_starts": lsq.n_starts, "noise_profiled": lsq.profiled,
                           "interval_method": "delta method in log(x - min), -log(max - x) or logit coordinates "
                                              "(identity when unbounded); one-sided on a bound"}))
    misfit, misfit_warnings = _misfit(problem, lsq, obs_coords)
    family_figures, family_warnings = problem.checks_at_best_fit(lsq.values)
    misfit.update(family_figures)
    misfit_warnings = bound_warnings(problem, lsq) + misfit_warnings + family_warnings
    if not lsq.success:
        misfit_warnings.append(f"least squares did not converge: {lsq.message}")
    warnings = correlation_warnings(lsq.names, lsq.correlation) + ridge_warnings(lsq.names, lsq.correlation)
    warnings += list(lsq.warnings)
    undefined = [n for n, e in zip(lsq.names, lsq.stderr) if not np.isfinite(e)]
    if undefined and not lsq.warnings:
        warnings.append(f"least-squares standard errors undefined for {undefined} (singular or indefinite "
                        "covariance): the data do not fix them locally; use --method emcee")
    if mc is not None:
        post = {n: (("chain", "draw"), mc.chain[:, :, i], {"units": units.get(n, ""), "long_name": meanings.get(n, "")})
                for i, n in enumerate(names)}
        coords = {"chain": np.arange(mc.walkers), "draw": np.arange(mc.chain.shape[1])}
        derived = _derived(problem, mc, units, meanings)
        post.update(derived)
        groups["posterior"] = Group(post, coords=coords)
        groups["sample_stats"] = Group({"lp": (("chain", "draw"), mc.log_prob)}, coords=coords)
        groups["diagnostics"] = _diagnostics(groups["posterior"], names, mc)
        groups["posterior_predictive"], groups["log_likelihood"] = _predictive(problem, mc, obs_coords, reading_units,
                                                                             predictive_draws)
        flat = mc.chain.reshape(-1, len(names))
        pc = np.corrcoef(flat.T) if len(names) > 1 else np.ones((1, 1))
        convergence = []  # first: an unconverged run makes every other statement provisional
        bad = [n for n, r in zip(names, groups["diagnostics"]["rhat"].values) if float(r) > 1.05]
        if bad:
            convergence.append(f"split R-hat above 1.05 for {', '.join(bad)}: the walkers have not converged; "
                               "run longer")
        if mc.auto and not mc.converged:
            convergence.append(f"the run stopped at its cap of {mc.steps} steps before the convergence criteria were "
                               f"met ({mc.verdict}); run longer (--max-steps) or fix the model")
        elif not mc.tau_reliable:
            convergence.append("the run is shorter than 50 autocorrelation times: intervals are approximate")
        warnings = convergence + correlation_warnings(names, pc) + sloppy_directions(names, flat)
        warnings += [w for w in problem.checks_of_posterior(mc.chain) if w not in family_warnings]
    status, undetermined, statement = verdict(problem, lsq, list(unresolved or []), posterior=mc is not None,
                                              agreement=agreement)
    if agreement is not None:
        warnings = list(agreement.cautions) + warnings
        fixes = list(fixes or []) + ([agreement.note()] if agreement.agrees and agreement.note() else [])
    warnings = _unique(([statement] if statement else []) + warnings + misfit_warnings
                       + list(getattr(problem, "data_warnings", [])))
    attrs = {
        "schema_version": SCHEMA_VERSION, "model": problem.family, "method": method, "seed": seed,
        "parameters": names, "units": units, "meanings": meanings, **problem.provenance(),
        "versions": dependency_versions(), "started": started,
        "finished": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "warnings": warnings, "failures": dict(problem.failures), "misfit": misfit,
        "notes": list(getattr(problem, "notes", [])) + list(fixes or []), "held": _held(problem, lsq),
        "verdict": status, "undetermined": undetermined, "other_optimum": dict(getattr(lsq, "other_optimum", {})),
    }
    if mc is not None:
        attrs.update(walkers=mc.walkers, steps=mc.steps, burn=mc.burn, resumed=mc.resumed, moves=mc.moves,
                     derived=list(derived), steps_mode="auto" if mc.auto else "fixed")
        if mc.auto:
            attrs.update(converged=int(bool(mc.converged)), convergence=mc.verdict)
    return Tree(clean_attrs(attrs), groups)


def _held(problem: Problem, lsq: LeastSquaresResult) -> dict[str, float]:
    """Parameters the fit did not vary (fixed by the scene, or tied to a free one), at their values.

    Reports list them as held; a noise scale profiled by least squares and sampled later is free,
    not held.
    """
    units = dict(problem.units)
    free = set(problem.names) | set(lsq.names)
    out = {}
    for name, value in dict(lsq.values).items():
        if name not in free and name in units and np.ndim(value) == 0 and np.isfinite(value):
            out[name] = float(value)
    return out


def _unique(items: list[str]) -> list[str]:
    return list(dict.fromkeys(items))


def _misfit(problem: Problem, lsq: LeastSquaresResult, coords: dict) -> tuple[dict, list[str]]:
    """Residual structure at the least-squares optimum (see :mod:`escfit.inference.misfit`).

    Readings and expectations in one unit give residuals in that unit; readings whose noise
    is not additive in their unit (notch counts) or is correlated (whose innovations should
    be white) are compared through the standardised residuals, as the problem's
    ``misfit_options`` say.
    """
    opts = dict(getattr(problem, "misfit_options", {}) or {})
    n = problem.n_data
    if opts.get("standardised"):
        resid, unit = np.asarray(problem.residuals(lsq.values), float)[:n], "noise scales"
    else:
        resid, unit = problem.observed - problem.expected(lsq.values), problem.reading_units
    swing = coords["swing"][1] if opts.get("branches") and "swing" in coords else None
    curve = coords["curve"][1] if "curve" in coords else None
    return misfit_report(resid, swing, curve, unit=unit, branches=bool(opts.get("branches")),
                         innovations=bool(opts.get("innovations")))


def _derived(problem: Problem, mc: McmcResult, units: dict, meanings: dict) -> dict:
    """Derived quantities of every posterior draw (``problem.derived``), as posterior variables."""
    first = problem.derived(problem.values(mc.chain[0, 0]))
    if not first:
        return {}
    flat = mc.chain.reshape(-1, mc.chain.shape[-1])
    rows = [problem.derived(problem.values(x)) for x in flat]
    out = {}
    for key in first:
        v = np.array([r.get(key, np.nan) for r in rows], float).reshape(mc.chain.shape[:2])
        out[key] = (("chain", "draw"), v, {"units": units.get(key, ""), "long_name": meanings.get(key, key)})
    return out


def _diagnostics(post: Group, names: list[str], mc: McmcResult) -> Group:
    from ..core.plain_tree import Group
    from .convergence import chain_diagnostics

    if mc.figures is not None and list(names) == list(mc.names):
        rhat, ess_b, ess_t = mc.figures  # the automatic stop's figures, of these very draws
    else:  # (chain, draw, parameter), each parameter's draws as the posterior group holds them
        rhat, ess_b, ess_t = chain_diagnostics(np.stack([post[n].values for n in names], axis=-1))  # (chain, draw)
    return Group(
        {"rhat": ("parameter", rhat),
         "ess_bulk": ("parameter", ess_b),
         "ess_tail": ("parameter", ess_t),
         "tau": ("parameter", mc.tau), "acceptance": ("chain", mc.acceptance)},
        coords={"parameter": names, "chain": np.arange(mc.walkers)},
        attrs={"tau_reliable": int(mc.tau_reliable)})


def _predictive(problem: Problem, mc: McmcResult, obs_coords: dict, reading_units: str,
                draws: int) -> tuple[Group, Group]:
    """Expected readings and pointwise log-likelihood for a thinned set of draws."""
    from ..core.plain_tree import Group

    per_chain = max(1, draws // mc.walkers)
    idx = np.unique(np.linspace(0, mc.chain.shape[1] - 1, per_chain).astype(int))
    many = getattr(problem, "predictive_many", None)
    if many is not None:  # every thinned draw in one batch call
        e, lp = many(mc.chain[:, idx, :].reshape(-1, mc.chain.shape[-1]))
        exp, ll = e.reshape(mc.walkers, idx.size, -1), lp.reshape(mc.walkers, idx.size, -1)
    else:
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
    return (Group({"expected": (("chain", "draw", "obs"), exp, {"units": reading_units})}, coords=coords),
            Group({"reading": (("chain", "draw", "obs"), ll)}, coords=coords,
                       attrs={"note": "pointwise log-likelihood on the thinned draws of posterior_predictive"}))


def _refit(problem, start, seed: int):
    """Least squares of another problem of the same record (the agreement check's turning-point
    fit): from ``start``, checked against the measured period, with the held omega0's
    uncertainty; ``(result, unresolved)``."""
    lsq = least_squares(problem, n_starts=1, seed=seed, start=start)
    lsq, _, unresolved, problem = reconcile(problem, lsq, seed=seed)
    lsq, _ = with_held_uncertainty(problem, lsq)
    return lsq, unresolved
