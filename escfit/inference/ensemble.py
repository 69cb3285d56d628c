"""emcee's ensemble sampler, taking a whole-ensemble log density's float array as it is.

With ``vectorize=True`` emcee converts the log density's result walker by walker (each
value checked for being a scalar and for carrying blobs) before it tests for NaN: tens of
microseconds a call, paid several times a step.  Every escfit log density returns a float
array of one value per walker, so :class:`ArraySampler` takes that array as it is, after the
same checks of the positions (no infinity, no NaN) and of the values (no NaN), with emcee's
own messages.  Named parameters, a log density of one walker at a time and positions emcee
refuses go through emcee's own code; blobs are not supported (escfit's log densities have none).  The values and hence the draws are those emcee's
conversion would give (``tests/test_moves.py``).
"""

from __future__ import annotations

import numpy as np

from .emcee_import import emcee

__all__ = ["ArraySampler"]


class ArraySampler(emcee.EnsembleSampler):
    """:class:`emcee.EnsembleSampler` whose whole-ensemble log density returns a float array."""

    def compute_log_prob(self, coords):
        if not self.vectorize or self.params_are_named or not np.isfinite(coords).all():
            return super().compute_log_prob(coords)  # emcee's path and messages
        lp = np.array(self.log_prob_fn(coords), dtype=float)  # a copy: the caller's array stays its own
        if lp.shape != (coords.shape[0],):
            raise ValueError(f"the log density gave shape {lp.shape} for {coords.shape[0]} walkers")
        if np.isnan(lp).any():
            raise ValueError("Probability function returned NaN")
        return lp, None
