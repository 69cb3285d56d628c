"""Every real file in ../shared/realdata read as it comes, checked against numbers read off the
file independently (a few lines of numpy or re here) or stated in its SOURCE.txt.

Skipped when ../shared is not beside the checkout (set ESCFIT_SHARED to point elsewhere); the GPL
files under gpl_tests_only are read from there and never copied into the repository.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from escfit.core.errors import DataError
from escfit.analysis.recordings.detect import candidates, read_with_spec
from escfit.analysis.recordings.recording_spec import RecordingSpec

from .conftest import SHARED

REAL = SHARED / "realdata"
GPL = REAL / "gpl_tests_only"
pytestmark = pytest.mark.skipif(not REAL.is_dir(), reason="../shared/realdata is not beside the checkout")


def test_cassy_labx_channels_against_the_xml():
    for name, n, t_end in (("CassyExample.labx", 1335, 266.8), ("Drehpendel.labx", 19361, 193.6)):
        path = GPL / "cassy_phyprakit" / name
        text = path.read_text(encoding="utf-8-sig")
        block = re.search(r"<quantity>Winkel</quantity>.*?<values[^>]*>(.*?)</values>", text).group(1)
        phi = np.array([float(v) for v in re.findall(r"<value>([^<]*)</value>", block)])
        ts = read_with_spec(path, None)
        assert candidates(path) == ["cassy"] and ts.time.size == n == phi.size
        assert ts.time[-1] == pytest.approx(t_end, abs=0.05)
        np.testing.assert_allclose(ts.theta, phi, rtol=0, atol=0)  # SOURCE: Winkel phi is rad (arc / radius)


def test_cassy_text_export_against_loadtxt():
    path = GPL / "cassy_phyprakit" / "Cassy.txt"
    raw = path.read_bytes().decode("utf-8-sig").replace("\r\r\n", "\n").replace(",", ".").split("\n")
    table = np.array([[float(x) for x in line.split("\t")] for line in raw[5:] if line.strip()])
    ts = read_with_spec(path, None)
    assert ts.time.size == 6609 == table.shape[0] and ts.time[-1] == pytest.approx(table[-1, 0]) == pytest.approx(660.8, abs=0.05)
    np.testing.assert_allclose(ts.theta, table[:, 2])
    assert np.median(np.diff(ts.time)) == pytest.approx(0.1, abs=1e-3)


def test_labview_files():
    path = REAL / "labview_impact_ladisk" / "long_single_header_multi_ch.lvm"
    with pytest.raises(DataError, match=r"no column looks like the angle in the header \['F \(g\)', 'm_1 \(m/s\^2\)'"):
        read_with_spec(path, None)
    lines = path.read_text().splitlines()
    data = np.array([[float(x) for x in line.split("\t")[1:4]] for line in lines[22:] if line.strip()])
    ts = read_with_spec(path, RecordingSpec(angle_column="m_1", angle_unit="rad"))  # reading only: m/s^2 as numbers
    assert ts.time.size == 16384 == data.shape[0]  # SOURCE: two 8192-sample records under one header
    np.testing.assert_allclose(ts.theta, data[:, 1])
    np.testing.assert_allclose(np.diff(ts.time), 0.000977, rtol=1e-9)
    assert "announcing 8192 samples" in ts.meta["notes"]
    with pytest.raises(DataError, match=r"short.lvm: only 10 samples"):
        read_with_spec(REAL / "labview_impact_ladisk" / "short.lvm", RecordingSpec(angle_column=1, angle_unit="rad"))


def test_tracker_trk_frequency_matches_the_authors_damped_sine():
    ts = read_with_spec(REAL / "pohl_heilaut" / "raw" / "Dämpfung.trk", None)
    assert ts.time.size == 240 and ts.time[-1] == pytest.approx(239 * 0.0334710743801653)
    x = ts.theta - np.polyval(np.polyfit(ts.time, ts.theta, 1), ts.time)
    ups = ts.time[1:][(x[:-1] < 0) & (x[1:] >= 0)]
    omega = 2 * math.pi / np.median(np.diff(ups))
    assert omega == pytest.approx(4.610, rel=0.03)  # Tracker's DampedSine fit: B = 4.610 rad/s


def test_arduino_encoder_csvs_need_their_unit():
    for name, t_end in (("galileo_2024-07-19_09-27-13.csv", 17.36), ("galileo_2024-07-19_15-25-54.csv", 90.4)):
        path = GPL / "arduino_encoder_galileo_ferrucci" / name
        with pytest.raises(DataError, match=r"no unit given \(rad assumed\).* set \[recording\] angle_unit = \"deg\""):
            read_with_spec(path, None)
        ts = read_with_spec(path, RecordingSpec(angle_unit="deg"))
        raw = np.loadtxt(path, delimiter=",", skiprows=1)
        assert ts.time.size == raw.shape[0] and ts.time[-1] == pytest.approx(t_end, abs=0.03)  # SOURCE's span
        np.testing.assert_allclose(ts.theta, np.radians(raw[:, 1]))


def test_encoder_pendulum_metadata_header_gives_the_rate():
    path = REAL / "encoder_pendulum_jensen" / "pendulum_free_swing_data_02.txt"
    ts = read_with_spec(path, RecordingSpec(angle_unit="deg"))
    values = np.loadtxt(path, skiprows=2)
    assert ts.time.size == 5000 == values.size and ts.time[-1] == pytest.approx(4.999)  # 1000 Hz from line 2
    assert math.degrees(ts.theta[0]) == pytest.approx(-135.27)  # SOURCE: starts at -135.27 deg


def test_rate_gyro_is_read_as_an_angular_velocity():
    for name, n, t_end in (("bicycle-wheel-radial-inertia-rate-gyro-measurement.csv", 1001, 2.0),
                           ("bicycle-wheel-axial-inertia-rate-gyro-measurement.csv", 2317, 4.632)):
        path = REAL / "gyro_torsion_resonance" / name
        with pytest.raises(DataError, match=r"'angular_velocity' looks like angular velocity: set \[recording\] "
                                            r"velocity_column"):
            read_with_spec(path, None)
        with pytest.raises(DataError, match=r"gives no unit: set \[recording\] velocity_unit"):
            read_with_spec(path, RecordingSpec(velocity_column="angular_velocity"))
        ts = read_with_spec(path, RecordingSpec(velocity_column="angular_velocity", velocity_unit="rad/s"))
        raw = np.loadtxt(path, delimiter=",", skiprows=1)
        assert ts.quantity == "angular_velocity" and ts.time.size == n and ts.time[-1] == pytest.approx(t_end)
        np.testing.assert_allclose(ts.theta, raw[:, 1])


def test_picoscope_and_phyphox_audio_exports():
    path = GPL / "picoscope_phyprakit" / "Wellenform.csv"
    ts = read_with_spec(path, RecordingSpec(angle_column="Channel A", angle_unit="rad"))
    raw = np.loadtxt(path, delimiter=",", skiprows=3)
    assert ts.time.size == 7817 == raw.shape[0]
    np.testing.assert_allclose(ts.time, raw[:, 0] / 1000.0)  # the units row says ms
    assert np.median(np.diff(ts.time)) == pytest.approx(1.28e-6, rel=1e-3)
    ts = read_with_spec(GPL / "picoscope_phyprakit" / "PicoScopeData.txt", RecordingSpec(angle_column=2,
                                                                                         angle_unit="rad"))
    assert ts.time.size == 50 and ts.time[0] == pytest.approx(-52.95e-3, abs=1e-5)
    path = GPL / "picoscope_phyprakit" / "AudioData.csv"
    assert candidates(path) == ["phyphox"]
    ts = read_with_spec(path, RecordingSpec(angle_column="Recording (a.u.)", angle_unit="rad"))
    assert ts.time.size == 480 and np.median(np.diff(ts.time)) == pytest.approx(2.088e-5, rel=1e-3)


@pytest.mark.parametrize("relative, message", [
    ("pohl_heilaut/raw/Dämpfung.lml", r"a LabPlot project \(.lml, xz-compressed\): export its spreadsheet as CSV"),
    ("pohl_heilaut/raw/V2.csv", r"V2.csv:1: no column looks like the angle in the header \['A_Skt', 'T_s'\]; set "
                                r"\[recording\] angle_column"),
    ("pohl_heilaut/derived/forced_resonance_2025-12-19.csv", r"forced_resonance_2025-12-19.csv:\d+ \[T_s\]: time goes "
                                                             r"backwards"),
    ("string_pendulum_video/lab1_data.txt", r"lab1_data.txt:1: 3 columns and no header: .* set \[recording\] "
                                            r"angle_column"),
])
def test_files_that_need_a_key_or_are_no_decay_get_one_line(relative, message):
    with pytest.raises(DataError, match=message) as info:
        read_with_spec(REAL / relative, None)
    assert "\n" not in str(info.value)
