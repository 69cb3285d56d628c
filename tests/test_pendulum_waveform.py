"""A column read as a pendulum's angle must be able to be one: no swing of 180 deg or more
(refused), and from 60 deg up the pendulum's flattened waveform (a warning when missing: an
angle tracked about a misplaced pivot can lose it).

The reference for the waveform is independent of escfit's code: the third harmonic of a free
pendulum measured by an FFT of scipy's solution of ``theta'' = -sin(theta)`` over one period, and
the lowest-order ``A**2/192``.  Genuine large swings come from escfit's own pendulum solver;
the columns that are not angles are what a video track gives (pixels, a plain sinusoid).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.integrate import solve_ivp

from escfit.analysis.pendulum_unit import third_harmonic_ratio, waveform_shape
from escfit.cli.main import cli
from escfit.core.errors import DataError
from escfit.core.scene import load_scene
from .cli_folder import new_folder


@pytest.mark.parametrize("deg", [20, 60, 120, 170])
def test_the_third_harmonic_matches_an_fft_of_the_pendulum(deg):
    a = math.radians(deg)
    sol = solve_ivp(lambda t, y: [y[1], -math.sin(y[0])], (0, 40), [a, 0.0], rtol=1e-11, atol=1e-12,
                    dense_output=True, events=lambda t, y: y[1], )
    turns = sol.t_events[0]
    period = float(turns[2] - turns[0])  # theta' = 0 at t = 0 (not an event), at T/2, T, ...
    n = 4096
    tt = np.linspace(0.0, period, n, endpoint=False)
    f = np.fft.rfft(sol.sol(tt)[0]) / n * 2
    fft_ratio = -f[3].real / f[1].real  # cosines about the release turning point: the opposite sign
    assert float(third_harmonic_ratio(a)) == pytest.approx(fft_ratio, rel=1e-4)
    if deg <= 20:
        assert float(third_harmonic_ratio(a)) == pytest.approx(a * a / 192, rel=0.02)


def _scene(theta0_deg: float, c: float = 0.03):
    return load_scene("p.toml", text=(
        'model = "balance"\n[oscillator]\nrestoring = "pendulum"\nomega0 = 5.2\n'
        f"theta0 = {math.radians(theta0_deg)}\n[effects.viscous]\nC = {c}\n"))


def _write(tmp_path, name, t, x, header="time (s)\tangle (deg)"):
    path = tmp_path / name
    lines = ([header] if header else []) + [f"{a:.4f}\t{b:.3f}" for a, b in zip(t, x)]
    path.write_text("\n".join(lines) + "\n")
    return path


def _init(args, tmp_path):
    runner = CliRunner()
    with new_folder(tmp_path) as here:
        return runner.invoke(cli, ["init", *map(str, args)], catch_exceptions=False), Path(here)


def _solver_swing(deg=120.0, seconds=40.0, rate=40.0, noise=0.1, seed=2):
    from escfit.balance import sample_scene

    t = np.arange(0.0, seconds, 1.0 / rate)
    theta, status = sample_scene(_scene(deg), t)
    rng = np.random.default_rng(seed)
    return t, np.degrees(theta) + rng.normal(0.0, noise, t.size)


def test_a_pixel_column_swinging_190_is_refused_at_init_and_at_fit(tmp_path):
    t = np.arange(0.0, 60.0, 1 / 30)
    x = 190.0 * np.exp(-0.01 * t) * np.cos(2 * math.pi * t / 1.2)  # pixels of a tracked bob, no header
    y = -360.0 + 0.1 * x ** 2 / 360.0
    path = tmp_path / "track.txt"
    path.write_text("\n".join(f"{a:.3f}\t{b:.1f}\t{c:.1f}" for a, b, c in zip(t, x, y)) + "\n")
    result, here = _init([path, "--pendulum", "--angle-column", "2", "--angle-unit", "deg"], tmp_path)
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    for words in ("column 2", "190", "past the 180 deg", "angle_unit", "displacement_column", "--angle-column"):
        assert words in result.output, (words, result.output)
    assert not list(here.glob("*.toml"))
    # a scene written by hand that claims degrees is refused by the fit too
    from escfit.balance.family import make_problem

    scene = tmp_path / "s.toml"
    scene.write_text('model = "balance"\n[oscillator]\nrestoring = "pendulum"\nomega0 = 5.2\n'
                     '[effects.viscous]\nC = { value = 0.02, vary = true, min = 0, max = 1 }\n'
                     '[recording]\nangle_column = 2\nangle_unit = "deg"\n')
    with pytest.raises(DataError, match=r"column 2 read as an angle in deg it swings 19\d"):
        make_problem(load_scene(str(scene)), str(path))


def test_a_genuine_120_degree_pendulum_is_accepted(tmp_path):
    t, x = _solver_swing(120.0)
    result, here = _init([_write(tmp_path, "big.txt", t, x), "--pendulum"], tmp_path)
    assert result.exit_code == 0, result.output
    assert (here / "big.toml").exists()


def test_a_plain_sinusoid_read_as_120_degrees_is_said_to_lack_the_pendulums_waveform(tmp_path):
    t = np.arange(0.0, 40.0, 1 / 40)
    x = 120.0 * np.exp(-0.015 * t) * np.cos(2 * math.pi * t / 1.4)  # millimetres of a track, say
    result, _ = _init([_write(tmp_path, "mm.txt", t, x), "--pendulum"], tmp_path)
    warning = [line for line in result.output.splitlines() if "third harmonic" in line]
    assert result.exit_code == 0 and warning, result.output
    assert "angle_unit" in warning[0] and "displacement_column" in warning[0] and "--angle-column" in warning[0]


@pytest.mark.parametrize("off", [0.125, -0.1])
def test_a_pendulum_tracked_about_a_misplaced_pivot_is_not_refused(tmp_path, off):
    # the angle of a true 120 deg pendulum measured about a pivot placed `off` of the length too
    # high (or low): theta - off sin(theta) to first order, its third harmonic far from the
    # pendulum's, yet an angle: a warning at most
    t, x = _solver_swing(120.0)
    th = np.radians(x)
    tracked = np.degrees(np.arctan2(np.sin(th), np.cos(th) + off))
    result, here = _init([_write(tmp_path, "track.txt", t, tracked), "--pendulum"], tmp_path)
    assert result.exit_code == 0, result.output
    assert (here / "track.toml").exists()


def test_the_waveform_measure_finds_the_pendulums_harmonic():
    from escfit.analysis.recordings.series import TimeSeries
    from escfit.analysis.recordings.turning_points import reduce_series

    t, x = _solver_swing(120.0, noise=0.0)
    tp = reduce_series(TimeSeries(time=t, theta=np.radians(x), source="s"), strict=False)
    times = np.r_[tp.release_time, tp.time]
    theta = np.r_[tp.release_theta, tp.theta]
    amps = np.abs(theta - tp.centre(times))
    shape = waveform_shape(t, np.radians(x) - tp.centre(t), times, amps)
    assert shape is not None and shape.pendulum
    assert shape.measured == pytest.approx(shape.expected, rel=0.1)  # a light damping aside, the closed form


def test_radians_labelled_degrees_are_caught_by_the_swings_size(tmp_path):
    t, x = _solver_swing(40.0)
    result, _ = _init([_write(tmp_path, "rad.txt", t, np.radians(x)), "--pendulum"], tmp_path)
    # 40 deg in radians read as degrees: a swing of 0.7 "deg" whose period shortens like a 40 deg swing's
    assert "angle_unit" in result.output and "rad" in result.output, result.output
