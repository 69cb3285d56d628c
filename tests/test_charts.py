"""Monday's charts, computed (seeds' README targets)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import escfit
from escfit.balance import solve
from escfit.balance.monday.charts import (REFERENCE_POWER_ANGLE, Pulse, amplitude_factor, equivalent_r, graph_factor, k_value,
                           steady_state, unit_curve)
from escfit.core.errors import SceneError

from .conftest import DATASETS, balance_toml

C, W0 = 0.833, 16.174
SAMPLE = [Pulse(-0.6338, -0.2787, -143.41 / W0**2), Pulse(-0.2787, 0.2787, 1245.8 / W0**2),
          Pulse(-math.pi / 2, math.pi / 2, -305.546 / W0**2)]


def test_graph_factor_is_3_636_not_3_65():
    assert graph_factor(C / W0) == pytest.approx(3.636, abs=5e-4)
    # undamped limit: the ratio of the work integrals 2 / (2 sin alpha)
    assert graph_factor(0.0) == pytest.approx(1 / math.sin(REFERENCE_POWER_ANGLE), rel=1e-12)


def test_conversion_charts_match_monday_readings():
    assert equivalent_r(0.05, 0.549, -0.6, -0.3) == pytest.approx(0.073, abs=1e-3)  # Fig. 10
    assert equivalent_r(0.05, 4.77, -0.2787, 0.2787) == pytest.approx(1.30, rel=0.015)  # Fig. 11


def test_sample_problem_k_is_0_2037_not_0_214():
    assert k_value(C / W0, SAMPLE) == pytest.approx(0.2037, abs=1e-4)


def test_steady_state_matches_the_phase_simulation():
    scene = escfit.load_scene(DATASETS / "scenes" / "monday_sample_phase.toml")
    tr = solve(scene, swings=600)
    assert steady_state(C / W0, SAMPLE) == pytest.approx(tr.amplitude[-1], rel=1e-9)


def test_unit_curve_equals_exact_reference_curve():
    k = 0.2037
    eff = (f'[effects.viscous]\nC = {C}\n[[effects.escapement]]\nkind = "impulse"\nfrom = {-REFERENCE_POWER_ANGLE}\n'
           f"to = {REFERENCE_POWER_ANGLE}\nX = {k * W0**2!r}\n")
    scene = escfit.load_scene("ref.toml", text=balance_toml(omega0=W0, theta0=6.28, swings=80, switching="phase", effects=eff))
    tr = solve(scene)
    np.testing.assert_allclose(unit_curve(C / W0, k, cycles=40)[1:], tr.amplitude[1::2], rtol=1e-10)


@pytest.mark.parametrize("c", [2.0, -0.1, float("nan")])
def test_overdamped_or_negative_damping_is_refused(c):
    with pytest.raises(SceneError, match=rf"c = {c!r}"):
        steady_state(c, SAMPLE)


def test_amplitude_factor_matches_fig_12_reading():
    # Monday: going from C/omega0 = 0.040 to 0.060 multiplies the amplitude by 0.83/1.2
    # (computed: 0.667 against his graphical 0.692, a 4 % reading difference)
    assert amplitude_factor(0.06) / amplitude_factor(0.04) == pytest.approx(0.83 / 1.2, rel=0.05)
    assert amplitude_factor(0.05) == 1.0


def test_charts_cli_writes_files_and_refuses_overwrite(tmp_path):
    from click.testing import CliRunner

    from escfit.cli.main import cli

    r = CliRunner().invoke(cli, ["charts", "--out", str(tmp_path), "--no-png"])
    assert r.exit_code == 0, r.output
    rows = (tmp_path / "factors.csv").read_text().splitlines()
    assert rows[0].startswith("c_over_omega0,graph_factor")
    again = CliRunner().invoke(cli, ["charts", "--out", str(tmp_path), "--no-png"])
    assert again.exit_code == 2 and "exists" in again.output
