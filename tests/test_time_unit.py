"""A clock in milliseconds: the pendulum's length refuses it, ``[recording] time_unit`` reads it.

The record is a gravity pendulum of omega0 = 2 pi / 1.2 s (a 36 cm string) integrated here with
scipy (``theta'' = -omega0^2 sin theta - C theta'``), sampled at 100 Hz with its times written
in milliseconds.  Read as seconds, the period is 1204 s: a pendulum 360 km long, which the
reader must refuse naming ``time_unit`` (and the 36 cm pendulum it would be in ms), never fit
(its rates would come out a thousand times too small).  With ``time_unit = "ms"`` (the header
silent, or naming s wrongly) the fit finds omega0 and C.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.integrate import solve_ivp

from escfit import read_recording
from escfit.cli.main import cli
from escfit.core.errors import SceneError
from escfit.results import load_fit

OMEGA0, C, THETA0 = 2 * math.pi / 1.2, 0.02, math.radians(15)


def _write(path, header: str) -> None:
    t = np.arange(0.0, 40.0, 0.01)
    sol = solve_ivp(lambda _, y: [y[1], -OMEGA0 ** 2 * math.sin(y[0]) - C * y[1]], (0, t[-1]), [THETA0, 0.0],
                    t_eval=t, rtol=1e-10, atol=1e-12)
    deg = np.degrees(sol.y[0]) + 0.02 * np.random.default_rng(1).standard_normal(t.size)
    path.write_text(header + "\n" + "".join(f"{1000 * a:.3f},{b:.4f}\n" for a, b in zip(t, deg)))


def test_a_clock_in_ms_read_as_s_is_refused_by_the_pendulums_length(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _write(tmp_path / "ms.csv", "time,angle")
    r = CliRunner().invoke(cli, ["init", "ms.csv", "--pendulum"])
    assert r.exit_code == 2, r.output
    period = 2 * math.pi / OMEGA0 * (1 + THETA0 ** 2 / 16)  # s, at 15 deg (the decay shortens it a little)
    metres = 9.80665 * (1000 * period / (2 * math.pi)) ** 2
    said = re.search(r"would be ([0-9.]+) km long", r.output)
    assert said and float(said.group(1)) == pytest.approx(metres / 1000, rel=0.01), r.output
    assert 'time_unit = "ms"' in r.output, r.output
    assert not (tmp_path / "ms.toml").exists()


@pytest.mark.parametrize("header", ["time,angle", "Time (s),Angle (deg)"])
def test_time_unit_ms_reads_the_clock_and_the_fit_finds_the_truth(tmp_path, monkeypatch, header):
    monkeypatch.chdir(tmp_path)
    _write(tmp_path / "ms.csv", header)
    r = CliRunner().invoke(cli, ["init", "ms.csv", "--pendulum", "--time-unit", "ms", "--angle-unit", "deg"])
    assert r.exit_code == 0, r.output
    assert 'time_unit = "ms"' in (tmp_path / "ms.toml").read_text()
    r = CliRunner().invoke(cli, ["fit", "ms.csv", "--scene", "ms.toml", "--out", "ms.h5"])
    assert r.exit_code == 0, r.output
    rows = load_fit(tmp_path / "ms.h5").summary()
    for name, truth in (("oscillator.omega0", OMEGA0), ("viscous.C", C)):
        est, lo, hi = (float(rows[name][k]) for k in ("estimate", "lo95", "hi95"))
        assert lo - 0.01 * truth < truth < hi + 0.01 * truth, (name, est, lo, hi, truth)


def test_time_unit_must_be_a_time(tmp_path):
    _write(tmp_path / "ms.csv", "time,angle")
    series = read_recording(tmp_path / "ms.csv", recording={"time_unit": "us", "angle_unit": "deg"})
    assert series.time[-1] == pytest.approx(39.99e-3)
    with pytest.raises(SceneError, match="expected a time unit"):
        read_recording(tmp_path / "ms.csv", recording={"time_unit": "kg"})
