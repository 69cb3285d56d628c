"""A record ringing in two modes: the mode asked is isolated and fitted (escfit.analysis.mode_filter).

The records are the closed form of two damped linear modes of one size (periods 1.3 s and a
2.7 times faster one, like a beam's first two) with white reading noise.  The filtered record
must follow the kept mode's own closed form, and ``escfit init`` followed by ``escfit fit``
must recover that mode's omega0 and C, the lowest mode by default and the other with
``--mode 2``.  A one-mode record with ``mode`` set, and unevenly spaced samples, are refused
in one line.
"""

from __future__ import annotations

import json
import math
import tomllib

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.analysis.mode_filter import isolate_mode
from escfit.cli.main import cli
from escfit.core.errors import DataError
from .cli_folder import new_folder

W1, G1 = 2 * math.pi / 1.3, 0.04  # rad/s, 1/s: x'' + 2 g x' + w^2 x = 0, so C = 2 g
W2, G2 = 2.7 * W1, 0.12
T = np.arange(0.0, 40.0, 0.01)


def _mode(w: float, g: float, phase: float = 0.0) -> np.ndarray:
    return 0.01 * np.exp(-g * T) * np.cos(math.sqrt(w * w - g * g) * T + phase)


def _record(noise: float = 1e-5) -> np.ndarray:
    return _mode(W1, G1) + _mode(W2, G2, 0.4) + noise * np.random.default_rng(1).standard_normal(T.size)


@pytest.mark.parametrize("mode, truth", [(1, (W1, G1, 0.0)), (2, (W2, G2, 0.4))])
def test_the_kept_mode_follows_its_closed_form(mode, truth):
    t, kept, split = isolate_mode(T, _record(noise=0.0), mode, "two.csv")
    w, g, phase = truth
    exact = 0.01 * np.exp(-g * t) * np.cos(math.sqrt(w * w - g * g) * t + phase)
    assert split.periods == pytest.approx((1.3, 1.3 / 2.7), rel=2e-3)
    assert t[0] == pytest.approx(2 * 1.3, abs=0.02) and t[-1] == pytest.approx(T[-1] - 2 * 1.3, abs=0.02)
    # the filter's edge: within 0.2 % of the mode's starting amplitude in the first period kept,
    # within 0.05 % from a period after the cut on (the Lorentzian tails of the damped lines)
    err = np.abs(kept - exact)
    inner = (t > t[0] + 1.3) & (t < t[-1] - 1.3)
    assert np.max(err) < 2e-3 * 0.01
    assert np.max(err[inner]) < 5e-4 * 0.01


def _fit(tmp_path, *init_args):
    data = tmp_path / "beam.csv"
    np.savetxt(data, np.c_[T, _record()], delimiter=",", header="t (s),x (m)", comments="", fmt="%.8g")
    runner = CliRunner()
    with new_folder(tmp_path):
        r = runner.invoke(cli, ["init", str(data), "--spring", "--out", "s.toml", *init_args])
        assert r.exit_code == 0, r.output
        recording = tomllib.loads(open("s.toml").read())["recording"]
        r = runner.invoke(cli, ["fit", str(data), "--scene", "s.toml", "--method", "leastsq", "--out", "r.h5"])
        assert r.exit_code == 0, r.output
        r = runner.invoke(cli, ["summary", "r.h5", "--json"])
    return recording, json.loads(r.output)["parameters"]


@pytest.mark.parametrize("args, w, g", [((), W1, G1), (("--mode", "2"), W2, G2)])
def test_init_and_fit_recover_the_mode_asked(tmp_path, args, w, g):
    recording, params = _fit(tmp_path, *args)
    assert recording["mode"] == (2 if args else 1)
    assert params["oscillator.omega0"]["estimate"] == pytest.approx(w, rel=1e-4)
    assert params["viscous.C"]["estimate"] == pytest.approx(2 * g, rel=2e-3)  # the filter's bias stays under 0.2 %


def test_modes_closer_than_the_clean_ratio_are_isolated_with_a_warning():
    """2.1 times apart the damped lines' tails cross the filter's crossover: the kept mode is
    still given, with a warning that its damping may be off (1.6 % low on this record)."""
    from escfit.analysis.mode_filter import CLEAN_RATIO

    x = _mode(W1, G1) + _mode(2.1 * W1, G2, 0.4)
    t, kept, split = isolate_mode(T, x, 1, "close.csv")
    assert split.close and split.warns and 2.1 < CLEAN_RATIO
    assert "times apart" in split.sentence() and "beyond its interval" in split.sentence()
    _, _, far = isolate_mode(T, _record(noise=0.0), 1, "far.csv")
    assert not far.close and not far.warns


def test_a_weak_second_mode_is_taken_out_when_asked():
    """A second mode with some 6 % of the power is only noted by the analysis (the fit follows
    the main swing, its C a few per cent off); with mode = 1 it is filtered out and the kept
    mode follows its closed form."""
    x = _mode(W1, G1) + 0.25 * _mode(W2, G2, 0.4)
    t, kept, split = isolate_mode(T, x, 1, "weak.csv")
    exact = 0.01 * np.exp(-G1 * t) * np.cos(math.sqrt(W1 * W1 - G1 * G1) * t)
    assert split.share < 0.2
    assert np.max(np.abs(kept - exact)) < 2e-3 * 0.01


def test_without_a_mode_the_fit_refuses_naming_the_key(tmp_path):
    from escfit.analysis.recordings.timeseries import TimeSeries
    from escfit.analysis.recordings.turning_points import reduce_series

    with pytest.raises(DataError, match=r"mode = 1 to fit the slower \(period 1\.3 s\) or mode = 2 the faster") as got:
        reduce_series(TimeSeries(time=T, theta=_record(), source="beam.csv"))
    assert got.value.modes == pytest.approx((1.3, 1.3 / 2.7), rel=2e-3)


def test_one_mode_with_a_mode_key_is_refused():
    with pytest.raises(DataError, match="holds one oscillation, not two modes"):
        isolate_mode(T, _mode(W1, G1), 1, "one.csv [recording].mode")


def test_uneven_samples_are_refused():
    t = T + 0.004 * np.random.default_rng(2).uniform(-1, 1, T.size)
    with pytest.raises(DataError, match="evenly spaced"):
        isolate_mode(np.sort(t), _record(), 1, "uneven.csv [recording].mode")


@pytest.mark.parametrize("slow, fast, warned", [(0.5, 1.0, True), (1.0, 0.5, False)])
def test_keeping_the_weaker_mode_is_a_warning(tmp_path, slow, fast, warned):
    """mode = 1 (the default) keeps the slower mode; when that one holds a quarter of the other's
    power (a stand's rocking under a swing, say) the choice is a warning naming mode = 2."""
    import escfit

    x = slow * _mode(W1, G1) + fast * _mode(W2, G1, 0.4)
    data = tmp_path / "two.csv"
    np.savetxt(data, np.c_[T, x], delimiter=",", header="t (s),x (m)", comments="", fmt="%.8g")
    series = escfit.read_recording(data, recording={"mode": 1, "displacement_column": "x (m)"})
    said = series.meta.get("warnings", "") if warned else series.meta.get("notes", "")
    assert "mode = 2" in said and ("if the other is the oscillation you recorded" in said) == warned
    assert ("two modes" in series.meta.get("warnings", "")) == warned
