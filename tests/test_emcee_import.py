"""emcee is imported without scipy.stats, and its KDE move still works (a fresh interpreter each)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

SCRIPT = r"""
import sys
import numpy as np
import escfit.inference.mcmc  # imports emcee, the sampler's moves and the convergence criteria
assert "scipy.stats" not in sys.modules, "scipy.stats imported with emcee"
import emcee
rng = np.random.default_rng(1)
s = emcee.EnsembleSampler(24, 2, lambda x: -0.5 * float(x @ x), moves=emcee.moves.KDEMove())
s.run_mcmc(rng.normal(size=(24, 2)), 400, progress=False)
draws = s.get_chain(discard=100, flat=True)
print("OK", "scipy.stats" in sys.modules, float(draws.mean()), float(draws.std()))
"""


def test_emcee_without_scipy_stats_and_kde_move_on_first_use():
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep))
    r = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    ok, stats_loaded, mean, sd = r.stdout.split()[-4:]
    assert stats_loaded == "True"  # imported by the KDE move's first proposal
    # the KDE move samples the standard normal: 24 walkers x 300 draws, a few hundred independent ones
    assert abs(float(mean)) < 0.2 and 0.85 < float(sd) < 1.15
