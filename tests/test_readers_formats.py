"""Instrument and program formats, each written here as its writer writes it (the writer's code or
a real file named in docs/recordings.md), read back and checked against the numbers written.

The signal is a known damped cosine; every reader must return it to the written precision, in SI
units, with the clock the format declares.
"""

from __future__ import annotations

import math
import zipfile

import numpy as np
import pytest

from escfit.core.errors import DataError, FitError, SceneError
from escfit.core.tabletext import cell_kind, numbered_lines, parse_number, time_seconds
from escfit.analysis.recordings.detect import candidates, detect_format, read_with_spec
from escfit.analysis.recordings.labfiles import write_cmbl
from escfit.analysis.recordings.phyphox import write_phyphox_csv, write_phyphox_zip
from escfit.analysis.recordings.rawseries import notes_of
from escfit.analysis.recordings.recording_spec import RecordingSpec, recording_spec_from_table
from escfit.analysis.recordings.tracker import arc_angle


def decay(n=600, rate=100.0, amp=0.8):
    t = np.arange(n) / rate
    return t, amp * np.exp(-0.2 * t) * np.cos(2 * math.pi * 1.3 * t)


def java_e(v: float, decimal: str = ".") -> str:
    """Java DecimalFormat("0.000000000E0") as phyphox's CsvFormat uses it."""
    m, e = f"{v:.9E}".split("E")
    return (f"{m}E{int(e)}").replace(".", decimal)


def write(tmp_path, name, data):
    p = tmp_path / name
    p.write_bytes(data if isinstance(data, bytes) else data.encode("utf-8"))
    return p


# -- the tokenizer ----------------------------------------------------------------------------------
@pytest.mark.parametrize("cell, dc, value", [
    ("1,234.5", False, 1234.5), ("1.234,5", True, 1234.5), ("1 234,5", True, 1234.5), ("1'234.5", False, 1234.5),
    ("-1.234567890E-1", False, -0.123456789), ("-1,234567890E-1", True, -0.123456789), ('"2.5"', False, 2.5),
    ("\u22123.5", False, -3.5), ("0,131", True, 0.131), ("12", False, 12.0)])
def test_numbers_as_programs_write_them(cell, dc, value):
    assert parse_number(cell, dc) == pytest.approx(value, rel=1e-12)


def test_cells_that_are_not_numbers():
    assert [cell_kind(c) for c in ("NaN", "", "---", "true", "16:04:31.273", "2024-05-03", "Masse A", "inf")] == \
        ["missing", "missing", "missing", "flag", "clock", "date", "text", "number"]
    assert time_seconds("16:04:31.273") == ("clock", pytest.approx(16 * 3600 + 4 * 60 + 31.273))
    # an ISO date-time with an offset is UTC seconds: 16:04 at +02:00 is 14:04 UTC
    assert time_seconds("2024-05-03T16:04:31+02:00")[1] - time_seconds("2024-05-03T14:04:31Z")[1] == 0.0
    assert numbered_lines("a\r\r\nb\r\nc\rd\ne\n") == [(1, "a"), (2, "b"), (3, "c"), (4, "d"), (5, "e")]


# -- generic tables ---------------------------------------------------------------------------------
def test_clock_time_column_beside_burst_stamps(tmp_path):
    """A logger's time of day, then elapsed seconds repeated in bursts of 10, then the angle."""
    t, a = decay(n=800, rate=100.0)
    origin = 16 * 3600 + 4 * 60 + 31.273
    rows = ["Time,Elapsed (s),Angle (deg)"]
    for ti, ai in zip(t, a):
        s = origin + ti
        clock = f"{int(s // 3600):02d}:{int(s // 60 % 60):02d}:{s % 60:06.3f}"
        rows.append(f"{clock},{math.floor(ti * 10) / 10:.1f},{math.degrees(ai):.6f}")
    p = write(tmp_path, "logger.csv", "\n".join(rows) + "\n")
    ts = read_with_spec(p, None)
    np.testing.assert_allclose(ts.time, t, atol=2e-6)  # the finer clock (times of day) is chosen, with a note
    np.testing.assert_allclose(ts.theta, a, atol=1e-7)
    assert any("most distinct stamps" in n for n in notes_of(ts.meta))
    ts2 = read_with_spec(p, RecordingSpec(time_column=2, angle_column=3))  # the user's choice: bursts re-timed
    assert ts2.time.size == 800 and abs(np.median(np.diff(ts2.time)) - 0.01) < 2e-4


