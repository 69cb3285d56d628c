"""Raw recordings (text tables in many shapes, MATLAB files) read into a TimeSeries.

Each shape is written from a known damped cosine and must come back exactly; every refusal
must name the file and the line, column, variable or key, and the value or option to set.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from escfit.core.errors import DataError, SceneError
from escfit.analysis.recordings.rawseries import warnings_of, notes_of, read_raw_series
from escfit.analysis.recordings.recording_spec import (RecordingSpec, header_role, merge_spec, recording_spec_from_table,
                                              safe_unit_text)

from .conftest import SHARED

REAL = SHARED / "realdata"


def decay(n: int = 400, rate: float = 200.0) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) and a damped cosine (rad) sampled uniformly."""
    t = np.arange(n) / rate
    return t, 0.8 * np.exp(-0.3 * t) * np.cos(2 * math.pi * 1.7 * t)


def fmt(x: float) -> str:
    return f"{x:.17g}"


def table(t, a, sep=",", header=None, head="", decimal_comma=False) -> str:
    rows = [sep.join(fmt(v) for v in row) for row in zip(t, a)]
    if decimal_comma:
        rows = [r.replace(".", ",") for r in rows]
    return head + (sep.join(header) + "\n" if header else "") + "\n".join(rows) + "\n"


def write(tmp_path, name: str, text: str | bytes):
    p = tmp_path / name
    p.write_bytes(text if isinstance(text, bytes) else text.encode())
    return p


def refused(exc_type, path, spec=None, *parts: str) -> str:
    with pytest.raises(exc_type) as info:
        read_raw_series(path, spec)
    msg = str(info.value)
    assert "\n" not in msg
    for p in parts:
        assert p in msg, (p, msg)
    return msg


# --- text tables --------------------------------------------------------------------------------

def test_headerless_two_columns_whitespace(tmp_path):
    t, a = decay()
    ts = read_raw_series(write(tmp_path, "run.txt", table(t, a, sep="   ")))
    np.testing.assert_array_equal(ts.time, t)
    np.testing.assert_array_equal(ts.theta, a)
    assert ts.meta["source_format"] == "text table, whitespace-separated, no header"
    assert ts.meta["angle_unit"] == "rad" and "rad assumed" in notes_of(ts.meta)[0]
    assert len(ts.sha256) == 64 and ts.source.endswith("run.txt")


def test_titles_separator_comments_and_metadata(tmp_path):
    t, a = decay()
    head = ("Pendulum run 3, lab 2\nrecorded by the tracker\n# operator: ann\n% matlab comment\n"
            "// c comment\n# release_s: 0.25\n----------------\n\n")
    ts = read_raw_series(write(tmp_path, "run.csv", table(t, a, header=["t (s)", "theta (deg)"], head=head)))
    np.testing.assert_array_equal(ts.time, t)
    np.testing.assert_allclose(ts.theta, np.radians(a), rtol=1e-15)
    assert ts.meta["title"] == "Pendulum run 3, lab 2 / recorded by the tracker"
    assert ts.meta["operator"] == "ann" and ts.release_s == 0.25
    assert ts.meta["source_format"] == "text table, comma-separated, header on line 9"
    assert ts.meta["angle_column"] == "theta (deg) (column 2)" and ts.meta["angle_unit"] == "deg"


def test_title_block_over_dashes_and_underlined_header(tmp_path):
    t, a = decay()
    ts = read_raw_series(write(tmp_path, "a.txt", table(t, a, sep=" ", head="Free decay\n============\n")))
    assert ts.meta["title"] == "Free decay" and ts.meta["source_format"].endswith("no header")
    head = "Time (s)   Angle (deg)\n--------   -----------\n"
    ts = read_raw_series(write(tmp_path, "b.txt", table(t, a, sep="   ", head=head)))
    np.testing.assert_allclose(ts.theta, np.radians(a), rtol=1e-15)
    assert ts.meta["source_format"] == "text table, whitespace-separated, header on line 1"
    # a title straight above the numbers cannot be told from a header: refused, not guessed
    refused(DataError, write(tmp_path, "c.txt", table(t, a, sep=" ", head="My pendulum\n")), None,
            "c.txt:1", "no column looks like the angle in the header ['My', 'pendulum']")


