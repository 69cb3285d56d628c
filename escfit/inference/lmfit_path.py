"""``--method lmfit:NAME``: any lmfit minimiser in place of escfit's trust-region runs.

The fit is the same as escfit's default least squares in everything but the optimiser: the
same cost (the readings' standardised residuals plus the Gaussian priors' rows), the same
ranked multistart, noise profiling, two-stage correlated noise, reconciliation with the
recording's direct measurements, and the same uncertainties (``J^T J`` of the stacked residuals
at the optimum lmfit found, by escfit's forward differences, the batch path where the problem
has one).  Each start runs ``lmfit.Minimizer(...).minimize(method=NAME)`` over
``lmfit.Parameters`` built as :mod:`escfit.inference.lmfit_params` builds them.

* ``leastsq`` (MINPACK's Levenberg-Marquardt) and ``least_squares`` (scipy's trust region) get
  escfit's Jacobian (one batch call per Jacobian where the problem is vectorised) and the trust
  region's tolerances (``ftol = xtol = gtol = 1e-8``);
* ``leastsq`` sees bounds through lmfit's transform, which is flat on a bound: a parameter the
  optimum puts on its bound is held there (:func:`_leastsq_with_active_bounds`);
* scalar minimisers with a gradient (``bfgs``, ``lbfgsb``, ``cg``, ``newton``, ``tnc``,
  ``slsqp``) get ``2 J^T r``; those without (``nelder``, ``powell``, ``cobyla``) use the cost alone;
* global searches (:data:`GLOBAL`) run once over the bounded box instead of from each start;
  an open bound is closed at the prior's 0.1 % / 99.9 % quantile, or refused when the prior is
  improper, and said so in the results' notes.

lmfit is imported only when such a method runs; :data:`LMFIT_METHODS` lets the command line
check a name without importing it.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from ..core.errors import FitError
from ..likelihood.problem import Problem
from .fdjac import batch_jacobian
from .lmfit_params import import_lmfit, lmfit_key
from .lsq import bound_flags
from .trf import DEFAULT_TOL, Optimum, optimum

__all__ = ["LMFIT_PREFIX", "LMFIT_METHODS", "GLOBAL", "lmfit_method", "lmfit_optimizer", "check_method"]

LMFIT_PREFIX = "lmfit:"

#: global searches: one run over the bounded box (they search it themselves)
GLOBAL = frozenset({"differential_evolution", "brute", "basinhopping", "ampgo", "shgo", "dual_annealing"})

#: scalar minimisers that take a gradient
GRADIENT = frozenset({"cg", "bfgs", "newton", "lbfgsb", "l-bfgsb", "tnc", "slsqp", "trust-constr"})

#: lmfit's minimiser names (``Minimizer.minimize(method=...)``) that escfit runs
LMFIT_METHODS = ("leastsq", "least_squares", "nelder", "powell", "cg", "bfgs", "newton", "lbfgsb", "l-bfgsb", "tnc",
                 "cobyla", "slsqp", "trust-constr", "differential_evolution", "brute", "basinhopping", "ampgo",
                 "shgo", "dual_annealing")

#: lmfit names escfit does not run, and why
NOT_RUN = {"emcee": "lmfit's emcee is a sampler, not a minimiser: use --method emcee (escfit's sampler)",
           "dogleg": "it needs a Hessian", "trust-ncg": "it needs a Hessian", "trust-exact": "it needs a Hessian",
           "trust-krylov": "it needs a Hessian"}

#: brute force: most grid points tried (lmfit's default is 20 per free parameter)
BRUTE_MAX_POINTS = 100_000


def check_method(method: str) -> str | None:
    """The lmfit minimiser a fit ``method`` names (``None`` for ``leastsq`` and ``emcee``).

    Raises
    ------
    FitError
        One line naming the valid methods, for an unknown method or lmfit name.
    """
    if method in ("leastsq", "emcee"):
        return None
    valid = ", ".join(LMFIT_PREFIX + m for m in LMFIT_METHODS)
    if not method.startswith(LMFIT_PREFIX):
        raise FitError(f"method must be 'leastsq', 'emcee' or lmfit:NAME ({valid}), got {method!r}")
    name = method[len(LMFIT_PREFIX):]
    if name in NOT_RUN:
        raise FitError(f"{method} is not run by escfit: {NOT_RUN[name]}; lmfit methods: {valid}")
    if name not in LMFIT_METHODS:
        raise FitError(f"unknown lmfit method {name!r}; lmfit methods: {valid}")
    return name


def lmfit_method(method: str) -> str | None:
    """``NAME`` of ``lmfit:NAME``, else ``None`` (no check; see :func:`check_method`)."""
    return method[len(LMFIT_PREFIX):] if method.startswith(LMFIT_PREFIX) else None


def _search_box(problem: Problem, names: list[str], lo: np.ndarray, hi: np.ndarray, method: str, notes: list[str]):
    """Finite bounds for a global search: the scene's, an open side closed at the prior's quantile
    (said in ``notes``, the optimiser's notes for the results)."""
    lo, hi = lo.copy(), hi.copy()
    closed = []
    for i, name in enumerate(names):
        if math.isfinite(lo[i]) and math.isfinite(hi[i]):
            continue
        prior = problem.priors[problem.names.index(name)]
        ppf = getattr(prior, "ppf", None)
        edges = np.asarray(ppf(np.array([1e-3, 1 - 1e-3])), float) if ppf is not None and getattr(prior, "proper", True) \
            else np.array([np.nan, np.nan])
        if not np.all(np.isfinite(edges)):
            raise FitError(f"lmfit:{method} searches a bounded box, and {name} has an open range and no proper prior "
                           "to close it: give it min and max in the scene")
        lo[i], hi[i] = max(lo[i], edges[0]), min(hi[i], edges[1])
        closed.append(f"{name} in [{lo[i]:.6g}, {hi[i]:.6g}]")
    if closed:
        note = (f"lmfit:{method} searched {', '.join(closed)} (the prior's 0.1-99.9 % range where the scene "
                "leaves the range open)")
        if note not in notes:
            notes.append(note)
    return lo, hi


def lmfit_optimizer(problem: Problem, method: str, *, seed: int = 0) -> Callable[..., Optimum]:
    """An optimiser for :func:`~escfit.inference.lsq.least_squares` running lmfit's ``method``.

    Parameters
    ----------
    problem
        The problem fitted (its priors close open bounds for a global search; notes are added).
    method
        An lmfit minimiser name (:data:`LMFIT_METHODS`).
    seed
        Seeds the stochastic searches (differential evolution, basin hopping, dual annealing).

    Returns
    -------
    callable
        ``(fun, x0, lower, upper, *, scale_covar, names, **options) -> Optimum``, as
        :func:`~escfit.inference.trf.minimize`.
    """
    lmfit = import_lmfit()

    def run(fun, x0, lower, upper, *, scale_covar: bool = False, names: list[str] | None = None,
            **options) -> Optimum:
        lower, upper = np.asarray(lower, float), np.asarray(upper, float)
        names = list(names) if names is not None else [f"p{i}" for i in range(len(x0))]
        k = len(names)
        diff_step = options.get("diff_step")
        batch = options.get("jac") if callable(options.get("jac")) else None

        def jacobian(x: np.ndarray, f0: np.ndarray | None = None) -> np.ndarray:
            if batch is not None:
                return np.asarray(batch(x), float)
            rows = lambda pts: np.array([fun(p) for p in pts])  # noqa: E731 - one evaluation per stepped point
            return batch_jacobian(rows, x, lower, upper, f0=fun(x) if f0 is None else f0, rel_step=diff_step)

        if method in GLOBAL and method != "basinhopping":
            lower, upper = _search_box(problem, names, lower, upper, method, run.notes)
            if method == "brute" and 20 ** k > BRUTE_MAX_POINTS:
                raise FitError(f"lmfit:brute would try 20**{k} = {20 ** k:.3g} grid points over {k} free parameters "
                               f"(at most {BRUTE_MAX_POINTS:g}): fix some parameters or use another method")
        keys = [lmfit_key(n) for n in names]

        def parameters(x: np.ndarray, held: np.ndarray):
            params = lmfit.Parameters()
            for key, v, a, b, h in zip(keys, x, lower, upper, held):
                params.add(key, value=float(v), min=float(a), max=float(b), vary=not h)
            return params

        def vector(p) -> np.ndarray:
            return np.array([p[key].value for key in keys], float)

        kws: dict = {}
        if method in ("leastsq", "least_squares"):
            kws["Dfun"] = lambda p: jacobian(vector(p))
            # the trust region's stopping tolerances (lmfit's leastsq defaults: 1.5e-8, 1.5e-8, 0)
            kws.update(ftol=DEFAULT_TOL, xtol=DEFAULT_TOL, gtol=DEFAULT_TOL)
            if method == "least_squares":
                kws.update(x_scale=1.0)
                if diff_step is not None:
                    kws["diff_step"] = diff_step
        elif method in GRADIENT:
            def gradient(p):
                x = vector(p)
                r = fun(x)
                return 2.0 * jacobian(x, r).T @ r
            kws["Dfun"] = gradient
        if method in ("differential_evolution", "dual_annealing", "basinhopping"):
            kws["seed"] = int(seed)
        max_nfev = 4000 * (k + 1) * (10 if method in GLOBAL else 1)

        def minimise(x: np.ndarray, held: np.ndarray, watch: np.ndarray | None = None):
            """lmfit's run from ``x`` with ``held`` fixed: ``(result, x)``, or ``(None, x)`` when an
            accepted point (where MINPACK asks for the Jacobian) puts a ``watch`` parameter on a bound."""
            mini = lmfit.Minimizer(lambda p: fun(vector(p)), parameters(x, held), max_nfev=max_nfev)
            call = dict(kws)
            if method == "leastsq":  # lmfit takes the columns of the varied parameters only
                def dfun(p):
                    at = vector(p)
                    if watch is not None and np.any(bound_flags(at, lower, upper)[watch]):
                        raise _ReachedBound(at)
                    return jacobian(at)[:, ~held]
                call["Dfun"] = dfun
            try:
                out = mini.minimize(method=method, **call)
            except _ReachedBound as reached:
                return None, np.clip(reached.x, lower, upper)
            return out, np.clip(vector(out.params), lower, upper)

        x = np.clip(np.asarray(x0, float), lower, upper)
        if method != "leastsq":
            out, x = minimise(x, np.zeros(k, bool))
            r = np.asarray(fun(x), float)
            jac, nfev, held = jacobian(x, r), int(getattr(out, "nfev", 0)), np.zeros(k, bool)
        else:
            out, x, r, jac, nfev, held = _leastsq_with_active_bounds(minimise, fun, jacobian, x, lower, upper)
        message = f"lmfit {method}: {out.message}" if getattr(out, "message", None) else f"lmfit {method}"
        if held.any():
            message += f" ({', '.join(n for n, h in zip(names, held) if h)} held on a bound the cost falls through)"
        return optimum(x, r, jac, scale_covar=scale_covar, success=bool(getattr(out, "success", True)),
                       message=message, nfev=nfev)

    run.global_search = method in GLOBAL  # no refits from nearby starts (neighbours.py): it searched the box
    run.notes = []  # what the runs chose that the results should say (the box a global search searched)
    return run


def _outward(x: np.ndarray, r: np.ndarray, jac: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Parameters on a bound (:func:`~escfit.inference.lsq.bound_flags`) whose cost gradient
    ``J^T r`` points out of the range: the KKT point holds them there."""
    g = jac.T @ r
    with np.errstate(invalid="ignore", divide="ignore"):
        se = np.sqrt(np.diag(np.linalg.pinv(jac.T @ jac)))
    flags = bound_flags(x, lower, upper, se)
    return ((flags < 0) & (g > 0)) | ((flags > 0) & (g < 0))


def _leastsq_with_active_bounds(minimise, fun, jacobian, x: np.ndarray, lower: np.ndarray, upper: np.ndarray):
    """MINPACK's Levenberg-Marquardt with the parameters the optimum holds on a bound fixed there.

    lmfit passes bounds to ``leastsq`` through its Minuit-style transform (``x = min + (max - min)
    (sin u + 1) / 2``, ``x = min - 1 + sqrt(u**2 + 1)`` for one bound), whose slope ``dx/du`` is 0
    on the bound.  A parameter on its bound has a zero column there, MINPACK scales its step by
    that column's norm, so its trust region no longer limits the step in ``u``: every trial
    step throws the parameter across its range, is refused, and the run ends on ``xtol`` where
    it started, reporting success (measured on the string pendulum's coulomb.R = 0: 8
    evaluations, cost 2297.59 against 2264.52 at the optimum, 5 standard errors away).
    Approaching a bound from inside, the slope vanishes as the bound nears and the run
    crawls (a thousand evaluations to bring R to 1e-8).

    So a run is stopped at the first accepted point (where MINPACK asks for the Jacobian) that puts
    a parameter on a bound (:func:`~escfit.inference.lsq.bound_flags`), a parameter on its bound
    with the cost falling outward (the gradient ``J^T r``) is held there
    (lmfit's ``vary=False``) and the others are fitted again, until a run ends with the held set
    the KKT point's.  A parameter found on a bound with the cost rising outward is released, moved
    off the flat end along the bounded Gauss-Newton step, and no longer watched.

    Returns
    -------
    out, x, r, jac, nfev, held
        lmfit's last result, the optimum, its residuals and Jacobian, evaluations, and which
        parameters are held.
    """
    k = x.size
    held, released = np.zeros(k, bool), np.zeros(k, bool)
    nfev = 0
    if bound_flags(x, lower, upper).any():  # a start on a bound: decide from the gradient there
        r = np.asarray(fun(x), float)
        held = _outward(x, r, jacobian(x, r), lower, upper)
        nfev += 1
    rounds = 2 * k + 2
    for i in range(rounds):
        x = np.where(held & (np.abs(x - lower) <= np.abs(x - upper)), lower, np.where(held, upper, x))
        out, x = minimise(x, held, ~held & ~released if i < rounds - 1 else None)
        nfev += (int(out.nfev) if out is not None else 0) + 1
        r = np.asarray(fun(x), float)
        jac = jacobian(x, r)
        now = _outward(x, r, jac, lower, upper)
        freed = (bound_flags(x, lower, upper) != 0) & ~now & ~released
        if freed.any():  # off the flat end of the transform along the bounded Gauss-Newton step
            x[freed] = (x + _bounded_step(x, r, jac, lower, upper))[freed]
            released |= freed
        if out is not None and np.array_equal(now, held):
            break
        held = now
    return out, x, r, jac, nfev, held


class _ReachedBound(Exception):
    """Raised from the Jacobian callback to stop MINPACK at an accepted point on a bound."""

    def __init__(self, x: np.ndarray):
        super().__init__("a parameter reached a bound")
        self.x = np.array(x, float)


def _bounded_step(x: np.ndarray, r: np.ndarray, jac: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The Gauss-Newton step of the linearised residuals inside the bounds."""
    from .bounded_linear import bounded_lstsq

    return bounded_lstsq(jac, -r, np.minimum(lower - x, 0.0), np.maximum(upper - x, 0.0))
