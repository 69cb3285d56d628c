"""Fits of records of known truth: the classes of real records that went wrong, end to end.

Each record is written as a file in the shape a real instrument gives, read raw through
``make_problem`` with a ``[recording]`` table and fitted by least squares; the truth must lie
inside the 95 % intervals.  Seeds are fixed (the noise is numpy's default generator), so the
outcome does not depend on library versions.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from escfit.balance.waveform import sample_theta
from escfit.core.scene import load_scene
from escfit.inference import least_squares, make_problem
from escfit.inference.reconcile import reconcile, with_held_uncertainty

from .test_motion_found import pushed, viscous


def fit(tmp_path: Path, text: str, scene: str, n_starts: int = 1):
    """Least squares as ``escfit fit`` runs it: checked against the record's period and refitted."""
    data = tmp_path / "record.csv"
    data.write_text(text)
    problem = make_problem(load_scene(str(tmp_path / "scene.toml"), text=scene), str(data))
    res, fixes, unresolved, problem = reconcile(problem, least_squares(problem, n_starts=n_starts))
    assert not unresolved, unresolved
    res, more = with_held_uncertainty(problem, res)
    fixes += more
    problem.notes = list(problem.notes) + fixes
    return problem, res


def inside(res, name: str, truth: float) -> bool:
    i = res.names.index(name)
    return bool(res.intervals["lo95"][i] <= truth <= res.intervals["hi95"][i])


def interval(res, name):
    i = res.names.index(name)
    return res.value[i], res.intervals["lo95"][i], res.intervals["hi95"][i]


PICKUP_SCENE = """model = "balance"
[recording]
angle_column = "pickup (V)"
angle_unit = "rad"
scale = 0.5                  # the pickup's 0.5 rad/V (here: the angle's, for a linear decay)
[oscillator]
omega0 = {{ value = 0.6, vary = true, min = 0.2, max = 2 }}
[effects.viscous]
C = {{ value = 0.1, vary = true, min = 0, max = 2 }}
[observation]
{observation}
"""


@pytest.mark.parametrize("q", [3, 7, 30])
@pytest.mark.parametrize("observation", ["", 'model = "waveform"'])
def test_slow_decay_sampled_at_10_hz_in_volts(tmp_path, q, observation):
    """A 9 s period at 10 Hz, in volts, at rest for 10 s, pushed and left to decay into the
    noise for the rest of two minutes: omega0 and C inside their 95 % intervals."""
    rng = np.random.default_rng(100 + q)
    period = 9.0
    t = np.arange(0.0, 120.0, 0.1)
    y, _, _ = pushed(t, 1.0, period, q, 10.0)
    volts = y / 0.5 + 0.004 * rng.standard_normal(t.size)
    text = "time (s),pickup (V)\n" + "".join(f"{a:.1f},{b:.5f}\n" for a, b in zip(t, volts))
    problem, res = fit(tmp_path, text, PICKUP_SCENE.format(observation=observation))
    w0 = 2 * math.pi / period
    assert inside(res, "viscous.C", w0 / q), (interval(res, "viscous.C"), w0 / q, problem.notes)
    if observation:
        assert inside(res, "oscillator.omega0", w0), interval(res, "oscillator.omega0")
    else:  # held at the measured period's value: within its own uncertainty
        held = problem.params["oscillator.omega0"].value
        assert abs(held / w0 - 1) < 0.01, (held, w0)
    assert problem.n_data >= 6 if not observation else True


HOLD_SCENE = """model = "balance"
[recording]
time_column = "t (s)"
angle_column = "angle (deg)"
[oscillator]
omega0 = {{ value = 6, vary = true, min = 4, max = 8 }}
[effects.viscous]
C = {{ value = 0.2, vary = true, min = 0, max = 2 }}
[effects.coulomb]
R = {{ value = 0.2, vary = true, min = 0, max = 5 }}
[observation]
{observation}
"""


def balance_motion(t: np.ndarray, theta0: float, release: float, c: float, r: float, w0: float) -> np.ndarray:
    """The exact solver's angle (rad) of a balance released at rest at theta0 at ``release``."""
    scene = load_scene("truth.toml", text=f'model = "balance"\n[oscillator]\nomega0 = {w0!r}\ntheta0 = {theta0!r}\n'
                                          f"[effects.viscous]\nC = {c!r}\n[effects.coulomb]\nR = {r!r}\n")
    theta, status = sample_theta(scene.system(scene.params.values()), np.maximum(t - release, 0.0), "exact")
    assert status in ("ok", "stopped")
    return np.where(t < release, theta0, theta)


