"""An ``lmfit.Minimizer`` whose ``leastsq`` holds a parameter on a bound the cost falls through.

lmfit hands bounds to MINPACK through its Minuit-style transform, whose slope is 0 on a bound
(see :func:`escfit.inference.lmfit_path._leastsq_with_active_bounds`).  A refit that starts
with a parameter on its bound while the cost still falls outward makes no step at all: MINPACK
stops on ``xtol`` where it started and reports success.  ``lmfit.conf_interval`` refits with
``Minimizer.leastsq`` from the best fit's values, so with a parameter on a bound at the best
fit (coulomb.R = 0 on the string pendulum) each refit on the side where it stays there
returns the start's cost and the interval ends too short.

:func:`bound_aware_minimizer` holds such a parameter on its bound (``vary=False``) for the
run, decided by the cost one small step inside, repeats the run while the run's end changes
that decision, and reports the result with the parameter counted as varied (``nvarys``,
``nfree``), as ``conf_interval``'s F test counts it.
"""

from __future__ import annotations

import copy
import math

import numpy as np

__all__ = ["bound_aware_minimizer", "INWARD_STEP"]

#: the inward step of the on-bound test, as a fraction of the range (closed) or of max(|bound|, 1)
INWARD_STEP = 1e-7


def _cost(minimizer, params) -> float:
    r = np.asarray(minimizer.userfcn(params, *minimizer.userargs, **minimizer.userkws), float)
    return float(r @ r)


def _falls_outward(minimizer, params, free: list[str]) -> set[str]:
    """Parameters of ``free`` on a bound whose cost rises one :data:`INWARD_STEP` inside."""
    held = set()
    base = None
    for name in free:
        par = params[name]
        lo, hi = par.min, par.max
        span = hi - lo if math.isfinite(lo) and math.isfinite(hi) else None
        for bound, sign in ((lo, 1.0), (hi, -1.0)):
            if not math.isfinite(bound):
                continue
            h = INWARD_STEP * (span if span is not None else max(abs(bound), 1.0))
            if abs(par.value - bound) > h:
                continue
            base = _cost(minimizer, params) if base is None else base
            trial = copy.deepcopy(params)
            trial[name].set(value=bound + sign * h)
            if _cost(minimizer, trial) > base:
                held.add(name)
    return held


def bound_aware_minimizer(lmfit):
    """The ``lmfit.Minimizer`` subclass (lmfit imported by the caller)."""

    class BoundAwareMinimizer(lmfit.Minimizer):
        """``lmfit.Minimizer`` whose ``leastsq`` holds a parameter on a bound the cost falls
        through (see :mod:`escfit.inference.lmfit_bounds`); other methods are lmfit's."""

        def leastsq(self, params=None, max_nfev=None, **kws):
            given = self.params if params is None else params  # what lmfit's leastsq leaves in self.params
            params = copy.deepcopy(given)
            free = [n for n, p in params.items() if p.vary and p.expr is None]
            held = _falls_outward(self, params, free)
            out = None
            for _ in range(len(free) + 1):
                run = copy.deepcopy(params)
                for name in held:
                    par = run[name]
                    par.set(value=par.min if abs(par.value - par.min) <= abs(par.value - par.max) else par.max,
                            vary=False)
                out = super().leastsq(params=run, max_nfev=max_nfev, **kws)
                now = _falls_outward(self, out.params, free)
                if now == held:
                    break
                params = copy.deepcopy(out.params)
                for name in free:
                    params[name].set(vary=True)
                held = now
            for name in held:  # a free parameter, on its bound: counted as varied
                out.params[name].set(vary=True)
            out.nvarys += len(held)
            out.nfree -= len(held)
            self.params = given  # not the last run's copy, whose held parameters do not vary
            return out

    return BoundAwareMinimizer
