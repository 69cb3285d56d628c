"""Friction coefficient shared by the torsion-wire rig and the decay curves at three loads."""

from __future__ import annotations

import numpy as np
import pytest

import escfit
from escfit.inference import fit
from escfit.balance.synthetic.unit_curves import record_unit_curve
from escfit.analysis.recordings import UnitCurve, write_unit_curve

from .conftest import DATASETS, balance_toml

MU, LEVER, INERTIA, R0 = 0.100, 1e-6, 1.243e-8, 60.0
LOADS = (100.0, 200.0, 300.0)  # g


def _unit(load, r, x3):
    eff = (f'[effects.viscous]\nC = 0.5\n[effects.coulomb]\nR = {r!r}\n[[effects.escapement]]\nkind = "unlock"\n'
           f'from = -0.633\nto = -0.278\nX = {0.1151 * x3!r}\n[[effects.escapement]]\nkind = "impulse"\n'
           f"from = -0.278\nto = 0.278\nX = {x3!r}\n")
    return escfit.load_scene("u.toml", text=balance_toml(omega0=15.9, theta0=6.28, swings=48, effects=eff))


FIT_SCENE = balance_toml(omega0=15.9, theta0=6.28, swings=48, effects="""[effects.viscous]
C = { value = 0.4, vary = true, min = 0.0, max = 5.0 }
[effects.coulomb]
R = { value = 50.0, vary = true, min = 0.0, max = 1000.0 }
[[effects.escapement]]
kind = "unlock"
from = -0.633
to = -0.278
eps = 0.1151
[[effects.escapement]]
kind = "impulse"
from = -0.278
to = 0.278
X = 1000.0
[observation]
model = "notches"
notch_deg = 6
sigma = { value = 0.03, vary = true, min = 0.001, max = 0.5, prior = "loguniform(0.001, 0.5)" }
[fit.loads]
reference = "100 g"
friction = "mu"
lever = "1e-6 m"
inertia = "1.243e-8 kg*m^2"
""")


@pytest.fixture(scope="module")
def decay_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("mu")
    swing, value, load = [], [], []
    for i, ld in enumerate(LOADS):
        r = R0 + MU * LEVER / INERTIA * (ld - LOADS[0]) * 1e-3 * 9.80665
        # recorded like Monday's rig: 6-degree notches every second cycle for 6.5 s
        c = record_unit_curve(_unit(ld, r, 1000.0 * ld / 100.0), every=4, duration=6.5, notch_deg=6, sigma=0.03,
                              seed=40 + i)
        swing += list(c.swing)
        value += list(c.value)
        load += [ld] * c.swing.size
    path = d / "three_loads.csv"
    write_unit_curve(path, UnitCurve(np.array(swing), np.array(value), "notches", np.radians(6.0), load=np.array(load),
                                     load_unit="g", unit=np.full(len(swing), "", dtype=str)), comments=["shared-mu test"])
    rig = d / "rig.h5"
    fit(DATASETS / "friction" / "monday1965_rig.toml", DATASETS / "friction" / "monday1965_session_1095_steel.csv",
        method="emcee", steps=800, out=rig)
    return d, path, rig


def test_rig_posterior_sharpens_mu_from_decay_curves(decay_file):
    d, data, rig = decay_file
    alone = fit(escfit.load_scene(d / "alone.toml", text=FIT_SCENE), data, method="emcee", walkers=12, steps=800, seed=1)
    joint_text = FIT_SCENE + f'mu_prior = "{rig}"\n'
    joint = fit(escfit.load_scene(d / "joint.toml", text=joint_text), data, method="emcee", walkers=12, steps=800,
                seed=1)
    a, j = alone.summary()["fit.mu"], joint.summary()["fit.mu"]
    assert a["lo95"] < MU < a["hi95"]
    assert j["lo95"] < MU < j["hi95"]
    print(f"mu 95% alone [{a['lo95']:.4f}, {a['hi95']:.4f}], with the rig [{j['lo95']:.4f}, {j['hi95']:.4f}]")
    assert (j["hi95"] - j["lo95"]) < 0.5 * (a["hi95"] - a["lo95"])  # the rig sharpens mu
