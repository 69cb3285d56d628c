"""A drive logged in a column beside the swing, switched off within the record (escfit.analysis.switch_off).

The detector is checked on columns built here with a known switch-off row, and on the lookalikes
it must leave alone: a logger that stalls on its last reading, a column of the same motion that
stops with it, a setting changed by hand.  ``escfit init`` is then run on a driven pendulum with
its motor's column (tests/artefacts/make.py, ``drive_logged``): the scene it writes must start
where the motor stopped and release the model at the first turning point after it.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.analysis.switch_off import drive_switched_off, switched_off
from escfit.cli.main import cli

from .artefacts import make

RATE = 50.0  # Hz
T = np.arange(0.0, 60.0, 1.0 / RATE)
SWING = np.exp(-0.02 * T) * np.cos(2 * math.pi * T / 1.3)  # the oscillator, swinging throughout
OFF_ROW = 2000  # 40 s


def _drive(level_after: float = 0.0) -> np.ndarray:
    drive = 2.5 * np.cos(2 * math.pi * T / 1.45)
    drive[OFF_ROW:] = level_after
    return drive


def test_switch_off_found_at_its_row():
    found = switched_off(T, _drive(), SWING, name="motor")
    assert found is not None
    assert found.time == pytest.approx(T[OFF_ROW], abs=1e-12)
    assert found.flat_rows == T.size - OFF_ROW
    assert found.value == 0.0
    assert found.frequency == pytest.approx(1 / 1.45, rel=0.01) and found.explained > 0.99
    # the range after the switch-off over the range before: exp(-0.02 * 40 s) of the swing is left
    assert found.swing_kept == pytest.approx(math.exp(-0.8), rel=0.02)


@pytest.mark.parametrize("phase", np.linspace(0.0, 2 * math.pi, 9)[:-1])
def test_a_stalled_logger_is_not_a_drive(phase):
    """A logger that stalls repeats its last reading, wherever in the swing that falls (near the
    centre too): only a column that reads exactly 0 is a drive switched off."""
    drive = 2.5 * np.cos(2 * math.pi * T / 1.45 + phase)
    drive[OFF_ROW:] = drive[OFF_ROW - 1]
    assert drive[OFF_ROW - 1] != 0.0
    assert switched_off(T, drive, SWING) is None


def test_a_noise_channel_that_drops_to_zero_is_not_a_drive():
    """A sensor's noise, rounded to a coarse step, changes at most rows and can stop on 0 exactly
    when the sensor is unplugged: it never oscillated, so it drove nothing."""
    noise = np.round(0.02 * np.random.default_rng(5).standard_normal(T.size), 2)
    noise[OFF_ROW:] = 0.0
    assert np.mean(np.diff(noise[:OFF_ROW]) != 0) > 0.5
    assert switched_off(T, noise, SWING) is None


def test_a_column_that_stops_with_the_swing_is_the_same_motion():
    swing = SWING.copy()
    swing[OFF_ROW:] = 0.0
    velocity = np.gradient(swing, T)
    velocity[OFF_ROW:] = 0.0
    assert switched_off(T, velocity, swing) is None


def test_a_setting_changed_by_hand_is_not_a_drive():
    setting = np.zeros_like(T)
    setting[500:1000] = 3.0
    setting[1000:1500] = 1.0
    assert switched_off(T, setting, SWING) is None


def test_a_short_flat_tail_is_not_a_switch_off():
    drive = 2.5 * np.cos(2 * math.pi * T / 1.45)
    drive[-10:] = 0.0  # ten rows: a gap or the file's end, not a drive left off
    assert switched_off(T, drive, SWING) is None


def test_the_last_of_several_switch_offs_wins():
    early, late = _drive(), 2.5 * np.sin(2 * math.pi * T / 0.9)
    late[OFF_ROW + 500:] = 0.0
    found = drive_switched_off(T, {"a": early, "b": late}, SWING)
    assert found is not None and found.column == "b"
    assert found.time == pytest.approx(T[OFF_ROW + 500], abs=1e-12)


def _key(text: str, key: str) -> float:
    m = re.search(rf'^{key} = "([0-9.e+-]+) s"', text, re.M)
    assert m, f"no active {key} key in the scene:\n{text[:1500]}"
    return float(m.group(1))


def test_init_starts_at_the_switch_off_and_releases_at_the_next_turn(tmp_path, monkeypatch):
    art = make("drive_logged", 3, periods=20)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "driven.csv").write_text(art.csv)
    r = CliRunner().invoke(cli, ["init", "driven.csv", "--pendulum"])
    assert r.exit_code == 0, r.output
    assert "'motor (V)'" in r.output and "drive switched off" in r.output
    scene = (tmp_path / "driven.toml").read_text()
    rows = np.array([[float(v) for v in line.split(",")] for line in art.csv.splitlines()[1:]])
    t_off = rows[np.flatnonzero(rows[:, 1] != 0.0)[-1] + 1, 0]  # the motor column's first flat row
    assert _key(scene, "start") == pytest.approx(t_off, abs=1e-3)
    # the truth's first turning point after the switch-off, to a tenth of a sample interval
    assert _key(scene, "release") == pytest.approx(art.truth.t_free_start, abs=0.1 * (rows[1, 0] - rows[0, 0]))
