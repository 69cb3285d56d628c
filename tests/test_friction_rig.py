"""Rig statics: F = dw sqrt(k^2/d^2 - 1), checked against an explicit moment balance."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from escfit.core.errors import SceneError
from escfit.friction import rig


def moment_about_wire(k, d, normal, friction):
    """Moment about the wire axis of the contact forces on the stylus (2-D cross product).

    Wire at the origin, disc surface at y = -d, contact at (a, -d).  The disc pushes the
    pallet up with ``normal`` and drags it along +x with ``friction``.
    """
    a = math.sqrt(k * k - d * d)
    r = np.array([a, -d])
    force = np.array([friction, normal])
    return r[0] * force[1] - r[1] * force[0]


@pytest.mark.parametrize("k,d", [(2.0, 1.0), (1.0, 0.9), (3.0, 0.5)])
def test_same_deflection_needs_dw_equal_to_f_d_over_a(k, d):
    w_cal, mu = 2.2, 0.125
    # friction along -x opposes the load's moment; solve w*a - mu*w*d = w_cal*a for w
    a = math.sqrt(k * k - d * d)
    w = w_cal * a / (a - mu * d)
    assert moment_about_wire(k, d, w, -mu * w) == pytest.approx(moment_about_wire(k, d, w_cal, 0.0))
    dw = w - w_cal
    assert rig.friction_force(dw, k, d) == pytest.approx(mu * w, rel=1e-13)
    assert dw * a == pytest.approx(mu * w * d, rel=1e-13)
    assert rig.mu_from_reading(w, dw, k, d) == pytest.approx(mu, rel=1e-13)
    assert rig.mu_from_reading(w_cal, dw, k, d, "calibration") == pytest.approx(mu, rel=1e-13)


def test_example_geometry():
    # k = 2 inch, d = 1 inch: a/d = sqrt(3)
    assert rig.lever_ratio(2.0, 1.0) == pytest.approx(math.sqrt(3.0))
    assert rig.friction_force(0.1, 0.0508, 0.0254) == pytest.approx(0.1 * math.sqrt(3.0))


def test_impossible_geometry_gives_nan():
    r = rig.lever_ratio(np.array([1.0, 1.0, 1.0]), np.array([1.0, 2.0, 0.0]))
    assert np.all(np.isnan(r))


@given(
    mu=st.floats(0.0, 0.8),
    w=st.floats(1e-4, 1.0),
    k=st.floats(0.01, 0.1),
    ratio=st.floats(0.05, 0.95),
    load_at=st.sampled_from(rig.LOAD_AT),
)
def test_prediction_and_inversion_round_trip(mu, w, k, ratio, load_at):
    d = ratio * k
    dw = rig.predicted_dw(w, mu, k, d, load_at)
    if not np.isfinite(dw):  # friction out-levers the load: no balance exists
        assert load_at == "calibration" and mu >= rig.lever_ratio(k, d)
        return
    assert rig.mu_from_reading(w, dw, k, d, load_at) == pytest.approx(mu, rel=1e-9, abs=1e-12)


def test_linear_laws():
    mu = rig.mu_law(0.1, np.array([1.0, 2.0, 3.0]), np.array([1.0, 1.0, 4.0]), mu_w=0.01, mu_v=0.002,
                    load_ref=2.0, speed_ref=1.0)
    assert np.allclose(mu, [0.09, 0.1, 0.116])


def test_scale_resolution_to_load_sd():
    # 1/2 inch steps, 5 gf over 11.5 ft, two settings: sd = sqrt(2/12) * 0.5/138 * 5 gf
    gf = 0.00980665
    sd = rig.load_sd_from_scale(0.5 * 0.0254, 11.5 * 12 * 0.0254 / (5 * gf), 2)
    assert sd / gf == pytest.approx(math.sqrt(1 / 6) * 0.5 / 138 * 5, rel=1e-12)
    assert round(sd / gf, 5) == 0.0074


def test_bad_arguments_are_refused_naming_the_value():
    with pytest.raises(SceneError, match="load_at = 'normal'"):
        rig.mu_from_reading(1.0, 0.1, 2.0, 1.0, "normal")
    with pytest.raises(SceneError, match="load_at = 'normal'"):
        rig.predicted_dw(1.0, 0.1, 2.0, 1.0, "normal")
    with pytest.raises(SceneError, match=r"resolution = 0\.0, slope = 1\.0, settings = 2"):
        rig.load_sd_from_scale(0.0, 1.0)
    with pytest.raises(SceneError, match="settings = 0"):
        rig.load_sd_from_scale(1e-3, 1.0, 0)
