"""What a column measures and which column is the decay, judged by shape (escfit.analysis).

Synthetic tables of known truth: a free decay ``theta'' + C theta' + omega0**2 theta = 0`` (closed
form: ``A exp(-C t/2) cos(omega_d t)``, ``omega_d = sqrt(omega0**2 - C**2/4)``) beside columns that
are not it: a function generator's steady sine, white noise, the kinetic energy
``theta'**2 / 2`` (per unit inertia), a clock.  Each case is read as ``escfit fit`` reads it
(:func:`escfit.balance.family.read_data`, :func:`escfit.balance.family.make_problem`) and as
``escfit init`` does.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from .cli_folder import new_folder
from escfit.analysis.channel import MARGIN, MIN_SCORE, choose_channel
from escfit.analysis.quantity import MAX_TURNS, SMALL_DEG, check_quantity, swing_shape
from escfit.balance.family import make_problem, read_data
from escfit.cli.main import cli
from escfit.core.errors import DataError

OMEGA0, C = 5.0, 0.06
RATE, DURATION = 50.0, 60.0


def _decay(amplitude=0.3):
    t = np.arange(0.0, DURATION, 1.0 / RATE)
    wd = math.sqrt(OMEGA0 ** 2 - C ** 2 / 4)
    theta = amplitude * np.exp(-C * t / 2) * np.cos(wd * t)
    rate = amplitude * np.exp(-C * t / 2) * (-C / 2 * np.cos(wd * t) - wd * np.sin(wd * t))
    return t, theta, rate


def _write(path: Path, header: list[str] | None, columns) -> Path:
    lines = [",".join(header)] if header else []
    lines += [",".join(f"{v:.9g}" for v in row) for row in zip(*columns)]
    path.write_text("\n".join(lines) + "\n")
    return path


def _init(tmp_path, data, *args):
    runner = CliRunner()
    with new_folder(tmp_path) as here:
        result = runner.invoke(cli, ["init", str(data), "--spring", *args], catch_exceptions=False)
        scene = Path(here) / f"{Path(data).stem}.toml"
        return result, (scene if scene.exists() else None)


RNG = np.random.default_rng(20240607)


def test_function_generator_beside_the_sensor_init_chooses_the_sensor_and_the_fit_finds_omega0(tmp_path):
    t, theta, _ = _decay()
    generator = 2.5 * np.sin(2 * math.pi * 2.3 * t)  # volts of a steady drive, 2.3 Hz
    data = _write(tmp_path / "rig.csv", ["t", "ch1", "ch2"], [t, generator, theta + 0.001 * RNG.standard_normal(t.size)])
    with pytest.raises(DataError, match=r"no column looks like the angle.*by shape: 'ch2' (0\.9\d|1\.00).*'ch1' 0\.0\d "
                                        r"\(a steady sine at 2\.3 Hz"):
        read_data(data)  # the fit does not guess an unnamed column; it says which one the shapes point to
    result, scene = _init(tmp_path, data)
    assert result.exit_code == 0, result.output
    assert "column 'ch2' chosen: a decaying oscillation" in result.output and "(a drive?)" in result.output
    doc = tomllib.loads(scene.read_text())
    assert doc["recording"]["angle_column"] == "ch2"
    from escfit.inference import fit

    res = fit(scene, str(data), n_starts=2)
    assert res.summary()["oscillator.omega0"]["estimate"] == pytest.approx(OMEGA0, rel=0.005)


def test_named_columns_the_reader_chooses_the_decay_over_a_drive_and_over_noise(tmp_path):
    t, theta, _ = _decay()
    drive = np.degrees(0.2 * np.sin(2 * math.pi * 1.7 * t))
    noise = RNG.standard_normal(t.size)
    for other, words in ((drive, "(a drive?)"), (noise, "(noise?)")):
        data = _write(tmp_path / "two.csv", ["t (s)", "theta (deg)", "phi (deg)"], [t, np.degrees(theta), other])
        series = read_data(data)
        np.testing.assert_allclose(series.theta, theta, atol=1e-7)
        assert "column 'theta (deg)' chosen" in series.meta["notes"] and words in series.meta["notes"]
        with pytest.raises(DataError, match=r"no column looks like the angle.*by shape: 'b' (0\.9\d|1\.00)"):  # unnamed too
            read_data(_write(tmp_path / "ab.csv", ["t", "a", "b"], [t, other, theta]))


def test_scores_of_a_decay_a_drive_noise_an_energy_and_a_clock():
    t, theta, rate = _decay()
    choice = choose_channel(t, {"theta": theta, "drive": np.sin(2 * math.pi * 2.3 * t), "noise": RNG.standard_normal(t.size),
                                "energy": rate ** 2 / 2, "clock": t.copy()})
    assert choice.chosen == "theta" and choice.scores["theta"] > 0.95
    assert all(choice.scores[c] < 0.1 for c in ("drive", "noise", "energy", "clock")), choice.scores
    assert "energy" in choice.why["energy"] and "monotone" in choice.why["clock"]
    # the decay's periodogram peak is its damped frequency
    assert swing_shape(t, theta).frequency == pytest.approx(math.sqrt(OMEGA0 ** 2 - C ** 2 / 4) / (2 * math.pi), rel=1e-3)


def test_kinetic_energy_alone_is_refused_as_an_energy_at_fit_and_at_init(tmp_path):
    t, _, rate = _decay()
    data = _write(tmp_path / "ke.csv", ["t", "y"], [t, rate ** 2 / 2])
    with pytest.raises(DataError, match=r"by shape: 'y' 0\.00 \(an even function of the swing, such as an energy"):
        read_data(data)
    with pytest.raises(DataError, match=r"such as an energy \(two peaks per swing, never below its floor\).*not an angle"):
        read_data(data, recording={"angle_column": "y", "angle_unit": "rad"})
    result, scene = _init(tmp_path, data)
    assert result.exit_code == 2 and scene is None and "energy" in result.output


def test_an_energy_column_beside_the_angle_is_passed_over(tmp_path):
    t, theta, rate = _decay()
    data = _write(tmp_path / "both.csv", ["t", "u", "v"], [t, rate ** 2 / 2, theta])
    result, scene = _init(tmp_path, data)
    assert result.exit_code == 0, result.output
    assert tomllib.loads(scene.read_text())["recording"]["angle_column"] == "v"
    assert "'u' 0 %: an even function of the swing, such as an energy" in result.output
    # named as two angles, the reader itself passes the energy over
    series = read_data(_write(tmp_path / "named.csv", ["t (s)", "angle 1 (rad)", "angle 2 (rad)"], [t, rate ** 2 / 2, theta]))
    np.testing.assert_allclose(series.theta, theta, atol=1e-8)


def test_a_pendulum_bobs_position_starts_omega0_at_its_period(tmp_path):
    """A pendulum recorded by its bob's horizontal position (a tracker's x, here 180 units of
    swing) and named as a pendulum: the record is a displacement, fitted as a linear oscillator,
    so omega0 starts at 2 pi / period.  The pendulum's period law with the swing read as an angle
    (180 "rad") wrote omega0 3.3 times too large, which the fit then refused."""
    t, theta, _ = _decay()
    data = _write(tmp_path / "bob.csv", ["t (s)", "x (m)"], [t, 600.0 * theta])
    runner = CliRunner()
    with new_folder(tmp_path) as here:
        result = runner.invoke(cli, ["init", str(data), "--pendulum"], catch_exceptions=False)
        assert result.exit_code == 0, result.output
        doc = tomllib.loads((Path(here) / "bob.toml").read_text())
    assert doc["oscillator"].get("coordinate") == "linear"
    assert doc["oscillator"]["omega0"]["value"] == pytest.approx(OMEGA0, rel=0.01)


def test_millimetres_are_a_displacement_and_accelerations_are_never_degrees(tmp_path):
    t, theta, _ = _decay()
    x_mm = 40.0 * theta
    result, scene = _init(tmp_path, _write(tmp_path / "x.csv", ["t (s)", "x (mm)"], [t, x_mm]))
    assert result.exit_code == 0, result.output
    doc = tomllib.loads(scene.read_text())
    assert doc["recording"].get("displacement_column") == "x (mm)" and "angle_column" not in doc["recording"]
    series = read_data(tmp_path / "x.csv", recording={"displacement_column": "x (mm)"})
    np.testing.assert_allclose(series.theta, x_mm / 1000, rtol=1e-8)
    # a length under a name that says nothing: still not an angle in degrees
    data = _write(tmp_path / "ch.csv", ["t (s)", "ch (mm)"], [t, x_mm])
    result, scene = _init(tmp_path, data)
    assert result.exit_code == 0 and tomllib.loads(scene.read_text())["recording"]["displacement_column"] == "ch (mm)"
    data = _write(tmp_path / "acc.csv", ["t (s)", "a (m/s^2)"], [t, -OMEGA0 ** 2 * theta])
    result, scene = _init(tmp_path, data)
    assert result.exit_code == 2 and scene is None and "an acceleration" in result.output
    with pytest.raises(DataError, match=r"'m/s\^2' is not an angle unit.* \(an acceleration: escfit fits angles"):
        read_data(data, recording={"angle_column": "a (m/s^2)"})
    check = check_quantity(t, -OMEGA0 ** 2 * theta, claimed="angle", unit="m/s^2", name="a (m/s^2)")
    assert check.verdict == "refuse" and check.quantity == "acceleration"


def test_radians_labelled_degrees_are_flagged_at_init_and_at_fit(tmp_path):
    t, theta, _ = _decay(amplitude=0.04)  # 2.3 deg, written as radians under a (deg) label
    data = _write(tmp_path / "small.csv", ["t (s)", "theta (deg)"], [t, theta])
    assert np.ptp(theta) / 2 < SMALL_DEG
    series = read_data(data)
    assert 'angle_unit = "rad"' in series.meta["notes"]
    result, scene = _init(tmp_path, data)
    assert result.exit_code == 0 and 'angle_unit = "rad"' in result.output
    problem = make_problem(scene, str(data))
    assert any('angle_unit = "rad"' in n for n in problem.notes)
    # with the key set the note goes away and the swing is 2.3 degrees
    series = read_data(data, recording={"angle_unit": "rad"})
    assert 'angle_unit = "rad"' not in series.meta.get("notes", "")


def test_degrees_labelled_radians_21_turns_are_refused_at_init_and_at_fit(tmp_path):
    t, theta, _ = _decay(amplitude=math.radians(132.0))
    data = _write(tmp_path / "turns.csv", ["t (s)", "theta (rad)"], [t, np.degrees(theta)])
    assert np.degrees(theta).max() / (2 * math.pi) > 20 > MAX_TURNS  # 21 turns read as radians
    with pytest.raises(DataError, match=r'turns either way without a wrap.*set \[recording\] angle_unit = "deg"'):
        read_data(data)
    result, scene = _init(tmp_path, data)
    assert result.exit_code == 2 and scene is None and 'angle_unit = "deg"' in result.output
    refused = CliRunner().invoke(cli, ["fit", str(data), "--scene", str(_scene(tmp_path))])
    assert refused.exit_code == 2 and 'angle_unit = "deg"' in refused.output
    np.testing.assert_allclose(read_data(data, recording={"angle_unit": "deg"}).theta, theta, atol=1e-8)


def _scene(tmp_path):
    path = tmp_path / "plain.toml"
    path.write_text(f'model = "balance"\n[oscillator]\nomega0 = {OMEGA0}\ntheta0 = "0.3 rad"\n[run]\nswings = 10\n'
                    "[effects.viscous]\nC = 0.05\n")
    return path


def test_two_equally_good_decays_are_refused_listing_both_with_scores(tmp_path):
    t, theta, _ = _decay()
    other = 0.8 * theta + 0.0005 * RNG.standard_normal(t.size)
    data = _write(tmp_path / "twin.csv", ["t (s)", "angle 1 (rad)", "angle 2 (rad)"], [t, theta, other])
    with pytest.raises(DataError, match=r"several columns could be the angle.*by shape: 'angle \d \(rad\)' 1\.00 "
                                        r"\(a decaying.*'angle \d \(rad\)' 1\.00 \(a decaying") as info:
        read_data(data)
    assert "\n" not in str(info.value)
    choice = choose_channel(t, {"a": theta, "b": other})
    assert choice.chosen is None and min(choice.scores.values()) > MARGIN * max(choice.scores.values())
    assert max(choice.scores.values()) >= MIN_SCORE
    result, scene = _init(tmp_path, _write(tmp_path / "twin2.csv", ["t", "p", "q"], [t, theta, other]))
    assert result.exit_code == 2 and scene is None
    assert "one motion in several columns" in result.output and "no label says which is the calibrated angle" in \
        result.output  # q is 0.8 p: one decay, two calibrations
    assert "'p' 1.00" in result.output and "'q' 1.00" in result.output
    assert "angle_column" in result.output


def _gyro_axes(main: str, scale_other: float):
    """A phone swinging about one axis (``main``): its rate there, the tilt's projection on a
    second axis (``scale_other`` of it) and, on the third, the body's wobble at half the frequency."""
    t, _, rate = _decay()
    wobble = 0.02 * np.exp(-C * t / 2) * np.sin(0.5 * OMEGA0 * t)
    axes = {"x": wobble, "y": scale_other * rate, "z": scale_other * rate}
    axes[main] = rate
    noise = {a: 2e-3 * RNG.standard_normal(t.size) for a in "xyz"}
    return t, [axes[a] + noise[a] for a in "xyz"]


