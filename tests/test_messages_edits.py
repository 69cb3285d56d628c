"""Every message names an edit the user can make: a misspelling's valid values, the scene line that
widens a range or starts a parameter elsewhere, a `next:` command a shell takes as it is, and
the angle unit to set when the swing says the unit is wrong (at init as at fit)."""

from __future__ import annotations

import math
import shlex
import tomllib
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.balance.scene import OBSERVATION_MODELS
from escfit.cli.main import cli
from escfit.core.errors import DataError, SceneError
from escfit.core.scene import load_scene
from escfit.inference.identifiability import bound_warnings
from escfit.inference.lsq import LeastSquaresResult
from escfit.inference.reconcile import NOT_DETERMINED, verdict
from escfit.likelihood.consistency import Implied

from .conftest import balance_toml
from .cli_folder import new_folder

# --- did you mean ---------------------------------------------------------------------------------


def test_misspelled_observation_model_lists_every_model_and_names_the_closest(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(balance_toml() + '[observation]\nmodel = "wavefrom"\n')
    with pytest.raises(SceneError) as info:
        load_scene(str(scene))
    message = str(info.value)
    assert "did you mean 'waveform'?" in message
    for model in ("amplitude", "notches", "waveform", "timegrapher", "passage_times"):
        assert repr(model) in message
    assert set(OBSERVATION_MODELS) == {"amplitude", "notches", "waveform", "timegrapher", "passage_times"}
    # through the command line: one line, exit 2, before any data is read
    r = CliRunner().invoke(cli, ["fit", str(tmp_path / "absent.csv"), "--scene", str(scene)])
    assert r.exit_code == 2


@pytest.mark.parametrize("effects, wrong, right", [
    ("[effects.viscus]\nC = 0.1\n", "viscus", "viscous"),
    ("[effects.coulomb]\nRR = 0.1\n", "RR", "R"),
])
def test_misspelled_effect_or_key_names_the_closest(tmp_path, effects, wrong, right):
    scene = tmp_path / "s.toml"
    scene.write_text(balance_toml(effects=effects))
    with pytest.raises(SceneError, match=rf"\['{wrong}'\] \(did you mean '{right}'\?\)"):
        load_scene(str(scene))


def test_misspelled_restoring_and_model_name_the_closest(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(balance_toml().replace("[oscillator]\n", '[oscillator]\nrestoring = "pendulm"\n'))
    with pytest.raises(SceneError, match=r"'spring', 'pendulum'; got 'pendulm' \(did you mean 'pendulum'\?\)"):
        load_scene(str(scene))
    scene.write_text(balance_toml().replace('model = "balance"', 'model = "balanse"'))
    with pytest.raises(SceneError, match=r"unknown model 'balanse' \(did you mean 'balance'\?\)"):
        load_scene(str(scene))


# --- the scene line that widens a range -----------------------------------------------------------

def _lsq(names, values, lower, upper):
    k = len(names)
    return LeastSquaresResult(list(names), np.array(values, float), np.full(k, 0.01), np.eye(k), 100.0, 1.0, 0.01,
                              200, 1, True, "", dict(zip(names, map(float, values))),
                              lower=np.array(lower, float), upper=np.array(upper, float))


def _scene_line(message: str) -> tuple[str, dict]:
    """The ``[table] key = { ... }`` a message asks for, parsed as TOML."""
    edit = message.split("set ", 1)[1].split(" in the scene")[0]
    table, line = edit.split("] ", 1)
    doc = tomllib.loads(f"{table}]\n{line}\n")
    path = []
    while "vary" not in doc:  # [effects.viscous] nests a table in a table
        (key, doc), = doc.items()
        path.append(key)
    return ".".join(path), doc


def test_bound_warning_names_the_key_the_starter_scene_lacks_and_a_wider_range():
    # the release instant and the release angle are set from the record: not written in a starter scene
    lsq = _lsq(["observation.t_release", "oscillator.theta0", "viscous.C"], [0.2029, -3.271, 0.3],
               [0.0699, -3.271, 0.0], [0.2029, -2.18, 5.0])
    messages = bound_warnings(None, lsq)
    assert len(messages) == 2, messages
    where, table = _scene_line(messages[0])
    assert where == "observation.t_release" and table["vary"] is True
    assert table["min"] == pytest.approx(0.0699) and table["max"] > 0.2029 and table["value"] == pytest.approx(0.2029)
    assert table["max"] - table["min"] == pytest.approx(2 * (0.2029 - 0.0699), rel=1e-4)  # doubled on that side
    where, table = _scene_line(messages[1])
    assert where == "oscillator.theta0" and table["min"] < -3.271 and table["max"] == pytest.approx(-2.18)
    # a positive parameter's lower bound is not widened into negative values
    lsq = _lsq(["viscous.C"], [0.5], [0.5], [5.0])
    (message,) = bound_warnings(None, lsq)
    assert _scene_line(message)[0] == "effects.viscous.C" and _scene_line(message)[1]["min"] == 0.0


def _verdict(observation_model: str | None):
    lsq = _lsq(["oscillator.omega0", "viscous.C"], [7.0, 0.1], [5.0, 0.0], [12.0, 1.0])
    extra = {"observation": {"model": observation_model}} if observation_model else {}
    problem = SimpleNamespace(scene=SimpleNamespace(extra=extra), curves=[])
    implied = Implied("oscillator.omega0", 7.0, 10.93, 0.01, "the record's period is 0.575 s")
    return verdict(problem, lsq, [implied])


def test_not_determined_names_the_start_and_offers_waveform_only_when_not_set():
    status, _, message = _verdict("waveform")
    assert status == NOT_DETERMINED
    assert "model = \"waveform\"" not in message  # the scene has it already
    where, table = _scene_line("set " + message.split("implied value, ")[1] + " in the scene")
    assert where == "oscillator.omega0" and table["value"] == pytest.approx(10.93) and table["max"] >= 12.0
    status, _, message = _verdict(None)
    assert "[observation] model = \"waveform\"" in message


# --- a next: line a shell takes as it is ----------------------------------------------------------

OMEGA0, C, RATE, DURATION = 4.0, 0.03, 50.0, 40.0


def _decay(amplitude: float, rate: float = RATE) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(0.0, DURATION, 1.0 / rate)
    wd = math.sqrt(OMEGA0 ** 2 - C ** 2 / 4)
    return t, amplitude * np.exp(-C * t / 2) * np.cos(wd * t)


def _write(path: Path, t, theta) -> Path:
    path.write_text("\n".join(f"{a:.9g},{b:.9g}" for a, b in zip(t, theta)) + "\n")  # no header: no unit said
    return path


def test_next_line_is_quoted_and_its_outputs_do_not_clash(tmp_path):
    folder = tmp_path / "my data"
    folder.mkdir()
    data = _write(folder / "swing 1.csv", *_decay(0.3))
    runner = CliRunner()
    with new_folder(tmp_path) as here:
        Path(here, "my scene_fit.h5").write_text("an earlier fit")
        Path(here, "my scene.html").write_text("its report")
        r = runner.invoke(cli, ["init", str(data), "--spring", "--angle-unit", "rad", "--out", "my scene.toml"])
        assert r.exit_code == 0, r.output
        line = next(x for x in r.output.splitlines() if x.startswith("next: "))[len("next: "):]
        words = shlex.split(line)
        assert words[:3] == ["escfit", "fit", str(data)]
        options = dict(zip(words[3::2], words[4::2]))
        assert options["--scene"] == "my scene.toml" and Path(here, options["--scene"]).is_file()
        assert options["--out"] == "my scene_2_fit.h5" and options["--report"] == "my scene_2.html"
        assert not Path(here, options["--out"]).exists() and not Path(here, options["--report"]).exists()


# --- angle units judged from the swing, at init as at fit -----------------------------------------

def test_degrees_read_as_radians_by_option_are_refused_at_init_naming_the_unit(tmp_path):
    t, theta = _decay(math.radians(130.0), rate=1000.0)  # as an encoder logs: a few degrees between samples
    data = _write(tmp_path / "deg.csv", t, np.degrees(theta))  # 130 "rad" = 21 turns
    runner = CliRunner()
    with new_folder(tmp_path) as here:
        for kind in ("--pendulum", "--spring"):
            r = runner.invoke(cli, ["init", str(data), kind, "--angle-unit", "rad"])
            assert r.exit_code == 2, r.output
            assert 'set [recording] angle_unit = "deg" (--angle-unit deg)' in r.output
            assert "20.7 turns" in r.output  # 130 rad / 2 pi
            assert len(r.output.strip().splitlines()) == 1 and not list(Path(here).glob("*.toml"))


def test_radians_read_as_degrees_by_option_are_warned_at_init_and_at_fit(tmp_path):
    from escfit.balance.family import make_problem

    t, theta = _decay(math.radians(40.0))
    data = _write(tmp_path / "rad.csv", t, theta)  # 0.70 rad, read as 0.70 deg
    runner = CliRunner()
    with new_folder(tmp_path) as here:
        r = runner.invoke(cli, ["init", str(data), "--pendulum", "--angle-unit", "deg"])
        assert r.exit_code == 0, r.output
        warning = next(x for x in r.output.splitlines() if x.startswith("warning: read in deg"))
        assert "largest swing is 0.698 deg" in warning and "it is 40 deg" in warning
        assert 'set [recording] angle_unit = "rad" (--angle-unit rad)' in warning
        scene = load_scene(str(Path(here) / "rad.toml"))
        problem = make_problem(scene, str(data))
        assert any('angle_unit = "rad"' in w for w in problem.data_warnings)
    # with the unit right there is nothing to say
    with new_folder(tmp_path):
        r = runner.invoke(cli, ["init", str(data), "--pendulum", "--angle-unit", "rad"])
        assert r.exit_code == 0 and "angle_unit" not in r.output.replace("angle_unit = 'rad'", "")


def test_a_pendulum_past_180_degrees_is_refused_in_the_fit_too(tmp_path):
    from escfit.balance.problems.release import swing_unit_warnings

    tp = SimpleNamespace(theta=np.array([-4.0, 3.9]), time=np.array([1.0, 2.0]), release_time=0.0,
                         release_theta=4.1, centre=lambda times: np.zeros_like(times))
    series = SimpleNamespace(quantity="angle", meta={"angle_unit": "rad"}, source="x.csv")
    with pytest.raises(DataError, match=r"past the 180 deg a pendulum can swing.*angle_unit = \"deg\""):
        swing_unit_warnings(series, tp, "pendulum")
    assert swing_unit_warnings(series, tp, "spring") == []  # 4.1 rad is a balance's swing


@pytest.mark.parametrize("name, key", [
    ("viscous.C", "[effects.viscous] C"), ("oscillator.theta0", "[oscillator] theta0"),
    ("observation.t_release", "[observation] t_release"), ("coulomb.R[load=330.66]", "[effects.coulomb] R"),
    ("escapement[2].X", "[[effects.escapement]] number 2, X"), ("fit.kappa", "[fit.loads] kappa"),
    ("geneva.mu", "[geneva] mu"), ("friction.mu", "[friction] mu"), ("rig.k", "[rig] k"),
])
def test_parameters_are_named_where_the_scene_writes_them(name, key):
    from escfit.core.names import scene_key

    assert scene_key(name) == key