def test_utf16_semicolon_decimal_comma_thousands_and_crcrlf(tmp_path):
    t, a = decay(n=300)
    body = "Zeit (s);Winkel (urad)\r\r\n" + "".join(f"{ti:.2f};{ai * 1e6:,.3f}\r\r\n".replace(",", " ")
                                                    .replace(".", ",") for ti, ai in zip(t, a))
    p = write(tmp_path, "u16.txt", body.encode("utf-16"))
    assert "800 000,000" in body
    ts = read_with_spec(p, None)
    np.testing.assert_allclose(ts.theta, a, atol=1e-9)
    np.testing.assert_allclose(ts.time, t, atol=1e-12)


def test_nan_rows_dropped_with_a_note_infinity_refused(tmp_path):
    t, a = decay(n=200)
    rows = ["t_s,theta_rad"] + [f"{ti},{'NaN' if i in (50, 51) else ai}" for i, (ti, ai) in enumerate(zip(t, a))]
    ts = read_with_spec(write(tmp_path, "gaps.csv", "\n".join(rows) + "\n"), RecordingSpec(format="raw"))
    assert ts.time.size == 198 and "2 row(s) without a reading" in ts.meta["notes"]
    rows[60] = "0.59,inf"
    with pytest.raises(DataError, match=r"inf.csv:61 \[theta_rad\]: value 'inf' is not a finite number"):
        read_with_spec(write(tmp_path, "inf.csv", "\n".join(rows) + "\n"), RecordingSpec(format="raw"))


def test_picoscope_units_row_and_blank_line(tmp_path):
    t, a = decay(n=400, rate=10000.0)
    text = "Time,Channel A\n(ms),(V)\n\n" + "".join(f"{1e3 * ti:.8f},{ai:.8f}\n" for ti, ai in zip(t, a))
    p = write(tmp_path, "pico.csv", text)
    with pytest.raises(DataError, match=r"'Channel A \(V\)'\]; set \[recording\] angle_column .* sensor's volts"):
        read_with_spec(p, None)
    ts = read_with_spec(p, RecordingSpec(angle_column="Channel A", angle_unit="rad", scale=0.5))
    np.testing.assert_allclose(ts.time, t, atol=1e-11)  # ms from the units row
    np.testing.assert_allclose(ts.theta, 0.5 * a, atol=1e-8)
    assert "row of units" in ts.meta["source_format"]


def test_volts_given_as_the_angle_unit_say_what_scale_is_for():
    """``angle_unit = "V"`` (the column's own unit) is refused with what the two keys hold."""
    from escfit.analysis.recordings.recording_spec import recording_spec_from_table
    from escfit.core.errors import SceneError

    with pytest.raises(SceneError, match=r"got 'V': a column in volts keeps its angle_unit for the angle \(deg or "
                                         r"rad\) and takes scale, the angle per volt"):
        recording_spec_from_table({"angle_column": "Channel A", "angle_unit": "V"}, "s.toml")


