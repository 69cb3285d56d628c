"""The plain summary says which part of the record its numbers come from when much was left out."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from click.testing import CliRunner

from escfit.cli.main import cli
from escfit.report.plain import window_sentences


def test_the_sentence_counts_time_from_the_record_s_first_sample():
    attrs = {"record_first_s": 100.0, "record_last_s": 125.8, "fit_first_s": 107.05, "fit_last_s": 117.3}
    assert window_sentences(attrs) == [
        "These numbers come from the part of the record from t = 7.05 to 17.3 s (40 % of its 25.8 s); the rest was "
        "left out, and the notes and warnings below say why."]


def test_a_window_the_scene_set_is_named_with_its_keys():
    """A window the scene's [recording] keys set (escfit init writes them where it left part of the
    record out, with its reasons as comments) is said to be theirs: the fit's own notes do not
    repeat the reasons."""
    attrs = {"record_first_s": 0.0, "record_last_s": 139.0, "fit_first_s": 95.3, "fit_last_s": 139.0,
             "window_keys": "start, release"}
    assert window_sentences(attrs) == [
        "These numbers come from the part of the record from t = 95.3 to 139 s (31 % of its 139 s); the scene's "
        "[recording] start and release left the rest out (the scene's comments say why)."]


def test_a_fit_of_most_of_the_record_or_without_a_record_says_nothing():
    assert window_sentences({"record_first_s": 0.0, "record_last_s": 10.0, "fit_first_s": 0.5, "fit_last_s": 9.0}) == []
    assert window_sentences({}) == []
    assert window_sentences({"record_first_s": 0.0, "record_last_s": 0.0, "fit_first_s": 0.0, "fit_last_s": 0.0}) == []


def test_a_record_pushed_twice_is_summarised_with_the_stretch_fitted(tmp_path, monkeypatch):
    """init and fit on a pendulum pushed twice: the summary's stretch is the fitted samples' span."""
    sys.path.insert(0, str(Path(__file__).parent))
    from artefacts.make import make
    from escfit.results import load_fit

    art = make("three_pushes", 3, periods=20)
    monkeypatch.chdir(tmp_path)
    Path("pushed.csv").write_text(art.csv)
    runner = CliRunner()
    assert runner.invoke(cli, ["init", "pushed.csv", "--pendulum"]).exit_code == 0
    fit = runner.invoke(cli, ["fit", "pushed.csv", "--scene", "pushed.toml", "--out", "f.h5"])
    assert fit.exit_code == 0, fit.output
    times = np.asarray(load_fit("f.h5").group("observed_data")["time"].values, float)
    record = np.loadtxt(art.csv.splitlines(), delimiter=",", skiprows=1)[:, 0]
    (a, b), = art.truth.all_windows()
    line = next(ln for ln in fit.output.splitlines() if ln.startswith("These numbers come from"))
    first, last = (float(w) for w in line.split("from t = ")[1].split(" s (")[0].split(" to "))
    # the stretch is the free decay between the pushes, and it covers the samples fitted
    assert first <= times.min() - record[0] + 1e-3 and last >= times.max() - record[0] - 1e-3
    assert abs(first - a) < 0.5 and abs(last - b) < 1.0
