"""Free-decay time series: turning points survive noise, quantisation and offset; round trip."""

from __future__ import annotations

import math

import numpy as np
import pytest

import escfit
from escfit.balance import solve
from escfit.balance.problems.curves import FitProblem
from escfit.inference import least_squares
from escfit.balance.synthetic.instruments import record_timeseries
from escfit.analysis.recordings.detect import detect_format, read_recording
from escfit.analysis.recordings.timeseries import (TimeSeries, read_timeseries, timeseries_to_unit_curve, turning_points,
                                          write_timeseries)

from .conftest import DATASETS

SCENE = DATASETS / "recordings" / "timeseries_scene.toml"
TRUTH = {"viscous.C": 0.6, "coulomb.R": 100.0, "escapement[2].X": 1500.0}


@pytest.fixture(scope="module")
def scene():
    return escfit.load_scene(SCENE)


@pytest.fixture(scope="module")
def truth(scene):
    return solve(scene, swings=40)


def test_dense_angle_matches_turning_points(scene, truth):
    tr = solve(scene, swings=40, dense=True)
    np.testing.assert_allclose(tr.dense.theta(tr.time[:10]), tr.theta_turn[:10], atol=1e-12)
    assert tr.dense.theta(np.array([0.0]))[0] == pytest.approx(6.28)


def test_noise_free_turning_points_are_unbiased(scene, truth):
    """The kinked local fit finds turning points to 1e-4 rad and 10 us despite the jump in
    curvature where Coulomb friction reverses."""
    tp = turning_points(record_timeseries(scene, rate_hz=500.0))
    k = tp.swing
    np.testing.assert_array_equal(k, np.arange(1, k.size + 1))
    assert k.size >= 38
    np.testing.assert_allclose(tp.theta, truth.theta_turn[k - 1], atol=1e-4)
    np.testing.assert_allclose(tp.time, truth.time[k - 1], atol=1e-5)
    assert tp.period == pytest.approx(2 * math.pi / 15.9, rel=0.02)


def test_a_smooth_fit_across_the_turn_would_misplace_it(scene, truth):
    """Why the kink: one quartic through both sides misses the turning time by ~1 ms."""
    ts = record_timeseries(scene, rate_hz=500.0)
    t_turn, i = truth.time[5], np.searchsorted(ts.time, truth.time[5])
    half = 0.125 * 2 * math.pi / 15.9
    sel = np.abs(ts.time - ts.time[i]) < half
    u = (ts.time[sel] - ts.time[i]) / half
    c = np.polynomial.polynomial.polyfit(u, ts.theta[sel], 4)
    r = np.polynomial.polynomial.polyroots(np.polynomial.polynomial.polyder(c))
    r = r[np.isreal(r)].real
    smooth_time = ts.time[i] + r[np.argmin(np.abs(r))] * half
    assert abs(smooth_time - t_turn) > 2e-4


@pytest.mark.parametrize("sigma, quantum, offset", [(0.002, 0.0, 0.0), (0.002, 2 * math.pi / 4096, 0.02),
                                                    (0.01, 2 * math.pi / 1024, -0.05)])
def test_noise_quantisation_and_offset(scene, truth, sigma, quantum, offset):
    ts = record_timeseries(scene, rate_hz=500.0, sigma=sigma, quantum=quantum, offset=offset, seed=3)
    curve = timeseries_to_unit_curve(ts)
    assert float(curve.meta["offset_rad"]) == pytest.approx(offset, abs=max(2e-3, sigma / 2))
    err = curve.value - truth.amplitude[curve.swing - 1]
    assert np.sqrt(np.mean(err**2)) < 0.5 * sigma + 5e-4
    assert abs(err.mean()) < 0.2 * sigma + 1e-4


def test_round_trip_in_degrees_recovers_the_scene(scene, tmp_path):
    ts = record_timeseries(scene, rate_hz=400.0, sigma=0.002, quantum=2 * math.pi / 4096, offset=0.02, seed=3)
    path = tmp_path / "decay.csv"
    write_timeseries(path, ts, unit="deg", decimals=4)
    back = read_timeseries(path)
    np.testing.assert_allclose(back.theta, ts.theta, atol=math.radians(0.6e-4))
    assert detect_format(path) == "timeseries"
    curve = timeseries_to_unit_curve(back, release_theta=6.28)
    lsq = least_squares(FitProblem(scene, curve), n_starts=2)
    for name, true in TRUTH.items():
        i = lsq.names.index(name)
        assert abs(lsq.value[i] - true) < 3 * lsq.stderr[i], (name, lsq.value[i], lsq.stderr[i])
    assert lsq.sigma_hat < 2e-3


def test_release_instant_from_metadata(scene, truth):
    """A series that starts before the release says when it happened; swings count from there."""
    ts = record_timeseries(scene, rate_hz=500.0, swings=12)
    pad = np.arange(-0.3, 0.0, 0.002)
    late = TimeSeries(np.r_[pad + 10.0, ts.time + 10.0], np.r_[np.full(pad.size, 6.28), ts.theta], 10.0)
    tp = turning_points(late)
    np.testing.assert_allclose(tp.time - 10.0, truth.time[tp.swing - 1], atol=1e-5)


def test_example_file_fits(scene):
    curve = timeseries_to_unit_curve(read_recording(DATASETS / "recordings" / "monday_timeseries.csv"))
    lsq = least_squares(FitProblem(scene, curve), n_starts=1)
    i = lsq.names.index("viscous.C")
    assert abs(lsq.value[i] - 0.6) < 4 * lsq.stderr[i]


@pytest.mark.parametrize("recorder, options, kind", [
    ("unit-curve", {"every": 2, "notch_deg": 6}, "notches"),
    ("pulses", {"swings": 6}, "pulses"),
    ("timegrapher", {"fmt": "json", "swings": 30}, "timegrapher"),
    ("timegrapher", {"fmt": "csv", "swings": 30}, "timegrapher"),
    ("timeseries", {"swings": 6, "unit": "deg"}, "timeseries"),
])
def test_record_writes_every_format_detectably(scene, tmp_path, recorder, options, kind):
    """The one entry point a command line needs: write, detect, read back, with provenance."""
    from escfit.balance.synthetic.instruments import record

    suffix = ".json" if options.get("fmt") == "json" else ".csv"
    path = record(scene, recorder, tmp_path / f"rec{suffix}", noise=None, seed=5, **options)
    assert detect_format(path) == recorder
    assert read_recording(path).kind == kind
    text = path.read_text()
    assert "record('timeseries_scene.toml'" in text and "seed=5" in text
