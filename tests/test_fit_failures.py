"""A solver that cannot finish is a failure that is reported, never a quiet best fit.

The case is a hairspring of identical pieces solved with a small segment budget: the exact
solver needs a segment per piece crossed, runs out of segments after a few swings, and a fit of
C used to exit 0 with C on a bound or a NaN interval (the failed solves only in the file's
attributes).  (A hairspring of 1000 pieces, the first such case, is now refused when the scene
is read: a spring has at most 8 pieces.)  The reference is the plain spring the pieces add up
to, which every solver finishes with its default budget.
"""

from __future__ import annotations

import numpy as np
import pytest

import escfit
from escfit.balance.synthetic.instruments import record
from escfit.balance.synthetic.unit_curves import record_unit_curve
from escfit.core.errors import FitError, SceneError

PIECES = 8
BUDGET = {"max_segments": 40}  # segments: 30 swings across 8 pieces need about 200


def spring_scene(c: str, pieces: int = PIECES) -> str:
    angles = ", ".join(repr(float(x)) for x in np.linspace(-6.0, 6.0, pieces - 1))
    return (f'model = "balance"\n[oscillator]\ntheta0 = 5.0\n[run]\nswings = 30\n[effects.viscous]\nC = {c}\n'
            f"[effects.coulomb]\nR = 5.0\n[effects.hairspring]\nangles = [{angles}]\n"
            f"omega0 = [{', '.join(['15.0'] * pieces)}]\n")


PLAIN = ('model = "balance"\n[oscillator]\ntheta0 = 5.0\nomega0 = 15.0\n[run]\nswings = 30\n'
         "[effects.viscous]\nC = 0.1\n[effects.coulomb]\nR = 5.0\n")


@pytest.fixture(scope="module")
def readings():
    """Unit-curve readings of the plain spring (C = 0.1), which the 1000 pieces reproduce."""
    return record_unit_curve(escfit.load_scene("plain.toml", text=PLAIN), every=1, swings=12, sigma=0.01, seed=3)


def test_a_best_fit_the_solver_cannot_compute_is_a_fit_error(readings):
    scene = escfit.load_scene("pieces.toml", text=spring_scene("{ value = 0.1, vary = true, min = 0.01, max = 0.3 }"))
    with pytest.raises(FitError, match=r"cannot be computed at the best fit .* solver ran out of segments"):
        escfit.fit(scene, readings, solver_options=BUDGET)


def test_failed_evaluations_during_the_search_are_warned(readings):
    """Where the search leaves the region the solver cannot compute, the fit says so."""
    scene = escfit.load_scene("pieces.toml", text=spring_scene("{ value = 2.0, vary = true, min = 0.01, max = 5.0 }"))
    res = escfit.fit(scene, readings, solver_options=BUDGET)
    assert any("failed while least squares searched" in w and "ran out of segments" in w for w in res.warnings), \
        res.warnings


def test_a_recorder_refuses_a_run_the_solver_did_not_finish(tmp_path, monkeypatch):
    import functools

    from escfit.balance.synthetic import unit_curves

    monkeypatch.setattr(unit_curves, "solve", functools.partial(unit_curves.solve, **BUDGET))
    scene = escfit.load_scene("pieces.toml", text=spring_scene("0.1"))
    with pytest.raises(SceneError, match=r"status 'max_segments' after \d+ half swing"):
        record(scene, "unit-curve", tmp_path / "u.csv", noise=0.01)
    assert not list(tmp_path.iterdir())
