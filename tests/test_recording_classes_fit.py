"""Raw recordings of known truth, one per real-world shape, read and fitted end to end.

Each record is a free decay (viscous C, Coulomb R) computed by the solvers, written in the shape
a real logger or tracker produces (batched time stamps, encoder counts with flat tops, a start
mid-swing on a negative turning point, a resting tail with one-count flicker, a drifting centre,
a sensor in volts, a gravity pendulum released at 150 deg), then read raw through
``make_problem`` with a ``[recording]`` table and fitted.  The truth must lie inside the 95 %
intervals of C and R.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from escfit.balance.waveform import sample_theta
from escfit.inference import least_squares, make_problem
from escfit.core.scene import load_scene

C_TRUE, R_TRUE, W0 = 0.3, 0.5, 2 * math.pi

SCENE = """model = "balance"
[recording]
{recording}
[oscillator]
omega0 = {w0!r}
{restoring}
[effects.viscous]
C = {{ value = 0.2, vary = true, min = 0, max = 2 }}
[effects.coulomb]
R = {{ value = 0.2, vary = true, min = 0, max = 5 }}
[observation]
{observation}
"""


def motion(t: np.ndarray, theta0: float = 0.5, *, restoring: str = "spring", t_release: float = 0.0) -> np.ndarray:
    """True angle (rad) at times t (s) of a balance released at rest at theta0 at t_release."""
    scene = load_scene("truth.toml", text=SCENE.format(recording="", w0=W0, observation="",
                                                       restoring=f'restoring = "{restoring}"\ntheta0 = {theta0!r}'))
    sys = scene.system({**scene.params.values(), "viscous.C": C_TRUE, "coulomb.R": R_TRUE})
    theta, status = sample_theta(sys, t - t_release, "dop853" if restoring == "pendulum" else "exact")
    assert status in ("ok", "stopped")
    return theta


def fit_file(tmp_path: Path, name: str, text: str, recording: str, *, restoring: str = "", observation: str = ""):
    path = tmp_path / name
    path.write_text(text)
    scene = load_scene(str(tmp_path / "scene.toml"), text=SCENE.format(recording=recording, w0=W0,
                                                                      restoring=restoring, observation=observation))
    problem = make_problem(scene, str(path))
    res = least_squares(problem, n_starts=1)
    return problem, res


def assert_truth_inside(res, truth=(("viscous.C", C_TRUE), ("coulomb.R", R_TRUE))):
    for name, value in truth:
        i = res.names.index(name)
        assert abs(res.value[i] - value) < 1.96 * res.stderr[i], (name, res.value[i], res.stderr[i], value)


def table(rows, fmt="{:.6f},{:.6f}") -> str:
    return "\n".join(fmt.format(*r) for r in rows) + "\n"


def test_batched_time_stamps(tmp_path):
    rng = np.random.default_rng(1)
    t = np.arange(0, 8, 0.01)
    y = np.degrees(motion(t)) + 0.2 * rng.standard_normal(t.size)
    stamps = np.floor(np.arange(t.size) / 12) * 0.12  # a logger writing one stamp per burst of 12 rows
    problem, res = fit_file(tmp_path, "logger.csv", "Time ( s ),Position(deg)\n" + table(zip(stamps, y)), "")
    # every row re-timed (more than 5 % of them): a warning the fit reports, not a note
    assert any("re-timed" in w for w in problem.data_warnings)
    assert_truth_inside(res)


def test_encoder_counts_with_flat_tops_and_a_resting_tail(tmp_path):
    t = np.arange(0, 14, 0.005)  # the balance stops after about 6 s; the encoder flickers by a count
    rng = np.random.default_rng(2)
    # a third of a count of jitter (vibration, electrical noise) before rounding: with none at all the
    # rounding errors are deterministic and the intervals come out about 3 times too narrow (docs/recordings.md)
    counts = np.round(motion(t) / (2 * math.pi) * 4000 + 0.3 * rng.standard_normal(t.size))
    rest = t > 7
    counts[rest] += rng.integers(-1, 2, rest.sum()) * (rng.random(rest.sum()) < 0.3)
    # whole counts are not Gaussian readings: every sample is fitted as the count interval it fell in
    problem, res = fit_file(tmp_path, "encoder.txt", "t\tcounts\n" + table(zip(t, counts), "{:.4f}\t{:.0f}"),
                            'angle_unit = "counts"\ncounts_per_turn = 4000',
                            observation=f'model = "waveform"\nquantum = {2 * math.pi / 4000!r}')
    assert any("motion stopped" in n for n in problem.notes)
    assert_truth_inside(res)


def test_mid_swing_start_on_a_negative_turning_point_with_a_drifting_centre(tmp_path):
    rng = np.random.default_rng(3)
    t = np.arange(0.3, 8, 0.01)
    y = motion(t) + 0.02 + 0.004 * t + 0.003 * rng.standard_normal(t.size)
    problem, res = fit_file(tmp_path, "tracker.txt", table(zip(t, y), "{:.4f} {:.6f}"), "")
    assert any("mid-swing" in n for n in problem.notes)
    assert res.values["oscillator.theta0"] < 0  # the first turning point after t = 0.3 s is on the negative side
    assert any("centre drifts" in n for n in problem.notes)  # +0.004 rad/s estimated and removed; the fit's
    i = res.names.index("observation.offset_rate")     # offset_rate is the correction to it
    assert abs(res.value[i]) < 1.96 * res.stderr[i] + 2e-4
    assert_truth_inside(res)


def test_sensor_in_volts(tmp_path):
    rng = np.random.default_rng(4)
    t = np.arange(0, 8, 0.01)
    volts = 2.0 * motion(t) + 0.004 * rng.standard_normal(t.size)  # 2 V/rad
    problem, res = fit_file(tmp_path, "daq.csv", "time_s,ch1_V\n" + table(zip(t, volts)),
                            'angle_column = "ch1_V"\nangle_unit = "rad"\nscale = 0.5')
    assert_truth_inside(res)


@pytest.mark.parametrize("observation", ["", 'model = "waveform"'])
def test_pendulum_released_at_150_deg(tmp_path, observation):
    rng = np.random.default_rng(5)
    theta0 = math.radians(150)
    t = np.arange(0, 12, 0.01)
    y = motion(t, theta0, restoring="pendulum") + 0.003 * rng.standard_normal(t.size)
    problem, res = fit_file(tmp_path, "pendulum.csv", "t_s,theta_rad\n" + table(zip(t, y)), "",
                            restoring='restoring = "pendulum"', observation=observation)
    assert problem.solver == "dop853"
    assert_truth_inside(res)


def test_degrees_without_a_unit_are_refused_with_what_to_set(tmp_path):
    t = np.arange(0, 8, 0.01)
    y = np.degrees(motion(t))  # a header that names no unit: 't,angle'
    from escfit.core.errors import DataError

    with pytest.raises(DataError, match='angle_unit = "deg"'):
        fit_file(tmp_path, "deg.csv", "t,angle\n" + table(zip(t, y)), "")
    problem, res = fit_file(tmp_path, "deg.csv", "t,angle\n" + table(zip(t, y)), 'angle_unit = "deg"')
    # noiseless samples: the fit lands on the truth
    assert abs(res.values["viscous.C"] - C_TRUE) < 0.01 and abs(res.values["coulomb.R"] - R_TRUE) < 0.01


def test_a_parameter_on_its_bound_and_an_assumed_unit_are_warned(tmp_path):
    from escfit.inference import fit

    rng = np.random.default_rng(6)
    t = np.arange(0, 8, 0.01)
    y = motion(t) + 0.003 * rng.standard_normal(t.size)
    path = tmp_path / "no_unit.txt"
    path.write_text(table(zip(t, y), "{:.4f} {:.6f}"))
    text = SCENE.format(recording="", w0=W0, restoring="", observation="").replace("max = 5 }", "max = 0.3 }")
    res = fit(load_scene(str(tmp_path / "s.toml"), text=text), str(path), method="leastsq", n_starts=1)
    assert any("coulomb.R ends on its upper bound 0.3" in w for w in res.warnings)
    assert any("radians were assumed" in w for w in res.warnings)
