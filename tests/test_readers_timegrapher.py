"""Timegrapher recordings: the instrument's amplitude formula, readers, round trips, recovery."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import escfit
from escfit.balance import solve
from escfit.inference import least_squares, run_emcee
from escfit.balance.problems.timegrapher import TimegrapherFitProblem
from escfit.balance.observation.timegrapher import TimegrapherObservation, beat_events, window_readings
from escfit.balance.synthetic.instruments import record_timegrapher
from escfit.analysis.recordings.detect import detect_format, read_recording, read_timegrapher
from escfit.analysis.recordings.timegrapher import (beat_swings, read_tg_json, read_timegrapher_csv, write_tg_json,
                                                   write_timegrapher_csv)

from .conftest import DATASETS, balance_toml

SCENE = DATASETS / "recordings" / "timegrapher_scene.toml"
TRUTH = {"viscous.C": 0.6, "coulomb.R": 100.0, "escapement[2].X": 1500.0}


@pytest.fixture(scope="module")
def scene():
    return escfit.load_scene(SCENE)


def test_harmonic_reading_is_amplitude_over_lift():
    """For harmonic motion the instrument's formula is exact: reading = L_set * A / L_true."""
    sc = escfit.load_scene("h.toml", text=balance_toml(omega0=15.9, theta0=3.0, swings=20))
    tr = solve(sc, swings=20, dense=True)
    tz, pulse = beat_events(tr.dense, 20, math.radians(50.0))
    frac = window_readings(tz, pulse, np.array([0.1, 1.0]), np.array([2.1, 3.0]))
    np.testing.assert_allclose(frac, 3.0 / math.radians(50.0), rtol=1e-10)
    np.testing.assert_allclose(tz[:3], (np.arange(3) + 0.5) * math.pi / 15.9, rtol=1e-12)


def test_unreached_lift_reads_half_the_lift_angle():
    sc = escfit.load_scene("h.toml", text=balance_toml(omega0=15.9, theta0=0.2, swings=8))
    tr = solve(sc, swings=8, dense=True)
    tz, pulse = beat_events(tr.dense, 8, 1.0)
    np.testing.assert_allclose(window_readings(tz, pulse, np.array([0.0]), np.array([1.5])), 0.5, rtol=1e-12)


def test_rounding_rejection_and_truncation_likelihoods():
    obs = TimegrapherObservation
    mu = np.array([200.2, 200.2, 134.0, 200.0])
    y = np.array([200.0, 201.0, np.nan, np.nan])
    ll = obs.amp_loglike_pointwise(mu, y, 0.5, 1.0, (135.0, 360.0), True)
    from scipy.stats import norm

    assert ll[0] == pytest.approx(math.log(norm.cdf(0.3 / 0.5) - norm.cdf(-0.7 / 0.5)))
    assert ll[1] == pytest.approx(math.log(norm.cdf(1.3 / 0.5) - norm.cdf(0.3 / 0.5)))
    assert ll[2] == pytest.approx(math.log(norm.cdf(1.0 / 0.5)), rel=1e-9)  # rejected: below 135
    assert ll[3] < -100  # a reading well inside the range cannot be rejected
    cont = obs.amp_loglike_pointwise(np.array([136.0]), np.array([136.0]), 1.0, 0.0, (135.0, 360.0), False)
    assert cont[0] == pytest.approx(norm.logpdf(0.0) - math.log(norm.cdf(224.0) - norm.cdf(-1.0)))


def test_json_round_trip_and_tg_fields(scene, tmp_path):
    rec = record_timegrapher(scene, fmt="json", seed=5, swings=50)
    path = tmp_path / "tg.json"
    write_tg_json(path, rec)
    doc = json.loads(path.read_text())
    assert set(doc) >= {"sample_rate", "bph", "beats", "amplitude"}
    assert set(doc["beats"]) == {"times", "tictoc"} and set(doc["amplitude"]) == {"liftangle", "times", "values"}
    assert all(isinstance(t, int) for t in doc["beats"]["times"])
    back = read_tg_json(path)
    np.testing.assert_allclose(back.beat_time, rec.beat_time, atol=0.5 / 48000)
    keep = np.isfinite(rec.amp_deg)
    np.testing.assert_allclose(back.amp_deg, rec.amp_deg[keep], rtol=1e-6)
    assert back.bph == 18000 and back.release_s == pytest.approx(0.25) and back.window == 2.0
    assert detect_format(path) == "timegrapher" and read_timegrapher(path).format == "tg-json"
    assert back.meta["seed"] == "5"


