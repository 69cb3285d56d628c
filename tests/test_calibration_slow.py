"""Calibration over 20 synthetic data sets (slow: run with ``python -m pytest -m slow``)."""

from __future__ import annotations

import importlib.util

import pytest

from .conftest import ROOT


@pytest.mark.slow
def test_ninety_percent_intervals_cover_between_75_and_100_percent():
    spec = importlib.util.spec_from_file_location("calibration", ROOT / "benchmarks" / "calibration.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    out = mod.run(n=20, walkers=16, steps=2000)
    for name, c in out["coverage_90"].items():
        assert 0.75 <= c <= 1.0, (name, c)
