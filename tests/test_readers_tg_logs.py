"""Timegrapher programs' logs written as their writers write them (TimeGrapher-Net's
MeasurementResultLogger.WriteEntry, peterhudson/timegrapher's write_beats / write_windows and
long's slices.csv, tg's dump_to_json), read back against the values written."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from escfit.core.errors import DataError
from escfit.analysis.recordings.detect import detect_format, read_with_spec
from escfit.analysis.recordings.recording_spec import RecordingSpec
from escfit.analysis.recordings.tg_applog import read_tg_applog
from escfit.analysis.recordings.tg_logs import TGNET_HEADER, rate_grid
from escfit.analysis.recordings.timegrapher import read_tg_json

BEAT = 0.2  # s, 18000 bph


def f6(v):
    """C#'s ToString("F6", InvariantCulture), or an empty field for null."""
    return "" if v is None else f"{v:.6f}"


def tgnet_log(n=60, *, lift=True, invalid=(7, 8, 30), cut=True) -> tuple[str, list[tuple[float, float]]]:
    lines = ["lift_angle_deg,52.000000"] if lift else []
    lines.append(",".join(TGNET_HEADER))
    kept = []
    for i in range(n):
        t = 3.0 + 2 * BEAT * i  # latest_time_s: the update's latest beat, two beats apart
        amp = 300.0 * math.exp(-0.02 * i) + 150.0
        ok = i not in invalid
        if ok:
            kept.append((t, round(amp, 6)))
        fields = ["1", "0", str(10 + i), f6(t), "18000", "DialUp", "true", f6(-3.25 + 0.01 * i), str(ok).lower(),
                  f6(amp if ok else None), "true", f6(0.4), "false", "", "false", "", "true", f6(200.0), str(i), f6(-3.1),
                  f6(0.5), str(i), f6(280.0), f6(12.0), "0", "0"]
        lines.append(",".join(fields))
    text = "\n".join(lines) + "\n"
    if cut:
        text += "1,0,99,15.400000,18000,DialUp,true,-2.9"  # stopped mid-row
    return text, kept


def test_timegrapher_net_log_as_the_logger_writes_it(tmp_path):
    text, kept = tgnet_log()
    p = tmp_path / "measurement.csv"
    p.write_text(text)
    assert detect_format(p) == "timegrapher-net"
    rec = read_with_spec(p, None)
    assert rec.format == "tg-applog" and rec.bph == 18000 and rec.lift_angle == pytest.approx(math.radians(52.0))
    np.testing.assert_allclose(rec.amp_deg, [a for _, a in kept])
    assert rec.meta["rows_kept"] == str(len(kept)) and rec.meta["rows_invalid"] == "3"
    assert "dropped the truncated last row" in rec.meta["notes"] and rec.meta["position"] == "DialUp"
    assert np.median(np.diff(rec.beat_time)) == pytest.approx(BEAT, rel=1e-6)
    np.testing.assert_allclose(rec.rate, [-3.25 + 0.01 * i for i in range(60) if i not in (7, 8, 30)])


def test_timegrapher_net_without_lift_line_needs_the_key(tmp_path):
    text, kept = tgnet_log(lift=False, cut=False)
    p = tmp_path / "m.csv"
    p.write_text(text)
    with pytest.raises(DataError, match=r"m.csv: the file does not say the lift angle set in TimeGrapher-Net .* set "
                                        r"\[recording\] lift_angle"):
        read_with_spec(p, None)
    rec = read_with_spec(p, RecordingSpec(lift_angle=math.radians(51.0)))
    assert rec.lift_angle == pytest.approx(math.radians(51.0))
    bad = text.replace(",true,", ",maybe,", 1)
    p.write_text(bad)
    with pytest.raises(DataError, match=r"m.csv:2 \[rate_valid\]: expected true or false, got 'maybe'"):
        read_with_spec(p, RecordingSpec(lift_angle=math.radians(51.0)))


def test_run_down_slices_follow_the_logged_rate(tmp_path):
    """peterhudson's long: one row per ~10 min slice over 30 h, the rate drifting by 40 s/day."""
    start = np.arange(0, 30 * 3600, 600.0)
    rate = 5.0 - 40.0 * start / start[-1]
    amp = 290.0 - 120.0 * start / start[-1]
    rows = "".join(f"{s:.2f},{s + 600:.2f},{r:.2f},0.300,{a:.1f}\n" for s, r, a in zip(start, rate, amp))
    p = tmp_path / "slices.csv"
    p.write_text("start_s,end_s,rate_s_per_day,beat_error_ms,amplitude_deg\n" + rows)
    assert detect_format(p) == "tgcli-slices"
    with pytest.raises(DataError, match=r"set \[recording\] lift_angle"):
        read_with_spec(p, RecordingSpec(bph=28800))
    rec = read_with_spec(p, RecordingSpec(bph=28800, lift_angle=math.radians(52.0)))
    np.testing.assert_allclose(rec.amp_deg, np.round(amp, 1))
    np.testing.assert_allclose(rec.amp_time, start + 300.0)
    # beats counted from the rate: the integral of (1 + r/86400) / P0 over the run, to a beat
    p0 = 3600.0 / 28800
    expected = np.sum(600.0 * (1 + rate / 86400.0) / p0)
    assert abs(np.searchsorted(rec.beat_time, start[-1] + 600.0) - expected) < 2
    assert "follows the logged rate" in rec.meta["notes"]