@pytest.mark.parametrize("observation", ["", 'model = "waveform"'])
def test_hold_then_pull_back(tmp_path, observation):
    """Held at 57 deg for 3 s, pulled by hand to 67 deg over 0.4 s, let go: the release is at
    67 deg (the hold is not the release) and C, R come out right."""
    rng = np.random.default_rng(57)
    c, r, w0 = 0.25, 0.4, 2 * math.pi
    t = np.arange(0.0, 14.0, 0.01)
    release = 3.4
    theta = balance_motion(t, math.radians(67.0), release, c, r, w0)
    ramp = np.clip((t - 3.0) / 0.4, 0.0, 1.0)
    pull = math.radians(57.0) + math.radians(10.0) * (0.5 - 0.5 * np.cos(math.pi * ramp))
    y = np.degrees(np.where(t < release, pull, theta)) + 0.05 * rng.standard_normal(t.size)
    text = "t (s),angle (deg)\n" + "".join(f"{a:.2f},{b:.3f}\n" for a, b in zip(t, y))
    problem, res = fit(tmp_path, text, HOLD_SCENE.format(observation=observation))
    assert any("then moved to 67" in n for n in problem.notes), problem.notes
    theta0 = problem.params["oscillator.theta0"]
    assert abs(math.degrees(theta0.value) - 67.0) < 1.0 or (theta0.vary and inside(res, "oscillator.theta0",
                                                                                      math.radians(67.0)))
    assert inside(res, "viscous.C", c), interval(res, "viscous.C")
    assert inside(res, "coulomb.R", r), interval(res, "coulomb.R")


PENDULUM_SCENE = """model = "balance"
[recording]
time_column = 1
angle_column = 2
angle_unit = "rad"
[oscillator]
restoring = "pendulum"
omega0 = {{ value = 6, vary = true, min = 4, max = 8 }}
[effects.viscous]
C = {{ value = 0.2, vary = true, min = 0, max = 2 }}
[effects.coulomb]
R = {{ value = 0.2, vary = true, min = 0, max = 5 }}
[observation]
{observation}
"""


def pendulum_record(theta0_deg: float, seed: int, c: float = 0.1, r: float = 0.3) -> str:
    """A gravity pendulum (omega0 = 2 pi) released at rest, recorded from 0.2 s on (mid-swing)
    at 200 Hz for 12 s with 0.003 rad of noise."""
    from .test_recording_classes_fit import SCENE as TRUTH

    truth = load_scene("truth.toml", text=TRUTH.format(recording="", w0=2 * math.pi, observation="",
                                                        restoring=f'restoring = "pendulum"\n'
                                                                  f"theta0 = {math.radians(theta0_deg)!r}"))
    sys = truth.system({**truth.params.values(), "viscous.C": c, "coulomb.R": r})
    t = np.arange(0.2, 12.2, 0.005)
    theta, status = sample_theta(sys, t, "dop853")
    assert status in ("ok", "stopped")
    y = theta + 0.003 * np.random.default_rng(seed).standard_normal(t.size)
    return "".join(f"{a:.4f} {b:.6f}\n" for a, b in zip(t, y))


@pytest.mark.parametrize("observation", ["", 'model = "waveform"'])
def test_pendulum_at_60_and_140_deg_gives_the_same_damping(tmp_path, observation):
    """The same pendulum released at 60 and at 140 deg: C and R agree with the truth and with
    each other within their intervals (a free centre and drift once doubled C and took R to 0)."""
    c, r = 0.1, 0.3
    got = {}
    for deg in (60.0, 140.0):
        folder = tmp_path / f"{deg:.0f}"
        folder.mkdir()
        problem, res = fit(folder, pendulum_record(deg, seed=int(deg)), PENDULUM_SCENE.format(observation=observation))
        assert inside(res, "viscous.C", c), (deg, interval(res, "viscous.C"))
        assert inside(res, "coulomb.R", r), (deg, interval(res, "coulomb.R"))
        got[deg] = res
    for name in ("viscous.C", "coulomb.R"):
        a, b = (got[d] for d in (60.0, 140.0))
        i, j = a.names.index(name), b.names.index(name)
        assert abs(a.value[i] - b.value[j]) < 1.96 * math.hypot(a.stderr[i], b.stderr[j]), name


@pytest.mark.slow
@pytest.mark.parametrize("q", [3, 7, 30])
def test_interval_coverage_of_slow_decays(tmp_path, q):
    """20 records (fixed seeds) per Q of the 10 Hz pickup: how often the 95 % intervals hold the
    truth.  Measured: waveform omega0 and C 0.95-1.0 of the time at Q = 3 and 7, 0.85-0.9 at
    Q = 30; turning points (omega0 held, its uncertainty carried) C 0.85 at Q = 3, 1.0 at Q = 7,
    0.95 at Q = 30 (docs/recordings.md)."""
    period = 9.0
    w0 = 2 * math.pi / period
    hits = {"waveform omega0": [], "waveform C": [], "turning points C": []}
    t = np.arange(0.0, 120.0, 0.1)
    y, _, _ = pushed(t, 1.0, period, q, 10.0)
    for seed in range(20):
        volts = y / 0.5 + 0.004 * np.random.default_rng(1000 + seed).standard_normal(t.size)
        text = "time (s),pickup (V)\n" + "".join(f"{a:.1f},{b:.6f}\n" for a, b in zip(t, volts))
        _, res = fit(tmp_path, text, PICKUP_SCENE.format(observation='model = "waveform"'))
        hits["waveform omega0"].append(inside(res, "oscillator.omega0", w0))
        hits["waveform C"].append(inside(res, "viscous.C", w0 / q))
        _, res = fit(tmp_path, text, PICKUP_SCENE.format(observation=""))
        hits["turning points C"].append(inside(res, "viscous.C", w0 / q))
    rates = {k: float(np.mean(v)) for k, v in hits.items()}
    assert rates["waveform omega0"] >= 0.8 and rates["waveform C"] >= 0.8, rates
    assert rates["turning points C"] >= 0.75, rates
