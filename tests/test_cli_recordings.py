"""Every recorder format through the command line: simulate --recorder, fit, summary, report."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from escfit.cli.main import cli

from .conftest import DATASETS

REC = DATASETS / "recordings"
SCENE = REC / "pulses_scene.toml"  # each format's scene has the same truth: C = 0.6, R = 100, X = 1500
TRUTH = {"viscous.C": 0.6, "coulomb.R": 100.0, "escapement[2].X": 1500.0}


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.mark.parametrize("recorder, name, scene, noise", [
    ("unit-curve", "u.csv", "timeseries_scene.toml", "0.002"),  # amplitudes, the scene's amplitude observation
    ("pulses", "p.csv", "pulses_scene.toml", "1e-4"),
    ("timegrapher", "t.json", "timegrapher_scene.toml", None),
    ("timegrapher", "t.csv", "timegrapher_scene.toml", None),
    ("timeseries", "s.csv", "timeseries_scene.toml", "0.001"),
])
def test_record_fit_summary_round_trip(tmp_path, recorder, name, scene, noise):
    data = tmp_path / name
    r = run("simulate", REC / scene, "--recorder", recorder, "--out", data, "--seed", "11",
            *(["--noise", noise] if noise else []))
    assert r.exit_code == 0, r.output
    out = tmp_path / "fit.h5"
    r = run("fit", data, "--scene", REC / scene, "--out", out, "--seed", "1", "--quiet")
    assert r.exit_code == 0, r.output
    s = json.loads(run("summary", out, "--json").output)["parameters"]
    for key, truth in TRUTH.items():
        p = s[key]
        half = 0.5 * (p["hi95"] - p["lo95"])
        # the least-squares 95% interval holds the truth (4 half widths guards against an unlucky seed)
        assert p["estimate_kind"] == "best fit" and "median" not in p
        assert abs(p["estimate"] - truth) < 4 * half, (recorder, key, p)
        assert half < 0.2 * truth, (recorder, key, p)  # and the data actually constrain it
    rep = tmp_path / "fit.md"
    r = run("report", out, "--format", "md", "--out", rep)
    assert r.exit_code == 0, r.output
    assert "data and fit" in rep.read_text()


def test_format_option_overrides_detection_and_mismatch_is_one_line(tmp_path):
    data = tmp_path / "p.csv"
    assert run("simulate", SCENE, "--recorder", "pulses", "--out", data, "--swings", "10").exit_code == 0
    r = run("fit", data, "--scene", SCENE, "--format", "unit-curve", "--out", tmp_path / "f.h5")
    assert r.exit_code == 2 and str(data) in r.output
    assert not (tmp_path / "f.h5").exists()


def test_recorder_refuses_without_out_and_keeps_existing_files(tmp_path):
    r = run("simulate", SCENE, "--recorder", "pulses")
    assert r.exit_code == 2 and "--out" in r.output
    data = tmp_path / "p.csv"
    data.write_text("keep me\n")
    r = run("simulate", SCENE, "--recorder", "pulses", "--out", data)
    assert r.exit_code == 2 and data.read_text() == "keep me\n"
    r = run("simulate", SCENE, "--recorder", "timeseries", "--notch-deg", "6", "--out", tmp_path / "s.csv")
    assert r.exit_code == 2 and "unit-curve" in r.output
    r = run("simulate", DATASETS / "geneva" / "four_pin.toml", "--recorder", "pulses", "--out", tmp_path / "g.csv")
    assert r.exit_code == 2 and "geneva" in r.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.csv"]
