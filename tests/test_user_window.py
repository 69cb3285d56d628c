"""The user's window wins: ``[recording] start``, ``stop`` and ``release`` (and ``--start``,
``--stop``, ``--release``) on records of known truth.

The records are escfit's own simulation (the exact solver, :func:`record_timeseries`) of a
spring-restored oscillator, period 1 s, viscous C = 0.04 1/s and Coulomb R = 0.03 rad/s^2,
released at rest at 0.5 rad at the first sample, sampled at 50 Hz with 0.002 rad of noise.
Mid-decay a sensor glitch (a raised-cosine bump of 0.03 rad over 0.6 s on the turning point
nearest 20 s) moves one turning point out of line: the automatic analysis sees no push in it
(one turning point, not a level kept) and keeps the whole record; the user's start or release
moves the window where the user says, and the fit covers the truth.  Clocks: the same record on an epoch clock (1.407e9 s + t), and a Tracker
``.trk`` video track of the shipped corpus.  ``escfit init`` writes the window it chose as keys,
and amplitude tables are told apart from samples.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import escfit
from escfit.balance.family import read_data
from escfit.analysis.recordings.turning_points import reduce_series
from escfit.cli.main import cli
from escfit.core.errors import DataError
from escfit.inference import fit
from escfit.results import load_fit

from .conftest import DATASETS

TRUTH = {"viscous.C": 0.04, "coulomb.R": 0.03}
OMEGA0 = 2 * math.pi
GLITCH_NEAR = 20.0  # s
EPOCH = 1.407e9
TRK = DATASETS / "real" / "pohl_heilaut" / "raw" / "Dämpfung.trk"
FIT_SCENE = ('model = "balance"\n[oscillator]\nomega0 = { value = 6.2, vary = true, min = 5.0, max = 7.5 }\n'
             "[effects.viscous]\nC = { value = 0.02, vary = true, min = 0.0, max = 1.0 }\n"
             "[effects.coulomb]\nR = { value = 0.01, vary = true, min = 0.0, max = 1.0 }\n"
             '[observation]\nmodel = "amplitude"\n')


def _truth():
    """The true trajectory's samples (no glitch) and turning times (s) of the simulated decay."""
    from escfit.balance.synthetic.instruments import record_timeseries

    scene = escfit.load_scene("truth.toml", text=(
        f'model = "balance"\n[oscillator]\nomega0 = {OMEGA0!r}\ntheta0 = 0.5\n[run]\nswings = 200\n'
        f"[effects.viscous]\nC = {TRUTH['viscous.C']}\n[effects.coulomb]\nR = {TRUTH['coulomb.R']}\n"))
    ts = record_timeseries(scene, rate_hz=50.0, duration=40.0, sigma=0.002, seed=1)
    turns = np.asarray(escfit.simulate(scene).time, float)
    return ts.time, ts.theta.copy(), np.r_[0.0, turns[turns < 40.0]]


def _glitched(tmp_path, *, clock0: float = 0.0, name: str = "bump.csv") -> tuple[Path, np.ndarray]:
    """The record with its sensor glitch, written as a user's table; and the true turning times (s)."""
    t, y, turns = _truth()
    k = int(np.argmin(np.abs(turns - GLITCH_NEAR)))
    outward = np.sign(np.interp(turns[k], t, y))
    y += outward * 0.03 * np.where(np.abs(t - turns[k]) < 0.3, 0.5 * (1 + np.cos(np.pi * (t - turns[k]) / 0.3)), 0.0)
    path = tmp_path / name
    rows = ["t (s),angle (rad)"] + [f"{clock0 + a:.6f},{b:.6f}" for a, b in zip(t, y)]
    path.write_text("\n".join(rows) + "\n")
    return path, turns


def _analysis(path, **recording):
    series = read_data(path, recording=recording or None)
    return reduce_series(series, strict=False, user_window=series.window), series


