"""Every recording reader refuses bad input with a DataError naming file, line or key and value.

``CASES`` is the table documented in docs/recordings.md: (id, reader, file name, content,
message pattern, location pattern).  Content is text, bytes, or a callable building the
case from the test's temporary directory (scene/data mismatches).
"""

from __future__ import annotations

import json
import re

import pytest

import escfit
from escfit.core.errors import DataError, EscfitError, FitError
from escfit.analysis.recordings.pulses import assign_pulses, read_pulses
from escfit.analysis.recordings.detect import detect_format, read_recording
from escfit.analysis.recordings.timegrapher import beat_swings, read_tg_json, read_timegrapher_csv
from escfit.analysis.recordings.timeseries import read_timeseries, timeseries_to_unit_curve

from .conftest import DATASETS

PULSE_HEAD = "# notches: 60\ntime_s,kind\n"
TG_CSV_HEAD = "# lift_angle_deg: 52\n# bph: 18000\n# window_s: 2\ntime_s,rate_s_per_day,amplitude_deg,beat_error_ms\n"
TS_HEAD = "time_s,theta_rad\n"


def _tg_doc(**changes) -> dict:
    doc = {"sample_rate": 48000, "bph": 18000,
           "beats": {"times": [1000, 10600, 20200, 29800], "tictoc": [True, False, True, False]},
           "amplitude": {"liftangle": 52.0, "times": [15000], "values": [4.0]}}
    for dotted, value in changes.items():
        cur = doc
        *path, last = dotted.split("__")
        for p in path:
            cur = cur[p]
        if value is _DELETE:
            del cur[last]
        else:
            cur[last] = value
    return doc


_DELETE = object()


def _ts_rows(n=40, bad=None) -> str:
    rows = [f"{0.01 * i:.2f},{1.0:.3f}" for i in range(n)]
    if bad is not None:
        i, text = bad
        rows[i] = text
    return TS_HEAD + "\n".join(rows) + "\n"


def _pulse_mismatch(tmp):
    from escfit.balance.problems.pulses import PulseFitProblem
    from escfit.balance.synthetic.instruments import record_pulses

    scene = escfit.load_scene(DATASETS / "recordings" / "pulses_scene.toml")
    train = record_pulses(scene, swings=4, seed=0)
    other = escfit.load_scene("other.toml", text=(DATASETS / "recordings" / "pulses_scene.toml").read_text()
                              .replace("theta0 = 6.28", "theta0 = 4.0"))
    PulseFitProblem(other, train)


def _tg_mismatch(tmp):
    from escfit.balance.problems.timegrapher import TimegrapherFitProblem
    from escfit.balance.synthetic.instruments import record_timegrapher

    scene = escfit.load_scene(DATASETS / "recordings" / "timegrapher_scene.toml")
    rec = record_timegrapher(scene, swings=30, seed=0)
    other = escfit.load_scene("other.toml", text=(DATASETS / "recordings" / "timegrapher_scene.toml").read_text()
                              .replace("omega0 = 15.9", "omega0 = 25.0"))
    TimegrapherFitProblem(other, rec)


def _tg_no_release(tmp):
    from escfit.balance.problems.timegrapher import TimegrapherFitProblem

    p = tmp / "norelease.json"
    p.write_text(json.dumps(_tg_doc()))
    TimegrapherFitProblem(escfit.load_scene(DATASETS / "recordings" / "timegrapher_scene.toml"), read_tg_json(p))


def _ts_mismatch(tmp):
    p = tmp / "decay.csv"
    import numpy as np

    t = np.arange(0, 4, 0.002)
    p.write_text(TS_HEAD + "\n".join(f"{a:.4f},{1.2 * np.cos(15.9 * a) * np.exp(-0.3 * a):.6f}" for a in t) + "\n")
    timeseries_to_unit_curve(read_timeseries(p), release_theta=6.28)


def _pulse_problem_wrong_data(tmp):
    from escfit.balance.problems.pulses import PulseFitProblem

    p = tmp / "tg.json"
    p.write_text(json.dumps(_tg_doc()))
    PulseFitProblem(escfit.load_scene(DATASETS / "recordings" / "pulses_scene.toml"), read_tg_json(p))


