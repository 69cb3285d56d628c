"""A record on an epoch clock (stamps near 1e9 s): the fit is the same as on a clock from zero.

The release instant is a parameter on the file's clock; scipy's trust region sized its first step
by the norm of the start, a billion, and the fit of such a record ended with C a fifth and R ten
times the truth, blaming drag and a temperature drift.  Shifting the clock must change no
physical estimate.  The record is a linear oscillator with viscous damping and Coulomb friction
(exact, half swing by half swing: ``tests.test_turning_points.decay``) with reading noise,
written as an epoch logger writes it (seven decimals), read by ``escfit init`` and fitted.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.cli.main import cli
from escfit.results import load_fit

from .test_turning_points import decay

OMEGA0, C, R = 4 * math.pi, 0.05, 0.01


def _fit(tmp_path, origin: float) -> dict:
    t = np.arange(0.0, 30.0, 1 / 300)
    theta, *_ = decay(t, math.radians(20), c=C, r=R, w0=OMEGA0)
    deg = np.degrees(theta) + 0.05 * np.random.default_rng(5).standard_normal(t.size)
    folder = tmp_path / f"at{origin:g}"
    folder.mkdir()
    (folder / "e.csv").write_text("Time (s),Angle (deg)\n" + "".join(f"{origin + a:.7f},{b:.5f}\n" for a, b in zip(t, deg)))
    runner = CliRunner()
    r = runner.invoke(cli, ["init", str(folder / "e.csv"), "--spring", "--out", str(folder / "e.toml")])
    assert r.exit_code == 0, r.output
    r = runner.invoke(cli, ["fit", str(folder / "e.csv"), "--scene", str(folder / "e.toml"), "--out", str(folder / "e.h5")])
    assert r.exit_code == 0, r.output
    return load_fit(folder / "e.h5").summary()


def test_an_epoch_clock_gives_the_fit_of_a_clock_from_zero(tmp_path):
    near, far = _fit(tmp_path, 0.0), _fit(tmp_path, 1e9)
    for name, truth in (("oscillator.omega0", OMEGA0), ("viscous.C", C), ("coulomb.R", R)):
        se = (near[name]["hi95"] - near[name]["lo95"]) / (2 * 1.96)
        assert abs(far[name]["estimate"] - near[name]["estimate"]) < 0.1 * se, (name, far[name], near[name])
        assert near[name]["lo95"] - se <= truth <= near[name]["hi95"] + se, (name, near[name])


def _damped(t, x):
    tr, c, a = x
    s = t - tr
    return a * np.exp(-0.5 * c * s) * np.cos(OMEGA0 * s)


def test_the_trust_region_fits_a_release_on_an_epoch_clock_as_on_a_clock_from_zero(monkeypatch):
    """Least squares of a damped cosine whose release instant lies at 1e9 s + 0.01 s, by scipy's
    own finite differences (2- and 3-point): the estimates are those of the same fit on a clock
    from zero.  Unshifted, scipy sized its trust region and its step tolerance by the start's
    norm, a billion, and stopped after two evaluations at the start."""
    from escfit.inference import trf

    t = np.arange(0, 30, 1 / 300)
    y = _damped(t, [0.01, C, 0.35]) + 1e-3 * np.random.default_rng(1).standard_normal(t.size)
    lo, hi, x0 = np.array([-0.2, 0.0, 0.1]), np.array([0.25, 1.0, 1.0]), np.array([0.02, 0.02, 0.3])
    ref = trf.minimize(lambda x: (_damped(t, x) - y) / 1e-3, x0, lo, hi)
    far = 1e9 + t

    def fun(x):
        return (_damped(far, x) - y) / 1e-3

    shift = np.array([1e9, 0.0, 0.0])
    for jac in ("2-point", "3-point"):
        got = trf.minimize(fun, x0 + shift, lo + shift, hi + shift, jac=jac)
        np.testing.assert_allclose(got.x - shift, ref.x, rtol=1e-6, atol=1e-7)
        assert got.chisqr == pytest.approx(ref.chisqr, rel=1e-5)  # each stops on its own ftol, xtol
    monkeypatch.setattr(trf, "OFFSET_RANGES", math.inf)  # what the unshifted start did
    assert trf.minimize(fun, x0 + shift, lo + shift, hi + shift).chisqr > 100 * ref.chisqr
