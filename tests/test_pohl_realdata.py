"""Real data: the free decay of a Pohl torsion wheel (shared/realdata, MIT licence).

Amplitudes are in scale divisions (Skt, 10 deg each) every half period; the decay model is homogeneous in
the amplitude, so the fit works in Skt directly (R is then in Skt/s^2).  Criterion: BIC from
the least-squares fits with the noise scale profiled out (Gaussian readings); a difference
above 10 is conventionally "very strong" evidence.
"""

from __future__ import annotations

import numpy as np
import pytest

import escfit
from escfit.balance.problems.curves import FitProblem
from escfit.inference import least_squares
from escfit.inference.information import bic, information_attrs
from escfit.analysis.recordings import UnitCurve
from escfit.core.csvtable import read_table

from .conftest import SHARED

POHL = SHARED / "realdata" / "pohl_heilaut" / "derived" / "decay_amplitude_halfperiod.csv"

SCENE = """model = "balance"
[oscillator]
omega0 = 4.394          # pi / (0.715 s half period)
theta0 = { value = 12.0, vary = true, min = 5, max = "20 rad" }
[run]
swings = 21
[effects.viscous]
C = { value = 0.2, vary = true, min = 0, max = 3 }
%s
[observation]
sigma = { value = 0.2, vary = true, min = 0.001, max = 5 }
offset = { value = 0.0, vary = true, min = -3, max = 3 }
"""
COULOMB = "[effects.coulomb]\nR = { value = 1.0, vary = true, min = 0, max = 50 }"


@pytest.fixture(scope="module")
def pohl():
    if not POHL.exists():
        pytest.skip("shared real data not present")
    table = read_table(POHL)
    t, a = np.array(table.floats("t_s")), np.array(table.floats("A_Skt"))
    k = np.arange(t.size, dtype=np.int64)  # row k is the reading after k half periods (0 = release)
    np.testing.assert_allclose(t, 0.715 * k, atol=1e-9)
    return UnitCurve(k, a, "amplitude", unit=np.full(k.size, "", dtype=str), source=str(POHL))


def _lsq(text, data):
    return least_squares(FitProblem(escfit.load_scene("pohl.toml", text=text), data), n_starts=12, seed=1)


def _bic(text, data, res) -> float:
    """BIC as escfit compare and the report compute it (the stored log-likelihood at the optimum)."""
    a = information_attrs(FitProblem(escfit.load_scene("pohl.toml", text=text), data), res)
    return bic(a["loglike"], a["n_params"], res.n_data)


def test_coulomb_plus_viscous_is_clearly_preferred(pohl):
    both = _lsq(SCENE % COULOMB, pohl)
    expo = _lsq(SCENE % "", pohl)
    assert _bic(SCENE % "", pohl, expo) - _bic(SCENE % COULOMB, pohl, both) > 10.0
    assert both.chisqr < 0.1 * expo.chisqr
    values = dict(zip(both.names, both.value))
    errors = dict(zip(both.names, both.stderr))
    # friction is clearly non-zero, and the zero offset shows in alternating readings
    assert values["coulomb.R"] > 10 * errors["coulomb.R"]
    assert abs(values["observation.offset"]) > 3 * errors["observation.offset"]
    # scatter of about a fifth of a scale division, as the readings' quarter-division rounding suggests
    assert 0.05 < both.sigma_hat < 0.4