BINARY = bytes(range(256)) * 4
TRUNCATED = json.dumps(_tg_doc(), indent=1)[:-40]

# id, reader, file name, content, message pattern, location pattern (after the file name)
def _unit_curve_release_mismatch(tmp):
    from escfit.balance.problems.curves import FitProblem
    from escfit.analysis.recordings import read_unit_curve

    scene = escfit.load_scene("s.toml", text=(DATASETS / "monday1965" / "unit1_fit.toml").read_text()
                              .replace("theta0 = 6.28", "theta0 = 0.1"))
    FitProblem(scene, read_unit_curve(DATASETS / "monday1965" / "synthetic" / "unit1.csv"))


def _pulse_stray_tail(tmp):
    from escfit.balance.problems.pulses import PulseFitProblem

    lines = (DATASETS / "recordings" / "monday_pulses.csv").read_text().splitlines()
    lines.append("1000000000,notch")
    p = tmp / "p.csv"
    p.write_text("\n".join(lines) + "\n")
    PulseFitProblem(escfit.load_scene(DATASETS / "recordings" / "pulses_scene.toml"), read_pulses(p))


UNIT_NOTCH = "swing,notches\n0,59\n4,41\n"
LATIN1 = "# op\u00e9rateur: Andr\u00e9\ntime_s,kind\n0.1,zero\n".encode("latin-1")
BOM = b"\xef\xbb\xbf"

