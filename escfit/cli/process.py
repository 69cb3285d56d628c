"""Settings of the command line's own process, made when it loads, before numpy does.

* **One BLAS thread** unless the environment says otherwise: escfit's linear algebra is a few
  parameters wide (Jacobians, covariances), and OpenBLAS's spinning thread pool cost 0.1-0.3 CPU s
  at start-up for nothing.
* **What the imports leave, frozen out of the cyclic collector's full passes.**  A command
  imports numba, scipy and its kernels: hundreds of thousands of objects that live as long as the
  process, which each full collection walked again (three of them, 0.15 s of the quick start's
  0.26 s of collection).  After each of the first :data:`FROZEN_PASSES` full collections, whatever
  survived it is moved to the collector's permanent generation (``gc.freeze``), so the next pass
  walks only what came after.  Later passes (a long sampling run) are left as they are, so
  cyclic garbage made while sampling is still collected; the youngest generation's threshold is
  not touched (raising it slowed the sampler's many short-lived arrays).
"""

from __future__ import annotations

import gc
import os

__all__ = ["FROZEN_PASSES"]

#: full collections after which the survivors are frozen (the imports' objects)
FROZEN_PASSES = 3

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

_passes = 0


def _freeze_after_full_pass(phase: str, info: dict) -> None:
    # (it stays registered after its passes, doing nothing: removing a callback while the
    # collector runs the list would skip the next one's "stop", which other libraries' callbacks,
    # dask's among them, count on)
    global _passes
    if _passes >= FROZEN_PASSES or phase != "stop" or info.get("generation") != 2:
        return
    _passes += 1
    gc.freeze()


if _freeze_after_full_pass not in gc.callbacks:
    gc.callbacks.append(_freeze_after_full_pass)
