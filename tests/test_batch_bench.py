"""``escfit bench --quick`` runs end to end, quickly, and its records say what they should."""

from __future__ import annotations

import json

from click.testing import CliRunner

from escfit.cli.main import cli


def test_bench_quick_json_and_plot(tmp_path):
    plot = tmp_path / "wp.png"
    result = CliRunner().invoke(cli, ["bench", "--quick", "--json", "--plot", str(plot)])
    assert result.exit_code == 0, result.output
    records = json.loads(result.stdout)  # "wrote ..." goes to stderr
    for r in records:
        assert {"method", "setting", "error_half_period_s", "us_per_swing"} <= set(r)
        assert r["us_per_swing"] > 0
    by = {(r["case"], r["method"], r["setting"]): r for r in records}
    for case in ("horology", "monday120"):
        exact = by[(case, "exact", "-")]
        assert exact["error_half_period_s"] < 1e-15 and exact["error_amplitude_rad"] < 1e-13
        naive = by[(case, "rk4 naive", "h=1e-05 s")]
        assert naive["error_half_period_s"] > 1e-10  # stepping over switches costs accuracy
    assert {r["method"] for r in records} >= {"exact", "exact batch", "rk4", "rk4 naive", "ivp RK45", "ivp DOP853",
                                             "ivp Radau", "emcee, vectorised exact"}
    assert plot.stat().st_size > 10_000
    again = CliRunner().invoke(cli, ["bench", "--quick", "--no-posterior", "--plot", str(plot)])
    assert again.exit_code == 2 and "exists" in again.output
