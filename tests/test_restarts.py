"""A record swung again and again by hand: separate free decays, the longest fitted (escfit.analysis.recordings.episodes).

Before, a record whose swing grew three times or more was refused as beats or a drive.  A hand's
restart rises within a swing or two and is followed by a much longer free fall; beats rise and
fall alike.  The records here are tests/artefacts/make.py's ``restarts``: five free decays of a
pendulum (escfit's forward simulator), each swung back to about A0 by a hand over a period.
``escfit init`` must put the window on the longest decay (the third), and beats of two close modes
must still be refused.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.analysis.recordings.timeseries import TimeSeries
from escfit.analysis.recordings.turning_points import reduce_series
from escfit.cli.main import cli
from escfit.core.errors import DataError

from .artefacts import make


def _key(text: str, key: str) -> float:
    m = re.search(rf'^{key} = "([0-9.e+-]+) s"', text, re.M)
    assert m, f"no active {key} key in the scene:\n{text[:2000]}"
    return float(m.group(1))


@pytest.mark.parametrize("seed", [0, 4])
def test_init_windows_the_longest_of_five_restarted_decays(seed, tmp_path, monkeypatch):
    art = make("restarts", seed, periods=60)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "swung.csv").write_text(art.csv)
    r = CliRunner().invoke(cli, ["init", "swung.csv", "--pendulum"])
    assert r.exit_code == 0, r.output
    scene = (tmp_path / "swung.toml").read_text()
    assert "set swinging again" in scene
    period = art.truth.period
    start, stop = _key(scene, "start"), _key(scene, "stop")
    # the window opens within half a period before the third decay's first turning point and
    # closes within a period of its end (the half swing before the next restart's hand)
    assert art.truth.t_free_start - 0.5 * period <= start <= art.truth.t_free_start
    assert stop == pytest.approx(art.truth.t_free_end, abs=period)


@pytest.mark.parametrize("f2", [21.0, 23.0, 24.0])
def test_beats_are_not_restarts(f2):
    """Two modes of equal size beat every 1/(f2 - 20) s: 20, 6.7 and 5 periods of the first.
    Their swing rises and falls alike, so the record is still refused as beating modes."""
    t = np.arange(0.0, 8.0, 1.0 / 1024)
    rng = np.random.default_rng(1)
    y = (np.cos(2 * math.pi * 20 * t) + np.cos(2 * math.pi * f2 * t)) * np.exp(-t / 3)
    series = TimeSeries(time=t, theta=y + 0.01 * rng.standard_normal(t.size), source="beats")
    with pytest.raises(DataError, match=r"grows again \d+ times .* beating modes"):
        reduce_series(series)


def test_a_record_that_ends_just_after_the_last_restart(tmp_path, monkeypatch):
    """The record's end cuts the last decay short, three seconds after the hand: that decay's
    fall cannot be judged, the others' can, so the record is still restarts, not beats."""
    from .artefacts.make import _pushed, angle_csv, draw, noisy

    p = draw(4, 60, loss=(2.0, 2.5))
    t, theta, windows = _pushed(p, [0.14, 0.18, 0.32, 0.2, 0.16])
    keep = t <= windows[-1][0] + 3.0
    monkeypatch.chdir(tmp_path)
    (tmp_path / "cut.csv").write_text(angle_csv(t[keep], noisy(p, theta[keep])))
    r = CliRunner().invoke(cli, ["init", "cut.csv", "--pendulum"])
    assert r.exit_code == 0, r.output
    scene = (tmp_path / "cut.toml").read_text()
    assert "set swinging again" in scene
    assert windows[2][0] - 0.5 * p.period <= _key(scene, "start") <= windows[2][0]