def test_file_metadata_kept_beside_the_readers_keys(tmp_path):
    t, a = decay()
    ts = read_raw_series(write(tmp_path, "m.csv", table(t, a, header=["t_s", "theta_rad"],
                                                        head="# source_format: logger v2\n# rig: 7\n")))
    assert ts.meta["file_source_format"] == "logger v2" and ts.meta["rig"] == "7"
    assert ts.meta["source_format"].startswith("text table")
    refused(DataError, write(tmp_path, "m2.csv", table(t, a, header=["t_s", "theta_rad"], head="# release_s: soon\n")),
            None, "m2.csv:1 [release_s]", "'soon'")
    refused(DataError, write(tmp_path, "h.csv", table(t, a, header=["t_s", "theta_rad"])),
            RecordingSpec(angle_column=("a", "b")), "lists of columns are for .mat files")
    refused(DataError, write(tmp_path, "n.txt", table(t, a, sep=" ")), RecordingSpec(angle_column="theta"),
            "n.txt", "no header; give a 1-based position")


def test_hdf5_that_is_not_a_mat_file(tmp_path):
    h5py = pytest.importorskip("h5py")
    with h5py.File(tmp_path / "r.h5", "w") as f:
        f["x"] = np.arange(3.0)
    refused(DataError, tmp_path / "r.h5", None, "r.h5", "an HDF5 file, not a text table")
    refused(DataError, tmp_path / "missing.txt", None, "missing.txt", "not found")


@pytest.mark.parametrize("sep", [",", ";", "\t", "  "])
@pytest.mark.parametrize("names, t_factor, a_factor", [
    (["Time ( s )", "Position(deg)"], 1.0, math.pi / 180),
    (["t [s]", "angle [grad]"], 1.0, math.pi / 200),
    (["t_s", "angle_deg"], 1.0, math.pi / 180),
    (["time_s", "theta_rad"], 1.0, 1.0),
    (["t (ms)", "phi (arcmin)"], 1e-3, math.pi / 180 / 60),
    (["zeit / s", "winkel / turn"], 1.0, 2 * math.pi),
])
def test_header_units_and_delimiters(tmp_path, sep, names, t_factor, a_factor):
    t, a = decay()
    ts = read_raw_series(write(tmp_path, "run.txt", table(t, a, sep=sep, header=names)))
    np.testing.assert_allclose(ts.time, t * t_factor, rtol=1e-15, atol=0)
    np.testing.assert_allclose(ts.theta, a * a_factor, rtol=1e-15, atol=0)


def test_header_roles():
    assert header_role("Time ( s )") == ("time", "s")
    assert header_role("Position(deg)") == ("angle", "deg")
    assert header_role("t_ms") == ("time", "ms")
    assert header_role("theta1") == ("angle", None)
    assert header_role("counts") == ("angle", "counts")
    assert header_role("x_px") == (None, None)
    assert header_role("A_deg") == ("angle", "deg")


def test_semicolon_with_decimal_comma(tmp_path):
    t, a = decay()
    ts = read_raw_series(write(tmp_path, "de.csv", table(t, a, sep=";", header=["Zeit (s)", "Winkel (deg)"],
                                                         decimal_comma=True)))
    np.testing.assert_allclose(ts.time, t, rtol=1e-15)
    np.testing.assert_allclose(ts.theta, np.radians(a), rtol=1e-15)
    assert "decimal comma" in ts.meta["source_format"]


def test_tabs_with_three_decimals_after_a_comma(tmp_path):
    """A logger's export: a comma-separated title line, then tab-separated rows whose numbers
    carry a decimal comma and three decimals ("0,020"): as a grouped number "0,020" would be
    twenty (a thousands mark after a leading 0 groups nothing), which read every time and angle
    a thousand times too large."""
    t = np.arange(600) * 0.02
    a = 0.25 * np.exp(-0.05 * t) * np.cos(2 * math.pi * t / 1.03)
    rows = "\n".join(f"{x:.3f}\t0.000\t{y:.3f}".replace(".", ",") for x, y in zip(t, a))
    p = write(tmp_path, "torsione.csv", "--- Pendolo di torsione ---\nTempo,Forzante,Pendolo\n" + rows + "\n")
    ts = read_raw_series(p, RecordingSpec.from_options(angle_column="Pendolo", angle_unit="rad"))
    np.testing.assert_allclose(ts.time, t, atol=1e-12)
    np.testing.assert_allclose(ts.theta, np.round(a, 3), atol=1e-12)
    assert "decimal comma" in ts.meta["source_format"]


