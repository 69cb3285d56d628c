"""No wrong answer is printed as a best fit.

- A sampled decay measures its period: a scene omega0 that contradicts it is refused (exit 2),
  turning-point amplitudes (which cannot determine omega0) hold it at the period's value, and
  the fitted model's period is checked after the fit.
- A fit that contradicts what the record measures is refitted from the measured value, or
  reported as not determined; a fit that determines nothing exits with status 3 and says so
  above the table.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.balance.waveform import sample_theta
from escfit.cli.main import EXIT_NOT_DETERMINED, cli
from escfit.core.scene import load_scene
from escfit.inference import least_squares
from escfit.inference.reconcile import NOT_DETERMINED, reconcile, verdict
from escfit.likelihood.consistency import Implied

from .test_lsq_honest import ToyProblem

C_TRUE, R_TRUE, W0 = 0.12, 0.15, 2 * math.pi * 0.7  # a 1.43 s period, as the student's pendulum

STUDENT_SCENE = """model = "balance"
[recording]
[oscillator]
{omega0}
[effects.viscous]
C = {{ value = 0.2, vary = true, min = 0, max = 3 }}
[effects.coulomb]
R = {{ value = 0.5, vary = true, min = 0, max = 10 }}
"""


def student_csv(path, seed: int = 8):
    """A free decay logged at 50 Hz from 25 deg, the logger started mid-swing, 0.2 deg of noise."""
    scene = load_scene("truth.toml", text=f'model = "balance"\n[oscillator]\nomega0 = {W0!r}\ntheta0 = 0.436\n'
                                          f"[effects.viscous]\nC = {C_TRUE!r}\n[effects.coulomb]\nR = {R_TRUE!r}\n")
    t = np.arange(0.37, 12.0, 0.02)
    theta, status = sample_theta(scene.system(scene.params.values()), t, "exact")
    assert status in ("ok", "stopped")
    y = np.degrees(theta) + 0.2 * np.random.default_rng(seed).standard_normal(t.size)
    path.write_text("Time (s),Angle (deg)\n" + "".join(f"{a:.2f},{b:.3f}\n" for a, b in zip(t - 0.37, y)))
    return path


def run_fit(tmp_path, data, scene_text):
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text)
    return CliRunner().invoke(cli, ["fit", str(data), "--scene", str(scene), "--out", str(tmp_path / "fit.h5"),
                                    "--force"])


def row(output: str, name: str) -> list[str]:
    line = next(ln for ln in output.splitlines() if ln.startswith(name))
    return line.split()


def test_free_omega0_on_turning_points_is_held_at_the_measured_period(tmp_path):
    """The student's case: omega0 free, the default (turning-point) observation.  Once this gave
    omega0 = 5.98 rad/s for a 4.42 rad/s pendulum, C and R 35 % and 80 % off, as a 'best fit'."""
    data = student_csv(tmp_path / "student.csv")
    r = run_fit(tmp_path, data, STUDENT_SCENE.format(omega0="omega0 = { value = 6.0, vary = true, min = 3, max = 9 }"))
    assert r.exit_code == 0, r.output
    assert "omega0 held at" in r.output and "cannot determine omega0" in r.output
    assert not any(ln.startswith("oscillator.omega0") for ln in r.output.splitlines())
    from escfit.results import load_fit

    res = load_fit(tmp_path / "fit.h5")
    rows = res.summary()
    # turning-point intervals run some 1.3 times too narrow here (20 seeds: coverage 0.9 for C,
    # 0.8 for R); the waveform fit's are calibrated (tests/test_fits_known_truth.py)
    for name, truth in (("viscous.C", C_TRUE), ("coulomb.R", R_TRUE)):
        r = rows[name]
        assert abs(r["estimate"] - truth) < min(3 * r["stderr"], 0.1 * truth), (name, r, truth)
    assert res.verdict == "determined"


def test_a_fixed_omega0_the_period_contradicts_is_refused(tmp_path):
    data = student_csv(tmp_path / "student.csv")
    r = run_fit(tmp_path, data, STUDENT_SCENE.format(omega0="omega0 = 20.0"))
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert len(lines) == 1, r.output
    assert "the record's period is 1.42" in lines[0] and "fixes omega0 = 20 rad/s" in lines[0]
    assert "set omega0 near 4.4" in lines[0]
    assert not (tmp_path / "fit.h5").exists()


def test_a_range_of_omega0_that_excludes_the_period_is_refused(tmp_path):
    data = student_csv(tmp_path / "student.csv")
    r = run_fit(tmp_path, data, STUDENT_SCENE.format(omega0="omega0 = { value = 12, vary = true, min = 10, max = 14 }")
                + '[observation]\nmodel = "waveform"\n')
    assert r.exit_code == 2 and "outside the scene's range of omega0 [10, 14]" in r.output, r.output


def test_a_fit_that_determines_nothing_exits_3_and_says_so(tmp_path):
    """A unit curve (amplitudes only, no times to measure a period) with omega0, C and R free:
    amplitudes fix only C/omega0 and R/omega0^2, so none of the three is determined."""
    truth = tmp_path / "truth.toml"
    truth.write_text(f'model = "balance"\n[oscillator]\nomega0 = {W0!r}\ntheta0 = 1.0\n[run]\nswings = 40\n'
                     f"[effects.viscous]\nC = {C_TRUE!r}\n[effects.coulomb]\nR = {R_TRUE!r}\n")
    curve = tmp_path / "curve.csv"
    rec = CliRunner().invoke(cli, ["simulate", str(truth), "--recorder", "unit-curve", "--noise", "0.002",
                                   "--out", str(curve)])
    assert rec.exit_code == 0, rec.output
    scene = (f'model = "balance"\n[oscillator]\nomega0 = {{ value = 5, vary = true, min = 2, max = 9 }}\n'
             f"theta0 = 1.0\n[effects.viscous]\nC = {{ value = 0.2, vary = true, min = 0, max = 3 }}\n"
             f"[effects.coulomb]\nR = {{ value = 0.5, vary = true, min = 0, max = 10 }}\n")
    r = run_fit(tmp_path, curve, scene)
    assert r.exit_code == EXIT_NOT_DETERMINED == 3, r.output
    head = next(ln for ln in r.output.splitlines() if ln.startswith("parameter"))
    assert "value (NOT determined)" in head and "best fit" not in head
    assert r.output.splitlines()[1].startswith("NOT DETERMINED")
    assert "the parameters are NOT determined" in r.output
    from escfit.results import load_fit

    assert load_fit(tmp_path / "fit.h5").verdict == NOT_DETERMINED


class PeriodToy(ToyProblem):
    """``y = sin(w t)``: a fit started far off finds a secondary minimum; the 'record' measures w."""

    def __init__(self, measured: float):
        t = np.linspace(0.0, 10.0, 200)
        super().__init__(lambda x, t: np.sin(x[0] * t), t, np.sin(1.0 * t), 0.05, ["w"], [0.1], [5.0], [2.6])
        self.measured = measured

    def consistency(self, values):
        return [Implied("w", values["w"], self.measured, 0.01, f"the record's period is {2 * math.pi / self.measured:.4g}")]


def test_a_fit_that_contradicts_the_measured_period_is_refitted_from_it():
    problem = PeriodToy(measured=1.0)
    first = least_squares(problem, n_starts=1)
    assert abs(first.values["w"] - 1.0) > 0.3  # a secondary minimum
    res, notes, unresolved, _ = reconcile(problem, first)
    assert not unresolved and abs(res.values["w"] - 1.0) < 1e-6
    assert notes and "refitted from w = 1" in notes[0] and "fits the readings better" in notes[0]


def test_a_fit_the_measurement_cannot_rescue_is_not_determined():
    problem = PeriodToy(measured=4.9)  # the record's period says 4.9; the readings want 1
    res, notes, unresolved, _ = reconcile(problem, least_squares(problem, n_starts=4))
    assert unresolved
    status, missing, message = verdict(problem, res, unresolved)
    assert status == NOT_DETERMINED and missing == ["w"] and "NOT determined" in message


def test_the_verdict_names_what_a_singular_fit_leaves_undetermined():
    t = np.linspace(0, 1, 6)
    problem = ToyProblem(lambda x, t: x[0] + x[1] + x[2] * t, t, 2.0 + 0.3 * t + 0.01 * np.cos(5 * t), 0.1,
                         ["a", "b", "slope"], [-np.inf] * 3, [np.inf] * 3, [0.5, 0.5, 0.0])
    problem.failures = Counter()
    status, missing, message = verdict(problem, least_squares(problem, n_starts=2), [])
    assert status == "partly determined" and missing == ["a", "b"] and message.startswith("a, b are not determined")