# -- phyphox ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("sep, dec", [(",", "."), ("\t", "."), (";", "."), ("\t", ","), (";", ",")])
def test_phyphox_csv_variants(tmp_path, sep, dec):
    t, w = decay(n=500)
    text = write_phyphox_csv({"Time (s)": list(t), "Gyroscope x (rad/s)": list(w), "Gyroscope y (rad/s)": list(w[:-7])},
                             separator=sep, decimal=dec)
    assert java_e(-0.123456789, dec) in write_phyphox_csv({"a": [-0.123456789]}, decimal=dec)
    p = write(tmp_path, "gyro.csv", text)
    assert detect_format(p) == "phyphox"
    # two identical rates: neither is the free decay more than the other, so none is named for the user
    with pytest.raises(DataError, match="look like angular velocity, and none is clearly the free decay: .*set "
                                        "\\[recording\\] velocity_column"):
        read_with_spec(p, None)
    ts = read_with_spec(p, RecordingSpec(velocity_column="Gyroscope y (rad/s)"))
    assert ts.quantity == "angular_velocity" and ts.unit == "rad/s" and ts.time.size == 493  # NaN padding dropped
    np.testing.assert_allclose(ts.theta, w[:-7], rtol=1e-9, atol=1e-12)
    assert "at the end (a shorter column padded)" in ts.meta["notes"]


def test_phyphox_zip_with_meta_and_a_pause(tmp_path):
    t, w = decay(n=500)
    p = tmp_path / "run.zip"
    write_phyphox_zip(p, {"Raw Data": {"Time (s)": list(t), "Rotation z (rad/s)": list(w)},
                          "Result History": {"Period (s)": [0.77], "Frequency (Hz)": [1.3]}},
                      time_events=[("START", 0.0, 1.7e9, "2024-05-03 16:04:31.273 UTC+02:00"),
                                   ("PAUSE", 2.5, 1.7e9 + 2.5, "x"), ("START", 2.5, 1.7e9 + 9.0, "y"),
                                   ("PAUSE", 6.0, 1.7e9 + 12.5, "z")])
    assert detect_format(p) == "phyphox"
    ts = read_with_spec(p, RecordingSpec(velocity_column="Rotation z (rad/s)"))
    np.testing.assert_allclose(ts.theta, w, rtol=1e-9, atol=1e-12)
    assert ts.meta["phyphox_set"] == "Raw Data" and ts.meta["start_time"].startswith("2024-05-03 16:04:31.273")
    assert "paused and resumed 1 time(s) (t = 2.5 s" in ts.meta["notes"]


def test_xlsx_is_refused_with_what_to_do(tmp_path):
    p = tmp_path / "run.xlsx"
    with zipfile.ZipFile(p, "w") as zf:
        zf.writestr("[Content_Types].xml", "<Types/>")
    with pytest.raises(DataError, match=r"Excel workbook \(.xlsx\): export it as CSV"):
        read_with_spec(p, None)


# -- CASSY ---------------------------------------------------------------------------------------------
def _labx(t, phi, runs=1) -> bytes:
    def channel(q, s, u, v):
        vals = "".join("<value />" if x != x else f"<value>{float(x)!r}</value>" for x in v)
        return f"<channel><quantity>{q}</quantity><symbol>{s}</symbol><unit>{u}</unit><values count=\"{len(v)}\">{vals}" \
               "</values></channel>"

    groups = [("Zeit", "t", "s", t), ("Frequenz", "f", "Hz", t[:10]), ("Winkel", "phi", "", phi),
              ("omega", "v", "1/s", np.r_[np.nan, np.diff(phi) / np.diff(t)])]
    body = "".join(f'<channels count="{runs}">' + "".join(channel(q, s, u, v * (k + 1) if q == "Winkel" else v)
                                                          for k in range(runs)) + "</channels>" for q, s, u, v in groups)
    return ('\ufeff<?xml version="1.0" encoding="utf-8"?><cassylab xml:lang="de-DE"><allchannels count="4">'
            f"{body}</allchannels></cassylab>").encode("utf-8")


def test_cassy_labx_runs_and_unitless_angle(tmp_path):
    t, a = decay(n=300)
    p = write(tmp_path, "d.labx", _labx(t, a, runs=2))
    assert detect_format(p) == "cassy"
    ts = read_with_spec(p, None)
    np.testing.assert_allclose(ts.theta, a, rtol=1e-15)
    assert "read as rad" in ts.meta["notes"] and "Frequenz" in ts.meta["notes"]
    np.testing.assert_allclose(read_with_spec(p, RecordingSpec(run=2)).theta, 2 * a, rtol=1e-15)
    with pytest.raises(DataError, match="run = 3, but channel 'Zeit' has 2 run"):
        read_with_spec(p, RecordingSpec(run=3))
    v = read_with_spec(p, RecordingSpec(velocity_column="omega"))  # the derivative's empty first value dropped
    assert v.quantity == "angular_velocity" and v.time.size == 299


