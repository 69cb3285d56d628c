"""A waveform fit of a record too long for its sample budget (escfit.balance.problems.thinning).

Thinned evenly, a record of thousands of periods kept under one sample a period and lost the
swing's phase; it is now read in blocks of whole periods.  Checked: which samples are kept (by
construction, against the record's own clock), that AR(1) noise starts afresh in each block
(against the innovations written out by hand), and a fit of a 5000-period record of known
truth through the command line.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from escfit.balance.problems.thinning import MIN_EVEN, MIN_PER_PERIOD, thin_samples

BUDGET = 4000


def clock(periods, per_period, period=1.0):
    return np.arange(int(periods * per_period)) * (period / per_period)


def test_a_record_within_the_budget_is_read_whole():
    t = clock(100, 20)
    got = thin_samples(t, np.arange(t.size), 1.0, BUDGET)
    assert got.index.size == t.size and got.fresh is None and got.note == ""


def test_a_moderately_long_record_is_thinned_evenly():
    t = clock(1000, 20)  # 20000 samples: every fifth keeps 4 a period
    got = thin_samples(t, np.arange(t.size), 1.0, BUDGET)
    assert got.fresh is None and np.all(np.diff(got.index) == 5) and got.index.size <= BUDGET
    assert 20 / 5 >= MIN_EVEN


def test_the_scene_s_thin_is_taken_as_given():
    t = clock(6000, 20)
    got = thin_samples(t, np.arange(t.size), 1.0, BUDGET, every=7)
    assert np.all(np.diff(got.index) == 7) and got.fresh is None


def test_a_record_of_thousands_of_periods_is_read_in_blocks_of_whole_periods():
    period = 1.3
    t = clock(6000, 50, period) + 0.2
    got = thin_samples(t, np.arange(t.size), period, BUDGET)
    kept = t[got.index]
    assert got.index.size <= BUDGET and got.fresh is not None and got.fresh[0]
    starts = np.flatnonzero(got.fresh)
    blocks = np.split(kept, starts[1:])
    cycle = lambda x: np.floor((x - t[0]) / period)  # noqa: E731
    for b in blocks:
        assert np.all(cycle(b) == cycle(b[0]))  # one period each
        assert b.size >= MIN_PER_PERIOD - 1  # at MIN_PER_PERIOD samples a period or more
    first_cycles = np.array([cycle(b[0]) for b in blocks])
    assert first_cycles[0] == 0 and first_cycles[-1] == cycle(t[-1])  # the first and last period
    gaps = np.diff(first_cycles[:-1])
    assert np.all(gaps == gaps[0])  # spread evenly
    assert len(blocks) > 100


def test_ar1_noise_starts_afresh_in_each_block():
    from dataclasses import replace

    from escfit.balance.observation.waveform import WaveformObservation

    obs = replace(WaveformObservation(0.0, 0, 0.0, (), "ar1"), fresh=np.array([True, False, False, True, False]))
    r = np.array([0.3, -0.1, 0.2, 0.5, 0.4])
    sigma, rho = 0.2, 0.6
    z, scale = obs._innovations(r, sigma, {"observation.rho": rho})
    inner = sigma * math.sqrt(1 - rho * rho)
    expected = [0.3 / sigma, (-0.1 - rho * 0.3) / inner, (0.2 + rho * 0.1) / inner, 0.5 / sigma, (0.4 - rho * 0.5) / inner]
    assert z == pytest.approx(expected, rel=1e-12)
    assert scale == pytest.approx([sigma, inner, inner, sigma, inner], rel=1e-12)


def test_a_five_thousand_period_decay_is_fitted_in_blocks(tmp_path, monkeypatch):
    """A linear oscillator (period 1 s) sampled 20 times a period for 5000 periods, with viscous
    damping and Coulomb friction.  Thinned evenly (0.8 samples a period) the fit's own checks
    found the model 6 standard errors off the first turning point and the waveform and
    turning-point fits 4.7 apart on R; in blocks, C and R come out inside their 95 % intervals
    and the model follows the record's turning points (the fit's own check says so)."""
    from click.testing import CliRunner

    from escfit.balance.synthetic.instruments import record_timeseries
    from escfit.cli.main import cli
    from escfit.core.scene import load_scene
    from escfit.results import load_fit

    monkeypatch.chdir(tmp_path)
    truth = {"C": 6e-4, "R": 4e-4}
    scene = load_scene("truth.toml", text=(
        'model = "balance"\n[oscillator]\nomega0 = 6.283185307179586\ntheta0 = "0.5 rad"\n[run]\nswings = 10000\n'
        f'[effects.viscous]\nC = {truth["C"]}\n[effects.coulomb]\nR = {truth["R"]}\n'))
    ts = record_timeseries(scene, rate_hz=20.0, sigma=0.002, seed=3)
    np.savetxt("long.csv", np.c_[ts.time, ts.theta], delimiter=",", header="time (s),angle (rad)", comments="",
               fmt="%.6f")
    runner = CliRunner()
    assert runner.invoke(cli, ["init", "long.csv", "--spring"]).exit_code == 0
    r = runner.invoke(cli, ["fit", "long.csv", "--scene", "long.toml", "--out", "f.h5"])
    assert r.exit_code == 0, r.output
    assert "blocks of one period" in r.output
    assert "the model's turning times and amplitudes follow the record's" in r.output, r.output
    # and fitted again from one period later, on the samples the fit used
    assert re.search(r"fitted again from one period later \(t = [0-9.]+ s\), the losses move by", r.output), r.output
    rows = load_fit("f.h5").summary()
    for key, name in (("C", "viscous.C"), ("R", "coulomb.R")):
        assert rows[name]["lo95"] <= truth[key] <= rows[name]["hi95"], (name, rows[name])
    assert rows["oscillator.omega0"]["estimate"] == pytest.approx(2 * math.pi, rel=1e-6)


def test_a_record_of_thousands_of_periods_is_fitted_again_from_one_period_later(tmp_path, monkeypatch):
    """A linear oscillator of period 1 s sampled 50 times a period for 2500 periods (viscous
    damping only: ``theta = A exp(-C t / 2) cos(omega_d t)``, with its sine term for a release at
    rest).  The fit from one period later is made (on another noise draw of such a record the
    analysis of the later window on the fit's own samples, blocks of one period far apart, found
    a 9 s swing and no refit was made: the whole record is then used), and the losses hold (the
    two fits share almost every sample: they move by a small part of their errors)."""
    from click.testing import CliRunner

    from escfit.cli.main import cli

    monkeypatch.chdir(tmp_path)
    c, w0 = 8e-4, 2 * math.pi
    wd = math.sqrt(w0 * w0 - c * c / 4)
    t = np.arange(0.0, 2500.0, 0.02)
    theta = 15 * np.exp(-0.5 * c * t) * (np.cos(wd * t) + 0.5 * c / wd * np.sin(wd * t))
    theta += 0.015 * np.random.default_rng(7).standard_normal(t.size)
    np.savetxt("long.csv", np.c_[t, theta], delimiter=",", header="time_s,theta_deg", comments="", fmt="%.6f")
    runner = CliRunner()
    assert runner.invoke(cli, ["init", "long.csv", "--spring"]).exit_code == 0
    r = runner.invoke(cli, ["fit", "long.csv", "--scene", "long.toml", "--out", "f.h5"])
    assert r.exit_code == 0, r.output
    moved = re.search(r"fitted again from one period later \(t = [0-9.]+ s\), the losses move by ([0-9.e-]+) of", r.output)
    assert moved and float(moved.group(1)) < 2, r.output