def test_the_axis_a_phone_swings_about_is_chosen_among_a_gyroscopes_three(tmp_path):
    t, columns = _gyro_axes("y", 0.05)  # y turns 20 times faster than z; x holds a wobble at half the frequency
    data = _write(tmp_path / "Gyroscope.csv", ["Time (s)", "Gyroscope x (rad/s)", "Gyroscope y (rad/s)",
                                               "Gyroscope z (rad/s)"], [t, *columns])
    result, scene = _init(tmp_path, data)
    assert result.exit_code == 0, result.output
    assert "velocity_column = 'Gyroscope y (rad/s)'" in result.output
    assert "axes of one sensor: 'Gyroscope y (rad/s)' oscillates" in result.output
    table = tomllib.loads(scene.read_text())
    assert table["recording"]["velocity_column"] == "Gyroscope y (rad/s)"


def test_axes_that_swing_alike_are_not_chosen_between(tmp_path):
    t, columns = _gyro_axes("y", 0.6)  # y and z within a factor 3: a tilted axis, no dominant one
    choice = choose_channel(t, {f"Gyroscope {a} (rad/s)": c for a, c in zip("xyz", columns)},
                            units={f"Gyroscope {a} (rad/s)": "rad/s" for a in "xyz"}, key="velocity_column")
    assert choice.chosen is None


