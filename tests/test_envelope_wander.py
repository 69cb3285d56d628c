"""An envelope that wanders leaves the split of C and R undetermined (escfit.analysis.agreement).

Turning-point amplitudes of a pendulum losing amplitude to viscous damping and pivot friction
are built by their recurrence (each half swing multiplies the amplitude by exp(-pi C / 2 omega)
and takes 2 R / omega^2 from it), with white reading noise, and fitted by the same recurrence
with scipy's least squares.  A slow 3 % wobble of the amplitude (a bob that does not swing in a
plane) moves the fitted C and R far from the truth with residuals that look small; the wander
rule must flag every such fit, and never a clean one.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import least_squares

from escfit.analysis.agreement import (ModelFacts, TurnDifferences, envelope_wander, judge, smooth_trend,
                                       turn_scatter)
from escfit.balance.decrement import loss_symbols

OMEGA = 5.36  # rad/s
C, R = 0.022, 0.020  # 1/s, rad/s^2: about half the loss each at 0.22 rad
A0 = 0.22  # rad
TURNS = 40  # 20 periods
NOISE = 2e-4  # rad, one turning point's reading
FACTS = ModelFacts(waveform=False, effects=frozenset({"oscillator", "viscous", "coulomb"}), restoring="pendulum",
                   losses=loss_symbols({"oscillator", "viscous", "coulomb"}))


def amplitudes(a0: float, c: float, r: float) -> np.ndarray:
    """The amplitude at each turning point (rad), from the release."""
    out = np.empty(TURNS)
    out[0] = a0
    for k in range(1, TURNS):
        out[k] = max(out[k - 1] * math.exp(-math.pi * c / (2 * OMEGA)) - 2 * r / OMEGA ** 2, 0.0)
    return out


def fitted(record: np.ndarray) -> tuple[np.ndarray, float, float]:
    """The recurrence fitted to ``record``: model amplitudes, C and R."""
    res = least_squares(lambda p: amplitudes(*p) - record, [record[0], 0.02, 0.01],
                        bounds=([0, 0, 0], [1, 1, 1]), x_scale=[0.1, 0.01, 0.01])
    return amplitudes(*res.x), float(res.x[1]), float(res.x[2])


def differences(record: np.ndarray, model: np.ndarray) -> TurnDifferences:
    swing = np.arange(TURNS)
    d = record - model
    return TurnDifferences("amplitude", swing, swing * math.pi / OMEGA, d, turn_scatter(d, 1e-12),
                           smooth_trend(swing, d), record)


def wobbly(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    k = np.arange(TURNS)
    periods = rng.uniform(10.0, 30.0)  # of the wobble, in swing periods (two turning points each)
    mod = 1.0 + 0.03 * np.sin(math.pi * k / periods + rng.uniform(0, 2 * math.pi))
    return mod * amplitudes(A0, C, R) + NOISE * rng.standard_normal(TURNS)


def test_a_clean_decay_is_never_taken_for_a_wandering_one():
    for seed in range(100):
        record = amplitudes(A0, C, R) + NOISE * np.random.default_rng(1000 + seed).standard_normal(TURNS)
        model, c, r = fitted(record)
        assert c == pytest.approx(C, rel=0.3) and r == pytest.approx(R, rel=0.3)  # the split is there to find
        wander = envelope_wander(differences(record, model))
        assert not wander.splits, (seed, wander)
        got = judge(None, differences(record, model), [], FACTS, periods=TURNS / 2, comments=[])
        assert got.agrees and not got.undetermined


def test_every_fit_a_wobble_moves_far_is_flagged():
    far = 0
    for seed in range(40):
        record = wobbly(seed)
        model, c, r = fitted(record)
        got = judge(None, differences(record, model), [], FACTS, periods=TURNS / 2, comments=[])
        if abs(c - C) > 0.3 * C or abs(r - R) > 0.3 * R:
            far += 1
            assert got.undetermined == ("viscous.C", "coulomb.R"), (seed, c, r, envelope_wander(
                differences(record, model)))
            assert got.agrees and got.cautions[0].startswith("C and R are not determined by this record: its "
                                                             "envelope wanders by")
    assert far >= 10  # the wobble does move most fits far: the rule is tested, not idle


def test_without_friction_in_the_model_nothing_is_marked():
    record = wobbly(0)
    model, _, _ = fitted(record)
    facts = ModelFacts(waveform=False, effects=frozenset({"oscillator", "viscous"}), restoring="pendulum",
                   losses=loss_symbols({"oscillator", "viscous"}))
    got = judge(None, differences(record, model), [], facts, periods=TURNS / 2, comments=[])
    assert not got.undetermined
