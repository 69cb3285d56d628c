"""Every real recording at hand, read raw by ``escfit fit RAW --scene SCENE.toml``.

The recordings are the shared folder's (``../shared/realdata``, with their licences and
``SOURCE.txt``; the ``gpl_tests_only`` ones are read from there and never copied) and the
repository's ``datasets/real``; the scenes in ``datasets/real/scenes`` hold at most a
``[recording]`` table about the file.  For each free decay the test checks that it reads, that
escfit finds the turning points counted by eye on plots of the record (the counts below, the
reference included), and that the fit agrees with the source's own value where the source gives
one.  What is not a free decay (a driven pendulum, a sound, a struck rod, beating modes) must be
read and refused in one line that says why.  What escfit cannot do yet is an expected failure
naming what it waits for.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from click.testing import CliRunner

from escfit.cli.main import cli
from escfit.results import load_fit

from .conftest import DATASETS, SHARED

SCENES = DATASETS / "real" / "scenes"
REAL = SHARED / "realdata"
OURS = DATASETS / "real"


@dataclass(frozen=True)
class Decay:
    """A free decay: its file, scene, the turning points counted by eye, and the source's value."""

    name: str
    data: Path
    scene: str
    turns: int  # counted by eye on a plot of the record, the reference turning point included
    slack: int = 0  # turning points at the noise floor that the eye cannot settle
    reference: tuple = ()  # (what, check(result) -> (value, source value, tolerance))
    slow: bool = False
    pending: str = ""  # what it waits for
    verdict: str = "determined"  # what the fit should say it determines


@dataclass(frozen=True)
class NotADecay:
    name: str
    data: Path
    scene: str
    refusal: str  # regex the one-line refusal must match
    pending: str = ""


def omega0(res) -> float:
    return float(res.summary()["oscillator.omega0"]["estimate"])


def small_swing_period(res) -> float:
    """2 pi / omega1 of the fit: the period of a small swing with the fitted damping."""
    rows = res.summary()
    c = float(rows["viscous.C"]["estimate"]) if "viscous.C" in rows else 0.0
    return 2 * math.pi / math.sqrt(omega0(res) ** 2 - 0.25 * c * c)


def measured_period(res) -> float:
    """The record's period as escfit measured it (the count note)."""
    for note in res.notes:
        m = re.search(r"turning points(?: \([^)]*\))? after the reference one .*; period ([0-9.]+) s", note)
        if m:
            return float(m.group(1))
    raise AssertionError(f"no period note in {res.notes}")


def counted(res) -> int:
    for note in res.notes:
        m = re.match(r"(\d+) turning points(?: \([^)]*\))? after the reference one", note)
        if m:
            return int(m.group(1)) + 1
    raise AssertionError(f"no count note in {res.notes}")


def jensen_first_period(res):
    """compute.py of the source fits exp(-zeta w_n t) through the first two maxima of this file
    (find_peaks on the raw degrees): zeta = 5.462062e-4 with w_n in deg/s, i.e. the first
    maximum falls to the second by the factor the samples show.  The fitted model must lose the
    same in that period: its expected readings at the two maxima."""
    import numpy as np

    obs = res.group("observed_data")
    lsq = res.group("least_squares")
    t = obs["time"].values
    y, e = obs["reading"].values, lsq["expected"].values
    first = (t > 0.45) & (t < 0.8)
    second = (t > 1.2) & (t < 1.55)
    ratio_data = y[second].max() / y[first].max()
    ratio_model = e[second].max() / e[first].max()
    return ratio_model, ratio_data, 0.01


def damped_cosine(path: Path, constant: bool):
    """The source notebook's own fit of the rate (03_bicycle_wheel_inertia.ipynb): scipy's curve_fit of
    ``a exp(lambda t) cos(omega t)`` to the rate samples, a viscous decay with C = -2 lambda; with
    ``constant``, plus a phase and a constant (the gyro's zero, which the notebook leaves out)."""
    import numpy as np
    from scipy.optimize import curve_fit

    t, v = np.loadtxt(path, delimiter=",", skiprows=1, unpack=True)
    if not constant:
        p, _ = curve_fit(lambda t, a, lam, w: a * np.exp(lam * t) * np.cos(w * t), t, v, p0=(v[0], -0.01, 14.0
                         if "radial" in path.name else 4.4))
        return -2.0 * p[1]
    p, _ = curve_fit(lambda t, a, lam, w, ph, b: a * np.exp(lam * t) * np.cos(w * t + ph) + b, t, v,
                     p0=(v[0], -0.01, 14.0 if "radial" in path.name else 4.4, 0.0, 0.0))
    return -2.0 * p[1]


