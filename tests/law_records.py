"""Synthetic free decays of a pendulum with a known damping law, written as a tracker writes them.

Shared by the slow studies of which law a record shows (``tests/test_law_recovery_slow.py``,
``tests/test_compare_slow.py``).  A gravity pendulum (period 1.6 s at small swings) is released
at rest from 29 to 52 deg and recorded at 20 Hz for 40 s from 0.4 s after the release (mid-swing,
as a video track starts) with Gaussian reading noise of 5 mrad (0.3 deg), white.  Its damping is
one of the laws below, with coefficients drawn per record so that the amplitude falls to 30-60 %
of the release amplitude over the record (:func:`draw_truth`).  The truth is the compiled dop853 solver's motion (rtol 1e-10), which has no
approximation a fit could share beyond the equation of motion itself.

Each record is fitted raw, as a user fits a recording: ``[recording]`` names the columns, and the
observation is either the waveform (``model = "waveform"``: every sample, omega0 free) or the
default turning points (amplitudes found in the samples, omega0 held at the record's measured
period with its uncertainty carried into the others).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from escfit.balance.waveform import sample_theta
from escfit.core.scene import load_scene

W0 = 2.0 * math.pi / 1.6  # rad/s
RATE, DURATION, START, NOISE = 20.0, 40.0, 0.4, 0.005  # Hz, s, s, rad

#: law -> the effects it has (keys of EFFECT_TABLES)
LAWS = {"viscous": ("C",), "coulomb": ("R",), "drag": ("D",), "viscous+coulomb": ("C", "R"),
        "viscous+drag": ("C", "D")}
#: laws whose coefficients are recovered but which the five-law comparison leaves out: a stiffening
#: spring dissipates nothing and shows in the period's growth with the amplitude, so it is fitted
#: on the waveform only (turning points hold omega0 at the measured period)
STIFF_LAWS = {"viscous+stiffening": ("C", "K")}
NAMES = {"C": "viscous.C", "R": "coulomb.R", "D": "drag.D", "K": "stiffening.k3"}
EFFECT_TABLES = {"C": "[effects.viscous]\nC = {{ value = 0.02, vary = true, min = 0, max = 1 }}\n",
                 "R": "[effects.coulomb]\nR = {{ value = 0.02, vary = true, min = 0, max = 1 }}\n",
                 "D": "[effects.drag]\nD = {{ value = 0.01, vary = true, min = 0, max = 1 }}\n",
                 "K": "[effects.stiffening]\nk3 = {{ value = 0.1, vary = true, min = 0, max = 3 }}\n"}
FIT_SCENE = """model = "balance"
[recording]
time_column = 1
angle_column = 2
angle_unit = "rad"
[oscillator]
restoring = "pendulum"
omega0 = {{ value = 3.9, vary = true, min = 3, max = 5 }}
{effects}[observation]
{observation}"""
WAVEFORM, TURNING_POINTS = 'model = "waveform"\n', ""


@dataclass(frozen=True)
class Record:
    """One synthetic record: its law, true coefficients (canonical units) and CSV text."""

    law: str
    truth: dict
    text: str


def draw_truth(law: str, rng: np.random.Generator) -> tuple[float, dict]:
    """Release angle (rad) and coefficients of one record.

    The amplitude falls to a fraction ``f`` of the release amplitude, drawn from 0.3-0.6, over the
    record's 50 half swings (a decay long enough to show its law, as a user's free decay does);
    each dissipative effect of a mixture takes about an equal share of the loss.  A stiffening
    spring's ``k3`` is drawn from 0.1-0.5 /rad^2 (at 0.5 rad it changes the restoring torque by
    2.5-12.5 %, against the pendulum's own softening of 4 %).  Small-swing forms: viscous
    ``A0 exp(-C t/2)``, Coulomb ``A0 - 2 n R/omega0**2``, drag ``1/A = 1/A0 + 4 n D/3``.
    """
    theta0 = float(rng.uniform(0.5, 0.9))
    f = float(rng.uniform(0.3, 0.6))
    keys = {**LAWS, **STIFF_LAWS}[law]
    share = 1.0 / len([k for k in keys if k != "K"])
    n = DURATION * W0 / math.pi  # half swings in the record
    truth = {}
    for key in keys:
        if key == "C":
            truth["viscous.C"] = share * -2.0 * math.log(f) / DURATION
        elif key == "R":
            truth["coulomb.R"] = share * (1.0 - f) * theta0 * W0**2 / (2.0 * n)
        elif key == "K":
            truth["stiffening.k3"] = float(rng.uniform(0.1, 0.5))
        else:
            truth["drag.D"] = share * 3.0 * (1.0 / f - 1.0) / (4.0 * n * theta0)
    return theta0, truth


def make_record(law: str, seed: int) -> Record:
    """The record of ``law`` with noise and coefficients from ``seed`` (numpy's PCG64)."""
    rng = np.random.default_rng(seed)
    theta0, truth = draw_truth(law, rng)
    text = (f'model = "balance"\n[oscillator]\nrestoring = "pendulum"\nomega0 = {W0!r}\ntheta0 = {theta0!r}\n'
            + "".join(f"[effects.{name.split('.')[0]}]\n{name.split('.')[1]} = {v!r}\n" for name, v in truth.items()))
    scene = load_scene("truth.toml", text=text)
    t = np.arange(START, DURATION + START, 1.0 / RATE)
    theta, status = sample_theta(scene.system(scene.params.values()), t, "dop853", rtol=1e-10)
    assert status in ("ok", "stopped"), status
    y = theta + NOISE * rng.standard_normal(t.size)
    return Record(law, {**truth, "oscillator.omega0": W0}, "".join(f"{a:.3f},{b:.7f}\n" for a, b in zip(t, y)))


def fit_scene(law: str, observation: str) -> str:
    """The scene a user writes to fit ``law`` (its coefficients free from a generic start)."""
    return FIT_SCENE.format(effects="".join(EFFECT_TABLES[k].format() for k in {**LAWS, **STIFF_LAWS}[law]), observation=observation)