def test_a_light_gates_pass_times_are_refused_as_event_times(tmp_path):
    """A light gate's log (pass number, pass time in ms) has no swing to sample: the column read as
    the angle only rises, and the refusal says what such a column is."""
    passes = np.arange(1, 421)
    ms = np.cumsum(np.full(420, 752.0) + RNG.normal(0, 2, 420))  # a pass every half period of 1.5 s
    data = tmp_path / "gate.csv"
    data.write_text("".join(f"{n},{m:.0f}\n" for n, m in zip(passes, ms)))
    result, scene = _init(tmp_path, data)
    assert result.exit_code == 2 and scene is None
    assert "only rises over all 420 samples and never turns" in result.output
    assert "a list of event times" in result.output and result.output.count("\n") == 1


def test_a_bob_s_height_beside_its_horizontal_position_is_no_rival(tmp_path):
    """A track of a pendulum's bob, x = L sin(theta) and y = -L cos(theta), read to 1 mm: the
    height swings at twice the frequency and keeps the square of the horizontal swing's amplitude
    (an 8 deg swing falling to 3.5 deg); it is the same motion, not a second decay, so the
    horizontal column is chosen (the rule for an energy needs a clean floor, which 1 mm of noise
    on a height range of 8 mm does not give)."""
    t = np.arange(0.0, 87.0, 1 / 60)
    theta = math.radians(8.0) * np.exp(-math.log(8.0 / 3.5) * t / 87.0) * np.cos(2 * math.pi * 0.656 * t)
    rng = np.random.default_rng(3)
    x = 0.6 * np.sin(theta) + 1e-3 * rng.standard_normal(t.size)
    y = -0.6 * np.cos(theta) + 1e-3 * rng.standard_normal(t.size)
    choice = choose_channel(t, {"column 2": x, "column 3": y})  # a headerless export: no axis names to go by
    assert choice.chosen == "column 2", (choice.scores, choice.why)
    assert "the height beside the horizontal swing of column 2" in choice.why["column 3"]


