"""Photo-cell pulse trains: exact crossing times, reconstruction, round trip, recovery.

The round trip: simulate a pulse train from a scene, write it, read it back, fit the
passage times, recover the scene's C, R, X.  The same train read as notch counts (the
amplitudes alone) determines them far less well.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import escfit
from escfit.balance import solve
from escfit.balance.problems.curves import FitProblem
from escfit.inference import least_squares, run_emcee
from escfit.balance.problems.pulses import PulseFitProblem
from escfit.balance.synthetic.instruments import record_pulses, swing_directions
from escfit.analysis.recordings.pulses import assign_pulses, pulses_to_unit_curve, read_pulses, write_pulses

from .conftest import DATASETS

SCENE = DATASETS / "recordings" / "pulses_scene.toml"
TRUTH = {"viscous.C": 0.6, "coulomb.R": 100.0, "escapement[2].X": 1500.0}


@pytest.fixture(scope="module")
def scene():
    return escfit.load_scene(SCENE)


@pytest.fixture(scope="module")
def train(scene, tmp_path_factory):
    """A recorded train written to disk and read back (the round trip under test)."""
    path = tmp_path_factory.mktemp("pulses") / "train.csv"
    write_pulses(path, record_pulses(scene, swings=24, sigma_t=1e-4, seed=1), comments=["test train"])
    return read_pulses(path)


def test_level_times_are_exact_crossings(scene):
    """theta at the predicted crossing time is the level, to rounding (closed form + root find)."""
    tr = solve(scene, swings=10, dense=True)
    m = np.repeat(np.arange(1, 11), 5)
    x = np.tile([-1.0, -0.3, 0.0, 0.5, 2.0], 10)
    t = tr.dense.crossings(m, x)
    s = swing_directions(scene.params["oscillator.theta0"].value, 10)[m - 1]
    theta = tr.dense.theta(t)
    np.testing.assert_allclose(s * theta, x, atol=1e-11)


def test_unreached_levels_clamp_to_the_turning_points(scene):
    tr = solve(scene, swings=4, dense=True)
    t = tr.dense.crossings(np.array([2, 2]), np.array([10.0, -10.0]))
    np.testing.assert_allclose(t, [tr.time[1], tr.time[0]], rtol=0, atol=1e-15)


def test_round_trip_keeps_times_kinds_and_metadata(scene, tmp_path):
    rec = record_pulses(scene, swings=6, seed=4, release_s=0.125)
    path = tmp_path / "p.csv"
    write_pulses(path, rec, comments=["generated for a test"])
    back = read_pulses(path)
    np.testing.assert_allclose(back.time, rec.time, atol=1e-9)
    assert np.array_equal(back.zero, rec.zero)
    assert back.notches == 60 and back.release_s == 0.125
    header = next(i for i, line in enumerate(path.read_text().splitlines(), 1) if line.startswith("time_s"))
    assert back.lines[0] == header + 1
    assert back.meta["seed"] == "4" and back.meta["generated_by"] == "escfit.balance.synthetic.instruments.record_pulses"
    assert back.sha256 and back.source == str(path)


def test_time_units_and_notch_angle_metadata(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("# notch_deg: 10\ntime_ms,kind\n100,notch\n150,zero\n")
    tr = read_pulses(path)
    np.testing.assert_allclose(tr.time, [0.1, 0.15])
    assert tr.notches == 36 and math.isclose(tr.notch, math.radians(10))


def test_counts_between_zero_pulses_are_the_notch_counts(scene, train):
    """Out-and-back pairs around the zero tooth give floor(A / notch) at every turning point."""
    tr = solve(scene, swings=24)
    a = assign_pulses(train)
    expected = np.floor(np.r_[6.28, tr.amplitude[: a.counts.size - 1]] / train.notch)
    np.testing.assert_array_equal(a.counts, expected)
    curve = pulses_to_unit_curve(train)
    assert curve.kind == "notches" and curve.swing[0] == 0 and curve.swing[-1] == 23
    np.testing.assert_allclose(curve.time[1:], tr.time[:23], atol=2e-3)


def test_passage_times_recover_the_scene(scene, train):
    problem = PulseFitProblem(scene, train)
    assert problem.n_data == np.flatnonzero(train.zero)[-1] + 1  # all but the unfinished last excursion
    lsq = least_squares(problem, n_starts=2)
    for name, true in TRUTH.items():
        i = lsq.names.index(name)
        assert abs(lsq.value[i] - true) < 3 * lsq.stderr[i], (name, lsq.value[i], lsq.stderr[i])
    assert lsq.sigma_hat == pytest.approx(1e-4, rel=0.1)


def test_passage_times_beat_the_amplitudes_alone(scene, train):
    """Notch counts from the same chart leave C, R, X at least 100 times less certain."""
    pulses = least_squares(PulseFitProblem(scene, train), n_starts=2)
    text = (DATASETS / "scenes" / "monday_unit_angle_fit.toml").read_text().replace("swings = 64", "swings = 24")
    amp = least_squares(FitProblem(escfit.load_scene("amp.toml", text=text), pulses_to_unit_curve(train)), n_starts=4)
    for name in TRUTH:
        ratio = amp.stderr[amp.names.index(name)] / pulses.stderr[pulses.names.index(name)]
        assert ratio > 100, (name, ratio)


def test_posterior_of_passage_times_covers_truth(scene, train):
    problem = PulseFitProblem(scene, train)
    lsq = least_squares(problem, n_starts=1)
    mc = run_emcee(problem, lsq, walkers=12, steps=300, burn=150, seed=3)
    flat = mc.chain.reshape(-1, len(problem.names))
    for name, true in TRUTH.items():
        col = flat[:, problem.names.index(name)]
        lo, hi = np.quantile(col, [0.001, 0.999])
        assert lo < true < hi, (name, lo, hi)
    sd = flat[:, problem.names.index("viscous.C")].std()
    assert sd == pytest.approx(lsq.stderr[lsq.names.index("viscous.C")], rel=0.5)


def test_free_release_instant_and_scale_offset(scene):
    """With t0 and the notch-scale offset free, both come back (the chart's clock and zero)."""
    text = SCENE.read_text().replace('model = "passage_times"', 'model = "passage_times"\n'
                                     't0 = { value = 0.0, vary = true, min = -0.1, max = 0.1 }\n'
                                     'offset = { value = 0.0, vary = true, min = -0.05, max = 0.05 }')
    sc = escfit.load_scene("free.toml", text=text)
    rec = record_pulses(sc, swings=12, seed=7, release_s=0.0123, offset=0.01)
    lsq = least_squares(PulseFitProblem(sc, rec), n_starts=1)
    for name, true in {"observation.t0": 0.0123, "observation.offset": 0.01, **TRUTH}.items():
        i = lsq.names.index(name)
        assert abs(lsq.value[i] - true) < 4 * lsq.stderr[i], (name, lsq.value[i], lsq.stderr[i])


def test_example_file_fits(scene):
    train = read_pulses(DATASETS / "recordings" / "monday_pulses.csv")
    assert train.meta["generated_by"].startswith("escfit")
    lsq = least_squares(PulseFitProblem(scene, train), n_starts=1)
    for name, true in TRUTH.items():
        i = lsq.names.index(name)
        assert abs(lsq.value[i] - true) < 4 * lsq.stderr[i]