def test_grouped_thousands_with_a_decimal_point_still_read():
    from escfit.core.tabletext import parse_number

    assert parse_number("12,345") == 12345.0 and parse_number("1,234.5") == 1234.5
    assert parse_number("-1 234 567.25") == -1234567.25
    assert parse_number("0,020") is None and parse_number("-0,001") is None  # a decimal comma's, not a grouping
    assert parse_number("0,020", decimal_comma=True) == 0.02


def test_one_column_with_sample_rate(tmp_path):
    t, a = decay(rate=500.0)
    p = write(tmp_path, "one.txt", "\n".join(map(fmt, a)) + "\n")
    ts = read_raw_series(p, RecordingSpec.from_options(sample_rate="500 Hz", angle_unit="deg"))
    np.testing.assert_allclose(ts.time, t, rtol=1e-15)
    np.testing.assert_allclose(ts.theta, np.radians(a), rtol=1e-15)
    assert ts.meta["time_column"] == "row number / 500 Hz"
    refused(DataError, p, None, "one.txt:1", "sample_rate")


@pytest.mark.parametrize("head, rate, factor", [("rate,units\n500,deg\n", 500.0, math.pi / 180),
                                                ("sample_rate\n1000\n", 1000.0, 1.0),
                                                ("dt;unit\n2 ms;rad\n", 500.0, 1.0)])
def test_metadata_header_over_one_column(tmp_path, head, rate, factor):
    t, a = decay(rate=rate)
    ts = read_raw_series(write(tmp_path, "m.csv", head + "\n".join(map(fmt, a)) + "\n"))
    np.testing.assert_allclose(ts.time, t, rtol=1e-12)
    np.testing.assert_allclose(ts.theta, a * factor, rtol=1e-15)
    assert "metadata header on lines 1-2" in ts.meta["source_format"]
    # the options win over the file's metadata
    ts = read_raw_series(write(tmp_path, "m.csv", head + "\n".join(map(fmt, a)) + "\n"),
                         RecordingSpec(sample_rate=2 * rate, angle_unit="rad"))
    np.testing.assert_allclose(ts.time, t / 2, rtol=1e-12)
    np.testing.assert_array_equal(ts.theta, a)


def test_three_columns_without_header(tmp_path):
    t, a = decay()
    body = "\n".join(f"{fmt(x)} {fmt(y)} 0.5" for x, y in zip(t, a)) + "\n"
    p = write(tmp_path, "lab.txt", body)
    refused(DataError, p, None, "lab.txt:1", "3 columns and no header", "angle_column")
    ts = read_raw_series(p, RecordingSpec(angle_column=2))
    np.testing.assert_array_equal(ts.time, t)
    np.testing.assert_array_equal(ts.theta, a)
    refused(DataError, p, RecordingSpec(angle_column=1), "lab.txt:1", "no clock for angle column 1", "sample_rate")
    swapped = write(tmp_path, "swapped.txt", table(a, t, sep=" "))
    ts = read_raw_series(swapped, RecordingSpec(angle_column=1))  # two columns: the other one is the time
    np.testing.assert_array_equal(ts.time, t)


def test_three_columns_constant_time_column_is_refused(tmp_path):
    t, a = decay()
    p = write(tmp_path, "lab.txt", "\n".join(f"{fmt(x)} {fmt(y)} 0.5" for x, y in zip(t, a)) + "\n")
    refused(DataError, p, RecordingSpec(angle_column=2, time_column=3), "lab.txt:2 [column 3]", "repeats")


@pytest.mark.parametrize("header, message", [
    (["t", "theta", "phi"], "several columns could be the angle"),
    (["a", "b"], "no column looks like the angle"),
    (["t", "x_px", "angle_deg", "time"], "several columns could be the time"),
])
def test_ambiguous_or_unknown_header_is_refused(tmp_path, header, message):
    t, a = decay()
    rows = "\n".join(",".join([fmt(x), fmt(y), fmt(y), fmt(x)][:len(header)]) for x, y in zip(t, a))
    p = write(tmp_path, "h.csv", ",".join(header) + "\n" + rows + "\n")
    msg = refused(DataError, p, None, "h.csv:1", message, str(header))
    assert "time_column" in msg or "angle_column" in msg


