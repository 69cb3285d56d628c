"""Bare angles of balance scenes are radians; one no balance or pendulum can reach is refused.

A bare number is read in the canonical unit (rad).  ``theta0 = 300`` meant as degrees would
otherwise run 48 turns and report success, so a bare angle beyond two turns (4*pi rad) is
refused with one line naming the file and key and suggesting the unit; a value written with
its unit is taken as written.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from click.testing import CliRunner

from escfit import SceneError, UnitError, load_scene
from escfit.balance.observation import observation_from_table

from .conftest import balance_toml

ROOT = Path(__file__).resolve().parents[1]
THETA0_300 = ('scene.toml [oscillator].theta0: bare number 300 is read as radians (47.7 turns); did you mean '
              '"300 deg"? write the unit to be explicit (or "300 rad")')


def test_bare_theta0_of_300_is_refused_with_one_clear_line():
    with pytest.raises(UnitError) as info:
        load_scene("scene.toml", text=balance_toml(theta0=300))
    assert str(info.value) == THETA0_300  # 300 / (2 pi) = 47.75 turns
    assert isinstance(info.value, SceneError) and isinstance(info.value, ValueError)


def test_cli_simulate_exits_2_with_one_line_naming_the_key(tmp_path):
    from escfit.cli.main import cli

    path = tmp_path / "scene.toml"
    path.write_text(balance_toml(theta0=300))
    result = CliRunner().invoke(cli, ["simulate", str(path)])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "[oscillator].theta0: bare number 300 is read as radians" in lines[0]
    assert str(path) in lines[0] and '"300 deg"' in lines[0]


def test_an_angle_with_its_unit_is_taken_as_written():
    deg = load_scene("s.toml", text=balance_toml(theta0="300 deg"))
    assert deg.params["oscillator.theta0"].value == pytest.approx(300 * math.pi / 180, rel=1e-14)
    rad = load_scene("s.toml", text=balance_toml(theta0="300 rad"))  # explicit: not second-guessed
    assert rad.params["oscillator.theta0"].value == 300.0


@pytest.mark.parametrize("theta0", [4 * math.pi - 1e-9, -(4 * math.pi - 1e-9), 6.28, 0.5])
def test_bare_angles_up_to_two_turns_are_accepted(theta0):
    scene = load_scene("s.toml", text=balance_toml(theta0=theta0))
    assert scene.params["oscillator.theta0"].value == theta0


@pytest.mark.parametrize("theta0", [4 * math.pi + 1e-9, -13.0])
def test_bare_angles_beyond_two_turns_are_refused(theta0):
    with pytest.raises(UnitError, match=r"\[oscillator\]\.theta0: bare number .* is read as radians"):
        load_scene("s.toml", text=balance_toml(theta0=theta0))


WINDOW = '[[effects.escapement]]\nkind = "impulse"\nfrom = {lo}\nto = {hi}\nX = 10.0\n'


@pytest.mark.parametrize("text, key, bare", [
    (balance_toml(effects=WINDOW.format(lo=-16, hi='"16 deg"')), "[effects.escapement 1].from", "-16"),
    (balance_toml(effects=WINDOW.format(lo='"-16 deg"', hi=16)), "[effects.escapement 1].to", "16"),
    (balance_toml(effects="[effects.banking]\nangle = 330\n"), "[effects.banking].angle", "330"),
    (balance_toml(effects="[effects.hairspring]\nangles = [-20, 20]\nomega0 = [9.0, 10.0, 11.0]\n")
     .replace("omega0 = 10.0\n", "", 1), "[effects.hairspring].angles[1]", "-20"),
    (balance_toml().replace("theta0 = 1.0", "theta0 = { value = 300, vary = true }"),
     "[oscillator].theta0.value", "300"),
    (balance_toml().replace("theta0 = 1.0", "theta0 = { value = 1.0, vary = true, min = 0, max = 360 }"),
     "[oscillator].theta0.max", "360"),
    (balance_toml().replace("theta0 = 1.0", "theta0 = { value = 1.0, vary = true, min = -360, max = 3 }"),
     "[oscillator].theta0.min", "-360"),
])
def test_every_angle_of_a_balance_scene_is_checked(text, key, bare):
    with pytest.raises(UnitError) as info:
        load_scene("s.toml", text=text)
    assert str(info.value).startswith(f"s.toml {key}: bare number {bare} is read as radians"), str(info.value)
    assert f'did you mean "{bare} deg"?' in str(info.value)


def test_window_limits_banking_and_spring_angles_with_units_are_converted():
    text = balance_toml(theta0="300 deg", effects=WINDOW.format(lo='"-16 deg"', hi='"16 deg"')
                        + '[effects.banking]\nangle = "330 deg"\n')
    scene = load_scene("s.toml", text=text)
    assert scene.effect("escapement").windows[0].lo == pytest.approx(-16 * math.pi / 180, rel=1e-14)
    assert scene.effect("banking").angle == pytest.approx(330 * math.pi / 180, rel=1e-14)


@pytest.mark.parametrize("key", ["sigma", "offset"])
def test_observation_angles_are_checked(key):
    with pytest.raises(UnitError, match=rf"\[observation\]\.{key}: bare number 20 is read as radians"):
        observation_from_table({"model": "notches", "notch_deg": 6, key: 20}, "s.toml", "notches")
    obs = observation_from_table({"model": "notches", "notch_deg": 6, key: "20 deg"}, "s.toml", "notches")
    assert next(p for p in obs.params if p.name == f"observation.{key}").value == pytest.approx(math.pi / 9)


def test_notch_angle_is_degrees_when_bare_and_as_written_with_a_unit():
    bare = observation_from_table({"model": "notches", "notch_deg": 6}, "s.toml", "notches")
    written = observation_from_table({"model": "notches", "notch_deg": "6 deg"}, "s.toml", "notches")
    assert bare.notch == pytest.approx(math.pi / 30, rel=1e-14) and written.notch == pytest.approx(math.pi / 30, rel=1e-14)


def test_other_families_keep_their_bare_angles():
    """The verge counts escape-wheel angles over several turns: its readers do not refuse them."""
    text = (ROOT / "datasets/verge/m739.toml").read_text().replace('phi_cut = "1485 deg"', "phi_cut = 25.918")
    assert 'phi_cut = 25.918' in text
    scene = load_scene("m739.toml", text=text)
    assert scene.params["verge.phi_cut"].value == pytest.approx(25.918)


def test_every_shipped_balance_scene_loads():
    """No shipped scene writes an implausible bare angle."""
    paths = sorted((ROOT / "datasets").rglob("*.toml"))
    loaded = 0
    for path in paths:
        text = path.read_text()
        if 'model = "balance"' not in text:
            continue
        load_scene(path)
        loaded += 1
    assert loaded >= 20


def _timegrapher(table):
    from escfit.balance.observation.timegrapher import TimegrapherObservation

    return TimegrapherObservation.from_table(table, "s.toml", lift_set=math.radians(52))


def _passage_times(table):
    from escfit.balance.observation.passage_times import PassageTimeObservation

    return PassageTimeObservation.from_table(table, "s.toml")


def _waveform(table):
    from escfit.balance.observation.waveform import WaveformObservation

    return WaveformObservation.from_table(table, "s.toml", t_release=0.0, period=0.5, offset=0.0, offset_rate=0.0,
                                          sigma=0.01)


@pytest.mark.parametrize("read, key", [(_timegrapher, "lift_angle"), (_passage_times, "offset"),
                                       (_waveform, "quantum")])
def test_bare_angles_of_other_observation_models_are_checked(read, key):
    # a timegrapher's lift angle of 52 written bare would be 52 rad (8.3 turns)
    with pytest.raises(UnitError, match=rf"\.{key}: bare number 52 is read as radians"):
        read({key: 52})
    read({key: "52 deg"} if key != "quantum" else {key: "0.1 deg"})  # with the unit: accepted
