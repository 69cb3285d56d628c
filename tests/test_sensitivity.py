"""Forward sensitivities of the dop853 motion and the waveform Jacobian built from them.

The reference is a second method: central differences of the batch sampler's theta(t) and
theta'(t) run at rtol 1e-13 (the step 1e-5 relative puts their own error near 1e-8 of the
largest sensitivity), on every effect the sensitivities cover -- a pendulum's ``sin(theta)``,
viscous damping, sliding Coulomb friction (whose sign change at each turning point is the
saltation rule), static friction holding the balance at a turning point, air drag and a
stiffening spring.  A Jacobian that ignored the turning points' jumps would miss by the size of
Coulomb's share of the decay, orders of magnitude beyond the tolerance.  Then the whole residual
Jacobian (AR(1) whitening, gain, offset drift, the release instant) against scipy's
``approx_derivative``, and a fit by sensitivities against one by scipy's own forward
(central) differences.  The conformance suite (``tests/test_conformance.py``) checks every registered
effect the sensitivities cover, and the contract they rest on: every smooth torque is linear in
its own record fields.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize._numdiff import approx_derivative

from escfit.balance.batch_dop853 import OMEGA, THETA, sample_batch_dop853
from escfit.balance.sensitivity import covers, record_tangents, sample_sensitivities
from escfit.balance.waveform import sample_state
from escfit.balance.problems.tolerance import JACOBIAN_RTOL
from escfit.core.scene import load_scene
from escfit.inference import make_problem
from escfit.inference.lsq import least_squares

from . import test_waveform_batch_dop853 as pendulum_case

PENDULUM = """model = "balance"
[oscillator]
restoring = "pendulum"
omega0 = { value = 3.7, vary = true, min = 3, max = 4.5 }
theta0 = { value = 1.2, vary = true, min = 0.2, max = 2.0 }
[effects.viscous]
C = { value = 0.05, vary = true, min = 0, max = 2 }
[effects.coulomb]
R = { value = 0.2, vary = true, min = 0, max = 5 }
%s
"""
SPRING = """model = "balance"
[oscillator]
omega0 = { value = 6.0, vary = true, min = 3, max = 9 }
theta0 = { value = -2.5, vary = true, min = -3.0, max = -1.0 }
[effects.viscous]
C = { value = 0.08, vary = true, min = 0, max = 2 }
[effects.coulomb]
R = { value = 0.5, vary = true, min = 0, max = 5 }
[effects.stiffening]
k3 = { value = 0.05, vary = true, min = 0, max = 1 }
"""
CASES = {
    "pendulum, viscous and Coulomb": (PENDULUM % "", 25.0),
    "pendulum held by static friction": (PENDULUM % "R_static = { value = 0.5, vary = true, min = 0, max = 50 }", 30.0),
    "pendulum with air drag": (PENDULUM % "[effects.drag]\nD = { value = 0.05, vary = true, min = 0, max = 1 }", 20.0),
    "stiffening spring": (SPRING, 12.0),
}


def _central(scene, vals, name, t, which):
    """d theta/dp (or d theta'/dp) by central differences of the batch sampler at rtol 1e-13."""
    h = 1e-5 * max(abs(vals[name]), 1e-2)
    batch = {k: np.array([v, v]) for k, v in vals.items()}
    batch[name] = np.array([vals[name] + h, vals[name] - h])
    y, summary = sample_batch_dop853(scene.system(batch, 2), t, np.zeros(2), which=which, rtol=1e-13)
    assert np.all(summary["usable"] == 1)
    return (y[0] - y[1]) / (2 * h)


@pytest.mark.parametrize("case", CASES)
def test_sensitivities_are_the_central_differences(case):
    text, duration = CASES[case]
    scene = load_scene("s.toml", text=text)
    vals = scene.params.values()
    names = [n for n in vals if scene.params[n].vary]
    t = np.linspace(0.05, duration, 700)
    system = scene.system(vals)
    assert covers(system)
    tangents = record_tangents(scene.system, vals, names, np.array([1e-6 * max(abs(vals[n]), 1e-3) for n in names]))
    motion, sens, status = sample_sensitivities(system, t, tangents, rtol=1e-12)
    assert motion is not None
    theta, _ = sample_batch_dop853(system, t, np.zeros(1), rtol=1e-13)
    np.testing.assert_allclose(motion[0], theta[0], atol=1e-9)
    if "static" in case:  # held at a turning point within the record: theta stays, its sensitivity too
        assert status == 1 and motion[1, -1] == 0.0 and np.all(sens[1, :, -1] == 0.0)
    # theta'(t) has a kink at each turning point (Coulomb's jump in the acceleration), and so its
    # sensitivity jumps there: a central difference whose two runs turn on either side of a
    # sample is no reference for it; that happens only where |theta'| is a hair from zero
    near_turn = (motion[1] != 0.0) & (np.abs(motion[1]) < 1e-3 * np.max(np.abs(motion[1])))
    assert near_turn.mean() < 0.01
    for j, name in enumerate(names):
        for which, row in ((THETA, 0), (OMEGA, 1)):
            ref = _central(scene, vals, name, t, which)
            scale = np.max(np.abs(ref))
            if name == "coulomb.R_static":
                assert scale == 0.0 and np.all(sens[row, j] == 0.0)  # it only decides where the balance stays
                continue
            assert scale > 1e-3
            keep = ~near_turn if row == 1 else slice(None)
            err = np.max(np.abs(sens[row, j] - ref)[keep]) / scale
            assert err < 2e-6, f"{case}: d{'theta' if row == 0 else 'omega'}/d{name} off by {err:.2g}"


def _ar1_problem():
    problem = pendulum_case._problem(observation='noise = "ar1"\ngain = { value = 1.0, vary = true, min = 0.5, max = 2 }',
                                     record={"noise": "ar1"})
    problem.solver_options = {**problem.solver_options, "rtol": 1e-12}
    return problem


def test_residual_jacobian_is_scipys_approx_derivative():
    problem = _ar1_problem()
    vals = problem.values(problem.initial)
    vals = {**vals, "observation.rho": 0.4}
    names = [n for n in problem.names if n not in ("observation.sigma", "observation.rho")]
    assert {"observation.t_release", "observation.gain", "observation.offset_rate", "drag.D"} <= set(names)
    x = np.array([vals[n] for n in names])

    def residuals(v):
        return problem.residuals({**vals, **dict(zip(names, v))})

    # steps of 1e-4: at 1e-5 and below, the adaptive steps' changes with the parameters (jumps near the
    # tolerance, 1e-12) show in the differences of the smallest parameters (R = 0.02)
    ref = approx_derivative(residuals, x, method="3-point", rel_step=1e-4)
    jac = problem.residual_jacobian(vals, names)
    scale = np.max(np.abs(ref), axis=0)
    assert np.all(scale > 0)
    # as in the test above: no central-difference reference where theta' is a hair from zero at a
    # turning point (the two runs turn on either side of the sample); the whitening spreads a
    # reading's error to the next one
    _, omega, _ = sample_state(problem.scene.system(vals), problem.sample_time - vals["observation.t_release"],
                               "dop853", rtol=1e-12)
    near = np.abs(omega) < 1e-3 * np.max(np.abs(omega))
    near[1:] |= near[:-1].copy()
    assert near.mean() < 0.02
    np.testing.assert_allclose((jac / scale)[~near], (ref / scale)[~near], rtol=0, atol=1e-5)


def test_fit_by_sensitivities_is_the_forward_difference_fit():
    """At rtol 1e-12 both fits agree with one by scipy's central differences (its "3-point" rule)."""
    problem = _ar1_problem()
    exact = least_squares(problem, n_starts=1)
    assert problem.jacobians["sensitivities"] > 3 and not problem.jacobians["forward differences"]
    assert "by sensitivities" in problem.provenance()["jacobian"]
    problem.lsq_options = {"jac": "3-point"}
    ref = least_squares(problem, n_starts=1)
    assert exact.success and ref.success and exact.names == ref.names
    assert np.max(np.abs(exact.value - ref.value) / ref.stderr) < 1e-3
    np.testing.assert_allclose(exact.stderr, ref.stderr, rtol=1e-3)
    # the trust region stops once a step gains less than ftol = 1e-8 of the cost, so either fit may
    # end a few ftol above the other (1.3e-8 seen on an AMD EPYC): the sensitivities must not do worse
    assert exact.chisqr == pytest.approx(ref.chisqr, rel=1e-6) and exact.chisqr <= ref.chisqr * (1 + 1e-7)


def test_scenes_with_other_switches_fall_back_to_forward_differences():
    text = """model = "balance"
[oscillator]
theta0 = { value = 1.2, vary = true, min = 0.2, max = 2.0 }
[effects.hairspring]
angles = [0.2]
omega0 = [3.9, 3.6]
[effects.viscous]
C = { value = 0.05, vary = true, min = 0, max = 2 }
[effects.drag]
D = { value = 0.05, vary = true, min = 0, max = 1 }
[observation]
model = "waveform"
"""  # a hairspring's break angle: a switch within the half swing, which the sensitivities do not cover
    problem = make_problem(load_scene("s.toml", text=text), pendulum_case._record())
    vals = problem.values(problem.initial)
    assert not covers(problem.scene.system(vals)) and not problem.has_sensitivities
    assert "sensitivities" not in problem.provenance()["solver_tolerance"]
    assert problem.solver_options["rtol"] == JACOBIAN_RTOL  # the forward differences' floor
    assert problem.residual_jacobian(vals, ["viscous.C"]) is None
    fit = least_squares(problem, n_starts=1)
    assert fit.success and problem.jacobians["forward differences"] > 0 and not problem.jacobians["sensitivities"]
    plain = _ar1_problem()  # a covered scene, but a noise parameter asked for
    assert plain.residual_jacobian(plain.values(plain.initial), ["observation.sigma"]) is None