def test_named_columns_and_positions(tmp_path):
    t, a = decay()
    rows = "\n".join(f"{i},{fmt(x)},{fmt(y)},{fmt(-y)}" for i, (x, y) in enumerate(zip(t, a)))
    p = write(tmp_path, "n.csv", "frame,t_s,left_deg,right_deg\n" + rows + "\n")
    ts = read_raw_series(p, RecordingSpec(angle_column="right_deg"))
    np.testing.assert_allclose(ts.theta, -np.radians(a), rtol=1e-15)
    ts = read_raw_series(p, merge_spec(None, angle_column="3", time_column="t_s"))
    np.testing.assert_allclose(ts.theta, np.radians(a), rtol=1e-15)
    refused(DataError, p, RecordingSpec(angle_column="middle"), "n.csv:1", "'middle'", "no column of that name")
    refused(DataError, p, RecordingSpec(angle_column=7), "n.csv", "angle_column = 7", "4 columns")


def test_text_and_nonfinite_values_name_line_and_column(tmp_path):
    t, a = decay()
    lines = table(t, a, header=["t_s", "theta_rad"]).splitlines()
    lines[30] = "0.145,abc"
    refused(DataError, write(tmp_path, "bad.csv", "\n".join(lines) + "\n"), None,
            "bad.csv:31 [theta_rad]", "expected a number, got 'abc'")
    lines[30] = "0.145,inf"
    refused(DataError, write(tmp_path, "bad.csv", "\n".join(lines) + "\n"), None,
            "bad.csv:31 [theta_rad]", "'inf' is not a finite number")
    lines = table(t, a).splitlines()
    lines[1] = "0.005,x1"  # a bad value in the second row still reads as data, not as a header
    refused(DataError, write(tmp_path, "bad2.csv", "\n".join(lines) + "\n"), None,
            "bad2.csv:2 [column 2]", "expected a number, got 'x1'")


