"""Tables of turning points told from sampled swings by their physics, with known truth.

A turning-point table is made from a damped oscillator whose turning points are known: the
closed form of a linear oscillator with viscous and dry friction (each half swing
``A' = r A - (1 + r) R / omega0**2``, half a damped period apart) and the pendulum's exact solver.
Sampled swings are a decaying sine sampled at 2-3 samples a period (a coarse record that also
alternates in sign): they must not be read as tables.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import escfit
from escfit.analysis.recordings.row_kind import judge_rows
from escfit.cli.main import cli
from .cli_folder import new_folder

OMEGA0, C, R = 4.08, 0.02, 0.002


def _linear_table(n=120, a0=0.5, omega0=OMEGA0, c=C, r_dry=R):
    """Closed form: signed turning points of a linear oscillator, release at t = 0."""
    wd = math.sqrt(omega0 ** 2 - c ** 2 / 4)
    r = math.exp(-math.pi * c / (2 * wd))
    amps = [a0]
    for _ in range(n - 1):
        amps.append(r * amps[-1] - (1 + r) * r_dry / omega0 ** 2)
    k = np.arange(n)
    return k * math.pi / wd, np.asarray(amps) * np.where(k % 2 == 0, 1.0, -1.0)


def _pendulum_table(theta0=0.5, swings=140):
    truth = escfit.load_scene("truth.toml", text=(
        f'model = "balance"\n[oscillator]\nrestoring = "pendulum"\nomega0 = {OMEGA0}\ntheta0 = {theta0}\n'
        f"[run]\nswings = {swings}\n[effects.viscous]\nC = {C}\n[effects.coulomb]\nR = {R}\n"))
    tr = escfit.simulate(truth)
    t = np.r_[0.0, np.asarray(tr.time)]
    a = np.r_[theta0, np.asarray(tr.amplitude)]
    return t, a * np.where(np.arange(a.size) % 2 == 0, 1.0, -1.0)


def test_a_closed_form_table_is_turning_points_a_half_period_apart():
    t, v = _linear_table()
    kind = judge_rows(t, v)
    assert kind.verdict == "turning points" and not kind.one_sided and kind.per_half_swing
    assert kind.alternation == 1.0 and kind.missing == 0
    assert kind.step == pytest.approx(math.pi / math.sqrt(OMEGA0 ** 2 - C ** 2 / 4), rel=1e-9)


def test_a_noisy_pendulum_table_with_an_offset_and_a_missing_row():
    t, v = _pendulum_table()
    rng = np.random.default_rng(3)
    t = np.round(t / (1 / 30)) * (1 / 30)  # turning times read off a 30 frames/s video
    v = v + 0.04 + rng.normal(0.0, 0.004, v.size)  # the scale's zero 0.04 rad off the centre, reading noise
    keep = np.ones(t.size, bool)
    keep[57] = False  # a turning point the reader missed
    kind = judge_rows(t[keep], v[keep])
    assert kind.verdict == "turning points" and kind.missing == 1, kind
    assert kind.centre == pytest.approx(0.04, abs=0.004)  # the offset, within the reading noise
    assert kind.step_spread < 0.05
    # one misread sign costs a step or two, not the table
    v2 = v.copy()
    v2[80] = 0.08 - v2[80]
    assert judge_rows(t, v2).verdict == "turning points"


def test_one_sided_tables_say_what_they_can():
    t, v = _pendulum_table()
    peaks = judge_rows(t[::2], v[::2])  # the maxima only, a period apart
    assert peaks.verdict == "turning points" and peaks.one_sided
    assert peaks.per_half_swing is None  # a period or a half swing: the rows cannot say
    assert peaks.step == pytest.approx(np.median(np.diff(t[::2])), rel=1e-9)
    # magnitudes read each side on a scale whose zero is 0.02 rad off the centre: a zig-zag
    mags = np.abs(v + 0.02)
    each = judge_rows(t, mags)
    assert each.verdict == "turning points" and each.one_sided and each.per_half_swing


@pytest.mark.parametrize("per_period", [2.02, 2.1, 2.3, 2.5, 2.8, 3.0])
@pytest.mark.parametrize("phase", [0.2, 1.0, 2.3])
def test_a_coarsely_sampled_sine_is_not_a_table(per_period, phase):
    period = 1.5
    t = np.arange(140) * period / per_period
    rng = np.random.default_rng(int(per_period * 100) + int(phase * 10))
    x = 0.4 * np.exp(-0.01 * t) * np.sin(2 * math.pi * t / period + phase) + rng.normal(0, 0.002, t.size)
    assert judge_rows(t, x).verdict != "turning points"


def test_a_well_sampled_swing_about_a_far_zero_is_not_a_table():
    t = np.arange(600) * 0.05
    x = 1000.0 + 30.0 * np.exp(-0.05 * t) * np.sin(2 * math.pi * t / 1.3)  # encoder counts, one sign
    assert judge_rows(t, x).verdict != "turning points"


def _write(tmp_path, name, t, v, header="time\tangle (rad)"):
    path = tmp_path / name
    path.write_text(header + "\n" + "\n".join(f"{a:.5f}\t{b:.6f}" for a, b in zip(t, v)) + "\n")
    return path


def _init(args, tmp_path):
    runner = CliRunner()
    with new_folder(tmp_path) as here:
        result = runner.invoke(cli, ["init", *map(str, args)], catch_exceptions=False)
        return result, Path(here)


def test_init_reads_a_long_turning_point_table_and_the_fit_recovers_the_damping(tmp_path):
    from escfit.analysis.pendulum_unit import pendulum_period_factor
    from escfit.inference import fit

    t, v = _pendulum_table(swings=60)
    rng = np.random.default_rng(5)
    v = v + rng.normal(0.0, 0.002, v.size)
    data = _write(tmp_path, "tp.txt", t, v)
    result, here = _init([data, "--pendulum"], tmp_path)
    assert result.exit_code == 0, result.output
    assert "signs alternating" in result.output and "spread" in result.output  # the evidence, said
    doc = tomllib.loads((here / "tp.toml").read_text())
    assert doc["recording"]["readings"] == "amplitudes"
    # omega0 is the small-swing value: the measured period shortened by the amplitude, exactly
    assert doc["oscillator"]["omega0"] == pytest.approx(OMEGA0, rel=2e-3)
    measured = 2 * float(np.polyfit(np.arange(t.size), t, 1)[0])
    assert measured > 2 * math.pi / OMEGA0 * float(pendulum_period_factor(np.array([0.3]))[0])  # it was longer
    res = fit(here / "tp.toml", str(data), n_starts=1)
    s = res.summary()
    assert s["viscous.C"]["lo95"] <= C <= s["viscous.C"]["hi95"], s["viscous.C"]


def test_init_refuses_a_coarse_sampled_swing_rather_than_read_it_as_a_table(tmp_path):
    t = np.arange(140) * 1.5 / 2.3
    x = 0.4 * np.exp(-0.01 * t) * np.sin(2 * math.pi * t / 1.5 + 0.7)
    result, here = _init([_write(tmp_path, "coarse.txt", t, x), "--pendulum"], tmp_path)
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert "samples" in result.output and not (here / "coarse.toml").exists()


def test_init_asks_whether_one_sided_peaks_are_half_swings_or_periods(tmp_path):
    t, v = _pendulum_table()
    peaks = _write(tmp_path, "peaks.txt", t[::2], v[::2])
    result, _ = _init([peaks, "--pendulum"], tmp_path)
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert "--readings amplitudes" in result.output
    import re

    found = re.search(r"omega0 = ([0-9.]+) \(([0-9.]+) for a gravity pendulum", result.output)
    assert found, result.output
    step = float(np.median(np.diff(t[::2])))
    assert float(found.group(1)) == pytest.approx(2 * math.pi / step, rel=0.01)  # the period at these amplitudes
    assert float(found.group(2)) == pytest.approx(OMEGA0, rel=2e-3)  # the truth's small-swing value


def test_rows_between_a_table_and_samples_are_refused_naming_both_readings(tmp_path):
    t, v = _pendulum_table()
    rng = np.random.default_rng(9)
    flip = rng.random(v.size) < 0.12  # one sign in eight misread: not clearly a table any more
    v = np.where(flip, -v, v)
    kind = judge_rows(t, v)
    assert kind.verdict == "ambiguous", kind
    result, here = _init([_write(tmp_path, "mixed.txt", t, v), "--pendulum"], tmp_path)
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert "--readings amplitudes" in result.output and "--readings samples" in result.output
    assert not list(here.glob("*.toml"))