def _track(noise_px: float = 0.5, rate_hz: float = 5.0):
    """A video track of a pendulum's bob in pixels at 5 frames a second, as a video-analysis
    program writes it: x, y and each one's velocity by central differences of the track."""
    t = np.arange(0.0, 300.0, 1.0 / rate_hz)
    theta = math.radians(20.0) * np.exp(-t / 150.0) * np.cos(2 * math.pi * t / 2.3)
    rng = np.random.default_rng(11)
    x = 190.0 + 400.0 * np.sin(theta) + noise_px * rng.standard_normal(t.size)
    y = 388.0 - 400.0 * np.cos(theta) + noise_px * rng.standard_normal(t.size)
    return t, x, y, np.gradient(x, t), np.gradient(y, t)


def test_a_position_and_its_velocity_are_one_motion_and_the_position_is_fitted(tmp_path):
    """A tracker's x and its 'X Velocity' decay at one frequency and rate: refused before as one
    motion with no label naming the calibrated column.  The velocity is x's time derivative
    (matched to r > 0.99 and in scale), so it is no second sensor: x is chosen, and since its rate
    is named a velocity, not an angular one, x is read as a displacement."""
    t, x, y, vx, vy = _track()
    names = ["Time (s)", "X", "Y", "X Velocity", "Y Velocity"]
    choice = choose_channel(t, {"X": x, "Y": y, "X Velocity": vx, "Y Velocity": vy})
    assert choice.chosen == "X", (choice.scores, choice.reason)
    assert choice.key_of("X") == "displacement_column"
    assert "'X Velocity' is the rate of change of 'X'" in choice.reason
    data = _write(tmp_path / "track.csv", names, [t, x, y, vx, vy])
    result, scene = _init(tmp_path, data)
    assert result.exit_code == 0, result.output
    recording = tomllib.loads(scene.read_text())["recording"]
    assert recording["displacement_column"] == "X"