def test_csv_round_trip(scene, tmp_path):
    rec = record_timegrapher(scene, fmt="csv", seed=5, swings=50)
    path = tmp_path / "tg.csv"
    write_timegrapher_csv(path, rec)
    back = read_timegrapher_csv(path)
    np.testing.assert_allclose(back.beat_time, rec.beat_time, atol=1e-6)
    np.testing.assert_array_equal(np.isnan(back.amp_deg), np.isnan(rec.amp_deg))
    np.testing.assert_allclose(back.amp_deg[np.isfinite(back.amp_deg)], rec.amp_deg[np.isfinite(rec.amp_deg)])
    assert np.all(back.amp_deg[np.isfinite(back.amp_deg)] % 1 == 0)  # whole degrees
    assert detect_format(path) == "timegrapher" and read_recording(path).format == "csv"
    shown = back.amp_deg[np.isfinite(back.amp_deg)]
    assert shown.min() >= 135 and shown.max() <= 360


def test_missed_beats_skip_half_swings(scene):
    rec = record_timegrapher(scene, fmt="json", seed=5, swings=40)
    full = beat_swings(rec)
    np.testing.assert_array_equal(full, np.arange(1, full.size + 1))
    drop = np.ones(rec.beat_time.size, bool)
    drop[[7, 20, 21]] = False
    rec.beat_time, rec.tictoc = rec.beat_time[drop], rec.tictoc[drop]
    np.testing.assert_array_equal(beat_swings(rec), full[drop])


@pytest.mark.parametrize("fmt", ["json", "csv"])
def test_timegrapher_recovers_the_scene(scene, fmt, tmp_path):
    rec = record_timegrapher(scene, fmt=fmt, seed=2)
    path = tmp_path / f"tg.{fmt}"
    (write_tg_json if fmt == "json" else write_timegrapher_csv)(path, rec)
    problem = TimegrapherFitProblem(scene, read_timegrapher(path))
    assert problem.used_readings.size >= 6
    lsq = least_squares(problem, n_starts=1)
    for name, true in {**TRUTH, "observation.lift_angle": math.radians(52.0)}.items():
        i = lsq.names.index(name)
        assert abs(lsq.value[i] - true) < 3 * lsq.stderr[i], (name, lsq.value[i], lsq.stderr[i])


def test_lift_angle_prior_carries_into_the_answer(scene):
    """A true lift angle 3 deg off the set one biases the amplitude scale; the nuisance absorbs it."""
    rec = record_timegrapher(scene, fmt="json", seed=2, true_lift_deg=55.0)
    lsq = least_squares(TimegrapherFitProblem(scene, rec), n_starts=1)
    i = lsq.names.index("observation.lift_angle")
    assert abs(lsq.value[i] - math.radians(55.0)) < 3 * lsq.stderr[i]
    for name, true in TRUTH.items():
        j = lsq.names.index(name)
        assert abs(lsq.value[j] - true) < 3 * lsq.stderr[j], (name, lsq.value[j], lsq.stderr[j])


def test_posterior_amplitudes_only(scene):
    """Without beat times the amplitudes alone still bracket the truth, more widely."""
    text = SCENE.read_text().replace("sigma_t = 1e-4", "sigma_t = 1e-4\nbeats = false")
    sc = escfit.load_scene("amp_only.toml", text=text)
    rec = record_timegrapher(sc, fmt="json", seed=2, sigma_deg=0.3, window_s=1.0)
    problem = TimegrapherFitProblem(sc, rec)
    assert [c.label for c in problem.curves] == ["amplitude"]
    lsq = least_squares(problem, n_starts=1)
    mc = run_emcee(problem, lsq, walkers=12, steps=400, burn=200, seed=1)
    flat = mc.chain.reshape(-1, len(problem.names))
    for name, true in TRUTH.items():
        lo, hi = np.quantile(flat[:, problem.names.index(name)], [0.001, 0.999])
        assert lo < true < hi, (name, lo, hi)


def test_example_files_read_and_fit(scene):
    for name in ("monday_timegrapher.json", "monday_timegrapher_beats.csv"):
        rec = read_recording(DATASETS / "recordings" / name)
        lsq = least_squares(TimegrapherFitProblem(scene, rec), n_starts=1)
        i = lsq.names.index("viscous.C")
        assert abs(lsq.value[i] - 0.6) < 4 * lsq.stderr[i], name