def test_cassy_text_export(tmp_path):
    t, a = decay(n=300)
    head = "MIN=0\t-1\t-5\r\r\nMAX=30\t1\t5\r\r\nSCALE=30\t0,5\t5\r\r\nDEC=1\t3\t4\r\r\n"
    head += 'DEF="Zeit" t / s\t"winkel" w / rad\t"Spannung" U_B1 / V\r\r\n'
    rows = "".join(f"{ti:.4f}\t{float(ai)!r}\t{0.5 * math.sin(ti):.3f}\r\r\n".replace(".", ",") for ti, ai in zip(t, a))
    p = write(tmp_path, "c.txt", "\ufeff" + head + rows)
    assert candidates(p) == ["cassy-text"]
    ts = read_with_spec(p, None)
    np.testing.assert_allclose(ts.theta, a, rtol=1e-14)
    assert "DEF= header on line 5" in ts.meta["source_format"] and ts.meta["cassy_max"] == "30 | 1 | 5"


# -- LabVIEW -----------------------------------------------------------------------------------------
def test_lvm_declared_clock_decimal_comma_and_sample_count(tmp_path):
    t, a = decay(n=400, rate=256.0)
    head = ("LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\nDecimal_Separator\t,\n"
            "Multi_Headings\tYes\nX_Columns\tNo\nTime_Pref\tAbsolute\nOperator\tJS\nDate\t2013/02/19\n"
            "Time\t09:51:39,19\n***End_of_Header***\t\n\t\nChannels\t2\t\t\nSamples\t200\t200\t\n"
            "Y_Unit_Label\tDeg\tV\t\nX_Dimension\tTime\tTime\t\nX0\t1,0000000000000000E+0\t1,0E+0\t\n"
            "Delta_X\t3,906250E-3\t3,906250E-3\t\n***End_of_Header***\t\t\t\nX_Value\tAngle\tDrive\tComment\n")
    rows = "".join(f"\t{math.degrees(ai):.6f}\t{0.1:.6f}\n".replace(".", ",") for ai in a)
    p = write(tmp_path, "m.lvm", head + rows)
    assert detect_format(p) == "lvm"
    ts = read_with_spec(p, None)
    np.testing.assert_allclose(ts.time, 1.0 + t, atol=1e-12)
    np.testing.assert_allclose(ts.theta, a, atol=1e-8)
    assert "400 rows under header(s) announcing 200 samples" in ts.meta["notes"]


# -- Vernier, PASCO -------------------------------------------------------------------------------------
def test_vernier_cmbl_and_csv_and_pasco_runs(tmp_path):
    t, a = decay(n=300)
    p = write(tmp_path, "v.cmbl", write_cmbl({"Run 1": {"Time": ("s", list(t)), "Angle": ("°", list(np.degrees(a)))},
                                               "Run 2": {"Time": ("s", []), "Angle": ("°", [])}}))
    assert detect_format(p) == "vernier-cmbl"
    np.testing.assert_allclose(read_with_spec(p, None).theta, a, rtol=1e-12)
    csv = '"Run 1: Time (s)","Run 1: Angle (°)","Run 2: Time (s)","Run 2: Angle (°)"\n' + "".join(
        f"{ti},{math.degrees(ai)},{ti},{2 * math.degrees(ai)}\n" for ti, ai in zip(t, a))
    p = write(tmp_path, "v.csv", csv)
    assert detect_format(p) == "vernier-csv"
    with pytest.raises(DataError, match=r"2 runs side by side \(Run 1, Run 2\); set \[recording\] run"):
        read_with_spec(p, None)
    np.testing.assert_allclose(read_with_spec(p, RecordingSpec(run=2)).theta, 2 * a, rtol=1e-12)
    pasco = "Time (s) Run #1,Angle (rad) Run #1,Time (s) Run #2,Angle (rad) Run #2\n" + "".join(
        f"{ti},{ai},{ti if i < 100 else ''},{-ai if i < 100 else ''}\n" for i, (ti, ai) in enumerate(zip(t, a)))
    p = write(tmp_path, "p.csv", pasco)
    assert detect_format(p) == "pasco-csv"
    ts = read_with_spec(p, RecordingSpec(run=2))
    assert ts.time.size == 100 and "at the end" in ts.meta["notes"]
    np.testing.assert_allclose(ts.theta, -a[:100], rtol=1e-15)