def _covers(res):
    s = res.summary()
    for name, truth in TRUTH.items():
        assert s[name]["lo95"] <= truth <= s[name]["hi95"], (name, truth, s[name])


def _cli(args, here):
    return CliRunner().invoke(cli, [*map(str, args)], catch_exceptions=False)


def test_the_glitch_is_no_push_and_the_users_start_moves_the_window(tmp_path):
    path, turns = _glitched(tmp_path)
    auto, _ = _analysis(path)
    assert auto.release_time < turns[1]  # the automatic choice: the whole record, the glitch no push
    assert not any("is not a free decay" in n for n in auto.notes), auto.notes
    tp, _ = _analysis(path, start="0.2 s")
    assert tp.release_time == pytest.approx(turns[1], abs=0.01)  # the first true turning point after 0.2 s
    np.testing.assert_allclose(tp.time[:60], turns[2:62], atol=0.01)  # none skipped, none spurious
    assert any(n.startswith("window set by [recording] start") for n in tp.notes), tp.notes


def test_release_snaps_to_the_turning_point_within_a_tenth_of_a_period_else_takes_the_next(tmp_path):
    path, turns = _glitched(tmp_path)
    near, _ = _analysis(path, release="1.04 s")  # 0.04 periods after the turn at 1.0 s
    assert near.release_time == pytest.approx(turns[2], abs=0.01)
    assert any("release set by [recording] release" in n and "released at rest at the turning point" in n
               for n in near.notes), near.notes
    mid, _ = _analysis(path, release="1.25 s")  # mid-swing: the next turning point, with a note
    assert mid.release_time == pytest.approx(turns[3], abs=0.01)
    assert any("is not at a turning point" in n for n in mid.notes), mid.notes


def test_release_after_a_hold_is_the_users_instant_at_the_held_angle():
    from escfit.analysis.recordings.timeseries import TimeSeries
    from escfit.analysis.recordings.window import RecordWindow

    t = np.arange(0.0, 30.0, 0.02)
    w, g = 2 * math.pi, 0.05
    tau = np.maximum(t - 2.0, 0.0)  # held at 0.4 rad until 2 s
    y = 0.4 * np.exp(-g * tau) * (np.cos(w * tau) + g / w * np.sin(w * tau))
    y += np.random.default_rng(3).normal(0.0, 1e-3, t.size)
    series = TimeSeries(t, y, source="held.csv", window=RecordWindow(0.0, release=2.0))
    tp = reduce_series(series, user_window=series.window)
    assert tp.release_time == 2.0 and tp.release_theta == pytest.approx(0.4, abs=3e-3)
    assert tp.time[0] == pytest.approx(2.5, abs=0.01)  # the first half swing after the release
    assert any("from the held" in n for n in tp.notes), tp.notes


def test_init_writes_the_window_and_a_fit_of_the_edited_scene_recovers_the_truth(tmp_path, monkeypatch):
    path, turns = _glitched(tmp_path)
    monkeypatch.chdir(tmp_path)
    result = _cli(["init", path, "--spring", "--out", "s.toml"], tmp_path)
    assert result.exit_code == 0, result.output
    text = (tmp_path / "s.toml").read_text()
    doc = tomllib.loads(text)
    assert "start" not in doc.get("recording", {})  # the whole record kept: the window only as comments
    assert "# start = " in text and "# stop = " in text  # the ends, as keys to edit
    # the user sets the start at 0.2 s and fits the edited scene
    edited = text.replace("# start = ", "start = ").replace("[recording]", "[recording]")
    assert "[recording]" in edited
    doc = tomllib.loads(edited.replace("# [recording]", "[recording]"))
    edited = edited.replace("# [recording]", "[recording]").replace(f'start = "{doc["recording"]["start"]}"', 'start = "0.2 s"')
    (tmp_path / "s.toml").write_text(edited.replace('model = "waveform"', 'model = "amplitude"'))
    result = _cli(["fit", path, "--scene", "s.toml", "--out", "s.h5", "--quiet"], tmp_path)
    assert result.exit_code == 0, result.output
    assert "window set by [recording] start" in result.output
    assert "78 turning points after the reference one at t = 0.5" in result.output.replace("\n", " ")
    _covers(load_fit(tmp_path / "s.h5"))