def test_a_neighbour_a_quarter_period_out_of_phase_is_not_a_rate():
    """The other axis of a bob going round (a conical pendulum) follows x's derivative in shape but
    is omega times smaller: not x's velocity, and the pair is still refused as one motion."""
    t = np.arange(0.0, 120.0, 1 / 30)
    w = 2 * math.pi / 2.3
    env = 50.0 * np.exp(-t / 80.0)
    x, y = env * np.cos(w * t), -env * np.sin(w * t)
    from escfit.analysis.channel import rate_of

    assert rate_of(t, x, y) is None  # the derivative of x is w = 2.7 times y
    assert rate_of(t, x, np.gradient(x, t)) == pytest.approx(1.0, abs=1e-3)
    choice = choose_channel(t, {"x": x, "y": y})
    assert choice.chosen is None and "one motion" in choice.reason


@pytest.mark.parametrize("order", [("p", "q", "r"), ("r", "p", "q"), ("q", "r", "p")])
def test_a_position_its_velocity_and_its_acceleration_in_any_order(order):
    """Three unlabelled columns of one motion: a position p, its velocity q and q's own rate r.
    r is q's rate and q is p's, so both are dropped whatever the columns' order and p is chosen."""
    t, x, _, vx, _ = _track(noise_px=0.05, rate_hz=30.0)
    series = {"p": x, "q": vx, "r": np.gradient(vx, t)}
    choice = choose_channel(t, {k: series[k] for k in order})
    assert choice.chosen == "p", (choice.scores, choice.reason)
    assert "one motion in 3 columns" in choice.reason


def test_a_volt_unit_is_not_a_velocity():
    from escfit.analysis.channel import _names_linear_rate

    assert not _names_linear_rate("CH2 (V)") and not _names_linear_rate("Winkel / V")
    assert _names_linear_rate("v_x (m/s)") and _names_linear_rate("X Velocity")
    assert not _names_linear_rate("angular velocity (rad/s)")