def viscous_c(res) -> float:
    return float(res.summary()["viscous.C"]["estimate"])


GYRO = OURS / "gyro_torsion_resonance"
RADIAL = GYRO / "bicycle-wheel-radial-inertia-rate-gyro-measurement.csv"
AXIAL = GYRO / "bicycle-wheel-axial-inertia-rate-gyro-measurement.csv"

DECAYS = [
    # fitted without drag from 146 deg: fitted again from one period later, R is four times larger
    # and C 15 % smaller (each several standard errors): the split of the losses is not determined
    Decay("encoder pendulum, 1 kHz, from 135 deg (jensen)", OURS / "encoder_pendulum_jensen" /
          "pendulum_free_swing_data_02.txt", "encoder_pendulum_jensen.toml", 15,
          slow=True, verdict="partly determined",
          reference=(("the source's zero-crossing period, 0.65 s (amplitude-dependent)",
                      lambda r: (measured_period(r), 0.65, 0.03)),
                     ("compute.py's decay of the first period (first two maxima)", jensen_first_period))),
    # the rate's zeros (the angle's turning points): 9 and 6 sign changes of the rate on a plot
    Decay("bicycle wheel on a torsion rod, rate gyro", RADIAL, "gyro_torsion_radial.toml", 9,
          reference=(("the source's period, 0.422 s", lambda r: (small_swing_period(r), 0.422, 0.002)),
                     ("the notebook's damped cosine of the rate, C = -2 lambda",
                      lambda r: (viscous_c(r), damped_cosine(RADIAL, False), 0.01)))),
    Decay("bicycle wheel as a compound pendulum, rate gyro", AXIAL, "gyro_compound_axial.toml", 6,
          slow=True,
          reference=(("the source's period, 1.429 s", lambda r: (small_swing_period(r), 1.429, 0.005)),
                     ("the notebook's damped cosine of the rate with the gyro's zero added",
                      lambda r: (viscous_c(r), damped_cosine(AXIAL, True), 0.006)))),
    Decay("encoder pendulum, Arduino 50 Hz, 17 s", REAL / "gpl_tests_only" / "arduino_encoder_galileo_ferrucci" /
          "galileo_2024-07-19_09-27-13.csv", "galileo_encoder_pendulum.toml", 30,
          slow=True,
          reference=(("the source's period, 1.16 s", lambda r: (small_swing_period(r), 1.16, 0.02)),)),
    # from 66 deg without drag: fitted again from one period later, R is 18 % larger (7 of its
    # standard errors) and C 4 % smaller (10): the split of the losses is not determined
    Decay("encoder pendulum, Arduino 50 Hz, 90 s from 69 deg", REAL / "gpl_tests_only" /
          "arduino_encoder_galileo_ferrucci" / "galileo_2024-07-19_15-25-54.csv", "galileo_encoder_pendulum.toml",
          129, slack=2, slow=True, verdict="partly determined",
          reference=(("the source's period, 1.36 s", lambda r: (small_swing_period(r), 1.36, 0.02)),)),
    # an 82-degree swing fitted without drag: the envelope wanders about the C + R decay by half of
    # what separates a viscous from a friction decay (the model's damping law is not the record's),
    # so the split of C and R is not determined; the loss and omega0 are
    Decay("string pendulum, 17 s from 82 deg (video)", OURS / "string_pendulum_video" / "trial1_rawdata.txt",
          "string_pendulum_trial1.toml", 19, verdict="partly determined"),
    # fitted without drag, the record swings 2.4 deg (29 standard errors) more than the model at its end
    # and its envelope wanders by 0.8 of what separates a viscous from a friction decay: C and R not split
    Decay("string pendulum, 116 s (video)", OURS / "string_pendulum_video" / "lab1_data.txt",
          "string_pendulum_lab1.toml", 142, slow=True, verdict="partly determined",
          reference=(("the source's Q ~ 140", lambda r: (omega0(r) / float(r.summary()["viscous.C"]["estimate"]),
                                                          140.0, 35.0)),)),
    Decay("Pohl wheel, video-tracked rim marker", OURS / "pohl_heilaut" / "derived" / "tracker_video_frames.csv",
          "pohl_tracker.toml", 11,
          reference=(("Tracker's damped sine, B = 4.610 rad/s", lambda r: (omega0(r), 4.610, 0.025)),)),
    Decay("multi-arm pendulum, free swing (10 kHz encoder)", OURS / "multiarm_pendulum" /
          "SingleDataFreeSwing_1_Dt_0_0001.mat", "multiarm_free_swing.toml", 15, slow=True,
          reference=(("the authors' omega0 = 8.01 rad/s", lambda r: (omega0(r), 8.01, 0.12)),)),
    # a 90-degree swing: the envelope wanders about the C + R decay, which leaves their split open
    Decay("multi-arm pendulum, 55 s from 90 deg", OURS / "multiarm_pendulum" /
          "SinglePendulumDataForParameterEstimation.mat", "multiarm_estimation.toml", 134, slow=True,
          verdict="partly determined",
          reference=(("the authors' omega0 = 8.01 rad/s", lambda r: (omega0(r), 8.01, 0.12)),)),
    # from 105 deg the record loses about 0.8 deg every half swing down to 50 deg and less below, which
    # no sum of viscous damping and friction does (0.80 against the fit's 0.95 deg at 92 deg, 11
    # standard errors): the law is refuted and the split of C and R is not determined
    Decay("torsion pendulum, CASSY Lab 2 .labx", REAL / "gpl_tests_only" / "cassy_phyprakit" / "Drehpendel.labx",
          "cassy_torsion_pendulum.toml", 186, slack=2, slow=True, verdict="partly determined",
          reference=(("the source's period, about 1.79 s", lambda r: (measured_period(r), 1.79, 0.01)),)),
    Decay("torsion pendulum, CASSY Lab 2 .labx, 0.2 s sampling", REAL / "gpl_tests_only" / "cassy_phyprakit" /
          "CassyExample.labx", "cassy_torsion_pendulum.toml", 0,
          pending="a turning-point analysis for under 16 samples per period (this record has 9.7)"),
    Decay("Pohl wheel, Tracker .trk (the rim marker's track)", OURS / "pohl_heilaut" / "raw" / "Dämpfung.trk",
          "pohl_tracker_trk.toml", 11,
          reference=(("Tracker's damped sine, B = 4.610 rad/s", lambda r: (omega0(r), 4.610, 0.025)),)),
]