def test_the_command_line_release_recovers_the_truth_the_automatic_window_misses(tmp_path):
    path, turns = _glitched(tmp_path)
    scene = tmp_path / "fit.toml"
    scene.write_text(FIT_SCENE)
    res = fit(scene, str(path), n_starts=2, recording={"release": "0 s"})
    assert any("release set by [recording] release" in n for n in res.notes), res.notes
    _covers(res)


def test_an_epoch_clock_reads_start_after_the_first_sample_and_notes_speak_relative_times(tmp_path):
    path, turns = _glitched(tmp_path, clock0=EPOCH, name="epoch.csv")
    tp, series = _analysis(path, start="17 s")
    assert series.time[0] - EPOCH == pytest.approx(17.0, abs=0.02)  # 17 s after the first sample, not of the epoch
    k = int(np.searchsorted(turns, 17.0))
    assert tp.origin == EPOCH and tp.after_first(tp.release_time) == pytest.approx(turns[k], abs=0.01)
    notes = list(tp.notes)
    assert any("counted from the record's first sample" in n and "1407000000 s on the file's clock" in n
               for n in notes), notes
    assert not any("e+09" in n or "140700" in n for n in tp.notes[1:]), tp.notes  # relative times only
    # the file's own clock: an abs stamp, or a bare number inside the clock's range, means the same instant
    for given in ("abs 1407000017 s", 1407000017.0):
        again, _ = _analysis(path, start=given)
        assert again.release_time == pytest.approx(tp.release_time)
    with pytest.raises(DataError, match=r"\[recording\] start = 500 s lies beyond the record, which spans 0 to 39\.98 s "
                                        r"after its first sample; the file's clock reads 1407000000 to"):
        read_data(path, recording={"start": "500 s"})


def test_the_epoch_record_through_the_command_line(tmp_path):
    path, turns = _glitched(tmp_path, clock0=EPOCH, name="epoch.csv")
    scene = tmp_path / "fit.toml"
    scene.write_text(FIT_SCENE)
    result = _cli(["fit", path, "--scene", scene, "--start", "17 s", "--stop", "35 s", "--out", tmp_path / "e.h5",
                   "--quiet"], tmp_path)
    assert result.exit_code == 0, result.output
    out = result.output.replace("\n", " ")
    k = int(np.searchsorted(turns, 17.0))
    assert f"after the reference one at t = {turns[k]:.3g}" in out, out
    assert "e+09" not in out


def test_a_tracker_trk_takes_start_and_stop():
    whole = read_data(TRK)
    part = read_data(TRK, recording={"start": "2 s", "stop": "6 s"})
    assert part.time[0] >= 2.0 and part.time[-1] <= 6.0 and part.time.size == 120 < whole.time.size
    np.testing.assert_array_equal(part.theta[:5], whole.theta[(whole.time >= 2.0)][:5])  # the same angles, cut
    tp, _ = _analysis(TRK, start="2 s", stop="6 s")
    assert tp.release_time >= 2.0 and any("window set by [recording] start" in n for n in tp.notes)
    with pytest.raises(DataError, match=r"\[recording\] stop = 9 s lies beyond the record, which spans 0 to 7\.99959 s"):
        read_data(TRK, recording={"stop": "9 s"})