CASES = [
    # pulse trains
    ("pulses-empty", read_pulses, "p.csv", "", r"empty file", r"^$"),
    ("pulses-comments-only", read_pulses, "p.csv", "# notches: 60\n", r"empty file", r"^$"),
    ("pulses-missing-column", read_pulses, "p.csv", "time_s\n0.1\n", r"need columns time_s .* and kind", r"^$"),
    ("pulses-text", read_pulses, "p.csv", PULSE_HEAD + "0.1,notch\nabc,notch\n", r"expected a number, got 'abc'",
     r":4 \[time_s\]"),
    ("pulses-nan", read_pulses, "p.csv", PULSE_HEAD + "0.1,notch\nnan,notch\n", r"'nan' is not a finite number",
     r":4 \[time_s\]"),
    ("pulses-time-back", read_pulses, "p.csv", PULSE_HEAD + "0.2,notch\n0.1,zero\n",
     r"must not decrease: 0.2 then 0.1", r":4 \[time_s\]"),
    ("pulses-unknown-unit", read_pulses, "p.csv", "time_blinks,kind\n1,zero\n", r"unknown time unit 'blinks'", r"^$"),
    ("pulses-unknown-kind", read_pulses, "p.csv", PULSE_HEAD + "0.1,tooth\n", r"kind must be .* got 'tooth'",
     r":3 \[kind\]"),
    ("pulses-bad-notches", read_pulses, "p.csv", "# notches: 7.5\ntime_s,kind\n0.1,zero\n",
     r"whole number .* got 7.5", r" \[notches\]"),
    ("pulses-json", read_pulses, "p.csv", json.dumps(_tg_doc()), r"this is a JSON file", r"^$"),
    ("pulses-binary", read_pulses, "p.csv", BINARY, r"binary file", r"^$"),
    ("pulses-odd-group", lambda p: assign_pulses(read_pulses(p)), "p.csv",
     PULSE_HEAD + "0.0,notch\n0.1,zero\n0.2,notch\n0.3,notch\n0.4,notch\n0.5,zero\n",
     r"3 notch pulses between the zero pulses .* must pair up", r":8$"),
    ("pulses-no-zero", lambda p: assign_pulses(read_pulses(p)), "p.csv", PULSE_HEAD + "0.1,notch\n",
     r"no zero pulse", r"^$"),
    ("pulses-scene-mismatch", _pulse_mismatch, None, None, r"59 notch pulses before the first zero pulse .* theta0 = 4",
     None),
    ("pulses-problem-wrong-data", _pulse_problem_wrong_data, None, None, r"needs a PulseTrain, got TimegrapherRecording",
     None),
    # timegrapher JSON
    ("tg-empty", read_tg_json, "t.json", "", r"empty file", r"^$"),
    ("tg-truncated", read_tg_json, "t.json", TRUNCATED, r"invalid JSON: .* \(the file is truncated\)", r":\d+$"),
    ("tg-nan", read_tg_json, "t.json", json.dumps(_tg_doc(amplitude__values=[float("nan")])),
     r"NaN is not a number JSON allows", r":1$"),
    ("tg-missing-key", read_tg_json, "t.json", json.dumps(_tg_doc(amplitude__liftangle=_DELETE)),
     r"missing key 'amplitude.liftangle'", r"^$"),
    ("tg-negative-amplitude", read_tg_json, "t.json", json.dumps(_tg_doc(amplitude__values=[-4.0])),
     r"value -4.0 must not be negative", r" \[amplitude.values\[0\]\]"),
    ("tg-text", read_tg_json, "t.json", json.dumps(_tg_doc(beats__times=[1000, 10600, "abc", 29800])),
     r"expected a whole number, got 'abc'", r" \[beats.times\[2\]\]"),
    ("tg-beats-back", read_tg_json, "t.json", json.dumps(_tg_doc(beats__times=[1000, 20200, 10600, 29800])),
     r"times must increase: 20200 then 10600", r" \[beats.times\[2\]\]"),
    ("tg-lift-range", read_tg_json, "t.json", json.dumps(_tg_doc(amplitude__liftangle=0.9)),
     r"lift angle 0.9 deg lies outside", r" \[amplitude.liftangle\]"),
    ("tg-length", read_tg_json, "t.json", json.dumps(_tg_doc(beats__tictoc=[True])), r"1 tictoc flags for 4 beats",
     r" \[beats.tictoc\]"),
    ("tg-binary", read_tg_json, "t.json", BINARY, r"binary file", r"^$"),
    ("tg-csv-given", read_tg_json, "t.json", TG_CSV_HEAD + "0.1,0,200,0\n", r"not a JSON file", r":1$"),
    ("tg-no-release", _tg_no_release, None, None, r"does not say when the balance was released", None),
    ("tg-scene-mismatch", _tg_mismatch, None, None, r"beats every [0-9.]+ ms .* omega0 = 25 .* another scene's data",
     None),
    # timegrapher per-beat CSV
    ("tgcsv-missing-column", read_timegrapher_csv, "t.csv", "# lift_angle_deg: 52\n# bph: 18000\ntime_s,rate_s_per_day\n0.1,3\n",
     r"missing column\(s\) \['amplitude_deg'\]", r"^$"),
    ("tgcsv-missing-meta", read_timegrapher_csv, "t.csv", "time_s,amplitude_deg\n0.1,200\n",
     r"missing metadata line '# lift_angle_deg: ...'", r"^$"),
    ("tgcsv-negative", read_timegrapher_csv, "t.csv", TG_CSV_HEAD + "0.1,3,200,0.1\n0.3,3,-200,0.1\n",
     r"'-200' must not be negative", r":6 \[amplitude_deg\]"),
    ("tgcsv-text", read_timegrapher_csv, "t.csv", TG_CSV_HEAD + "0.1,3,abc,0.1\n", r"expected a number .* got 'abc'",
     r":5 \[amplitude_deg\]"),
    ("tgcsv-nan", read_timegrapher_csv, "t.csv", TG_CSV_HEAD + "0.1,3,nan,0.1\n", r"'nan' is not a finite number",
     r":5 \[amplitude_deg\]"),
    ("tgcsv-time-back", read_timegrapher_csv, "t.csv", TG_CSV_HEAD + "0.3,3,200,0.1\n0.1,3,200,0.1\n",
     r"beat times must increase: 0.3 then 0.1", r":6 \[time_s\]"),
    ("tgcsv-json", read_timegrapher_csv, "t.csv", json.dumps(_tg_doc()), r"this is a JSON file", r"^$"),
    ("tgcsv-unknown-column", read_timegrapher_csv, "t.csv", TG_CSV_HEAD.replace("beat_error_ms", "beat_error_us") +
     "0.1,3,200,0.1\n", r"unknown column\(s\) \['beat_error_us'\]", r"^$"),
    # time series
    ("ts-empty", read_timeseries, "s.csv", "\n\n", r"empty file", r"^$"),
    ("ts-missing-column", read_timeseries, "s.csv", "time_s\n0.1\n", r"need columns time_s and one angle column",
     r"^$"),
    ("ts-text", read_timeseries, "s.csv", _ts_rows(bad=(5, "0.05,abc")), r"expected a number, got 'abc'",
     r":7 \[theta_rad\]"),
    ("ts-nan", read_timeseries, "s.csv", _ts_rows(bad=(5, "0.05,NaN")), r"'NaN' is not a finite number",
     r":7 \[theta_rad\]"),
    # one row out of order is dropped (tests/test_timebase.py); a clock that starts again is refused
    ("ts-time-reset", read_timeseries, "s.csv", TS_HEAD + "".join(f"{0.01 * (i % 20):.2f},1.0\n" for i in range(40)),
     r"time goes backwards: 0.19 then 0.0 s.*set \[recording\] sample_rate \(or --sample-rate\)", r":22 \[time_s\]"),
    ("ts-unknown-unit", read_timeseries, "s.csv", "time_s,theta_blorp\n0,1\n", r"unknown angle unit 'blorp'", r"^$"),
    ("ts-not-angle", read_timeseries, "s.csv", "time_s,theta_m\n0,1\n", r"'m' is not an angle unit", r"^$"),
    ("ts-too-short", read_timeseries, "s.csv", TS_HEAD + "0,1\n0.1,0.9\n", r"only 2 samples", r"^$"),
    ("ts-json", read_timeseries, "s.csv", json.dumps(_tg_doc()), r"this is a JSON file", r"^$"),
    ("ts-binary", read_timeseries, "s.csv", BINARY, r"binary file", r"^$"),
    ("ts-scene-mismatch", _ts_mismatch, None, None, r"starts at 1.2 rad but the scene releases the balance at 6.28",
     None),
    # format detection and the dispatching reader
    ("detect-unknown-header", detect_format, "x.csv", "a,b\n1,2\n", r"cannot tell the recording format .*\['a', 'b'\]",
     r"^$"),
    ("unit-curve-json", lambda p: read_recording(p, "unit-curve"), "u.csv", json.dumps(_tg_doc()),
     r"this is a JSON file, not the CSV table of a unit curve", r"^$"),
    ("unit-curve-negative", lambda p: read_recording(p, "unit-curve"), "u.csv", "swing,amplitude_rad\n0,6\n1,-5\n",
     r"'-5' must not be negative", r":3 \[amplitude_rad\]"),
    ("missing-file", read_pulses, None, None, r"data file not found", None),
    # values no recording can hold, encodings, sizes
    ("unit-curve-notch-inf", lambda p: read_recording(p, "unit-curve"), "u.csv", "# notch_deg: inf\n" + UNIT_NOTCH,
     r"notch_deg must be a positive number of degrees up to 180, got 'inf'", r"^$"),
    ("unit-curve-huge-swing", lambda p: read_recording(p, "unit-curve"), "u.csv",
     "swing,amplitude_rad\n0,6\n1000000000,5\n", r"swing index 1000000000 is beyond 1,000,000 half swings",
     r":3 \[swing\]"),
    ("unit-curve-release-mismatch", _unit_curve_release_mismatch, None, None,
     r"releases the balance at 5.73 deg .* release reading \(swing 0\) .* is 354 deg", None),
    ("tg-json-1e400", read_tg_json, "t.json", json.dumps(_tg_doc()).replace('"sample_rate": 48000', '"sample_rate": 1e400'),
     r"number 1e400 is out of range", r"^$"),
    ("tg-json-deep", read_tg_json, "t.json", "[" * 100_000 + "]" * 100_000, r"nested too deeply", r"^$"),
    ("pulses-stray-tail", _pulse_stray_tail, None, None,
     r"pulse at 1e\+09 s comes 1e\+09 s after the last zero pulse, longer than the whole fitted record", None),
    ("tg-json-release-far", lambda p: beat_swings(read_tg_json(p)), "t.json", json.dumps({**_tg_doc(), "escfit": {"release_sample": -1e12}}),
     r"lies .* beats before the first beat: more than 1,440,000 half swings", r"^$"),
    ("tg-json-amplitude-far", read_tg_json, "t.json", json.dumps(_tg_doc(amplitude__times=[10**14])),
     r"amplitude reading at sample 100000000000000 lies far outside the beats", r" \[amplitude.times\[0\]\]"),
    ("tg-csv-range-reversed", read_timegrapher_csv, "b.csv",
     "# amplitude_range_deg: 360, 135\n" + TG_CSV_HEAD + "0.1,0,250,0.1\n0.3,0,250,0.1\n",
     r"0 <= low < high, got '360, 135'", r" \[amplitude_range_deg\]"),
    ("tg-csv-range-nan", read_timegrapher_csv, "b.csv",
     "# amplitude_range_deg: nan, 360\n" + TG_CSV_HEAD + "0.1,0,250,0.1\n0.3,0,250,0.1\n",
     r"0 <= low < high", r" \[amplitude_range_deg\]"),
    ("ts-release-nan", read_timeseries, "s.csv", "# release_s: nan\n" + _ts_rows(), r"release_s must be a finite time",
     r" \[release_s\]"),
    ("csv-field-over-limit", read_recording, "u.csv", "swing,amplitude_rad\n0," + "9" * 200_000 + "\n",
     r"cannot read as a table \(field larger than field limit", r"^$"),
    ("csv-header-power", read_recording, "u.csv", "swing,amplitude_rad,load_g**9**9**9\n0,6,3\n1,5,3\n",
     r"unknown load unit 'g\*\*9\*\*9\*\*9'", r"^$"),
    ("csv-latin1", read_pulses, "p.csv", LATIN1,
     r"not UTF-8 text: byte 0xe9 on line 1 \(in Latin-1 / Windows-1252 that is 'é'\); save the file as UTF-8",
     r"^:1$"),
]


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_refused_naming_where(case, tmp_path):
    cid, reader, name, content, message, location = case
    if name is None and content is None and cid != "missing-file":
        with pytest.raises(EscfitError, match=message) as info:
            reader(tmp_path)
        assert isinstance(info.value, (DataError, FitError))
        return
    path = tmp_path / (name or "absent.csv")
    if content is not None:
        path.write_bytes(content) if isinstance(content, bytes) else path.write_text(content)
    with pytest.raises(DataError, match=message) as info:
        reader(path)
    err = info.value
    assert err.where is not None and err.where.startswith(str(path)), err.where
    if location is not None:
        assert re.search(location, err.where[len(str(path)):]), (err.where, location)


def test_table_in_docs_matches_cases():
    """docs/recordings.md lists every case id of the table above."""
    doc = (DATASETS.parent / "docs" / "recordings.md").read_text()
    missing = [c[0] for c in CASES if f"`{c[0]}`" not in doc]
    assert not missing, missing


@pytest.mark.parametrize("name, reader", [("monday_pulses.csv", read_pulses), ("monday_timeseries.csv", read_timeseries),
                                          ("monday_timegrapher_beats.csv", read_timegrapher_csv)])
def test_a_utf8_byte_order_mark_is_read_as_without(name, reader, tmp_path):
    # spreadsheets save UTF-8 with a byte-order mark; it is not part of the first line
    plain = DATASETS / "recordings" / name
    marked = tmp_path / name
    marked.write_bytes(BOM + plain.read_bytes())
    a, b = reader(plain), reader(marked)
    for field in ("time", "kind", "theta", "amplitude"):
        if hasattr(a, field) and getattr(a, field) is not None:
            assert list(getattr(a, field)) == list(getattr(b, field)), field
