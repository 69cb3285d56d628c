"""Readings after a balance stops by friction: it rests where its last half swing left it.

Reference: the closed form of a Coulomb-damped linear oscillator (no viscous damping).  Each
half swing takes ``a = R / omega0**2`` twice off the amplitude: the turning points are
``theta_k = (-1)**k (A0 - 2 k a)`` until the first with ``|theta_k| <= a``, where the balance
stays.  An amplitude reading of half swing ``j`` after that is ``|theta_stop - offset|``, and a
change of R that moves the stop by one half swing moves no reading by more than the change
itself does (the readings are continuous in R).  Reading the centre (0) after the stop, as
before, made the readings jump there by about ``a``.
"""

from __future__ import annotations

import numpy as np
import pytest

from escfit.inference import make_problem

OMEGA0 = 4.0
A0 = 1.0
OFFSET = 0.02


def _problem(tmp_path, n_rows: int):
    rows = ["t,A"] + [f"{0.5 * k},{0.5 * 0.98 ** k:.6f}" for k in range(n_rows)]  # readings' values do not matter here
    data = tmp_path / "rows.csv"
    data.write_text("\n".join(rows) + "\n")
    scene = tmp_path / "scene.toml"
    scene.write_text(
        'model = "balance"\n'
        f"[oscillator]\nomega0 = {OMEGA0}\ntheta0 = {{ value = {A0}, vary = true, min = 0.5, max = 1.5 }}\n"
        "[effects.coulomb]\nR = { value = 1.0, vary = true, min = 0, max = 10 }\n"
        f'[observation]\nmodel = "amplitude"\nsigma = 0.01\noffset = {OFFSET}\n'
        '[recording]\ntime_column = "t"\nangle_column = "A"\nangle_unit = "rad"\nreadings = "amplitudes"\n')
    return make_problem(str(scene), str(data))


def _closed_form(R: float, n_rows: int) -> np.ndarray:
    a = R / OMEGA0 ** 2
    theta = [A0]
    while len(theta) < n_rows:
        last = theta[-1]
        if abs(last) <= a:  # at rest inside the dead band: it stays there
            theta.append(last)
        else:
            theta.append(-np.sign(last) * (abs(last) - 2 * a))
    return np.abs(np.array(theta) - OFFSET)


@pytest.mark.parametrize("R", [1.9, 2.3, 3.1])
def test_readings_after_the_stop_are_the_rest_angle(tmp_path, R):
    p = _problem(tmp_path, 16)
    vals = p.values({"oscillator.theta0": A0, "coulomb.R": R})
    want = _closed_form(R, 16)
    assert np.count_nonzero(np.diff(want) == 0) >= 3  # the balance stops before the last reading
    assert np.allclose(p.expected(vals), want, atol=1e-9)
    # the sampler's whole-array path and the one-set compiled path read the same
    vec = np.array([vals[n] for n in p.names])
    assert np.allclose(p.log_prob_many(np.array([vec, vec])), p.log_prob(vec), rtol=1e-12)
    z = (p.observed - want) / 0.01
    assert p.log_prob(vec) - p.log_prior(vec) == pytest.approx(
        -0.5 * z @ z - z.size * np.log(0.01 * np.sqrt(2 * np.pi)), rel=1e-9)


def test_readings_are_continuous_where_the_stop_moves_by_one_half_swing(tmp_path):
    p = _problem(tmp_path, 16)
    # the stop moves by one half swing where A0 - 2 k a = a, i.e. R = omega0**2 A0 / (2 k + 1)
    for k in (4, 5, 6):
        r_edge = OMEGA0 ** 2 * A0 / (2 * k + 1)
        below = p.expected(p.values({"oscillator.theta0": A0, "coulomb.R": r_edge * (1 - 1e-7)}))
        above = p.expected(p.values({"oscillator.theta0": A0, "coulomb.R": r_edge * (1 + 1e-7)}))
        # a readings' change of order (2 k + 1) * dR / omega0**2, not the dead band a ~ 0.1 rad
        assert np.max(np.abs(above - below)) < 1e-5, (k, np.max(np.abs(above - below)))