# -- Tracker and Arduino -------------------------------------------------------------------------------
def test_tracker_export_angle_from_the_arc(tmp_path):
    t, a = decay(n=400, rate=30.0, amp=0.35)
    pivot, r = np.array([0.12, 1.5]), 1.47  # m, world frame (y up): the bob hangs below the pivot
    x, y = pivot[0] + r * np.sin(a), pivot[1] - r * np.cos(a)
    rng = np.random.default_rng(4)
    text = "mass A\nt\tx\ty\n" + "".join(f"{ti:.4f}\t{xi + 1e-4 * rng.standard_normal():.5f}\t{yi:.5f}\n"
                                         for ti, xi, yi in zip(t, x, y))
    p = write(tmp_path, "track.txt", text)
    assert detect_format(p) == "tracker"
    ts = read_with_spec(p, None)
    err = (ts.theta - a) - np.mean(ts.theta - a)  # the zero is the track's mean direction
    assert np.max(np.abs(err)) < 5e-4
    assert "pivot at (0.12" in ts.meta["notes"] and "radius 1.4" in ts.meta["notes"] and ts.meta["track"] == "mass A"
    with pytest.raises(DataError, match="too flat to locate the pivot"):
        arc_angle(np.linspace(0, 1, 50), 2 + 1e-6 * np.linspace(0, 1, 50) ** 2, "flat")


def test_arduino_serial_log_with_stray_lines(tmp_path):
    t, a = decay(n=300, rate=50.0)
    lines = ["Starting encoder...", "Calibrating"] + [f"Time: {round(1000 * ti)} ms, Angle: {math.degrees(ai):.1f}"
                                                     for ti, ai in zip(t, a)] + ["Done."]
    p = write(tmp_path, "serial.txt", "\r\n".join(lines) + "\r\n")
    assert detect_format(p) == "arduino-log"
    ts = read_with_spec(p, RecordingSpec(angle_unit="deg"))
    np.testing.assert_allclose(ts.time, t, atol=1e-12)
    np.testing.assert_allclose(ts.theta, a, atol=math.radians(0.051))
    assert "3 line(s) that are not 'Time: .., Angle: ..' left out (first: line 1)" in ts.meta["notes"]


# -- detection and the [recording] keys -------------------------------------------------------------------
def test_ambiguous_content_is_refused_with_the_candidates(tmp_path):
    t, a = decay(n=100)
    p = write(tmp_path, "both.csv", '"Run 1: Time (s)","Run 1: Angle (rad)"\n' + "".join(
        f"{java_e(ti)},{java_e(ai)}\n" for ti, ai in zip(t, a)))
    with pytest.raises(DataError, match=r"fits several formats \(vernier-csv, phyphox\); set \[recording\] format"):
        read_with_spec(p, None)
    assert read_with_spec(p, RecordingSpec(format="vernier-csv")).time.size == 100


def test_recording_keys_for_velocity_and_displacement():
    spec = recording_spec_from_table({"displacement_column": "Position (m)", "displacement_unit": "mm"}, "s.toml")
    assert spec.quantity == "displacement" and spec.signal_unit == "mm"
    spec = recording_spec_from_table({"velocity_column": 2, "velocity_unit": "V", "scale": 0.8}, "s.toml")
    assert spec.quantity == "angular_velocity"
    for table, message in [({"velocity_unit": "V"}, "give scale, the SI value per V"),
                           ({"velocity_column": 1, "angle_column": 2}, "give one of angle_column"),
                           ({"displacement_unit": "deg"}, "expected a length unit"),
                           ({"format": "excel"}, "unknown format 'excel'"), ({"run": 0}, "run counts from 1"),
                           ({"lift_angle": 120}, "within 10-90 deg"), ({"bph": 12.5}, "whole number")]:
        with pytest.raises(SceneError, match=message):
            recording_spec_from_table(table, "s.toml")