def test_generic_app_log_with_long_windows_is_not_required_on_beats(tmp_path):
    rows = ["Lift angle,52", "BPH,21600", "Time (s),Rate (s/d),Amplitude (deg)"]
    for i in range(60):
        rows.append(f"{601.37 * i:.2f},{4.0 - 0.1 * i:.1f},{300 - 2 * i}")
    p = tmp_path / "rundown.csv"
    p.write_text("\n".join(rows) + "\n")
    rec = read_tg_applog(p)
    assert rec.amp_deg.size == 60 and "counted from the logged rate" in rec.meta["notes"]
    beats = np.searchsorted(rec.beat_time, 601.37 * 59) - np.searchsorted(rec.beat_time, 0.0)
    expected = sum(601.37 * (1 + (4.0 - 0.1 * i) / 86400.0) * 6.0 for i in range(1, 60))
    assert abs(beats - expected) <= 30  # rounding the count at each of the 59 rows


def test_peterhudson_beats_and_windows(tmp_path):
    t = 0.5 + np.cumsum(np.full(400, 0.125 * (1 - 5 / 86400)))
    p = tmp_path / "beats.csv"
    p.write_text("index,time_s,quality,residual_us\n" + "".join(f"{i},{ti:.6f},0.950,{1.5:.1f}\n"
                                                                 for i, ti in enumerate(t)))
    rec = read_with_spec(p, None)
    assert rec.format == "tgcli-beats" and rec.bph == 28800 and rec.amp_deg.size == 0
    np.testing.assert_allclose(rec.beat_time, np.round(t, 6))
    w = tmp_path / "windows.csv"
    w.write_text("kind,start_s,end_s,rate_s_per_day,beat_error_ms,beat_error_unlock_ms,amplitude_even_deg,"
                 "amplitude_odd_deg\nrate,0.00,10.00,4.50,0.300,,,\nrate,10.00,20.00,4.10,0.310,,,\n"
                 "amplitude,0.00,2.00,,0.300,0.200,280.5,281.5\namplitude,2.00,4.00,,,,279.0,\n"
                 "amplitude,4.00,6.00,,,,,\n")
    rec = read_with_spec(w, RecordingSpec(bph=28800, lift_angle=math.radians(52.0)))
    np.testing.assert_allclose(rec.amp_deg, [281.0, 279.0])  # even and odd averaged; a window with neither dropped
    assert "1 window(s) without an amplitude" in rec.meta["notes"]


def test_peterhudson_json_summary_is_read_and_refused(tmp_path):
    p = tmp_path / "a.json"
    p.write_text(json.dumps({"schema": "timegrapher.analyze/1", "software": {"name": "timegrapher"},
                             "duration_s": 60.0, "amplitude_deg": 275.0}))
    assert detect_format(p) == "tgcli-json"
    with pytest.raises(DataError, match=r"a timegrapher summary \(timegrapher.analyze/1: median amplitude 275.0 deg "
                                        r"over 60.0 s\), not readings over time"):
        read_with_spec(p, None)


def test_tg_dump_without_amplitude(tmp_path):
    """tg's dump_to_json writes "amplitude": null when it has none, and the sample rate with %f."""
    p = tmp_path / "dump.json"
    p.write_text('{"sample_rate": 48000.000000, "bph": 18000, "beats": {"times": [9600, 19200, 28800], '
                 '"tictoc": [true, false, true]}, "amplitude": null}')
    rec = read_tg_json(p)
    np.testing.assert_allclose(rec.beat_time, [0.2, 0.4, 0.6])
    assert rec.amp_deg.size == 0 and math.isnan(rec.lift_angle)


def test_rate_grid_counts_beats_of_a_gaining_watch():
    grid = rate_grid(0.0, 3600.0, 18000, np.array([0.0, 3600.0]), np.array([86.4, 86.4]))
    assert grid.size - 1 == pytest.approx(18000 * 1.001, abs=1.5)  # 86.4 s/day gains 0.1 %


def test_a_log_of_a_running_watch_is_refused_as_such(tmp_path):
    """A TimeGrapher-Net log starts with the watch already running: no release to start the model
    from.  The fit says so in one line (the amplitude it saw), not in terms of escfit's own keys."""
    from click.testing import CliRunner

    from escfit.cli.main import cli

    text, _ = tgnet_log()
    (tmp_path / "measurement.csv").write_text(text)
    (tmp_path / "watch.toml").write_text(
        'model = "balance"\n[oscillator]\nomega0 = 18.85\ntheta0 = "220 deg"\n[run]\nswings = 400\n'
        "[effects.viscous]\nC = { value = 0.5, vary = true, min = 0.0, max = 10.0 }\n"
        '[observation]\nmodel = "timegrapher"\n')
    out = tmp_path / "r.h5"
    r = CliRunner().invoke(cli, ["fit", str(tmp_path / "measurement.csv"), "--scene", str(tmp_path / "watch.toml"),
                                 "--out", str(out)])
    lines = [s for s in r.output.splitlines() if s.strip()]
    assert r.exit_code == 2 and len(lines) == 1 and not out.exists(), r.output
    assert "the log begins with the watch already running (amplitude" in lines[0] and "no release" in lines[0]
