"""Settings of the command line's own process, made when it loads, before numpy does.

* **One BLAS thread** unless the environment says otherwise: escfit's linear algebra is a few
  parameters wide (Jacobians, covariances), and OpenBLAS's spinning thread pool cost 0.1-0.3 CPU s
  at start-up for nothing.
* **The cyclic garbage collector's first threshold at 20 000 allocations** instead of 700: a
  command imports numba, scipy and its kernels, hundreds of thousands of objects that live as
  long as the process, and with the default thresholds the collector walked them again and
  again (0.26 s of the quick start, 0.2 s of a least-squares fit; 0.09 s now).  The older
  generations keep their default ratios, so full collections still run in a long sampling run
  and cyclic garbage stays bounded.
"""

from __future__ import annotations

import gc
import os

__all__ = ["FIRST_THRESHOLD"]

#: allocations (net of deallocations) between collections of the youngest generation
FIRST_THRESHOLD = 20_000

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
_, _second, _third = gc.get_threshold()
if gc.get_threshold()[0] < FIRST_THRESHOLD:
    gc.set_threshold(FIRST_THRESHOLD, _second, _third)