def test_displacement_in_mm_and_pickup_volts(tmp_path):
    t, x = decay(n=300, amp=0.05)
    p = write(tmp_path, "spring.csv", "Time (s),Position (mm),Pickup (V)\n" + "".join(
        f"{ti},{1e3 * xi},{xi / 0.02}\n" for ti, xi in zip(t, x)))
    d = read_with_spec(p, RecordingSpec(displacement_column="Position (mm)"))
    assert d.quantity == "displacement" and d.unit == "m"
    np.testing.assert_allclose(d.theta, x, rtol=1e-12)
    v = read_with_spec(p, RecordingSpec(velocity_column=3, velocity_unit="V", scale=0.02))
    np.testing.assert_allclose(v.theta, x, rtol=1e-12)


def _zip_two_sets(tmp_path):
    p = tmp_path / "run.zip"
    write_phyphox_zip(p, {"A": {"Time (s)": [0.0, 1.0], "x (rad)": [0.0, 1.0]},
                          "B": {"Time (s)": [0.0, 1.0], "y (rad)": [0.0, 1.0]}})
    return p


def _tgnet_two_sessions(tmp_path):
    from escfit.analysis.recordings.tg_logs import TGNET_HEADER

    rows = [",".join(TGNET_HEADER)]
    for s in (1, 2):
        for i in range(5):
            rows.append(",".join([str(s), "0", str(i), f"{0.4 * i:.6f}", "18000", "DialUp", "true", "1.000000", "true",
                                  "250.000000", "true", "0.300000"] + [""] * 14))
    return write(tmp_path, "m.csv", "lift_angle_deg,52.000000\n" + "\n".join(rows) + "\n")


@pytest.mark.parametrize("make, spec, message", [
    (_zip_two_sets, None, r"run.zip: several data sets in the zip \(A.csv, B.csv\): cannot tell which holds the "
                          r"recording; extract that set's CSV and read it"),
    (lambda tmp: write(tmp, "x.cmbl", '<?xml version="1.0"?><!DOCTYPE d [<!ENTITY a "aaaa">]><Document><DataSet>'
                       '</DataSet></Document>'), RecordingSpec(format="vernier-cmbl"),
     r"x.cmbl: XML with a document type or entity declaration: not an instrument's data file"),
    (lambda tmp: write(tmp, "cut.labx", b'\xef\xbb\xbf<?xml version="1.0"?><cassylab><allchannels><channels>'),
     None, r"cut.labx:1: invalid XML .* the file is cut short or damaged"),
    (_tgnet_two_sessions, None, r"m.csv: 2 sessions in the log \(session_id 1, 2\); set \[recording\] run"),
    (lambda tmp: write(tmp, "x.csv", "a,b\n1,2\n"), RecordingSpec(format="lvm"),
     r"x.csv:1: does not start with 'LabVIEW Measurement': not an .lvm file"),
    (lambda tmp: write(tmp, "s.txt", "Time: 1 ms, Angle: 2\nTime: 2 ms, Angle: 3\nTime: 3 ms, Angle: 4\n"),
     RecordingSpec(angle_unit="deg"), r"s.txt: only 3 samples; a decay needs at least 20"),
])
def test_bad_instrument_files_get_one_line(tmp_path, make, spec, message):
    with pytest.raises(DataError, match=message) as info:
        read_with_spec(make(tmp_path), spec)
    assert "\n" not in str(info.value)


