"""A watch at steady state: the record fixes only the balance of C, R and X, and the fit says so."""

from __future__ import annotations

from escfit.balance import solve
from escfit.inference import fit
from escfit.balance.synthetic.instruments import record_timegrapher
from escfit.core.scene import load_scene

SCENE = "datasets/recordings/timegrapher_scene.toml"


def test_steady_state_timegrapher_record_is_flagged_and_a_decay_is_not():
    scene = load_scene(SCENE)
    steady = float(solve(scene, "exact").amplitude[-1])  # released at its steady amplitude: no decay
    at_rest = scene.with_values({"oscillator.theta0": steady})
    flat = record_timegrapher(at_rest, swings=500, seed=3)
    decay = record_timegrapher(scene, swings=500, seed=3)
    flat_fit = fit(at_rest, flat, method="leastsq", n_starts=2)
    decay_fit = fit(scene, decay, method="leastsq", n_starts=2)
    assert any("steady-state record fixes only the balance of C, R and X" in w for w in flat_fit.warnings)
    assert not any("steady-state" in w for w in decay_fit.warnings)
