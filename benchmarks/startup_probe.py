"""Seconds from process start to ``escfit fit RECIPE``'s first model evaluation (printed as JSON).

Run by ``benchmarks/startup.py`` under the current and the previous version (``PYTHONPATH``
selects which):  python benchmarks/startup_probe.py RECIPE.toml LAUNCH_TIME

``LAUNCH_TIME`` is the parent's ``time.time()`` just before it started this process.  The
command line runs as a user runs it; the first call of the problem's ``residuals`` (the least
squares' first model evaluation) prints the elapsed time and ends the process.  Hooking it
imports ``escfit.inference.fit``, which ``escfit fit`` imports before it anyway.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time

#: libraries a least-squares fit does not need before its first evaluation (reported when loaded)
HEAVY = ("xarray", "h5py", "scipy.stats", "lmfit", "emcee", "arviz", "matplotlib", "pandas", "scipy.signal", "dask")


def main() -> None:
    recipe, launched = sys.argv[1], float(sys.argv[2])
    import escfit.inference.fit  # noqa: F401 - the package's attribute ``fit`` is the function

    fit_module = sys.modules["escfit.inference.fit"]
    inner = fit_module.least_squares

    def hooked(problem, **kws):
        def first(vals):
            heavy = [m for m in HEAVY if m in sys.modules]
            print(json.dumps({"first_evaluation_s": time.time() - launched, "loaded": heavy}), flush=True)
            os._exit(0)

        problem.residuals = first
        return inner(problem, **kws)

    fit_module.least_squares = hooked
    from escfit.cli.main import main as cli

    out = os.path.join(tempfile.mkdtemp(prefix="escfit-startup-"), "x.h5")
    sys.argv = ["escfit", "fit", recipe, "--out", out, "--force", "--quiet"]
    cli()


if __name__ == "__main__":
    main()