NOT_DECAYS = [
    NotADecay("impact test of a structure (LabVIEW .lvm, two records)", REAL / "labview_impact_ladisk" /
              "long_single_header_multi_ch.lvm", "labview_impact.toml", r"beating modes"),
    NotADecay("driven torsion pendulum with its drive (CASSY text export)", REAL / "gpl_tests_only" / "cassy_phyprakit" /
              "Cassy.txt", "cassy_driven.toml", r"a drive|keeps its amplitude|driven"),
    NotADecay("sound recording (phyphox audio scope)", REAL / "gpl_tests_only" / "picoscope_phyprakit" / "AudioData.csv",
              "sound_recording.toml", r"not a free decay|sustained|second oscillation"),
    NotADecay("struck metal rod (PicoScope CSV)", REAL / "gpl_tests_only" / "picoscope_phyprakit" / "Wellenform.csv",
              "struck_rod.toml", r"second oscillation|beating modes"),
    NotADecay("Pohl wheel's forced-resonance table", OURS / "pohl_heilaut" / "derived" /
              "forced_resonance_2025-12-19.csv", "resonance_table.toml", r"time goes backwards|no column looks like the time"),
]


def run(tmp_path: Path, data: Path, scene: str):
    out = tmp_path / "fit.h5"
    result = CliRunner().invoke(cli, ["fit", str(data), "--scene", str(SCENES / scene), "--method", "leastsq",
                                      "--out", str(out)])
    return result, out


def _params(cases, kind):
    marks = []
    for c in cases:
        m = []
        if getattr(c, "slow", False):
            m.append(pytest.mark.slow)
        if c.pending:
            m.append(pytest.mark.xfail(reason=f"waits for {c.pending}", strict=False))
        marks.append(pytest.param(c, id=c.name, marks=m))
    return marks


@pytest.mark.parametrize("case", _params(DECAYS, "decay"))
def test_every_real_decay_reads_counts_and_fits(tmp_path, case: Decay):
    if not case.data.exists():
        pytest.skip(f"{case.data} not present")
    result, out = run(tmp_path, case.data, case.scene)
    assert result.exit_code == 0, result.output
    res = load_fit(out)
    assert abs(counted(res) - case.turns) <= case.slack, (counted(res), case.turns, res.notes)
    assert res.verdict == case.verdict, res.warnings
    for what, check in case.reference:
        value, source, tolerance = check(res)
        assert abs(value - source) <= tolerance, (what, value, source, tolerance)


@pytest.mark.parametrize("case", _params(NOT_DECAYS, "refusal"))
def test_what_is_not_a_free_decay_is_read_and_refused_in_one_line(tmp_path, case: NotADecay):
    if not case.data.exists():
        pytest.skip(f"{case.data} not present")
    result, out = run(tmp_path, case.data, case.scene)
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert re.search(case.refusal, lines[0]) and case.data.name in lines[0], lines[0]
    assert not out.exists()
