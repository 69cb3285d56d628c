"""Misfit diagnostics: silent on white noise, and each structure named when it is there."""

from __future__ import annotations

import numpy as np

from escfit.inference.misfit import misfit_report


def test_white_noise_raises_no_warning_in_200_records():
    rng = np.random.default_rng(1)
    alarms = 0
    for _ in range(200):
        r = rng.standard_normal(60)
        _, warnings = misfit_report(r, np.arange(1, 61), None)
        alarms += bool(warnings)
    assert alarms <= 2  # each check is set for a false alarm well below 1 %


def test_alternating_branches_from_an_offset_centre():
    rng = np.random.default_rng(2)
    swing = np.arange(1, 41)
    r = 0.01 * rng.standard_normal(40) + np.where(swing % 2 == 0, 0.03, -0.03)  # branches 6 noise sd apart
    figures, warnings = misfit_report(r, swing, None, unit="rad")
    assert abs(figures["branch_difference"] - 0.06) < 0.015
    assert any("two branches" in w and "offset" in w for w in warnings)


def test_runs_from_a_missed_trend_and_correlated_neighbours():
    rng = np.random.default_rng(3)
    t = np.linspace(0, 1, 200)
    r = np.sin(2 * np.pi * 1.5 * t) + 0.1 * rng.standard_normal(t.size)
    figures, warnings = misfit_report(r, None, None, branches=False)
    assert figures["runs"] < 0.2 * figures["runs_expected"]
    assert figures["lag1_autocorrelation"] > 0.9
    assert any("long runs" in w for w in warnings) and any("lag-1" in w for w in warnings)


def test_curves_are_checked_separately():
    rng = np.random.default_rng(4)
    swing = np.tile(np.arange(1, 31), 2)
    curve = np.repeat(["load 100", "load 200"], 30)
    r = 0.01 * rng.standard_normal(60)
    r[30:] += np.where(swing[30:] % 2 == 0, 0.05, -0.05)
    _, warnings = misfit_report(r, swing, curve)
    assert warnings and all(w.startswith("load 200: ") for w in warnings)
