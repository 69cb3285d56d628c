"""Three layouts of real exports the readers got wrong, and the time base they needed.

Each is a synthetic damped oscillation (known period and decay) written as a real file was:

- a PASCO Capstone export of one run, one column ``"Position (mm) Run #1"`` with a decimal comma
  and no time column: its one quoted name was split at the spaces, so the run label was missed
  and the unit with it; the comma was read as a delimiter (``38,0169`` as 38 and 0169), the
  integer parts taken for the time.  It is one column in mm, a displacement (``escfit init``
  writes ``displacement_column``), on the rate the user gives;
- a headerless ``reading, time`` log (a distance sensor's): column 1 was taken as the time and
  the rows refused as "sorted by the reading"; the second column alone rises at every row;
- a video tool's ``x y`` table with the angle first and the clock second, written to three
  significant digits: thirty rows share each stamp past 100 s at 30 frames a second.  The clock
  was refused as stalled; an even clock whose rounding gives those stamps is now found
  (:mod:`escfit.analysis.rounded_stamps`) and every row re-timed on it.  A clock that drops rows
  is not such a clock, and stays refused.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.analysis.rounded_stamps import rounded_clock, significant_digits
from escfit.analysis.recordings.rawseries import notes_of
from escfit.analysis.timebase import time_base
from escfit.balance.family import read_data
from escfit.cli.main import cli
from escfit.core.errors import DataError


def _sig(x: np.ndarray, digits: int) -> np.ndarray:
    mag = np.floor(np.log10(np.abs(np.where(x == 0, 1.0, x))))
    q = 10.0 ** (mag - digits + 1)
    return np.round(x / q) * q


def test_a_one_column_decimal_comma_pasco_run_is_a_displacement_in_mm(tmp_path):
    t = np.arange(3000) / 100.0
    x_mm = 50.0 * np.exp(-0.08 * t) * np.cos(2 * math.pi * t / 0.81)
    rows = "\r\n".join(f"{v:.4f}".replace(".", ",") for v in x_mm)
    path = tmp_path / "run.csv"
    path.write_bytes(b"\xef\xbb\xbf" + ('"Position (mm) Run #1"\r\n' + rows + "\r\n").encode())
    with pytest.raises(DataError, match=r"'mm' is not an angle unit.*displacement_column = 'Position \(mm\)'"):
        read_data(path, recording={"sample_rate": "100 Hz"})
    data = read_data(path, recording={"sample_rate": "100 Hz", "displacement_column": "Position (mm)"})
    assert data.theta.size == 3000
    assert np.allclose(data.theta, x_mm / 1000.0, atol=1e-7)  # metres, every digit after the comma kept
    runner = CliRunner()
    out = tmp_path / "s.toml"
    res = runner.invoke(cli, ["init", str(path), "--spring", "--sample-rate", "100 Hz", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert 'displacement_column = "Position (mm)"' in out.read_text()


def test_a_headerless_reading_then_time_log_takes_the_rising_column_as_the_time(tmp_path):
    t = 0.0076 + np.arange(4000) * 0.0099
    reading = np.round(400 + 120 * np.exp(-0.02 * t) * np.cos(2 * math.pi * t / 1.6))
    path = tmp_path / "log.txt"
    path.write_text("".join(f"{int(r)}, {float(s)!r}\n" for r, s in zip(reading, t)))
    data = read_data(path, recording={"angle_unit": "deg"})
    assert np.allclose(data.time, t)
    assert np.allclose(np.degrees(data.theta), reading)
    assert any("column 2 taken as the time" in n for n in notes_of(data.meta)), notes_of(data.meta)


@pytest.mark.parametrize("fps, frames", [(29.97, 0.1), (30.0, 1.0)])
def test_a_clock_written_to_three_significant_digits_is_re_timed_evenly(fps, frames):
    """At 29.97 frames a second the stamp changes at every phase of a frame and the line comes
    within a tenth of a frame of the true clock; at exactly 30 the 1 s stamps change at one phase
    only, and the stamps themselves say no more than one frame."""
    true = 0.0004 + np.arange(20000) / fps
    stamps = _sig(true, 3)
    assert significant_digits(stamps) == 3
    assert np.mean(np.diff(stamps) == 0) > 0.8  # past 100 s thirty rows share a stamp
    base = time_base(stamps)
    assert np.max(np.abs(base.time - true)) < frames / fps
    assert 1.0 / base.interval == pytest.approx(fps, rel=1e-4)
    assert any("3 significant digits" in w for w in base.warnings), base.warnings


def test_a_rounded_clock_that_drops_rows_is_not_re_timed():
    true = 0.0004 + np.arange(20000) / 30.0
    dropped = np.r_[true[:5000], true[5010:]]  # ten frames lost at 167 s
    assert rounded_clock(_sig(dropped, 3)) is None
    with pytest.raises(DataError, match="sample_rate"):
        time_base(_sig(dropped, 3))


def test_x_y_table_with_the_clock_second_and_rounded_is_read(tmp_path):
    t = 0.0004 + np.arange(9000) / 30.0
    angle = 0.18 * np.exp(-0.004 * t) * np.cos(2 * math.pi * t / 1.55)
    path = tmp_path / "track.txt"
    path.write_text("x y\n" + "".join(f"{a:.3E}\t{s:.3E}\n" for a, s in zip(angle, _sig(t, 3))))
    data = read_data(path, recording={"angle_unit": "rad", "angle_column": "x"})
    assert np.max(np.abs(data.time - t)) < 1.0 / 30.0
    assert any("column 'y' taken as the time" in n for n in notes_of(data.meta)), notes_of(data.meta)
    out = tmp_path / "s.toml"
    res = CliRunner().invoke(cli, ["init", str(path), "--pendulum", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert 'angle_column = "x"' in out.read_text() or "angle_column = 1" in out.read_text()


def test_two_runs_without_a_clock_are_refused_naming_both_options(tmp_path):
    """Two PASCO runs side by side and no time column: one message names the run and the rate
    (a user had to meet three refusals in turn), and with both given the run is read."""
    t = np.arange(2000) / 100.0
    one, two = (40.0 * np.exp(-0.05 * t) * np.cos(2 * math.pi * t / p) for p in (1.11, 0.87))
    rows = "".join(f"{a:.4f};{b:.4f}\r\n".replace(".", ",") for a, b in zip(one, two))
    path = tmp_path / "two.csv"
    path.write_text('"Position (mm) Run #1";"Position (mm) Run #2"\r\n' + rows)
    with pytest.raises(DataError, match=r"set \[recording\] run \(1-based\); the runs have no time column either: "
                                        r"set \[recording\] sample_rate"):
        read_data(path)
    data = read_data(path, recording={"run": 2, "sample_rate": "100 Hz", "displacement_column": "Position (mm)"})
    assert np.allclose(data.theta, two / 1000.0, atol=1e-7)
