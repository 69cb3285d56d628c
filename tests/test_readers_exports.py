"""Real instruments' exports that put more in a file than the recording: a CASSY table with an FFT
and derived columns, Vernier/Logger Pro runs side by side, files escfit cannot read, a column of
angles without a clock, escfit's own text formats through the shared tokenizer.

Each layout is written here as its program writes it (the program and the real file it was built
from are named in docs/recordings.md, "Exports with more than the recording"); the signal is a known
damped cosine and every reader must return it to the written precision.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from escfit.core.errors import DataError
from escfit.analysis.recordings.detect import read_with_spec
from escfit.analysis.recordings.recording_spec import RecordingSpec


def decay(n=800, rate=100.0, amp=0.8):
    t = np.arange(n) / rate
    return t, amp * np.exp(-0.2 * t) * np.cos(2 * math.pi * 1.3 * t)


def write(tmp_path, name, data):
    p = tmp_path / name
    p.write_bytes(data if isinstance(data, bytes) else data.encode("utf-8"))
    return p


def _comma(v: float) -> str:
    return "" if not np.isfinite(v) else repr(float(v)).replace(".", ",")


def _cassy_columns(t, a):
    """The channels of a CASSY Lab 2 torsion-pendulum measurement (PhyPraKit's Drehpendel.labx):
    time, the FFT's frequency axis and the angle's spectrum (shorter than the time: 2^k + 1 bins),
    the angle, a running mean of it and its derivative, angles in degrees."""
    deg = np.degrees(a)
    nfft = 2 ** int(math.log2(t.size)) // 2 + 1
    f = np.arange(nfft) / (t[1] - t[0]) / (2 * (nfft - 1))
    spec = np.abs(np.fft.rfft(deg, 2 * (nfft - 1)))[:nfft] * 2 / deg.size
    mean = np.convolve(deg, np.ones(5) / 5, mode="same")
    rate = np.r_[np.nan, np.diff(deg) / np.diff(t)]
    return [("Zeit", "t", "s", t), ("Frequenz", "f", "Hz", f), ("Fourier-Transformation von α", "F_α", "°", spec),
            ("Winkel", "α", "°", deg), ("Winkel gemittelt", "α_m", "°", mean),
            ("Winkelgeschwindigkeit", "ω", "°/s", rate)]


def _cassy_text(cols) -> str:
    """CASSY Lab 2's text export (as PhyPraKit's Cassy.txt): BOM, MIN=/DEF= lines, tabs, decimal
    commas, CR CR LF; a channel shorter than the time leaves its cells empty."""
    n = max(v.size for *_, v in cols)
    lines = ["MIN=" + "\t".join("0" for _ in cols), "MAX=" + "\t".join("1" for _ in cols),
             "DEF=" + "\t".join(f'"{q}" {s} / {u}' for q, s, u, _ in cols)]
    lines += ["\t".join(_comma(v[i]) if i < v.size else "" for *_, v in cols) for i in range(n)]
    return "\ufeff" + "\r\r\n".join(lines) + "\r\r\n"


def test_cassy_text_export_with_fft_and_derived_columns_reads_the_angle(tmp_path):
    t, a = decay()
    p = write(tmp_path, "drehpendel.txt", _cassy_text(_cassy_columns(t, a)))
    ts = read_with_spec(p, None)
    np.testing.assert_allclose(ts.theta, a, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(ts.time, t, atol=1e-12)
    notes = ts.meta["notes"]
    assert "column 'Winkel' is the measured one" in notes
    assert "'Fourier-Transformation von α' (a spectrum)" in notes and "'Winkel gemittelt' (derived)" in notes


def test_cassy_csv_with_symbol_headers_passes_over_short_columns(tmp_path):
    """The same table saved as CSV from a spreadsheet (semicolons, decimal commas, ``symbol / unit``
    headers): the spectrum is known only by being shorter than the time."""
    t, a = decay()
    cols = [c for c in _cassy_columns(t, a) if c[0] != "Winkel gemittelt"]
    head = ";".join(f"{s} / {u}" for _, s, u, _ in cols)
    rows = [";".join(_comma(v[i]) if i < v.size else "" for *_, v in cols) for i in range(t.size)]
    p = write(tmp_path, "drehpendel.csv", head + "\r\n" + "\r\n".join(rows) + "\r\n")
    ts = read_with_spec(p, None)
    np.testing.assert_allclose(ts.theta, a, rtol=1e-12, atol=1e-15)
    assert f"'F_α / °' ({2 ** int(math.log2(t.size)) // 2 + 1} readings of {t.size})" in ts.meta["notes"]


def test_two_measured_angles_are_still_refused_with_the_candidates(tmp_path):
    t, a = decay(n=200)
    p = write(tmp_path, "two.csv", "t / s;Winkel 1 / °;Winkel 2 / °\n" + "".join(
        f"{ti};{math.degrees(ai)};{2 * math.degrees(ai)}\n" for ti, ai in zip(t, a)))
    with pytest.raises(DataError, match=r"several columns could be the angle in the header .*Winkel 1.*Winkel 2"):
        read_with_spec(p, None)
    np.testing.assert_allclose(read_with_spec(p, RecordingSpec(angle_column="Winkel 2 / °")).theta, 2 * a, rtol=1e-12)


# -- Vernier / Logger Pro runs side by side ---------------------------------------------------------------
@pytest.mark.parametrize("names", [
    ['"Run 1: Time (s)"', '"Run 1: Position (m)"', '"Run 2: Time (s)"', '"Run 2: Position (m)"'],  # Graphical Analysis
    ['"Data Set 1:Time(s)"', '"Data Set 1:Position(m)"', '"Data Set 2:Time(s)"', '"Data Set 2:Position(m)"'],
    ["Time 1 (s)", "Position 1 (m)", "Time 2 (s)", "Position 2 (m)"],  # Logger Pro's numbered columns
])
def test_motion_detector_runs_side_by_side(tmp_path, names):
    t, x = decay(n=300, amp=0.05)
    short = 200  # the second run stopped earlier: its cells end empty
    rows = "".join(f"{ti},{xi},{ti if i < short else ''},{-xi if i < short else ''}\n"
                   for i, (ti, xi) in enumerate(zip(t, x)))
    p = write(tmp_path, "motion.csv", ",".join(names) + "\n" + rows)
    with pytest.raises(DataError, match=r"motion.csv:1: 2 runs side by side \((Run|Data Set) 1, (Run|Data Set) 2\); "
                                        r"set \[recording\] run \(1-based\)") as info:
        read_with_spec(p, RecordingSpec(displacement_column=2))
    assert "\n" not in str(info.value)
    ts = read_with_spec(p, RecordingSpec(run=2, displacement_column=2))
    assert ts.quantity == "displacement" and ts.time.size == short
    np.testing.assert_allclose(ts.theta, -x[:short], rtol=1e-12)
    np.testing.assert_allclose(read_with_spec(p, RecordingSpec(run=1, displacement_column=2)).theta, x, rtol=1e-12)


def test_motion_detector_export_with_velocity_and_acceleration(tmp_path):
    """A Vernier motion detector's CSV as a real export shows it (20 Hz, six decimals, unquoted
    ``Run 1: Time (s),Run 1: Position (m),Run 1: Velocity (m/s),Run 1: Acceleration (m/s^2)``): the
    linear velocity is not an angular one; with displacement_column the position is read in m."""
    t, x = decay(n=300, rate=20.0, amp=0.05)
    x = 0.18 + x  # the detector measures the distance to the mass
    v, acc = np.gradient(x, t), np.gradient(np.gradient(x, t), t)
    head = ",".join(f"Run {r}: {q}" for r in (1, 2) for q in ("Time (s)", "Position (m)", "Velocity (m/s)",
                                                             "Acceleration (m/s^2)"))
    rows = "".join(",".join(f"{c:.6f}" for c in (ti, xi, vi, ai, ti, xi, vi, ai)) + "\n"
                   for ti, xi, vi, ai in zip(t, x, v, acc))
    p = write(tmp_path, "detector.csv", head + "\n" + rows)
    with pytest.raises(DataError, match=r"2 runs side by side \(Run 1, Run 2\)"):
        read_with_spec(p, None)
    with pytest.raises(DataError, match=r"no column looks like the angle .*'Position \(m\)' looks like displacement: "
                                        r"set \[recording\] displacement_column"):
        read_with_spec(p, RecordingSpec(run=1))
    ts = read_with_spec(p, RecordingSpec(run=1, displacement_column="Position (m)"))
    np.testing.assert_allclose(ts.theta, x, atol=5e-7)


def test_numbered_angle_columns_under_one_clock_are_not_runs(tmp_path):
    t, a = decay(n=200)
    p = write(tmp_path, "two.csv", "Time (s),Angle 1 (deg),Angle 2 (deg)\n" + "".join(
        f"{ti},{math.degrees(ai)},{-math.degrees(ai)}\n" for ti, ai in zip(t, a)))
    np.testing.assert_allclose(read_with_spec(p, RecordingSpec(angle_column=3)).theta, -a, rtol=1e-12)


# -- files escfit cannot read: one line, exit 2 --------------------------------------------------------------
def _zip(path, members):
    import zipfile

    with zipfile.ZipFile(path, "w") as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return path


def _foreign_files(tmp_path):
    """The first bytes of each kind as its program writes them (the formats' magic numbers)."""
    import gzip

    ole2 = b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1" + bytes(504)  # a compound document's header sector
    return [
        (write(tmp_path, "run.xls", ole2), r"an Excel 97-2003 workbook \(.xls.*save the sheet as CSV"),
        (_zip(tmp_path / "run.xlsx", {"[Content_Types].xml": "<Types/>", "xl/workbook.xml": "<workbook/>"}),
         r"an Excel workbook \(.xlsx\): export it as CSV"),
        (_zip(tmp_path / "run.ods", {"mimetype": "application/vnd.oasis.opendocument.spreadsheet",
                                     "content.xml": "<x/>"}), r"an OpenDocument file \(.ods\): save the sheet as CSV"),
        (_zip(tmp_path / "pendel.labx", {"a.labx": "<cassylab/>", "b.labx": "<cassylab/>"}),
         r"a zip archive holding no single CASSY Lab data file \(a.labx, b.labx\): extract the .labx"),
        (_zip(tmp_path / "run.gambl", {"data.json": "{}"}), r"a Vernier Graphical Analysis file \(.gambl\): export"),
        (write(tmp_path, "run.cmbl", gzip.compress(b'<?xml version="1.0"?><Document/>')),
         r"a compressed Logger Pro file \(.cmbl\): open it in Logger Pro and File > Export As > CSV"),
        (write(tmp_path, "beats.wav", b"RIFF\x24\x08\x00\x00WAVEfmt " + bytes(64)),
         r"a sound recording \(WAV\): escfit does not read audio"),
        (write(tmp_path, "Pendulum.phyphox", b'<?xml version="1.0" encoding="UTF-8"?><phyphox version="1.14" '
               b'locale="en">\n  <title>Pendulum</title>\n<data-containers>\n<container init="0.1,0.2">acc'
               b'</container></data-containers></phyphox>\n'),
         r"a phyphox experiment file \(.phyphox.*'Export data' with 'CSV \(Comma, decimal point\)'"),
        (write(tmp_path, "seiko.dat", bytes(range(256)) * 2),
         r"a binary file of unknown layout .*save it as CSV \(or text\) from the program that wrote it"),
    ]


def test_files_escfit_cannot_read_get_one_line_and_exit_2(tmp_path):
    from click.testing import CliRunner

    from escfit.cli.main import cli

    scene = write(tmp_path, "s.toml", 'model = "balance"\n[oscillator]\nomega0 = 5.0\n[effects.viscous]\nC = 0.1\n')
    for path, message in _foreign_files(tmp_path):
        for extra in ([], ["--format", "raw"]):
            out = tmp_path / "out.h5"
            result = CliRunner().invoke(cli, ["fit", str(path), "--scene", str(scene), "--out", str(out), *extra])
            lines = [s for s in result.output.splitlines() if s.strip()]
            assert result.exit_code == 2 and len(lines) == 1, (path.name, extra, result.output)
            assert lines[0].startswith(f"escfit: error: {path}: ") and re.search(message, lines[0]), lines
            assert not out.exists()


# -- one column of angles -----------------------------------------------------------------------------------
@pytest.mark.parametrize("head", ["", "Angle (deg)\n"])
def test_a_column_of_angles_asks_for_the_sample_rate_and_reads_with_it(tmp_path, head):
    from click.testing import CliRunner

    from escfit.cli.main import cli

    t, a = decay(n=500, rate=50.0)
    p = write(tmp_path, "angles.txt", head + "".join(f"{math.degrees(ai):.6f}\n" for ai in a))
    with pytest.raises(DataError, match=r"angles.txt:\d: a single column .*and no time: set the samples per second "
                                        r"with \[recording\] sample_rate \(e.g. sample_rate = \"50 Hz\"\) or "
                                        r"--sample-rate 50$"):
        read_with_spec(p, RecordingSpec(angle_unit="deg"))
    ts = read_with_spec(p, RecordingSpec(angle_unit="deg", sample_rate=50.0))
    np.testing.assert_allclose(ts.time, t, atol=1e-12)
    np.testing.assert_allclose(ts.theta, a, atol=math.radians(1e-6))
    scene = write(tmp_path, "s.toml", 'model = "balance"\n[oscillator]\nomega0 = 8.0\n[effects.viscous]\nC = 0.4\n')
    result = CliRunner().invoke(cli, ["fit", str(p), "--scene", str(scene), "--out", str(tmp_path / "o.h5")])
    assert result.exit_code == 2 and "--sample-rate 50" in result.output and len(result.output.strip().splitlines()) == 1
    # with the rate given the fit recovers the written decay: amplitude e^(-0.2 t) is C = 0.4 1/s, and
    # the period 1/1.3 s (the turning-point fit holds omega0 at the measured period)
    scene = write(tmp_path, "free.toml", 'model = "balance"\n[oscillator]\nomega0 = { value = 8.0, vary = true, '
                  'min = 5, max = 11 }\n[effects.viscous]\nC = { value = 0.3, vary = true, min = 0, max = 2 }\n')
    from escfit.inference import fit

    res = fit(scene, str(p), n_starts=1, recording={"sample_rate": "50 Hz", "angle_unit": "deg"})
    assert res.summary()["viscous.C"]["estimate"] == pytest.approx(0.4, rel=1e-3)
    period = float(re.search(r"period ([0-9.]+) s", " ".join(res.notes)).group(1))
    assert period == pytest.approx(1 / 1.3, rel=1e-3)


# -- a Tracker track that starts with the bob held --------------------------------------------------------------
TRACKER_SCENE = """model = "balance"
[oscillator]
restoring = "pendulum"
omega0 = { value = 4.5, vary = true, min = 3, max = 6 }
[effects.viscous]
C = { value = 0.1, vary = true, min = 0, max = 1 }
[effects.coulomb]
R = { value = 0.05, vary = true, min = 0, max = 1 }
[observation]
model = "waveform"
"""


def _tracker_with_hold(tmp_path, hanging_first: bool):
    """Tracker's File > Export > Data of a 0.5 m pendulum filmed at 30 fps (track-name line, ``t x y``
    in m, 1 mm of tracking noise): the bob is held (hanging first, then pulled aside, when
    ``hanging_first``; else held at 20 deg and pulled to 25 deg), shakes in the hand, and is let go
    at t = 2.4 s from 25 deg. The truth after the release is the exact pendulum solution."""
    from escfit.balance.waveform import sample_theta
    from escfit.core.scene import load_scene

    w0, c, r, release = math.sqrt(9.81 / 0.5), 0.12, 0.05, 2.4
    truth = load_scene("truth.toml", text=f'model = "balance"\n[oscillator]\nrestoring = "pendulum"\n'
                                          f"omega0 = {w0!r}\ntheta0 = {math.radians(25.0)!r}\n[effects.viscous]\n"
                                          f"C = {c!r}\n[effects.coulomb]\nR = {r!r}\n")
    t = np.arange(0.0, 16.0, 1 / 30)
    theta, status = sample_theta(truth.system(truth.params.values()), np.maximum(t - release, 0.0), "dop853")
    assert status in ("ok", "stopped")
    if hanging_first:  # at rest, pulled out over 1 s, held with a shaking hand, let go
        ramp = np.clip(t - 1.0, 0.0, 1.0)
        hand = math.radians(25.0) * (0.5 - 0.5 * np.cos(math.pi * ramp)) + \
            math.radians(1.0) * np.sin(2 * math.pi * 1.3 * t) * ((t > 1.2) & (t < 2.3))
    else:  # held at 20 deg, pulled to 25 deg over 0.4 s, let go
        ramp = np.clip((t - 2.0) / 0.4, 0.0, 1.0)
        hand = math.radians(20.0) + math.radians(5.0) * (0.5 - 0.5 * np.cos(math.pi * ramp))
    angle = np.where(t < release, hand, theta)
    rng = np.random.default_rng(5)
    x = 0.5 * np.sin(angle) + 1e-3 * rng.standard_normal(t.size)
    y = -0.5 * np.cos(angle) + 1e-3 * rng.standard_normal(t.size)
    p = write(tmp_path, "track.txt", "mass A\nt\tx\ty\n" + "".join(f"{a:.4f}\t{b:.5f}\t{d:.5f}\n"
                                                               for a, b, d in zip(t, x, y)))
    return p, {"oscillator.omega0": w0, "viscous.C": c, "coulomb.R": r}


@pytest.mark.parametrize("hanging_first", [False, True])
def test_tracker_track_held_before_the_release(tmp_path, hanging_first):
    from escfit.inference import fit

    data, truth = _tracker_with_hold(tmp_path, hanging_first)
    scene = write(tmp_path, "s.toml", TRACKER_SCENE)
    res = fit(scene, str(data), n_starts=1)
    ref = float(re.search(r"turning points after the reference one at t = ([0-9.]+) s", " ".join(res.notes)).group(1))
    assert abs(ref - 2.4) < 0.05, res.notes  # the release, not the hold nor the hand's shaking
    summary = res.summary()
    # the release instant within a frame (its interval, from a start at rest seen at 30 fps, can be
    # narrower than the hand's last shake allows)
    assert abs(summary["observation.t_release"]["estimate"] - 2.4) < 1 / 30
    for name, value in truth.items():
        row = summary[name]
        assert row["lo95"] <= value <= row["hi95"], (name, value, row["lo95"], row["hi95"])


def test_tracker_export_with_trailing_tabs_and_untracked_frames(tmp_path):
    """Tracker writes some exports with a tab at the end of the name and header lines
    (``<TAB>mass A<TAB><TAB>``, ``t<TAB>x<TAB>y<TAB>``) and a frame the track was not marked in as
    its time and empty cells (``4.367<TAB><TAB>``): read, those frames left out with a note,
    the angle about the arc's centre that of the pendulum drawn (a sinusoid, exactly)."""
    t = np.arange(0.0, 12.0, 1 / 30)
    angle = 0.3 * np.cos(2 * math.pi * t / 1.2)
    x, y = -150.0 + 400.0 * np.sin(angle), -650.0 + 400.0 * (1 - np.cos(angle))
    lines = ["\tmass A\t\t", "t\tx\ty\t"]
    gaps = {131, 202, 203}
    lines += [f"{a:.3f}\t\t" if i in gaps else f"{a:.3f}\t{b:.3f}\t{d:.3f}" for i, (a, b, d) in enumerate(zip(t, x, y))]
    series = read_with_spec(write(tmp_path, "track.txt", "\n".join(lines) + "\n"), RecordingSpec())
    assert series.time.size == t.size - len(gaps)
    from escfit.analysis.recordings.rawsteps import notes_of

    assert any("3 frame(s) without a position" in n for n in notes_of(series.meta)), series.meta
    keep = np.array([i not in gaps for i in range(t.size)])
    got = series.theta - np.median(series.theta) + np.median(angle[keep])
    assert np.max(np.abs(np.abs(got) - np.abs(angle[keep]))) < 0.01


# -- escfit's own text formats through the shared tokenizer ------------------------------------------------------
@pytest.mark.parametrize("end", ["\r\n", "\r", "\r\r\n"])
def test_escfit_formats_read_any_line_end_and_name_the_editors_line(tmp_path, end):
    """A unit curve and a pulse train saved with Windows, old-Mac or CASSY-style line ends read as
    with LF, and an error names the line an editor shows (the tokenizer's lines)."""
    from escfit.analysis.recordings.pulses import read_pulses
    from escfit.analysis.recordings.unit_curve import read_unit_curve

    curve = ["# notch_deg: 6", "swing,amplitude_deg", *(f"{k},{200 * math.exp(-0.05 * k):.4f}" for k in range(12))]
    ref = read_unit_curve(write(tmp_path, "lf.csv", "\n".join(curve) + "\n"))
    got = read_unit_curve(write(tmp_path, "ends.csv", end.join(curve) + end))
    np.testing.assert_array_equal(got.value, ref.value)
    np.testing.assert_allclose(np.degrees(got.value[:2]), [200.0, 200 * math.exp(-0.05)], atol=1e-4)
    np.testing.assert_array_equal(got.swing, ref.swing)
    pulses = ["# notches: 60", "time_s,kind", '0.0702,"notch"', "0.1087,zero", "0.1501,notch"]
    train = read_pulses(write(tmp_path, "p.csv", end.join(pulses) + end))
    np.testing.assert_allclose(train.time, [0.0702, 0.1087, 0.1501])
    assert train.zero.tolist() == [False, True, False]
    bad = curve[:5] + ["5,1,2e"] + curve[6:]
    with pytest.raises(DataError, match=r"bad.csv:6"):
        read_unit_curve(write(tmp_path, "bad.csv", end.join(bad) + end))


def test_escfit_formats_still_refuse_what_they_refused(tmp_path):
    """The tokenizer does not widen what escfit's own formats accept: numbers are plain (no decimal
    comma), the text UTF-8, the fields comma-separated."""
    from escfit.analysis.recordings.unit_curve import read_unit_curve

    with pytest.raises(DataError, match=r"dc.csv:3: expected 1 fields \(swing;amplitude_deg\), found 2"):
        read_unit_curve(write(tmp_path, "dc.csv", "# notch_deg: 6\nswing;amplitude_deg\n0;199,5\n1;190,2\n"))
    with pytest.raises(DataError, match=r"latin.csv:2: not UTF-8 text"):
        read_unit_curve(write(tmp_path, "latin.csv", "swing,amplitude_deg\n# \xb0\n0,1\n".encode("latin-1")))


def test_a_compressed_cassy_labx_reads_as_the_plain_one(tmp_path):
    """CASSY Lab 2 saves a .labx compressed as a zip whose data.xml is the XML."""
    from escfit.analysis.recordings.detect import detect_format

    from .test_readers_formats import _labx

    t, a = decay(n=300)
    plain = write(tmp_path, "plain.labx", _labx(t, a))
    packed = _zip(tmp_path / "packed.labx", {"data.xml": _labx(t, a)})
    assert detect_format(packed) == "cassy"
    got, ref = read_with_spec(packed, None), read_with_spec(plain, None)
    np.testing.assert_array_equal(got.theta, ref.theta)
    np.testing.assert_allclose(got.theta, a, rtol=1e-15)
    assert "compressed, data.xml" in got.meta["source_format"]


def test_init_picks_a_run_with_run_and_refuses_without(tmp_path):
    import tomllib

    from click.testing import CliRunner

    from escfit.cli.main import cli

    t, x = decay(n=400, rate=50.0, amp=0.05)
    p = write(tmp_path, "motion.csv", "Time 1 (s),Position 1 (m),Time 2 (s),Position 2 (m)\n" + "".join(
        f"{ti},{xi},{ti},{2 * xi}\n" for ti, xi in zip(t, x)))
    runner = CliRunner()
    refused = runner.invoke(cli, ["init", str(p), "--out", str(tmp_path / "a.toml")])
    assert refused.exit_code == 2 and len(refused.output.strip().splitlines()) == 1
    assert "2 runs side by side (Run 1, Run 2); set [recording] run (1-based)" in refused.output
    assert not (tmp_path / "a.toml").exists()
    done = runner.invoke(cli, ["init", str(p), "--run", "2", "--out", str(tmp_path / "b.toml")])
    assert done.exit_code == 0, done.output
    doc = tomllib.loads((tmp_path / "b.toml").read_text())
    assert doc["recording"]["run"] == 2 and doc["recording"]["displacement_column"] == "Position (m)"
    assert doc["oscillator"]["coordinate"] == "linear"
    assert "amplitude about the centre 0.1 m at the release" in done.output  # run 2 is twice run 1


def test_cassy_path_symbol_s_is_a_length_not_the_time(tmp_path):
    """CASSY names the path sensor's reading ``s`` (``s / m``): a length, never a second clock."""
    t, a = decay(n=300)
    s = 0.0919 * a  # the path over the wheel's radius is the angle (Drehpendel.labx's formula)
    p = write(tmp_path, "weg.csv", "t / s;s / m;α / °\n" + "".join(
        f"{_comma(ti)};{_comma(si)};{_comma(math.degrees(ai))}\n" for ti, si, ai in zip(t, s, a)))
    ts = read_with_spec(p, None)
    np.testing.assert_allclose(ts.time, t, atol=1e-15)
    np.testing.assert_allclose(ts.theta, a, rtol=1e-12, atol=1e-15)
    d = read_with_spec(p, RecordingSpec(displacement_column="s / m"))
    assert d.quantity == "displacement"
    np.testing.assert_allclose(d.theta, s, rtol=1e-12, atol=1e-15)