@pytest.mark.parametrize("content, message", [
    (b"", "empty file"),
    (b"  \n\n", "empty file"),
    (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", "binary"),
    (b'{"time": [0, 1], "theta": [1, 0]}', "JSON"),
    (b"# only a comment\n", "only comments"),
    (b"hello world\nthis is prose\n", "cannot find a table of numbers"),
])
def test_files_that_are_not_tables(tmp_path, content, message):
    refused(DataError, write(tmp_path, "x.txt", content), None, "x.txt", message)


def test_truncated_last_row_is_dropped_elsewhere_refused(tmp_path):
    t, a = decay()
    text = table(t, a, header=["t_s", "theta_rad"])
    ts = read_raw_series(write(tmp_path, "cut.csv", text + "2.0\n"))
    np.testing.assert_array_equal(ts.time, t)
    assert "the last row (line 402) has 1 of 2 fields and was dropped as truncated" in notes_of(ts.meta)
    lines = text.splitlines()
    lines[10] = "0.045"
    refused(DataError, write(tmp_path, "cut2.csv", "\n".join(lines) + "\n"), None,
            "cut2.csv:11", "expected 2 fields (t_s, theta_rad), found 1")


# --- time stamps -------------------------------------------------------------------------------

def test_burst_stamps_are_retimed_by_a_line(tmp_path):
    rate, burst = 200.0, 13
    t, a = decay(n=1300, rate=rate)
    stamps = t[(np.arange(t.size) // burst) * burst]
    ts = read_raw_series(write(tmp_path, "burst.csv", table(stamps, a, header=["time_s", "theta_rad"])))
    fitted = 1.0 / np.mean(np.diff(ts.time))
    assert fitted == pytest.approx(rate, rel=1e-3)
    np.testing.assert_allclose(np.diff(ts.time), 1 / rate, rtol=1e-3)
    # every row re-timed: more than 5 % of the rows, so a warning rather than a note
    warning = warnings_of(ts.meta)[0]
    assert warning.startswith("time stamps repeat in bursts of ~13 rows: all 1300 rows re-timed by a straight line")
    assert float(re.search(r"([\d.]+) Hz", warning).group(1)) == pytest.approx(rate, rel=1e-3)


def test_a_row_out_of_order_and_a_repeated_stamp_are_repaired(tmp_path):
    """A row stamped before its predecessor is dropped; a stamp repeated on the next row (another
    reading) is re-timed between its neighbours; both are notes (one row of 400)."""
    t, a = decay()
    back = t.copy()
    back[50] = back[48]
    ts = read_raw_series(write(tmp_path, "back.csv", table(back, a, header=["t_s", "theta_rad"])))
    np.testing.assert_array_equal(ts.time, np.delete(t, 50))
    np.testing.assert_array_equal(ts.theta, np.delete(a, 50))
    assert "1 row(s) out of time order dropped (time going backwards for one row: the first stamped 0.24 s after " \
           "0.245 s)" in notes_of(ts.meta) and not warnings_of(ts.meta)
    dup = t.copy()
    dup[50] = dup[49]
    ts = read_raw_series(write(tmp_path, "dup.csv", table(dup, a, header=["t_s", "theta_rad"])))
    np.testing.assert_allclose(ts.time, t, rtol=0, atol=1e-12)  # the true times of rows 49 and 50
    assert any(n.startswith("2 row(s) sharing a stamp with a neighbour") for n in notes_of(ts.meta))


def test_a_clock_reset_is_refused_naming_sample_rate(tmp_path):
    t, a = decay()
    reset = t.copy()
    reset[200:] -= reset[200]  # the clock starts again from 0 at row 200
    msg = refused(DataError, write(tmp_path, "reset.csv", table(reset, a, header=["t_s", "theta_rad"])), None,
                  "reset.csv:202 [t_s]", "time goes backwards: 0.995 then 0.0 s",
                  "set [recording] sample_rate (or --sample-rate) to the logger's rate (about 200 Hz")
    assert msg.count("sample_rate") == 1


# --- angle units -------------------------------------------------------------------------------

def test_counts_and_volts(tmp_path):
    t, a = decay()
    counts = np.round(a / (2 * math.pi) * 40000)
    p = write(tmp_path, "enc.csv", table(t, counts, header=["t_s", "encoder (counts)"]))
    refused(DataError, p, None, "counts_per_turn")
    ts = read_raw_series(p, RecordingSpec(counts_per_turn=40000))
    np.testing.assert_allclose(ts.theta, counts * 2 * math.pi / 40000, rtol=1e-15)
    ts = read_raw_series(write(tmp_path, "raw.txt", table(t, counts, sep=" ")),
                         recording_spec_from_table({"angle_unit": "counts", "counts_per_turn": 40000}, "s.toml"))
    np.testing.assert_allclose(ts.theta, counts * 2 * math.pi / 40000, rtol=1e-15)
    assert ts.meta["angle_unit"] == "counts (40000 per turn)"
    volts = a / 0.5
    p = write(tmp_path, "volts.csv", table(t, volts, header=["t_s", "pos (V)"]))
    refused(DataError, p, None, "volts.csv:1 [pos (V)]", "column 'pos (V)': 'V' is not an angle unit; "
            "set [recording] angle_unit and scale")
    ts = read_raw_series(p, RecordingSpec(angle_unit="deg", scale=0.5))
    np.testing.assert_allclose(ts.theta, np.radians(a), rtol=1e-15)
    assert ts.meta["scale"] == "0.5" and "labelled 'V'" in ts.meta["notes"]


def test_non_angle_header_unit(tmp_path):
    t, a = decay()
    refused(DataError, write(tmp_path, "mm.csv", table(t, a, header=["t_s", "pos (mm)"])), None,
            "mm.csv:1 [pos (mm)]", "column 'pos (mm)': 'mm' is not an angle unit; set [recording] angle_unit and scale")
    refused(DataError, write(tmp_path, "tdeg.csv", table(t, a, header=["t (deg)", "theta_rad"])), None,
            "tdeg.csv:1 [t (deg)]", "'deg' is not a time unit")


def test_unit_grammar_refuses_arithmetic_quickly(tmp_path):
    assert safe_unit_text("deg") and safe_unit_text("m/s^2") and safe_unit_text("kg*m**2") and safe_unit_text("s**-1")
    for bad in ("9**9**9", "m**999", "2**-(3)", "x" * 41, "deg; import os", "__import__('os')", ""):
        assert not safe_unit_text(bad), bad
    with pytest.raises(SceneError, match=r"s.toml \[recording\].angle_unit"):
        recording_spec_from_table({"angle_unit": "9**9**9"}, "s.toml")
    with pytest.raises(SceneError, match=r"s.toml \[recording\].sample_rate"):
        recording_spec_from_table({"sample_rate": "1 Hz**9**9**9"}, "s.toml")
    t, a = decay()
    refused(DataError, write(tmp_path, "u.csv", table(t, a, header=["t_s", "theta (9**9**9)"])), None,
            "u.csv:1 [theta (9**9**9)]", "cannot read '9**9**9' as a unit")


# --- options -----------------------------------------------------------------------------------

def test_recording_table_is_validated():
    spec = recording_spec_from_table({"time_column": "t (s)", "angle_column": 2, "angle_unit": "deg", "scale": 2,
                                      "start": "13 s", "stop": "1 min"}, "scene.toml")
    assert spec == RecordingSpec("t (s)", None, 2, "deg", None, 2.0, 13.0, 60.0)
    assert recording_spec_from_table({"sample_rate": "2 kHz"}, "s.toml").sample_rate == 2000.0
    assert recording_spec_from_table({"sample_rate": 500}, "s.toml").sample_rate == 500.0
    assert recording_spec_from_table({"angle_column": ["Y_id[1]", "Y_vad[1]"]}, "s.toml").angle_column == \
        ("Y_id[1]", "Y_vad[1]")


@pytest.mark.parametrize("table, key, message", [
    ({"angle_colum": 2}, "angle_colum", "known: time_column, sample_rate, angle_column"),
    ({"time_column": 1, "sample_rate": 100}, "sample_rate", "not both"),
    ({"angle_unit": "mm"}, "angle_unit", "expected an angle unit"),
    ({"angle_unit": "counts"}, "angle_unit", "needs counts_per_turn"),
    ({"angle_unit": "deg", "counts_per_turn": 100}, "counts_per_turn", "goes with angle_unit = 'counts'"),
    ({"counts_per_turn": -4}, "counts_per_turn", "must be positive"),
    ({"sample_rate": "5 m"}, "sample_rate", "dimension"),
    ({"start": "2 s", "stop": "1 s"}, "stop", "must come before stop"),
    ({"scale": True}, "scale", "True"),
    ({"scale": 0}, "scale", "non-zero"),
    ({"angle_column": 0}, "angle_column", "count from 1"),
    ({"time_column": False}, "time_column", "False"),
])
def test_recording_table_refusals(table, key, message):
    with pytest.raises(SceneError) as info:
        recording_spec_from_table(table, "scene.toml")
    assert f"scene.toml [recording].{key}" in str(info.value) and message in str(info.value)


def test_command_line_overrides_key_by_key():
    scene = recording_spec_from_table({"time_column": "t", "angle_column": "theta", "angle_unit": "counts",
                                       "counts_per_turn": 4000}, "s.toml")
    merged = merge_spec(scene, sample_rate="250", angle_unit="deg")
    assert merged == RecordingSpec(None, 250.0, "theta", "deg", None, None, None, None)
    assert merge_spec(scene, angle_column="3").angle_column == 3
    assert merge_spec(scene, angle_column="Y_id[1],Y_vad[1]").angle_column == ("Y_id[1]", "Y_vad[1]")
    assert merge_spec(scene, start="2 s", stop=None) == RecordingSpec("t", None, "theta", "counts", 4000.0, None, 2.0)
    with pytest.raises(SceneError, match="command line --counts-per-turn.*must be positive"):
        merge_spec(scene, counts_per_turn="-3")
    with pytest.raises(SceneError, match="unknown option.*'rate'"):
        merge_spec(scene, rate="3")
    with pytest.raises(SceneError, match="command line --sample-rate: give time_column or sample_rate, not both"):
        RecordingSpec.from_options(time_column="1", sample_rate="3 Hz")


def test_window(tmp_path):
    t, a = decay()
    p = write(tmp_path, "w.csv", table(t, a, header=["t_s", "theta_rad"]))
    ts = read_raw_series(p, RecordingSpec(start=0.5, stop=1.0))
    np.testing.assert_array_equal(ts.time, t[(t >= 0.5) & (t <= 1.0)])
    assert ts.meta["window"] == "0.5 s <= t <= 1 s"
    refused(DataError, p, RecordingSpec(start=0.5, stop=0.55), "w.csv [recording].start/stop", "keeps 11 of 400")
    refused(DataError, p, RecordingSpec(start=5.0), "w.csv [recording].start",
            "start = 5 s lies beyond the record, which spans 0 to 1.995 s after its first sample")
    late = write(tmp_path, "late.csv", table(t + 100.0, a, header=["t_s", "theta_rad"]))  # a clock not at 0
    ts = read_raw_series(late, RecordingSpec(start=0.5, stop=1.0))  # after the first sample
    np.testing.assert_array_equal(ts.time, t[(t >= 0.5) & (t <= 1.0)] + 100.0)
    ts = read_raw_series(late, RecordingSpec.from_options(start="abs 100.5 s", stop="101 s"))  # the file's clock
    np.testing.assert_array_equal(ts.time, t[(t >= 0.5) & (t <= 1.0)] + 100.0)


# --- MATLAB files ------------------------------------------------------------------------------

def _cells(pieces):
    out = np.empty(len(pieces), dtype=object)
    for i, p in enumerate(pieces):
        out[i] = p
    return out


@pytest.fixture
def matfiles(tmp_path):
    from scipy.io import savemat

    t, a = decay(n=600)
    sim = {name: {"time": t, "signals": {"values": v, "dimensions": 1}, "blockName": name}
           for name, v in (("Theta1", a), ("Velocity", np.zeros_like(a)), ("Distance", np.zeros_like(a)))}
    savemat(tmp_path / "sim.mat", sim)
    savemat(tmp_path / "plain.mat", {"t": t, "theta": np.degrees(a), "other": a[::-1].copy()})
    cut = [0, 150, 300, 420, 600]
    y = [np.vstack([a[i:j], -a[i:j]]) for i, j in zip(cut, cut[1:])]
    tt = [t[i:j] for i, j in zip(cut, cut[1:])]
    savemat(tmp_path / "cells.mat", {"Y_id": _cells(y[:2]), "Time_id": _cells(tt[:2]), "Y_vad": _cells(y[2:]),
                                     "Time_vad": _cells(tt[2:]), "dt": 1 / 200})
    return tmp_path, t, a


def test_mat_simulink_structures(matfiles):
    d, t, a = matfiles
    ts = read_raw_series(d / "sim.mat", RecordingSpec(angle_column="Theta1"))
    np.testing.assert_array_equal(ts.time, t)
    np.testing.assert_array_equal(ts.theta, a)
    assert ts.meta["time_column"] == "Theta1.time" and ts.meta["source_format"] == "MATLAB v5 .mat"
    ts = read_raw_series(d / "sim.mat")
    np.testing.assert_array_equal(ts.theta, a)
    assert "the only varying signal of Theta1, Velocity, Distance" in ts.meta["notes"]
    refused(DataError, d / "sim.mat", RecordingSpec(angle_column="Theta"), "sim.mat [Theta]", "no variable 'Theta'",
            "Theta1 (Simulink structure with time)")
    refused(DataError, d / "sim.mat", RecordingSpec(angle_column="Theta1.signals.label"), "[Theta1.signals.label]",
            "no field 'label'")


def test_mat_several_varying_candidates_are_refused(tmp_path):
    from scipy.io import savemat

    t, a = decay()
    savemat(tmp_path / "two.mat", {name: {"time": t, "signals": {"values": v}} for name, v in (("A", a), ("B", -a))})
    refused(DataError, tmp_path / "two.mat", None, "two.mat", "several variables could be the angle: A, B",
            "angle_column")


def test_mat_plain_variables(matfiles):
    d, t, a = matfiles
    ts = read_raw_series(d / "plain.mat", RecordingSpec(angle_column="theta", time_column="t", angle_unit="deg"))
    np.testing.assert_array_equal(ts.time, t)
    np.testing.assert_allclose(ts.theta, a, rtol=1e-14)
    ts = read_raw_series(d / "plain.mat", RecordingSpec(angle_column="theta", angle_unit="deg"))
    np.testing.assert_array_equal(ts.time, t)  # the vector named t
    refused(DataError, d / "plain.mat", None, "plain.mat", "several variables could be the angle: theta, other")
    refused(DataError, d / "plain.mat", RecordingSpec(angle_column=2), "plain.mat", "names variables")


def test_mat_cell_pieces_joined(matfiles):
    d, t, a = matfiles
    spec = recording_spec_from_table({"angle_column": ["Y_id[1]", "Y_vad[1]"], "time_column": ["Time_id", "Time_vad"]},
                                     "s.toml")
    ts = read_raw_series(d / "cells.mat", spec)
    np.testing.assert_array_equal(ts.time, t)
    np.testing.assert_array_equal(ts.theta, a)
    assert "angle joined from 4 pieces" in ts.meta["notes"]
    ts = read_raw_series(d / "cells.mat", RecordingSpec(angle_column=("Y_id[2]", "Y_vad[2]")))  # clock: dt
    np.testing.assert_allclose(ts.time, t, atol=1e-12)
    np.testing.assert_array_equal(ts.theta, -a)
    refused(DataError, d / "cells.mat", RecordingSpec(angle_column=("Y_vad[1]", "Y_id[1]"),
                                                      time_column=("Time_vad", "Time_id")),
            "cells.mat [Time_id piece 1, sample 1]", "time goes backwards")
    refused(DataError, d / "cells.mat", RecordingSpec(angle_column="Y_id[3]"), "[Y_id[3] piece 1]", "2 signals")
    refused(DataError, d / "cells.mat", RecordingSpec(angle_column="Y_id"), "[Y_id piece 1]", "select one signal")
    refused(DataError, d / "cells.mat", RecordingSpec(angle_column=("Y_id[1]", "Y_vad[1]"), time_column="Time_id"),
            "cells.mat", "the time (Time_id) has 300 samples but the angle (Y_id[1], Y_vad[1]) has 600")


def test_mat_v73_hdf5(tmp_path):
    h5py = pytest.importorskip("h5py")
    t, a = decay()
    path = tmp_path / "v73.mat"
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, v in (("t", t), ("theta", a)):
            ds = f.create_dataset(name, data=v[None, :])  # MATLAB stores an N x 1 column as 1 x N
            ds.attrs["MATLAB_class"] = np.bytes_("double")
    with open(path, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, Platform: test".ljust(116) + b"\x00" * 8 + b"\x00\x02IM")
    ts = read_raw_series(path, RecordingSpec(angle_column="theta", time_column="t"))
    np.testing.assert_array_equal(ts.time, t)
    np.testing.assert_array_equal(ts.theta, a)
    assert ts.meta["source_format"] == "MATLAB v7.3 .mat (HDF5)"


def test_mat_garbage(tmp_path):
    refused(DataError, write(tmp_path, "junk.mat", b"not a mat file at all" * 10), None, "junk.mat",
            "cannot read as a MATLAB file")


# --- real recordings ---------------------------------------------------------------------------

needs_real = pytest.mark.skipif(not REAL.is_dir(), reason="shared real recordings not present")


@needs_real
def test_real_string_pendulum_lab1():
    path = REAL / "string_pendulum_video" / "lab1_data.txt"
    refused(DataError, path, None, "lab1_data.txt:1", "3 columns", "angle_column")
    ts = read_raw_series(path, RecordingSpec(angle_column=2))
    assert ts.time.size == 2330
    assert ts.theta[0] == pytest.approx(0.7020338666, abs=1e-10)
    assert ts.time[0] == 0.0 and ts.time[-1] == pytest.approx(116.40911111, abs=1e-8)


@needs_real
def test_real_string_pendulum_trial1():
    ts = read_raw_series(REAL / "string_pendulum_video" / "trial1_rawdata.txt")
    assert ts.time.size == 500 and 1 / np.mean(np.diff(ts.time)) == pytest.approx(29.6, rel=0.01)
    assert np.max(np.abs(ts.theta)) == pytest.approx(1.44, abs=0.02)


@needs_real
def test_real_tracker_frames():
    ts = read_raw_series(REAL / "pohl_heilaut" / "derived" / "tracker_video_frames.csv",
                         RecordingSpec(angle_column="angle_deg"))
    assert ts.time.size == 240 and ts.meta["time_column"] == "t_s (column 2)"
    assert ts.time[1] == pytest.approx(0.033471) and ts.theta[0] == pytest.approx(math.radians(-21.646))


@needs_real
def test_real_multiarm_free_swing():
    ts = read_raw_series(REAL / "multiarm_pendulum" / "SingleDataFreeSwing_1_Dt_0_0001.mat",
                         RecordingSpec(angle_column="Theta1"))
    assert ts.time.size == 231757
    np.testing.assert_allclose(np.diff(ts.time), 1e-4, atol=1e-9)
    assert np.median(ts.theta) == pytest.approx(math.pi, abs=0.1)


@needs_real
def test_real_multiarm_parameter_estimation_pieces():
    spec = RecordingSpec(angle_column=("Y_id[1]", "Y_vad[1]"), time_column=("Time_id", "Time_vad"))
    ts = read_raw_series(REAL / "multiarm_pendulum" / "SinglePendulumDataForParameterEstimation.mat", spec)
    assert ts.time.size == 55001 and ts.time[-1] == pytest.approx(55.0)
    np.testing.assert_allclose(np.diff(ts.time), 1e-3, atol=1e-9)
    assert np.max(ts.theta) - np.min(ts.theta) > 2.0
