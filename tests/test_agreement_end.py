"""A record that ends in another motion (escfit.analysis.agreement, the end check).

Record-minus-model differences at the turning points are drawn here with known structure: white
scatter, a smooth misfit along the record (a damping law the model lacks), and a tail of the last
turning points displaced (a hand that stops the swing, a take spliced on).  The end check must
find the tail where it is and nothing where there is none; the fit's status and advice follow.
"""

from __future__ import annotations

import numpy as np
import pytest

from escfit.analysis.agreement import END_TURNS, ModelFacts, TurnDifferences, judge, smooth_trend, turn_scatter
from escfit.balance.decrement import loss_symbols

SCATTER = 0.01  # the differences' white scatter (readings' unit)
HALF = 0.5  # s between turning points


def differences(n: int, *, seed: int, tail=(), smooth: float = 0.0, what: str = "amplitude") -> TurnDifferences:
    """``n`` turning points; ``smooth`` the size of a quadratic misfit along the record; ``tail``
    added to the last ``len(tail)`` differences."""
    rng = np.random.default_rng(seed)
    swing = np.arange(n)
    diff = SCATTER * rng.standard_normal(n) + smooth * (swing / n) ** 2
    if tail:
        diff[n - len(tail):] += np.asarray(tail, dtype=float)
    size = 1.0 * np.exp(-swing / n) if what == "amplitude" else None
    return TurnDifferences(what, swing, HALF * swing, diff, turn_scatter(diff, 1e-12), smooth_trend(swing, diff),
                           size=size)


FACTS = ModelFacts(waveform=True, effects=frozenset({"viscous", "coulomb"}), restoring="pendulum",
                   losses=loss_symbols({"viscous", "coulomb"}))


def test_no_end_is_found_in_scatter_or_a_smooth_misfit():
    found = [differences(n, seed=s, smooth=m).end_break() for s in range(150) for n in (12, 40, 200)
             for m in (0.0, 0.3)]
    # 5 spreads and twice the others' 95th percentile: 1 in 6000 draws of white noise (measured)
    assert sum(k is not None for k in found) <= 2, sum(k is not None for k in found)


@pytest.mark.parametrize("tail, first", [((0.0, 0.0, 0.3), -1), ((0.0, -0.2, -0.4), -2), ((0.3, 0.3, 0.3), -3)])
def test_the_end_is_found_where_it_starts(tail, first):
    for seed in range(20):
        d = differences(60, seed=seed, tail=tail)
        assert d.end_break() == 60 + first, (seed, d.end_break())


def test_a_displaced_turning_point_followed_by_good_ones_is_not_an_end():
    d = differences(60, seed=4, tail=(0.4, 0.0, 0.0))
    assert d.end_break() is None


def test_a_small_departure_or_one_near_rest_is_left_to_the_warnings():
    # 0.08 of a swing of about 0.4 (a fifth of it, below GROSS_SHARE): a compromise, not another motion
    assert differences(60, seed=1, tail=(0.0, 0.0, 0.08)).end_break() is None
    # a phase jump where the swing has fallen below a tenth of its first amplitude: near rest
    d = differences(60, seed=1, tail=(0.0, 1.5, 1.6), what="phase")
    assert d.end_break(np.linspace(1.0, 0.05, 60)) is None
    assert d.end_break(np.linspace(1.0, 0.5, 60)) == 58
    assert d.end_break() is None  # no amplitudes: nothing decided


def test_too_few_turning_points_decide_nothing():
    assert differences(END_TURNS + 7, seed=1, tail=(1.0,)).end_break() is None


def test_an_end_makes_the_fit_not_determined_and_names_the_stop():
    d = differences(60, seed=3, tail=(0.0, 0.5, 0.6))
    got = judge(None, d, [], FACTS, periods=30.0, comments=[])
    assert not got.agrees
    text = got.statement()
    assert "last turning points do not follow the decay" in text and "turning point 58 at t = 29 s" in text, text
    # the last turning point that follows: number 57, at 28.5 s
    assert "[recording] stop = 28.5 (or --stop 28.5)" in text, text


def test_a_phase_jump_at_the_end_is_found_too():
    d = differences(60, seed=5, tail=(0.0, 1.5, 1.6), what="phase")
    amp = differences(60, seed=6)  # the same turning points' amplitudes, following the decay
    got = judge(d, amp, [], FACTS, periods=30.0, comments=[])
    assert not got.agrees and "rad of phase" in got.statement() and "stop = 28.5" in got.statement()
