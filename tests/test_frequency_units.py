"""Every unit naming a frequency means the same angular frequency at every key that takes one.

The rule (escfit.core.units.angular_frequency): a unit counting cycles is times 2 pi
("2.5 Hz" = 5 pi rad/s), an angle per time is converted (rpm, turn/s, bph = beats per hour, a
beat being half a period), a bare number or a bare 1/s is rad/s.  The references below are the
definitions written by hand (f Hz = 60 f rpm = 7200 f bph = 360 f deg/s = 2 pi f rad/s), not pint.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from escfit import SceneError, UnitError, load_scene
from escfit.core.units import angular_frequency, angular_frequency_factor, to_canonical

from .conftest import balance_toml

ROOT = Path(__file__).resolve().parents[1]

# unit -> the text of the frequency f (Hz) in that unit, by the unit's definition
UNITS = {
    "Hz": lambda f: f"{f!r} Hz",
    "kHz": lambda f: f"{f / 1e3!r} kHz",
    "mHz": lambda f: f"{f * 1e3!r} mHz",
    "bph": lambda f: f"{7200 * f!r} bph",
    "rpm": lambda f: f"{60 * f!r} rpm",
    "rps": lambda f: f"{f!r} rps",
    "turn/s": lambda f: f"{f!r} turn/s",
    "cycles/s": lambda f: f"{f!r} cycles/s",
    "deg/s": lambda f: f"{360 * f!r} deg/s",
    "rad/s": lambda f: f"{2 * math.pi * f!r} rad/s",
    "1/s": lambda f: f"{2 * math.pi * f!r} 1/s",  # a bare 1/s is rad/s (the physics convention)
    "s^-1": lambda f: f"{2 * math.pi * f!r} s^-1",
    "bare": lambda f: 2 * math.pi * f,
}


# -- the keys: each reads the value (a TOML value or the text of one) and returns it in rad/s --------

def _omega0(v):
    return load_scene("s.toml", text=balance_toml(omega0=v)).params["oscillator.omega0"].value


def _hairspring(v):
    text = balance_toml(effects=f"[effects.hairspring]\nangles = [0.5]\nomega0 = [{_toml(v)}, 10.0]\n")
    return load_scene("s.toml", text=text.replace("omega0 = 10.0\n", "", 1)).params["hairspring.omega0[1]"].value


def _toml(v):
    return repr(v) if isinstance(v, float) else f'"{v}"'


def _spin(v):
    text = (ROOT / "datasets" / "verge" / "m739.toml").read_text()
    text, n = re.subn(r'(?m)^spin = "30000 rpm"', f"spin = {_toml(v)}", text)
    assert n == 1
    return load_scene("m739.toml", text=text).params["verge.spin"].value


def _geneva_sigma(v):
    from escfit.geneva.data import read_speed_trace
    from escfit.geneva.problem import SIGMA, GenevaProblem

    head = ('model = "geneva"\n[geneva]\nslots = 4\ndriver_inertia = "3e-6 lbf*inch*s^2"\n'
            'follower_inertia = "50e-6 lbf*inch*s^2"\ntorque = "0.08 lbf*inch"\n'
            'mu = { value = 0.3, vary = true, prior = "uniform(0, 0.6)" }\n')
    scene = load_scene("g.toml", text=head + f"[observation]\nsigma = {_toml(v)}\n")
    data = read_speed_trace(ROOT / "datasets" / "geneva" / "synthetic_four_pin_trace.csv")
    return GenevaProblem(scene, data).params[SIGMA].value


def _amplitude_offset_rate(v):
    from escfit.balance.observation.amplitude import AmplitudeObservation

    obs = AmplitudeObservation.from_table({"offset_rate": v}, "s.toml [observation]")
    return next(p.value for p in obs.params if p.name == "observation.offset_rate")


def _waveform(key, quantity):
    def read(v):
        from escfit.balance.observation.waveform import WaveformObservation

        obs = WaveformObservation.from_table({key: v}, "s.toml [observation]", t_release=0.0, period=0.5, offset=0.0,
                                             offset_rate=0.0, sigma=0.01, quantity=quantity)
        if key == "quantum":
            return obs.quantum
        return next(p.value for p in obs.params if p.name == f"observation.{key}")
    return read


# key -> (its reader, a frequency f in Hz such a key holds)
KEYS = {
    "[oscillator] omega0": (_omega0, 2.5),
    "[effects.hairspring] omega0[1]": (_hairspring, 2.5),
    "[verge] spin": (_spin, 500.0),
    "geneva [observation] sigma": (_geneva_sigma, 2.5),
    "amplitude [observation] offset_rate": (_amplitude_offset_rate, 1e-3),
    "waveform of angles [observation] offset_rate": (_waveform("offset_rate", "angle"), 1e-3),
    "waveform of rates [observation] sigma": (_waveform("sigma", "angular_velocity"), 0.01),
    "waveform of rates [observation] offset": (_waveform("offset", "angular_velocity"), 0.01),
    "waveform of rates [observation] quantum": (_waveform("quantum", "angular_velocity"), 0.01),
}


@pytest.mark.parametrize("unit", UNITS)
@pytest.mark.parametrize("key", KEYS)
def test_every_frequency_unit_means_the_same_rad_per_s_at_every_key(key, unit):
    read, f = KEYS[key]
    if key == "[verge] spin" and unit == "bare":  # a spin rate needs its unit (the report's inputs are in rpm)
        with pytest.raises(UnitError, match=r"\[verge.spin\]: give the spin rate with its unit"):
            read(UNITS[unit](f))
        return
    assert read(UNITS[unit](f)) == pytest.approx(2 * math.pi * f, rel=1e-12)


@pytest.mark.parametrize("value, why", [("2.5 turn", "not an angular frequency"), ("2.5 s", "not an angular frequency"),
                                        ("5 percent/s", "not an angular frequency"),
                                        ("2 rad*Hz", "mixes Hz (cycles) with an angle"),
                                        ("2 Hz**2*s", "not an angular frequency")])
@pytest.mark.parametrize("key", KEYS)
def test_what_is_not_one_angular_frequency_is_refused_naming_key_value_and_units(key, value, why):
    with pytest.raises(UnitError) as err:
        KEYS[key][0](value)
    msg = str(err.value)
    assert why in msg and repr(value) in msg and len(msg.splitlines()) == 1
    assert "rad/s" in msg and "Hz" in msg
    assert key.split()[-1].replace("[1]", "") in msg  # the key, with its file


def test_the_examples_of_the_rule():
    five_pi = 5 * math.pi
    for text in ("2.5 Hz", "18000 bph", "150 rpm", "2.5 turn/s", "2.5 cycles/s", "900 deg/s"):
        assert angular_frequency(text, "w") == pytest.approx(five_pi, rel=1e-14), text
    assert angular_frequency("15.70796 rad/s", "w") == pytest.approx(15.70796, rel=1e-14)
    assert angular_frequency("942 /min", "w") == pytest.approx(942 / 60, rel=1e-14)  # no cycle, no angle: rad
    assert angular_frequency(3.0, "w") == 3.0
    assert angular_frequency_factor("Hz", "w") == pytest.approx(2 * math.pi, rel=1e-15)
    assert angular_frequency_factor("1/s", "w") == 1.0
    assert angular_frequency_factor("rpm", "w") == pytest.approx(2 * math.pi / 60, rel=1e-15)


# -- the inverse: keys in cycles or events per second, and the damping rate C -------------------------

@pytest.mark.parametrize("value, hz", [("500 Hz", 500.0), ("0.5 kHz", 500.0), ("500 /s", 500.0), ("500 s^-1", 500.0),
                                       ("30000 /min", 500.0)])
def test_a_sample_rate_takes_hz(value, hz):
    from escfit.analysis.recordings.recording_spec import recording_spec_from_table

    assert recording_spec_from_table({"sample_rate": value}, "s.toml").sample_rate == pytest.approx(hz, rel=1e-14)


@pytest.mark.parametrize("value", ["3141.6 rad/s", "30000 rpm", "500 turn/s", "5 m"])
def test_a_sample_rate_refuses_an_angle_per_time(value):
    from escfit.analysis.recordings.recording_spec import recording_spec_from_table

    with pytest.raises(SceneError) as err:
        recording_spec_from_table({"sample_rate": value}, "s.toml")
    assert "sample_rate" in str(err.value) and repr(value) in str(err.value) and "Hz" in str(err.value)


def test_the_sample_rate_option_refuses_rpm_on_the_command_line(tmp_path):
    from escfit.cli.main import cli

    data = tmp_path / "angles.csv"
    data.write_text("angle\n" + "".join(f"{0.5 * math.cos(0.1 * i):.6f}\n" for i in range(400)))
    r = CliRunner().invoke(cli, ["init", str(data), "--sample-rate", "30000 rpm", "--angle-unit", "rad",
                                 "--out", str(tmp_path / "s.toml")])
    assert r.exit_code == 2, r.output
    assert "'30000 rpm'" in r.output and "Hz" in r.output and len(r.output.strip().splitlines()) == 1


@pytest.mark.parametrize("value, c", [(0.5, 0.5), ("0.5/s", 0.5), ("0.5 1/s", 0.5), ("0.5 s^-1", 0.5)])
def test_viscous_c_is_a_rate_per_second(value, c):
    scene = load_scene("s.toml", text=balance_toml(effects=f"[effects.viscous]\nC = {_toml(value)}\n"))
    assert scene.params["viscous.C"].value == c


@pytest.mark.parametrize("value", ["0.5 Hz", "0.5 rpm", "0.5 rad/s"])
def test_viscous_c_refuses_a_frequency(value):
    with pytest.raises(UnitError, match=r"s.toml \[effects.viscous\].C: .*not a frequency.*1/s"):
        load_scene("s.toml", text=balance_toml(effects=f'[effects.viscous]\nC = "{value}"\n'))
    assert to_canonical("0.5/s", "rate_per_s", "w") == 0.5


# -- columns of angular velocity: the unit of a recording's column, and a Geneva speed trace ----------

@pytest.mark.parametrize("unit, rad_s_per_unit", [("rad/s", 1.0), ("deg/s", math.pi / 180), ("rpm", 2 * math.pi / 60),
                                                  ("Hz", 2 * math.pi), ("turn/s", 2 * math.pi),
                                                  ("bph", 2 * math.pi / 7200), ("1/s", 1.0)])
def test_a_velocity_column_in_any_frequency_unit(tmp_path, unit, rad_s_per_unit):
    from escfit.analysis.recordings.detect import read_with_spec
    from escfit.analysis.recordings.recording_spec import RecordingSpec, parse_option

    assert parse_option("velocity_unit", unit, "--velocity-unit") == unit
    t = np.arange(600) / 100.0
    w = 0.8 * np.exp(-0.2 * t) * np.cos(2 * math.pi * 1.3 * t)  # rad/s
    p = tmp_path / "gyro.csv"
    p.write_text("Time (s),Gyro\n" + "".join(f"{ti:.17g},{wi / rad_s_per_unit:.17g}\n" for ti, wi in zip(t, w)))
    ts = read_with_spec(p, RecordingSpec(velocity_column="Gyro", velocity_unit=unit))
    np.testing.assert_allclose(ts.theta, w, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("unit", ["percent/s", "m/s", "turn"])
def test_a_velocity_unit_that_is_no_angular_frequency_is_refused(unit):
    from escfit.analysis.recordings.recording_spec import parse_option

    with pytest.raises(SceneError, match=r"--velocity-unit: expected an angular velocity unit"):
        parse_option("velocity_unit", unit, "--velocity-unit")


@pytest.mark.parametrize("unit, rad_s_per_unit", [("rad/s", 1.0), ("rpm", 2 * math.pi / 60), ("Hz", 2 * math.pi)])
def test_a_geneva_speed_trace_in_any_frequency_unit(tmp_path, unit, rad_s_per_unit):
    from escfit.geneva.data import read_speed_trace

    p = tmp_path / "trace.csv"
    p.write_text(f"time [s],speed [{unit}]\n0,0\n0.001,{10 / rad_s_per_unit!r}\n0.002,{20 / rad_s_per_unit!r}\n")
    np.testing.assert_allclose(read_speed_trace(p).speed, [0.0, 10.0, 20.0], rtol=1e-12)


# -- end to end: the simulated half period of an undamped spring ---------------------------------------

@pytest.mark.parametrize("omega0", ["2.5 Hz", "18000 bph", "150 rpm", "2.5 turn/s"])
def test_simulate_gives_the_half_period_of_the_frequency(tmp_path, omega0):
    from escfit.cli.main import cli

    scene = tmp_path / "s.toml"
    scene.write_text(f'model = "balance"\n[oscillator]\nomega0 = "{omega0}"\ntheta0 = "200 deg"\n[run]\nswings = 3\n')
    r = CliRunner().invoke(cli, ["simulate", str(scene), "--json"])
    assert r.exit_code == 0, r.output
    half = json.loads(r.output)["half_period"]
    assert half == pytest.approx([0.2] * 3, rel=1e-6)  # 1 / (2 f), f = 2.5 Hz
