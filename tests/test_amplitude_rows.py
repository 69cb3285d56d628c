"""Amplitude rows read every few swings (peak amplitudes off a video track every 5-9 swings) and
rows a spreadsheet repeated: numbered by their times, the truth recovered.

The reference is the truth of the simulated pendulum: its turning points (exact solver) are
subsampled at irregular steps of 5-9 half swings, a reading noise added, and written as a
spreadsheet's CSV (empty leading columns, E-notation times, the last row pasted twice).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import escfit
from escfit.core.errors import DataError
from escfit.inference import fit

TRUTH = {"C": 0.03, "R": 0.004}
OMEGA0 = 5.76


def _scene_text(*, omega0=f"{{ value = {OMEGA0}, vary = true, min = 5.0, max = 6.5 }}") -> str:
    return ('model = "balance"\n[oscillator]\nrestoring = "pendulum"\n'
            f"omega0 = {omega0}\n"
            "[effects.viscous]\nC = { value = 0.05, vary = true, min = 0, max = 1 }\n"
            "[effects.coulomb]\nR = { value = 0.001, vary = true, min = 0, max = 1 }\n"
            '[observation]\nmodel = "amplitude"\n'
            '[recording]\ntime_column = 4\nangle_column = 5\nangle_unit = "rad"\nreadings = "amplitudes"\n')


def _rows(tmp_path, *, sigma=0.001, seed=4, repeat_last=True):
    truth = escfit.load_scene("truth.toml", text=(
        f'model = "balance"\n[oscillator]\nrestoring = "pendulum"\nomega0 = {OMEGA0}\ntheta0 = 0.22\n'
        f"[run]\nswings = 200\n[effects.viscous]\nC = {TRUTH['C']}\n[effects.coulomb]\nR = {TRUTH['R']}\n"))
    tr = escfit.simulate(truth)
    rng = np.random.default_rng(seed)
    picks = np.cumsum(rng.integers(5, 10, size=40))
    picks = picks[picks < tr.amplitude.size]
    t = np.r_[0.0, np.asarray(tr.time)[picks - 1]]
    a = np.r_[0.22, np.asarray(tr.amplitude)[picks - 1]] + rng.normal(0.0, sigma, picks.size + 1)
    lines = [",,,t,theta (rad),frame"] + [f",,,{x:.3E},{y:.10f},{i}" for i, (x, y) in enumerate(zip(t, a))]
    if repeat_last:
        lines.append(lines[-1])
    path = tmp_path / "peaks.csv"
    path.write_text("\n".join(lines))  # no final newline, as a spreadsheet writes it
    return path


def test_peak_amplitudes_every_few_swings_recover_the_pendulums_damping(tmp_path):
    data = _rows(tmp_path)
    scene = tmp_path / "peaks.toml"
    scene.write_text(_scene_text())
    res = fit(scene, str(data))
    s = res.summary()
    for name, key in (("viscous.C", "C"), ("coulomb.R", "R")):
        assert s[name]["lo95"] <= TRUTH[key] <= s[name]["hi95"], (name, s[name])
    assert any("omega0 held at the scene's" in n for n in res.notes), res.notes
    assert any("numbered by their times" in n for n in res.notes), res.notes
    assert any("repeating the previous row exactly" in n for n in res.notes), res.notes


def test_rows_every_few_swings_need_omega0_and_distinct_turning_points(tmp_path):
    from escfit.balance.problems.amplitude_rows import amplitude_readings_curve
    from escfit.analysis.recordings.series import TimeSeries

    t = np.array([0.0, 4.0, 9.0, 13.5, 22.0])
    amps = np.array([0.2, 0.18, 0.16, 0.15, 0.13])
    with pytest.raises(DataError, match="give omega0 in the scene"):
        amplitude_readings_curve(TimeSeries(time=t, theta=amps, source="p.csv"))
    curve, by_time = amplitude_readings_curve(TimeSeries(time=t, theta=amps, source="p.csv"), omega0=2 * math.pi)
    assert by_time and list(curve.swing) == [0, 8, 18, 27, 44]  # half period 0.5 s (small amplitude, a spring)
    with pytest.raises(DataError, match="less than a half swing"):
        amplitude_readings_curve(TimeSeries(time=np.array([0.0, 0.1, 5.0, 9.0]), theta=amps[:4], source="p.csv"),
                                 omega0=2 * math.pi)
    # rows one per half swing (a half period apart) keep their row order
    half = np.arange(6) * 0.5
    curve, by_time = amplitude_readings_curve(TimeSeries(time=half, theta=np.linspace(0.2, 0.15, 6), source="p.csv"),
                                              omega0=2 * math.pi)
    assert not by_time and list(curve.swing) == list(range(6))
