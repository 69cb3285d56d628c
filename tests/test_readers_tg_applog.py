"""Timegrapher app logs: the shipped example, its variations, refusals, steady state, a fit."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import escfit
from escfit.core.errors import DataError
from escfit.inference import least_squares, make_problem
from escfit.analysis.recordings.tg_applog import STEADY_STATE_WARNING, is_steady_state, read_tg_applog
from escfit.analysis.recordings.detect import detect_format, read_recording, read_timegrapher

from .conftest import DATASETS

EXAMPLE = DATASETS / "recordings" / "tg_applog_example.csv"
SCENE = DATASETS / "recordings" / "timegrapher_scene.toml"
TRUTH = {"viscous.C": 0.6, "coulomb.R": 100.0, "escapement[2].X": 1500.0}


@pytest.fixture(scope="module")
def example():
    return read_tg_applog(EXAMPLE)


def _parts() -> tuple[list[str], list[str]]:
    """Settings lines and table lines (header first) of the example."""
    lines = EXAMPLE.read_text().splitlines()
    h = next(i for i, s in enumerate(lines) if s.startswith("Time,"))
    return lines[:h], lines[h:]


def _write(tmp_path, settings, table, *, name="log.csv", end="") -> str:
    path = tmp_path / name
    path.write_text("\n".join(settings + table) + end)
    return str(path)


def _clock_s(text: str) -> float:
    h, m, s = text.split(":")
    return 3600 * int(h) + 60 * int(m) + float(s)


def test_example_reads_as_an_app_log(example):
    assert detect_format(EXAMPLE) == "tg-applog"
    assert read_recording(EXAMPLE).format == read_timegrapher(EXAMPLE).format == "tg-applog"
    m = example.meta
    assert (m["rows"], m["rows_invalid"], m["rows_truncated"], m["rows_kept"]) == ("73", "4", "1", "69")
    assert "dropped 4 row(s) flagged invalid" in m["notes"] and "truncated last row (line 85)" in m["notes"]
    assert m["lift_angle_deg"] == "52" and m["lift_angle_source"] == f"{EXAMPLE}:7"
    assert example.lift_angle == pytest.approx(math.radians(52.0)) and example.bph == 18000
    assert m["model"] == "Monday-like unit" and m["position"] == "DU" and m["title"] == "TimeGrapher log export"
    assert (m["beats_per_update"], m["beats_per_reading"]) == ("2", "2") and example.resolution_deg == 1.0
    assert example.release_s == pytest.approx(_clock_s("21:47:03.250") - _clock_s("21:47:03.951"))
    # the grid beats at the watch's beat; readings' windows hold their two beats and do not overlap
    assert np.median(np.diff(example.beat_time)) == pytest.approx(0.2002, abs=2e-4)
    start, end = example.amp_window
    assert np.all(start[1:] > end[:-1]) and start[0] >= example.beat_time[0] and end[-1] <= example.beat_time[-1]
    for s, e in zip(start[::10], end[::10]):
        assert np.count_nonzero((example.beat_time >= s) & (example.beat_time <= e)) == 2
    # the tocs come 0.2 ms late: the signed beat error says so, row by row
    assert example.beat_error.mean() == pytest.approx(0.2, abs=0.05) and example.rate.size == example.amp_deg.size
    assert m["steady_state"] == "false" and "steady_state_warning" not in m  # it records the decay


def test_seconds_semicolons_decimal_commas_tabs_and_yes_no_read_alike(example, tmp_path):
    settings, table = _parts()
    origin = _clock_s(table[1].split(",")[0])
    secs = [table[0].replace("Time", "Time (s)")] + [
        f"{_clock_s(r.split(',')[0]) - origin + 100.0:.3f}," + r.split(",", 1)[1] for r in table[1:]]
    secs_settings = [s.replace("Release,21:47:03.250", f"Release,{100.0 + _clock_s('21:47:03.250') - origin:.3f}")
                     for s in settings]
    semi = [r.replace(",", ";").replace(".", ",") for r in table]
    semi_settings = [s.replace("Lift angle,52", "Lift angle: 52").replace("BPH,18000", "BPH = 18000")
                     .replace(",", ";", 1) for s in settings]
    yes_no = [table[0].replace("Valid", "OK")] + [r.replace("true", "yes").replace("false", "no") for r in table[1:]]
    tab = [r.replace(",", "\t") for r in table]
    dated = [table[0]] + ["2024-05-03 " + r for r in table[1:]]
    hashed = [f"# {x.replace(',', ': ', 1)}" if x.startswith(("Lift", "BPH", "Release")) else x for x in settings]
    for variant in (_write(tmp_path, secs_settings, secs, name="s.csv"),
                    _write(tmp_path, semi_settings, semi, name="semi.csv"),
                    _write(tmp_path, settings, yes_no, name="yn.csv"),
                    _write(tmp_path, settings, tab, name="tab.txt"),
                    _write(tmp_path, hashed, dated, name="dated.csv")):
        assert detect_format(variant) == "tg-applog", variant
        rec = read_tg_applog(variant)
        np.testing.assert_allclose(rec.amp_time, example.amp_time, atol=1e-9)
        np.testing.assert_array_equal(rec.amp_deg, example.amp_deg)
        np.testing.assert_array_equal(rec.beat_error, example.beat_error)
        assert rec.release_s == pytest.approx(example.release_s) and rec.meta["rows_invalid"] == "4"


def test_clock_passing_midnight(example, tmp_path):
    settings, table = _parts()
    shift = _clock_s("23:59:50.000") - _clock_s("21:47:03.951")

    def moved(text: str) -> str:
        s = (_clock_s(text) + shift) % 86400.0
        return f"{int(s // 3600):02d}:{int(s // 60 % 60):02d}:{s % 60:06.3f}"

    rows = [table[0]] + [moved(r.split(",")[0]) + "," + r.split(",", 1)[1] for r in table[1:]]
    assert any(r.startswith("00:00:") for r in rows)
    settings = [s.replace("21:47:03.250", moved("21:47:03.250")) for s in settings]
    rec = read_tg_applog(_write(tmp_path, settings, rows))
    np.testing.assert_allclose(rec.amp_time, example.amp_time, atol=1e-6)
    assert rec.release_s == pytest.approx(example.release_s)


def test_invalid_rows_dropped_and_signed_beat_error_kept(tmp_path):
    rows = ["time_s,rate_s_per_day,amplitude_deg,beat_error_ms,valid"]
    for i in range(30):
        be = "-0.3" if i % 3 else "+0.3"
        rows.append(f"{0.4 * i:.3f},{-3 + i % 2},{280 + i % 3},{be},{'0' if i in (4, 9, 17) else '1'}")
    rec = read_tg_applog(_write(tmp_path, ["Lift angle,52", "BPH,18000"], rows, end="\n"))
    assert rec.meta["rows_invalid"] == "3" and "dropped 3 row(s) flagged invalid" in rec.meta["notes"]
    assert rec.amp_deg.size == 27 and rec.meta["rows_truncated"] == "0"
    kept = [i for i in range(30) if i not in (4, 9, 17)]
    np.testing.assert_array_equal(rec.beat_error, [-0.3 if i % 3 else 0.3 for i in kept])
    assert detect_format(_write(tmp_path, ["Lift angle,52", "BPH,18000"], rows, name="d.csv")) == "tg-applog"
    assert rec.meta["steady_state"] == "true" and rec.meta["steady_state_warning"] == STEADY_STATE_WARNING


def _drop_setting(prefix):
    return lambda s, t: ([x for x in s if not x.startswith(prefix)], t)


def _row(i, old, new):
    return lambda s, t: (s, t[:i] + [t[i].replace(old, new)] + t[i + 1:])


def _no_bph(settings, table):
    return [x for x in settings if not x.startswith("BPH")], [r.replace(",BPH,", ",").replace(",18000,", ",")
                                                              for r in table]


@pytest.mark.parametrize("case, edit, message, location", [
    ("no-lift-angle", _drop_setting("Lift"),
     r"no lift angle: .* add a settings line 'Lift angle,52' .* before the header at line 10", r"^$"),
    ("no-bph", _no_bph, r"no beat rate: add a settings line 'BPH,18000' .* before the header at line 10", r"^$"),
    ("cut-middle-row", lambda s, t: (s, t[:20] + [t[20][:15]] + t[21:]), r"row has 2 of 6 fields .* cut short",
     r"^:31$"),
    ("bad-flag", _row(5, "true", "maybe"), r"validity flag .* 'maybe'", r"^:16 \[Valid\]$"),
    ("text-amplitude", _row(5, ",183,", ",abc,"), r"expected a number \(the amplitude\), got 'abc'",
     r"^:16 \[Amplitude \(deg\)\]$"),
    ("time-back", lambda s, t: (s, t[:6] + [t[7], t[6]] + t[8:]), r"does not come after .* time order",
     r"^:18 \[Time\]$"),
    ("bph-off-beat", lambda s, t: ([x.replace("BPH,18000", "BPH,21600") for x in s],
                                   [r.replace(",18000,", ",21600,") for r in t]),
     r"2.40 beats at 21600 bph: not a whole number", r"^$"),
    ("unit", _row(0, "(deg)", "(grad)"), r"unknown unit 'grad' of the amplitude", r"^:11 \[Amplitude \(grad\)\]$"),
    ("bph-disagrees", lambda s, t: ([x.replace("BPH,18000", "BPH,19800") for x in s], t),
     r"beat rate is not one number: \[18000.0, 19800.0\]", r"^:8$"),
    ("release-after-start", lambda s, t: ([x.replace("Release,21:47:03.250", "Release,21:47:05") for x in s], t),
     r"release '21:47:05' does not come before the first kept row \(line 13\)", r"^:9$"),
])
def test_bad_logs_are_refused_in_one_line(case, edit, message, location, tmp_path):
    settings, table = edit(*_parts())
    path = _write(tmp_path, settings, table, name=f"{case}.csv", end="\n")
    with pytest.raises(DataError, match=message) as info:
        read_tg_applog(path)
    err = info.value
    assert err.where.startswith(path) and re.search(location, err.where[len(path):]), err.where
    assert "\n" not in str(err)


def test_a_plain_time_amplitude_table_is_not_claimed(tmp_path):
    plain = _write(tmp_path, [], ["time,amplitude", "0.0,3.1", "0.2,3.0"], name="plain.csv")
    with pytest.raises(DataError, match="cannot tell the recording format"):
        detect_format(plain)


def test_steady_state_criterion_and_a_running_watch(tmp_path):
    rng = np.random.default_rng(0)
    t = np.arange(60) * 0.4
    flat = 250 + 0.5 * rng.standard_normal(60)
    assert is_steady_state(flat, t) and is_steady_state(np.round(flat), t, resolution_deg=1.0)
    assert not is_steady_state(flat - 0.1 * t, t)  # 2.4 deg over the record, 0.5 deg scatter
    assert not is_steady_state(flat + 40 * np.exp(-t), t)  # a decay that settles in 3 s
    assert not is_steady_state(flat[:6], t[:6])  # too short to tell
    settings, table = _parts()  # the example after 10 s: the watch has settled
    late = [r for r in table[1:] if _clock_s(r.split(",")[0]) > _clock_s("21:47:14")]
    rec = read_tg_applog(_write(tmp_path, [x for x in settings if not x.startswith("Release")], table[:1] + late))
    assert rec.meta["steady_state"] == "true" and STEADY_STATE_WARNING in rec.meta["notes"]
    assert math.isnan(rec.release_s)


def test_least_squares_on_the_example_finds_the_truth():
    """Amplitudes only (the beat grid is not beat data); the steady amplitude is pinned to a
    fraction of a degree, the transient's few readings bracket C, R and X."""
    text = SCENE.read_text().replace("sigma_t = 1e-4", "sigma_t = 1e-4\nbeats = false")
    problem = make_problem(escfit.load_scene("applog.toml", text=text), EXAMPLE)  # the format is detected
    assert problem.data.format == "tg-applog" and problem.used_readings.size == 69
    truth = {p.name: p.value for p in problem.params}  # the scene's values generated the example
    lsq = least_squares(problem, n_starts=1)
    for name, true in {**TRUTH, "observation.lift_angle": math.radians(52.0)}.items():
        i = lsq.names.index(name)
        assert abs(lsq.value[i] - true) < 3 * lsq.stderr[i], (name, lsq.value[i], lsq.stderr[i])
    fitted, expected = problem.expected(lsq.values)[-40:], problem.expected(truth)[-40:]
    assert np.all(np.abs(fitted - expected) < 0.3), (fitted.mean(), expected.mean())
