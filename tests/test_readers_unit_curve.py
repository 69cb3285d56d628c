"""Unit-curve CSV reader: round trip and every refusal, naming file, line and column."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

import escfit
from escfit.cli.main import cli
from escfit.core.errors import DataError, FitError, SceneError
from escfit.balance.problems.curves import FitProblem
from escfit.balance.synthetic.unit_curves import record_unit_curve
from escfit.analysis.recordings import read_unit_curve, write_unit_curve

from .conftest import DATASETS

BAD = [
    ("empty.csv", "", "empty file"),
    ("comments_only.csv", "# notch_deg: 6\n# nothing else\n", "empty file"),
    ("header_only.csv", "swing,amplitude_rad\n", "header only"),
    ("no_amplitude.csv", "swing,time_s\n1,0.1\n", "amplitude column"),
    ("no_index.csv", "amplitude_rad\n1.0\n", "index column"),
    ("text.csv", "swing,amplitude_rad\n1,1.0\n2,abc\n", "text.csv:3 [amplitude_rad]: expected a number, got 'abc'"),
    ("nan.csv", "swing,amplitude_rad\n1,nan\n", "nan.csv:2 [amplitude_rad]: value 'nan' is not a finite"),
    ("negative.csv", "swing,amplitude_deg\n1,-3\n", "negative.csv:2 [amplitude_deg]: value '-3' must not be negative"),
    ("nonmono.csv", "swing,amplitude_rad\n2,1.0\n4,0.9\n4,0.8\n", "nonmono.csv:4 [swing]: swing index must increase"),
    ("fraction.csv", "swing,amplitude_rad\n1.5,1.0\n", "whole number"),
    ("unit.csv", "swing,amplitude_rad,load_furlongs\n1,1.0,3\n", "load unit 'furlongs' in column 'load_furlongs' is not"),
    ("unit2.csv", "swing,amplitude_rad,load_zorks\n1,1.0,3\n", "unknown load unit 'zorks'"),
    ("extra.csv", "swing,amplitude_rad,colour\n1,1.0,red\n", "unknown column(s) ['colour']"),
    ("fields.csv", "swing,amplitude_rad\n1,1.0,7\n", "fields.csv:2: expected 2 fields"),
    ("notches.csv", "swing,notches\n1,40\n", "notch angle"),
    ("notch_frac.csv", "# notch_deg: 6\nswing,notches\n1,40.5\n", "whole numbers"),
    ("binary.csv", b"\x89PNG\r\n\x1a\n\x00\x00", "a binary file, not a CSV table"),
    ("two_amp.csv", "swing,amplitude_rad,amplitude_deg\n1,1,57\n", "exactly one amplitude column"),
]


@pytest.mark.parametrize("name, content, fragment", BAD, ids=[b[0] for b in BAD])
def test_bad_unit_curve_files(tmp_path, name, content, fragment):
    path = tmp_path / name
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    with pytest.raises(DataError) as info:
        read_unit_curve(path)
    assert str(path) in str(info.value)
    assert fragment in str(info.value), str(info.value)


def test_cli_refuses_bad_data_with_exit_2_and_no_output(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("swing,amplitude_rad\n1,1.0\n2,oops\n")
    out = tmp_path / "fit.h5"
    r = CliRunner().invoke(cli, ["fit", str(bad), "--scene", str(DATASETS / "scenes" / "monday_unit_angle_fit.toml"),
                                 "--out", str(out)])
    assert r.exit_code == 2 and "bad.csv:3 [amplitude_rad]" in r.output
    assert not out.exists() and not list(tmp_path.glob("*.part"))


def test_missing_file():
    with pytest.raises(DataError, match="data file not found"):
        read_unit_curve("does/not/exist.csv")


def test_scene_data_mismatch(tmp_path):
    scene = escfit.load_scene(DATASETS / "scenes" / "monday_unit_angle_fit.toml")  # notch observation model
    path = tmp_path / "amp.csv"
    path.write_text("swing,amplitude_rad\n4,4.3\n8,3.5\n")
    with pytest.raises(SceneError, match="does not match the data"):
        FitProblem(scene, read_unit_curve(path))
    multi = tmp_path / "multi.csv"
    multi.write_text("# notch_deg: 6\nswing,notches,unit\n4,41,a\n4,40,b\n")
    with pytest.raises(FitError, match="several units"):
        FitProblem(scene, read_unit_curve(multi))


def test_round_trip_recovers_the_scene(tmp_path):
    scene = escfit.load_scene(DATASETS / "scenes" / "monday_unit_angle_fit.toml")
    curve = record_unit_curve(scene, every=4, duration=6.5, notch_deg=6, sigma=0.03, seed=7)
    path = tmp_path / "u.csv"
    write_unit_curve(path, curve, comments=["round trip"])
    back = read_unit_curve(path)
    np.testing.assert_array_equal(back.swing, curve.swing)
    np.testing.assert_array_equal(back.value, curve.value)
    assert back.kind == "notches" and back.notch == pytest.approx(np.radians(6))
    cycles = tmp_path / "cycles.csv"
    cycles.write_text("cycle,amplitude_deg\n1,300\n2,280\n")
    c = read_unit_curve(cycles)
    np.testing.assert_array_equal(c.swing, [2, 4])
    np.testing.assert_allclose(c.value, np.radians([300, 280]))
