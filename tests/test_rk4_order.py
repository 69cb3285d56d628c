"""Measured convergence order of fixed-step RK4 (instead of stored numbers)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from escfit.balance import solve

WINDOWS = """[effects.viscous]\nC = 0.5\n[effects.coulomb]\nR = 20.0\n
[[effects.escapement]]\nkind = "unlock"\nfrom = -0.43\nto = -0.21\nX = 100.0\n
[[effects.escapement]]\nkind = "impulse"\nfrom = -0.21\nto = 0.37\nX = 900.0\n"""


def _orders(scene, hs, **kw):
    ref = solve(scene, "exact", swings=4)
    errs = []
    for h in hs:
        tr = solve(scene, "rk4", swings=4, h=h, **kw)
        errs.append(max(np.max(np.abs(tr.time - ref.time)), np.max(np.abs(tr.amplitude - ref.amplitude))))
    errs = np.array(errs)
    return np.log(errs[:-1] / errs[1:]) / np.log(np.asarray(hs[:-1]) / np.asarray(hs[1:])), errs


HS = [2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4]


def _slope(hs, errs):
    return np.polyfit(np.log(hs), np.log(errs), 1)[0]


def test_rk4_is_fourth_order_without_switching(make_scene):
    scene = make_scene(omega0=31.4, theta0=2.0, effects="[effects.viscous]\nC = 0.5\n")
    _, errs = _orders(scene, HS)
    assert 3.6 < _slope(HS, errs) < 4.4, errs


def test_rk4_with_located_events_stays_fourth_order(make_scene):
    scene = make_scene(omega0=31.4, theta0=2.0, effects=WINDOWS)
    _, errs = _orders(scene, HS)
    assert 3.6 < _slope(HS, errs) < 4.4, errs


def test_naive_rk4_degrades_to_first_order_at_switches(make_scene):
    scene = make_scene(omega0=31.4, theta0=2.0, effects=WINDOWS)
    hs = [1e-4 * 2.0**-k for k in range(5)]
    orders, errs = _orders(scene, hs, locate_events=False)
    # a switch inside a step costs O(h) per event: the mean observed order is about one
    assert 0.6 < float(np.mean(orders)) < 1.6, orders
    located = _orders(scene, [hs[-1]])[1][0]
    assert errs[-1] > 1e3 * located  # stepping over switches costs orders of magnitude
