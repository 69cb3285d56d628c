"""Tables whose names do not say which column is the time or the angle (escfit.analysis.roles, channel).

Synthetic tables of known truth, written the way plotting programs and lab loggers write them: a
free decay ``theta'' + C theta' + omega0**2 theta = 0`` (closed form ``A exp(-C t/2) cos(omega_d t)``)
as ``x, y, dx, dy`` (the quantity and its uncertainty), as ``X, Y, X', Y'``, a table of amplitudes
sorted by amplitude, one motion seen by two sensors, and a counts column read as an angle.  Each is
read as ``escfit fit`` (:func:`escfit.balance.family.read_data`) and ``escfit init`` read it; the
estimate of omega0 is held against the closed form's.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.analysis.channel import choose_channel
from escfit.analysis.roles import companions, rising_clock
from escfit.balance.family import read_data
from escfit.cli.main import cli
from escfit.core.errors import DataError
from .cli_folder import new_folder

OMEGA0, C = 4.0, 0.05
RATE, DURATION = 30.0, 40.0
RNG = np.random.default_rng(20261202)
WD = math.sqrt(OMEGA0 ** 2 - C ** 2 / 4)


def _decay(amplitude=0.4):
    t = np.arange(0.0, DURATION, 1.0 / RATE)
    return t, amplitude * np.exp(-C * t / 2) * np.cos(WD * t)


def _init(tmp_path, data, *args):
    runner = CliRunner()
    with new_folder(tmp_path) as here:
        result = runner.invoke(cli, ["init", str(data), "--pendulum", *args], catch_exceptions=False)
        scene = Path(here) / f"{Path(data).stem}.toml"
        return result, (tomllib.loads(scene.read_text()) if scene.exists() else None)


def test_uncertainty_columns_are_companions_only_when_never_negative():
    t, theta = _decay()
    names = ["x", "y", "dx", "dy", "Amplitude (rad)", "Amplitude uncertainty (rad)", "velocity error"]
    values = {0: t, 1: theta, 2: np.full(t.size, 0.017), 3: np.gradient(theta, t),  # dy here is a derivative
              4: np.abs(theta), 5: np.full(t.size, 0.01), 6: np.full(t.size, 0.2)}
    found = companions(names, values)
    assert found == {2: 0, 5: 4, 6: None}  # dy changes sign: a derivative, not an uncertainty
    assert rising_clock({0: t, 1: theta, 2: values[2]}) == 0
    assert rising_clock({0: t, 1: t ** 2}) is None  # two rising columns: no choice


def test_x_y_dx_dy_header_spaced_above_tab_separated_data_with_a_rounded_clock(tmp_path):
    t, theta = _decay()
    rows = [f"{float(f'{a:.3g}'):.2E}\t{b:.6f}\t0.017\t0.005" for a, b in zip(t, theta)]  # x written to 3 digits
    data = tmp_path / "20deg.txt"
    data.write_text("x y dx dy\t\t\t\n" + "\n".join(rows) + "\n")
    with pytest.raises(DataError, match=r"no column looks like the angle.*by shape: 'y' (0\.9\d|1\.00) \(a decaying "
                                        r"oscillation at 0\.63\d+ Hz"):
        read_data(data)  # the fit does not guess; the shapes name 'y', at the record's frequency in Hz
    result, scene = _init(tmp_path, data)
    assert result.exit_code == 0, result.output
    assert scene["recording"]["angle_column"] == "y"
    assert "'dx' (of 'x'), 'dy' (of 'y')" in result.output and "column 'x' taken as the time" in result.output
    series = read_data(data, recording={"angle_column": "y", "angle_unit": "rad"})
    crossings = np.flatnonzero(np.diff(np.sign(series.theta)) > 0)
    period = np.median(np.diff(series.time[crossings]))  # crossings at 30 samples a second: a frame's precision
    assert period == pytest.approx(2 * math.pi / WD, abs=1.5 / RATE)


def test_primed_uncertainty_columns_keep_their_prime_and_x_is_the_clock(tmp_path):
    t, theta = _decay()
    data = tmp_path / "q2.csv"
    data.write_text("X,Y,X',Y'\n" + "\n".join(f"{a:.4f},{b:.7f},0.0166667,{0.002 + 0.01 * abs(b):.6f}"
                                               for a, b in zip(t, theta)) + "\n")
    series = read_data(data, recording={"angle_column": "Y", "angle_unit": "rad"})
    np.testing.assert_allclose(series.time, t, atol=1e-4)
    assert """"X'" (of 'X'), "Y'" (of 'Y')""" in series.meta["notes"]
    result, scene = _init(tmp_path, data)
    assert result.exit_code == 0, result.output
    assert scene["recording"]["angle_column"] == "Y"


def test_a_table_of_amplitudes_sorted_by_amplitude(tmp_path):
    t, theta = _decay()
    peaks = np.flatnonzero((theta[1:-1] > theta[:-2]) & (theta[1:-1] >= theta[2:])) + 1
    order = np.argsort(-theta[peaks])[::-1]  # rows sorted by amplitude, smallest first
    rows = [f"{t[peaks][k]:.4f},{theta[peaks][k]:.6f},0.02,0.005" for k in order]
    head = "Time (seconds),Amplitude (radians),Time uncertainty (seconds),Amplitude uncertainty (radians)"
    data = tmp_path / "sorted.csv"
    data.write_text(head + "\n" + "\n".join(rows * 1) + "\n")
    with pytest.raises(DataError, match=r'rows are sorted by the reading.*readings = "amplitudes"'):
        read_data(data)
    series = read_data(data, recording={"readings": "amplitudes"})
    assert np.all(np.diff(series.time) > 0) and "not in time order" in series.meta["notes"]
    # the amplitudes fall as exp(-C t / 2): the log slope of the sorted rows gives C back
    slope = np.polyfit(series.time, np.log(series.theta), 1)[0]
    assert -2 * slope == pytest.approx(C, rel=0.05)


def test_one_motion_in_two_sensors_is_one_decay_but_two_pendulums_are_not():
    t, theta = _decay()
    laser = 2.9e6 + 4e5 * theta + 300 * RNG.standard_normal(t.size)  # counts of a position sensor
    coil = -80 * np.gradient(theta, t) + 0.5 * RNG.standard_normal(t.size)  # volts of a coil: the velocity
    choice = choose_channel(t, {"FuncGen": coil, "Laser": laser})  # no label says which is calibrated
    assert choice.chosen is None and "one motion in several columns" in choice.refusal()
    assert "no label says which is the calibrated angle" in choice.refusal()
    named = choose_channel(t, {"ch1": coil, "position (mm)": laser / 1e3}, units={"position (mm)": "mm"})
    assert named.chosen == "position (mm)"  # the label that names the fitted quantity wins
    assert "one motion in several columns: 'ch1' decays" in named.note()
    other = 0.3 * np.exp(-C * t / 2) * np.cos(1.08 * WD * t)  # a second pendulum, 8 % faster
    two = choose_channel(t, {"Angle, Ch 1+2": theta, "Angle, Ch 3+4": other})
    assert two.chosen is None and "runner-up" in two.reason


def test_counts_read_as_an_angle_are_not_unwrapped_and_the_refusal_says_why(tmp_path):
    t, theta = _decay()
    data = tmp_path / "laser.csv"
    data.write_text("t,Laser\n" + "\n".join(f"{a:.5f},{2.9e6 + 4e5 * b:.0f}" for a, b in zip(t, theta)) + "\n")
    result, scene = _init(tmp_path, data, "--angle-unit", "deg")
    assert result.exit_code == 2 and scene is None
    assert "wraps" not in result.output and "unwrap it" not in result.output
    assert "further than any swing moves between two samples" in result.output and "displacement_column" in \
        result.output