def test_window_keys_are_checked_in_one_line():
    from escfit.analysis.recordings.recording_spec import recording_spec_from_table
    from escfit.core.errors import SceneError

    spec = recording_spec_from_table({"start": "abs 1407000013 s", "release": "14 s", "stop": 60}, "s.toml")
    assert spec.start.absolute and spec.start.seconds == 1407000013.0 and not spec.release.absolute
    with pytest.raises(SceneError, match=r"s.toml \[recording\].stop: release \(20 s\) must come before stop"):
        recording_spec_from_table({"release": "20 s", "stop": "10 s"}, "s.toml")
    with pytest.raises(SceneError, match=r"\[recording\].start: expected a time"):
        recording_spec_from_table({"start": True}, "s.toml")


def test_starter_comments_hold_one_line_each():
    from escfit.balance.starter_text import _one_line

    assert _one_line("column 'a\r\nmodel = \"x\"'\x00") == "column 'a model = \"x\"' "


def _amplitude_table(tmp_path, rows: int, name="peaks.csv") -> Path:
    """One amplitude per half swing (deg, magnitudes) of the truth, with their times."""
    scene = escfit.load_scene("truth.toml", text=(
        f'model = "balance"\n[oscillator]\nomega0 = {OMEGA0!r}\ntheta0 = 0.5\n[run]\nswings = {rows}\n'
        f"[effects.viscous]\nC = {TRUTH['viscous.C']}\n[effects.coulomb]\nR = {TRUTH['coulomb.R']}\n"))
    tr = escfit.simulate(scene)
    t = np.r_[0.0, np.asarray(tr.time, float)][:rows]
    a = np.degrees(np.r_[0.5, np.asarray(tr.amplitude, float)])[:rows]
    path = tmp_path / name
    path.write_text("\n".join(["t (s),amplitude (deg)"] + [f"{x:.4f},{y:.4f}" for x, y in zip(t, a)]) + "\n")
    return path


def test_init_reads_an_amplitude_table_with_the_option_and_the_fit_finds_the_truth(tmp_path, monkeypatch):
    path = _amplitude_table(tmp_path, 40)
    monkeypatch.chdir(tmp_path)
    result = _cli(["init", path, "--spring", "--readings", "amplitudes", "--out", "a.toml"], tmp_path)
    assert result.exit_code == 0, result.output
    doc = tomllib.loads((tmp_path / "a.toml").read_text())
    assert doc["recording"]["readings"] == "amplitudes" and doc["observation"]["model"] == "amplitude"
    assert doc["oscillator"]["omega0"] == pytest.approx(OMEGA0, rel=1e-3)  # rows half a period apart
    _covers(fit(tmp_path / "a.toml", str(path), n_starts=2))


def test_init_tells_a_short_amplitude_table_from_samples(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = _amplitude_table(tmp_path, 12)
    # magnitudes of one sign, no zig-zag: a half swing each or the peaks a period apart, the rows
    # cannot say which, so init asks (a period twice too long would otherwise be a silent guess)
    asked = _cli(["init", path, "--spring", "--out", "b.toml"], tmp_path)
    assert asked.exit_code == 2 and "turning points of one sign" in asked.output, asked.output
    assert "--readings amplitudes" in asked.output and not (tmp_path / "b.toml").exists()
    result = _cli(["init", path, "--spring", "--readings", "amplitudes", "--out", "b.toml"], tmp_path)
    assert result.exit_code == 0, result.output
    assert tomllib.loads((tmp_path / "b.toml").read_text())["recording"]["readings"] == "amplitudes"
    wiggle = tmp_path / "wiggle.csv"  # too few rows, and no amplitudes either (signs and sizes at random)
    wiggle.write_text("t (s),angle (deg)\n" + "\n".join(f"{i * 0.1:.1f},{v:.2f}" for i, v in
                                                        enumerate([3, -1, 4, 1, -5, 9, 2, -6, 5, 3])) + "\n")
    refused = CliRunner().invoke(cli, ["init", str(wiggle), "--spring", "--out", "w.toml"])
    assert refused.exit_code == 2
    line = [s for s in refused.output.splitlines() if "only 10 samples" in s]
    assert line and 'give --readings amplitudes ([recording] readings = "amplitudes")' in line[0], refused.output
