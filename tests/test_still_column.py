"""A signal column holding one value in every row (escfit.analysis.recordings.still_column).

A video tracker's export ``time,x,y,theta`` whose theta column is all zeros beside the bob's
pixel position: read as the angle, it has no spectrum peak, and "no oscillation found" would
hide why.  The reader names the still column and the moving x and y; ``escfit init`` reads the
file as a track (the angle about the arc x and y trace), and the fit finds the pendulum's
period: the track is made here from a known swing about a known pivot.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.balance.family import read_data
from escfit.cli.main import cli
from escfit.core.errors import DataError

PERIOD, PIVOT, RADIUS = 0.82, (404.0, 63.0), 185.0  # s, px, px


def _track(tmp_path, header="time,x,y,theta", still=True):
    t = np.arange(0.0, 20.0, 1 / 120)
    angle = math.radians(40) * np.exp(-0.05 * t) * np.cos(2 * math.pi * t / PERIOD)
    x = PIVOT[0] + RADIUS * np.sin(angle) + 0.2 * np.random.default_rng(3).standard_normal(t.size)
    y = PIVOT[1] + RADIUS * np.cos(angle)
    cols = [t, x, y, np.zeros(t.size) if still else y]
    path = tmp_path / "track.csv"
    path.write_text(header + "\n" + "".join(",".join(f"{c[i]:.6f}" for c in cols) + "\n" for i in range(t.size)))
    return path


def test_the_still_column_is_named_with_the_moving_x_and_y(tmp_path):
    with pytest.raises(DataError, match=r"column 'theta' holds one value \(0\) in every row: no swing to fit; x and "
                                        r"y vary: a position tracked on video\? --format tracker"):
        read_data(_track(tmp_path))


def test_a_still_column_beside_other_columns_names_them(tmp_path):
    path = _track(tmp_path, header="time,a,b,angle")
    with pytest.raises(DataError, match=r"column 'angle' holds one value \(0\) in every row: no swing to fit; 'a', "
                                        r"'b' vary; set \[recording\] angle_column"):
        read_data(path)


def test_init_reads_it_as_a_track_and_the_fit_finds_the_period(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _track(tmp_path)
    r = CliRunner().invoke(cli, ["init", "track.csv", "--pendulum"])
    assert r.exit_code == 0, r.output
    assert 'format = "tracker"' in (tmp_path / "track.toml").read_text()
    assert "pivot at (404" in r.output, r.output
    period = float(r.output.split("period ")[1].split(" s")[0])
    assert period == pytest.approx(PERIOD, rel=2e-3)