def test_a_title_line_naming_one_run_is_not_a_header_of_runs(tmp_path):
    """DataStudio's text export: a title line (``Output Voltage, Run #16``) above the real header
    (``Time ( s )<TAB>Voltage ( V )``); the title's comma split it into two names, one of them a
    run label, and the file was taken for a runs-side-by-side CSV ("no run labels ...")."""
    from escfit.analysis.recordings.detect import detect_format
    from escfit.analysis.recordings.rawseries import read_raw_series
    from escfit.analysis.recordings.recording_spec import RecordingSpec

    t = np.arange(0, 40, 0.1)
    x = 0.2 * np.exp(-0.03 * t) * np.cos(2 * np.pi * t / 14.3)
    body = "\r\n".join(f"{a:.4f}\t{b:.3f}" for a, b in zip(t, x))
    path = tmp_path / "blow.txt"
    path.write_bytes(("Output Voltage, Run #16\r\nTime ( s )\tVoltage ( V )\r\n" + body + "\r\n").encode())
    try:
        found = detect_format(path)
    except DataError:  # a plain table: read with the [recording] table, as below
        found = None
    assert found != "pasco-csv"
    ts = read_raw_series(path, RecordingSpec(time_column=1, angle_column=2, angle_unit="rad"))
    assert ts.time.size == t.size and ts.theta[0] == pytest.approx(0.2, abs=1e-3)


def test_a_stalled_clock_at_the_end_is_cut_with_a_warning(tmp_path):
    """An encoder log whose time column stops advancing for its last rows (the logger's clock
    stalled while the angle went on): the record is cut at the stall, with a warning (a fifth of
    the rows go) naming it; `stop` cuts it as before."""
    from escfit.analysis.recordings.rawseries import read_raw_series, warnings_of
    from escfit.analysis.recordings.recording_spec import RecordingSpec

    t = np.arange(0, 30, 0.02)
    x = 1.2 * np.exp(-0.05 * t) * np.cos(4.8 * t)
    t[1200:] = t[1200]
    path = tmp_path / "enc.csv"
    path.write_text("time, angle\n" + "\n".join(f"{a:.3f}, {b:.5f}" for a, b in zip(t, x)))
    spec = dict(time_column=1, angle_column=2, angle_unit="rad")
    ts = read_raw_series(path, RecordingSpec(**spec))
    assert ts.time.size == 1201 and ts.time[-1] == pytest.approx(24.0)  # the stall's first row keeps its stamp
    np.testing.assert_allclose(ts.theta, np.round(x[:1201], 5))
    assert warnings_of(ts.meta) == ["the clock stalls (the stamp 24 s repeats over 300 rows): the record is cut there, "
                                    "keeping the longest stretch that keeps time, t = 0 to 24 s (1201 of 1500 rows, "
                                    "[recording] start and stop choose another)"]
    ts = read_raw_series(path, RecordingSpec(**spec, stop=23.98))
    assert ts.time.size == 1200 and ts.time[-1] == pytest.approx(23.98)


def test_graphical_analysis_runs_numbered_first(tmp_path):
    """Graphical Analysis' CSV export numbers each column by its run first (``1 Time``,
    ``1 Position``, ... and once ``7: Position``); the header starts with a digit, which is not a
    row of numbers.  Read as runs side by side: refused without a run, naming them."""
    from click.testing import CliRunner

    from escfit.analysis.recordings.detect import detect_format
    from escfit.cli.main import cli

    t = np.arange(0, 5, 0.05)
    names, cols = [], []
    for run in (1, 2, 3):
        names += [f"{run} Time", f"{run}{':' if run == 2 else ''} Position"]
        cols += [t, 0.04 * np.cos(7.3 * t + run)]
    rows = [",".join(f"{c[i]:.6g}" for c in cols) for i in range(t.size)]
    path = tmp_path / "data.csv"
    path.write_text(",".join(names) + "\n" + "\n".join(rows) + "\n")
    assert detect_format(path) == "vernier-csv"
    r = CliRunner().invoke(cli, ["init", str(path), "--spring", "--out", str(tmp_path / "s.toml")])
    assert r.exit_code == 2 and "3 runs side by side (Run 1, Run 2, Run 3)" in r.output, r.output
